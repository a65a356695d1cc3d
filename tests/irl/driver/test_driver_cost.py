"""The driver style's per-step cost as a reward: hand computations, look-ahead, float path."""

import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from drivestyle.envs import LaneChangeEnv


def test_driver_step_cost_equals_a_hand_computation():
    from drivestyle.envs.scenario import get_scenario
    from drivestyle.irl.driver.driver_cost import driver_step_cost

    sc = get_scenario("paper")
    la, lb = sc.l_a, sc.l_b
    # EV 0.5 l_a behind and 0.5 l_b beside the TV: inside the ellipse (‖z̄‖ = √0.5)
    ev = np.array([100.0, sc.y_bounds[0] - 0.2, 1.5 * sc.phi_max, 1.1 * sc.v_max])
    tv = np.array([[100.0 + 0.5 * la, sc.y_bounds[0] - 0.2 + 0.5 * lb, 0.0, 20.0]])
    w = np.array([2.0, 3.0, 0.5, 1.0, 7.0])
    u = np.array([-1.5, 0.01])
    sigma = np.array([[4.0, 0.0], [0.0, 1.0]])
    terms = driver_step_cost(ev, u, tv, w, 5.0, 25.0, 1.0, sigma, sc)
    y, phi, v = ev[1:]
    stage = [2 * (y - 5) ** 2, 3 * phi**2, 0.5 * (v - 25) ** 2, 1.5**2, 7 * 0.01**2]
    # g = ‖z‖ − 1 − κ sqrt(zᵀ S z)/‖z‖ with z = (−0.5, −0.5), S = diag(4/l_a², 1/l_b²)
    norm = np.sqrt(0.5)
    g = norm - 1 - np.sqrt(0.25 * 4 / la**2 + 0.25 / lb**2) / norm
    bounds = 0.2 / sc.lane_width + 0.5 + 0.1
    expected = [*stage, -g, 1 - norm, bounds]
    np.testing.assert_allclose(terms, expected, rtol=1e-12)
    # outside every constraint: no penalty
    far = np.array([[0.0, 0.0, 0.0, 20.0]])
    ok = driver_step_cost([100.0, 5.0, 0.0, 25.0], u, far, w, 5.0, 25.0, 1.0, sigma, sc)
    np.testing.assert_allclose(ok[5:], 0.0)


def test_driver_cost_reward_is_the_scaled_negative_cost(tmp_path):
    from drivestyle.irl.driver.driver_cost import (
        DriverCostConfig,
        DriverCostReward,
        driver_step_cost,
    )
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY

    style = DriverStyle((0.04, 400.0, 0.04, 1.0, 2500.0), risk=0.8)
    env = DriverCostReward(LaneChangeEnv(), style, DriverCostConfig(chance_weight=3.0))
    obs, _ = env.reset(seed=0)
    sc = env.unwrapped.scenario
    u = np.array([0.5, 0.01])
    obs, r, _, _, info = env.step(u)
    sigma = np.diag([PAPER_TV_UNCERTAINTY.sigma_x0**2, PAPER_TV_UNCERTAINTY.sigma_y0**2])
    terms = driver_step_cost(
        obs[:4], u, obs[None, 4:8], style.weights, sc.y_ref, sc.v_ref, style.kappa, sigma, sc
    )
    expected = -(terms[:5].sum() / (0.04 * sc.lane_width**2) + 3.0 * terms[5] + 100.0 * terms[6])
    assert r == pytest.approx(expected - 10.0 * terms[7], rel=1e-12)
    np.testing.assert_array_equal(info["style_feature_increment"], terms)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check_env(DriverCostReward(LaneChangeEnv(randomize=True), style))
    with pytest.raises(ValueError, match="chance_weight"):
        DriverCostConfig(chance_weight=-1.0)


def test_driver_step_cost_look_ahead_takes_the_worst_extrapolated_stage():
    from drivestyle.envs.scenario import get_scenario
    from drivestyle.irl.driver.driver_cost import driver_step_cost
    from drivestyle.planning.chance import chance_margin

    sc = get_scenario("paper")
    w = np.ones(5)
    sigma = np.array([np.eye(2) * s for s in (1.0, 4.0, 9.0)])  # Σ_0, Σ_1, Σ_2
    # the TV 20 m behind in the EV's lane, 10 m/s faster: closes 10 T_s metres per stage
    ev = np.array([100.0, 5.0, 0.0, 20.0])
    tv = np.array([[80.0, 5.0, 0.0, 30.0]])
    got = driver_step_cost(ev, np.zeros(2), tv, w, 5.0, 20.0, 1.0, sigma, sc)[5]
    stages = [
        chance_margin(20.0 - 10.0 * sc.dt * j, 0.0, s, 0.0, s, sc.l_a, sc.l_b, 1.0)
        for j, s in enumerate((1.0, 4.0, 9.0))
    ]
    assert got == pytest.approx(-min(stages), rel=1e-12) and got > 0.1
    assert min(stages) == stages[2] < 0 < stages[0]  # only the look-ahead sees the TV close in
    only_now = driver_step_cost(ev, np.zeros(2), tv, w, 5.0, 20.0, 1.0, sigma[0], sc)[5]
    assert only_now == 0.0


@pytest.mark.parametrize("look_ahead", [0, 3])
@pytest.mark.parametrize("m", [1, 4])
def test_the_driver_cost_step_equals_driver_step_cost(look_ahead, m):
    from drivestyle.envs.scenario import get_scenario
    from drivestyle.irl.driver.driver_cost import DriverCost, DriverCostConfig, driver_step_cost
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY, tv_covariance

    sc = get_scenario("paper")
    style = DriverStyle(weights=(0.2, 50.0, 0.2, 1.0, 10.0), risk=0.7)
    cost = DriverCost(style, DriverCostConfig(look_ahead=look_ahead))
    rng = np.random.default_rng(m + 10 * look_ahead)
    cost.reset(sc, sc.ev_initial_state, sc.tv_initial_state)
    sigma = tv_covariance(PAPER_TV_UNCERTAINTY, sc.dt, look_ahead)
    for _ in range(200):
        # the EV near the vehicles (inside their ellipses at times), off the road or too fast
        ev = np.array([100.0, *rng.uniform([-1, -0.1, 20], [17, 0.1, 75])])
        veh = np.column_stack(
            [rng.uniform(80, 120, m), rng.uniform(0, 16, m), rng.uniform(-0.05, 0.05, m),
             rng.uniform(15, 35, m)]
        )  # fmt: skip
        u = rng.uniform([-9, -0.05], [6, 0.05])
        r, terms = cost.step(u, ev, veh[0], sc.dt, veh[1:] if m > 1 else None)
        want = driver_step_cost(ev, u, veh, style.weights, sc.y_ref, sc.v_ref, style.kappa,
                                sigma, sc)  # fmt: skip
        np.testing.assert_allclose(terms, want, rtol=1e-12, atol=1e-15)
        expected = -(want[:5].sum() / cost.scale + cost.penalties @ want[5:])
        assert r == pytest.approx(expected, rel=1e-12)
