"""Teacher-forced learning of a driver style (DESIGN §15).

From every recorded state ξ_k the style's plan must start with the input the driver
applied (Levine & Koltun's locally optimal examples): r_k = (u_0(ξ_k; w, p) − u_k) / σ_u.
:func:`learn_driver` minimises Σ‖r_k‖² by Levenberg–Marquardt over log w (and p and v_ref
where free) with forward-difference Jacobians, from several screened starting points and
alternating with a 1-D profile over p (the objective is a saw-tooth in p), first on a
Cauchy loss of the residuals and then on their squares (the continuation that leaves the
local minima of a few mistimed steps); it then compares each demonstration's residuals with
the noise floor one driver of the class leaves (``poor_fit`` when no single driver explains
them all). The optimiser is :mod:`drivestyle.irl.driver.descent`; the fit it returns
(:class:`~drivestyle.irl.driver.driver_fit.DriverFit`, per demonstration whether the style
explains it) and its ``style.json`` are :mod:`drivestyle.irl.driver.driver_fit`'s.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver import descent
from drivestyle.irl.driver.descent import EXACT, PROFILE_RISKS, Box, Run
from drivestyle.irl.driver.driver_fit import (
    POOR_FIT_RATIO,
    DriverFit,
    closed_loop_errors,
    diagnose,
    reproduced_note,
)
from drivestyle.irl.driver.driver_style import (
    GAUGE,
    INPUT_SCALE,
    MIN_GAP_RANGE,
    RESIDUAL_FLOOR,
    RISK_RANGE,
    TIME_GAP_RANGE,
    DriverStyle,
    DriverStyleError,
    check_demo,
    initial_weights,
    n_vehicles,
)
from drivestyle.irl.driver.style_planner import Link, PlanRow, RowsResult, StylePlanner, planner_for
from drivestyle.planning.description import N_WEIGHTS

__all__ = [
    "RESTARTS",
    "ROBUST_SCALE",
    "SCREEN_CANDIDATES",
    "cauchy_residuals",
    "learn_driver",
    "step_residuals",
    "style_from_coordinates",
    "teacher_forced",
]

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


def cauchy_residuals(r: np.ndarray, scale: float) -> np.ndarray:
    """Each step's residual rescaled so that its square is the Cauchy loss of the step's.

    r̃_k = r_k √(c² ln(1 + ‖r_k‖²/c²)) / ‖r_k‖, so ½‖r̃_k‖² = ½ c² ln(1 + ‖r_k‖²/c²):
    ½‖r_k‖² for ‖r_k‖ ≪ c, growing only logarithmically above c. A step (its
    acceleration and steering together) whose plan switched branch weighs little, so
    Levenberg–Marquardt on r̃ (its Jacobian differenced from r̃ itself: Gauss–Newton on the
    Cauchy loss) follows the other steps. r̃ is smooth in r (ln(1 + x)/x is analytic).

    Args:
        r: residuals per step, shape (n, 2) [σ_u units].
        scale: c > 0 [σ_u units].

    Returns:
        r̃, shape (n, 2); a zero residual stays zero.
    """
    s2 = np.sum(r**2, axis=1, keepdims=True)
    c2 = scale**2
    ratio = np.divide(c2 * np.log1p(s2 / c2), s2, out=np.ones_like(s2), where=s2 > 0)
    return r * np.sqrt(ratio)


# ---------------------------------------------------------------------------- learning
ROBUST_SCALE = POOR_FIT_RATIO
"""c of the Cauchy loss of the first descent, in noise floors: a step whose residual lies
above the poor-fit threshold weighs as an outlier there."""
ROBUST_TOL = 1e-2
"""Relative cost decrease below which the Cauchy descent stops: it only has to reach the
basin, the least-squares descent after it converges (at 1e-4 its runs near an exact fit
went to the iteration cap: 3× the evaluations)."""
NEGLIGIBLE_RATIO = 1e-3
"""Residual RMS, in noise floors, at which a Cauchy descent has explained the
demonstrations: it stops there and the other starts are not tried (near an exact fit
forward-difference LM converges linearly, ≈ ×0.3 per iteration: the way on to 1e-20 is
least squares' alone)."""
_RISK_STEP = 0.0025
"""Forward-difference step of the risk coordinate (p itself)."""
_RISK_MAX_STEP = 0.1
"""Largest change of p in one Levenberg–Marquardt step."""


def style_from_coordinates(
    z: np.ndarray,
    base: DriverStyle,
    *,
    fit_risk: bool,
    fit_speed: bool,
    fit_region: bool,
    fit_weights: bool = True,
) -> DriverStyle:
    """The style at a learner's coordinates (the one map every driver learner uses).

    Args:
        z: (4·fit_weights + fit_risk + fit_speed + 2·fit_region,): the free log weights
            (w_a = 1, the gauge), then where fitted p, v_des [m/s], T [s] and s_0 [m], in
            that order.
        base: what is not fitted (weights, risk, desired speed, region, horizon).
        fit_risk: z carries p.
        fit_speed: z carries the desired speed.
        fit_region: z carries T and s_0.
        fit_weights: z carries the log weights (False: ``base``'s, a population's cost).

    Returns:
        The style, each fitted coordinate clipped to the class's range (an optimiser may
        step outside it: a bounded coordinate, not a failure).
    """
    free = [i for i in range(N_WEIGHTS) if i != GAUGE]
    if fit_weights:
        w = np.ones(N_WEIGHTS)
        w[free] = np.exp(z[: len(free)])
        i = len(free)
    else:
        w, i = np.asarray(base.weights, dtype=float), 0
    risk, v_ref, gap, s0 = base.risk, base.v_ref, base.time_gap, base.min_gap
    if fit_risk:
        risk = float(np.clip(z[i], *RISK_RANGE))
        i += 1
    if fit_speed:
        v_ref = float(np.clip(z[i], 0.1, 69.9))
        i += 1
    if fit_region:
        gap = float(np.clip(z[i], *TIME_GAP_RANGE))
        s0 = float(np.clip(z[i + 1], *MIN_GAP_RANGE))
    return DriverStyle(tuple(w), risk=risk, v_ref=v_ref, horizon=base.horizon, time_gap=gap,
                       min_gap=s0)  # fmt: skip


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
    residual_floor: float = RESIDUAL_FLOOR,
    fit_region: bool = False,
    fit_weights: bool = True,
) -> DriverFit:
    """Learn one driver's style from its demonstrations in several scenarios.

    Minimises ½ Σ_d Σ_k ‖r_k‖² (:func:`step_residuals`) over log w (w_a = 1), the risk
    p (unless ``risks`` fixes each demonstration's) and the desired speed (``fit_speed``),
    by Levenberg–Marquardt with forward-difference Jacobians, p and v_ref as bounded
    coordinates (p reaches 0.5). The objective has local minima (the active set of the
    chance constraint changes with the weights: a p = 0.9 driver's LM run from the
    normalised start stopped at cost 197 where the truth has 1e-23), so ``screen``
    starting points — the normalised weights and log-uniform perturbations of e^±2.5
    drawn from a fixed seed — are scored first and LM runs from the ``restarts`` best.
    In p the objective is a saw-tooth (a step's plan switches branch as p moves: with one
    SMPC(0.5) driver's weights fixed, Σ‖r‖² jumps by 2650 between p = 0.6968 and 0.6944
    while its trend falls 160-fold to p = 0.5), so LM alone stops on a tooth far from the
    driver's risk: before and after each LM run the 1-D profile over
    :data:`PROFILE_RISKS` (weights fixed) moves p to a grid risk that fits better, and
    LM restarts from there (at most
    :data:`~drivestyle.irl.driver.descent.PROFILE_ROUNDS` runs). Least squares also has
    local minima where a few steps' plans switch branch a step early or late: LM raises
    the steering weight to damp them and stops (five SMPC(0.9) demonstrations: w_δ 25–1133
    against the driver's 10, some ``poor_fit``). So the descents from the ``restarts``
    best starts minimise the Cauchy loss of the steps' residuals first
    (:func:`cauchy_residuals`, c = :data:`ROBUST_SCALE` floors, stopping at a relative
    decrease of :data:`ROBUST_TOL`, or at :data:`NEGLIGIBLE_RATIO` floors, where the other
    starts are skipped), where those steps weigh little, and least squares finishes from
    the end with the lowest squared cost (with ``fit_weights`` False: least squares from
    ``initial`` alone).

    Each demonstration's residual RMS is then compared with the noise floor: above
    :data:`POOR_FIT_RATIO` floors the demonstration is not explained by the learned
    driver and the status is ``poor_fit`` (``per_demo`` says which, and the risk that fits
    each best alone).

    Args:
        demos: demonstrations of one driver (or, with ``risks``, of drivers that share the
            cost but differ in risk).
        risks: each demonstration's known risk (a library's training), or None to learn
            one shared p.
        fit_speed: also learn the desired speed v_ref (recorded traffic: unknown).
        initial: the starting style (default: :func:`initial_weights`, p = 0.7).
        max_iter: iteration cap of each LM run.
        tol: relative cost decrease below which the run has converged.
        progress: called with (iteration, cost) after each iteration (the Cauchy loss's
            cost in the first descents, then the squared one's).
        screen: starting points scored (1: the normalised start only).
        restarts: Cauchy descents from the best-scored starting points.
        residual_floor: the residual RMS one driver of the class leaves [σ_u units]
            (:data:`RESIDUAL_FLOOR`; a driver library's for its kind of data).
        fit_region: also learn the speed-scaled safety region, its time gap T and
            standstill axis s_0 (:meth:`DriverStyle.region`, DESIGN §18), as bounded
            coordinates starting from ``initial``'s (T = 0 and s_0 = the demonstrations'
            median l_a when it has none: the fixed ellipse the fit improves on).
        fit_weights: learn the cost weights; False keeps ``initial``'s (a population's
            cost, :class:`~drivestyle.irl.identification.library.DriverLibrary`'s style) and learns
            only the driver's own coordinates (p, and v_des, T, s_0 as asked): one LM run from
            ``initial``, no screening (its starting points differ in the weights only).

    Returns:
        The :class:`DriverFit`.

    Raises:
        DriverStyleError: no demonstrations, risks of the wrong length or range, a
            non-positive floor, or a demonstration off its scenario's time grid.
    """
    demos = list(demos)
    if not demos:
        raise DriverStyleError("need at least one demonstration")
    lo, hi = RISK_RANGE
    if risks is not None:
        risks = [float(p) for p in risks]
        if len(risks) != len(demos):
            raise DriverStyleError(f"got {len(risks)} risks for {len(demos)} demonstrations")
        if not all(lo <= p <= hi for p in risks):
            raise DriverStyleError(f"every risk must lie in [{lo}, {hi}], got {risks}")
    if not (math.isfinite(residual_floor) and residual_floor > 0):
        raise DriverStyleError(f"the residual floor must be > 0, got {residual_floor!r}")
    planners = [
        planner_for(check_demo(d), (initial.horizon if initial else 10), n_vehicles(d))
        for d in demos
    ]
    start = initial or DriverStyle(tuple(initial_weights()), risk=0.7)
    v0 = start.v_ref or float(np.median([d.scenario.v_ref for d in demos]))
    if not fit_weights and initial is None:
        raise DriverStyleError("fit_weights=False keeps initial's weights: give initial")
    free = [i for i in range(N_WEIGHTS) if i != GAUGE] if fit_weights else []
    risk_free = risks is None
    if not (fit_weights or risk_free or fit_speed or fit_region):
        raise DriverStyleError("nothing to learn: the weights and the risks are given")
    i_p = len(free)  # the risk coordinate (when free): p itself, bounded
    t0 = time.perf_counter()

    base = start if risk_free else replace(start, risk=0.7)

    def unpack(z: np.ndarray) -> tuple[DriverStyle, list[float]]:
        style = style_from_coordinates(
            z, base, fit_risk=risk_free, fit_speed=fit_speed, fit_region=fit_region,
            fit_weights=fit_weights,
        )  # fmt: skip
        return style, (risks if risks is not None else [style.risk] * len(demos))

    def parts(z: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per demonstration: residuals (n−1, 2) and where a chance constraint binds."""
        style, ps = unpack(z)
        return [
            step_residuals(replace(style, risk=p), d, planners[i])
            for i, (d, p) in enumerate(zip(demos, ps, strict=True))
        ]

    scale = ROBUST_SCALE * residual_floor

    def losses(z: np.ndarray, robust: bool) -> list[np.ndarray]:
        """Per demonstration: the residuals, or (``robust``) their Cauchy version."""
        return [cauchy_residuals(r, scale) if robust else r for r, _ in parts(z)]

    def residuals(z: np.ndarray, robust: bool = False) -> np.ndarray:
        return np.concatenate([r.ravel() for r in losses(z, robust)])

    w0 = np.asarray(start.weights) / start.weights[GAUGE]
    z = list(np.log(w0[free]))
    fd = [0.02] * len(free)  # forward-difference steps
    big = [2.0] * len(free)  # log-weights: at most e² per iteration
    lower, upper = [-np.inf] * len(free), [np.inf] * len(free)
    if risk_free:
        # p itself, bounded: a sigmoid coordinate never reaches p = 0.5 (a driver at the
        # bound sat at s → −∞, its Jacobian column vanishing on the way)
        z.append(start.risk)
        fd.append(_RISK_STEP)
        big.append(_RISK_MAX_STEP)
        lower.append(lo)
        upper.append(hi)
    if fit_speed:
        # an LM step may carry the speed below 0 (a braking driver): bounded, not a failure
        z.append(v0)
        fd.append(0.05)
        big.append(2.0)
        lower.append(0.1)
        upper.append(69.9)
    if fit_region:
        # T and s_0 bounded: a region can shrink to the class's least (T = 0, s_0 = 1 m)
        # from the demonstrations' own ellipse (T = 0, s_0 = their l_a): the fit can only
        # improve on the fixed region (from T = 1 s, s_0 = 5 m LM stalled on 3 of 4 NGSIM
        # episodes at a worse cost than the fixed ellipse's)
        s0 = start.min_gap or float(np.median([d.scenario.l_a for d in demos]))
        z += [start.time_gap, float(np.clip(s0, *MIN_GAP_RANGE))]
        fd += [0.02, 0.1]
        big += [0.5, 5.0]
        lower += [TIME_GAP_RANGE[0], MIN_GAP_RANGE[0]]
        upper += [TIME_GAP_RANGE[1], MIN_GAP_RANGE[1]]
    z0 = np.array(z, dtype=float)
    box = Box(np.array(fd), np.array(big), np.array(lower), np.array(upper))
    rng = np.random.default_rng(SCREEN_SEED)
    candidates = [z0]
    for _ in range(max(screen, 1) - 1 if fit_weights else 0):
        c = z0.copy()
        c[: len(free)] += rng.uniform(-2.5, 2.5, len(free))
        candidates.append(c)
    scored: list[tuple[float, int, np.ndarray, np.ndarray]] = []
    for c in candidates:
        rc = residuals(c)
        scored.append((0.5 * float(rc @ rc), len(scored), c, rc))
    scored.sort(key=lambda item: (item[0] if np.isfinite(item[0]) else np.inf, item[1]))

    def profile(z: np.ndarray, robust: bool = False) -> tuple[np.ndarray, list[np.ndarray]]:
        """Σ_k ‖r_k‖² per (grid risk, demonstration) at z's weights, and the residuals."""
        ssr = np.empty((len(PROFILE_RISKS), len(demos)))
        rs = []
        for j, p in enumerate(PROFILE_RISKS):
            zp = z.copy()
            zp[i_p] = p
            pp = losses(zp, robust)
            ssr[j] = [float(np.sum(r**2)) for r in pp]
            rs.append(np.concatenate([r.ravel() for r in pp]))
        return ssr, rs

    def robust_profile(z: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        return profile(z, robust=True)

    # a Cauchy descent is done when the fit is negligible against the noise floor
    negligible = 0.5 * scored[0][3].size * (NEGLIGIBLE_RATIO * residual_floor) ** 2

    def descend(z: np.ndarray, r: np.ndarray, robust: bool) -> Run:
        prof = (robust_profile if robust else profile) if risk_free else None
        return descent.descend(
            (lambda x: residuals(x, robust=True)) if robust else residuals, prof, i_p, z, r,
            0.5 * float(r @ r), box, max_iter, ROBUST_TOL if robust else tol, progress,
            max(negligible, EXACT) if robust else EXACT,
        )  # fmt: skip

    starts = scored[: max(restarts, 1)]
    total_it = 0
    if fit_weights:
        # Least squares has local minima where a few steps' plans switch branch a step
        # early or late (3–5 σ_u each, constant between switches): LM raises the steering
        # and heading weights to damp those steps and stops (five SMPC(0.9)
        # demonstrations: 6 of 7 draws stuck at w_δ 25–1133 against 10, 3 of them
        # poor_fit). On the Cauchy loss those steps weigh little, the other steps lead
        # the weights across the switches, and least squares finishes from the end with
        # the lowest squared cost (all 7 draws: w_δ 9.9–11.2, ≤ 0.1 floors).
        ends = []
        for _, _, c, _ in starts:
            run = descend(c, residuals(c, robust=True), robust=True)
            total_it += run.iterations
            r_end = residuals(run.z)
            ends.append((0.5 * float(r_end @ r_end), run.z, r_end))
            if ends[-1][0] <= negligible:
                break  # explained to a thousandth of the floor: no start can do better
        _, z_end, r_end = min(ends, key=lambda e: e[0] if np.isfinite(e[0]) else np.inf)
        best = descend(z_end, r_end, robust=False)
        total_it += best.iterations
    else:
        _, _, c, rc = starts[0]
        best = descend(c, rc, robust=False)
        total_it += best.iterations
    status = best.status
    if status == "stalled" and best.cost < min(cost for cost, *_ in starts):
        # the Cauchy descent moved, least squares had no step left to take: a minimum
        status = "converged"
    style, ps = unpack(best.z)
    final = parts(best.z)
    # the closed loop decides whether a residual above the threshold is the data's (the
    # driver not reproduced) or the learner's (a local minimum that still reproduces it)
    closed = [
        closed_loop_errors(replace(style, risk=p), d, planners[i])
        for i, (d, p) in enumerate(zip(demos, ps, strict=True))
    ]
    per_demo = diagnose(final, best.ssr, style.risk if risk_free else None, residual_floor, closed)
    r = best.r
    rms = float(np.sqrt(np.mean(r**2)))
    # the whole fit's RMS lies above the threshold only if some demonstration's does
    poor = any(d.poor for d in per_demo)
    notes = tuple(
        reproduced_note(d, residual_floor, f"per_demo[{d.index}]")
        for d in per_demo
        if d.reproduced and d.residual_rms > POOR_FIT_RATIO * residual_floor
    )
    return DriverFit(
        style=style,
        risks=tuple(ps),
        cost=best.cost,
        residual_rms=rms,
        n_residuals=int(r.size),
        iterations=total_it,
        status="poor_fit" if poor else status,
        seconds=time.perf_counter() - t0,
        history=tuple(best.history),
        residual_floor=float(residual_floor),
        per_demo=tuple(per_demo),
        optimiser_status=status,
        notes=notes,
    )
