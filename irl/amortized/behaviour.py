"""What a driver did in one episode: the behaviour statistics the predictive check compares.

Five model-free numbers of a :class:`~drivestyle.envs.demonstration.Demonstration`
(simulated or recorded, in the road frame: x along travel, y to the left, lane i covering
[i·w, (i + 1)·w)), each read the same way from an observed episode and from a simulation
of it (:mod:`drivestyle.irl.amortized.predictive_check`, DESIGN §22):

- **closest approach** [m]: the least signed distance between the EV's and a surrounding
  vehicle's rectangles over the episode (:func:`box_distance`: bumper to bumper behind or
  ahead in a lane, side to side alongside, the penetration depth negative where they
  overlap), over the states that are recorded samples only
  (:func:`~drivestyle.recorded.observed.observed_mask`: a recorded episode's
  constant-velocity continuations are the extraction's, not traffic), capped at
  :data:`DISTANCE_CAP_M`;
- **accepted gap** [m]: at the crossing — when the EV's smoothed lateral position enters
  the target lane — the tighter of the lead gap (to the nearest observed vehicle ahead in
  the target lane, bumper to bumper) and the lag gap (to the nearest behind), capped at
  :data:`DISTANCE_CAP_M` (no vehicle there: the cap); NaN without a crossing;
- **lane-change start** [s]: the last time before the crossing at which the smoothed
  lateral offset towards the target lane, y − y(0), was within :data:`LATERAL_BAND_M` of
  where the EV started; NaN without a crossing;
- **lane-change duration** [s]: from the start to settling — the first time after which
  the smoothed y stays within :data:`LATERAL_BAND_M` of its final value, which must lie in
  the target lane, the EV at rest laterally by then: within half the band of it over the
  last :data:`SETTLE_HOLD_S` (a lateral speed ≲ 0.4 m/s); NaN when the change does not
  complete so. Start and end both sit one band from rest, so a lateral move Δ made at a
  constant lateral speed over D seconds has duration D (1 − 2 b / Δ) — a rise time;
- **speed change** [m/s]: the mean speed (the state's v) over the last
  :data:`SPEED_WINDOW_S` minus the mean over the first.

Lateral positions are smoothed by a centred moving average over :data:`SMOOTH_S`
(:func:`smoothed`). Position noise still moves the times: a tracker's errors
(:func:`~drivestyle.envs.tracking.observe`) are correlated over a second, which no
smoothing removes — at 0.2 m, on a smooth 3.5 m lane change over 4.5 s, the start errs by
≤ 0.22 s and the duration by ≤ 0.33 s in nine draws of ten (≤ 0.27 s and 0.41 s with a
0.5 m band, hence 0.75 m: a fifth of a narrow lane, far inside any lane change). Headings
are ignored in the rectangles (≤ 0.3 rad on recorded traffic: ≤ 0.75 m at a 5 m car's
corner), and every vehicle has the scenario's size (a recorded episode carries no other).
:data:`RESOLUTIONS` are the differences a statistic cannot resolve at that noise: the
predictive check counts values that close as ties.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lanes import lane_index
from drivestyle.recorded.observed import observed_mask

__all__ = [
    "DISTANCE_CAP_M",
    "LATERAL_BAND_M",
    "RESOLUTIONS",
    "SETTLE_HOLD_S",
    "SMOOTH_S",
    "SPEED_WINDOW_S",
    "STATISTICS",
    "Behaviour",
    "accepted_gap",
    "behaviour",
    "box_distance",
    "closest_approach",
    "lane_change_times",
    "smoothed",
    "speed_change",
]

STATISTICS: tuple[str, ...] = (
    "closest_approach", "accepted_gap", "lane_change_start", "lane_change_duration",
    "speed_change",
)  # fmt: skip
"""The statistics the predictive check compares, in order (fields of :class:`Behaviour`)."""

DISTANCE_CAP_M = 100.0
"""Distances and gaps beyond this are open road [m] (the extraction's interaction range:
farther vehicles do not interact); no observed vehicle at all gives the cap."""
SMOOTH_S = 1.0
"""The lateral position's moving-average window [s] (5 samples at T_s = 0.2 s)."""
LATERAL_BAND_M = 0.75
"""b: a lane change starts when the smoothed offset leaves this band around where the EV
started and ends when it enters this band around where it settled [m]."""
SETTLE_HOLD_S = 1.0
"""Settled: the smoothed y stays within half the band of its final value over the last
this long of the episode [s] (an episode that ends mid-motion has no rest to settle to)."""
SPEED_WINDOW_S = 2.0
"""The speed change compares the mean speeds over the first and the last this long [s]
(at 0.2 m of position noise the tracked speed's change errs by 0.28 m/s in nine episodes
of ten over 2 s windows, by 0.52 m/s over 1 s windows)."""
RESOLUTIONS: dict[str, float] = {
    "closest_approach": 0.3,
    "accepted_gap": 1.0,
    "lane_change_start": 0.2,
    "lane_change_duration": 0.4,
    "speed_change": 0.2,
}
"""Per statistic the difference it cannot resolve under 0–0.2 m of position noise [m, m, s,
s, m/s]: the predictive check counts replicates this close to the observed value as ties."""


@dataclass(frozen=True)
class Behaviour:
    """The behaviour statistics of one episode (module docstring); NaN where undefined."""

    closest_approach: float
    """Least signed rectangle distance to an observed surrounding vehicle [m] (≤ cap)."""
    accepted_gap: float
    """The tighter of the lead and lag gaps in the target lane at the crossing [m]."""
    lane_change_start: float
    """When the lateral motion towards the target lane began [s from the first sample]."""
    lane_change_duration: float
    """From the start to settling in the target lane [s]."""
    speed_change: float
    """Mean speed over the last :data:`SPEED_WINDOW_S` minus over the first [m/s]."""
    crossing_time: float
    """When the smoothed lateral position entered the target lane [s] (not compared)."""

    def values(self) -> np.ndarray:
        """The compared statistics in :data:`STATISTICS` order, shape (S,)."""
        return np.array([getattr(self, name) for name in STATISTICS], float)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (NaN as None)."""
        values = {name: float(getattr(self, name)) for name in (*STATISTICS, "crossing_time")}
        return {name: (None if math.isnan(v) else v) for name, v in values.items()}


def box_distance(dx: np.ndarray, dy: np.ndarray, length: float, width: float) -> np.ndarray:
    """Signed distance between two equal road-frame rectangles whose centres are (dx, dy) apart.

    With g_x = |dx| − L and g_y = |dy| − W: hypot(max(g_x, 0), max(g_y, 0)) when they are
    apart (bumper to bumper when g_y ≤ 0, side to side when g_x ≤ 0), max(g_x, g_y) < 0 —
    minus the depth to separate them — when they overlap.

    Args:
        dx: centre offsets along x, any shape [m].
        dy: centre offsets along y, the same shape [m].
        length: L, the vehicles' length [m].
        width: W, their width [m].

    Returns:
        The signed distance, the shape of ``dx`` [m].
    """
    gx = np.abs(np.asarray(dx, float)) - length
    gy = np.abs(np.asarray(dy, float)) - width
    apart = np.hypot(np.maximum(gx, 0.0), np.maximum(gy, 0.0))
    return np.where((gx > 0) | (gy > 0), apart, np.maximum(gx, gy))


def smoothed(y: np.ndarray, window: int) -> np.ndarray:
    """Centred moving average over ``window`` samples, shrinking to the samples there at the ends.

    Args:
        y: a series, shape (n,).
        window: samples averaged (odd; 1: no smoothing).

    Returns:
        Shape (n,); a series linear over a full window is returned unchanged there.
    """
    y = np.asarray(y, float)
    h = max(int(window) // 2, 0)
    c = np.concatenate([[0.0], np.cumsum(y)])
    k = np.arange(y.size)
    lo, hi = np.maximum(k - h, 0), np.minimum(k + h + 1, y.size)
    return (c[hi] - c[lo]) / (hi - lo)


def _cut(t: np.ndarray, f: np.ndarray, j: int) -> float:
    """Where f crosses 0 between samples j and j + 1 (linear interpolation) [s]."""
    return float(t[j] + (t[j + 1] - t[j]) * f[j] / (f[j] - f[j + 1]))


def closest_approach(
    ev: np.ndarray, vehicles: np.ndarray, observed: np.ndarray, length: float, width: float
) -> float:
    """The least :func:`box_distance` to any surrounding vehicle where it is observed.

    Args:
        ev: EV states [x, y, φ, v], shape (n, 4) [m, m, rad, m/s].
        vehicles: surrounding vehicles' states, shape (n, m, 4).
        observed: which of their states are observed, shape (m, n) bool.
        length: the vehicles' length [m].
        width: their width [m].

    Returns:
        The closest approach [m], at most :data:`DISTANCE_CAP_M` (the cap: none observed).
    """
    d = box_distance(vehicles[..., 0] - ev[:, None, 0], vehicles[..., 1] - ev[:, None, 1],
                     length, width)  # fmt: skip
    d = np.where(np.asarray(observed, bool).T, d, np.inf)
    return float(min(d.min(initial=np.inf), DISTANCE_CAP_M))


def lane_change_times(
    t: np.ndarray, y: np.ndarray, lane_width: float, from_lane: int, target_lane: int
) -> tuple[float, float, float]:
    """Start, crossing and settling of the lane change into ``target_lane`` (module docstring).

    Args:
        t: sample times, shape (n,) [s].
        y: the EV's lateral positions, shape (n,) [m].
        lane_width: w [m].
        from_lane: the lane it changes from (only the direction is read).
        target_lane: the lane it changes to.

    Returns:
        (start, crossing, end) [s, from t_0]: all NaN when the smoothed y starts in the
        target lane or never enters it; ``end`` NaN when the change does not settle there.
    """
    t = np.asarray(t, float)
    dt = float(np.median(np.diff(t)))
    ys = smoothed(y, 2 * round(SMOOTH_S / dt / 2) + 1)
    inside = lane_index(ys, lane_width) == target_lane
    nan = (math.nan, math.nan, math.nan)
    if inside[0] or not inside.any():
        return nan
    k = int(np.argmax(inside))  # the first sample in the target lane
    d = 1.0 if target_lane > from_lane else -1.0
    line = (target_lane if d > 0 else target_lane + 1) * lane_width
    crossing = _cut(t, ys - line, k - 1) if ys[k] != ys[k - 1] else float(t[k])
    offset = d * (ys - ys[0]) - LATERAL_BAND_M
    j = int(np.flatnonzero(offset[:k] <= 0)[-1])  # offset[0] = −b: there is one
    start = _cut(t, offset, j) if j + 1 < t.size and offset[j + 1] > 0 else float(t[j])
    origin = float(t[0])
    if not inside[-1]:
        return start - origin, crossing - origin, math.nan
    away = np.abs(ys - ys[-1]) - LATERAL_BAND_M
    out = np.flatnonzero(away > 0)
    end = crossing if out.size == 0 else max(_cut(t, away, int(out[-1])), crossing)
    hold = t >= t[-1] - SETTLE_HOLD_S - 1e-9
    if np.any(np.abs(ys[hold] - ys[-1]) > LATERAL_BAND_M / 2):  # still moving at the end
        return start - origin, crossing - origin, math.nan
    return start - origin, crossing - origin, end - origin


def accepted_gap(
    t: np.ndarray, ev: np.ndarray, vehicles: np.ndarray, observed: np.ndarray,
    crossing: float, target_lane: int, lane_width: float, length: float,
) -> float:  # fmt: skip
    """The tighter of the lead and lag gaps in the target lane at the crossing.

    The states at ``crossing`` are interpolated linearly between its two samples; a vehicle
    counts when observed at both and in the target lane. Lead gap x_j − x_EV − L to the
    nearest ahead, lag gap x_EV − x_j − L to the nearest behind (negative: overlapping
    along x).

    Args:
        t: sample times, shape (n,) [s].
        ev: EV states, shape (n, 4).
        vehicles: surrounding vehicles' states, shape (n, m, 4).
        observed: which of their states are observed, shape (m, n) bool.
        crossing: the crossing time [s from t_0]; NaN: none.
        target_lane: the target lane's index.
        lane_width: w [m].
        length: the vehicles' length [m].

    Returns:
        The accepted gap [m], at most :data:`DISTANCE_CAP_M`; NaN without a crossing.
    """
    if math.isnan(crossing):
        return math.nan
    tc = float(t[0]) + crossing
    k = int(np.clip(np.searchsorted(t, tc), 1, t.size - 1))
    a = (tc - t[k - 1]) / (t[k] - t[k - 1])
    x_ev = (1 - a) * ev[k - 1, 0] + a * ev[k, 0]
    at = (1 - a) * vehicles[k - 1] + a * vehicles[k]  # (m, 4)
    seen = np.asarray(observed, bool)[:, k - 1] & np.asarray(observed, bool)[:, k]
    there = seen & (lane_index(at[:, 1], lane_width) == target_lane)
    dx = at[there, 0] - x_ev
    gaps = np.concatenate([dx[dx >= 0] - length, -dx[dx < 0] - length])
    return float(min(gaps.min(initial=np.inf), DISTANCE_CAP_M))


def speed_change(t: np.ndarray, v: np.ndarray) -> float:
    """Mean speed over the last :data:`SPEED_WINDOW_S` minus over the first [m/s].

    Args:
        t: sample times, shape (n,) [s].
        v: speeds, shape (n,) [m/s].
    """
    t, v = np.asarray(t, float), np.asarray(v, float)
    first = t <= t[0] + SPEED_WINDOW_S + 1e-9
    last = t >= t[-1] - SPEED_WINDOW_S - 1e-9
    return float(v[last].mean() - v[first].mean())


def behaviour(demo: Demonstration) -> Behaviour:
    """The behaviour statistics of one episode (module docstring).

    The lanes, the lane change's direction and target and the vehicles' size are the
    demonstration's scenario's; the observed states its
    :func:`~drivestyle.recorded.observed.observed_mask`.

    Args:
        demo: a simulated or recorded episode in the road frame.

    Returns:
        The :class:`Behaviour`.
    """
    sc = demo.scenario
    vehicles, mask = demo.vehicles, observed_mask(demo)
    length, width = sc.vehicle_length, sc.vehicle_width
    start, crossing, end = lane_change_times(demo.t, demo.ev[:, 1], sc.lane_width, sc.ev_lane,
                                             sc.target_lane)  # fmt: skip
    gap = accepted_gap(demo.t, demo.ev, vehicles, mask, crossing, sc.target_lane, sc.lane_width,
                       length)  # fmt: skip
    return Behaviour(
        closest_approach=closest_approach(demo.ev, vehicles, mask, length, width),
        accepted_gap=gap,
        lane_change_start=start,
        lane_change_duration=end - start,
        speed_change=speed_change(demo.t, demo.ev[:, 3]),
        crossing_time=crossing,
    )
