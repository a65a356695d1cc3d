"""Trajectory errors of a reproduction against the trajectory it reproduces.

One set of metrics for every comparison in the project (learning, identification,
recorded traffic, the SMPC/spline/SB3 comparison), taken at the reference's samples.
"""

from __future__ import annotations

import math

import numpy as np

from drivestyle.envs.demonstration import Demonstration

__all__ = ["trajectory_errors"]


def trajectory_errors(
    xy: np.ndarray,
    demo: Demonstration,
    t_trg: float | None = None,
    t_rct_end: float | None = None,
) -> dict[str, float | None]:
    """Errors of positions at the demonstration's samples [m].

    Args:
        xy: reproduced EV positions [x, y] at the demonstration's samples, shape (n, 2).
        demo: the reference demonstration.
        t_trg: start of the reaction window (None: no window).
        t_rct_end: end of the reaction window [s].

    Returns:
        ``rmse_y_m`` and ``rmse_xy_m`` over the whole horizon, ``fde_m`` (final
        displacement error) and ``rmse_y_reaction_m`` over [t_trg, t_rct_end] (None
        without a window).

    Raises:
        ValueError: ``xy`` does not have one row per sample.
    """
    xy = np.asarray(xy, float)
    if xy.shape != (demo.n, 2):
        raise ValueError(f"xy must have shape ({demo.n}, 2), got {xy.shape}")
    dx, dy = xy[:, 0] - demo.ev[:, 0], xy[:, 1] - demo.ev[:, 1]
    out: dict[str, float | None] = {
        "rmse_y_m": float(np.sqrt(np.mean(dy**2))),
        "rmse_xy_m": float(np.sqrt(np.mean(dx**2 + dy**2))),
        "fde_m": float(math.hypot(dx[-1], dy[-1])),
        "rmse_y_reaction_m": None,
    }
    if t_trg is not None and t_rct_end is not None:
        w = (demo.t >= t_trg - 1e-9) & (demo.t <= t_rct_end + 1e-9)
        out["rmse_y_reaction_m"] = float(np.sqrt(np.mean(dy[w] ** 2)))
    return out
