"""The style model's planner: its NLP solved for every style of the class (DESIGN §15, §16).

:class:`StylePlanner` is the model's prediction of the driver's inputs — what learning
(:mod:`drivestyle.irl.driver.driver_learning`), the risk profile
(:mod:`drivestyle.irl.driver.risk_profile`) and identification compare with the recorded
ones, and what the closed loop (:func:`drivestyle.irl.driver.driver_style.closed_loop`)
applies —, not a controller of the simulated world. One parametric NLP per scenario
geometry (:func:`planner_for` caches them): the style's weights, risk, desired speed and
region are its parameters. A plan is one solve (:meth:`StylePlanner.plan`); a batch of
plans warm-started from one another (:class:`PlanRow`, :class:`Link`) is one call of the
compiled solver (:meth:`StylePlanner.solve_rows`), the generic solvers (fatrop, then IPOPT)
taking the rows it fails on. A row that :mod:`drivestyle.planning.reachability` certifies
has no plan is answered without a solve. The NLP itself is :mod:`drivestyle.planning`'s;
the style it plans for is :class:`~drivestyle.irl.driver.driver_style.DriverStyle`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.description import (
    NX,
    NLPBounds,
    PrimalDual,
    SMPCConfig,
    constrained_vehicles,
    constraint_violation,
    nlp_parameters,
)
from drivestyle.planning.plan_solver import PlanSolver, SolveStatus, bounds_vector, compiled_solver
from drivestyle.planning.reachability import (
    box_blocked,
    coasting_stages,
    reachable_boxes,
    stage_one_blocked,
    stage_one_box,
)
from drivestyle.planning.smpc_problem import SMPCProblem
from drivestyle.planning.warm_starts import warm_start

if TYPE_CHECKING:  # the planner reads a style's attributes; the style's closed loop imports it
    from drivestyle.irl.driver.driver_style import DriverStyle

__all__ = [
    "Link",
    "PlanResult",
    "PlanRow",
    "RowsResult",
    "StylePlanner",
    "planner_for",
]


@dataclass(frozen=True)
class PlanResult:
    """One plan from one state."""

    u0: np.ndarray
    """The first input [a, δ], clipped to the scenario's bounds; when the solve failed, the
    braking input [a_min/2, 0] (the expert's last fallback)."""
    ok: bool
    """The solver succeeded and the point is feasible."""
    chance_active: bool
    """A chance constraint binds (multiplier or slack > 0) at some stage of the plan."""
    point: PrimalDual | None
    """The solution (None when the solve failed)."""


@dataclass(frozen=True)
class Link:
    """Where a row of :meth:`StylePlanner.solve_rows` takes its warm start from."""

    shift: int | None = None
    """An earlier row whose solution, shifted by one stage, is the guess (the driver's own
    re-planning: the previous step)."""
    copy: int | None = None
    """An earlier row whose solution is the guess unshifted (the same step at another
    risk or style)."""
    given: PrimalDual | None = None
    """An explicit guess (neither index set; None with no index: a cold start)."""


@dataclass(frozen=True)
class PlanRow:
    """One plan of a batch: the EV's state, the vehicles around it, the style and the link."""

    xi0: np.ndarray
    others: np.ndarray
    style: DriverStyle
    link: Link = field(default_factory=Link)
    y_ref: float | None = None
    """The lateral position the plan aims for [m]; None: the scenario's target lane."""


_NO_PLAN = 4
"""Status of a row neither solver solved (its first input is the braking fallback)."""


def _input_limits(scenario: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """([a_min, −δ_max], [a_max, δ_max]): a plan's first input is clipped to these."""
    return (np.array([scenario.a_min, -scenario.delta_max]),
            np.array([scenario.a_max, scenario.delta_max]))  # fmt: skip


def _braking(scenario: ScenarioConfig) -> np.ndarray:
    """[a_min/2, 0]: the input where no plan was found (the expert's last fallback)."""
    return np.array([scenario.a_min / 2, 0.0])


@dataclass(frozen=True, eq=False)
class RowsResult:
    """The plans of a batch, as arrays (:meth:`StylePlanner.solve_rows`)."""

    u0: np.ndarray
    """First inputs, clipped to the bounds (braking where no plan), shape (n, 2)."""
    ok: np.ndarray
    """Solved (and feasible), shape (n,)."""
    chance_active: np.ndarray
    """A chance constraint binds in the plan (True where no plan), shape (n,)."""
    points: Callable[[int], PrimalDual | None]
    """Row i's solution as a primal-dual point (None where no plan), built on demand."""

    def result(self, i: int) -> PlanResult:
        """Row i as a :class:`PlanResult`."""
        return PlanResult(self.u0[i].copy(), bool(self.ok[i]), bool(self.chance_active[i]),
                          self.points(i))  # fmt: skip

    @classmethod
    def from_results(cls, results: Sequence[PlanResult]) -> RowsResult:
        """From the generic solvers' per-row results."""
        return cls(
            np.array([r.u0 for r in results]).reshape(-1, 2),
            np.array([r.ok for r in results], dtype=bool),
            np.array([r.chance_active for r in results], dtype=bool),
            lambda i: results[i].point,
        )

    @classmethod
    def from_states(
        cls, planner: StylePlanner, states: np.ndarray, ok: np.ndarray, scenario: ScenarioConfig
    ) -> RowsResult:
        """From the compiled solver's interior-point states."""
        fast = planner.fast
        assert fast is not None  # only the compiled path has states
        lay = fast.layout
        w, _, _, z = lay.split(states)
        u0 = np.clip(w[:, lay.nlp.iu[0]], *_input_limits(scenario))
        u0[~ok] = _braking(scenario)
        active = np.any(z[:, lay.h_chance.ravel()] > 1e-8, axis=1) | np.any(
            w[:, lay.nlp.i_s.ravel()] > 1e-8, axis=1
        )
        active |= ~ok
        return cls(u0, ok, active, lambda i: fast.primal_dual(states[i]) if ok[i] else None)


class StylePlanner:
    """The NLP of the style model for one scenario geometry and M surrounding vehicles.

    One :class:`~drivestyle.planning.smpc_problem.SMPCProblem` built with
    ``weights_as_parameters``: every style, risk, speed and scenario of the geometry reuses
    it. Solves are warm-started from :meth:`plan`'s ``guess`` (the previous step's shifted
    solution); fatrop first, IPOPT from the same guess if fatrop fails.
    """

    def __init__(
        self,
        scenario: ScenarioConfig,
        horizon: int = 10,
        n_vehicles: int = 1,
        jit: bool = False,
        compiled: bool = True,
        ipm: bool = False,
    ):
        """Build the parametric NLP.

        Args:
            scenario: the geometry (T_s, wheelbase, ellipse).
            horizon: N.
            n_vehicles: M, vehicles with a chance constraint (nearest first).
            jit: CasADi's jit for the interpreted solvers (≈ 5 s in every process; only
                used when ``compiled`` is off or unavailable).
            compiled: fatrop as generated C, compiled once per machine and cached on disk
                (:attr:`SMPCConfig.compiled`: same iterates, no compilation in later
                processes); without gcc, the interpreted solvers.
            ipm: first try the experimental compiled interior-point solver
                (:mod:`drivestyle.planning.plan_solver`, DESIGN §16), fatrop where it fails.
        """
        self.config = SMPCConfig(
            horizon=horizon, max_vehicles=n_vehicles, weights_as_parameters=True,
            jit=jit and not compiled, compiled=compiled,
        )  # fmt: skip
        self.scenario = scenario
        self.problem = SMPCProblem(self.config, scenario)
        self.layout = self.problem.layout
        self._bounds: dict[tuple, NLPBounds] = {}
        self.fast: PlanSolver | None = compiled_solver(self.config, scenario) if ipm else None
        self.fallbacks = 0
        """Solves the compiled solver handed to the generic solvers (diagnostics)."""
        self.blocked = 0
        """Plans answered without a solve: no plan exists (:meth:`_blocked`; diagnostics)."""

    def serves(self, scenario: ScenarioConfig, horizon: int, n_vehicles: int) -> bool:
        """Whether this planner's NLP fits ``scenario`` with N and M."""
        return (
            self.problem.serves(scenario)
            and self.config.horizon == horizon
            and self.config.max_vehicles == n_vehicles
        )

    def bounds(self, scenario: ScenarioConfig) -> NLPBounds:
        """The scenario's bounds (cached per scenario)."""
        key = (scenario.y_bounds, scenario.phi_max, scenario.v_max, scenario.a_min,
               scenario.a_max, scenario.delta_max)  # fmt: skip
        if key not in self._bounds:
            self._bounds[key] = self.problem.bounds(scenario)
        return self._bounds[key]

    def guess(self, xi0: np.ndarray, previous: PrimalDual | None) -> PrimalDual:
        """The shifted previous solution, or a zero-input rollout."""
        return warm_start(self.problem, xi0, previous, self.scenario)

    def plan(
        self,
        xi0: np.ndarray,
        others: np.ndarray,
        style: DriverStyle,
        scenario: ScenarioConfig,
        previous: PrimalDual | None = None,
        warm: PrimalDual | None = None,
        y_ref: float | None = None,
    ) -> PlanResult:
        """Plan from ξ0 against the surrounding vehicles ``others`` (m, 4).

        Args:
            xi0: the EV's state.
            others: the surrounding vehicles' current states (predicted at constant
                velocity inside the NLP).
            style: weights, risk, desired speed.
            scenario: target lane y_ref, v_ref (unless the style has one) and bounds.
            previous: the previous step's solution (shifted: the warm start) or None.
            warm: a solution of the same step (another risk or style) used unshifted as
                the warm start; overrides ``previous``.
            y_ref: the lateral position to aim for [m] (a driver not yet changing lane: its
                own lane's centre); None: the scenario's target lane.

        Returns:
            The first input and whether the plan is trustworthy.
        """
        if self.fast is not None:
            link = Link(given=warm if warm is not None else self.guess(xi0, previous))
            out = self.solve_rows([PlanRow(xi0, others, style, link, y_ref)], scenario)
            return out.result(0)
        guess = warm if warm is not None else self.guess(xi0, previous)
        p = self.parameters(xi0, others, style, scenario, y_ref)
        return self._plan_generic(p, scenario, guess)

    def parameters(
        self,
        xi0: np.ndarray,
        others: np.ndarray,
        style: DriverStyle,
        scenario: ScenarioConfig,
        y_ref: float | None = None,
    ) -> np.ndarray:
        """The NLP's parameter vector of one plan (the M nearest vehicles constrained).

        ``y_ref`` [m] replaces the scenario's target-lane centre when given.
        """
        cfg = self.config
        vehicles = constrained_vehicles(xi0, others, cfg.max_vehicles, cfg.vehicle_range)
        v_ref = scenario.v_ref if style.v_ref is None else style.v_ref
        target = scenario.y_ref if y_ref is None else y_ref
        return nlp_parameters(xi0, vehicles, target, v_ref, style.kappa, style.weights,
                              style.region(xi0[3], scenario))  # fmt: skip

    def _plan_generic(
        self, p: np.ndarray, scenario: ScenarioConfig, guess: PrimalDual
    ) -> PlanResult:
        """One plan with the generic solvers: fatrop, then IPOPT from the same guess."""
        bounds = self.bounds(scenario)
        if self._blocked(p, bounds):
            self.blocked += 1
            return PlanResult(_braking(scenario), False, True, None)
        sol = self.problem.solve("fatrop", p, guess, bounds)
        if not sol.success:
            sol = self.problem.solve("ipopt", p, guess, bounds)
        viol = constraint_violation(sol.point.w, sol.g, bounds, self.layout.equality)
        ok = bool(sol.success and np.isfinite(viol) and viol < 1e-4)
        if not ok:
            return PlanResult(_braking(scenario), False, True, None)
        u0 = np.clip(sol.point.w[self.layout.iu[0]], *_input_limits(scenario))
        chance_rows = self.layout.ig_path[:, 0::2]
        active = bool(
            np.any(np.abs(sol.point.lam_g[chance_rows]) > 1e-8)
            or np.any(sol.point.w[self.layout.i_s] > 1e-8)
        )
        return PlanResult(u0, True, active, sol.point)

    def _blocked(self, p: np.ndarray, bounds: NLPBounds) -> bool:
        """Whether no plan exists: some stage cannot leave a nominal ellipse (DESIGN §16).

        :mod:`drivestyle.planning.reachability`'s certificates on the parameter vector
        ``p`` (ξ0, the M vehicles, the region l_a) and the bounds, at the stages where the
        EV coasting would be inside an ellipse (stage 1: the heading-frame rectangle, then
        interval boxes), and, when ξ0 is outside the later stages' state bounds, whether
        every stage's bounds can be reached; sound, so a row certified is one the solvers
        fail on and the planner rejects — its answer, the failed plan, is the same
        without them.
        """
        M, N, sc = self.config.max_vehicles, self.config.horizon, self.scenario
        vehicles, l_a, xi0 = p[NX : NX + 4 * M], float(p[-1]), p[:NX]
        u, x1 = self.layout.iu[0], self.layout.ix[1]
        lo, hi = bounds.lbw[x1], bounds.ubw[x1]
        # a few float operations each: ξ0 outside the later stages' state bounds (a recorded
        # heading beyond the model's), and the stages coasting would end inside an ellipse
        outside = bool(np.any(xi0[1:] < lo[1:]) or np.any(xi0[1:] > hi[1:]))
        stages = coasting_stages(xi0, vehicles, sc.dt, l_a, sc.l_b, N)
        if not stages and not outside:
            return False
        if stages and stages[0] == 1:
            corners = stage_one_box(xi0, bounds.lbw[u], bounds.ubw[u], sc.dt, sc.l_f, sc.l_r)
            if stage_one_blocked(corners, vehicles, sc.dt, l_a, sc.l_b):
                return True
        K = N if outside else stages[-1]
        boxes = reachable_boxes(xi0, bounds.lbw[u], bounds.ubw[u], lo, hi, sc.dt, sc.l_f, sc.l_r, K)
        if boxes[-1, 0, 0] > boxes[-1, 0, 1]:  # some stage's bounds cannot be reached
            return True
        return any(box_blocked(boxes[k - 1], vehicles, k * sc.dt, l_a, sc.l_b) for k in stages)

    # ------------------------------------------------------------------ batches
    def solve_rows(
        self, rows: Sequence[PlanRow], scenario: ScenarioConfig, fallback: bool = True
    ) -> RowsResult:
        """Plan every row, in order, warm-started as each row's :class:`Link` says.

        With the compiled solver the whole batch is one call (a row linked to an earlier
        one is warm-started from that row's solution inside it); a row it cannot solve is
        re-solved by the generic solvers from the same guess, and a row whose source has
        no solution at all starts cold, as :meth:`plan` with ``previous=None`` does.

        Args:
            rows: the plans (a :class:`Link`'s ``shift``/``copy`` index must be earlier).
            scenario: target lane, reference speed and bounds of every row.
            fallback: re-solve a row the compiled solver fails with the generic solvers
                (False: the row fails — a caller with its own fallback, e.g. the previous
                plan's next input, saves their far slower solve).

        Returns:
            The first inputs, success and chance activity per row, and the solutions.
        """
        n = len(rows)
        fast = self.fast
        if fast is None:
            results: list[PlanResult] = []
            for row in rows:
                j = row.link.shift if row.link.shift is not None else row.link.copy
                guess = self._link_guess(row, None if j is None else results[j].point)
                p = self.parameters(row.xi0, row.others, row.style, scenario, row.y_ref)
                results.append(self._plan_generic(p, scenario, guess))
            return RowsResult.from_results(results)
        P = np.array([self.parameters(r.xi0, r.others, r.style, scenario, r.y_ref) for r in rows])
        bnd = np.tile(bounds_vector(scenario), (n, 1))
        states = np.zeros((n, fast.layout.n_state))
        src = np.full(n, -1, np.int32)
        mode = np.zeros(n, np.int32)
        status = np.full(n, SolveStatus.FAILED, np.int32)
        for i, row in enumerate(rows):
            link = row.link
            if link.shift is not None or link.copy is not None:
                j = link.shift if link.shift is not None else link.copy
                if not (isinstance(j, int) and 0 <= j < i):
                    raise ValueError(f"row {i} links to row {j}: links must point to earlier rows")
                src[i], mode[i] = j, 1 if link.shift is not None else 2
            else:
                states[i] = fast.state_from(self._link_guess(row, None))
        while True:
            fast.solve_batch(states, P, bnd, src, mode, status)
            failed = np.flatnonzero((status == SolveStatus.FAILED) & (mode != 3))
            solved = (status == SolveStatus.CONVERGED) & (mode != 3)
            mode[solved] = 3
            for i in failed.tolist():
                if not fallback:
                    mode[i], status[i] = 3, _NO_PLAN
                    continue
                # the guess the compiled solver started from, for the generic solvers
                source = fast.primal_dual(states[src[i]]) if src[i] >= 0 else None
                res = self._plan_generic(P[i], scenario, self._link_guess(rows[i], source))
                self.fallbacks += 1
                mode[i] = 3
                if res.ok and res.point is not None:
                    states[i] = fast.state_from(res.point)
                    status[i] = SolveStatus.CONVERGED
                else:
                    status[i] = _NO_PLAN
            blocked = np.flatnonzero(mode != 3)
            if blocked.size == 0:
                break
            for i in blocked.tolist():
                if status[src[i]] == _NO_PLAN:  # as plan(previous=None): a cold start
                    mode[i], src[i] = 0, -1
                    states[i] = fast.state_from(self._link_guess(rows[i], None))
        return RowsResult.from_states(self, states, status == SolveStatus.CONVERGED, scenario)

    def _link_guess(self, row: PlanRow, source: PrimalDual | None) -> PrimalDual:
        """A row's warm start from its link and its source row's solution.

        ``shift``: the source shifted (no source solution: a cold start); ``copy``: the
        source as it is (none: cold); otherwise the given guess, or cold.
        """
        link = row.link
        if link.shift is not None:
            return self.guess(row.xi0, source)
        if link.copy is not None and source is not None:
            return source
        return link.given or self.guess(row.xi0, None)


_PLANNERS: dict[tuple, StylePlanner] = {}


def planner_for(scenario: ScenarioConfig, horizon: int, n_vehicles: int) -> StylePlanner:
    """A cached :class:`StylePlanner` for the geometry (one NLP build per process).

    Its fatrop is the compiled one cached on disk (:attr:`SMPCConfig.compiled`), or the
    interpreted one when no C compiler is available.
    """
    # l_a is a parameter of the style's NLP (DESIGN §18): one planner serves every region
    key = (scenario.dt, scenario.l_f, scenario.l_r, scenario.l_b, horizon, n_vehicles)
    if key not in _PLANNERS:
        _PLANNERS[key] = StylePlanner(scenario, horizon, n_vehicles)
    return _PLANNERS[key]
