import dataclasses

import casadi as ca
import numpy as np
import pytest

from drivestyle.agents import smpc
from drivestyle.envs import PAPER
from drivestyle.envs.dynamics import rk4_step
from drivestyle.planning import smpc_problem
from drivestyle.planning.chance import chance_margin
from drivestyle.planning.description import (
    NU,
    NX,
    PrimalDual,
    SMPCConfig,
    nlp_bounds,
    nlp_layout,
    nlp_parameters,
)
from drivestyle.planning.smpc_problem import SMPCProblem
from drivestyle.planning.tv_gaussian import tv_covariance


@pytest.fixture(scope="module")
def problem():
    return SMPCProblem(SMPCConfig(max_vehicles=2), PAPER)


def _evaluate(problem: SMPCProblem, w: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, float]:
    nlp = problem.nlp
    gf = ca.Function("gf", [nlp["x"], nlp["p"]], [nlp["g"], nlp["f"]])
    g, f = gf(w, p)
    return np.asarray(g).ravel(), float(f)


def _rollout(xi0: np.ndarray, us: np.ndarray) -> np.ndarray:
    xs = [xi0]
    for u in us:
        xs.append(rk4_step(xs[-1], u, PAPER.dt, PAPER.l_f, PAPER.l_r))
    return np.array(xs)


@pytest.mark.parametrize("N, M", [(10, 1), (4, 3), (1, 2)])
def test_dimensions_are_as_documented(N, M):
    layout = nlp_layout(N, M)
    assert layout.ix.shape == (N + 1, NX) and layout.iu.shape == (N, NU)
    assert layout.i_s.shape == (N, M) and layout.ig_dyn.shape == (N, NX)
    assert layout.ig_initial.shape == (NX,) and layout.ig_path.shape == (N, 2 * M)
    assert layout.n_w == (N + 1) * NX + N * NU + N * M
    assert layout.n_g == N * NX + NX + N * 2 * M
    # every variable and every constraint row has exactly one place
    w_idx = np.concatenate([layout.ix.ravel(), layout.iu.ravel(), layout.i_s.ravel()])
    g_idx = np.concatenate([layout.ig_dyn.ravel(), layout.ig_initial, layout.ig_path.ravel()])
    np.testing.assert_array_equal(np.sort(w_idx), np.arange(layout.n_w))
    np.testing.assert_array_equal(np.sort(g_idx), np.arange(layout.n_g))
    # stage order [ξ_0, u_0, ξ_1, u_1, s_1, …, ξ_N, s_N] (fatrop's structure detection)
    assert layout.iu[0, 0] == NX and layout.ix[1, 0] == NX + NU
    assert layout.i_s[-1, -1] == layout.n_w - 1
    assert layout.equality.sum() == N * NX + NX
    problem = SMPCProblem(SMPCConfig(horizon=N, max_vehicles=M), PAPER)
    assert problem.nlp["x"].numel() == layout.n_w == problem.layout.n_w
    assert problem.nlp["g"].numel() == layout.n_g
    assert problem.n_p == NX + 4 * M + 3


def test_dynamics_constraints_hold_for_an_rk4_rollout(problem):
    rng = np.random.default_rng(0)
    layout, N = problem.layout, problem.config.horizon
    xi0 = np.array([10.0, 1.8, 0.01, 28.0])
    us = rng.uniform([-3, -0.05], [2, 0.05], size=(N, NU))
    w = np.zeros(layout.n_w)
    w[layout.ix], w[layout.iu] = _rollout(xi0, us), us
    p = nlp_parameters(xi0, [[60.0, 5.4, 0.0, 25.0], [-40, 1.8, 0, 30]], 5.4, 30.0, 0.5)
    g, _ = _evaluate(problem, w, p)
    np.testing.assert_allclose(g[layout.ig_dyn], 0.0, atol=1e-10)
    np.testing.assert_allclose(g[layout.ig_initial], 0.0, atol=0)
    # a state off the rollout breaks exactly the two gap-closing rows around it
    w[layout.ix[3, 1]] += 0.1
    g, _ = _evaluate(problem, w, p)
    broken = np.flatnonzero(np.abs(g[layout.ig_dyn]).max(axis=1) > 1e-3)
    np.testing.assert_array_equal(broken, [2, 3])


def test_path_rows_are_the_chance_and_nominal_margins(problem):
    layout, N, sc = problem.layout, problem.config.horizon, PAPER
    xi0 = np.array([0.0, 1.8, 0.0, 30.0])
    us = np.zeros((N, NU))
    w = np.zeros(layout.n_w)
    w[layout.ix], w[layout.iu] = _rollout(xi0, us), us
    w[layout.i_s] = 0.25
    tvs = np.array([[40.0, 5.4, 0.02, 25.0], [-30.0, 1.8, 0.0, 31.0]])
    kappa = 0.8
    g, _ = _evaluate(problem, w, nlp_parameters(xi0, tvs, sc.y_ref, sc.v_ref, kappa))
    sigma = tv_covariance(problem.config.uncertainty, sc.dt, N)
    xs = w[layout.ix]
    for k in range(1, N + 1):
        t = k * sc.dt
        for j, tv in enumerate(tvs):
            dx = xs[k, 0] - (tv[0] + tv[3] * np.cos(tv[2]) * t)
            dy = xs[k, 1] - (tv[1] + tv[3] * np.sin(tv[2]) * t)
            s = sigma[k]
            chance = chance_margin(dx, dy, s[0, 0], s[0, 1], s[1, 1], sc.l_a, sc.l_b, kappa)
            nominal = np.hypot(dx / sc.l_a, dy / sc.l_b) - 1
            rows = g[layout.ig_path[k - 1]]
            assert rows[2 * j] == pytest.approx(chance + 0.25, rel=1e-12)
            assert rows[2 * j + 1] == pytest.approx(nominal, rel=1e-12)


def test_objective_is_zero_on_the_reference_and_penalises_slack(problem):
    layout, N, sc, cfg = problem.layout, problem.config.horizon, PAPER, problem.config
    xi0 = np.array([12.0, sc.y_ref, 0.0, sc.v_ref])
    w = np.zeros(layout.n_w)
    w[layout.ix] = [[xi0[0] + sc.v_ref * k * sc.dt, sc.y_ref, 0, sc.v_ref] for k in range(N + 1)]
    p = nlp_parameters(xi0, np.zeros((2, 4)), sc.y_ref, sc.v_ref, 0.5)
    _, f = _evaluate(problem, w, p)
    assert f == pytest.approx(0.0, abs=1e-12)
    w[layout.i_s[4, 1]] = 2.0
    w[layout.iu[0]] = [1.0, 0.1]
    _, f = _evaluate(problem, w, p)
    expected = cfg.slack_l1 * 2 + cfg.slack_l2 * 4 + cfg.R[0] * 1 + cfg.R[1] * 0.01
    assert f == pytest.approx(expected, rel=1e-12)


def test_bounds_free_the_initial_state_and_keep_slacks_nonnegative(problem):
    layout = problem.layout
    b = nlp_bounds(layout, PAPER)
    assert np.all(np.isinf(b.lbw[layout.ix[0]])) and np.all(np.isinf(b.ubw[layout.ix[0]]))
    assert np.all(b.lbw[layout.i_s] == 0) and np.all(np.isinf(b.ubw[layout.i_s]))
    np.testing.assert_array_equal(
        b.lbw[layout.iu], np.tile([PAPER.a_min, -PAPER.delta_max], (10, 1))
    )
    assert np.all(b.ubg[layout.equality] == 0) and np.all(np.isinf(b.ubg[~layout.equality]))
    assert np.all(b.lbg == 0)


def test_a_cold_solve_gives_the_experts_first_action_and_keeps_no_state():
    sc, cfg = PAPER, SMPCConfig()
    problem = SMPCProblem(cfg, sc)
    layout = problem.layout
    xi0, tv = sc.ev_initial_state, sc.tv_initial_state
    w = np.zeros(layout.n_w)
    w[layout.ix] = _rollout(xi0, np.zeros((cfg.horizon, NU)))
    guess = PrimalDual(w, np.zeros(layout.n_g), np.zeros(layout.n_w))
    p = nlp_parameters(xi0, tv[None], sc.y_ref, sc.v_ref, cfg.kappa)
    first = problem.solve("fatrop", p, guess, problem.bounds(sc))
    assert first.success and first.solver == "fatrop" and first.iterations > 0
    kept = first.point.w.copy()
    u0 = first.point.w[layout.iu[0]]
    np.testing.assert_array_equal(u0, smpc.SMPCExpert(cfg, sc).act(np.concatenate([xi0, tv])))
    # another solve (other parameters) neither changes the first result nor depends on it
    problem.solve(
        "fatrop", nlp_parameters(xi0, tv[None], 1.8, 25.0, 1.5), guess, problem.bounds(sc)
    )
    np.testing.assert_array_equal(first.point.w, kept)
    again = problem.solve("fatrop", p, guess, problem.bounds(sc))
    np.testing.assert_array_equal(again.point.w, kept)
    # the retry solver is built on first use and solves the same NLP
    retry = problem.solve("ipopt", p, guess, problem.bounds(sc))
    np.testing.assert_allclose(retry.point.w[layout.iu[0]], u0, atol=1e-5)


def test_a_failed_solve_is_a_result_and_a_nan_guess_an_error():
    starved = SMPCProblem(SMPCConfig(max_iter=1), PAPER)
    layout = starved.layout
    w = np.zeros(layout.n_w)
    w[layout.ix] = _rollout(PAPER.ev_initial_state, np.zeros((10, NU)))
    guess = PrimalDual(w, np.zeros(layout.n_g), np.zeros(layout.n_w))
    p = nlp_parameters(PAPER.ev_initial_state, PAPER.tv_initial_state[None], 5.4, 30.0, 0.5)
    for solver in ("fatrop", "ipopt"):
        sol = starved.solve(solver, p, guess, starved.bounds(PAPER))
        assert not sol.success and sol.solver == solver and 0 < sol.iterations <= 2
    # fatrop never returns from a NaN initial guess: refused before the call
    nan_guess = dataclasses.replace(guess, w=np.where(np.arange(layout.n_w) == 3, np.nan, w))
    with pytest.raises(ValueError, match=r"guess\.w contains NaN or inf"):
        starved.solve("fatrop", p, nan_guess, starved.bounds(PAPER))
    with pytest.raises(ValueError, match="p contains NaN or inf"):
        starved.solve("fatrop", p * np.nan, guess, starved.bounds(PAPER))


def test_serves_only_the_same_geometry(problem):
    assert problem.serves(dataclasses.replace(PAPER, v_ref=25.0))
    assert not problem.serves(dataclasses.replace(PAPER, dt=0.1))


def test_bad_solver_name_is_rejected(problem):
    with pytest.raises(ValueError, match="solver must be one of"):
        smpc_problem.solver_options("snopt", problem.config, problem.layout.equality)
