"""The learner's descent: Levenberg–Marquardt in a box, alternating with a profile over p.

:func:`levenberg_marquardt` is projected LM with forward-difference Jacobians: a coordinate
at its bound whose gradient points out of the :class:`Box` is held, each step is clipped to
the coordinates' largest steps and to the box. :func:`descend` alternates it with the 1-D
profile of the cost over :data:`PROFILE_RISKS` (the other coordinates fixed), because the
cost is a saw-tooth in the risk p on which LM alone stops far from the driver's risk
(DESIGN §15). Pure functions of a residual function; the teacher-forced residuals they
minimise and the starting points are :mod:`drivestyle.irl.driver.driver_learning`'s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = [
    "EXACT",
    "PROFILE_RISKS",
    "PROFILE_ROUNDS",
    "Box",
    "Run",
    "descend",
    "levenberg_marquardt",
]

PROFILE_RISKS = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.99)
"""Risks of the 1-D profile over p (identification's grid,
:data:`~drivestyle.irl.driver.risk_profile.RISK_EVAL`): where
:func:`~drivestyle.irl.driver.driver_learning.learn_driver` looks for a better risk than its
Levenberg–Marquardt run found, and each demonstration's best risk."""
PROFILE_ROUNDS = 3
"""Profile-then-LM rounds per start at most (each round must lower the cost)."""
EXACT = 1e-18
"""A cost this small is an exact fit (simulated drivers reach ~1e-22): nothing to improve."""


@dataclass(frozen=True)
class Box:
    """The coordinates' forward-difference steps, largest steps and bounds."""

    fd: np.ndarray
    max_step: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


class Run(NamedTuple):
    """One start's descent (:func:`descend`)."""

    z: np.ndarray
    r: np.ndarray
    cost: float
    history: list[float]
    iterations: int
    status: str
    ssr: np.ndarray | None
    """The profile over p at the final weights (None: the risk was not free)."""


def descend(
    residuals: Callable[[np.ndarray], np.ndarray],
    profile: Callable[[np.ndarray], tuple[np.ndarray, list[np.ndarray]]] | None,
    i_p: int,
    z: np.ndarray,
    r: np.ndarray,
    cost: float,
    box: Box,
    max_iter: int,
    tol: float,
    progress: Callable[[int, float], None] | None,
    exact: float = EXACT,
) -> Run:
    """LM from z, alternating with the 1-D profile over p while it finds a better risk.

    Args:
        residuals: z → all residuals.
        profile: z → (Σ‖r‖² per profile risk and demonstration, the residuals per risk),
            or None when the risk is not a coordinate.
        i_p: the risk's coordinate.
        z: the start.
        r: its residuals.
        cost: ½‖r‖².
        box: the coordinates' steps and bounds.
        max_iter: iteration cap of each LM run.
        tol: relative cost decrease below which a run has converged.
        progress: called with (iteration, cost) after each iteration.
        exact: a cost this small is an exact fit: nothing to improve.
    """
    history = [cost]
    iterations, status = 0, "converged"
    ssr, rs = profile(z) if profile is not None and cost > exact else (None, [])
    for round_ in range(PROFILE_ROUNDS):
        if cost <= exact:
            break
        if ssr is not None:
            totals = 0.5 * ssr.sum(axis=1)
            j = int(np.argmin(totals))
            # another grid risk fits clearly better at these weights: LM's p sat on a
            # tooth of the saw (or the start's p was far off)
            if totals[j] < cost * (1.0 - tol) - 1e-12:
                z = z.copy()
                z[i_p] = PROFILE_RISKS[j]
                r, cost = rs[j], float(totals[j])
                history.append(cost)
            elif round_ > 0:
                break
        z, r, cost, h, it, status = levenberg_marquardt(
            residuals, z, r, cost, box, max_iter, tol, progress, exact
        )
        history.extend(h[1:])
        iterations += it
        if profile is None or cost <= exact:
            break
        ssr, rs = profile(z)
    if profile is not None and ssr is None and cost > exact:
        ssr, _ = profile(z)  # each demonstration's best risk (DriverFit.per_demo)
    return Run(z, r, cost, history, iterations, status, ssr)


def levenberg_marquardt(
    residuals: Callable[[np.ndarray], np.ndarray],
    z: np.ndarray,
    r: np.ndarray,
    cost: float,
    box: Box,
    max_iter: int,
    tol: float,
    progress: Callable[[int, float], None] | None,
    exact: float = EXACT,
) -> tuple[np.ndarray, np.ndarray, float, list[float], int, str]:
    """Projected LM with forward-difference Jacobians from z (residuals r, cost ½‖r‖²).

    A coordinate at its bound whose gradient points out of the box is held for the
    iteration; the step is clipped to each coordinate's largest step and to the box. A
    cost at or below ``exact`` is an exact fit: the run stops there.

    Returns:
        (z, r, cost, cost history, iterations, status).
    """
    history = [cost]
    lam = 1e-2
    status = "max_iter"
    it = 0
    if cost <= exact:
        return z, r, cost, history, it, "converged"
    for it in range(1, max_iter + 1):
        J = np.empty((r.size, z.size))
        for i in range(z.size):
            h = box.fd[i] if z[i] + box.fd[i] <= box.upper[i] else -box.fd[i]
            dz = np.zeros(z.size)
            dz[i] = h
            J[:, i] = (residuals(z + dz) - r) / h
        g = J.T @ r
        held = ((z <= box.lower) & (g > 0)) | ((z >= box.upper) & (g < 0))
        move = ~held
        H = (J.T @ J)[np.ix_(move, move)]
        improved = False
        for _ in range(8):
            step = np.zeros(z.size)
            step[move] = -np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-9), g[move])
            step = np.clip(step, -box.max_step, box.max_step)
            z_try = np.clip(z + step, box.lower, box.upper)
            r_try = residuals(z_try)
            cost_try = 0.5 * float(r_try @ r_try)
            if np.isfinite(cost_try) and cost_try < cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            # nothing lowers the cost: a minimum (an exact fit counts, even at once)
            status = "stalled" if it == 1 and cost > exact else "converged"
            break
        rel = (cost - cost_try) / max(cost, 1e-12)
        z, r, cost = z_try, r_try, cost_try
        lam = max(lam / 10.0, 1e-6)
        history.append(cost)
        if progress is not None:
            progress(it, cost)
        if rel < tol or cost <= exact:
            status = "converged"
            break
    return z, r, cost, history, it, status
