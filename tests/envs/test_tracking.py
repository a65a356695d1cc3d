"""The tracker: an RTS smoother recovers a known motion; noise is seeded; bad input is refused."""

import numpy as np
import pytest

from drivestyle.envs.tracking import observe, rts_smooth


def test_rts_smoother_recovers_constant_acceleration():
    dt, n = 0.2, 31
    t = np.arange(n) * dt
    r = 3.0 + 25.0 * t + 0.5 * 1.5 * t**2  # constant acceleration 1.5 m/s²
    rng = np.random.default_rng(0)
    est = rts_smooth(r + 0.05 * rng.standard_normal(n), dt, 0.05)
    assert np.sqrt(np.mean((est[:, 0] - r) ** 2)) < 0.05  # better than the raw noise
    assert np.median(np.abs(est[:, 1] - (25.0 + 1.5 * t))) < 0.15
    exact = rts_smooth(r, dt, 1e-4)
    np.testing.assert_allclose(exact[:, 0], r, atol=1e-3)


def test_observe_is_seeded_and_keeps_the_grid(paper_demo):
    a = observe(paper_demo, 0.1, np.random.default_rng(5))
    b = observe(paper_demo, 0.1, np.random.default_rng(5))
    np.testing.assert_array_equal(a.ev, b.ev)
    np.testing.assert_array_equal(a.t, paper_demo.t)
    assert a.meta["observation"]["noise_sigma_m"] == 0.1
    assert np.max(np.abs(a.ev[:, :2] - paper_demo.ev[:, :2])) < 0.5
    speed_err = np.abs(a.ev[:, 3] - paper_demo.ev[:, 3])
    assert np.median(speed_err) < 0.3


@pytest.mark.parametrize("sigma", [-0.1, float("nan")])
def test_bad_noise_is_refused(paper_demo, sigma):
    with pytest.raises(ValueError, match="sigma"):
        observe(paper_demo, sigma, np.random.default_rng(0))
