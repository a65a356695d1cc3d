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
    IDMParams,
    TrafficEnv,
    TrafficRanges,
    TrafficScene,
    VehicleSpec,
    idm_acceleration,
    idm_accelerations,
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


def test_the_array_idm_is_the_scalar_one_elementwise():
    rng = np.random.default_rng(0)
    v, v0 = rng.uniform(-1, 35, 200), rng.uniform(1, 35, 200)
    gap, v_leader = rng.uniform(-5, 80, 200), rng.uniform(0, 35, 200)
    gap[::4] = np.nan  # no leader
    p = IDMParams(a_max=1.3, b=2.1, s0=1.5, time_gap=0.9)
    scalar = [idm_acceleration(a, b, None if np.isnan(g) else g, c, p)
              for a, b, g, c in zip(v, v0, gap, v_leader, strict=True)]  # fmt: skip
    assert np.allclose(idm_accelerations(v, v0, gap, v_leader, p), scalar, rtol=1e-13, atol=0)
    led = ~np.isnan(gap)  # behind a leader braking is bounded, as in the scalar function
    assert idm_accelerations(v, v0, gap, v_leader, p)[led].min() == -p.max_decel


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


# ------------------------------------------------------------ the fast step equals the reference
def _reference_episode(env, scenario, scene, actions):
    """The traffic env's steps as first written (numpy arrays throughout): the reference."""
    from drivestyle.envs.dynamics import rk4_step
    from drivestyle.envs.safety import elliptical_index, rectangles_overlap, vehicle_corners

    sc = scenario
    low, high = env.action_space.low, env.action_space.high
    ev, vehicles = sc.ev_initial_state, scene.initial_states()
    desired = vehicles[:, 3].copy()
    for k, u in enumerate(actions):
        u_clip = np.clip(u, low, high)
        new_ev = rk4_step(ev, u_clip, sc.dt, sc.l_f, sc.l_r)
        new_ev[3] = np.clip(new_ev[3], 0.0, sc.v_max)
        old = vehicles.copy()
        new = old.copy()
        lane_of = np.clip(old[:, 1] // sc.lane_width, 0, sc.n_lanes - 1)
        ev_lane = int(np.clip(ev[1] // sc.lane_width, 0, sc.n_lanes - 1))
        for j, behaviour in enumerate(scene.behaviours):
            x, y, phi, v = old[j]
            if behaviour == "idm":
                ahead = [
                    (old[i, 0], old[i, 3])
                    for i in range(len(old))
                    if i != j and lane_of[i] == lane_of[j] and old[i, 0] > x
                ]
                if ev_lane == lane_of[j] and ev[0] > x:
                    ahead.append((ev[0], ev[3]))
                leader = min(ahead, default=None)
                gap = None if leader is None else leader[0] - x - sc.vehicle_length
                a = idm_acceleration(v, desired[j], gap, 0.0 if leader is None else leader[1])
                v_new = max(v + a * sc.dt, 0.0)
                x += 0.5 * (v + v_new) * sc.dt
                new[j] = [x, y, 0.0, v_new]
            else:
                new[j] = [x + v * np.cos(phi) * sc.dt, y + v * np.sin(phi) * sc.dt, phi, v]
        ev, vehicles = new_ev, new
        tv = vehicles[0]
        s_e = float(elliptical_index(ev[0] - tv[0], ev[1] - tv[1], sc.l_a, sc.l_b))
        corners = vehicle_corners(ev, sc.vehicle_length, sc.vehicle_width)
        collision = any(
            rectangles_overlap(corners, vehicle_corners(s, sc.vehicle_length, sc.vehicle_width))
            for s in vehicles
        )
        off_road = not (0.0 <= ev[1] <= sc.road_width)
        terminated = collision or off_road
        truncated = (not terminated) and k + 1 >= sc.n_steps
        lane_err = (ev[1] - sc.y_ref) / sc.lane_width
        speed_err = (ev[3] - sc.v_ref) / 10.0
        reward = float(-(lane_err**2 + speed_err**2) - 10.0 * terminated)
        s_all = elliptical_index(ev[0] - vehicles[:, 0], ev[1] - vehicles[:, 1], sc.l_a, sc.l_b)
        info = {
            "t": (k + 1) * sc.dt,
            "s_e": s_e,
            "d_k": s_e - 1.0,
            "collision": collision,
            "off_road": off_road,
            "lane_index": int(np.clip(ev[1] // sc.lane_width, 0, sc.n_lanes - 1)),
            "action_clipped": bool(np.any(u_clip != u)),
            "action": u_clip,
            "s_e_min": float(np.min(s_all)),
            "vehicles": vehicles.copy(),
        }
        obs = np.zeros(4 + 5 * OBS_SLOTS)
        obs[:4] = ev
        dist = np.hypot(*(vehicles[:, :2] - ev[:2]).T)
        for slot, j in enumerate(np.argsort(dist, kind="stable")[:OBS_SLOTS]):
            obs[4 + 5 * slot] = 1.0
            obs[5 + 5 * slot : 9 + 5 * slot] = vehicles[j]
        yield obs, reward, terminated, truncated, info
        if terminated or truncated:
            return


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("drivestyle/Traffic-v0", {}),
        ("drivestyle/TrafficRandom-v0", {}),
        (
            "drivestyle/Traffic-v0",
            {
                "others": [
                    VehicleSpec(lane=0, gap=25.0, speed=10.0, behaviour="constant"),
                    VehicleSpec(lane=1, gap=15.0, speed=24.0, behaviour="idm"),
                    VehicleSpec(lane=1, gap=45.0, speed=20.0, behaviour="idm"),
                    VehicleSpec(lane=2, gap=-10.0, speed=30.0, behaviour="idm"),
                ]
            },
        ),
    ],
    ids=["default", "random", "dense"],
)
def test_the_traffic_step_equals_the_reference_implementation(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(4)
    sp = env.action_space
    # in range, gentle (full episodes) and out of range (clipped) actions
    actions = np.concatenate(
        [
            rng.uniform(sp.low, sp.high, (150, 2)),
            rng.uniform(sp.low, sp.high, (150, 2)) * [1.0, 0.1],
            rng.uniform(2 * sp.low, 2 * sp.high, (50, 2)),
        ]
    )
    _, info = env.reset(seed=2)
    n, episodes, collisions = 0, 0, 0
    while n < len(actions):
        for want in _reference_episode(env, info["scenario"], info["scene"], actions[n:]):
            got = env.step(actions[n])
            n += 1
            np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-9)
            assert got[1] == pytest.approx(want[1], rel=0, abs=1e-9)
            assert (got[2], got[3]) == (want[2], want[3])
            for key, value in want[4].items():
                if isinstance(value, (bool, int)):
                    assert got[4][key] == value, key
                else:
                    np.testing.assert_allclose(got[4][key], value, rtol=0, atol=1e-9, err_msg=key)
            collisions += want[4]["collision"]
            if want[2] or want[3]:
                break
        _, info = env.reset()
        episodes += 1
    assert episodes >= 8
    if "others" in kwargs:
        assert collisions >= 1
