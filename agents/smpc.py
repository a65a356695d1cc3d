"""Stochastic MPC expert (paper §II-A, eq. 1–4; docs/DESIGN.md §3).

At each step the EV solves

    min_u  Σ_{k<N} ‖ξ_k − ξ_k^ref‖²_Q + ‖u_k‖²_R + ‖ξ_N − ξ_N^ref‖²_{Q_N}
    s.t.   ξ_{k+1} = F(ξ_k, u_k)                      (the env's RK4 map, envs/dynamics.py)
           ξ_k ∈ Ξ, u_k ∈ U                           (heading, speed, road, input bounds)
           g_k(ξ_k) + s_k ≥ 0, s_k ≥ 0, k = 1 … N     (tangent chance constraint, agents/chance.py)
           ‖z̄_k‖ − 1 ≥ 0, k = 1 … N                  (nominal ellipse, hard)

with ξ^ref_k = [x_0 + v_ref t_k, y_ref, 0, v_ref] (the x weight is 1e-6, so x_ref only
keeps that term bounded) and the slack s_k penalised by ρ₁ s_k + ρ₂ s_k² in the cost.

Why the slack: the chance constraint can be infeasible from the current state — a
growing TV covariance at large p may demand more distance than the road offers — and a
hard constraint then makes every solve fail. The exact L1 penalty (ρ₁ larger than any
multiplier the hard problem needs) returns the hard solution whenever one exists and
otherwise the plan that violates the probabilistic margin least. The nominal ellipse
(p = 0.5, d_k ≥ 0) stays hard, so the closed loop keeps d_k ≥ 0 whatever p.

The NLP is built once per geometry with CasADi (exact first and second derivatives), its
variables ordered by stage ([ξ_0, u_0, ξ_1, u_1, s_1, …, ξ_N, s_N]) so that fatrop can
exploit the optimal-control structure, and warm-started from the previous solution
shifted by one step (primal and dual).

On solver failure the expert falls back (documented in :meth:`SMPCExpert.act`) and
reports it in :attr:`SMPCExpert.last_report`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from drivestyle.agents.chance import chance_margin, risk_quantile
from drivestyle.agents.prediction import PAPER_TV_UNCERTAINTY, TVUncertainty, tv_covariance
from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.scenario import PAPER, ScenarioConfig
from drivestyle.envs.traffic import parse_traffic_observation
from numpy.typing import ArrayLike

__all__ = ["InfeasibleStartError", "SMPCConfig", "SMPCExpert", "SolveReport"]

NX, NU = 4, 2
SOLVERS = ("fatrop", "ipopt")


class InfeasibleStartError(ValueError):
    """The EV starts where no admissible plan exists (e.g. inside the safety ellipse)."""


def _diag4(name: str, value: tuple[float, ...], n: int) -> None:
    if len(value) != n or not all(math.isfinite(v) and v >= 0 for v in value):
        raise ValueError(f"{name} must be {n} finite non-negative numbers, got {value!r}")


@dataclass(frozen=True)
class SMPCConfig:
    """Parameters of the SMPC expert (defaults: the paper's, DESIGN §1)."""

    risk: float = 0.7
    """p: required probability of staying outside the TV's safety ellipse, in (0, 1)."""
    horizon: int = 10
    """N: prediction horizon [steps]."""
    Q: tuple[float, float, float, float] = (1e-6, 0.2, 50.0, 0.2)
    """Stage state weights on [x, y, φ, v] errors."""
    Q_N: tuple[float, float, float, float] = (1e-6, 0.2, 50.0, 0.2)
    """Terminal state weights."""
    R: tuple[float, float] = (1.0, 10.0)
    """Input weights on [a, δ]."""
    uncertainty: TVUncertainty = field(default_factory=lambda: PAPER_TV_UNCERTAINTY)
    """TV prediction error model (drivestyle.agents.prediction)."""
    solver: str = "fatrop"
    """'fatrop' (structure-exploiting interior point) or 'ipopt'."""
    max_iter: int = 200
    """Solver iteration cap."""
    mu_init: float = 1e-3
    """Initial barrier parameter (small: the warm start is close to the solution)."""
    jit: bool = False
    """Compile the NLP functions with the system C compiler (gcc): ≈2× faster solves after
    a few seconds of compilation per geometry. Needs a working ``gcc``."""
    tol: float = 1e-6
    """Solver convergence tolerance. 1e-8 is below what this NLP's scaling allows (costs up
    to 1e4 from the slack penalty, positions of hundreds of metres): fatrop's line search
    then stalls next to the optimum and reports failure (status 1) in ≈ 1 of 5 p = 0.8
    demonstrations, although the iterate is optimal to 1e-6 (DESIGN §3)."""
    max_vehicles: int = 1
    """M: surrounding vehicles with a chance constraint each (1: the paper's TV only; in
    traffic the M nearest within :attr:`vehicle_range`, fewer are padded with a far,
    standing placeholder whose constraints never bind)."""
    vehicle_range: float = 100.0
    """Vehicles farther than this from the EV (centre distance) are not constrained [m]."""
    retry_solver: str | None = "ipopt"
    """Second attempt when the first solve fails, from the same initial guess, before any
    fallback (None: no retry). Built on first use only."""
    slack_l1: float = 1e4
    """ρ₁: linear (exact) penalty on the chance-constraint slack."""
    slack_l2: float = 1e2
    """ρ₂: quadratic penalty on the slack (keeps the problem strictly convex in s)."""

    def __post_init__(self) -> None:
        risk_quantile(self.risk)  # validates p ∈ (0, 1)
        if not (isinstance(self.horizon, int) and self.horizon >= 1):
            raise ValueError(f"horizon must be a positive integer, got {self.horizon!r}")
        _diag4("Q", self.Q, 4)
        _diag4("Q_N", self.Q_N, 4)
        _diag4("R", self.R, 2)
        if self.solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {self.solver!r}")
        if not (isinstance(self.max_vehicles, int) and 1 <= self.max_vehicles <= 12):
            raise ValueError(
                f"max_vehicles must be an integer in [1, 12], got {self.max_vehicles!r}"
            )
        if not (math.isfinite(self.vehicle_range) and self.vehicle_range > 0):
            raise ValueError(f"vehicle_range must be > 0 m, got {self.vehicle_range!r}")
        if self.retry_solver is not None and self.retry_solver not in SOLVERS:
            raise ValueError(
                f"retry_solver must be None or one of {SOLVERS}, got {self.retry_solver!r}"
            )
        if self.max_iter < 1 or not (self.tol > 0) or not (self.mu_init > 0):
            raise ValueError("max_iter must be >= 1, tol > 0 and mu_init > 0")
        if not (self.slack_l1 > 0 and self.slack_l2 >= 0):
            raise ValueError("slack_l1 must be > 0 and slack_l2 >= 0")

    @property
    def kappa(self) -> float:
        """Φ⁻¹(p), the back-off quantile."""
        return risk_quantile(self.risk)


@dataclass(frozen=True)
class SolveReport:
    """What happened in one call of :meth:`SMPCExpert.act`."""

    success: bool
    """The solver reported success."""
    status: str
    """Solver return status."""
    iterations: int
    """Solver iterations."""
    solve_ms: float
    """Wall time of the solver call [ms]."""
    fallback: str | None
    """None, 'shifted_plan' or 'brake' (see :meth:`SMPCExpert.act`)."""
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


def _geometry_key(sc: ScenarioConfig) -> tuple:
    return (sc.dt, sc.l_f, sc.l_r, sc.l_a, sc.l_b)


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


class SMPCExpert:
    """SMPC expert acting on ``drivestyle`` env observations.

    Example:
        >>> expert = SMPCExpert(SMPCConfig(risk=0.7))
        >>> obs, info = env.reset()
        >>> action = expert.act(obs)

    The NLP is built once per scenario geometry (dt, l_f, l_r, ellipse); speeds, lanes
    and gaps are parameters, so random scenarios reuse it. Call :meth:`reset` at the start
    of each episode (or pass a different scenario) to drop the warm start.
    """

    def __init__(self, config: SMPCConfig | None = None, scenario: ScenarioConfig = PAPER):
        self.config = config or SMPCConfig()
        self.scenario = scenario
        self._solver: ca.Function | None = None
        self._key: tuple | None = None
        self.last_report: SolveReport | None = None
        self.reset(scenario)

    # ------------------------------------------------------------------ building
    def _build(self) -> None:
        cfg, sc = self.config, self.scenario
        N, T_s = cfg.horizon, sc.dt
        x_sym, u_sym = ca.SX.sym("xi", NX), ca.SX.sym("u", NU)
        F = ca.Function("F", [x_sym, u_sym], [rk4_step(x_sym, u_sym, T_s, sc.l_f, sc.l_r)])

        # parameters: ξ0 (4), TV state (4), y_ref, v_ref
        M = cfg.max_vehicles
        # κ = Φ⁻¹(p) is a parameter: one built solver serves every risk (set_risk)
        P = ca.SX.sym("P", NX + 4 * M + 3)
        xi0, y_ref, v_ref = P[0:4], P[NX + 4 * M], P[NX + 4 * M + 1]
        kappa = P[NX + 4 * M + 2]
        vehicles = [P[NX + 4 * j : NX + 4 * j + 4] for j in range(M)]
        sigma = tv_covariance(cfg.uncertainty, T_s, N)
        Q, QN, R = (np.diag(w) for w in (cfg.Q, cfg.Q_N, cfg.R))
        xs = [ca.SX.sym(f"x{k}", NX) for k in range(N + 1)]
        us = [ca.SX.sym(f"u{k}", NU) for k in range(N)]
        ss = [ca.SX.sym(f"s{k}", M) for k in range(N + 1)]  # ss[0] unused; one per vehicle

        def margins(k: int, tv: ca.SX) -> tuple[ca.SX, ca.SX]:
            t_k = k * T_s
            dx = xs[k][0] - (tv[0] + tv[3] * ca.cos(tv[2]) * t_k)
            dy = xs[k][1] - (tv[1] + tv[3] * ca.sin(tv[2]) * t_k)
            g = chance_margin(
                dx, dy, sigma[k, 0, 0], sigma[k, 0, 1], sigma[k, 1, 1], sc.l_a, sc.l_b, kappa
            )
            nominal = chance_margin(dx, dy, 0.0, 0.0, 0.0, sc.l_a, sc.l_b, 0.0)
            return g, nominal

        # fatrop's stage layout: per stage k the variables [ξ_k, u_k, s_k]; in g first the
        # gap-closing ξ_{k+1} − F(ξ_k, u_k), then the path constraints of stage k
        # (k = 0: ξ_0 = ξ0; k ≥ 1: softened chance constraint, nominal ellipse)
        w, g, eq, J = [], [], [], 0
        ix, iu, i_s, ig_dyn, ig_path = [], [], [], [], []

        def add_var(v: ca.SX) -> np.ndarray:
            start = sum(int(x.numel()) for x in w)
            w.append(v)
            return np.arange(start, start + int(v.numel()))

        def add_con(c: ca.SX, equality: bool) -> np.ndarray:
            start = len(eq)
            g.append(c)
            eq.extend([equality] * int(c.numel()))
            return np.arange(start, len(eq))

        for k in range(N + 1):
            e = xs[k] - ca.vertcat(xi0[0] + v_ref * k * T_s, y_ref, 0, v_ref)
            ix.append(add_var(xs[k]))
            if k < N:
                iu.append(add_var(us[k]))
            if k > 0:
                i_s.append(add_var(ss[k]))
                J += cfg.slack_l1 * ca.sum1(ss[k]) + cfg.slack_l2 * ca.sumsqr(ss[k])
            if k < N:
                J += ca.mtimes([e.T, Q, e]) + ca.mtimes([us[k].T, R, us[k]])
                ig_dyn.append(add_con(xs[k + 1] - F(xs[k], us[k]), True))
            else:
                J += ca.mtimes([e.T, QN, e])
            if k == 0:
                ig_path.append(add_con(xs[0] - xi0, True))
            else:
                rows = []
                for j, tv in enumerate(vehicles):
                    chance, nominal = margins(k, tv)
                    rows += [chance + ss[k][j], nominal]
                ig_path.append(add_con(ca.vertcat(*rows), False))
        nlp = {"x": ca.vertcat(*w), "f": J, "g": ca.vertcat(*g), "p": P}
        self._ix, self._iu, self._is = np.array(ix), np.array(iu), np.array(i_s)
        self._ig_dyn, self._ig_path = np.array(ig_dyn), ig_path
        self._eq = np.array(eq)

        self._nlp, self._F = nlp, F
        self._solver = solver = self._make_solver(cfg.solver)
        # zero-copy calls: the solver reads and writes these numpy arrays in place, which
        # saves ≈0.2 ms of numpy↔DM conversion per step
        self._in = {n: np.zeros(solver.nnz_in(n)) for n in solver.name_in()}
        self._out = {n: np.zeros(solver.nnz_out(n)) for n in solver.name_out()}
        self._calls: dict[str, tuple] = {cfg.solver: self._bind(solver)}

    def _make_solver(self, name: str) -> ca.Function:
        """The NLP of :meth:`_build` as a CasADi solver ``name`` (fatrop or ipopt)."""
        cfg = self.config
        common: dict = {"expand": True, "print_time": False}
        if cfg.jit:
            # compile the NLP's derivative functions with the system C compiler
            common |= {
                "jit": True,
                "compiler": "shell",
                "jit_options": {"flags": ["-O2"], "verbose": False},
            }
        if name == "fatrop":
            opts = common | {
                "structure_detection": "auto",
                "equality": self._eq.tolist(),
                "fatrop": {
                    "print_level": 0,
                    "max_iter": cfg.max_iter,
                    "tol": cfg.tol,
                    "mu_init": cfg.mu_init,
                },
            }
        else:
            opts = common | {
                "ipopt": {
                    "print_level": 0,
                    "sb": "yes",
                    "max_iter": cfg.max_iter,
                    "tol": cfg.tol,
                    "mu_init": cfg.mu_init,
                    "warm_start_init_point": "yes",
                    "warm_start_bound_push": 1e-6,
                    "warm_start_mult_bound_push": 1e-6,
                },
            }
        return ca.nlpsol(f"smpc_{name}", name, self._nlp, opts)

    def _bind(self, solver: ca.Function) -> tuple:
        """(buffer, evaluate) of ``solver`` reading and writing :attr:`_in` / :attr:`_out`."""
        buffer, evaluate = solver.buffer()
        for i, n in enumerate(solver.name_in()):
            buffer.set_arg(i, memoryview(self._in[n]))
        for i, n in enumerate(solver.name_out()):
            buffer.set_res(i, memoryview(self._out[n]))
        return buffer, evaluate

    def _solve(self, name: str) -> tuple[bool, str, int]:
        """Run solver ``name`` on the prepared inputs: (success, status, iterations)."""
        if name not in self._calls:
            self._calls[name] = self._bind(self._make_solver(name))
        buffer, evaluate = self._calls[name]
        try:
            evaluate()
            stats = buffer.stats()
            return (
                bool(stats.get("success", False)),
                str(stats.get("return_status", "unknown")),
                int(stats.get("iter_count", -1)),
            )
        except RuntimeError as exc:  # CasADi raises on NaN evaluations, solver errors, ...
            return False, f"error: {exc}".splitlines()[0], -1

    def _bounds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        sc = self.scenario
        nw = self._in["x0"].size
        lbw, ubw = np.full(nw, -np.inf), np.full(nw, np.inf)
        lbw[self._ix[1:]] = [-np.inf, sc.y_bounds[0], -sc.phi_max, 0.0]
        ubw[self._ix[1:]] = [np.inf, sc.y_bounds[1], sc.phi_max, sc.v_max]
        lbw[self._iu] = [sc.a_min, -sc.delta_max]
        ubw[self._iu] = [sc.a_max, sc.delta_max]
        lbw[self._is] = 0.0
        lbg = np.zeros(self._eq.size)
        ubg = np.where(self._eq, 0.0, np.inf)
        return lbw, ubw, lbg, ubg

    def set_risk(self, risk: float) -> None:
        """Drive with another risk p from the next episode on (no rebuild: κ is a parameter).

        Raises:
            ValueError: p outside (0, 1).
        """
        self.config = dataclasses.replace(self.config, risk=risk)
        self.reset()

    # ------------------------------------------------------------------ episode
    def reset(self, scenario: ScenarioConfig | None = None) -> None:
        """Start a new episode (drops the warm start); rebuilds the NLP if the geometry changed.

        Args:
            scenario: the episode's scenario; ``None`` keeps the current one.
        """
        if scenario is not None:
            self.scenario = scenario
        if self._key != _geometry_key(self.scenario):
            self._build()
            self._key = _geometry_key(self.scenario)
        self._lbw, self._ubw, lbg, ubg = self._bounds()
        for name, value in (("lbx", self._lbw), ("ubx", self._ubw), ("lbg", lbg), ("ubg", ubg)):
            self._in[name][:] = value
        self._w0: np.ndarray | None = None
        self._lam_g: np.ndarray | None = None
        self._lam_x: np.ndarray | None = None
        self._plan_u: np.ndarray | None = None
        self._first = True
        self.last_report = None

    def _initial_guess(self, xi0: np.ndarray) -> np.ndarray:
        """Previous solution shifted by one stage, or a zero-input rollout from ξ0."""
        N, sc = self.config.horizon, self.scenario
        w = np.zeros(self._in["x0"].size)
        if self._w0 is not None:
            xs, us = self._w0[self._ix], self._w0[self._iu]
            x_tail = np.asarray(self._F(xs[-1], us[-1])).ravel()
            w[self._ix] = np.vstack([xs[1:], x_tail])
            w[self._iu] = np.vstack([us[1:], us[-1:]])
            w[self._is] = np.vstack([self._w0[self._is][1:], self._w0[self._is][-1:]])
        else:
            xs = np.empty((N + 1, NX))
            xs[0] = xi0
            for k in range(N):
                xs[k + 1] = rk4_step(xs[k], np.zeros(NU), sc.dt, sc.l_f, sc.l_r)
            w[self._ix] = xs
        w[self._ix[0]] = xi0
        return w

    def _shifted_duals(self) -> tuple[np.ndarray, np.ndarray]:
        """Multipliers of the previous solution shifted by one stage (last stage repeated)."""
        N = self.config.horizon
        lg, lx = self._lam_g, self._lam_x
        new_g, new_x = lg.copy(), lx.copy()
        nxt = np.minimum(np.arange(N) + 1, N - 1)
        new_g[self._ig_dyn] = lg[self._ig_dyn[nxt]]
        path = self._ig_path[1:]  # stages 1 … N
        for k in range(len(path) - 1):
            new_g[path[k]] = lg[path[k + 1]]
        new_x[self._ix[1:-1]] = lx[self._ix[2:]]
        new_x[self._iu] = lx[self._iu[nxt]]
        new_x[self._is[:-1]] = lx[self._is[1:]]
        return new_g, new_x

    def _constrained_vehicles(self, xi0: np.ndarray, others: np.ndarray) -> np.ndarray:
        """The M vehicles the NLP constrains, nearest first, padded with placeholders.

        A placeholder stands 10 km behind the EV: its margins are huge and never bind.
        """
        M = self.config.max_vehicles
        dist = np.hypot(others[:, 0] - xi0[0], others[:, 1] - xi0[1]) if len(others) else []
        order = [j for j in np.argsort(dist, kind="stable") if dist[j] <= self.config.vehicle_range]
        if M == 1 and len(others) == 1:
            order = [0]  # the paper's TV is always constrained, however far
        chosen = [others[j] for j in order[:M]]
        chosen += [np.array([xi0[0] - 1e4, xi0[1], 0.0, 0.0])] * (M - len(chosen))
        return np.array(chosen)

    def act(
        self, obs: ArrayLike, return_info: bool = False
    ) -> np.ndarray | tuple[np.ndarray, dict[str, object]]:
        """Solve the SMPC problem for the current observation and return u_0.

        Args:
            obs: env observation: [x, y, φ, v]_EV ++ [x, y, φ, v]_TV, shape (8,), or a traffic
                observation (``drivestyle.envs.traffic``: EV ++ K × [present, x, y, φ, v]).
            return_info: also return the solve's info dict (``success``, ``status``,
                ``iterations``, ``solve_ms``, ``fallback``, ``slack``).

        Returns:
            The action [a, δ], shape (2,) [m/s², rad] (and the info dict).

        Raises:
            ValueError: obs has the wrong shape or non-finite entries.
            InfeasibleStartError: the episode's first state lies inside a safety ellipse.

        Retry: if the solver does not report success, :attr:`SMPCConfig.retry_solver` solves
        the same NLP from the same initial guess. Fallback: if that fails too (e.g. the
        nominal ellipse cannot be kept), the expert applies the next input of the last accepted plan
        (``'shifted_plan'``, still safe for a TV that follows its prediction) while one
        remains, else brakes at a_min/2 and steers the heading back to 0 (``'brake'``).
        :attr:`last_report` records which.
        """
        obs = np.asarray(obs, dtype=float)
        if obs.ndim != 1 or (obs.shape != (8,) and (obs.size < 9 or (obs.size - 4) % 5)):
            raise ValueError(
                f"observation must have shape (8,) or the traffic layout 4 + 5K, got {obs.shape}"
            )
        if not np.all(np.isfinite(obs)):
            raise ValueError(f"observation contains NaN or inf: {obs}")
        sc = self.scenario
        if obs.shape == (8,):
            xi0, others = obs[:4], obs[4:].reshape(1, 4)
        else:
            xi0, others = parse_traffic_observation(obs)
        vehicles = self._constrained_vehicles(xi0, others)
        if self._first:
            s_e = elliptical_index(xi0[0] - others[:, 0], xi0[1] - others[:, 1], sc.l_a, sc.l_b)
            if s_e.size and float(np.min(s_e)) <= 1.0:
                who = "the TV's" if len(others) == 1 else "a vehicle's"
                raise InfeasibleStartError(
                    f"infeasible start: the EV is inside {who} safety ellipse (s_e="
                    f"{float(np.min(s_e)):.3f} <= 1); no plan can satisfy the chance constraint"
                )
            self._first = False
        self._in["p"][:] = np.concatenate(
            [xi0, vehicles.ravel(), [sc.y_ref, sc.v_ref, self.config.kappa]]
        )
        self._in["x0"][:] = self._initial_guess(xi0)
        if self._lam_g is not None:
            self._in["lam_g0"][:], self._in["lam_x0"][:] = self._shifted_duals()
        else:
            self._in["lam_g0"][:] = self._in["lam_x0"][:] = 0.0
        t0 = time.perf_counter()
        guess = self._in["x0"].copy(), self._in["lam_g0"].copy(), self._in["lam_x0"].copy()
        ok, status, iters = self._solve(self.config.solver)
        retried = False
        if not ok and self.config.retry_solver is not None:
            retried = True  # same initial guess; the first attempt may have overwritten it
            self._in["x0"][:], self._in["lam_g0"][:], self._in["lam_x0"][:] = guess
            ok, status, iters = self._solve(self.config.retry_solver)
            status = f"{self.config.retry_solver}: {status}"
        solve_ms = (time.perf_counter() - t0) * 1e3

        if ok:
            w = self._out["x"].copy()
            g = self._out["g"]
            # a reported success whose point violates constraints is not accepted
            viol = max(
                float(np.max(np.abs(g[self._eq]))),
                float(np.max(np.maximum(-g[~self._eq], 0))),
                float(np.max(np.maximum(self._lbw - w, 0))),
                float(np.max(np.maximum(w - self._ubw, 0))),
            )
            if not np.isfinite(viol) or viol > 1e-6:
                ok, status = False, f"{status} (constraint violation {viol:.2e})"
        if ok:
            self._w0 = w
            self._lam_g = self._out["lam_g"].copy()
            self._lam_x = self._out["lam_x"].copy()
            us = w[self._iu]
            self._plan_u = us[1:]
            action, fallback, plan = us[0].copy(), None, w[self._ix]
            slack = float(max(np.max(w[self._is[0]]), 0.0))
        else:
            self._w0 = self._lam_g = self._lam_x = None
            if self._plan_u is not None and len(self._plan_u) > 0:
                action, fallback = self._plan_u[0].copy(), "shifted_plan"
                self._plan_u = self._plan_u[1:]
            else:
                action, fallback = np.array([sc.a_min / 2, straighten_steer(xi0, sc)]), "brake"
            plan, slack = None, float("nan")
        action = np.clip(action, [sc.a_min, -sc.delta_max], [sc.a_max, sc.delta_max])
        self.last_report = SolveReport(
            ok, status, iters, solve_ms, fallback, action, plan, slack, retried
        )
        if return_info:
            return action, self.last_report.info()
        return action

    def predict(self, obs: ArrayLike, state=None, episode_start=None, deterministic=True):
        """stable-baselines3-style alias of :meth:`act` (returns ``(action, None)``)."""
        return self.act(obs), None
