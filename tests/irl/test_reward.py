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
