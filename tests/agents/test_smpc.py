import dataclasses

import numpy as np
import pytest
from drivestyle.agents import InfeasibleStartError, SMPCConfig, SMPCExpert, generate_demonstration
from drivestyle.agents.smpc import straighten_steer
from drivestyle.envs import PAPER, LaneChangeEnv
from drivestyle.envs.safety import ellipse_constraint, elliptical_index


@pytest.fixture(scope="module")
def paper_demo():
    return generate_demonstration(0.7, "paper")


def test_paper_demo_is_safe_feasible_and_ends_in_centre_lane(paper_demo):
    demo, summary = paper_demo
    sc = PAPER
    d_k = ellipse_constraint(
        demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], sc.l_a, sc.l_b
    )
    assert d_k.min() >= 0 and summary["min_d_k"] >= 0
    assert not summary["collision"] and summary["n_solver_failures"] == 0
    tol = 1e-6
    a, delta = demo.u[:, 0], demo.u[:, 1]
    assert a.min() >= sc.a_min - tol and a.max() <= sc.a_max + tol
    assert np.abs(delta).max() <= sc.delta_max + tol
    assert np.abs(demo.ev[:, 2]).max() <= sc.phi_max + tol
    assert demo.ev[:, 3].min() >= -tol and demo.ev[:, 3].max() <= sc.v_max + tol
    assert demo.ev[:, 1].min() >= sc.y_bounds[0] - tol
    assert demo.ev[:, 1].max() <= sc.y_bounds[1] + tol
    assert summary["final_lane"] == 1
    assert abs(demo.ev[-1, 1] - sc.y_ref) < 0.5
    assert demo.n == 31 and demo.u.shape == (30, 2)


def test_closed_loop_follows_prediction(paper_demo):
    # the env and the SMPC share one discrete map: replaying the inputs reproduces the states
    demo, _ = paper_demo
    env = LaneChangeEnv()
    env.reset(seed=0)
    for k, u in enumerate(demo.u):
        obs, *_ = env.step(u)
        np.testing.assert_allclose(obs[:4], demo.ev[k + 1], atol=1e-12)


def test_larger_risk_is_more_conservative():
    # documented measure: the minimum elliptical index (distance kept from the TV)
    mins = {}
    for p in (0.5, 0.7, 0.95):
        _, summary = generate_demonstration(p, "paper")
        # the softened chance constraint keeps every solve feasible: no fallbacks
        assert summary["min_d_k"] >= 0 and not summary["collision"]
        assert summary["n_solver_failures"] == 0 and summary["final_lane"] == 1
        mins[p] = summary["min_s_e"]
    assert mins[0.5] < mins[0.7] < mins[0.95]
    assert mins[0.95] - mins[0.5] > 0.5


def test_deterministic():
    a, _ = generate_demonstration(0.7, "paper", seed=3)
    b, _ = generate_demonstration(0.7, "paper", seed=3)
    np.testing.assert_array_equal(a.ev, b.ev)
    np.testing.assert_array_equal(a.u, b.u)


def test_fatrop_and_ipopt_agree():
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    u_f = SMPCExpert(SMPCConfig(solver="fatrop")).act(obs)
    u_i = SMPCExpert(SMPCConfig(solver="ipopt")).act(obs)
    np.testing.assert_allclose(u_f, u_i, atol=1e-5)


def test_bad_inputs_raise():
    with pytest.raises(ValueError, match="open interval"):
        SMPCConfig(risk=1.0)
    with pytest.raises(ValueError, match="open interval"):
        SMPCConfig(risk=0.0)
    with pytest.raises(ValueError, match="solver"):
        SMPCConfig(solver="snopt")
    expert = SMPCExpert()
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    for bad in (np.where(np.arange(8) == 1, np.nan, obs), np.where(np.arange(8) == 0, np.inf, obs)):
        with pytest.raises(ValueError, match="NaN or inf"):
            expert.act(bad)
    with pytest.raises(ValueError, match="shape"):
        expert.act(obs[:6])
    inside = obs.copy()
    inside[4:6] = inside[0] - 5.0, inside[1]  # TV 5 m behind in the EV's lane
    assert elliptical_index(5.0, 0.0, 15, 3) < 1
    with pytest.raises(InfeasibleStartError, match="inside the TV's safety ellipse"):
        SMPCExpert().act(inside)


def test_solver_failure_falls_back_and_reports():
    sc = PAPER
    obs = np.concatenate([sc.ev_initial_state, sc.tv_initial_state])
    starved = SMPCExpert(SMPCConfig(max_iter=1))
    u = starved.act(obs)
    report = starved.last_report
    assert not report.success and report.fallback == "brake"
    assert u[0] == pytest.approx(sc.a_min / 2) and abs(u[1]) <= sc.delta_max
    # after a success, a failure replays the shifted plan
    expert = SMPCExpert()
    u0 = expert.act(obs)
    plan_next = expert.last_report.plan  # predicted states of the accepted plan
    assert expert.last_report.success and plan_next is not None
    expert.config = dataclasses.replace(expert.config, max_iter=1)
    expert._build()
    obs1 = np.concatenate([plan_next[1], sc.tv_initial_state + np.array([28 * sc.dt, 0, 0, 0])])
    expert.act(obs1)
    assert expert.last_report.fallback == "shifted_plan" and not expert.last_report.success
    assert np.all(np.isfinite(u0))


def test_straighten_steer_zeroes_heading():
    from drivestyle.envs.dynamics import rk4_step

    xi = np.array([0.0, 5.0, 0.01, 25.0])
    delta = straighten_steer(xi, PAPER)
    nxt = rk4_step(xi, np.array([0.0, delta]), PAPER.dt, PAPER.l_f, PAPER.l_r)
    assert abs(nxt[2]) < 1e-3


def test_act_returns_info():
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    action, info = SMPCExpert().act(obs, return_info=True)
    assert action.shape == (2,)
    assert info["success"] and info["fallback"] is None and info["iterations"] > 0
    assert info["slack"] == pytest.approx(0.0, abs=1e-6) and info["solve_ms"] > 0


def test_a_failed_solve_is_retried_before_any_fallback(monkeypatch):
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    expert = SMPCExpert(SMPCConfig(retry_solver="ipopt"))
    real_solve = expert._solve

    def fatrop_fails(name):
        if name == "fatrop":
            expert._out["x"][:] = np.nan  # a failed attempt may leave garbage behind
            return False, "1", 40
        return real_solve(name)

    monkeypatch.setattr(expert, "_solve", fatrop_fails)
    u = expert.act(obs)
    report = expert.last_report
    assert report.success and report.retried and report.fallback is None
    assert report.status.startswith("ipopt")
    u_ipopt = SMPCExpert(SMPCConfig(solver="ipopt")).act(obs)
    np.testing.assert_allclose(u, u_ipopt, atol=1e-5)
    # without a retry solver the same failure falls back at once
    plain = SMPCExpert(SMPCConfig(retry_solver=None))
    monkeypatch.setattr(plain, "_solve", lambda name: (False, "1", 40))
    plain.act(obs)
    assert plain.last_report.fallback == "brake" and not plain.last_report.retried


def test_bad_retry_solver_is_rejected():
    with pytest.raises(ValueError, match="retry_solver"):
        SMPCConfig(retry_solver="snopt")
