import json

import numpy as np
import pytest

from drivestyle.irl import (
    FeatureConfig,
    InnerProblem,
    IRLConfig,
    MaxEntIRL,
    newton_minimize,
    normalise_theta,
)
from drivestyle.irl.paper.inner import InnerSolveError
from drivestyle.irl.paper.style import StyleError, fit_style, load_style


@pytest.fixture(scope="module")
def inner(paper_demo):
    return InnerProblem(paper_demo, FeatureConfig(feature_set="reactive"))


def _theta(ip, seed=0):
    rng = np.random.default_rng(seed)
    return np.exp(rng.uniform(-0.5, 0.5, ip.f_demo.size)) / np.maximum(abs(ip.f_demo), 0.05)


@pytest.mark.parametrize("axis", ["x", "y"])
def test_inner_gradient_and_hessian_match_finite_differences(inner, axis):
    fgh_fn, _, f_fn = inner._fns[axis]
    names = inner.groups[axis]
    th = _theta(inner)[[inner.names.index(n) for n in names]]
    rng = np.random.default_rng(1)
    z = inner._z[axis] + rng.normal(scale=0.05, size=inner._z[axis].size)
    _f0, g, H = fgh_fn(z, th)
    assert f_fn(z, th)[0][0] == pytest.approx(_f0[0], rel=1e-12)  # the line search's value
    h = 1e-6
    for i in rng.choice(z.size, 8, replace=False):
        e = np.zeros(z.size)
        e[i] = h
        fp, gp, _ = fgh_fn(z + e, th)
        fm, gm, _ = fgh_fn(z - e, th)
        assert (fp[0] - fm[0]) / (2 * h) == pytest.approx(g[i], rel=1e-5, abs=1e-6)
        np.testing.assert_allclose((gp - gm) / (2 * h), H[:, i], rtol=1e-4, atol=1e-4)


def test_sensitivity_matches_finite_differences(inner):
    th = _theta(inner, 2)
    base = inner.solve(th, tol=1e-11)
    for i in (0, 3, 9):
        step = th.copy()
        step[i] *= 1 + 1e-4
        pert = inner.solve(step, tol=1e-11)
        fd = (pert.features - base.features) / (th[i] * 1e-4)
        # atol: the other group is re-solved too, to its tolerance (FD noise ~0.1)
        np.testing.assert_allclose(fd, base.sensitivity[:, i], rtol=0.05, atol=0.15)
        inner.solve(th, tol=1e-11)


def test_newton_minimize_rosenbrock():
    def fgh(z):
        x, y = z
        f = (1 - x) ** 2 + 100 * (y - x**2) ** 2
        g = np.array([-2 * (1 - x) - 400 * x * (y - x**2), 200 * (y - x**2)])
        H = np.array([[2 - 400 * (y - 3 * x**2), -400 * x], [-400 * x, 200.0]])
        return f, g, H

    z, it, ok = newton_minimize(fgh, np.array([-1.2, 1.0]), tol=1e-12)
    assert ok and it < 50
    np.testing.assert_allclose(z, [1.0, 1.0], atol=1e-6)


@pytest.mark.parametrize("feature_set", ["base", "reactive"])
def test_recovers_known_weights(paper_demo, feature_set):
    # a demonstration that is exactly optimal for θ_true: learning must reproduce it
    fc = FeatureConfig(feature_set=feature_set)
    ip = InnerProblem(paper_demo, fc)
    truth = ip.solve(_theta(ip, 1)).control_points
    result = MaxEntIRL(paper_demo, fc, IRLConfig(), control_points=[truth]).learn()
    C = result.solutions[0].control_points
    assert np.sqrt(np.mean((C[:, 3] - truth[:, 3]) ** 2)) < 0.05  # rmse_y vs the truth
    assert np.sqrt(np.mean((C[:, 0] - truth[:, 0]) ** 2)) < 0.05
    rel = np.abs(result.feature_values_reproduced - result.feature_values_demo)
    assert np.all(rel <= 0.02 * np.maximum(np.abs(result.feature_values_demo), 0.05))


def test_reactive_beats_base_on_the_paper_demo(paper_demo):
    out = {}
    for fs in ("base", "reactive"):
        res = MaxEntIRL(paper_demo, FeatureConfig(feature_set=fs)).learn()
        assert res.converged
        out[fs] = res.errors[0]
    assert out["reactive"]["rmse_y_reaction_m"] < 0.5 * out["base"]["rmse_y_reaction_m"]
    assert out["reactive"]["rmse_y_m"] < out["base"]["rmse_y_m"]
    assert out["reactive"]["rmse_y_m"] < 0.3


def test_multi_demo_with_one_demo_equals_single(paper_demo):
    fc = FeatureConfig(feature_set="base")
    a = MaxEntIRL(paper_demo, fc).learn()
    b = MaxEntIRL([paper_demo], fc).learn()
    np.testing.assert_array_equal(a.theta, b.theta)
    assert a.iterations == b.iterations


@pytest.mark.parametrize("alpha", [1e-2, 5e-2])
def test_paper_rule_first_update_is_the_papers_step(paper_demo, alpha):
    # θ₁ = max(θ₀ + α (f(r*_θ₀) − f_D), θ_min) with θ₀ = 1, f(r*_θ₀) solved independently;
    # α = 0.05 pushes f_l's weight below zero, so the floor θ_min must act
    fc = FeatureConfig(feature_set="base")
    cfg = IRLConfig(method="paper", max_iter=2, alpha=alpha)
    ip = InnerProblem(paper_demo, fc)
    f0 = ip.solve(np.ones(ip.f_demo.size), tol=cfg.inner_tol).features
    expected = np.maximum(1.0 + alpha * (f0 - ip.f_demo), cfg.theta_min)
    assert (expected == cfg.theta_min).any() == (alpha == 5e-2)
    res = MaxEntIRL(paper_demo, fc, cfg).learn()
    np.testing.assert_allclose(res.history[0].theta, 1.0)
    np.testing.assert_allclose(res.history[1].theta, expected, rtol=1e-9)
    np.testing.assert_array_equal(res.theta, res.history[-1].theta)


def test_paper_rule_lowers_the_learning_error(paper_demo):
    res = MaxEntIRL(
        paper_demo,
        FeatureConfig(feature_set="base"),
        IRLConfig(method="paper", max_iter=8, alpha=1e-2),
    ).learn()
    eps = [h.epsilon for h in res.history]
    assert eps[-1] < 0.5 * eps[0], eps  # 31.7 -> 9.1 on the paper demo
    assert res.learning_error == pytest.approx(eps[-1])
    # |Δε| is still far above ε̄ after 8 iterations: the cap stopped it, not convergence
    assert res.status == "max_iter" and not res.converged


def _fail_after(monkeypatch, n_ok, error=None):
    """Make every InnerProblem.solve after the first n_ok calls raise ``error``."""
    error = error or InnerSolveError("Newton did not converge (forced)")
    calls = {"n": 0}
    solve = InnerProblem.solve

    def failing(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > n_ok:
            raise error
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(InnerProblem, "solve", failing)
    return calls


@pytest.mark.parametrize("method", ["lm", "paper"])
def test_learning_whose_inner_solves_all_fail_is_stalled_not_converged(
    paper_demo, monkeypatch, method
):
    learner = MaxEntIRL(paper_demo, FeatureConfig(feature_set="base"), IRLConfig(method=method))
    calls = _fail_after(monkeypatch, 1)  # only the initial θ can be solved
    res = learner.learn()
    assert res.status == "stalled"
    assert res.converged is False
    assert "forced" in res.stop_reason and res.inner_failures == calls["n"] - 1 >= 1
    assert res.iterations == 1  # nothing was accepted: θ is the initial one
    assert res.to_json()["status"] == "stalled" and res.to_json()["converged"] is False


@pytest.mark.parametrize(("failing_trial", "status"), [(1, "converged"), (12, "stalled")])
def test_lm_stalls_only_when_its_smallest_step_cannot_be_solved(
    paper_demo, monkeypatch, failing_trial, status
):
    # every solved trial reproduces the initial features (so none lowers the cost); one trial
    # fails: a failed large first step still ends at a point no damped step improves
    # ("converged"), a failed smallest (12th) step leaves it unknown ("stalled")
    learner = MaxEntIRL(paper_demo, FeatureConfig(feature_set="base"))
    solve, calls, first = InnerProblem.solve, {"n": 0}, []

    def fake(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 1:
            first.append(solve(self, *args, **kwargs))
            return first[0]
        if calls["n"] == 1 + failing_trial:
            raise InnerSolveError("forced")
        return first[0]

    monkeypatch.setattr(InnerProblem, "solve", fake)
    res = learner.learn()
    assert calls["n"] == 1 + 12  # the initial θ and the 12 trials of iteration 2
    assert res.status == status and res.inner_failures == 1
    assert res.converged == (status == "converged")


def test_only_inner_solve_errors_are_taken_as_failed_trials(paper_demo, monkeypatch):
    learner = MaxEntIRL(paper_demo, FeatureConfig(feature_set="base"))
    _fail_after(monkeypatch, 1, RuntimeError("a bug, not a failed solve"))
    with pytest.raises(RuntimeError, match="a bug"):
        learner.learn()


def test_an_unsolvable_initial_theta_raises(paper_demo, monkeypatch):
    learner = MaxEntIRL(paper_demo, FeatureConfig(feature_set="base"))
    _fail_after(monkeypatch, 0)
    with pytest.raises(InnerSolveError, match="forced"):
        learner.learn()


def test_learning_result_is_frozen_and_serialises(paper_demo):
    res = MaxEntIRL(paper_demo, FeatureConfig(feature_set="base")).learn()
    with pytest.raises(AttributeError):
        res.status = "stalled"  # type: ignore[misc]
    js = res.to_json()
    assert js["iterations"] == res.iterations == len(js["history"])
    assert js["status"] == res.status and js["converged"] == res.converged
    assert js["history"][0]["iteration"] == 1 and "control_points" not in js["history"][0]
    json.dumps(js)


def test_normalise_theta_per_group():
    names = ("ax", "ay", "v", "l", "il", "el")
    th = normalise_theta(np.array([1.0, 2.0, 3.0, 2.0, 4.0, 2.0]), names)
    np.testing.assert_allclose(th, [0.25, 0.2, 0.75, 0.2, 0.4, 0.2])


def test_bad_inputs(inner, paper_demo):
    with pytest.raises(ValueError, match="positive finite"):
        inner.solve(np.full(10, -1.0))
    with pytest.raises(ValueError, match="method"):
        IRLConfig(method="adam")
    with pytest.raises(ValueError, match="at least one"):
        MaxEntIRL([])
    with pytest.raises(ValueError, match="control_points"):
        InnerProblem(paper_demo, control_points=np.zeros((3, 6)))


def test_style_round_trip(tmp_path, paper_demo):
    from drivestyle.common.io import write_json

    fitted = fit_style(paper_demo, FeatureConfig(feature_set="base"), IRLConfig())
    result, payload = fitted.result, fitted.to_json()
    assert payload["status"] == result.status == fitted.status
    assert payload["rmse_y_m"] == pytest.approx(result.errors[0]["rmse_y_m"])
    write_json(tmp_path / "style.json", payload)
    style = load_style(tmp_path)
    np.testing.assert_allclose(style.theta, result.theta)
    assert style.names == result.names and style.features.feature_set == "base"
    (tmp_path / "bad.json").write_text('{"features": ["ax"], "theta": [1.0]}')
    with pytest.raises(StyleError, match="feature_config"):
        load_style(tmp_path / "bad.json")
    with pytest.raises(FileNotFoundError):
        load_style(tmp_path / "none.json")
