"""Teacher-forced learning of a driver style (DESIGN §15).

From every recorded state ξ_k the style's plan must start with the input the driver
applied (Levine & Koltun's locally optimal examples): r_k = (u_0(ξ_k; w, p) − u_k) / σ_u.
:func:`learn_driver` minimises Σ‖r_k‖² by Levenberg–Marquardt over log w (and p and v_ref
where free) with forward-difference Jacobians, from several screened starting points;
:func:`save_driver_style` writes the result as ``style.json``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import write_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver_style import (
    DRIVER_STYLE_KIND,
    GAUGE,
    INPUT_SCALE,
    RISK_RANGE,
    DriverStyle,
    DriverStyleError,
    Link,
    PlanRow,
    RowsResult,
    StylePlanner,
    check_demo,
    initial_weights,
    n_vehicles,
    planner_for,
)
from drivestyle.planning.smpc_problem import (
    N_WEIGHTS,
)

__all__ = ["DriverFit", "learn_driver", "save_driver_style", "step_residuals"]

SCREEN_CANDIDATES = 24
"""Starting points :func:`learn_driver` scores before its Levenberg–Marquardt runs."""
RESTARTS = 2
"""Levenberg–Marquardt runs, from the best-scored starting points."""
SCREEN_SEED = 17
"""Seed of the starting points' perturbations (learning is deterministic)."""


# ---------------------------------------------------------------------------- residuals
def step_residuals(
    style: DriverStyle, demo: Demonstration, planner: StylePlanner | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Teacher-forced input residuals of ``style`` on every step of ``demo``.

    r_k = (u_0(ξ_k; style) − u_k) / σ_u (:data:`INPUT_SCALE`), the plan starting from the
    demonstration's own state ξ_k with the surrounding vehicles at their recorded states.

    Args:
        style: the driver style.
        demo: the demonstration (samples T_s apart).
        planner: the NLP to use (default: the cached one of the demo's geometry).

    Returns:
        (r, active): residuals, shape (n−1, 2), and per step whether a chance constraint
        binds in the plan (where p can matter), shape (n−1,).
    """
    sc = check_demo(demo)
    planner = planner or planner_for(sc, style.horizon, n_vehicles(demo))
    r, active, _ = teacher_forced(style, demo, sc, planner)
    return r, active


def teacher_forced(
    style: DriverStyle, demo: Demonstration, sc: ScenarioConfig, planner: StylePlanner
) -> tuple[np.ndarray, np.ndarray, RowsResult]:
    """:func:`step_residuals`' pass, also returning the plans.

    One batch, each step warm-started from the previous step's plan (after a failed plan:
    a cold start).
    """
    vehicles = demo.vehicles
    rows = [PlanRow(demo.ev[k], vehicles[k], style, Link(shift=k - 1 if k else None))
            for k in range(demo.n - 1)]  # fmt: skip
    out = planner.solve_rows(rows, sc)
    r = (out.u0 - demo.u[: demo.n - 1]) / np.asarray(INPUT_SCALE)  # failed plans brake
    return r, out.chance_active.copy(), out


# ---------------------------------------------------------------------------- learning
@dataclass(frozen=True)
class DriverFit:
    """The result of :func:`learn_driver`."""

    style: DriverStyle
    """The learned style (weights, risk, desired speed)."""
    risks: tuple[float, ...]
    """The risk each demonstration was fitted with (all equal unless risks were given)."""
    cost: float
    """½ Σ ‖r‖² at the optimum (teacher-forced input residuals)."""
    residual_rms: float
    """RMS of the residuals (in σ_u units)."""
    n_residuals: int
    """Number of residual entries (2 per step)."""
    iterations: int
    """Levenberg–Marquardt iterations."""
    status: str
    """'converged', 'max_iter' or 'stalled' (no step lowered the cost)."""
    seconds: float
    """Wall time [s]."""
    history: tuple[float, ...] = field(default=())
    """Cost per iteration."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "style": self.style.to_json(),
            "risks": list(self.risks),
            "cost": self.cost,
            "residual_rms": self.residual_rms,
            "n_residuals": self.n_residuals,
            "iterations": self.iterations,
            "status": self.status,
            "seconds": self.seconds,
            "history": list(self.history),
        }


def _risk_of(s: float) -> float:
    """The risk 0.5 + 0.49·sigmoid(s): an unconstrained coordinate for p ∈ (0.5, 0.99)."""
    lo, hi = RISK_RANGE
    return lo + (hi - lo) / (1.0 + math.exp(-s))


def _s_of(risk: float) -> float:
    lo, hi = RISK_RANGE
    q = min(max((risk - lo) / (hi - lo), 1e-4), 1 - 1e-4)
    return math.log(q / (1 - q))


def learn_driver(
    demos: Sequence[Demonstration],
    risks: Sequence[float] | None = None,
    fit_speed: bool = False,
    initial: DriverStyle | None = None,
    max_iter: int = 30,
    tol: float = 1e-4,
    progress: Callable[[int, float], None] | None = None,
    screen: int = SCREEN_CANDIDATES,
    restarts: int = RESTARTS,
) -> DriverFit:
    """Learn one driver's style from its demonstrations in several scenarios.

    Minimises ½ Σ_d Σ_k ‖r_k‖² (:func:`step_residuals`) over log w (w_a = 1), the risk
    p (unless ``risks`` fixes each demonstration's) and the desired speed (``fit_speed``),
    by Levenberg–Marquardt with forward-difference Jacobians. The objective has local
    minima (the active set of the chance constraint changes with the weights: a p = 0.9
    driver's LM run from the normalised start stopped at cost 197 where the truth has
    1e-23), so ``screen`` starting points — the normalised weights and log-uniform
    perturbations of e^±2.5 drawn from a fixed seed — are scored first and LM runs from
    the ``restarts`` best; the lowest cost wins.

    Args:
        demos: demonstrations of one driver (or, with ``risks``, of drivers that share the
            cost but differ in risk).
        risks: each demonstration's known risk (a library's training), or None to learn
            one shared p.
        fit_speed: also learn the desired speed v_ref (recorded traffic: unknown).
        initial: the starting style (default: :func:`initial_weights`, p = 0.7).
        max_iter: iteration cap.
        tol: relative cost decrease below which the run has converged.
        progress: called with (iteration, cost) after each iteration.
        screen: starting points scored (1: the normalised start only).
        restarts: LM runs from the best-scored starting points.

    Returns:
        The :class:`DriverFit`.

    Raises:
        DriverStyleError: no demonstrations, risks of the wrong length or range, or a
            demonstration off its scenario's time grid.
    """
    demos = list(demos)
    if not demos:
        raise DriverStyleError("need at least one demonstration")
    if risks is not None:
        risks = [float(p) for p in risks]
        if len(risks) != len(demos):
            raise DriverStyleError(f"got {len(risks)} risks for {len(demos)} demonstrations")
        lo, hi = RISK_RANGE
        if not all(lo <= p <= hi for p in risks):
            raise DriverStyleError(f"every risk must lie in [{lo}, {hi}], got {risks}")
    planners = [
        planner_for(check_demo(d), (initial.horizon if initial else 10), n_vehicles(d))
        for d in demos
    ]
    start = initial or DriverStyle(tuple(initial_weights()), risk=0.7)
    v0 = start.v_ref or float(np.median([d.scenario.v_ref for d in demos]))
    free = [i for i in range(N_WEIGHTS) if i != GAUGE]
    t0 = time.perf_counter()

    def unpack(z: np.ndarray) -> tuple[DriverStyle, list[float]]:
        w = np.ones(N_WEIGHTS)
        w[free] = np.exp(z[: len(free)])
        j = len(free)
        p = _risk_of(z[j]) if risks is None else 0.7
        j += risks is None
        # an LM step may carry the raw speed coordinate below 0 (a braking driver):
        # keep it in DriverStyle's range instead of failing the fit
        v_ref = float(np.clip(z[j], 0.1, 69.9)) if fit_speed else start.v_ref
        style = DriverStyle(tuple(w), risk=p, v_ref=v_ref, horizon=start.horizon)
        return style, (risks if risks is not None else [p] * len(demos))

    def residuals(z: np.ndarray) -> np.ndarray:
        style, ps = unpack(z)
        pairs = zip(demos, ps, strict=True)
        out = [
            step_residuals(replace(style, risk=p), d, planners[i])[0].ravel()
            for i, (d, p) in enumerate(pairs)
        ]
        return np.concatenate(out)

    w0 = np.asarray(start.weights) / start.weights[GAUGE]
    z = list(np.log(w0[free]))
    if risks is None:
        z.append(_s_of(start.risk))
    if fit_speed:
        z.append(v0)
    z0 = np.array(z, dtype=float)
    steps = np.full(z0.size, 0.02)
    if fit_speed:
        steps[-1] = 0.05
    rng = np.random.default_rng(SCREEN_SEED)
    candidates = [z0]
    for _ in range(max(screen, 1) - 1):
        c = z0.copy()
        c[: len(free)] += rng.uniform(-2.5, 2.5, len(free))
        candidates.append(c)
    scored: list[tuple[float, int, np.ndarray, np.ndarray]] = []
    for c in candidates:
        rc = residuals(c)
        scored.append((0.5 * float(rc @ rc), len(scored), c, rc))
    scored.sort(key=lambda item: (item[0] if np.isfinite(item[0]) else np.inf, item[1]))
    best: tuple | None = None
    total_it = 0
    for cost_c, _, c, rc in scored[: max(restarts, 1)]:
        result = _levenberg_marquardt(residuals, c, rc, cost_c, steps, max_iter, tol, progress)
        total_it += result[4]
        if best is None or result[2] < best[2]:
            best = result
    assert best is not None
    z, r, cost, history, _, status = best
    style, ps = unpack(z)
    return DriverFit(
        style=style,
        risks=tuple(ps),
        cost=cost,
        residual_rms=float(np.sqrt(np.mean(r**2))),
        n_residuals=int(r.size),
        iterations=total_it,
        status=status,
        seconds=time.perf_counter() - t0,
        history=tuple(history),
    )


def _levenberg_marquardt(
    residuals: Callable[[np.ndarray], np.ndarray],
    z: np.ndarray,
    r: np.ndarray,
    cost: float,
    steps: np.ndarray,
    max_iter: int,
    tol: float,
    progress: Callable[[int, float], None] | None,
) -> tuple[np.ndarray, np.ndarray, float, list[float], int, str]:
    """LM with forward-difference Jacobians from z (residuals r, cost ½‖r‖²).

    Returns:
        (z, r, cost, cost history, iterations, status).
    """
    history = [cost]
    lam = 1e-2
    status = "max_iter"
    it = 0
    for it in range(1, max_iter + 1):
        J = np.empty((r.size, z.size))
        for i in range(z.size):
            dz = np.zeros(z.size)
            dz[i] = steps[i]
            J[:, i] = (residuals(z + dz) - r) / steps[i]
        g = J.T @ r
        H = J.T @ J
        improved = False
        for _ in range(8):
            step = -np.linalg.solve(H + lam * np.diag(np.diag(H) + 1e-9), g)
            step = np.clip(step, -2.0, 2.0)  # log-weights: at most e² per iteration
            z_try = z + step
            r_try = residuals(z_try)
            cost_try = 0.5 * float(r_try @ r_try)
            if np.isfinite(cost_try) and cost_try < cost:
                improved = True
                break
            lam *= 10.0
        if not improved:
            status = "stalled" if it == 1 else "converged"
            break
        rel = (cost - cost_try) / max(cost, 1e-12)
        z, r, cost = z_try, r_try, cost_try
        lam = max(lam / 10.0, 1e-6)
        history.append(cost)
        if progress is not None:
            progress(it, cost)
        if rel < tol:
            status = "converged"
            break
    return z, r, cost, history, it, status


def save_driver_style(
    fit: DriverFit,
    path: str | Path,
    demo_paths: Sequence[str] = (),
    reproductions: Sequence[dict[str, Any]] = (),
) -> Path:
    """Write a driver-style file (``kind`` :data:`DRIVER_STYLE_KIND`).

    Args:
        fit: the learning result.
        path: the file to write.
        demo_paths: the demonstrations it was learned from.
        reproductions: per demonstration, e.g. ``{"rmse_y_m": …, "rmse_xy_m": …}``.

    Returns:
        The path written.
    """
    payload = {
        "kind": DRIVER_STYLE_KIND,
        "version": 1,
        "model": "receding-horizon style (DESIGN §15)",
        **fit.to_json(),
        "demos": [{"path": str(p)} for p in demo_paths],
        "reproductions": list(reproductions),
    }
    return write_json(Path(path), payload)
