import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drivestyle.envs import LaneChangeEnv
from drivestyle.irl import FeatureConfig, IRLConfig, feature_basis, feature_values
from drivestyle.irl.reward import LearnedStyleReward
from drivestyle.irl.spline import demo_control_points
from drivestyle.irl.style import fit_style, load_style


@pytest.fixture(scope="module")
def styles(tmp_path_factory, paper_demo):
    from drivestyle.common.io import write_json

    out = {}
    for fs in ("base", "reactive"):
        payload = fit_style(paper_demo, FeatureConfig(feature_set=fs), IRLConfig()).to_json()
        path = write_json(tmp_path_factory.mktemp(fs) / "style.json", payload)
        out[fs] = path
    return out


@pytest.mark.parametrize("fs", ["base", "reactive"])
def test_replayed_demo_sums_to_learned_cost(styles, paper_demo, fs):
    style = load_style(styles[fs])
    env = LearnedStyleReward(LaneChangeEnv(), style)
    env.reset(seed=0)
    total, originals = 0.0, 0.0
    for u in paper_demo.u:
        _, r, term, trunc, info = env.step(u)
        total += r
        originals += info["original_env_rew"]
    assert trunc and not term
    C = demo_control_points(paper_demo, style.control_point_rule)
    f = feature_values(
        C[:, :3].ravel(),
        C[:, 3:].ravel(),
        feature_basis(paper_demo, style.features),
        names=style.names,
    )
    # the increments telescope: equal up to round-off (documented tolerance 1e-8 relative)
    assert total == pytest.approx(-style.theta @ f, rel=1e-8)
    assert originals < 0  # the task reward is still reported


def test_kwarg_path_equals_wrapper(styles, paper_demo):
    a = gym.make("drivestyle/LaneChange-v0", style=str(styles["reactive"]))
    b = LearnedStyleReward(gym.make("drivestyle/LaneChange-v0"), styles["reactive"])
    a.reset(seed=0)
    b.reset(seed=0)
    for u in paper_demo.u[:10]:
        ra, rb = a.step(u)[1], b.step(u)[1]
        assert ra == pytest.approx(rb, rel=1e-12)


def test_check_env_with_learned_reward(styles):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(gym.make("drivestyle/LaneChange-v0", style=str(styles["base"])).unwrapped)
        check_env(LearnedStyleReward(LaneChangeEnv(randomize=True), styles["reactive"]))


def test_crash_costs_the_penalty(styles):
    env = LearnedStyleReward(
        LaneChangeEnv(tv_lane=0, tv_speed=60.0, ev_speed=20.0),
        styles["reactive"],
        crash_penalty=500.0,
    )
    env.reset(seed=0)
    for _ in range(10):
        _, r, term, _, info = env.step(np.zeros(2))
        if term:
            break
    assert term and info["collision"] and r < -400


def test_bad_style_path():
    with pytest.raises(FileNotFoundError):
        LearnedStyleReward(LaneChangeEnv(), "no/such/style.json")


def test_a_style_names_its_demonstration_or_says_it_has_none(tmp_path):
    from drivestyle.irl.style import Style, StyleError

    named = Style(("ax",), np.ones(1), None, "kinematic", {"demos": [{"path": "d/demo.npz"}]})
    assert str(named.demo_path()) == "d/demo.npz"
    with pytest.raises(StyleError, match=r"s\.json names no demonstration: pass --demo"):
        Style(("ax",), np.ones(1), None, "kinematic", {"demos": []}).demo_path("s.json")


def _scaled_style(path, tmp_path, theta_scale, f_demo=None):
    import json

    raw = json.loads(path.read_text())
    raw["theta"] = [t * theta_scale for t in raw["theta"]]
    if f_demo is not None:
        raw["feature_values_demo"] = f_demo
    out = tmp_path / "style.json"
    out.write_text(json.dumps(raw))
    return out


def test_an_overflowing_theta_says_what_is_wrong_with_the_style(styles, tmp_path):
    from drivestyle.irl.style import StyleError

    # finite θ (load_style accepts it) whose cost of its own demonstration overflows
    path = _scaled_style(styles["base"], tmp_path, 5e306)  # largest θ about 1e308
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow warning on the way
        with pytest.raises(StyleError, match=r"style θ overflows: .*relearn or rescale"):
            LearnedStyleReward(LaneChangeEnv(), path)
        with pytest.raises(StyleError, match="overflows"):  # also with an explicit penalty
            LearnedStyleReward(LaneChangeEnv(), path, crash_penalty=5.0)


def test_a_malformed_demo_feature_vector_is_a_style_error(styles, tmp_path):
    from drivestyle.irl.style import StyleError

    path = _scaled_style(styles["base"], tmp_path, 1.0, f_demo=[1.0, 2.0])
    with pytest.raises(StyleError, match="feature_values_demo"):
        LearnedStyleReward(LaneChangeEnv(), path)


def test_driver_step_cost_equals_a_hand_computation():
    from drivestyle.envs.scenario import get_scenario
    from drivestyle.irl.reward import driver_step_cost

    sc = get_scenario("paper")
    la, lb = sc.l_a, sc.l_b
    # EV 0.5 l_a behind and 0.5 l_b beside the TV: inside the ellipse (‖z̄‖ = √0.5)
    ev = np.array([100.0, sc.y_bounds[0] - 0.2, 1.5 * sc.phi_max, 1.1 * sc.v_max])
    tv = np.array([[100.0 + 0.5 * la, sc.y_bounds[0] - 0.2 + 0.5 * lb, 0.0, 20.0]])
    w = np.array([2.0, 3.0, 0.5, 1.0, 7.0])
    u = np.array([-1.5, 0.01])
    sigma = np.array([[4.0, 0.0], [0.0, 1.0]])
    terms = driver_step_cost(ev, u, tv, w, 5.0, 25.0, 1.0, sigma, sc)
    y, phi, v = ev[1:]
    stage = [2 * (y - 5) ** 2, 3 * phi**2, 0.5 * (v - 25) ** 2, 1.5**2, 7 * 0.01**2]
    # g = ‖z‖ − 1 − κ sqrt(zᵀ S z)/‖z‖ with z = (−0.5, −0.5), S = diag(4/l_a², 1/l_b²)
    norm = np.sqrt(0.5)
    g = norm - 1 - np.sqrt(0.25 * 4 / la**2 + 0.25 / lb**2) / norm
    bounds = 0.2 / sc.lane_width + 0.5 + 0.1
    expected = [*stage, -g, 1 - norm, bounds]
    np.testing.assert_allclose(terms, expected, rtol=1e-12)
    # outside every constraint: no penalty
    far = np.array([[0.0, 0.0, 0.0, 20.0]])
    ok = driver_step_cost([100.0, 5.0, 0.0, 25.0], u, far, w, 5.0, 25.0, 1.0, sigma, sc)
    np.testing.assert_allclose(ok[5:], 0.0)


def test_driver_cost_reward_is_the_scaled_negative_cost(tmp_path):
    from drivestyle.irl.driver_style import DriverStyle
    from drivestyle.irl.prediction import PAPER_TV_UNCERTAINTY
    from drivestyle.irl.reward import DriverCostConfig, DriverCostReward, driver_step_cost

    style = DriverStyle((0.04, 400.0, 0.04, 1.0, 2500.0), risk=0.8)
    env = DriverCostReward(LaneChangeEnv(), style, DriverCostConfig(chance_weight=3.0))
    obs, _ = env.reset(seed=0)
    sc = env.unwrapped.scenario
    u = np.array([0.5, 0.01])
    obs, r, _, _, info = env.step(u)
    sigma = np.diag([PAPER_TV_UNCERTAINTY.sigma_x0**2, PAPER_TV_UNCERTAINTY.sigma_y0**2])
    terms = driver_step_cost(
        obs[:4], u, obs[None, 4:8], style.weights, sc.y_ref, sc.v_ref, style.kappa, sigma, sc
    )
    expected = -(terms[:5].sum() / (0.04 * sc.lane_width**2) + 3.0 * terms[5] + 100.0 * terms[6])
    assert r == pytest.approx(expected - 10.0 * terms[7], rel=1e-12)
    np.testing.assert_array_equal(info["style_feature_increment"], terms)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(DriverCostReward(LaneChangeEnv(randomize=True), style))
    with pytest.raises(ValueError, match="chance_weight"):
        DriverCostConfig(chance_weight=-1.0)


def test_driver_step_cost_look_ahead_takes_the_worst_extrapolated_stage():
    from drivestyle.envs.scenario import get_scenario
    from drivestyle.irl.chance import chance_margin
    from drivestyle.irl.reward import driver_step_cost

    sc = get_scenario("paper")
    w = np.ones(5)
    sigma = np.array([np.eye(2) * s for s in (1.0, 4.0, 9.0)])  # Σ_0, Σ_1, Σ_2
    # the TV 20 m behind in the EV's lane, 10 m/s faster: closes 10 T_s metres per stage
    ev = np.array([100.0, 5.0, 0.0, 20.0])
    tv = np.array([[80.0, 5.0, 0.0, 30.0]])
    got = driver_step_cost(ev, np.zeros(2), tv, w, 5.0, 20.0, 1.0, sigma, sc)[5]
    stages = [
        chance_margin(20.0 - 10.0 * sc.dt * j, 0.0, s, 0.0, s, sc.l_a, sc.l_b, 1.0)
        for j, s in enumerate((1.0, 4.0, 9.0))
    ]
    assert got == pytest.approx(-min(stages), rel=1e-12) and got > 0.1
    assert min(stages) == stages[2] < 0 < stages[0]  # only the look-ahead sees the TV close in
    only_now = driver_step_cost(ev, np.zeros(2), tv, w, 5.0, 20.0, 1.0, sigma[0], sc)[5]
    assert only_now == 0.0
