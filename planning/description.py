"""The SMPC planner's NLP described: what is solved, not how (paper §II-A, eq. 1–4; DESIGN §3).

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
at constant velocity with the covariance of :func:`drivestyle.planning.tv_gaussian.tv_covariance`.

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


The description depends on the scenario's geometry only (T_s, l_f, l_r, l_a, l_b); the
bounds (road, speed, inputs) come per scenario from :func:`nlp_bounds`.

This module holds what every user of the planner shares: the configuration
(:class:`SMPCConfig`), the layout of w and g (:class:`NLPLayout`), the parameter vector
(:func:`nlp_parameters`, filled with :func:`constrained_vehicles`), the bounds and a
point's violation, and the primal-dual point solvers read and write (:class:`PrimalDual`).
As acados separates an OCP's description from its solver, the rest lives apart: the
CasADi symbols in :mod:`drivestyle.planning.transcription`, the solvers in
:mod:`drivestyle.planning.smpc_problem` (and the compiled :mod:`drivestyle.planning.plan_solver`),
the warm start in :mod:`drivestyle.planning.warm_starts`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.chance import risk_quantile
from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY, TVUncertainty

__all__ = [
    "NU",
    "NX",
    "N_WEIGHTS",
    "SOLVERS",
    "NLPBounds",
    "NLPLayout",
    "PrimalDual",
    "SMPCConfig",
    "constrained_vehicles",
    "constraint_violation",
    "nlp_bounds",
    "nlp_layout",
    "nlp_parameters",
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
    """TV prediction error model (drivestyle.planning.tv_gaussian)."""
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
    the receding-horizon style model (``drivestyle.irl.driver.driver_style``, DESIGN §15) learns
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


@dataclass(frozen=True, eq=False)
class PrimalDual:
    """A primal-dual point of the NLP: an initial guess or a solution."""

    w: np.ndarray
    """Variables, shape (n_w,)."""
    lam_g: np.ndarray
    """Constraint multipliers, shape (n_g,)."""
    lam_x: np.ndarray
    """Bound multipliers, shape (n_w,)."""


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
