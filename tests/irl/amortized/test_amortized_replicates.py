"""A replicate of an episode: the driver of θ in the episode's scene, from its start."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.amortized.replicates import planned_vehicles, replicate, scene_of, truth_draw
from drivestyle.irl.amortized.simulations import parameters_of
from drivestyle.irl.driver.stochastic_prior import StochasticPrior, simulate_params
from drivestyle.recorded.real_data import RECORDED_DELTA_MAX, RECORDED_PHI_MAX

SHORT = StochasticPrior(horizon_s=4.0)


@pytest.fixture(scope="module")
def episode():
    params = SHORT.draw(1, 3)[0]
    return params, simulate_params(params, 3)


def test_a_replicate_drives_in_the_episodes_scene_from_its_start(episode):
    params, demo = episode
    view, sc = scene_of(demo)
    assert view is demo and sc == demo.scenario  # a simulated episode as it is
    rep = replicate(parameters_of(params), view, sc, 7, 0.0)
    np.testing.assert_array_equal(rep.vehicles, demo.vehicles)
    np.testing.assert_array_equal(rep.ev[0], demo.ev[0])
    np.testing.assert_array_equal(rep.observed, np.ones((demo.vehicles.shape[1], demo.n), bool))
    assert rep.meta["stochastic_style"]["v_ref"] == pytest.approx(params.style.v_ref)
    again = replicate(parameters_of(params), view, sc, 7, 0.0)
    np.testing.assert_array_equal(again.ev, rep.ev)  # deterministic given the seed


def test_a_noisy_episodes_truth_is_drawn_as_its_states_less_the_trackers_error(episode):
    _, demo = episode
    sc = demo.scenario
    start, vehicles = truth_draw(demo, sc, 0.0, np.random.default_rng(0))
    np.testing.assert_array_equal(start, demo.ev[0])
    np.testing.assert_array_equal(vehicles, demo.vehicles)
    a, va = truth_draw(demo, sc, 0.2, np.random.default_rng(0))
    b, _ = truth_draw(demo, sc, 0.2, np.random.default_rng(1))
    again, v_again = truth_draw(demo, sc, 0.2, np.random.default_rng(0))
    np.testing.assert_array_equal(a, again)
    np.testing.assert_array_equal(va, v_again)
    assert not np.array_equal(a, b) and np.all(np.abs(a - demo.ev[0])[:2] < 1.0)
    assert abs(a[2]) <= sc.phi_max
    assert 0 < np.abs(va[:, 0, :2] - demo.tv[:, :2]).max() < 1.0  # the TV moved, by the noise
    np.testing.assert_array_equal(va[:, 1:], demo.vehicles[:, 1:])  # the others are exact


def test_a_recorded_episode_is_replicated_under_the_bounds_identification_uses(episode):
    params, demo = episode
    ev = demo.ev.copy()
    ev[5:8, 2] = 0.2  # a heading the scenario's bound does not allow: recorded bounds
    recorded = replace(demo, ev=ev, origin="recorded", meta={**demo.meta, "episode_id": "r"})
    view, sc = scene_of(recorded)
    assert (sc.phi_max, sc.delta_max) == (RECORDED_PHI_MAX, RECORDED_DELTA_MAX)
    rep = replicate(parameters_of(params), view, sc, 0, 0.0)
    assert (rep.scenario.phi_max, rep.scenario.delta_max) == (RECORDED_PHI_MAX, RECORDED_DELTA_MAX)


def test_a_replicate_drives_under_the_priors_speed_limit_of_its_driver(episode):
    params, demo = episode
    view, sc = scene_of(demo)
    theta = parameters_of(params)
    assert replicate(theta, view, sc, 0, 0.0).scenario == sc  # its own driver: its own scene
    fast = theta.copy()
    fast[1] = 1.3  # the prior's fastest desired speed
    open_road = replace(sc, v_max=70.0)  # a recorded scene's bound
    limit = replicate(fast, view, open_road, 0, 0.0).scenario.v_max
    assert limit == pytest.approx(SHORT.speed_limit(1.3 * sc.ev_speed, sc.ev_speed))
    assert limit < 70.0


def test_the_planner_sees_velocities_fitted_to_the_positions():
    t = np.arange(41) * 0.2
    vehicles = np.zeros((41, 2, 4))
    vehicles[:, 0, 0] = 10 + 20 * t  # constant velocity, its heading and speed recorded wrong
    vehicles[:, 0, 2], vehicles[:, 0, 3] = 0.05, 18.0
    vehicles[:, 1, 0] = 5 + 3 * t + 0.5 * t**2  # accelerating at 1 m/s², drifting left
    vehicles[:, 1, 1] = 2 + 0.5 * t
    planned = planned_vehicles(vehicles, 0.2)
    np.testing.assert_array_equal(planned[..., :2], vehicles[..., :2])  # positions kept
    np.testing.assert_allclose(planned[:, 0, 2:], np.tile([0.0, 20.0], (41, 1)), atol=1e-9)
    speed = np.hypot(3 + t, 0.5)
    inside = slice(5, -5)  # a full ±1 s window: exact at constant acceleration
    np.testing.assert_allclose(planned[inside, 1, 3], speed[inside], rtol=1e-9)
    assert np.all(np.abs(planned[:, 1, 3] - speed) <= 0.5 * 1.0 + 1e-9)
