"""Episodes no driver drives, made from a real one (the predictive check's power)."""

import numpy as np
import pytest

from drivestyle.irl.amortized.behaviour import behaviour
from drivestyle.irl.amortized.counterfeits import driven_through, pasted, played_backwards
from drivestyle.irl.driver.stochastic_prior import StochasticPrior, simulate_params

SHORT = StochasticPrior(horizon_s=4.0)


@pytest.fixture(scope="module")
def episodes():
    return [simulate_params(p, i) for i, p in enumerate(SHORT.draw(2, 8))]


def test_played_backwards_reverses_the_ev_alone(episodes):
    demo = episodes[0]
    back = played_backwards(demo)
    np.testing.assert_array_equal(back.ev, demo.ev[::-1])
    np.testing.assert_array_equal(back.vehicles, demo.vehicles)
    np.testing.assert_array_equal(played_backwards(back).ev, demo.ev)
    assert back.meta == demo.meta


def test_driven_through_meets_the_vehicle_mid_episode_and_keeps_the_ends(episodes):
    demo = episodes[0]
    through = driven_through(demo)
    np.testing.assert_allclose(through.ev[[0, -1]], demo.ev[[0, -1]])
    mid = demo.n // 2
    np.testing.assert_allclose(through.ev[mid], demo.tv[mid])
    assert behaviour(through).closest_approach == pytest.approx(-demo.scenario.vehicle_width)


def test_pasted_moves_another_path_to_this_start(episodes):
    demo, other = episodes
    paste = pasted(demo, other)
    assert paste.ev[0, 0] == demo.ev[0, 0]
    np.testing.assert_allclose(np.diff(paste.ev[:, 0]), np.diff(other.ev[:, 0]))
    np.testing.assert_array_equal(paste.ev[:, 1:], other.ev[:, 1:])
    np.testing.assert_array_equal(paste.vehicles, demo.vehicles)
    with pytest.raises(ValueError, match="samples"):
        pasted(demo, simulate_params(StochasticPrior().draw(1, 0)[0], 0))
