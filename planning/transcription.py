"""The SMPC planner's NLP transcribed into CasADi symbols (DESIGN §3).

:func:`transcribe` turns the description of :mod:`drivestyle.planning.description` (its
configuration and a scenario's geometry) into CasADi's NLP dict: the variables w stage by
stage, the objective (tracking, input cost, slack penalty) and the constraints g in
:func:`~drivestyle.planning.description.nlp_layout`'s order, with the discrete dynamics F.
Its pieces — the symbols (:func:`nlp_symbols`), F (:func:`discrete_dynamics`) and a
vehicle's chance and nominal margins (:func:`ellipse_margins`) — are shared with the
compiled Newton step (:mod:`drivestyle.planning.plan_solver`), so both solve one NLP.
Solving it is :mod:`drivestyle.planning.smpc_problem`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.chance import chance_margin
from drivestyle.planning.description import N_WEIGHTS, NU, NX, SMPCConfig
from drivestyle.planning.tv_gaussian import tv_covariance

__all__ = [
    "NLPSymbols",
    "discrete_dynamics",
    "ellipse_margins",
    "geometry_key",
    "nlp_symbols",
    "transcribe",
]


@dataclass(frozen=True)
class NLPSymbols:
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


def nlp_symbols(N: int, M: int, parametric: bool = False, paths: bool = False) -> NLPSymbols:
    """The symbols of the NLP with N stages and M vehicles.

    The parameter vector ``P`` is ordered as
    :func:`~drivestyle.planning.description.nlp_parameters` fills it.

    Args:
        N: horizon.
        M: constrained vehicles.
        parametric: the cost weights and l_a are parameters
            (:attr:`~drivestyle.planning.description.SMPCConfig.weights_as_parameters`).
        paths: each vehicle is given as its predicted path
            (:attr:`~drivestyle.planning.description.SMPCConfig.predicted_paths`).

    Returns:
        The symbols; their parameter vector is ``P``.
    """
    b = 2 * N if paths else 4  # a vehicle's block: its predicted path, or its state
    n_base = NX + b * M + 3
    P = ca.SX.sym("P", n_base + (N_WEIGHTS + 1 if parametric else 0))
    return NLPSymbols(
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


def discrete_dynamics(sc: ScenarioConfig) -> ca.Function:
    """F(ξ, u): one RK4 step of the env's kinematic bicycle."""
    x_sym, u_sym = ca.SX.sym("xi", NX), ca.SX.sym("u", NU)
    return ca.Function("F", [x_sym, u_sym], [rk4_step(x_sym, u_sym, sc.dt, sc.l_f, sc.l_r)])


def _reference(sym: NLPSymbols, k: int, dt: float) -> ca.SX:
    """ξ^ref_k = [x_0 + v_ref t_k, y_ref, 0, v_ref]."""
    return ca.vertcat(sym.xi0[0] + sym.v_ref * k * dt, sym.y_ref, 0, sym.v_ref)


def ellipse_margins(
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
    :func:`drivestyle.planning.tv_gaussian.tv_mean_prediction`), or, with ``paths``, ``vehicle``
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


def _objective(cfg: SMPCConfig, sc: ScenarioConfig, sym: NLPSymbols) -> ca.SX:
    """Tracking cost, input cost and slack penalty (:mod:`drivestyle.planning.description`)."""
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


def _constraints(
    cfg: SMPCConfig, sc: ScenarioConfig, sym: NLPSymbols, F: ca.Function
) -> list[ca.SX]:
    """The blocks of g in :func:`~drivestyle.planning.description.nlp_layout`'s order."""
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
            chance, nominal = ellipse_margins(
                sym.xs[k], vehicle, k, sigma, sc, sym.kappa, sym.paths, sym.l_a
            )
            rows += [chance + sym.ss[k][j], nominal]
        g.append(ca.vertcat(*rows))
    return g


def _variables(sym: NLPSymbols) -> list[ca.SX]:
    """The blocks of w in the layout's order: per stage [ξ_k, u_k, s_k].

    The layout is :func:`~drivestyle.planning.description.nlp_layout`'s.
    """
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
    """The NLP of one SMPC solve (its formulation: :mod:`drivestyle.planning.description`).

    Args:
        config: horizon, weights, slack penalty, uncertainty and M (the risk is not used:
            κ is a parameter).
        scenario: geometry (T_s, l_f, l_r, l_a, l_b).

    Returns:
        CasADi's NLP dict ``{"x": w, "f": J, "g": g, "p": p}`` (layout:
        :func:`~drivestyle.planning.description.nlp_layout`) and the discrete dynamics F(ξ, u).
    """
    sym = nlp_symbols(
        config.horizon, config.max_vehicles, config.weights_as_parameters, config.predicted_paths
    )
    F = discrete_dynamics(scenario)
    nlp = {
        "x": ca.vertcat(*_variables(sym)),
        "f": _objective(config, scenario, sym),
        "g": ca.vertcat(*_constraints(config, scenario, sym, F)),
        "p": sym.P,
    }
    return nlp, F


def geometry_key(sc: ScenarioConfig, l_a_given: bool = False) -> tuple:
    """What an NLP depends on of the scenario (l_a not, when it is a parameter)."""
    return (sc.dt, sc.l_f, sc.l_r, None if l_a_given else sc.l_a, sc.l_b)
