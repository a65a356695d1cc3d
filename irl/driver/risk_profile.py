"""The risk profile S(p): a style's teacher-forced fit to one demonstration per risk.

Identification (:mod:`drivestyle.irl.identification.posterior`) turns S(p) into a posterior over p;
only the steps where a chance constraint binds at the largest risk are re-solved per risk
(DESIGN §15).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.driver_learning import teacher_forced
from drivestyle.irl.driver.driver_style import (
    INPUT_SCALE,
    DriverStyle,
    DriverStyleError,
    check_demo,
    n_vehicles,
)
from drivestyle.irl.driver.style_planner import Link, PlanRow, StylePlanner, planner_for
from drivestyle.planning.description import PrimalDual

__all__ = ["REFINE_PER_SIDE", "RISK_EVAL", "RiskProfile", "refined_profile", "risk_profile"]

# ---------------------------------------------------------------------------- risk profile
RISK_EVAL = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.93, 0.95, 0.97, 0.99)
"""Risks at which :func:`risk_profile` solves; identification interpolates between them."""


@dataclass(frozen=True)
class RiskProfile:
    """The teacher-forced fit of a style to one demonstration as a function of its risk."""

    risks: tuple[float, ...]
    """Risks p evaluated (increasing)."""
    ssr: tuple[float, ...]
    """Σ_k ‖r_k‖² at each risk (:func:`step_residuals`)."""
    n_residuals: int
    """Residual entries (2 per step)."""
    n_active: int
    """Steps at which a chance constraint binds at the largest risk: the only steps whose
    plan can depend on p (0: the demonstration says nothing about p)."""


def risk_profile(
    style: DriverStyle,
    demo: Demonstration,
    risks: Sequence[float] = RISK_EVAL,
    planner: StylePlanner | None = None,
) -> RiskProfile:
    """Σ‖r‖² of ``style`` with each risk in ``risks`` on ``demo`` (its weights fixed).

    Every step is solved once at the largest risk. A step whose plan has no binding chance
    constraint there has the same optimum at every smaller risk (the constraint only
    loosens as p falls, so the optimum stays feasible and its KKT conditions hold), so only
    the steps with a binding constraint are re-solved per risk, warm-started from the
    previous step's plan at the same risk, as the driver's own warm start was.

    Args:
        style: the driver style (its ``risk`` is ignored).
        demo: the demonstration.
        risks: increasing risks in :data:`RISK_RANGE`.
        planner: the NLP (default: the cached one of the demo's geometry).

    Returns:
        The :class:`RiskProfile`.
    """
    sc = check_demo(demo)
    risks = tuple(sorted(float(p) for p in risks))
    if not risks:
        raise DriverStyleError("need at least one risk")
    planner = planner or planner_for(sc, style.horizon, n_vehicles(demo))
    scale = np.asarray(INPUT_SCALE)
    vehicles = demo.vehicles
    n = demo.n - 1
    r_top, active, top = teacher_forced(replace(style, risk=risks[-1]), demo, sc, planner)
    ssr = np.empty(len(risks))
    ssr[-1] = float(np.sum(r_top**2))
    constant = float(np.sum(r_top[~active] ** 2))
    steps = [int(i) for i in np.flatnonzero(active)]
    # the driver's own warm start: its previous step's plan at this risk, which at a step
    # without a binding constraint is the largest risk's plan (the NLP is not convex — the
    # nominal ellipse — and the warm start picks the branch)
    starts: dict[int, PrimalDual] = {}
    for k in steps:
        if k == 0 or not active[k - 1]:
            prev = top.points(k - 1) if k > 0 else None
            starts[k] = planner.guess(demo.ev[k], prev)
    rows: list[PlanRow] = []
    for j in range(len(risks) - 1):
        styled = replace(style, risk=risks[j])
        for k in steps:
            link = Link(given=starts[k]) if k in starts else Link(shift=len(rows) - 1)
            rows.append(PlanRow(demo.ev[k], vehicles[k], styled, link))
    if rows:
        u0 = planner.solve_rows(rows, sc).u0.reshape(len(risks) - 1, len(steps), 2)
        ssr[:-1] = constant + np.sum(((u0 - demo.u[steps]) / scale) ** 2, axis=(1, 2))
    else:
        ssr[:-1] = constant
    return RiskProfile(risks, tuple(ssr.tolist()), 2 * n, int(active.sum()))


REFINE_PER_SIDE = 2
"""Risks :func:`refined_profile` adds inside each grid interval next to the coarse minimum."""


def refined_profile(
    style: DriverStyle,
    demo: Demonstration,
    risks: Sequence[float] = RISK_EVAL,
    planner: StylePlanner | None = None,
) -> RiskProfile:
    """:func:`risk_profile` on ``risks``, refined around its minimum.

    Between grid risks S(p) is interpolated linearly, and a driver's minimum is sharp (an
    SMPC driver's S vanishes at its own risk only): with the 13-risk grid alone the
    posterior mean of drivers of continuous risk was off by 0.042 on average, of those at
    the grid's midpoints by 0.014. So :data:`REFINE_PER_SIDE` risks are added, evenly,
    inside each of the two grid intervals beside the coarse minimum and solved the same
    way; the merged profile is what identification interpolates.

    Args:
        style: the driver style (its ``risk`` is ignored).
        demo: the demonstration.
        risks: the coarse grid (increasing, in :data:`RISK_RANGE`).
        planner: the NLP (default: the cached one of the demo's geometry).

    Returns:
        The merged :class:`RiskProfile` (``n_active`` the coarse profile's); the coarse
        one when no chance constraint binds (S is flat: nothing to refine).
    """
    coarse = risk_profile(style, demo, risks, planner)
    if coarse.n_active == 0 or len(coarse.risks) < 2:
        return coarse
    grid = coarse.risks
    j = int(np.argmin(coarse.ssr))
    extra: list[float] = []
    for a, b in ((max(j - 1, 0), j), (j, min(j + 1, len(grid) - 1))):
        if a != b:
            inner = np.linspace(grid[a], grid[b], REFINE_PER_SIDE + 2)[1:-1]
            extra += [round(float(p), 6) for p in inner]
    fine = risk_profile(style, demo, extra, planner)
    solved = dict(zip(grid, coarse.ssr, strict=True))
    solved.update(zip(fine.risks, fine.ssr, strict=True))
    merged = sorted(solved.items())
    return RiskProfile(
        tuple(p for p, _ in merged), tuple(v for _, v in merged), coarse.n_residuals,
        coarse.n_active,
    )  # fmt: skip
