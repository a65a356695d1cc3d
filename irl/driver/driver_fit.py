"""How well a learned driver style explains its demonstrations: the fit and its file.

:func:`~drivestyle.irl.driver.driver_learning.learn_driver` returns a :class:`DriverFit`: the
style, its residuals and status, and per demonstration (:class:`DemoFit`, :func:`diagnose`)
the residual RMS against the noise floor, the risk it prefers alone and the style's closed
loop from its first state (:class:`ClosedLoop`): a residual above :data:`POOR_FIT_RATIO`
floors is a poor fit unless the closed loop reproduces the demonstration
(:data:`REPRODUCTION_TOLERANCE`). :func:`save_driver_style` writes it as ``style.json``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import write_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.descent import PROFILE_RISKS
from drivestyle.irl.driver.driver_style import (
    DRIVER_STYLE_KIND,
    RESIDUAL_FLOOR,
    DriverStyle,
    reproduce,
)
from drivestyle.irl.driver.style_planner import StylePlanner

__all__ = [
    "POOR_FIT_RATIO",
    "REPRODUCTION_TOLERANCE",
    "RISK_AGREEMENT",
    "ClosedLoop",
    "DemoFit",
    "DriverFit",
    "closed_loop_errors",
    "diagnose",
    "reproduced_note",
    "save_driver_style",
]

POOR_FIT_RATIO = 3.0
"""A demonstration whose residual RMS exceeds this many noise floors, and whose closed loop
does not reproduce it (:data:`REPRODUCTION_TOLERANCE`), is not explained by the learned
driver: status ``poor_fit``."""
REPRODUCTION_TOLERANCE = 0.01
"""Closed-loop rmse_xy [m] within which the learned style reproduces a demonstration: its
teacher-forced residual above the threshold is then the learner's (a local minimum whose
mistimed plans re-planning recovers) or the recorded inputs', not the trajectory's. Exact
fits reproduce to 1e-4 m; the local minima measured left 0.04–1.1 m, recorded drivers
≈ 1 m."""
RISK_AGREEMENT = 0.05
"""A demonstration whose best risk alone lies further than this (the profile grid's
spacing) from the learned risk disagrees with it."""


@dataclass(frozen=True)
class ClosedLoop:
    """A style driven in closed loop in a demonstration's scenario (:func:`reproduce`)."""

    rmse_y_m: float
    """RMS lateral error against the demonstration [m]."""
    rmse_xy_m: float
    """RMS position error [m]."""
    min_d: float
    """Least nominal ellipse margin
    (:attr:`~drivestyle.irl.driver.driver_style.Reproduction.min_d`)."""
    failures: int
    """Steps whose solve failed."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (an entry of ``style.json``'s ``reproductions``)."""
        return {"rmse_y_m": self.rmse_y_m, "rmse_xy_m": self.rmse_xy_m, "min_d": self.min_d,
                "failures": self.failures}  # fmt: skip


def closed_loop_errors(
    style: DriverStyle, demo: Demonstration, planner: StylePlanner | None = None
) -> ClosedLoop:
    """Drive ``style`` from the demonstration's first state and measure it against it.

    Args:
        style: the driver style.
        demo: the demonstration.
        planner: the NLP (default: the cached one of the demo's geometry).

    Returns:
        Its rmse_y, rmse_xy [m], least ellipse margin and failed solves.
    """
    rep = reproduce(style, demo, planner)
    rmse_y, rmse_xy = rep.errors(demo)
    return ClosedLoop(rmse_y, rmse_xy, rep.min_d, rep.failures)


@dataclass(frozen=True)
class DemoFit:
    """How well the learned style explains one demonstration."""

    index: int
    """Position of the demonstration in the input."""
    n_residuals: int
    """Residual entries (2 per step)."""
    residual_rms: float
    """RMS of its residuals at the learned style [σ_u units]."""
    active_steps: int
    """Steps whose plan has a binding chance constraint (where p matters; 0: the
    demonstration says nothing about p)."""
    best_risk: float | None
    """The risk that fits this demonstration best with the learned weights (the profile's
    grid risks and the learned one); None when the risks were given."""
    best_residual_rms: float | None
    """Its residual RMS at ``best_risk``."""
    poor: bool
    """The learned driver does not explain it: residual RMS above the poor-fit threshold
    and the closed loop (where driven) not within :data:`REPRODUCTION_TOLERANCE`."""
    disagrees: bool = False
    """Alone it prefers another risk: ``best_risk`` lies more than :data:`RISK_AGREEMENT`
    from the learned one (with the learned weights)."""
    closed_loop: ClosedLoop | None = None
    """The learned style driven in closed loop from its first state (None: not driven)."""

    @property
    def reproduced(self) -> bool:
        """The closed loop lies within :data:`REPRODUCTION_TOLERANCE` of it."""
        return self.closed_loop is not None and self.closed_loop.rmse_xy_m <= REPRODUCTION_TOLERANCE

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "disagrees": self.disagrees,
            "index": self.index,
            "n_residuals": self.n_residuals,
            "residual_rms": self.residual_rms,
            "active_steps": self.active_steps,
            "best_risk": self.best_risk,
            "best_residual_rms": self.best_residual_rms,
            "poor": self.poor,
            "closed_loop": None if self.closed_loop is None else self.closed_loop.to_json(),
            "reproduced": self.reproduced,
        }


@dataclass(frozen=True)
class DriverFit:
    """The result of :func:`~drivestyle.irl.driver.driver_learning.learn_driver`."""

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
    """Levenberg–Marquardt iterations (every descent's)."""
    status: str
    """'converged', 'max_iter', 'stalled' (no step lowered the cost) or 'poor_fit' (the
    optimiser stopped, but some demonstrations' residuals are far above the noise floor
    and the learned style's closed loop does not reproduce them: no single driver of the
    class explains them all; see ``per_demo``)."""
    seconds: float
    """Wall time [s]."""
    history: tuple[float, ...] = field(default=())
    """Cost per iteration of the final (least-squares) descent."""
    residual_floor: float = RESIDUAL_FLOOR
    """The noise floor the residuals were compared with [σ_u units]."""
    per_demo: tuple[DemoFit, ...] = field(default=())
    """Per demonstration, in input order: residual RMS, best risk, poor or not."""
    optimiser_status: str = ""
    """The optimiser's own status ('converged', 'max_iter' or 'stalled') under
    ``poor_fit``; equal to ``status`` otherwise."""
    notes: tuple[str, ...] = field(default=())
    """What the status does not say: a demonstration whose residual lies above the
    threshold but whose closed loop reproduces it (:func:`reproduced_note`)."""

    @property
    def poor_fit_threshold(self) -> float:
        """Residual RMS above which a demonstration is poorly fitted [σ_u units]."""
        return POOR_FIT_RATIO * self.residual_floor

    @property
    def poor_demos(self) -> tuple[int, ...]:
        """Indices of the demonstrations the learned driver does not explain.

        The poorly fitted ones that alone prefer another risk (the odd ones out: the shared
        weights compromise for them, which may lift the others above the threshold too),
        else every poorly fitted one.
        """
        poor = [d for d in self.per_demo if d.poor]
        odd = [d for d in poor if d.disagrees]
        return tuple(d.index for d in (odd or poor))

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
            "optimiser_status": self.optimiser_status or self.status,
            "residual_floor": self.residual_floor,
            "poor_fit_threshold": self.poor_fit_threshold,
            "poor_demos": list(self.poor_demos),
            "per_demo": [d.to_json() for d in self.per_demo],
            "notes": list(self.notes),
            "seconds": self.seconds,
            "history": list(self.history),
        }


def reproduced_note(demo: DemoFit, floor: float, name: str) -> str:
    """One sentence: ``demo``'s residual lies above the threshold, its closed loop within.

    Args:
        demo: a demonstration's fit (driven in closed loop).
        floor: the noise floor [σ_u units].
        name: how to call the demonstration (a file name, or ``per_demo[i]``).
    """
    xy = demo.closed_loop.rmse_xy_m if demo.closed_loop is not None else float("nan")
    return (
        f"{name}: teacher-forced residual {demo.residual_rms / floor:.1f} noise floors, above "
        f"{POOR_FIT_RATIO:g}, but the closed loop reproduces it (rmse_xy {xy:.3f} m ≤ "
        f"{REPRODUCTION_TOLERANCE:g} m): not a poor fit of the data (a local minimum of "
        "learning, or recorded inputs its path does not show)"
    )


def diagnose(
    final: list[tuple[np.ndarray, np.ndarray]],
    ssr: np.ndarray | None,
    risk: float | None,
    floor: float,
    closed: Sequence[ClosedLoop | None] | None = None,
) -> list[DemoFit]:
    """Per demonstration: residual RMS, best risk alone, and whether it is explained.

    Explained: its residual RMS within the poor-fit threshold, or its closed loop within
    :data:`REPRODUCTION_TOLERANCE`.

    Args:
        final: each demonstration's residuals and chance activity at the learned style.
        ssr: Σ‖r‖² per (profile risk, demonstration) at the learned weights, or None
            (risks given, or an exact fit: the learned risk is each one's best).
        risk: the learned shared risk (None: the risks were given).
        floor: the noise floor [σ_u units].
        closed: each demonstration's closed loop at the learned style (None: not driven,
            the residual alone decides).
    """
    loops = list(closed) if closed is not None else [None] * len(final)
    out = []
    for i, ((r, active), loop) in enumerate(zip(final, loops, strict=True)):
        n = int(r.size)
        s_here = float(np.sum(r**2))
        rms = float(np.sqrt(s_here / max(n, 1)))
        best_risk, best_rms = (risk, rms) if risk is not None else (None, None)
        if ssr is not None and risk is not None:
            column = np.append(ssr[:, i], s_here)
            j = int(np.argmin(column))
            best_risk = float(PROFILE_RISKS[j]) if j < len(PROFILE_RISKS) else risk
            best_rms = float(np.sqrt(column[j] / max(n, 1)))
        reproduced = loop is not None and loop.rmse_xy_m <= REPRODUCTION_TOLERANCE
        poor = rms > POOR_FIT_RATIO * floor and not reproduced
        disagrees = (
            best_risk is not None and risk is not None and abs(best_risk - risk) > RISK_AGREEMENT
        )
        out.append(DemoFit(i, n, rms, int(active.sum()), best_risk, best_rms, poor, disagrees,
                           loop))  # fmt: skip
    return out


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
    fitted = fit.to_json()
    if len(demo_paths) == len(fit.per_demo):  # name the demonstrations, poor ones too
        paths = [str(p) for p in demo_paths]
        fitted["per_demo"] = [{"path": paths[d["index"]], **d} for d in fitted["per_demo"]]
    payload = {
        "kind": DRIVER_STYLE_KIND,
        "version": 1,
        "model": "receding-horizon style (DESIGN §15)",
        **fitted,
        "demos": [{"path": str(p)} for p in demo_paths],
        "reproductions": list(reproductions),
    }
    return write_json(Path(path), payload)
