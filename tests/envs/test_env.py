import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import drivestyle.envs
from drivestyle.envs import ENV_IDS, PAPER, LaneChangeEnv


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_gymnasium_and_sb3(env_id, make_env):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advisory warnings (unbounded Box, float64)
        check_env(make_env(env_id, render_mode="rgb_array").unwrapped)
        sb3_check_env(make_env(env_id).unwrapped)


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
def test_seeded_determinism(env_id, make_env):
    a = _rollout(make_env(env_id), seed=7)
    b = _rollout(make_env(env_id), seed=7)
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


# ------------------------------------------------------------ gymnasium conformance
@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_passes_on_every_registered_id(env_id, render_mode, make_env):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # advisory: unbounded Box, wrapped env
        check_env(make_env(env_id, render_mode=render_mode))


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


# ------------------------------------------------------------ the fast step equals the reference
def _reference_step(sc, ev, tv, u, low, high, k, deviation=None):
    """One step of the env as first written (numpy arrays throughout), the fast step's reference.

    Returns (ev, tv, obs, reward, terminated, truncated, info) with the info entries it
    computed.
    """
    from drivestyle.envs.dynamics import rk4_step
    from drivestyle.envs.safety import elliptical_index, rectangles_overlap, vehicle_corners

    u = np.asarray(u, float)
    u_clip = np.clip(u, low, high)
    ev = rk4_step(ev, u_clip, sc.dt, sc.l_f, sc.l_r)
    ev[3] = np.clip(ev[3], 0.0, sc.v_max)
    x, y, phi, v = tv
    a = 0.0 if deviation is None else deviation.accel_at(k * sc.dt)
    v_new = max(v + a * sc.dt, 0.0)
    step = 0.5 * (v + v_new) * sc.dt
    tv = np.array([x + step * np.cos(phi), y + step * np.sin(phi), phi, v_new])
    k += 1
    s_e = float(elliptical_index(ev[0] - tv[0], ev[1] - tv[1], sc.l_a, sc.l_b))
    collision = rectangles_overlap(
        vehicle_corners(ev, sc.vehicle_length, sc.vehicle_width),
        vehicle_corners(tv, sc.vehicle_length, sc.vehicle_width),
    )
    off_road = not (0.0 <= ev[1] <= sc.road_width)
    info = {
        "t": k * sc.dt,
        "s_e": s_e,
        "d_k": s_e - 1.0,
        "collision": collision,
        "off_road": off_road,
        "lane_index": int(np.clip(ev[1] // sc.lane_width, 0, sc.n_lanes - 1)),
        "action_clipped": bool(np.any(u_clip != u)),
        "action": u_clip,
    }
    terminated = collision or off_road
    truncated = (not terminated) and k >= sc.n_steps
    lane_err = (ev[1] - sc.y_ref) / sc.lane_width
    speed_err = (ev[3] - sc.v_ref) / 10.0
    reward = float(-(lane_err**2 + speed_err**2) - 10.0 * terminated)
    return ev, tv, np.concatenate([ev, tv]), reward, terminated, truncated, info


def _assert_matches_reference(env, seed, actions, reference_episode, tol=1e-9):
    """Step ``env`` with ``actions`` (resetting after each end) against a reference episode.

    ``reference_episode(reset_info, actions)`` yields (obs, reward, terminated, truncated,
    info) per step, starting from the reset's scenario.
    """
    _, info = env.reset(seed=seed)
    n, episodes, collisions = 0, 0, 0
    while n < len(actions):
        expected = reference_episode(info, actions[n:])
        for want in expected:
            got = env.step(actions[n])
            n += 1
            np.testing.assert_allclose(got[0], want[0], rtol=0, atol=tol)
            assert got[1] == pytest.approx(want[1], rel=0, abs=tol)
            assert (got[2], got[3]) == (want[2], want[3])
            for key, value in want[4].items():
                if isinstance(value, (bool, int, np.bool_)):
                    assert got[4][key] == value, key
                else:
                    np.testing.assert_allclose(got[4][key], value, rtol=0, atol=tol, err_msg=key)
            collisions += want[4]["collision"]
            if want[2] or want[3]:
                break
        _, info = env.reset()
        episodes += 1
    return episodes, collisions


def _lane_change_reference(env, deviation=None):
    low, high = env.action_space.low, env.action_space.high

    def episode(info, actions):
        sc = info["scenario"]
        ev, tv = sc.ev_initial_state, sc.tv_initial_state
        for k, u in enumerate(actions):
            ev, tv, *out = _reference_step(sc, ev, tv, u, low, high, k, deviation)
            yield out
            if out[2] or out[3]:
                return

    return episode


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("drivestyle/LaneChange-v0", {}),
        ("drivestyle/LaneChangeRandom-v0", {}),
        ("drivestyle/LaneChange-v0", {"tv_lane": 0, "tv_speed": 40.0, "ev_speed": 20.0}),
    ],
    ids=["paper", "random", "collisions"],
)
def test_the_step_equals_the_reference_implementation(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(3)
    sp = env.action_space
    # in range, gentle (full episodes) and out of range (clipped) actions
    actions = np.concatenate(
        [
            rng.uniform(sp.low, sp.high, (150, 2)),
            rng.uniform(sp.low, sp.high, (150, 2)) * [1.0, 0.1],
            rng.uniform(2 * sp.low, 2 * sp.high, (50, 2)),
        ]
    )
    episodes, collisions = _assert_matches_reference(env, 5, actions, _lane_change_reference(env))
    assert episodes >= 8
    assert collisions >= 1 or "tv_lane" not in kwargs


def test_a_deviating_tv_equals_the_reference_implementation():
    from drivestyle.envs.lane_change import TVDeviation

    deviation = TVDeviation(t_start=0.4, accel=-3.0, duration=1.0)
    env = LaneChangeEnv(tv_deviation=deviation)
    actions = np.tile([[0.5, 0.01], [-0.2, -0.005]], (40, 1))
    _assert_matches_reference(env, 0, actions, _lane_change_reference(env, deviation))
