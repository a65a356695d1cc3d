"""Stochastic MPC expert: the closed loop around the SMPC problem (paper §II-A; DESIGN §3).

At each step the EV solves the SMPC problem of :mod:`drivestyle.planning.smpc_problem`
(tracking cost, RK4 dynamics, state and input bounds, a softened tangent chance constraint
and a hard nominal ellipse per constrained vehicle) and applies the first input. This
module is the closed-loop shell around that transcription:

- which vehicles are constrained (the M nearest within range, padded with placeholders)
  and the parameters of each solve (EV state, vehicle states, reference, κ = Φ⁻¹(p));
- the warm start: the previous solution shifted by one stage, primal and dual;
- the retry with a second solver, and the fallbacks when both fail (the rest of the last
  accepted plan, else braking with the heading straightened);
- the risk (:meth:`SMPCExpert.set_risk`: κ is a parameter, no rebuild).

:meth:`SMPCExpert.act` returns the action; :meth:`SMPCExpert.plan` returns it with the
step's :class:`SolveReport`.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.scenario import PAPER, ScenarioConfig
from drivestyle.envs.traffic import parse_traffic_observation
from drivestyle.planning.description import (
    NU,
    NLPBounds,
    PrimalDual,
    SMPCConfig,
    constrained_vehicles,
    constraint_violation,
    nlp_parameters,
)
from drivestyle.planning.smpc_problem import NLPSolution, SMPCProblem
from drivestyle.planning.warm_starts import warm_start

__all__ = [
    "InfeasibleStartError",
    "SMPCConfig",
    "SMPCDecision",
    "SMPCDriver",
    "SMPCExpert",
    "SolveReport",
    "cut_in_driver",
    "straighten_steer",
]

ACCEPT_VIOLATION = 1e-6
"""A reported success whose point violates a constraint or bound by more is rejected."""


class InfeasibleStartError(ValueError):
    """The EV starts where no admissible plan exists (e.g. inside the safety ellipse)."""


@dataclass(frozen=True)
class SolveReport:
    """What happened in one step of :meth:`SMPCExpert.plan`."""

    success: bool
    """The solver reported success."""
    status: str
    """Solver return status."""
    iterations: int
    """Solver iterations."""
    solve_ms: float
    """Wall time of the solver call [ms]."""
    fallback: str | None
    """None, 'shifted_plan' or 'brake' (see :meth:`SMPCExpert.plan`)."""
    action: np.ndarray
    """Applied [a, δ]."""
    plan: np.ndarray | None
    """Predicted states ξ_0 … ξ_N, shape (N+1, 4), of the accepted plan."""
    slack: float
    """Chance-constraint relaxation s_1 at the next state (0: the chance constraint holds
    there; > 0: only the nominal ellipse does). NaN on fallback."""
    retried: bool = False
    """The first solver failed and :attr:`SMPCConfig.retry_solver` was tried (``status``,
    ``iterations`` and ``success`` are then the retry's; ``solve_ms`` covers both)."""

    def info(self) -> dict[str, object]:
        """JSON-ready summary (no arrays)."""
        return {
            "success": self.success,
            "status": self.status,
            "iterations": self.iterations,
            "solve_ms": self.solve_ms,
            "fallback": self.fallback,
            "slack": self.slack,
            "retried": self.retried,
        }


@dataclass(frozen=True)
class SMPCDecision:
    """One closed-loop step of :meth:`SMPCExpert.plan`: the action and how it was found."""

    action: np.ndarray
    """The action [a, δ] to apply, shape (2,) [m/s², rad]."""
    report: SolveReport
    """The solve (status, iterations, time, fallback, plan, slack)."""


def straighten_steer(xi: np.ndarray, sc: ScenarioConfig) -> float:
    """Steering that brings the heading back to 0 within one step (clipped to the bound).

    Inverts φ̇ = (v/l_r) sin β, β = atan(l_r/(l_f+l_r) tan δ) for φ̇ = −φ/T_s.

    Args:
        xi: EV state [x, y, φ, v].
        sc: scenario (geometry, T_s, steering bound).

    Returns:
        δ [rad].
    """
    phi, v = float(xi[2]), max(float(xi[3]), 1e-3)
    sin_beta = np.clip(-phi * sc.l_r / (v * sc.dt), -0.99, 0.99)
    delta = np.arctan(np.tan(np.arcsin(sin_beta)) * (sc.l_f + sc.l_r) / sc.l_r)
    return float(np.clip(delta, -sc.delta_max, sc.delta_max))


def parse_observation(obs: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """EV state and the other vehicles' states of an env observation.

    Args:
        obs: [x, y, φ, v]_EV ++ [x, y, φ, v]_TV, shape (8,), or a traffic observation
            (``drivestyle.envs.traffic``: EV ++ K × [present, x, y, φ, v]).

    Returns:
        ξ0, shape (4,), and the present vehicles' states, shape (m, 4).

    Raises:
        ValueError: wrong shape or non-finite entries.
    """
    obs = np.asarray(obs, dtype=float)
    if obs.ndim != 1 or (obs.shape != (8,) and (obs.size < 9 or (obs.size - 4) % 5)):
        raise ValueError(
            f"observation must have shape (8,) or the traffic layout 4 + 5K, got {obs.shape}"
        )
    if not np.all(np.isfinite(obs)):
        raise ValueError(f"observation contains NaN or inf: {obs}")
    if obs.shape == (8,):
        return obs[:4], obs[4:].reshape(1, 4)
    return parse_traffic_observation(obs)


def _check_start(xi0: np.ndarray, others: np.ndarray, sc: ScenarioConfig) -> None:
    """Raise :class:`InfeasibleStartError` if the EV starts inside a safety ellipse."""
    s_e = elliptical_index(xi0[0] - others[:, 0], xi0[1] - others[:, 1], sc.l_a, sc.l_b)
    if s_e.size and float(np.min(s_e)) <= 1.0:
        who = "the TV's" if len(others) == 1 else "a vehicle's"
        raise InfeasibleStartError(
            f"infeasible start: the EV is inside {who} safety ellipse (s_e="
            f"{float(np.min(s_e)):.3f} <= 1); no plan can satisfy the chance constraint"
        )


class SMPCExpert:
    """SMPC expert acting on ``drivestyle`` env observations.

    Example:
        >>> expert = SMPCExpert(SMPCConfig(risk=0.7))
        >>> obs, info = env.reset()
        >>> action = expert.act(obs)
        >>> decision = expert.plan(obs)  # the action and its SolveReport

    The NLP (:class:`drivestyle.planning.smpc_problem.SMPCProblem`) is built once per scenario
    geometry (dt, l_f, l_r, ellipse); speeds, lanes and gaps are parameters, so random
    scenarios reuse it. Call :meth:`reset` at the start of each episode (or pass a
    different scenario) to drop the warm start.
    """

    def __init__(self, config: SMPCConfig | None = None, scenario: ScenarioConfig = PAPER):
        """Build the NLP for ``scenario``'s geometry.

        Args:
            config: SMPC parameters (default: the paper's).
            scenario: the first episode's scenario.
        """
        self._config = config or SMPCConfig()
        self._scenario = scenario
        self._problem = SMPCProblem(self._config, scenario)
        self._bounds: NLPBounds = self._problem.bounds(scenario)
        self._previous: PrimalDual | None = None
        """Last accepted solution: the next step's warm start (None: cold start)."""
        self._plan_inputs = np.empty((0, NU))
        """Inputs of the last accepted plan not yet applied (the 'shifted_plan' fallback)."""
        self._start_checked = False
        """The episode's first observation has been checked for an infeasible start."""

    @property
    def config(self) -> SMPCConfig:
        """The SMPC parameters (change the risk with :meth:`set_risk`)."""
        return self._config

    @property
    def scenario(self) -> ScenarioConfig:
        """The current episode's scenario (change it with :meth:`reset`)."""
        return self._scenario

    @property
    def problem(self) -> SMPCProblem:
        """The NLP and its solvers for the current scenario's geometry."""
        return self._problem

    # ------------------------------------------------------------------ episode
    def set_risk(self, risk: float) -> None:
        """Drive with another risk p from the next episode on (no rebuild: κ is a parameter).

        Raises:
            ValueError: p outside (0, 1).
        """
        self._config = dataclasses.replace(self._config, risk=risk)
        self.reset()

    def reset(self, scenario: ScenarioConfig | None = None) -> None:
        """Start a new episode (drops the warm start); rebuilds the NLP if the geometry changed.

        Args:
            scenario: the episode's scenario; ``None`` keeps the current one.
        """
        if scenario is not None:
            self._scenario = scenario
        if not self._problem.serves(self._scenario):
            self._problem = SMPCProblem(self._config, self._scenario)
        self._bounds = self._problem.bounds(self._scenario)
        self._previous = None
        self._plan_inputs = np.empty((0, NU))
        self._start_checked = False

    # ------------------------------------------------------------------ acting
    def act(self, obs: ArrayLike) -> np.ndarray:
        """The action for the current observation: :meth:`plan`'s ``action``.

        Args:
            obs: env observation (see :meth:`plan`).

        Returns:
            [a, δ], shape (2,) [m/s², rad].
        """
        return self.plan(obs).action

    def predict(self, obs: ArrayLike, state=None, episode_start=None, deterministic=True):
        """stable-baselines3-style alias of :meth:`act` (returns ``(action, None)``)."""
        return self.act(obs), None

    def plan(self, obs: ArrayLike) -> SMPCDecision:
        """Solve the SMPC problem for the current observation: u_0 and the solve's report.

        Args:
            obs: env observation: [x, y, φ, v]_EV ++ [x, y, φ, v]_TV, shape (8,), or a traffic
                observation (``drivestyle.envs.traffic``: EV ++ K × [present, x, y, φ, v]).

        Returns:
            The action [a, δ], shape (2,) [m/s², rad], and its :class:`SolveReport`.

        Raises:
            ValueError: obs has the wrong shape or non-finite entries.
            InfeasibleStartError: the episode's first state lies inside a safety ellipse.

        Retry: if the solver does not report success, :attr:`SMPCConfig.retry_solver` solves
        the same NLP from the same initial guess. Fallback: if that fails too (e.g. the
        nominal ellipse cannot be kept), the expert applies the next input of the last
        accepted plan (``'shifted_plan'``, still safe for a TV that follows its prediction)
        while one remains, else brakes at a_min/2 and steers the heading back to 0
        (``'brake'``). The report records which.
        """
        xi0, others = parse_observation(obs)
        sc = self._scenario
        vehicles = self._constrained_vehicles(xi0, others)
        if not self._start_checked:
            _check_start(xi0, others, sc)
            self._start_checked = True
        p = nlp_parameters(xi0, vehicles, sc.y_ref, sc.v_ref, self._config.kappa)
        t0 = time.perf_counter()
        solution, retried = self._solve(p, self._warm_start(xi0))
        solve_ms = (time.perf_counter() - t0) * 1e3
        status = f"{solution.solver}: {solution.status}" if retried else solution.status
        ok, status = self._accept(solution, status)
        if ok:
            action, plan, slack = self._adopt(solution)
            fallback = None
        else:
            action, fallback = self._fall_back(xi0)
            plan, slack = None, float("nan")
        action = np.clip(action, [sc.a_min, -sc.delta_max], [sc.a_max, sc.delta_max])
        report = SolveReport(
            ok, status, solution.iterations, solve_ms, fallback, action, plan, slack, retried
        )
        return SMPCDecision(action, report)

    # ------------------------------------------------------------------ the steps of plan
    def _constrained_vehicles(self, xi0: np.ndarray, others: np.ndarray) -> np.ndarray:
        """The M vehicles the NLP constrains, nearest first, padded with placeholders."""
        cfg = self._config
        return constrained_vehicles(xi0, others, cfg.max_vehicles, cfg.vehicle_range)

    def _warm_start(self, xi0: np.ndarray) -> PrimalDual:
        """The previous solution shifted by one stage (primal and dual), or a cold start."""
        return warm_start(self._problem, xi0, self._previous, self._scenario)

    def _solve(self, p: np.ndarray, guess: PrimalDual) -> tuple[NLPSolution, bool]:
        """Solve with the configured solver, retrying once from the same guess on failure.

        Returns:
            The last solution and whether the retry solver ran.
        """
        solution = self._problem.solve(self._config.solver, p, guess, self._bounds)
        if solution.success or self._config.retry_solver is None:
            return solution, False
        return self._problem.solve(self._config.retry_solver, p, guess, self._bounds), True

    def _accept(self, solution: NLPSolution, status: str) -> tuple[bool, str]:
        """Whether to apply ``solution``, and its status.

        A reported success whose point violates constraints is not accepted (the status
        then says by how much).
        """
        if not solution.success:
            return False, status
        equality = self._problem.layout.equality
        viol = constraint_violation(solution.point.w, solution.g, self._bounds, equality)
        if not np.isfinite(viol) or viol > ACCEPT_VIOLATION:
            return False, f"{status} (constraint violation {viol:.2e})"
        return True, status

    def _adopt(self, solution: NLPSolution) -> tuple[np.ndarray, np.ndarray, float]:
        """Keep an accepted solution as warm start and fallback plan.

        Returns:
            u_0, the planned states ξ_0 … ξ_N and the slack s_1 (clipped at 0).
        """
        layout = self._problem.layout
        w = solution.point.w
        self._previous = solution.point
        us = w[layout.iu]
        self._plan_inputs = us[1:]
        slack = float(max(np.max(w[layout.i_s[0]]), 0.0))
        return us[0].copy(), w[layout.ix], slack

    def _fall_back(self, xi0: np.ndarray) -> tuple[np.ndarray, str]:
        """The action after a failed solve, which drops the warm start.

        Returns:
            The next input of the last accepted plan while one remains ('shifted_plan'),
            else braking at a_min/2 with the heading straightened ('brake').
        """
        self._previous = None
        if len(self._plan_inputs) > 0:
            action = self._plan_inputs[0].copy()
            self._plan_inputs = self._plan_inputs[1:]
            return action, "shifted_plan"
        sc = self._scenario
        return np.array([sc.a_min / 2, straighten_steer(xi0, sc)]), "brake"


class SMPCDriver:
    """The lane changer of ``drivestyle/CutIn-v0``: SMPC(p) with the ego as its TV.

    Implements the env's ``CutInDriver`` protocol (:mod:`drivestyle.envs.cut_in`). The
    cutter is the scenario's EV; it sees the ego exactly as the demonstrations' SMPC(p)
    sees its TV (one constrained vehicle, predicted at constant velocity with the paper's
    uncertainty). One :class:`SMPCExpert` is built at the first :meth:`reset` and re-used:
    later episodes only change its risk and scenario (κ and speeds are NLP parameters).

    Args:
        config: SMPC parameters; ``risk`` is replaced per episode (default: the paper's,
            compiled solver).
    """

    def __init__(self, config: SMPCConfig | None = None) -> None:
        self._config = config or SMPCConfig(compiled=True)
        self._expert: SMPCExpert | None = None

    @property
    def expert(self) -> SMPCExpert | None:
        """The SMPC expert (None before the first :meth:`reset`)."""
        return self._expert

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode of ``scenario`` driving with risk p = ``risk``.

        Raises:
            ValueError: p outside (0, 1).
        """
        if self._expert is None:
            config = dataclasses.replace(self._config, risk=risk)
            self._expert = SMPCExpert(config, scenario)
        else:
            self._expert.set_risk(risk)
            self._expert.reset(scenario)

    def act(self, cutter: np.ndarray, ego: np.ndarray) -> np.ndarray:
        """The cutter's input [a, δ] for the states at t_k (cutter's EV, ego as its TV).

        Raises:
            RuntimeError: called before :meth:`reset`.
        """
        if self._expert is None:
            raise RuntimeError("SMPCDriver.act() before reset(scenario, risk)")
        return self._expert.act(np.concatenate([cutter, ego]))


def cut_in_driver() -> SMPCDriver:
    """Factory of the ``smpc`` entry point of the ``drivestyle.drivers`` group (CutIn-v0)."""
    return SMPCDriver()
