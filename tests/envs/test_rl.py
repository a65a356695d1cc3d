"""The RL wrappers (drivestyle.envs.rl): gymnasium conformance, spaces, observation, action."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import RecordConstructorArgs
from gymnasium.utils.env_checker import check_env

from drivestyle.envs import ENV_IDS, PAPER
from drivestyle.envs.rl import NormalisedAction, RLObservation

WRAPPERS = {
    "RLObservation": lambda env: RLObservation(env),
    "NormalisedAction": lambda env: NormalisedAction(env),
    "both": lambda env: NormalisedAction(RLObservation(env)),
}


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
