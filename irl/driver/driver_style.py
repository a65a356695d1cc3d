"""The receding-horizon style model: a driver as a planner with a cost and a risk (DESIGN §15).

A :class:`DriverStyle` describes a *driver*, not one scenario. At every sample the
driver solves, from its current state ξ_k and with the surrounding vehicles predicted at
constant velocity under the uncertainty of :mod:`drivestyle.planning.tv_gaussian`,

    min_u  Σ_{i<N} w_y (y_i − y_ref)² + w_φ φ_i² + w_v (v_i − v_ref)² + w_a a_i² + w_δ δ_i²
              + (terminal state terms) + slack penalty
    s.t.   the vehicle's dynamics and limits (heading, speed, road, inputs),
           Pr(outside every nearby vehicle's safety ellipse) ≥ p   (chance constraint),
           the nominal ellipse (hard),

and applies the first input (the transcription is :mod:`drivestyle.planning.transcription`'s,
with the weights as parameters). The five terms are the horizon versions of the paper's
classic features — lane deviation (f_il/f_el), lateral speed (v·φ, the heading term),
speed deviation (f_v), longitudinal acceleration (f_a) and lateral acceleration (∝ δ); the
paper's reaction features (f_sd, f_ed, f_id and the trigger) are what the chance
constraint produces, with the risk p as an explicit parameter. The weights are defined
up to a common scale (the argmin is invariant), so w_a = 1 fixes the gauge.

*Reproduction* (:func:`reproduce`, :func:`closed_loop`) drives the style in closed loop
from a demonstration's first state, re-planning every T_s against the recorded surrounding
vehicles, as the driver did. Learning a style from demonstrations (teacher forcing) is
:mod:`drivestyle.irl.driver.driver_learning`; its fit per risk, which identification uses, is
:mod:`drivestyle.irl.driver.risk_profile`. The NLP itself is :mod:`drivestyle.planning`'s.

The module is one concept at ≈ 750 lines: a driver style *is* a planner, so its parameters
(:class:`DriverStyle`), the planner that solves its NLP for every style of the class
(:class:`StylePlanner`, the model's prediction of the driver's inputs that learning and
identification compare with the recorded ones, not a controller of the simulated world) and
the closed loop that drives it are the model together.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import read_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.chance import risk_quantile
from drivestyle.planning.description import (
    N_WEIGHTS,
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

__all__ = [
    "DRIVER_STYLE_KIND",
    "GAUGE",
    "INPUT_SCALE",
    "MIN_GAP_RANGE",
    "RESIDUAL_FLOOR",
    "RISK_RANGE",
    "TIME_GAP_RANGE",
    "WEIGHT_NAMES",
    "DriverStyle",
    "DriverStyleError",
    "Link",
    "PlanResult",
    "PlanRow",
    "Reproduction",
    "RowsResult",
    "StylePlanner",
    "check_demo",
    "closed_loop",
    "expert_style",
    "initial_weights",
    "load_driver_style",
    "n_vehicles",
    "planner_for",
    "reproduce",
]

WEIGHT_NAMES = ("lane", "heading", "speed", "accel", "steer")
"""Names of the cost weights [w_y, w_φ, w_v, w_a, w_δ] (w_a = 1 is the gauge)."""
RISK_RANGE = (0.5, 0.99)
"""Risks p the model infers: from the nominal ellipse (0.5) to nearly certain safety."""
RESIDUAL_FLOOR = 0.1
"""s_floor: the residual RMS one driver of the class leaves on its own demonstrations
[σ_u units] (DESIGN §15). Identification's likelihood never assumes a smaller scale (a
demonstration the style fits exactly does not make the posterior a point mass), and
learning calls a fit poor far above it (a simulated driver is fitted exactly; a driver
library's own learning leaves 0.010)."""
INPUT_SCALE = (0.5, 0.005)
"""σ_u: the scale of the input residuals [m/s², rad] (≈ a tenth of the inputs' ranges in
the demonstrations: a and δ then weigh alike)."""
GAUGE = 3
"""Index of the weight fixed at 1 (w_a)."""
TIME_GAP_RANGE = (0.0, 4.0)
"""Time gaps T the style class admits [s] (highway drivers keep 0.5–2.5 s)."""
MIN_GAP_RANGE = (1.0, 60.0)
"""Standstill semi-major axes s_0 the class admits [m]."""


class DriverStyleError(ValueError):
    """A driver style, its file or its demonstrations are unusable."""


def initial_weights() -> np.ndarray:
    """Scale-normalised starting weights: each term ≈ 1 at a typical lane change.

    Typical magnitudes: lane error 5 m, heading 0.05 rad, speed error 5 m/s,
    acceleration 1 m/s², steering 0.02 rad; w = 1 / magnitude². Learning starts here, not
    at any expert's weights.

    Returns:
        [w_y, w_φ, w_v, w_a, w_δ], shape (5,).
    """
    return 1.0 / np.array([5.0, 0.05, 5.0, 1.0, 0.02]) ** 2


@dataclass(frozen=True)
class DriverStyle:
    """One driver: cost weights, risk level and (optionally) desired speed."""

    weights: tuple[float, ...]
    """[w_y, w_φ, w_v, w_a, w_δ] (:data:`WEIGHT_NAMES`), positive."""
    risk: float = 0.7
    """p of the chance constraint, in :data:`RISK_RANGE`."""
    v_ref: float | None = None
    """Desired speed [m/s]; None: the scenario's v_ref."""
    horizon: int = 10
    """N: the planning horizon [steps of T_s]."""
    time_gap: float = 0.0
    """T: the safety region grows with the EV's speed, l_a = s_0 + T·v (:meth:`region`)
    [s]; 0: a fixed ellipse (the SMPC expert's, DESIGN §18)."""
    min_gap: float | None = None
    """s_0: the region's semi-major axis at standstill [m]; None: the scenario's l_a."""

    def __post_init__(self) -> None:
        w = tuple(float(x) for x in self.weights)
        if len(w) != N_WEIGHTS or not all(math.isfinite(x) and x > 0 for x in w):
            raise DriverStyleError(
                f"weights must be {N_WEIGHTS} finite positive numbers, got {self.weights!r}"
            )
        object.__setattr__(self, "weights", w)
        lo, hi = RISK_RANGE
        if not (isinstance(self.risk, (int, float)) and lo <= self.risk <= hi):
            raise DriverStyleError(f"risk must lie in [{lo}, {hi}], got {self.risk!r}")
        if self.v_ref is not None and not (math.isfinite(self.v_ref) and 0 < self.v_ref < 70):
            raise DriverStyleError(f"v_ref must be in (0, 70) m/s, got {self.v_ref!r}")
        if not (isinstance(self.horizon, int) and 1 <= self.horizon <= 50):
            raise DriverStyleError(f"horizon must be an integer in [1, 50], got {self.horizon!r}")
        lo_t, hi_t = TIME_GAP_RANGE
        if not (isinstance(self.time_gap, (int, float)) and lo_t <= self.time_gap <= hi_t):
            raise DriverStyleError(
                f"time_gap must lie in [{lo_t}, {hi_t}] s, got {self.time_gap!r}"
            )
        lo_g, hi_g = MIN_GAP_RANGE
        if self.min_gap is not None and not (
            isinstance(self.min_gap, (int, float)) and lo_g <= self.min_gap <= hi_g
        ):
            raise DriverStyleError(f"min_gap must lie in [{lo_g}, {hi_g}] m, got {self.min_gap!r}")

    def region(self, speed: float, scenario: ScenarioConfig) -> float:
        """l_a = s_0 + T·max(v, 0): the safety region's semi-major axis at speed v [m].

        A headway-like region (DESIGN §18): drivers keep a time gap, not a fixed
        distance; with T = 0 and s_0 the scenario's l_a it is the SMPC expert's ellipse.
        """
        s0 = scenario.l_a if self.min_gap is None else self.min_gap
        return float(s0 + self.time_gap * max(float(speed), 0.0))

    @property
    def kappa(self) -> float:
        """Φ⁻¹(p)."""
        return risk_quantile(self.risk)

    def normalised(self) -> np.ndarray:
        """The weights divided by w_a (the gauge), shape (5,)."""
        w = np.asarray(self.weights)
        return w / w[GAUGE]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the ``style`` entry of a driver-style file)."""
        return {
            "weights": list(self.weights),
            "weight_names": list(WEIGHT_NAMES),
            "risk": self.risk,
            "v_ref": self.v_ref,
            "horizon": self.horizon,
            "time_gap": self.time_gap,
            "min_gap": self.min_gap,
        }

    @classmethod
    def from_json(cls, raw: Any) -> DriverStyle:
        """Inverse of :meth:`to_json`.

        Raises:
            DriverStyleError: a key is missing or a value is invalid.
        """
        if not isinstance(raw, dict):
            kind = type(raw).__name__
            raise DriverStyleError(f"a driver style must be a JSON object, got {kind}")
        try:
            return cls(
                weights=tuple(float(x) for x in raw["weights"]),
                risk=float(raw["risk"]),
                v_ref=None if raw.get("v_ref") is None else float(raw["v_ref"]),
                horizon=int(raw.get("horizon", 10)),
                time_gap=float(raw.get("time_gap", 0.0)),
                min_gap=None if raw.get("min_gap") is None else float(raw["min_gap"]),
            )
        except KeyError as exc:
            raise DriverStyleError(f"driver style is missing key {exc}") from None
        except (TypeError, ValueError) as exc:
            raise DriverStyleError(f"invalid driver style: {exc}") from None


def expert_style(config: SMPCConfig) -> DriverStyle:
    """The SMPC expert as a member of the style class (its weights, risk and horizon).

    The parametric NLP with w = [Q_y, Q_φ, Q_v, R_a, R_δ] and the expert's risk is the
    expert's own NLP (Q_N = Q), so this style plans the expert's inputs (tested): the oracle
    of the prediction and planning studies.

    Raises:
        DriverStyleError: the expert's terminal weights differ from its stage weights, or
            its risk lies outside :data:`RISK_RANGE`.
    """
    if tuple(config.Q_N) != tuple(config.Q):
        raise DriverStyleError("the style class has Q_N = Q; this expert's terminal weights differ")
    q, r = config.Q, config.R
    return DriverStyle((q[1], q[2], q[3], r[0], r[1]), risk=config.risk, horizon=config.horizon)


# ---------------------------------------------------------------------------- the planner
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

        Returns:
            The first input and whether the plan is trustworthy.
        """
        if self.fast is not None:
            link = Link(given=warm if warm is not None else self.guess(xi0, previous))
            out = self.solve_rows([PlanRow(xi0, others, style, link)], scenario)
            return out.result(0)
        guess = warm if warm is not None else self.guess(xi0, previous)
        return self._plan_generic(self.parameters(xi0, others, style, scenario), scenario, guess)

    def parameters(
        self, xi0: np.ndarray, others: np.ndarray, style: DriverStyle, scenario: ScenarioConfig
    ) -> np.ndarray:
        """The NLP's parameter vector of one plan (the M nearest vehicles constrained)."""
        cfg = self.config
        vehicles = constrained_vehicles(xi0, others, cfg.max_vehicles, cfg.vehicle_range)
        v_ref = scenario.v_ref if style.v_ref is None else style.v_ref
        return nlp_parameters(xi0, vehicles, scenario.y_ref, v_ref, style.kappa, style.weights,
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
    def solve_rows(self, rows: Sequence[PlanRow], scenario: ScenarioConfig) -> RowsResult:
        """Plan every row, in order, warm-started as each row's :class:`Link` says.

        With the compiled solver the whole batch is one call (a row linked to an earlier
        one is warm-started from that row's solution inside it); a row it cannot solve is
        re-solved by the generic solvers from the same guess, and a row whose source has
        no solution at all starts cold, as :meth:`plan` with ``previous=None`` does.

        Args:
            rows: the plans (a :class:`Link`'s ``shift``/``copy`` index must be earlier).
            scenario: target lane, reference speed and bounds of every row.

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
                p = self.parameters(row.xi0, row.others, row.style, scenario)
                results.append(self._plan_generic(p, scenario, guess))
            return RowsResult.from_results(results)
        P = np.array([self.parameters(r.xi0, r.others, r.style, scenario) for r in rows])
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


def n_vehicles(demo: Demonstration) -> int:
    """M of a demonstration: the TV alone, or up to 4 vehicles in traffic (the expert's)."""
    return 1 if demo.other_vehicles.shape[1] == 0 else 4


def check_demo(demo: Demonstration) -> ScenarioConfig:
    """The demonstration's scenario, after checking its samples are T_s apart."""
    sc = demo.scenario
    dt = np.diff(demo.t)
    if not np.allclose(dt, sc.dt, rtol=1e-6, atol=1e-9):
        raise DriverStyleError(
            f"the demonstration's samples are {dt.min():.3g}–{dt.max():.3g} s apart, but its "
            f"scenario's T_s is {sc.dt} s: resample it to T_s"
        )
    return sc


# ---------------------------------------------------------------------------- closed loop
@dataclass(frozen=True)
class Reproduction:
    """A style driven in closed loop in a demonstration's scenario."""

    t: np.ndarray
    """Sample times, shape (n,) [s]."""
    states: np.ndarray
    """EV states [x, y, φ, v], shape (n, 4)."""
    inputs: np.ndarray
    """Applied inputs [a, δ], shape (n−1, 2)."""
    failures: int
    """Steps whose solve failed (a fallback input was applied)."""
    min_d: float
    """Least nominal ellipse margin d_k = (Δx/l_a)² + (Δy/l_b)² − 1 against any vehicle."""

    def errors(self, demo: Demonstration) -> tuple[float, float]:
        """(rmse_y, rmse_xy) against the demonstration [m]."""
        d = self.states[:, :2] - demo.ev[:, :2]
        return float(np.sqrt(np.mean(d[:, 1] ** 2))), float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def closed_loop(
    style: DriverStyle,
    xi0: np.ndarray,
    vehicles: np.ndarray,
    scenario: ScenarioConfig,
    planner: StylePlanner,
    previous: PrimalDual | None = None,
) -> tuple[np.ndarray, list[PrimalDual | None], np.ndarray, int]:
    """Drive ``style`` from ξ0 past the vehicles' given states, re-planning every T_s.

    A failed solve applies the previous plan's next input while one remains, else brakes
    at a_min/2 (as the expert does).

    Args:
        style: the driver style.
        xi0: the start state [x, y, φ, v].
        vehicles: the surrounding vehicles' states at each sample, shape (n, m, 4)
            (they do not react to the driven vehicle).
        scenario: target lane, reference speed and bounds.
        planner: the NLP.
        previous: the plan of the step before ξ0, the first solve's warm start (None:
            cold; the NLP is not convex, so a cold start mid-drive may find another plan
            than the driver's warm-started one).

    Returns:
        (states (n, 4), each step's plan or None, inputs (n−1, 2), failed solves).
    """
    n = vehicles.shape[0]
    xs = np.empty((n, 4))
    us = np.empty((n - 1, 2))
    xs[0] = xi0
    plans: list[PrimalDual | None] = []
    spare = np.empty((0, 2))
    failures = 0
    sc = scenario
    for k in range(n - 1):
        res = planner.plan(xs[k], vehicles[k], style, sc, previous)
        if res.ok and res.point is not None:
            us[k] = res.u0
            previous = res.point
            spare = res.point.w[planner.layout.iu][1:]
        else:
            failures += 1
            previous = None
            if len(spare):
                us[k], spare = spare[0], spare[1:]
            else:
                us[k] = res.u0  # braking
        plans.append(previous)
        xs[k + 1] = rk4_step(xs[k], us[k], sc.dt, sc.l_f, sc.l_r)
    return xs, plans, us, failures


def reproduce(
    style: DriverStyle, demo: Demonstration, planner: StylePlanner | None = None
) -> Reproduction:
    """Drive ``style`` from the demonstration's first state, re-planning every T_s.

    The surrounding vehicles move as recorded (they do not react to the reproduction).
    A failed solve applies the previous plan's next input while one remains, else brakes
    at a_min/2 (as the expert does).

    Args:
        style: the driver style.
        demo: the demonstration whose scenario and vehicles to drive in.
        planner: the NLP (default: the cached one of the demo's geometry).

    Returns:
        The closed-loop trajectory.
    """
    sc = check_demo(demo)
    planner = planner or planner_for(sc, style.horizon, n_vehicles(demo))
    vehicles = demo.vehicles
    xs, _, us, failures = closed_loop(style, demo.ev[0], vehicles, sc, planner)
    rel = xs[:, None, :2] - vehicles[:, :, :2]
    d = (rel[..., 0] / sc.l_a) ** 2 + (rel[..., 1] / sc.l_b) ** 2 - 1.0
    return Reproduction(demo.t.copy(), xs, us, failures, float(np.min(d)))


# ---------------------------------------------------------------------------- files
DRIVER_STYLE_KIND = "driver-style"
"""``kind`` of a driver-style file (``style.json`` written by ``learn_style.py``)."""


def load_driver_style(path: str | Path) -> DriverStyle:
    """Read the style of a ``style.json`` written by ``learn_style.py`` (default model).

    Args:
        path: the file or its folder.

    Returns:
        The driver style.

    Raises:
        FileNotFoundError: no such file.
        DriverStyleError: not a driver-style file (a paper-model style says how to make
            one), or its style entry is invalid.
    """
    path, raw = read_json(path, "style.json", DriverStyleError, "style file")
    if raw.get("kind") != DRIVER_STYLE_KIND:
        if "theta" in raw and "features" in raw:
            raise DriverStyleError(
                f"{path} is a paper-model style (whole-horizon weights θ over the ten "
                "features); learn the driver's style with `drivestyle learn-style DEMO… "
                "--out DIR` (default --model driver), or pass it where a paper style is "
                "expected (e.g. compare-baseline --spline-style)"
            )
        raise DriverStyleError(f"{path}: not a driver-style file (kind {raw.get('kind')!r})")
    try:
        return DriverStyle.from_json(raw["style"])
    except KeyError:
        raise DriverStyleError(f"{path}: missing key 'style'") from None
