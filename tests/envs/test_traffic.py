"""The traffic env: registered ids, observation layout, IDM, collisions, scene validation."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import drivestyle.envs  # noqa: F401  (registers the ids)
from drivestyle.envs.traffic import (
    DEFAULT_TRAFFIC,
    IDM,
    OBS_SLOTS,
    TrafficEnv,
    TrafficRanges,
    TrafficScene,
    VehicleSpec,
    idm_acceleration,
    parse_traffic_observation,
)


@pytest.mark.parametrize("env_id", ["drivestyle/Traffic-v0", "drivestyle/TrafficRandom-v0"])
def test_check_env_passes(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert obs.shape == (4 + 5 * OBS_SLOTS,)
    assert info["vehicles"].shape == (4, 4)


def test_observation_lists_the_nearest_vehicles_with_presence_flags():
    env = TrafficEnv()
    obs, info = env.reset()
    ev, present = parse_traffic_observation(obs)
    np.testing.assert_array_equal(ev, DEFAULT_TRAFFIC.base.ev_initial_state)
    assert len(present) == 4 and np.all(obs[4 + 5 * 4 :: 5] == 0)  # two empty slots
    dist = np.hypot(*(present[:, :2] - ev[:2]).T)
    assert np.all(np.diff(dist) >= 0)
    assert {tuple(r) for r in present} == {tuple(r) for r in info["vehicles"]}


def test_idm_closed_form():
    assert idm_acceleration(20.0, 30.0, None, 0.0) == pytest.approx(IDM.a_max * (1 - (2 / 3) ** 4))
    s_star = IDM.s0 + 25.0 * IDM.time_gap  # equal speeds: no approach term
    a = idm_acceleration(25.0, 25.0, 40.0, 25.0)
    assert a == pytest.approx(IDM.a_max * (0.0 - (s_star / 40.0) ** 2))


def test_an_idm_leader_brakes_behind_a_slow_vehicle_and_constant_ones_do_not():
    slow_ahead = (
        VehicleSpec(lane=2, gap=30.0, speed=30.0, behaviour="idm"),
        VehicleSpec(lane=2, gap=50.0, speed=15.0, behaviour="constant"),
    )
    env = TrafficEnv(others=slow_ahead)
    env.reset()
    for _ in range(10):
        env.step(np.zeros(2))
    assert env.vehicles[1, 3] < 30.0 - 1.0  # braked
    assert env.vehicles[2, 3] == 15.0


def test_collision_with_any_vehicle_terminates():
    env = TrafficEnv(others=[VehicleSpec(lane=0, gap=20.0, speed=5.0, behaviour="constant")])
    env.reset()
    for _ in range(30):
        _, _, terminated, _, info = env.step(np.array([0.0, 0.0]))
        if terminated:
            break
    assert terminated and info["collision"]


def test_bad_scenes_are_refused():
    with pytest.raises(ValueError, match="inside the EV's safety ellipse"):
        TrafficScene(others=(VehicleSpec(lane=0, gap=8.0, speed=25.0),))
    with pytest.raises(ValueError, match="lane 5 does not exist"):
        TrafficScene(others=(VehicleSpec(lane=5, gap=80.0, speed=25.0),))
    with pytest.raises(ValueError, match="behaviour"):
        VehicleSpec(lane=1, gap=50.0, speed=25.0, behaviour="aggressive")
    with pytest.raises(ValueError, match="speed"):
        VehicleSpec(lane=1, gap=50.0, speed=float("nan"))


def test_random_scenes_follow_the_seed_and_round_trip():
    a = TrafficRanges().sample(np.random.default_rng(4))
    b = TrafficRanges().sample(np.random.default_rng(4))
    assert a == b
    assert TrafficScene.from_dict(a.to_dict()) == a


def test_traffic_without_other_vehicles_drives_exactly_as_the_single_tv_env():
    # the single-TV env is the reference: traffic must add vehicles, not change the physics
    single = gym.make("drivestyle/LaneChange-v0")
    lone = TrafficEnv(others=[])
    obs_s, _ = single.reset(seed=0)
    obs_t, info_t = lone.reset(seed=0)
    np.testing.assert_array_equal(obs_s[:4], obs_t[:4])
    np.testing.assert_array_equal(obs_s[4:], info_t["vehicles"][0])
    for k in range(12):
        action = np.array([0.5 * np.sin(k), 0.01 * np.cos(k)])
        obs_s, r_s, *_ = single.step(action)
        obs_t, r_t, _, _, info_t = lone.step(action)
        np.testing.assert_array_equal(obs_s[:4], obs_t[:4])
        np.testing.assert_array_equal(obs_s[4:], info_t["vehicles"][0])
        assert r_s == r_t
    assert obs_s.shape == (8,)


def test_rendering_draws_every_vehicle():
    env = TrafficEnv(render_mode="rgb_array")
    env.reset()
    with_traffic = env.render()
    lone = TrafficEnv(render_mode="rgb_array", others=[])
    lone.reset()
    alone = lone.render()
    # three 5 m x 2 m vehicles at 5.5 px/m are a few hundred pixels
    assert np.any(with_traffic != alone, axis=-1).sum() > 300
    env.close()
    lone.close()
