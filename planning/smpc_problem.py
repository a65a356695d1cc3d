"""The SMPC expert's optimal-control problem as a CasADi NLP (paper §II-A, eq. 1–4; DESIGN §3).

One solve of the stochastic MPC is

    min_u  Σ_{k<N} ‖ξ_k − ξ_k^ref‖²_Q + ‖u_k‖²_R + ‖ξ_N − ξ_N^ref‖²_{Q_N}
                + Σ_{k=1…N} Σ_j ρ₁ s_kj + ρ₂ s_kj²
    s.t.   ξ_{k+1} = F(ξ_k, u_k)                      (the env's RK4 map, envs/dynamics.py)
           ξ_0 = ξ0
           ξ_k ∈ Ξ, u_k ∈ U                           (heading, speed, road, input bounds)
           g_kj(ξ_k) + s_kj ≥ 0, s_kj ≥ 0, k = 1 … N  (tangent chance constraint, chance.py)
           ‖z̄_kj‖ − 1 ≥ 0, k = 1 … N                 (nominal ellipse, hard)

for every constrained vehicle j = 1 … M, with ξ^ref_k = [x_0 + v_ref t_k, y_ref, 0, v_ref]
(the x weight is 1e-6, so x_ref only keeps that term bounded) and the vehicles predicted
at constant velocity with the covariance of :func:`drivestyle.planning.prediction.tv_covariance`.

Why the slack: the chance constraint can be infeasible from the current state — a
growing TV covariance at large p may demand more distance than the road offers — and a
hard constraint then makes every solve fail. The exact L1 penalty (ρ₁ larger than any
multiplier the hard problem needs) returns the hard solution whenever one exists and
otherwise the plan that violates the probabilistic margin least. The nominal ellipse
(p = 0.5, d_k ≥ 0) stays hard, so the closed loop keeps d_k ≥ 0 whatever p.

Layout (:class:`NLPLayout`): the variables are ordered by stage,
w = [ξ_0, u_0, ξ_1, u_1, s_1, …, ξ_{N−1}, u_{N−1}, s_{N−1}, ξ_N, s_N] (s_k holds one slack per
vehicle), and the constraints g stage by stage as fatrop's structure detection expects:
for stage k first the gap-closing ξ_{k+1} − F(ξ_k, u_k) (k < N), then the stage's path
constraints (k = 0: ξ_0 − ξ0 = 0; k ≥ 1: [g_k1 + s_k1, ‖z̄_k1‖ − 1, …, g_kM + s_kM,
‖z̄_kM‖ − 1] ≥ 0). The parameters are p = [ξ0 (4), vehicle states M × [x, y, φ, v], y_ref,
v_ref, κ] (:func:`nlp_parameters`); κ = Φ⁻¹(p) is a parameter, so one problem serves
every risk.

The problem depends on the scenario's geometry only (T_s, l_f, l_r, l_a, l_b,
:meth:`SMPCProblem.serves`); the bounds (road, speed, inputs) come per scenario from
:func:`nlp_bounds`. :class:`SMPCProblem` holds the NLP and its solvers and nothing of a
closed loop: the warm start, the previous plan and the fallbacks live in
:class:`drivestyle.agents.smpc.SMPCExpert`.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import PAPER, ScenarioConfig
from drivestyle.planning.buffered import BufferedFunction
from drivestyle.planning.chance import chance_margin, risk_quantile
from drivestyle.planning.compiled import compiled_function, source_digest
from drivestyle.planning.prediction import PAPER_TV_UNCERTAINTY, TVUncertainty, tv_covariance

__all__ = [
    "NU",
    "NX",
    "N_WEIGHTS",
    "SOLVERS",
    "NLPBounds",
    "NLPLayout",
    "NLPSolution",
    "PrimalDual",
    "SMPCConfig",
    "SMPCProblem",
    "cold_primal",
    "constrained_vehicles",
    "constraint_violation",
    "nlp_bounds",
    "nlp_layout",
    "nlp_parameters",
    "shifted_duals",
    "shifted_primal",
    "transcribe",
    "warm_start",
]

NX, NU = 4, 2
"""State [x, y, φ, v] and input [a, δ] dimensions."""
SOLVERS = ("fatrop", "ipopt")
"""CasADi NLP solvers the problem can be solved with."""


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
    """TV prediction error model (drivestyle.planning.prediction)."""
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
    compiled: bool = False
    """Solve fatrop as C generated by CasADi from this NLP, compiled once per machine and
    cached on disk (:mod:`drivestyle.planning.compiled`): the same iterates as the interpreted
    solver, ≈ 25 % faster than ``jit`` and no compilation in later processes. Falls back to
    the interpreted solver without gcc. The IPOPT retry is never compiled."""
    predicted_paths: bool = False
    """Take each constrained vehicle's predicted mean positions at stages 1 … N as
    parameters (2N per vehicle: [x_1, y_1, …, x_N, y_N], :func:`nlp_parameters`) instead of
    its state predicted at constant velocity: a planner that predicts the vehicle by another
    model — its identified style (``drivestyle.agents.aware_planner``, DESIGN §17). The
    covariance Σ_k is the same."""
    weights_as_parameters: bool = False
    """Make the cost weights w = [q_y, q_φ, q_v, r_a, r_δ] parameters of each solve
    (appended to p, :func:`nlp_parameters`), with Q_N = Q and the x weight fixed at Q[0]:
    the receding-horizon style model (``drivestyle.irl.driver_style``, DESIGN §15) learns
    them without rebuilding the NLP. False (the expert's default) keeps Q, Q_N and R as
    the constants above, so the expert's NLP is exactly the one first built."""

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


# ---------------------------------------------------------------------------- layout
@dataclass(frozen=True, eq=False)
class NLPLayout:
    """Where each stage's variables and constraints sit in w and g (module docstring)."""

    ix: np.ndarray
    """Indices of ξ_0 … ξ_N in w, shape (N+1, 4)."""
    iu: np.ndarray
    """Indices of u_0 … u_{N−1} in w, shape (N, 2)."""
    i_s: np.ndarray
    """Indices of the slacks s_1 … s_N in w, shape (N, M)."""
    ig_dyn: np.ndarray
    """Rows of ξ_{k+1} − F(ξ_k, u_k), k = 0 … N−1, in g, shape (N, 4)."""
    ig_initial: np.ndarray
    """Rows of ξ_0 − ξ0 in g, shape (4,)."""
    ig_path: np.ndarray
    """Rows of stage k = 1 … N's [g_k1 + s_k1, ‖z̄_k1‖ − 1, …] in g, shape (N, 2M)."""
    equality: np.ndarray
    """Per row of g: an equality (= 0) rather than an inequality (≥ 0), shape (n_g,)."""

    @property
    def n_w(self) -> int:
        """Number of variables, (N+1)·4 + N·2 + N·M."""
        return int(self.ix.size + self.iu.size + self.i_s.size)

    @property
    def n_g(self) -> int:
        """Number of constraints, N·4 + 4 + N·2M."""
        return int(self.equality.size)


def nlp_layout(horizon: int, n_vehicles: int) -> NLPLayout:
    """The stage-ordered layout of the NLP with N = ``horizon`` and M = ``n_vehicles``.

    Args:
        horizon: N ≥ 1.
        n_vehicles: M ≥ 1, vehicles with a chance constraint.

    Returns:
        The index arrays of :class:`NLPLayout`.
    """
    if horizon < 1 or n_vehicles < 1:
        raise ValueError(f"horizon and n_vehicles must be >= 1, got {horizon}, {n_vehicles}")
    N, M = horizon, n_vehicles
    ix, iu, i_s, ig_dyn, ig_path = [], [], [], [], []
    n_w = n_g = 0

    def take(n: int, start: int) -> tuple[np.ndarray, int]:
        return np.arange(start, start + n), start + n

    ig_initial = np.empty(0, dtype=int)
    for k in range(N + 1):
        block, n_w = take(NX, n_w)
        ix.append(block)
        if k < N:
            block, n_w = take(NU, n_w)
            iu.append(block)
        if k > 0:
            block, n_w = take(M, n_w)
            i_s.append(block)
        if k < N:
            block, n_g = take(NX, n_g)
            ig_dyn.append(block)
        if k == 0:
            ig_initial, n_g = take(NX, n_g)
        else:
            block, n_g = take(2 * M, n_g)
            ig_path.append(block)
    equality = np.zeros(n_g, dtype=bool)
    equality[np.concatenate(ig_dyn)] = True
    equality[ig_initial] = True
    return NLPLayout(
        ix=np.array(ix),
        iu=np.array(iu),
        i_s=np.array(i_s),
        ig_dyn=np.array(ig_dyn),
        ig_initial=ig_initial,
        ig_path=np.array(ig_path),
        equality=equality,
    )


N_WEIGHTS = 5
"""Cost weights of a parametric NLP: [q_y, q_φ, q_v, r_a, r_δ]."""


def nlp_parameters(
    xi0: ArrayLike,
    vehicles: ArrayLike,
    y_ref: float,
    v_ref: float,
    kappa: float,
    weights: ArrayLike | None = None,
    l_a: float | None = None,
) -> np.ndarray:
    """The parameter vector p of one solve (module docstring).

    Args:
        xi0: EV state ξ0 = [x, y, φ, v], shape (4,).
        vehicles: states of the M constrained vehicles, shape (M, 4), or for an NLP
            built with :attr:`SMPCConfig.predicted_paths` their predicted positions at
            stages 1 … N, shape (M, N, 2).
        y_ref: reference lateral position [m].
        v_ref: reference speed [m/s].
        kappa: Φ⁻¹(p), the back-off quantile.
        weights: [q_y, q_φ, q_v, r_a, r_δ] for an NLP built with
            :attr:`SMPCConfig.weights_as_parameters` (None for the expert's NLP).
        l_a: the safety region's semi-major axis [m] of such an NLP (required with
            ``weights``; the expert's NLP takes the scenario's).

    Returns:
        p, shape (4 + 4M + 3,) or (4 + 4M + 3 + 5 + 1,) with weights and l_a.
    """
    parts: list[np.ndarray] = [
        np.asarray(xi0, dtype=float),
        np.asarray(vehicles, dtype=float).ravel(),
        np.array([y_ref, v_ref, kappa], dtype=float),
    ]
    if weights is not None:
        w = np.asarray(weights, dtype=float).ravel()
        if w.shape != (N_WEIGHTS,):
            raise ValueError(f"weights must have {N_WEIGHTS} entries, got shape {w.shape}")
        if l_a is None or not (math.isfinite(l_a) and l_a > 0):
            raise ValueError(
                f"a parametric NLP takes the safety region's semi-major axis l_a > 0 [m], got "
                f"{l_a!r}"
            )
        parts += [w, np.array([l_a], dtype=float)]
    elif l_a is not None:
        raise ValueError("l_a is a parameter of the parametric (weights) NLP only")
    return np.concatenate(parts)


@dataclass(frozen=True, eq=False)
class NLPBounds:
    """Bounds of w and g for one scenario."""

    lbw: np.ndarray
    """Lower bounds of w (ξ_0 is free: the equality ξ_0 = ξ0 fixes it)."""
    ubw: np.ndarray
    """Upper bounds of w."""
    lbg: np.ndarray
    """Lower bounds of g (all 0)."""
    ubg: np.ndarray
    """Upper bounds of g (0 for equalities, +∞ for inequalities)."""


def nlp_bounds(layout: NLPLayout, scenario: ScenarioConfig) -> NLPBounds:
    """State, input and slack bounds from ``scenario``; g = 0 or g ≥ 0 from ``layout``.

    Args:
        layout: the NLP's layout.
        scenario: road (y), heading, speed and input limits.

    Returns:
        The bounds.
    """
    sc = scenario
    lbw, ubw = np.full(layout.n_w, -np.inf), np.full(layout.n_w, np.inf)
    lbw[layout.ix[1:]] = [-np.inf, sc.y_bounds[0], -sc.phi_max, 0.0]
    ubw[layout.ix[1:]] = [np.inf, sc.y_bounds[1], sc.phi_max, sc.v_max]
    lbw[layout.iu] = [sc.a_min, -sc.delta_max]
    ubw[layout.iu] = [sc.a_max, sc.delta_max]
    lbw[layout.i_s] = 0.0
    lbg = np.zeros(layout.n_g)
    ubg = np.where(layout.equality, 0.0, np.inf)
    return NLPBounds(lbw, ubw, lbg, ubg)


def constraint_violation(
    w: np.ndarray, g: np.ndarray, bounds: NLPBounds, equality: np.ndarray
) -> float:
    """Largest violation of a point's constraints and variable bounds (NaN if any is NaN).

    Args:
        w: variables.
        g: constraint values at w.
        bounds: the bounds.
        equality: per row of g, whether it is an equality (:attr:`NLPLayout.equality`).

    Returns:
        max(|g_eq|, max(−g_ineq, 0), bound excesses of w).
    """
    return max(
        float(np.max(np.abs(g[equality]))),
        float(np.max(np.maximum(-g[~equality], 0))),
        float(np.max(np.maximum(bounds.lbw - w, 0))),
        float(np.max(np.maximum(w - bounds.ubw, 0))),
    )


# ---------------------------------------------------------------------------- transcription
@dataclass(frozen=True)
class _Symbols:
    """The NLP's symbolic variables and parameters."""

    xs: list[ca.SX]
    us: list[ca.SX]
    ss: list[ca.SX]  # ss[0] unused (no constraint at ξ_0); one slack per vehicle
    P: ca.SX
    xi0: ca.SX
    vehicles: list[ca.SX]
    y_ref: ca.SX
    v_ref: ca.SX
    kappa: ca.SX
    weights: ca.SX | None  # [q_y, q_φ, q_v, r_a, r_δ] of a parametric NLP
    paths: bool = False  # vehicles are predicted paths [x_1, y_1, …, x_N, y_N]
    l_a: ca.SX | None = None  # the safety region's semi-major axis of a parametric NLP


def _symbols(N: int, M: int, parametric: bool = False, paths: bool = False) -> _Symbols:
    b = 2 * N if paths else 4  # a vehicle's block: its predicted path, or its state
    n_base = NX + b * M + 3
    P = ca.SX.sym("P", n_base + (N_WEIGHTS + 1 if parametric else 0))
    return _Symbols(
        xs=[ca.SX.sym(f"x{k}", NX) for k in range(N + 1)],
        us=[ca.SX.sym(f"u{k}", NU) for k in range(N)],
        ss=[ca.SX.sym(f"s{k}", M) for k in range(N + 1)],
        P=P,
        xi0=P[0:NX],
        vehicles=[P[NX + b * j : NX + b * j + b] for j in range(M)],
        y_ref=P[NX + b * M],
        v_ref=P[NX + b * M + 1],
        kappa=P[NX + b * M + 2],
        weights=P[n_base : n_base + N_WEIGHTS] if parametric else None,
        paths=paths,
        l_a=P[n_base + N_WEIGHTS] if parametric else None,
    )


def _dynamics(sc: ScenarioConfig) -> ca.Function:
    """F(ξ, u): one RK4 step of the env's kinematic bicycle."""
    x_sym, u_sym = ca.SX.sym("xi", NX), ca.SX.sym("u", NU)
    return ca.Function("F", [x_sym, u_sym], [rk4_step(x_sym, u_sym, sc.dt, sc.l_f, sc.l_r)])


def _reference(sym: _Symbols, k: int, dt: float) -> ca.SX:
    """ξ^ref_k = [x_0 + v_ref t_k, y_ref, 0, v_ref]."""
    return ca.vertcat(sym.xi0[0] + sym.v_ref * k * dt, sym.y_ref, 0, sym.v_ref)


def _ellipse_margins(
    x_k: ca.SX,
    vehicle: ca.SX,
    k: int,
    sigma: np.ndarray,
    sc: ScenarioConfig,
    kappa: ca.SX,
    paths: bool = False,
    l_a: ca.SX | None = None,
) -> tuple[ca.SX, ca.SX]:
    """(chance margin g_k, nominal margin ‖z̄_k‖ − 1) of the EV at ξ_k against one vehicle.

    The vehicle is predicted at constant velocity from its state ``vehicle`` (the mean of
    :func:`drivestyle.planning.prediction.tv_mean_prediction`), or, with ``paths``, ``vehicle``
    is its predicted path; covariance Σ_k. The ellipse's semi-major axis is ``l_a`` (a
    parametric NLP's parameter: the style's speed-scaled region, DESIGN §18) or the
    scenario's.
    """
    axis: float | ca.SX = sc.l_a if l_a is None else l_a
    if paths:
        dx, dy = x_k[0] - vehicle[2 * (k - 1)], x_k[1] - vehicle[2 * (k - 1) + 1]
    else:
        t_k = k * sc.dt
        dx = x_k[0] - (vehicle[0] + vehicle[3] * ca.cos(vehicle[2]) * t_k)
        dy = x_k[1] - (vehicle[1] + vehicle[3] * ca.sin(vehicle[2]) * t_k)
    chance = chance_margin(
        dx, dy, sigma[k, 0, 0], sigma[k, 0, 1], sigma[k, 1, 1], axis, sc.l_b, kappa
    )
    nominal = chance_margin(dx, dy, 0.0, 0.0, 0.0, axis, sc.l_b, 0.0)
    return chance, nominal


def _objective(cfg: SMPCConfig, sc: ScenarioConfig, sym: _Symbols) -> ca.SX:
    """Tracking cost, input cost and slack penalty (module docstring)."""
    N = cfg.horizon
    Q: np.ndarray | ca.SX
    QN: np.ndarray | ca.SX
    R: np.ndarray | ca.SX
    Q, QN, R = (np.diag(w) for w in (cfg.Q, cfg.Q_N, cfg.R))
    if sym.weights is not None:
        w = sym.weights
        Q = QN = ca.diag(ca.vertcat(cfg.Q[0], w[0], w[1], w[2]))
        R = ca.diag(w[3:5])
    # summed stage by stage (slack, then stage or terminal cost) as the NLP was first built:
    # the summation order fixes the floating-point result the solvers see
    J: ca.SX | int = 0
    for k in range(N + 1):
        e = sym.xs[k] - _reference(sym, k, sc.dt)
        if k > 0:
            J += cfg.slack_l1 * ca.sum1(sym.ss[k]) + cfg.slack_l2 * ca.sumsqr(sym.ss[k])
        if k < N:
            J += ca.mtimes([e.T, Q, e]) + ca.mtimes([sym.us[k].T, R, sym.us[k]])
        else:
            J += ca.mtimes([e.T, QN, e])
    if not isinstance(J, ca.SX):  # range(N + 1) adds at least one term: never reached
        raise ValueError(f"the SMPC objective has no terms (horizon {N})")
    return J


def _constraints(cfg: SMPCConfig, sc: ScenarioConfig, sym: _Symbols, F: ca.Function) -> list[ca.SX]:
    """The blocks of g in :func:`nlp_layout`'s order."""
    sigma = tv_covariance(cfg.uncertainty, sc.dt, cfg.horizon)
    g = []
    for k in range(cfg.horizon + 1):
        if k < cfg.horizon:
            g.append(sym.xs[k + 1] - F(sym.xs[k], sym.us[k]))
        if k == 0:
            g.append(sym.xs[0] - sym.xi0)
            continue
        rows = []
        for j, vehicle in enumerate(sym.vehicles):
            chance, nominal = _ellipse_margins(
                sym.xs[k], vehicle, k, sigma, sc, sym.kappa, sym.paths, sym.l_a
            )
            rows += [chance + sym.ss[k][j], nominal]
        g.append(ca.vertcat(*rows))
    return g


def _variables(sym: _Symbols) -> list[ca.SX]:
    """The blocks of w in :func:`nlp_layout`'s order: per stage [ξ_k, u_k, s_k]."""
    N = len(sym.us)
    w = []
    for k in range(N + 1):
        w.append(sym.xs[k])
        if k < N:
            w.append(sym.us[k])
        if k > 0:
            w.append(sym.ss[k])
    return w


def transcribe(config: SMPCConfig, scenario: ScenarioConfig) -> tuple[dict, ca.Function]:
    """The NLP of one SMPC solve (module docstring).

    Args:
        config: horizon, weights, slack penalty, uncertainty and M (the risk is not used:
            κ is a parameter).
        scenario: geometry (T_s, l_f, l_r, l_a, l_b).

    Returns:
        CasADi's NLP dict ``{"x": w, "f": J, "g": g, "p": p}`` (layout: :func:`nlp_layout`)
        and the discrete dynamics F(ξ, u).
    """
    sym = _symbols(
        config.horizon, config.max_vehicles, config.weights_as_parameters, config.predicted_paths
    )
    F = _dynamics(scenario)
    nlp = {
        "x": ca.vertcat(*_variables(sym)),
        "f": _objective(config, scenario, sym),
        "g": ca.vertcat(*_constraints(config, scenario, sym, F)),
        "p": sym.P,
    }
    return nlp, F


# ---------------------------------------------------------------------------- solvers
def solver_options(name: str, config: SMPCConfig, equality: np.ndarray) -> dict:
    """CasADi ``nlpsol`` options of solver ``name`` for this NLP.

    Args:
        name: 'fatrop' or 'ipopt'.
        config: iteration cap, tolerance, initial barrier parameter, jit.
        equality: per row of g, whether it is an equality (fatrop needs it).

    Returns:
        The options dict.
    """
    if name not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {name!r}")
    common: dict = {"expand": True, "print_time": False}
    if config.jit:
        # compile the NLP's derivative functions with the system C compiler
        common |= {
            "jit": True,
            "compiler": "shell",
            "jit_options": {"flags": ["-O2"], "verbose": False},
        }
    if name == "fatrop":
        return common | {
            "structure_detection": "auto",
            "equality": equality.tolist(),
            "fatrop": {
                "print_level": 0,
                "max_iter": config.max_iter,
                "tol": config.tol,
                "mu_init": config.mu_init,
            },
        }
    return common | {
        "ipopt": {
            "print_level": 0,
            "sb": "yes",
            "max_iter": config.max_iter,
            "tol": config.tol,
            "mu_init": config.mu_init,
            # the guess is the shifted previous solution: keep it (and its multipliers)
            "warm_start_init_point": "yes",
            "warm_start_bound_push": 1e-6,
            "warm_start_mult_bound_push": 1e-6,
        },
    }


@dataclass(frozen=True, eq=False)
class PrimalDual:
    """A primal-dual point of the NLP: an initial guess or a solution."""

    w: np.ndarray
    """Variables, shape (n_w,)."""
    lam_g: np.ndarray
    """Constraint multipliers, shape (n_g,)."""
    lam_x: np.ndarray
    """Bound multipliers, shape (n_w,)."""


@dataclass(frozen=True, eq=False)
class NLPSolution:
    """What one solver call returned (copies; the solver's buffers are reused)."""

    solver: str
    """The solver that ran."""
    success: bool
    """The solver reported success."""
    status: str
    """Solver return status (``'error: …'`` when CasADi raised)."""
    iterations: int
    """Solver iterations (−1 when CasADi raised)."""
    point: PrimalDual
    """The returned primal-dual point."""
    g: np.ndarray
    """Constraint values at ``point.w``."""


class SMPCProblem:
    """The SMPC NLP of one configuration and scenario geometry, and its solvers.

    Example:
        >>> problem = SMPCProblem(SMPCConfig(), PAPER)
        >>> p = nlp_parameters(xi0, tv[None], PAPER.y_ref, PAPER.v_ref, 0.52)
        >>> sol = problem.solve("fatrop", p, guess, problem.bounds(PAPER))

    Pure transcription: no state carries over from one solve to the next. The solver
    reads and writes numpy buffers in place (zero-copy calls save ≈0.2 ms of
    numpy↔DM conversion per solve); :meth:`solve` fills them from its arguments and
    returns copies.
    """

    def __init__(self, config: SMPCConfig | None = None, scenario: ScenarioConfig = PAPER):
        """Transcribe the NLP and build the primary solver ``config.solver``.

        Args:
            config: SMPC parameters (the risk is not used: κ is a parameter of each solve).
            scenario: the geometry the NLP is built for.
        """
        self.config = config or SMPCConfig()
        self.scenario = scenario
        self.layout = nlp_layout(self.config.horizon, self.config.max_vehicles)
        self.nlp, self.dynamics = transcribe(self.config, scenario)
        self._external: set[str] = set()
        self._kkt: BufferedFunction | None = None
        self._step = BufferedFunction(self.dynamics)
        primary = self._make_solver(self.config.solver)
        self._inputs = {n: np.zeros(primary.nnz_in(n)) for n in primary.name_in()}
        self._outputs = {n: np.zeros(primary.nnz_out(n)) for n in primary.name_out()}
        # further solvers (the retry) are built on first use and share the buffers
        self._calls: dict[str, tuple] = {self.config.solver: self._bind(primary)}

    @property
    def n_p(self) -> int:
        """Number of parameters, 4 + 4M + 3 (+ 5 weights if parametric)."""
        return int(self.nlp["p"].numel())

    def serves(self, scenario: ScenarioConfig) -> bool:
        """Whether this NLP is the one of ``scenario`` (same T_s, l_f, l_r and ellipse)."""
        given = self.config.weights_as_parameters
        return _geometry_key(scenario, given) == _geometry_key(self.scenario, given)

    def bounds(self, scenario: ScenarioConfig) -> NLPBounds:
        """:func:`nlp_bounds` of ``scenario`` for this layout."""
        return nlp_bounds(self.layout, scenario)

    def solve(
        self, solver: str, p: np.ndarray, guess: PrimalDual, bounds: NLPBounds
    ) -> NLPSolution:
        """Solve the NLP once with ``solver`` from ``guess``.

        Args:
            solver: 'fatrop' or 'ipopt' (built on first use).
            p: parameters (:func:`nlp_parameters`).
            guess: initial primal-dual point.
            bounds: variable and constraint bounds.

        Returns:
            The solver's point and status; a CasADi error (NaN evaluation, solver
            exception) is a failed solution, not an exception.

        Raises:
            ValueError: ``p`` or the guess has a NaN or inf entry (fatrop does not return
                from a NaN initial guess).
        """
        for name, value in (("p", p), ("guess.w", guess.w), ("guess.lam_g", guess.lam_g),
                            ("guess.lam_x", guess.lam_x)):  # fmt: skip
            if not np.all(np.isfinite(value)):
                raise ValueError(f"SMPC problem input {name} contains NaN or inf")
        buffer, evaluate = self._solver_call(solver)
        for name, value in (
            ("p", p), ("x0", guess.w), ("lam_g0", guess.lam_g), ("lam_x0", guess.lam_x),
            ("lbx", bounds.lbw), ("ubx", bounds.ubw), ("lbg", bounds.lbg), ("ubg", bounds.ubg),
        ):  # fmt: skip
            self._inputs[name][:] = value
        try:
            evaluate()
            if solver in self._external:  # the generated solver has no stats
                out = self._outputs
                success = self._stationary(out["x"], out["lam_g"], out["lam_x"])
                status = "Solve_Succeeded" if success else "not stationary"
                iterations = -1
            else:
                stats = buffer.stats()
                success = bool(stats.get("success", False))
                status = str(stats.get("return_status", "unknown"))
                iterations = int(stats.get("iter_count", -1))
        except RuntimeError as exc:  # CasADi raises on NaN evaluations, solver errors, ...
            success, status, iterations = False, f"error: {exc}".splitlines()[0], -1
        out = self._outputs
        point = PrimalDual(out["x"].copy(), out["lam_g"].copy(), out["lam_x"].copy())
        return NLPSolution(solver, success, status, iterations, point, out["g"].copy())

    def step(self, xi: np.ndarray, u: np.ndarray) -> np.ndarray:
        """F(ξ, u), one RK4 step, through bound buffers.

        :attr:`dynamics`' result to the bit, without its numpy↔DM conversions (≈ 60 µs of
        every warm start's shift).
        """
        return self._step(xi, u)[0]

    def _stationary(self, w: np.ndarray, lam_g: np.ndarray, lam_x: np.ndarray) -> bool:
        """Whether a generated solver's point is a KKT point to fatrop's tolerance.

        ‖∇f + J_gᵀλ_g + λ_x‖∞ ≤ 10·tol·s_d, with IPOPT's scaling s_d = max(1, mean |λ| / 100)
        (the slack penalty puts multipliers at ≈ 1e4); feasibility is the caller's check.
        """
        if self._kkt is None:
            x, p = self.nlp["x"], self.nlp["p"]
            lg, lx = ca.SX.sym("lg", self.layout.n_g), ca.SX.sym("lx", self.layout.n_w)
            lagrangian = self.nlp["f"] + ca.dot(lg, self.nlp["g"]) + ca.dot(lx, x)
            # bound buffers: a plain call converted four inputs and the result to DM on
            # every solve, ≈ a fifth of a tracker update's solve time
            self._kkt = BufferedFunction(
                ca.Function("kkt", [x, p, lg, lx], [ca.gradient(lagrangian, x)])
            )
        (grad,) = self._kkt.evaluate(w, self._inputs["p"], lam_g, lam_x)
        scale = max(1.0, float(np.mean(np.abs(np.concatenate([lam_g, lam_x])))) / 100.0)
        return bool(
            np.all(np.isfinite(grad)) and np.max(np.abs(grad)) <= 10 * self.config.tol * scale
        )

    def _make_solver(self, name: str) -> ca.Function:
        options = solver_options(name, self.config, self.layout.equality)
        if self.config.compiled and name == "fatrop":
            plain = {
                k: v for k, v in options.items() if k not in ("jit", "compiler", "jit_options")
            }
            # the generated solver has no stats(): a failure must raise instead
            compiled = compiled_function(
                "ds_smpc_fatrop",
                _compiled_key(self.config, self.scenario),
                lambda: ca.nlpsol("ds_smpc_fatrop", "fatrop", self.nlp, plain),
                link_casadi=True,
            )
            if compiled is not None:
                self._external.add(name)
                return compiled
        if not self.config.jit:
            return ca.nlpsol(f"smpc_{name}", name, self.nlp, options)
        # CasADi writes the generated C (and leaves it) in the working directory: build in
        # a folder of its own under the temp folder, never in the user's cwd
        cwd = os.getcwd()
        os.chdir(tempfile.mkdtemp(prefix="drivestyle_jit_"))
        try:
            return ca.nlpsol(f"smpc_{name}", name, self.nlp, options)
        finally:
            os.chdir(cwd)

    def _solver_call(self, name: str) -> tuple:
        if name not in self._calls:
            self._calls[name] = self._bind(self._make_solver(name))
        return self._calls[name]

    def _bind(self, solver: ca.Function) -> tuple:
        """(buffer, evaluate) of ``solver`` reading and writing the shared numpy buffers."""
        buffer, evaluate = solver.buffer()
        # .data: the arrays' memoryviews (numpy's stubs give ndarray no __buffer__ before
        # Python 3.12). casadi's stub also lists the byte size, which its SWIG wrapper reads
        # from the buffer itself and refuses as a third argument.
        for i, n in enumerate(solver.name_in()):
            buffer.set_arg(i, self._inputs[n].data)  # type: ignore[call-arg]
        for i, n in enumerate(solver.name_out()):
            buffer.set_res(i, self._outputs[n].data)  # type: ignore[call-arg]
        return buffer, evaluate


# ---------------------------------------------------------------------------- vehicles
def constrained_vehicles(
    xi0: np.ndarray, others: np.ndarray, n_vehicles: int, vehicle_range: float
) -> np.ndarray:
    """The M vehicles an NLP constrains, nearest first, padded with placeholders.

    A placeholder stands 10 km behind the EV: its margins are huge and never bind.

    Args:
        xi0: the EV's state [x, y, φ, v].
        others: the surrounding vehicles' states, shape (m, 4).
        n_vehicles: M, the NLP's vehicle slots.
        vehicle_range: vehicles farther than this (centre distance) are left out [m]; a
            single vehicle with M = 1 (the paper's TV) is always constrained.

    Returns:
        Shape (M, 4).
    """
    M = n_vehicles
    dist = np.hypot(others[:, 0] - xi0[0], others[:, 1] - xi0[1]) if len(others) else []
    order = [j for j in np.argsort(dist, kind="stable") if dist[j] <= vehicle_range]
    if M == 1 and len(others) == 1:
        order = [0]  # the paper's TV is always constrained, however far
    chosen = [others[j] for j in order[:M]]
    chosen += [np.array([xi0[0] - 1e4, xi0[1], 0.0, 0.0])] * (M - len(chosen))
    return np.array(chosen)


# ---------------------------------------------------------------------------- warm starts
def cold_primal(layout: NLPLayout, xi0: np.ndarray, scenario: ScenarioConfig) -> np.ndarray:
    """A zero-input rollout from ξ0 as initial guess (inputs and slacks 0).

    Args:
        layout: the NLP's layout.
        xi0: the plan's first state [x, y, φ, v].
        scenario: T_s and the wheelbase of the rollout.

    Returns:
        w, shape (n_w,).
    """
    N = layout.iu.shape[0]
    xs = np.empty((N + 1, NX))
    xs[0] = xi0
    for k in range(N):
        xs[k + 1] = rk4_step(xs[k], np.zeros(NU), scenario.dt, scenario.l_f, scenario.l_r)
    w = np.zeros(layout.n_w)
    w[layout.ix] = xs
    return w


def shifted_primal(
    layout: NLPLayout,
    previous: np.ndarray,
    xi0: np.ndarray,
    dynamics: Callable[[np.ndarray, np.ndarray], Any],
) -> np.ndarray:
    """The previous solution shifted by one stage: the last input repeated, ξ_0 set to ξ0.

    Args:
        layout: the NLP's layout.
        previous: the previous step's solution w.
        xi0: the new first state.
        dynamics: F(ξ, u), to extend the plan by one stage.

    Returns:
        w, shape (n_w,).
    """
    ix, iu, i_s = layout.ix, layout.iu, layout.i_s
    xs, us = previous[ix], previous[iu]
    x_tail = np.asarray(dynamics(xs[-1], us[-1])).ravel()
    w = np.zeros(layout.n_w)
    w[ix] = np.vstack([xs[1:], x_tail])
    w[iu] = np.vstack([us[1:], us[-1:]])
    w[i_s] = np.vstack([previous[i_s][1:], previous[i_s][-1:]])
    w[ix[0]] = xi0
    return w


def shifted_duals(layout: NLPLayout, previous: PrimalDual) -> tuple[np.ndarray, np.ndarray]:
    """Multipliers of ``previous`` shifted by one stage (last stage repeated).

    Args:
        layout: the NLP's layout.
        previous: the previous step's primal-dual solution.

    Returns:
        (λ_g, λ_x) of the shifted guess.
    """
    N = layout.iu.shape[0]
    lg, lx = previous.lam_g, previous.lam_x
    new_g, new_x = lg.copy(), lx.copy()
    nxt = np.minimum(np.arange(N) + 1, N - 1)
    new_g[layout.ig_dyn] = lg[layout.ig_dyn[nxt]]
    new_g[layout.ig_path[:-1]] = lg[layout.ig_path[1:]]
    new_x[layout.ix[1:-1]] = lx[layout.ix[2:]]
    new_x[layout.iu] = lx[layout.iu[nxt]]
    new_x[layout.i_s[:-1]] = lx[layout.i_s[1:]]
    return new_g, new_x


def warm_start(
    problem: SMPCProblem, xi0: np.ndarray, previous: PrimalDual | None, scenario: ScenarioConfig
) -> PrimalDual:
    """The next solve's initial guess: the previous solution shifted, or a cold start.

    ``previous`` is shifted by one stage (primal and dual); without one, a zero-input
    rollout from ξ0 with zero multipliers.

    Args:
        problem: the NLP (layout and dynamics).
        xi0: the new first state.
        previous: the last accepted solution, or None (cold start).
        scenario: T_s and wheelbase of the cold rollout.

    Returns:
        The guess.
    """
    layout = problem.layout
    if previous is None:
        zeros = np.zeros(layout.n_g), np.zeros(layout.n_w)
        return PrimalDual(cold_primal(layout, xi0, scenario), *zeros)
    lam_g, lam_x = shifted_duals(layout, previous)
    return PrimalDual(shifted_primal(layout, previous.w, xi0, problem.step), lam_g, lam_x)


def _compiled_key(config: SMPCConfig, scenario: ScenarioConfig) -> str:
    """Digest of everything the generated fatrop solver depends on."""
    c = config
    fields = (c.horizon, c.max_vehicles, c.weights_as_parameters, c.predicted_paths,
              c.Q, c.Q_N, c.R, c.uncertainty, c.max_iter, c.tol, c.mu_init, c.slack_l1,
              c.slack_l2,
              _geometry_key(scenario, c.weights_as_parameters))  # fmt: skip
    digest = source_digest([
        "drivestyle.envs.dynamics", "drivestyle.planning.chance", "drivestyle.planning.compiled",
        "drivestyle.planning.prediction", "drivestyle.planning.smpc_problem",
    ])  # fmt: skip
    return hashlib.sha256((repr(fields) + digest).encode()).hexdigest()


def _geometry_key(sc: ScenarioConfig, l_a_given: bool = False) -> tuple:
    """What an NLP depends on of the scenario (l_a not, when it is a parameter)."""
    return (sc.dt, sc.l_f, sc.l_r, None if l_a_given else sc.l_a, sc.l_b)
