"""The amortized posterior's training set: stochastic drivers simulated from their prior."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.amortized.simulations import (
    PARAMETERS,
    parameter_box,
    parameters_of,
    series_width,
    simulate_set,
    style_of,
    with_prefixes,
)
from drivestyle.irl.driver.stochastic_prior import StochasticPrior

PRIOR = StochasticPrior()


@pytest.fixture(scope="module")
def sims():
    return simulate_set(PRIOR, 3, seed=5)


def test_the_training_set_has_one_row_of_every_parameter_and_one_series_per_episode(sims):
    low, high = parameter_box(PRIOR)
    assert sims.theta.shape == (3, len(PARAMETERS)) == (3, 9)
    assert np.all(sims.theta >= low - 1e-12) and np.all(sims.theta <= high + 1e-12)
    assert [x.shape for x in sims.series] == [(41, series_width())] * 3  # 8 s at 0.2 s
    assert series_width() == 4 + 4 * 3  # EV, then per vehicle [Δx, Δy, Δv] and its mask
    assert all(np.all(np.isfinite(x)) for x in sims.series)
    assert sims.seconds.shape == sims.failures.shape == (3,) and sims.wall_s > 0
    # θ is the drawn driver's, the desired speed as its ratio to the EV's start speed
    draws = PRIOR.draw(3, 5)
    np.testing.assert_array_equal(sims.theta, np.stack([parameters_of(d) for d in draws]))
    d = draws[0]
    assert sims.theta[0, 1] == pytest.approx(d.style.v_ref / d.scene.base.ev_speed)


def test_the_training_set_is_deterministic_given_the_seed(sims):
    again = simulate_set(PRIOR, 2, seed=5)  # the first two of the same draws
    np.testing.assert_array_equal(again.theta, sims.theta[:2])
    for a, b in zip(again.series, sims.series[:2], strict=True):
        np.testing.assert_array_equal(a, b)
    other = simulate_set(PRIOR, 1, seed=6)
    assert not np.array_equal(other.theta[0], sims.theta[0])


def test_prefixes_are_the_episodes_observed_for_less_time(sims):
    low, high = parameter_box(PRIOR)
    rows = with_prefixes(sims, 2, 6, 0, low, high)
    assert rows.n == 3 + 3 * 2
    for i in range(3):
        np.testing.assert_array_equal(rows.x[i], sims.series[i])  # whole episodes first
        for j in (3 + 2 * i, 4 + 2 * i):
            t = rows.x[j].shape[0]
            assert 6 <= t < 41
            np.testing.assert_array_equal(rows.x[j], sims.series[i][:t])
            np.testing.assert_array_equal(rows.theta[j], rows.theta[i])
    np.testing.assert_array_equal(rows.groups, [0, 1, 2, 0, 0, 1, 1, 2, 2])  # validated whole
    again = with_prefixes(sims, 2, 6, 0, low, high)
    assert [x.shape for x in again.x] == [x.shape for x in rows.x]
    assert with_prefixes(sims, 0, 6, 0, low, high).n == 3


def test_a_parameter_the_prior_does_not_vary_is_refused():
    with pytest.raises(ValueError, match="risk"):
        parameter_box(StochasticPrior(risk=(0.7, 0.7)))


def test_style_of_inverts_parameters_of():
    for params in PRIOR.draw(20, 3):
        style = style_of(parameters_of(params), params.scene.base.ev_speed)
        assert style.v_ref == pytest.approx(params.style.v_ref, rel=1e-12)
        assert replace(style, v_ref=params.style.v_ref) == params.style
    with pytest.raises(ValueError, match="9 finite numbers"):
        style_of(np.zeros(3), 20.0)
