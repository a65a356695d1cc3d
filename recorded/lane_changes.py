"""Lane changes of a recorded track: where its lane changes by one and holds (DESIGN §15).

:func:`find_lane_changes` finds every change of lane by one that the vehicle held
``min_stay_s`` before and after (the crossing time where its centre crosses the line);
:func:`lateral_move` measures how far a track moved towards the new lane across a window,
which tells a lane change from a drift along the line (rules:
:mod:`drivestyle.recorded.episodes`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drivestyle.recorded.tracks import Carriageway, Track

__all__ = [
    "LATERAL_MOVE_SPAN_S",
    "LaneChange",
    "find_lane_changes",
    "lateral_move",
]


LATERAL_MOVE_SPAN_S = 0.5
"""The window's first and last this many seconds give its lateral positions (their median,
:func:`lateral_move`) [s]: 5 samples at 10 Hz, so one noisy fix does not decide; short
against a lane change's 3–6 s, so the median stays near the window's ends."""


@dataclass(frozen=True)
class LaneChange:
    """One lane change of a track (before any window or usability check)."""

    vehicle_id: str
    from_lane: int
    """Lane before, in the carriageway's numbering (0 rightmost)."""
    to_lane: int
    """Lane after."""
    t_cross: float
    """When the centre crosses the line [s] (the source's time)."""
    index: int
    """The last sample before the crossing."""


def _lanes(track: Track, road: Carriageway) -> np.ndarray:
    """Lane index per sample: the track's own, else from y and the markings."""
    if track.lane is not None:
        return np.round(track.lane).astype(int)
    return np.asarray(road.lane_of(track.y), int)


def find_lane_changes(track: Track, road: Carriageway, min_stay_s: float) -> list[LaneChange]:
    """Every change of lane by one that holds ``min_stay_s`` before and after.

    Args:
        track: one vehicle.
        road: its carriageway (markings).
        min_stay_s: time in the old lane before and the new one after [s].

    Returns:
        The lane changes in time order.
    """
    lane = _lanes(track, road)
    t, y = track.t, track.y
    changes = []
    n_lanes = len(road.markings) - 1
    for k in np.flatnonzero(lane[1:] != lane[:-1]):
        a, b = int(lane[k]), int(lane[k + 1])
        if abs(b - a) != 1 or not (0 <= a < n_lanes and 0 <= b < n_lanes):
            continue
        line = road.markings[max(a, b)]
        if (y[k] - line) * (y[k + 1] - line) <= 0 and y[k + 1] != y[k]:
            t_c = float(t[k] + (line - y[k]) / (y[k + 1] - y[k]) * (t[k + 1] - t[k]))
        else:
            t_c = float((t[k] + t[k + 1]) / 2)
        before = (t >= t_c - min_stay_s) & (t < t_c)
        after = (t > t_c) & (t <= t_c + min_stay_s)
        if t[0] > t_c - min_stay_s or t[-1] < t_c + min_stay_s:
            continue
        if np.all(lane[before] == a) and np.all(lane[after] == b):
            changes.append(LaneChange(track.vehicle_id, a, b, t_c, int(k)))
    return changes


def _crossings(track: Track, road: Carriageway) -> np.ndarray:
    """Sample index k of every lane-index change of a track (between k and k + 1)."""
    lane = _lanes(track, road)
    return np.flatnonzero(lane[1:] != lane[:-1])


def lateral_move(
    t: np.ndarray, y: np.ndarray, start: float, stop: float, span_s: float = LATERAL_MOVE_SPAN_S
) -> float:
    """How far a track moves laterally across a window: its y at the end minus at the start.

    Each end's y is the median over the window's first (last) ``span_s`` seconds: the
    recorded samples inside and y interpolated at the span's bounds (so a sparse track
    still has a value). Why the window's ends, not the lanes held around the crossing
    (``min_stay_s``): a lane change takes 3–6 s, and the second before and after the
    crossing hold only its middle (0.2–0.3 w on the shipped samples' real changes, as
    little as a drift's), while the window (≥ ``min_before_s`` before, ≥ ``min_after_s``
    after) holds most of it. Why a median over a span, not the end samples: one noisy fix
    (GNSS, video transcription) would decide alone.

    Args:
        t: sample times, shape (n,) [s], increasing.
        y: lateral positions, shape (n,) [m].
        start: the window's start, within [t[0], t[-1]] [s].
        stop: the window's end, within [start, t[-1]] [s].
        span_s: the span at each end [s] (at most half the window).

    Returns:
        y(end) − y(start) [m]: positive to +y.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    span = min(span_s, (stop - start) / 2)

    def level(a: float, b: float) -> float:
        inside = t[(t > a) & (t < b)]
        return float(np.median(np.interp(np.concatenate([[a], inside, [b]]), t, y)))

    return level(stop - span, stop) - level(start, start + span)
