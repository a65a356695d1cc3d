"""The stochastic driver: its AR(1) deviation, its style, its closed loop and its prior."""

import dataclasses
import math

import numpy as np
import pytest

from drivestyle.envs.plausibility import check_plausible
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.driver.driver_style import closed_loop, expert_style
from drivestyle.irl.driver.stochastic import (
    StochasticStyle,
    StochasticStyleError,
    ar1_deviation,
    closed_loop_stochastic,
    constant_velocity,
    lane_targets,
    simulate_episode,
)
from drivestyle.irl.driver.stochastic_prior import EpisodeParams, StochasticPrior
from drivestyle.irl.driver.style_planner import planner_for
from drivestyle.planning.description import SMPCConfig


# ---------------------------------------------------------------------------- AR(1)
def _chains(k, n, dt, sigma, tau, seed):
    rng = np.random.default_rng(seed)
    return np.stack([ar1_deviation(n, dt, sigma, tau, rng) for _ in range(k)])


def test_ar1_is_stationary_with_its_variance_and_lag_one_correlation():
    sigma, tau, dt = (0.5, 0.004), 1.0, 0.2
    e = _chains(400, 40, dt, sigma, tau, seed=7)  # (chains, samples, 2)
    rho = math.exp(-dt / tau)
    for j, s in enumerate(sigma):
        # every sample, the first included, has variance σ² (stationary from e_0)
        var = e[:, :, j].var(axis=0) / s**2
        assert abs(var[0] - 1) < 0.2 and abs(var[-1] - 1) < 0.2
        assert abs(var.mean() - 1) < 0.1
        lag1 = np.mean(e[:, 1:, j] * e[:, :-1, j]) / s**2
        assert lag1 == pytest.approx(rho, abs=0.05)
        lag5 = np.mean(e[:, 5:, j] * e[:, :-5, j]) / s**2
        assert lag5 == pytest.approx(rho**5, abs=0.05)


def test_ar1_with_no_correlation_time_is_white_and_with_no_scale_zero():
    e = _chains(200, 40, 0.2, (1.0, 1.0), 0.0, seed=3)
    assert abs(np.mean(e[:, 1:] * e[:, :-1])) < 0.03
    assert np.mean(e**2) == pytest.approx(1.0, abs=0.05)
    short = _chains(200, 40, 0.2, (1.0, 1.0), 1e-3, seed=3)  # τ → 0: the white limit
    assert np.allclose(short, e)
    assert not ar1_deviation(30, 0.2, (0.0, 0.0), 1.0, np.random.default_rng(0)).any()
    assert ar1_deviation(0, 0.2, (1.0, 1.0), 1.0, np.random.default_rng(0)).shape == (0, 2)


@pytest.mark.parametrize(
    "args, match",
    [((5, 0.2, (-1.0, 0.0), 1.0), "sigma"), ((5, 0.0, (1.0, 0.0), 1.0), "dt"),
     ((5, 0.2, (1.0, 0.0), -1.0), "tau"), ((-1, 0.2, (1.0, 0.0), 1.0), "n"),
     ((5, 0.2, (1.0,), 1.0), "sigma")],
)  # fmt: skip
def test_ar1_refuses_bad_arguments_in_one_line(args, match):
    with pytest.raises(ValueError, match=match) as info:
        ar1_deviation(*args, np.random.default_rng(0))
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------- the style
@pytest.mark.parametrize(
    "fields, name",
    [({"risk": 1.2}, "risk"), ({"lateral": 0.0}, "lateral"), ({"onset": -1.0}, "onset"),
     ({"sigma_a": -0.1}, "sigma_a"), ({"sigma_delta": 1.0}, "sigma_delta"),
     ({"tau": -1.0}, "tau"), ({"time_gap": 9.0}, "time_gap"), ({"min_gap": 0.1}, "min_gap"),
     ({"v_ref": 0.0}, "v_ref"), ({"weights": (1.0, 2.0)}, "weights"),
     ({"risk": True}, "risk")],
)  # fmt: skip
def test_a_stochastic_style_refuses_a_bad_parameter_in_one_line(fields, name):
    with pytest.raises(StochasticStyleError, match=name) as info:
        StochasticStyle(**fields)
    assert "\n" not in str(info.value)


def test_the_style_gives_the_planner_its_parameters_and_survives_json():
    style = StochasticStyle(risk=0.8, v_ref=20.0, time_gap=1.2, min_gap=4.0, lateral=2.0,
                            onset=1.0, sigma_a=0.3, sigma_delta=0.002, tau=1.5)  # fmt: skip
    driver = style.driver_style()
    assert driver.weights == (0.4, 50.0, 0.2, 1.0, 10.0)
    assert (driver.risk, driver.v_ref, driver.time_gap, driver.min_gap) == (0.8, 20.0, 1.2, 4.0)
    assert StochasticStyle.from_json(style.to_json()) == style
    with pytest.raises(StochasticStyleError, match="unknown"):
        StochasticStyle.from_json({**style.to_json(), "sigma": 1})
    expert = StochasticStyle.expert()
    assert expert.driver_style() == expert_style(SMPCConfig()) and expert.deterministic


def test_lane_targets_keep_the_own_lane_until_the_onset():
    y = lane_targets(10, 0.5, PAPER.ev_initial_state, PAPER)
    own, target = PAPER.lane_centres[0], PAPER.y_ref
    assert list(y) == [own] * 3 + [target] * 7  # t = 0, 0.2, 0.4 s before t_on = 0.5 s


# ---------------------------------------------------------------------------- closed loop
@pytest.fixture(scope="module")
def paper_vehicles():
    return constant_velocity(PAPER.tv_initial_state[None], PAPER.n_steps + 1, PAPER.dt)


def test_the_member_with_no_deviation_and_no_onset_is_the_planners_closed_loop(paper_vehicles):
    planner = planner_for(PAPER, 10, 1)
    expert = StochasticStyle.expert()
    xs, _, us, failures = closed_loop(expert.driver_style(), PAPER.ev_initial_state,
                                      paper_vehicles, PAPER, planner)  # fmt: skip
    rng = np.random.default_rng(0)
    xi0 = PAPER.ev_initial_state
    xs2, _, us2, failures2 = closed_loop_stochastic(expert, xi0, paper_vehicles, PAPER, planner,
                                                    rng)  # fmt: skip
    assert np.array_equal(xs, xs2) and np.array_equal(us, us2) and failures == failures2 == 0
    assert xs[-1, 1] > PAPER.lane_width  # it changed lane
    demo = simulate_episode(expert, PAPER, seed=5)
    assert np.array_equal(demo.ev, xs) and np.array_equal(demo.u, us)


def test_the_deviation_is_added_to_the_applied_input_and_replanned_from(paper_vehicles):
    planner = planner_for(PAPER, 10, 1)
    style = dataclasses.replace(StochasticStyle.expert(), sigma_a=1.0, sigma_delta=0.004, tau=1.0)
    xs, plans, us, _ = closed_loop_stochastic(style, PAPER.ev_initial_state, paper_vehicles,
                                              PAPER, planner, np.random.default_rng(1))  # fmt: skip
    e = ar1_deviation(PAPER.n_steps, PAPER.dt, style.sigma, style.tau, np.random.default_rng(1))
    planned = np.array([p.w[planner.layout.iu[0]] for p in plans])
    lo, hi = [PAPER.a_min, -PAPER.delta_max], [PAPER.a_max, PAPER.delta_max]
    plan_u = np.clip(planned, lo, hi)
    deviated = np.all(np.abs(us - np.clip(plan_u + e, lo, hi)) < 1e-12, axis=1)
    kept = np.all(np.abs(us - plan_u) < 1e-12, axis=1)
    assert np.all(deviated | kept) and deviated.mean() > 0.5  # the plan rides φ_max early
    # a step keeps the plan's input only where the deviated one would leave the bounds
    y_lo, y_hi = PAPER.y_bounds
    on_road = (y_lo <= xs[:, 1]) & (xs[:, 1] <= y_hi)
    assert np.all(on_road & (np.abs(xs[:, 2]) <= PAPER.phi_max + 1e-6))
    assert np.all(us >= lo) and np.all(us <= hi)


def test_braking_by_the_deviation_stops_the_car_and_never_reverses_it():
    slow = dataclasses.replace(PAPER, ev_speed=1.0, tv_speed=1.0, v_ref=1.0)
    style = StochasticStyle(risk=0.5, sigma_a=3.0, tau=5.0, onset=30.0)
    speeds = np.concatenate([simulate_episode(style, slow, seed=s).ev[:, 3] for s in range(4)])
    assert speeds.min() >= -1e-12 and np.any(speeds < 0.05)


def test_an_episode_is_deterministic_given_its_seed():
    style = StochasticStyle(sigma_a=0.4, sigma_delta=0.003, tau=0.8, onset=0.6)
    a, b = (simulate_episode(style, PAPER, seed=11, noise=0.1) for _ in range(2))
    assert np.array_equal(a.ev, b.ev) and np.array_equal(a.u, b.u) and a.meta == b.meta
    c = simulate_episode(style, PAPER, seed=12, noise=0.1)
    assert not np.array_equal(a.ev, c.ev)
    assert a.origin == "simulated" and a.meta["stochastic_style"] == style.to_json()


def test_before_the_onset_the_driver_keeps_its_lane():
    late = simulate_episode(StochasticStyle(risk=0.5, onset=2.0), PAPER, seed=0)
    early = simulate_episode(StochasticStyle(risk=0.5), PAPER, seed=0)
    before = late.t <= 2.0
    y0 = PAPER.ev_initial_state[1]
    assert np.max(np.abs(late.ev[before, 1] - y0)) < 1e-3
    assert np.max(np.abs(early.ev[before, 1] - y0)) > 0.1
    assert late.ev[-1, 1] > PAPER.lane_width  # it changes lane after t_on


def test_an_episode_starts_where_it_is_told():
    start = PAPER.ev_initial_state + np.array([3.0, 0.4, 0.01, -1.0])
    moved = simulate_episode(StochasticStyle(), PAPER, seed=0, start=start)
    np.testing.assert_array_equal(moved.ev[0], start)
    default = simulate_episode(StochasticStyle(), PAPER, seed=0)
    told = simulate_episode(StochasticStyle(), PAPER, seed=0, start=PAPER.ev_initial_state)
    np.testing.assert_array_equal(told.ev, default.ev)
    with pytest.raises(ValueError, match="start"):
        simulate_episode(StochasticStyle(), PAPER, seed=0, start=np.zeros(3))


def test_simulate_episode_refuses_reacting_vehicles_and_bad_noise():
    from drivestyle.envs.traffic import DEFAULT_TRAFFIC

    with pytest.raises(ValueError, match="constant velocity"):
        simulate_episode(StochasticStyle(), DEFAULT_TRAFFIC, seed=0)
    with pytest.raises(ValueError, match="noise"):
        simulate_episode(StochasticStyle(), PAPER, seed=0, noise=-1.0)


# ---------------------------------------------------------------------------- the prior
def test_the_priors_draws_lie_inside_their_ranges():
    prior = StochasticPrior()
    draws = prior.draw(300, seed=4)
    assert [d.to_json() for d in draws[:5]] == [d.to_json() for d in prior.draw(5, seed=4)]
    for name in ("risk", "time_gap", "min_gap", "lateral", "onset", "sigma_a", "sigma_delta",
                 "tau"):  # fmt: skip
        lo, hi = getattr(prior, name)
        values = np.array([getattr(d.style, name) for d in draws])
        assert np.all((lo <= values) & (values <= hi)), name
        assert values.max() - values.min() > 0.5 * (hi - lo), name  # the range is covered
    speeds = np.array([d.scene.base.ev_speed for d in draws])
    assert speeds.min() >= 2.0 and speeds.max() <= 35.0
    assert speeds.min() < 5.0 and speeds.max() > 30.0  # stop-and-go to free flow
    ratio = np.array([d.style.v_ref / d.scene.base.ev_speed for d in draws])
    assert np.all((0.9 - 1e-9 <= ratio) & (ratio <= 1.3 + 1e-9))
    noise = np.array([d.noise for d in draws])
    assert np.all((0 <= noise) & (noise <= 0.2))
    widths = np.array([d.scene.base.lane_width for d in draws])
    assert widths.min() >= 3.2 and widths.max() <= 5.25 and widths.min() < 3.5 < 5.0 < widths.max()
    assert {len(d.scene.others) for d in draws} == {0, 1, 2}
    assert EpisodeParams.from_json(draws[0].to_json()) == draws[0]


def test_the_prior_refuses_a_bad_range_in_one_line():
    with pytest.raises(ValueError, match="risk") as info:
        StochasticPrior(risk=(0.4, 0.9))
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="log-uniformly"):
        StochasticPrior(tau=(0.0, 1.0))


def test_simulated_episodes_of_the_prior_are_plausible_demonstrations():
    prior = StochasticPrior()
    for i, params in enumerate(prior.draw(4, seed=21)):
        demo = prior.simulate(params, seed=i)
        check_plausible(demo)
        assert demo.meta["risk"] == params.style.risk
        assert demo.others.shape[1] == len(params.scene.others)
        assert demo.n == round(prior.horizon_s / PAPER.dt) + 1
