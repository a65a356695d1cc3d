"""The paper model's learned reward: telescoping sums, the plugin, crash costs, the O(1) update."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drivestyle.envs import LaneChangeEnv
from drivestyle.irl import FeatureConfig, IRLConfig, feature_basis, feature_values
from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.irl.paper.style import fit_style, load_style
from drivestyle.irl.paper.style_reward import LearnedStyleReward


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
    from drivestyle.irl.paper.style import Style, StyleError

    named = Style(("ax",), np.ones(1), None, "kinematic", {"demos": [{"path": "d/demo.npz"}]})
    assert str(named.demo_path()) == "d/demo.npz"
    # where style.json records it relative to its own folder, it is found from there
    located = {"demos": [{"path": "d/demo.npz", "path_from_style": "../d/demo.npz"}]}
    file = tmp_path / "styles" / "a" / "style.json"
    beside = Style(("ax",), np.ones(1), None, "kinematic", located, file)
    assert beside.demo_path() == tmp_path / "styles" / "a" / ".." / "d" / "demo.npz"
    unread = Style(("ax",), np.ones(1), None, "kinematic", located)  # not read from a file
    assert str(unread.demo_path()) == "d/demo.npz"
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
    from drivestyle.irl.paper.style import StyleError

    # finite θ (load_style accepts it) whose cost of its own demonstration overflows
    path = _scaled_style(styles["base"], tmp_path, 5e306)  # largest θ about 1e308
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow warning on the way
        with pytest.raises(StyleError, match=r"style θ overflows: .*relearn or rescale"):
            LearnedStyleReward(LaneChangeEnv(), path)
        with pytest.raises(StyleError, match="overflows"):  # also with an explicit penalty
            LearnedStyleReward(LaneChangeEnv(), path, crash_penalty=5.0)


def test_a_malformed_demo_feature_vector_is_a_style_error(styles, tmp_path):
    from drivestyle.irl.paper.style import StyleError

    path = _scaled_style(styles["base"], tmp_path, 1.0, f_demo=[1.0, 2.0])
    with pytest.raises(StyleError, match="feature_values_demo"):
        LearnedStyleReward(LaneChangeEnv(), path)


# ------------------------------------------------------------ the fast reward equals the reference
class _ReferenceStyleReward:
    """The style reward as first written: every step recomputes the whole trajectory's
    control points, event times and last segments (the reference of the O(1) update)."""

    TAIL = 4

    def __init__(self, style):
        from drivestyle.irl.paper.features import FEATURES

        self.style = style
        self.config = style.features
        self.theta = np.asarray(style.theta, float)
        self.idx = np.array([FEATURES.index(n) for n in style.names])
        self.omega = np.asarray(self.config.omega, float)

    def reset(self, scenario, ev, tv, others=None):
        from drivestyle.irl.paper.features import feature_constants

        self.sc = scenario
        self.constants = feature_constants(self.config, scenario)
        self.ratio = scenario.l_r / (scenario.l_f + scenario.l_r)
        self.t = [0.0]
        self.ev = [np.asarray(ev, float).copy()]
        self.tv = [np.asarray(tv, float).copy()]
        self.m = 0 if others is None else int(np.shape(others)[0])
        self.others = [np.zeros((0, 4)) if others is None else np.asarray(others, float)]
        self.delta = []
        self.segments = []
        self.f = np.zeros(len(self.omega))

    def features(self):
        from drivestyle.irl.paper.features import (
            FEATURES,
            SEGMENT_FEATURES,
            event_times,
            instant_feature,
            segment_integrals,
            tiv_reference,
            tv_control_points,
        )
        from drivestyle.irl.paper.spline import spline_eval, state_control_points

        n = len(self.t)
        t = np.asarray(self.t)
        ev, tv = np.asarray(self.ev), np.asarray(self.tv)
        others = np.asarray(self.others).reshape(n, self.m, 4) if self.m else None
        events = event_times(t, ev, tv, self.sc, self.config, others)
        delta = np.asarray([*self.delta, self.delta[-1]])
        C = state_control_points(t, ev, delta, self.style.control_point_rule, self.ratio)
        vehicles = tv[:, None, :] if others is None else np.concatenate([tv[:, None], others], 1)
        Ts = [tv_control_points(t, vehicles[:, i]) for i in range(vehicles.shape[1])]
        ref = tiv_reference(ev, tv, self.sc, others)
        y_trg = None
        if events.reactive_active:
            y_trg = float(spline_eval(C, t, [events.reactive_window()[0]])[0, 1])
        first_tail = max(0, n - 1 - self.TAIL)
        del self.segments[first_tail:]
        for j in range(first_tail, n - 1):
            self.segments.append(
                segment_integrals(
                    np.r_[C[j, :3], C[j + 1, :3]],
                    np.r_[C[j, 3:], C[j + 1, 3:]],
                    np.r_[Ts[ref[j]][j, :3], Ts[ref[j]][j + 1, :3]],
                    t[j],
                    t[j + 1],
                    self.config,
                    self.constants,
                    events,
                    y_trg,
                    j == 0,
                )
            )
        f = dict.fromkeys(FEATURES, 0.0)
        for name in SEGMENT_FEATURES:
            f[name] = sum(seg[name] for seg in self.segments)
        f["el"] = self.segments[-1]["l"]
        if events.reactive_active:
            window = list(events.reactive_window())
            at = spline_eval(C, t, window)[:, 1]
            at_tv = spline_eval(Ts[events.critical], t, window)[:, 1]
            f["sd"] = float(instant_feature(at[0], at_tv[0], np.exp, np.abs))
            f["ed"] = float(instant_feature(at[1], at_tv[1], np.exp, np.abs))
        return self.omega * np.array([f[k] for k in FEATURES])

    def step(self, u, ev, tv, dt, others=None):
        self.delta.append(float(u[1]))
        self.t.append(self.t[-1] + dt)
        self.ev.append(np.asarray(ev, float).copy())
        self.tv.append(np.asarray(tv, float).copy())
        self.others.append(
            np.zeros((0, 4)) if not self.m else np.asarray(others, float).reshape(self.m, 4)
        )
        f = self.features()
        df = (f - self.f)[self.idx]
        self.f = f
        return -float(self.theta @ df), df


def _known_style(feature_set="reactive", rule="kinematic"):
    """A paper-model style with known weights (no learning)."""
    from drivestyle.irl.paper.features import FEATURE_SETS
    from drivestyle.irl.paper.style import Style

    names = FEATURE_SETS[feature_set]
    theta = np.array([0.8, 2.0, 0.05, 0.6, 0.3, 1.5, 0.2, 4.0, 3.0, 0.7])[: len(names)]
    return Style(names, theta, FeatureConfig(feature_set=feature_set), rule, {})


def _compare_rewards(env, reference, actions, seed):
    """Step ``env`` (the style reward) and ``reference`` side by side; returns the number
    of episodes in which the trigger fired and in which the EV turned."""
    obs, info = env.reset(seed=seed)
    base = env.unwrapped
    others = info["vehicles"][1:] if "vehicles" in info else None
    reference.reset(base.scenario, obs[:4], obs[4:8] if others is None else info["vehicles"][0],
                    others)  # fmt: skip
    fired = turned = 0
    for u in actions:
        obs, r, term, trunc, info = env.step(u)
        tv = obs[4:8] if others is None else info["vehicles"][0]
        others = None if others is None else info["vehicles"][1:]
        want_r, want_df = reference.step(info["action"], obs[:4], tv, base.scenario.dt, others)
        if term:
            want_r -= env.style_reward.crash_penalty
        np.testing.assert_allclose(info["style_feature_increment"], want_df, rtol=1e-9, atol=1e-9)
        assert r == pytest.approx(want_r, rel=1e-9, abs=1e-9)
        if term or trunc:
            fired += reference.f[7] != 0.0
            turned += len(reference.t) > 2 and np.asarray(reference.ev)[-1, 1] > 5.25
            obs, info = env.reset()
            others = info["vehicles"][1:] if "vehicles" in info else None
            tv = obs[4:8] if others is None else info["vehicles"][0]
            reference.reset(base.scenario, obs[:4], tv, others)
    return fired, turned


@pytest.mark.parametrize(
    ("feature_set", "rule"),
    [("reactive", "kinematic"), ("base", "kinematic"), ("reactive", "paper")],
)
def test_the_incremental_reward_equals_the_reference_on_the_paper_demo(
    paper_demo, feature_set, rule
):
    style = _known_style(feature_set, rule)
    env = LearnedStyleReward(LaneChangeEnv(), style)
    fired, turned = _compare_rewards(env, _ReferenceStyleReward(style), paper_demo.u, 0)
    assert fired == turned == 1


@pytest.mark.parametrize("env_id", [
    "drivestyle/LaneChangeRandom-v0",
    pytest.param("drivestyle/Traffic-v0", marks=pytest.mark.slow),  # TrafficRandom covers it
    "drivestyle/TrafficRandom-v0",
])  # fmt: skip
def test_the_incremental_reward_equals_the_reference_on_random_driving(env_id):
    style = _known_style()
    env = LearnedStyleReward(gym.make(env_id), style)
    rng = np.random.default_rng(1)
    sp = env.action_space
    # accelerate and steer left (lane changes that fire the trigger), then random inputs
    steer = np.column_stack([rng.uniform(-1, 3, 300), rng.uniform(0.0, 0.02, 300)])
    actions = np.concatenate([steer, rng.uniform(sp.low, sp.high, (100, 2))])
    fired, turned = _compare_rewards(env, _ReferenceStyleReward(style), actions, 3)
    assert fired >= 2 and turned >= 2
