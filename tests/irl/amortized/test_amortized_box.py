import numpy as np
import pytest

from drivestyle.irl.amortized.box import (
    check_box,
    from_unconstrained,
    log_abs_det,
    to_unconstrained,
)

LOW = np.array([0.0, -1.0, 10.0])
HIGH = np.array([1.0, 2.0, 35.0])


def test_round_trip_and_every_z_maps_inside(rng):
    theta = LOW + (HIGH - LOW) * rng.random((50, 3))
    z = to_unconstrained(theta, LOW, HIGH)
    assert np.allclose(from_unconstrained(z, LOW, HIGH), theta, atol=1e-9)
    back = from_unconstrained(np.array([[-1e4, 0.0, 1e4]]), LOW, HIGH)
    assert np.all(back >= LOW) and np.all(back <= HIGH)
    assert np.allclose(back, [[0.0, 0.5, 35.0]])


def test_the_edges_map_to_finite_z():
    z = to_unconstrained(np.stack([LOW, HIGH]), LOW, HIGH)
    assert np.all(np.isfinite(z)) and np.all(np.abs(z) < 14)


def test_log_abs_det_is_the_jacobian(rng):
    theta = LOW + (HIGH - LOW) * (0.05 + 0.9 * rng.random((5, 3)))
    h = 1e-6
    for d in range(3):
        step = np.zeros(3)
        step[d] = h * (HIGH - LOW)[d]
        fd = to_unconstrained(theta + step, LOW, HIGH) - to_unconstrained(theta - step, LOW, HIGH)
        assert np.all(fd[:, [x for x in range(3) if x != d]] == pytest.approx(0.0, abs=1e-9))
        theta_d = theta[:, d]
        deriv = fd[:, d] / (2 * step[d])
        u = (theta_d - LOW[d]) / (HIGH - LOW)[d]
        assert np.allclose(deriv, 1 / ((HIGH - LOW)[d] * u * (1 - u)), rtol=1e-5)
    expected = -np.sum(np.log(HIGH - LOW) + np.log((theta - LOW) / (HIGH - LOW))
                       + np.log(1 - (theta - LOW) / (HIGH - LOW)), axis=1)  # fmt: skip
    assert np.allclose(log_abs_det(theta, LOW, HIGH), expected)


@pytest.mark.parametrize(
    ("low", "high", "match"),
    [([0.0], [0.0], "below high"), ([0.0, 1.0], [1.0], "one shape"), ([np.inf], [1.0], "finite")],
)
def test_a_box_is_checked(low, high, match):
    with pytest.raises(ValueError, match=match):
        check_box(np.array(low), np.array(high))
