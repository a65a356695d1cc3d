"""Lanes on a straight road: which lane a position is in, who leads, where a lane change goes.

One home for three rules that the environment, the features, the learned reward, the
physics baseline, the observer's view and the studies all apply:

- **Lane.** Lanes are ``w`` wide and lane i covers [i·w, (i + 1)·w) laterally (y = 0 the
  right edge of lane 0, y to the left of travel; the frame of every scenario and episode).
- **Leader.** A vehicle's leader is the nearest vehicle ahead (larger x) in its lane.
- **Target line of an observed lane change.** The direction is the sign of the lateral
  velocity over the last :data:`LATERAL_WINDOW_S` of the observation (0 counts as +y); the
  target is the neighbouring lane in that direction, or the current lane when the vehicle
  crossed into it in that direction during the observation. Only the observed samples are
  read: the recorded destination is the future.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "LATERAL_WINDOW_S",
    "lane_change_target",
    "lane_index",
    "leaders",
]

LATERAL_WINDOW_S = 0.6
"""The observed lateral velocity is the mean over the last this many seconds [s]."""


def lane_index(y: np.ndarray | float, lane_width: np.ndarray | float) -> np.ndarray:
    """The lane of lateral positions: ⌊y / w⌋ (lane i covers [i·w, (i + 1)·w)).

    Args:
        y: lateral positions, any shape [m].
        lane_width: w [m] (or one per row, broadcast with ``y``: scenes of several widths).

    Returns:
        Lane indices, the broadcast shape (integers; −1 right of lane 0).
    """
    return np.floor(np.asarray(y, dtype=float) / lane_width).astype(int)


def leaders(
    x: np.ndarray, y: np.ndarray, others_x: np.ndarray, others_y: np.ndarray, lane_width: float
) -> np.ndarray:
    """The nearest vehicle ahead in the same lane, per sample (module docstring).

    Args:
        x: the vehicle's longitudinal positions, shape (n,) [m].
        y: its lateral positions, shape (n,) [m].
        others_x: the other vehicles' longitudinal positions, shape (n, m) [m].
        others_y: their lateral positions, shape (n, m) [m].
        lane_width: w [m].

    Returns:
        The leader's column in ``others_*`` per sample, −1 where none is ahead, shape (n,).
    """
    x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
    ox = np.asarray(others_x, float).reshape(x.size, -1) if x.size else np.empty((0, 0))
    oy = np.asarray(others_y, float).reshape(x.size, -1) if x.size else np.empty((0, 0))
    if ox.shape[1] == 0:
        return np.full(x.size, -1)
    ahead = (lane_index(oy, lane_width) == lane_index(y, lane_width)[:, None]) & (ox > x[:, None])
    nearest = np.argmin(np.where(ahead, ox, np.inf), axis=1)
    return np.where(ahead.any(axis=1), nearest, -1)


def lane_change_target(y: np.ndarray, dt: float, lane_width: float) -> tuple[int, int]:
    """The target lane and direction of an observed lateral motion (module docstring).

    Args:
        y: the observed lateral positions y_0 … y_k, shape (k + 1,) [m], k ≥ 1.
        dt: T_s [s].
        lane_width: w [m].

    Returns:
        (target lane index, direction d = +1 to the left or −1 to the right).
    """
    y = np.asarray(y, dtype=float)
    m = min(len(y) - 1, max(1, round(LATERAL_WINDOW_S / dt)))
    d = 1 if y[-1] >= y[-1 - m] else -1
    lane, first = math.floor(y[-1] / lane_width), math.floor(y[0] / lane_width)
    return (lane if lane == first + d else lane + d), d
