"""Regression tests of reported defects: API conformance and clear errors on bad input.

(Rendering with several envs: tests/envs/test_rendering.py; malformed recorded-data
files: tests/envs/test_real_data.py.)
"""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from drivestyle.envs import ENV_IDS, PAPER, LaneChangeEnv
from drivestyle.envs.real_data import load_cats, load_ngsim
from drivestyle.envs.rl import NormalisedAction, RLObservation
from gymnasium.utils import RecordConstructorArgs
from gymnasium.utils.env_checker import check_env

WRAPPERS = {
    "RLObservation": lambda env: RLObservation(env),
    "NormalisedAction": lambda env: NormalisedAction(env),
    "both": lambda env: NormalisedAction(RLObservation(env)),
}


# ------------------------------------------------------------ gymnasium conformance
@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_passes_on_every_registered_id(env_id, render_mode):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advisory: unbounded Box, wrapped env
        check_env(gym.make(env_id, render_mode=render_mode))


@pytest.mark.parametrize("wrap", WRAPPERS.values(), ids=WRAPPERS.keys())
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_passes_on_the_rl_wrappers(env_id, wrap):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(wrap(gym.make(env_id, render_mode="rgb_array")))


def test_rl_wrappers_record_their_constructor_args():
    env = NormalisedAction(RLObservation(gym.make(ENV_IDS[0])))
    assert isinstance(env, RecordConstructorArgs)
    assert isinstance(env.env, RecordConstructorArgs)
    names = [w.name for w in env.spec.additional_wrappers]
    assert names == ["RLObservation", "NormalisedAction"]
    # the spec rebuilds the same stack (what gymnasium's checker and vector envs rely on)
    again = gym.make(env.spec)
    assert isinstance(again, NormalisedAction) and isinstance(again.env, RLObservation)
    assert again.action_space == env.action_space
    assert again.observation_space == env.observation_space


def test_rl_spaces_are_float32_and_normalised():
    env = NormalisedAction(RLObservation(gym.make(ENV_IDS[0])))
    a = env.action_space
    assert a.dtype == np.float32 and a.shape == (2,)
    np.testing.assert_array_equal(a.low, [-1, -1])
    np.testing.assert_array_equal(a.high, [1, 1])
    obs, _ = env.reset(seed=0)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)
    obs, *_ = env.step(a.sample())
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)


# ------------------------------------------------------------ step after the end
class CountingReward:
    """A RewardModel stub that counts its calls."""

    crash_penalty = 5.0

    def __init__(self):
        self.steps = 0

    def reset(self, scenario, ev, tv):
        self.steps = 0

    def step(self, u, ev, tv, dt):
        self.steps += 1
        return -1.0, np.zeros(1)


def test_step_after_truncation_raises_until_reset():
    env = LaneChangeEnv()
    env.reset(seed=0)
    trunc = False
    while not trunc:
        _, _, term, trunc, _ = env.step(np.zeros(2))
        assert not term
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))
    env.reset(seed=0)
    env.step(np.zeros(2))  # a new episode steps again


def test_step_after_termination_raises_and_charges_the_crash_once():
    model = CountingReward()
    # TV in the EV's lane, 20 m behind and much faster: a collision within a few steps
    env = LaneChangeEnv(tv_lane=0, tv_speed=60.0, ev_speed=20.0, reward=model)
    env.reset(seed=0)
    rewards = []
    for _ in range(20):
        _, r, term, trunc, info = env.step(np.zeros(2))
        rewards.append(r)
        if term:
            break
    assert term and not trunc and info["collision"]
    assert rewards[-1] == -1.0 - model.crash_penalty  # charged on the crash step
    assert all(r == -1.0 for r in rewards[:-1])
    n = model.steps
    for _ in range(2):
        with pytest.raises(RuntimeError, match="reset"):
            env.step(np.zeros(2))
    assert model.steps == n  # the reward model saw no further step: no second penalty


def test_step_after_termination_through_gym_make_raises():
    env = gym.make(ENV_IDS[0], tv_lane=0, tv_speed=60.0, ev_speed=20.0)
    env.reset(seed=0)
    term = False
    while not term:
        _, _, term, _, _ = env.step(np.zeros(2))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2))


# ------------------------------------------------------------ clear errors on bad input
@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"ev_speed": "fast"}, TypeError, "ev_speed must be a number"),
        ({"ev_speed": float("nan")}, ValueError, "ev_speed must be finite"),
        ({"tv_speed": float("inf")}, ValueError, "tv_speed must be finite"),
        ({"n_lanes": 3.0}, TypeError, "n_lanes must be an integer"),
        ({"scenario": 123}, KeyError, "unknown scenario 123"),
        ({"randomize": "yes"}, TypeError, "randomize"),
        ({"show_ellipse": "no"}, TypeError, "show_ellipse"),
        ({"reward": object()}, TypeError, "reward must be a RewardModel"),
        ({"render_mode": "video"}, ValueError, "render_mode"),
    ],
)
def test_bad_make_kwargs_are_clear_errors(kwargs, exc, match):
    with warnings.catch_warnings(), pytest.raises(exc, match=match):
        warnings.simplefilter("ignore")  # gymnasium's own warning about render_mode
        gym.make(ENV_IDS[0], **kwargs)


@pytest.mark.parametrize(
    ("options", "exc", "match"),
    [
        ({"scenario": "nope"}, KeyError, r"options\['scenario'\].*'nope'.*paper"),
        ({"scenario": 5}, KeyError, r"options\['scenario'\].*unknown scenario 5"),
        ({"scenario": None}, KeyError, r"options\['scenario'\]"),
        ({"scenaro": "paper"}, ValueError, "unknown reset option"),
        (["scenario"], TypeError, "options must be a dict"),
        ("paper", TypeError, "options must be a dict"),
    ],
)
def test_bad_reset_options_are_clear_errors(options, exc, match):
    env = LaneChangeEnv()
    with pytest.raises(exc, match=match):
        env.reset(seed=0, options=options)
    _, info = env.reset(seed=0, options={"scenario": "paper"})  # still usable
    assert info["scenario"] == PAPER


@pytest.mark.parametrize(
    "action",
    ["abc", {"a": 1.0}, None, np.array([1j, 0.0]), ["1.0", "0.0"], object()],
    ids=["str", "dict", "None", "complex", "numeric-strings", "object"],
)
def test_non_numeric_action_is_a_clear_error(action):
    env = LaneChangeEnv()
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. numpy's ComplexWarning: no silent casting
        with pytest.raises(ValueError, match="action must be"):
            env.step(action)
    env.step(np.zeros(2))  # the episode goes on


@pytest.mark.parametrize("action", [np.zeros(3), "ab", np.array([1j, 0.0])])
def test_normalised_action_bad_input_is_a_clear_error(action):
    env = NormalisedAction(gym.make(ENV_IDS[0]))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be"):
        env.step(action)


def test_rl_wrappers_reject_a_foreign_env():
    env = gym.make("CartPole-v1")
    with pytest.raises(TypeError, match="RLObservation needs a drivestyle env"):
        RLObservation(env)
    with pytest.raises(TypeError, match="NormalisedAction needs a bounded Box"):
        NormalisedAction(env)


@pytest.mark.parametrize("loader", [load_ngsim, load_cats])
@pytest.mark.parametrize("dt", [0.0, -0.2, float("nan"), "0.2"])
def test_loaders_reject_a_bad_dt(tmp_path, loader, dt):
    with pytest.raises((ValueError, TypeError), match="dt must be"):
        loader(tmp_path, dt=dt)


def test_the_rl_action_keeps_the_smpc_heading_bound():
    from drivestyle.envs.rl import heading_steering_limits

    env = NormalisedAction(RLObservation(gym.make(ENV_IDS[1])))
    env.reset(seed=3)
    base = env.unwrapped
    phi_max = base.scenario.phi_max
    headings = []
    for k in range(30):
        swing = 1.0 if (k // 5) % 2 == 0 else -1.0  # full steering, alternating
        _, _, terminated, truncated, _ = env.step(np.array([0.0, swing], np.float32))
        headings.append(base.ev[2])
        if terminated or truncated:
            break
    assert max(abs(h) for h in headings) <= phi_max * 1.05  # first order in T_s
    unbounded = NormalisedAction(RLObservation(gym.make(ENV_IDS[1])), heading_bound=False)
    unbounded.reset(seed=3)
    for _ in range(5):
        unbounded.step(np.array([0.0, 1.0], np.float32))
    assert unbounded.unwrapped.ev[2] > 2 * phi_max
    lo, hi = heading_steering_limits(np.array([0.0, 2.6, phi_max, 25.0]), base.scenario)
    assert hi == pytest.approx(0.0, abs=1e-9) and lo < 0


def test_the_rl_observation_is_relative():
    from drivestyle.envs.rl import rl_observation

    sc = PAPER
    obs = np.concatenate([sc.ev_initial_state, sc.tv_initial_state])
    o = rl_observation(obs, 0, sc)
    np.testing.assert_allclose(
        o, [2.625 - 7.875, 0.0, 0.0, 25 - 30, -20.0, 5.25, 3.0, 1.0], rtol=1e-6, atol=1e-6
    )
    shifted = obs.copy()
    shifted[[0, 4]] += 500.0  # the same situation further down the road
    np.testing.assert_array_equal(rl_observation(shifted, 0, sc), o)
