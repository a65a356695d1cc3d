"""A recorded track's states on an episode's time grid (DESIGN §15).

:func:`resample_states`: cubic splines through the recorded positions, the recorded heading
and speed where the track has them; :func:`time_grid`: the multiples of T_s within a span.
Beyond a track's first and last samples its states are continued at constant velocity
(``_states_on``): an interacting vehicle recorded for part of a window still has a state
at every sample, and the episode says which are recorded
(:attr:`~drivestyle.envs.demonstration.Demonstration.observed`,
:mod:`drivestyle.recorded.observed`).
"""

from __future__ import annotations

import math

import numpy as np

from drivestyle.recorded.tracks import Track

__all__ = [
    "resample_states",
    "time_grid",
]


def time_grid(t: np.ndarray, dt: float) -> np.ndarray:
    """The multiples of ``dt`` within [min t, max t] (rounded to 1e-9 s), shape (m,) [s]."""
    t = np.asarray(t, float)
    start = math.ceil(t.min() / dt - 1e-9) * dt
    stop = math.floor(t.max() / dt + 1e-9) * dt
    return np.round(np.arange(start, stop + dt / 2, dt), 9)


def resample_states(
    t_src: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    t_new: np.ndarray,
    v: np.ndarray | None = None,
    heading: np.ndarray | None = None,
) -> np.ndarray:
    """States [x, y, φ, v] at ``t_new`` from recorded positions (and speed, heading).

    Positions: cubic splines through the samples (they pass through them). Heading: the
    recorded one (unwrapped, interpolated linearly) or φ = atan2(ẏ, ẋ) of the splines.
    Speed: the recorded one (linear) or ‖(ẋ, ẏ)‖ of the splines.

    Args:
        t_src: sample times, shape (n,) [s], increasing, n ≥ 2.
        x: positions along the road, shape (n,) [m].
        y: lateral positions, shape (n,) [m].
        t_new: query times within [t_src[0], t_src[-1]], shape (m,) [s].
        v: recorded speeds, shape (n,) [m/s], or None.
        heading: recorded headings, shape (n,) [rad], or None.

    Returns:
        States, shape (m, 4) [m, m, rad, m/s].
    """
    from scipy.interpolate import CubicSpline

    sx, sy = CubicSpline(t_src, x), CubicSpline(t_src, y)
    dx, dy = sx(t_new, 1), sy(t_new, 1)
    phi = (
        np.arctan2(dy, dx)
        if heading is None
        else np.interp(t_new, t_src, np.unwrap(np.asarray(heading, float)))
    )
    speed = np.hypot(dx, dy) if v is None else np.interp(t_new, t_src, v)
    return np.column_stack([sx(t_new), sy(t_new), phi, speed])


def _constant_velocity(state: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """States [x, y, φ, v] ``tau`` seconds from ``state`` at constant velocity, shape (m, 4)."""
    x, y, phi, v = state
    return np.column_stack(
        [x + v * np.cos(phi) * tau, y + v * np.sin(phi) * tau, np.full_like(tau, phi),
         np.full_like(tau, v)]
    )  # fmt: skip


def _states_on(track: Track, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A track's states on ``t``: resampled where recorded, constant velocity beyond.

    Returns:
        (states, shape (len(t), 4); True where a state is resampled from the track's
        samples, False where it is the constant-velocity continuation before its first or
        after its last sample — everywhere when the track covers fewer than two of the
        times — shape (len(t),) bool: the episode's
        :attr:`~drivestyle.envs.demonstration.Demonstration.observed`).
    """
    inside = (t >= track.t[0] - 1e-9) & (t <= track.t[-1] + 1e-9)
    out = np.empty((t.size, 4))
    idx = np.flatnonzero(inside)
    if idx.size < 2:
        # (almost) no overlap: the nearest recorded state, carried at constant velocity
        k = 0 if t[0] < track.t[0] else track.n - 1
        edge = resample_states(track.t, track.x, track.y, track.t[[k]], track.v, track.heading)
        return _constant_velocity(edge[0], t - track.t[k]), np.zeros(t.size, bool)
    out[idx] = resample_states(track.t, track.x, track.y, t[idx], track.v, track.heading)
    for edge, span in ((idx[0], slice(0, idx[0])), (idx[-1], slice(idx[-1] + 1, None))):
        out[span] = _constant_velocity(out[edge], t[span] - t[edge])
    return out, inside
