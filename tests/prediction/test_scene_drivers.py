"""Style drivers of a recorded scene (prediction/scene_drivers.py) and Recorded-v0's posterior=."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.recorded_scene import RecordedSceneEnv, drive_style
from drivestyle.envs.rollout import run_episode
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.stochastic import StochasticStyle
from drivestyle.prediction.scene_drivers import (
    StyleDriver,
    attended,
    planning_scenario,
    scene_styles,
    style_drivers,
)

ID = "drivestyle/Recorded-v0"
START = 5
"""The synthetic scene's default start (its observed part: 1 s)."""


def _inputs(drivers: dict, states: np.ndarray, t0: float, dt: float, steps: int = 3) -> list:
    """Each driver's inputs at ``steps`` consecutive calls on the same states."""
    return [
        [drivers[j](j, t0 + k * dt, states).tolist() for k in range(steps)] for j in sorted(drivers)
    ]


def test_the_drivers_read_nothing_after_the_start(recorded_scene, tiny_posterior):
    posterior, _ = tiny_posterior
    drivers = style_drivers(posterior, recorded_scene, START)
    assert sorted(drivers) == [0, 1, 2]  # vehicle 3 enters at sample 10: no past, no driver
    # another future: every state after the start moved, the inputs too
    future = np.arange(recorded_scene.n) > START
    ev, tv, others = (a.copy() for a in (recorded_scene.ev, recorded_scene.tv,
                                         recorded_scene.others))  # fmt: skip
    ev[future, :2] += [7.0, 1.3]
    tv[future, 3] += 4.0
    assert others is not None
    others[future, :, 0] -= 11.0
    u = recorded_scene.u.copy()
    u[START:] *= -1.0
    other = dataclasses.replace(recorded_scene, ev=ev, tv=tv, others=others, u=u)
    again = style_drivers(posterior, other, START)
    assert [d.style for d in again.values()] == [d.style for d in drivers.values()]
    assert [d.y_ref for d in again.values()] == [d.y_ref for d in drivers.values()]
    sc = recorded_scene.scenario
    now = np.concatenate([recorded_scene.ev[START, None], recorded_scene.vehicles[START]])
    now[3] = np.nan  # not yet in the scene
    t0 = float(recorded_scene.t[START])
    assert _inputs(again, now, t0, sc.dt) == _inputs(drivers, now, t0, sc.dt)


def test_the_start_must_leave_a_past_to_identify(recorded_scene, tiny_posterior):
    posterior, _ = tiny_posterior
    with pytest.raises(ValueError, match=r"sample 2 or later .*got 1"):
        style_drivers(posterior, recorded_scene, 1)
    with pytest.raises(ValueError, match="attend must be one of"):
        style_drivers(posterior, recorded_scene, START, attend="nobody")


def _follower_scene(n: int = 51) -> Demonstration:
    """The EV at 8 m/s in lane 0; the TV 30 m behind it in the same lane at 14 m/s."""
    dt = 0.2
    sc = ScenarioConfig(ev_x=30.0, ev_speed=8.0, tv_lane=0, tv_gap=-30.0, tv_speed=14.0,
                        v_ref=8.0, horizon_s=(n - 1) * dt, check_start=False)  # fmt: skip
    t = np.arange(n) * dt
    y = sc.lane_centres[0]
    ev = np.column_stack([30.0 + 8.0 * t, np.full(n, y), np.zeros(n), np.full(n, 8.0)])
    tv = np.column_stack([14.0 * t, np.full(n, y), np.zeros(n), np.full(n, 14.0)])
    meta = {"scenario": sc.to_dict(), "episode_id": "follower", "observed_until_s": 1.0}
    return Demonstration(t=t, ev=ev, tv=tv, u=np.zeros((n - 1, 2)), meta=meta, origin="recorded")


def test_a_style_driver_behind_a_slower_leader_keeps_its_distance():
    demo = _follower_scene()
    sc = demo.scenario
    style = StochasticStyle(risk=0.7, v_ref=14.0, time_gap=1.0, min_gap=5.0)
    driver = StyleDriver(1, style, sc.lane_centres[0], sc)
    env = RecordedSceneEnv(demo, others="style", drivers={1: driver}, start=5)
    episode = run_episode(env, lambda e, o: np.zeros(2))  # the leader keeps 8 m/s
    states = np.stack([i["states"] for i in (episode.reset_info, *episode.infos)])
    gap = states[:, 0, 0] - states[:, 1, 0]
    assert episode.n_steps == 45 and driver.plans == 45 and driver.failures == 0
    assert gap.min() > sc.vehicle_length + style.min_gap  # never closer than its region's s_0
    assert states[-1, 1, 3] == pytest.approx(8.0, abs=0.5)  # it follows at the leader's speed
    assert np.abs(states[:, 1, 1] - sc.lane_centres[0]).max() < 0.1  # in its lane


def test_a_vehicle_off_the_planners_road_plans_as_in_its_middle_lane():
    sc = ScenarioConfig()
    w = sc.lane_width
    style = StochasticStyle(risk=0.8, v_ref=20.0, time_gap=1.0, min_gap=5.0)
    inside = np.array([[100.0, 1.5 * w, 0.0, 18.0], [130.0, 1.5 * w, 0.0, 15.0]])
    outside = inside - np.array([0.0, 2 * w, 0.0, 0.0])  # the same scene two lanes right
    a = StyleDriver(0, style, 1.5 * w, sc)(0, 0.0, inside)
    b = StyleDriver(0, style, -0.5 * w, sc)(0, 0.0, outside)
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert planning_scenario(sc).phi_max == pytest.approx(0.3)
    assert planning_scenario(sc).delta_max == sc.delta_max  # the env's steering bound


def test_a_driver_answers_for_its_own_vehicle_only():
    sc = ScenarioConfig()
    driver = StyleDriver(1, StochasticStyle(), sc.lane_centres[0], sc)
    states = np.array([[0.0, 1.9, 0.0, 20.0], [50.0, 1.9, 0.0, 20.0]])
    with pytest.raises(ValueError, match="driver of vehicle 1 was asked for vehicle 0"):
        driver(0, 0.0, states)


def test_whom_a_driver_plans_around():
    sc = ScenarioConfig()
    w = sc.lane_width
    style = StochasticStyle(risk=0.9, v_ref=15.0, time_gap=1.0, min_gap=5.0)
    me = [100.0, 0.5 * w, 0.0, 15.0]
    # a faster follower 25 m behind, a neighbour 30 m behind in the next lane, one 12 m ahead
    # in the next lane: the TV uncertainty of each grows into its lane
    states = np.array([me, [75.0, 0.5 * w, 0.0, 18.0], [70.0, 1.5 * w, 0.0, 15.0],
                       [112.0, 1.5 * w, 0.0, 15.0]])  # fmt: skip

    def first(attend, rows):
        return StyleDriver(0, style, 0.5 * w, sc, attend=attend)(0, 0.0, states[rows])

    alone = first("all", [0])
    behind = [0, 1, 2]
    np.testing.assert_allclose(first("ahead", behind), alone, atol=1e-9)  # the joint rule
    np.testing.assert_allclose(first("lanes", behind), alone, atol=1e-9)
    assert first("all", behind)[0] > alone[0] + 3.0  # it escapes them at full throttle
    every = [0, 1, 2, 3]
    assert first("ahead", every)[0] < alone[0] - 1.0  # it brakes for the next lane's car
    np.testing.assert_allclose(first("lanes", every), alone, atol=1e-9)  # not its lane
    np.testing.assert_array_equal(attended(states, 0, 1.5 * w, w, "lanes"), [2, 3])  # changing


def test_the_env_with_style_drivers_passes_both_checkers(recorded_scene, tiny_posterior):
    _, path = tiny_posterior
    env = gym.make(ID, episode=recorded_scene, others="style", posterior=str(path))
    check_env(env.unwrapped)
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(
        gym.make(ID, episode=recorded_scene, others="style", posterior=path).unwrapped
    )
    env = gym.make(ID, episode=recorded_scene, others="style", posterior=str(path))
    episode = run_episode(env, drive_style)
    base = env.unwrapped
    assert sorted(base.drivers) == [0, 1, 2] and episode.n_steps == recorded_scene.n - 1 - START
    assert all(d.plans == episode.n_steps for d in base.drivers.values())
    # the late vehicle follows its log from its entry
    last = episode.infos[-1]["states"][3]
    np.testing.assert_array_equal(last, recorded_scene.others[-1, 1])


def test_the_envs_posterior_errors_name_it(recorded_scene, tiny_posterior, tmp_path):
    posterior, path = tiny_posterior
    base = {"episode": recorded_scene}
    cases = [
        ({"posterior": path}, ValueError, "posterior= drives the vehicles of others='style'"),
        ({"others": "style", "posterior": path, "drivers": {}}, ValueError, "contradict"),
        ({"others": "style", "posterior": tmp_path / "no.npz"}, FileNotFoundError,
         "posterior= .*no.npz: no such estimator file"),
        ({"others": "style", "posterior": 3}, ValueError, "posterior= must be an amortized"),
    ]  # fmt: skip
    for kwargs, exc, match in cases:
        with pytest.raises(exc, match=match) as info:
            gym.make(ID, **base, **kwargs)
        assert "\n" not in str(info.value)
    env = RecordedSceneEnv(recorded_scene, others="style", posterior=posterior)
    assert isinstance(scene_styles(posterior)(recorded_scene, START)[0], StyleDriver)
    with pytest.raises(ValueError, match="sample 2 or later"):
        env.reset(options={"start": 1})
    env = RecordedSceneEnv(recorded_scene, others="log")
    with pytest.raises(ValueError, match="the agent \\(vehicle 0\\) has no driver"):
        drive_style(env, env.reset()[0])
