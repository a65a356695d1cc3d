import ast
import dataclasses
import inspect

import numpy as np
import pytest

from drivestyle.agents import (
    InfeasibleStartError,
    SMPCConfig,
    SMPCDecision,
    SMPCExpert,
    SMPCProblem,
    generate_demonstration,
)
from drivestyle.agents.smpc import SolveReport, straighten_steer
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


def test_solver_failure_falls_back_and_reports(monkeypatch):
    sc = PAPER
    obs = np.concatenate([sc.ev_initial_state, sc.tv_initial_state])
    starved = SMPCExpert(SMPCConfig(max_iter=1))
    decision = starved.plan(obs)
    report, u = decision.report, decision.action
    assert not report.success and report.fallback == "brake"
    assert u[0] == pytest.approx(sc.a_min / 2) and abs(u[1]) <= sc.delta_max
    # after a success, a failure replays the shifted plan
    expert = SMPCExpert()
    first = expert.plan(obs)
    plan_next = first.report.plan  # predicted states of the accepted plan
    assert first.report.success and plan_next is not None
    starving = SMPCProblem(dataclasses.replace(expert.config, max_iter=1), sc)
    monkeypatch.setattr(expert, "_problem", starving)
    obs1 = np.concatenate([plan_next[1], sc.tv_initial_state + np.array([28 * sc.dt, 0, 0, 0])])
    second = expert.plan(obs1)
    assert second.report.fallback == "shifted_plan" and not second.report.success
    assert np.all(np.isfinite(first.action)) and np.all(np.isfinite(second.action))


def test_straighten_steer_zeroes_heading():
    from drivestyle.envs.dynamics import rk4_step

    xi = np.array([0.0, 5.0, 0.01, 25.0])
    delta = straighten_steer(xi, PAPER)
    nxt = rk4_step(xi, np.array([0.0, delta]), PAPER.dt, PAPER.l_f, PAPER.l_r)
    assert abs(nxt[2]) < 1e-3


def test_plan_returns_the_action_and_its_report_and_act_only_the_action():
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    decision = SMPCExpert().plan(obs)
    assert isinstance(decision, SMPCDecision) and isinstance(decision.report, SolveReport)
    assert decision.action.shape == (2,)
    np.testing.assert_array_equal(decision.action, decision.report.action)
    info = decision.report.info()
    assert info["success"] and info["fallback"] is None and info["iterations"] > 0
    assert info["slack"] == pytest.approx(0.0, abs=1e-6) and info["solve_ms"] > 0
    action = SMPCExpert().act(obs)
    assert isinstance(action, np.ndarray) and action.shape == (2,)
    np.testing.assert_array_equal(action, decision.action)
    with pytest.raises(TypeError):
        SMPCExpert().act(obs, return_info=True)  # one return type: the report is plan()'s
    with pytest.raises(dataclasses.FrozenInstanceError):
        decision.action = np.zeros(2)


def test_the_warm_start_carries_over_steps_and_reset_drops_it():
    # the second step of a closed loop differs from a cold solve of the same observation
    # only through the warm start; after reset the expert solves cold again
    sc = PAPER
    obs = np.concatenate([sc.ev_initial_state, sc.tv_initial_state])
    expert = SMPCExpert()
    first = expert.plan(obs)
    obs1 = np.concatenate(
        [first.report.plan[1], sc.tv_initial_state + np.array([30 * sc.dt, 0, 0, 0])]
    )
    warm = expert.plan(obs1).report
    cold_report = SMPCExpert().plan(obs1).report
    assert warm.iterations < cold_report.iterations
    expert.reset()
    assert expert.plan(obs1).report.iterations == cold_report.iterations


def test_set_risk_changes_kappa_without_rebuilding_the_problem():
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    expert = SMPCExpert(SMPCConfig(risk=0.5))
    problem = expert.problem
    expert.set_risk(0.95)
    assert expert.problem is problem and expert.config.risk == 0.95
    np.testing.assert_allclose(
        expert.act(obs), SMPCExpert(SMPCConfig(risk=0.95)).act(obs), atol=1e-12
    )
    with pytest.raises(ValueError, match="open interval"):
        expert.set_risk(1.5)


def test_a_new_geometry_rebuilds_the_problem():
    expert = SMPCExpert()
    problem = expert.problem
    expert.reset(dataclasses.replace(PAPER, v_ref=25.0))
    assert expert.problem is problem
    expert.reset(dataclasses.replace(PAPER, dt=0.1))
    assert expert.problem is not problem and expert.problem.scenario.dt == 0.1


def _self_attributes_assigned(func: ast.FunctionDef) -> set[str]:
    names = set()
    for node in ast.walk(func):
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
            targets = [node.target]
        else:
            continue
        for target in targets:
            for t in target.elts if isinstance(target, ast.Tuple) else [target]:
                if isinstance(t, ast.Attribute) and getattr(t.value, "id", None) == "self":
                    names.add(t.attr)
    return names


@pytest.mark.parametrize("cls", [SMPCExpert, SMPCProblem])
def test_every_attribute_is_first_set_in_init(cls):
    (node,) = ast.parse(inspect.getsource(cls)).body
    methods = [m for m in node.body if isinstance(m, ast.FunctionDef)]
    in_init = set().union(*(_self_attributes_assigned(m) for m in methods if m.name == "__init__"))
    elsewhere = set().union(
        *(_self_attributes_assigned(m) for m in methods if m.name != "__init__")
    )
    assert in_init and elsewhere <= in_init, sorted(elsewhere - in_init)


def test_a_failed_solve_is_retried_before_any_fallback(monkeypatch):
    obs = np.concatenate([PAPER.ev_initial_state, PAPER.tv_initial_state])
    expert = SMPCExpert(SMPCConfig(retry_solver="ipopt"))
    problem = expert.problem
    real_solve = problem.solve

    def fatrop_fails(name, p, guess, bounds):
        sol = real_solve(name, p, guess, bounds)
        if name == "fatrop":
            problem._outputs["x"][:] = np.nan  # a failed attempt may leave garbage behind
            return dataclasses.replace(sol, success=False, status="1", iterations=40)
        return sol

    monkeypatch.setattr(problem, "solve", fatrop_fails)
    report = expert.plan(obs).report
    assert report.success and report.retried and report.fallback is None
    assert report.status.startswith("ipopt")
    u_ipopt = SMPCExpert(SMPCConfig(solver="ipopt")).act(obs)
    np.testing.assert_allclose(report.action, u_ipopt, atol=1e-5)
    # without a retry solver the same failure falls back at once
    plain = SMPCExpert(SMPCConfig(retry_solver=None))
    monkeypatch.setattr(plain.problem, "solve", fatrop_fails)
    report = plain.plan(obs).report
    assert report.fallback == "brake" and not report.retried and not report.success


def test_bad_retry_solver_is_rejected():
    with pytest.raises(ValueError, match="retry_solver"):
        SMPCConfig(retry_solver="snopt")
