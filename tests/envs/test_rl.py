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
def test_check_env_passes_on_the_rl_wrappers(env_id, wrap, make_env):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(wrap(make_env(env_id, render_mode="rgb_array")))


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


# ------------------------------------------------------------ the fast wrappers equal the reference
def _reference_rl_observation(observation, k, sc):
    """rl_observation as first written (numpy arrays throughout)."""
    observation = np.asarray(observation, float)
    ev = observation[:4]
    left = max(1.0 - k / sc.n_steps, 0.0)
    own = [ev[1] - sc.y_ref, ev[1] - sc.lane_centres[sc.ev_lane], ev[2], ev[3] - sc.v_ref]
    if observation.size == 8:
        tv = observation[4:8]
        return np.array([*own, tv[0] - ev[0], tv[1] - ev[1], tv[3] - ev[3], left], np.float32)
    slots = observation[4:].reshape(-1, 5)
    rel = np.column_stack(
        [slots[:, 0], slots[:, 1] - ev[0], slots[:, 2] - ev[1], slots[:, 4] - ev[3]]
    )
    rel[slots[:, 0] < 0.5] = 0.0
    return np.concatenate([own, rel.ravel(), [left]]).astype(np.float32)


def _reference_physical_action(a, low, high, ev, sc):
    """physical_action with heading_steering_limits as first written."""
    a = np.clip(np.asarray(a, float), -1.0, 1.0)
    u = low + (a + 1.0) * 0.5 * (high - low)
    phi, v = float(ev[2]), max(float(ev[3]), 1e-3)
    scale = sc.l_r / (v * sc.dt)

    def steer(sin_beta):
        sin_beta = float(np.clip(sin_beta, -0.99, 0.99))
        return float(np.arctan(np.tan(np.arcsin(sin_beta)) * (sc.l_f + sc.l_r) / sc.l_r))

    lo = max(-sc.delta_max, steer((-sc.phi_max - phi) * scale))
    hi = min(sc.delta_max, steer((sc.phi_max - phi) * scale))
    if lo > hi:
        lo = hi = -sc.delta_max if phi > 0 else sc.delta_max
    u[1] = np.clip(u[1], lo, hi)
    return u


@pytest.mark.parametrize(
    "env_id", ["drivestyle/LaneChangeRandom-v0", "drivestyle/TrafficRandom-v0"]
)
def test_the_rl_wrappers_equal_the_reference_implementation(env_id):
    env = gym.make(env_id)
    wrapped = NormalisedAction(RLObservation(gym.make(env_id)))
    rng = np.random.default_rng(5)
    obs, _ = env.reset(seed=1)
    got, _ = wrapped.reset(seed=1)
    base = env.unwrapped
    low, high = base.action_space.low, base.action_space.high
    for _ in range(300):
        np.testing.assert_array_equal(got, _reference_rl_observation(obs, base.k, base.scenario))
        # beyond [-1, 1] (clipped), and the heading bound's edge cases (swinging)
        a = rng.uniform(-1.3, 1.3, 2).astype(np.float32)
        u = _reference_physical_action(a, low, high, base.ev, base.scenario)
        obs, _, term, trunc, info = env.step(u)
        got, _, term_w, trunc_w, info_w = wrapped.step(a)
        np.testing.assert_array_equal(info_w["action"], info["action"])
        assert (term, trunc) == (term_w, trunc_w)
        if term or trunc:
            obs, _ = env.reset()
            got, _ = wrapped.reset()
