import warnings

import drivestyle.envs
import gymnasium as gym
import numpy as np
import pytest
from drivestyle.envs import ENV_IDS, PAPER, LaneChangeEnv
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_gymnasium_and_sb3(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advisory warnings (unbounded Box, float64)
        check_env(gym.make(env_id, render_mode="rgb_array").unwrapped)
        sb3_check_env(gym.make(env_id).unwrapped)


def test_registration_is_idempotent():
    drivestyle.envs.register_envs()
    drivestyle.envs.register_envs()
    assert all(i in gym.registry for i in ENV_IDS)


def _rollout(env, seed, n=20):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    for _ in range(n):
        obs, r, term, trunc, _ = env.step(env.action_space.sample())
        out.append(np.append(obs, r))
        if term or trunc:
            break
    return out


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_seeded_determinism(env_id):
    a = _rollout(gym.make(env_id), seed=7)
    b = _rollout(gym.make(env_id), seed=7)
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


def test_random_env_draws_different_scenarios_per_reset():
    env = gym.make("drivestyle/LaneChangeRandom-v0")
    _, i1 = env.reset(seed=1)
    _, i2 = env.reset()
    assert i1["scenario"] != i2["scenario"]


def test_kwargs_override_and_info():
    env = gym.make("drivestyle/LaneChange-v0", ev_speed=27.0, tv_gap=-25.0)
    obs, info = env.reset(seed=0)
    assert obs.shape == (8,) and obs.dtype == np.float64
    assert obs[3] == 27.0 and obs[4] == PAPER.ev_x - 25.0
    assert {"s_e", "d_k", "collision", "lane_index", "t"} <= set(info)
    assert info["lane_index"] == 0 and info["d_k"] == pytest.approx(info["s_e"] - 1)


def test_truncation_at_horizon():
    env = LaneChangeEnv()
    env.reset(seed=0)
    steps, trunc = 0, False
    while not trunc:
        _, _, term, trunc, info = env.step(np.zeros(2))
        assert not term
        steps += 1
    assert steps == PAPER.n_steps == 30
    assert info["t"] == pytest.approx(6.0)


def test_terminates_on_collision():
    # TV in the EV's lane, 20 m behind and 40 m/s faster
    env = LaneChangeEnv(tv_lane=0, tv_speed=60.0, ev_speed=20.0)
    env.reset(seed=0)
    for _ in range(10):
        _, r, term, trunc, info = env.step(np.zeros(2))
        if term:
            break
    assert term and info["collision"] and not trunc
    assert r < -9


def test_terminates_off_road():
    env = LaneChangeEnv()
    env.reset(seed=0)
    for _ in range(30):
        _, _, term, _, info = env.step(np.array([0.0, -0.05]))  # steer right, off the edge
        if term:
            break
    assert term and info["off_road"] and not info["collision"]


def test_action_validation_and_clipping():
    env = LaneChangeEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0.0]))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    _, _, _, _, info = env.step(np.array([100.0, 0.0]))
    assert info["action_clipped"]


def test_bad_construction_raises():
    with pytest.raises(KeyError, match="unknown scenario"):
        gym.make("drivestyle/LaneChange-v0", scenario="nope")
    with pytest.raises(TypeError, match="unknown scenario parameter"):
        gym.make("drivestyle/LaneChange-v0", ev_sped=20)
    with pytest.raises(ValueError, match="inside the TV's safety ellipse"):
        gym.make("drivestyle/LaneChange-v0", tv_lane=0, tv_gap=-10.0)
    with pytest.raises(ValueError, match="render_mode"):
        LaneChangeEnv(render_mode="video")


def test_rgb_frames_are_not_blank():
    env = gym.make("drivestyle/LaneChange-v0", render_mode="rgb_array")
    env.reset(seed=0)
    frames = [env.render()]
    for _ in range(3):
        env.step(np.array([1.0, 0.02]))
        frames.append(env.render())
    env.close()
    for f in frames:
        assert f.ndim == 3 and f.shape[2] == 3 and f.dtype == np.uint8
        assert f.std() > 5  # not a uniform fill
        colours = f.reshape(-1, 3).astype(int)
        red = (colours[:, 0] > 180) & (colours[:, 1] < 90) & (colours[:, 2] < 90)
        blue = (colours[:, 2] > 180) & (colours[:, 0] < 90)
        assert red.sum() > 50 and blue.sum() > 50  # EV red and TV blue are drawn
    assert not np.array_equal(frames[0], frames[-1])


def test_human_mode_runs_headless():
    # SDL's dummy driver stands in for a display; the window path must not crash
    env = gym.make("drivestyle/LaneChange-v0", render_mode="human")
    env.reset(seed=0)
    for _ in range(2):
        env.step(np.zeros(2))
    assert env.render() is None
    env.close()
