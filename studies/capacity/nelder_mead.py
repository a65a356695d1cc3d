"""Nelder–Mead under a hard evaluation budget: the capacity study's derivative-free search.

SciPy's simplex with what SciPy lacks: a budget that keeps the best point found so far,
non-finite values counted as +∞, and restarts around the best point after the simplex
collapses (:func:`nelder_mead`). The capacity study fits each reproduction class's
parameters with it (:mod:`drivestyle.studies.capacity.study`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize

__all__ = ["NelderMeadResult", "nelder_mead"]


@dataclass(frozen=True)
class NelderMeadResult:
    """The outcome of :func:`nelder_mead`."""

    x: np.ndarray
    """The best point evaluated."""
    fun: float
    """Its value."""
    evaluations: int
    """Function evaluations used (≤ the budget)."""
    iterations: int
    """Simplex iterations (all restarts)."""
    restarts: int
    """Restarts around the best point after the simplex collapsed."""
    history: tuple[float, ...]
    """The best value after each evaluation."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (without the history)."""
        return {
            "x": self.x.tolist(),
            "fun": self.fun,
            "evaluations": self.evaluations,
            "iterations": self.iterations,
            "restarts": self.restarts,
        }


class _BudgetSpentError(Exception):
    """Internal: the evaluation budget is used up."""


def nelder_mead(
    fun: Callable[[np.ndarray], float],
    x0: np.ndarray | Sequence[float],
    step: float | Sequence[float],
    budget: int,
    xtol: float = 1e-4,
    ftol: float = 1e-7,
    max_restarts: int = 5,
) -> NelderMeadResult:
    """Minimise ``fun`` by the Nelder–Mead simplex method within ``budget`` evaluations.

    SciPy's simplex (``scipy.optimize.minimize(method="Nelder-Mead")``) with the adaptive
    coefficients of Gao & Han (2012), which keep the method effective beyond a few
    dimensions (the standard ones at n = 1, where the adaptive shrink degenerates). This
    wrapper adds what SciPy's lacks: a hard evaluation budget that keeps the best point
    found so far, non-finite values counted as +∞ (a parameter vector that cannot be
    evaluated), and restarts — when the simplex collapses (its values within ``ftol`` and
    its vertices within ``xtol`` of the best) the search restarts around the best point
    with the initial steps, until a restart improves by less than ``ftol`` or the budget is
    spent.

    Args:
        fun: the objective, x ↦ value.
        x0: the starting point, shape (n,).
        step: the initial simplex's step along each coordinate (> 0).
        budget: the most evaluations (≥ 1).
        xtol: collapse tolerance on the vertices.
        ftol: collapse tolerance on the values.
        max_restarts: the most restarts.

    Returns:
        The best point evaluated.

    Raises:
        ValueError: a non-finite start, non-positive steps or a budget < 1.
    """
    x0 = np.array(x0, dtype=float).ravel()
    n = x0.size
    steps = np.broadcast_to(np.asarray(step, dtype=float), (n,)).copy()
    if n == 0 or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be a non-empty finite vector, got {x0}")
    if not np.all(np.isfinite(steps) & (steps > 0)):
        raise ValueError(f"step must be finite and > 0, got {step}")
    if not (isinstance(budget, int) and budget >= 1):
        raise ValueError(f"budget must be an integer >= 1, got {budget!r}")
    best: dict[str, Any] = {"x": x0.copy(), "f": math.inf}
    history: list[float] = []
    counts = {"iterations": 0}

    def f(x: np.ndarray) -> float:
        if len(history) >= budget:
            raise _BudgetSpentError
        value = float(fun(x))
        if not math.isfinite(value):
            value = math.inf
        if value < best["f"]:
            best["x"], best["f"] = np.array(x, dtype=float), value
        history.append(best["f"])
        return value

    def count(_: Any) -> None:
        counts["iterations"] += 1

    # the budget, not SciPy's caps, ends the search
    options = {"xatol": xtol, "fatol": ftol, "adaptive": n > 1, "maxiter": 2**62, "maxfev": 2**62}
    restarts = 0
    try:
        center = x0
        while True:
            start_f = best["f"]
            simplex = np.vstack([center, center + np.diag(steps)])
            minimize(f, center, method="Nelder-Mead", callback=count,
                     options={**options, "initial_simplex": simplex})  # fmt: skip
            if restarts >= max_restarts or start_f - best["f"] <= ftol:
                break
            restarts += 1
            center = best["x"]
    except _BudgetSpentError:
        pass
    return NelderMeadResult(
        x=best["x"],
        fun=best["f"],
        evaluations=len(history),
        iterations=counts["iterations"],
        restarts=restarts,
        history=tuple(history),
    )
