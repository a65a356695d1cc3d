import numpy as np
import pytest

from drivestyle.irl.amortized.calibration import (
    calibrate,
    central_coverage,
    central_intervals,
    rank_histogram,
    rank_uniformity,
    sbc_ranks,
)


def _gaussian_case(rng, n=400, s=99, width=1.0):
    """Conjugate normal: θ ~ N(0, 1), x ~ N(θ, 1), posterior N(x/2, 1/2); ``width`` scales it."""
    theta = rng.standard_normal((n, 1))
    x = theta + rng.standard_normal((n, 1))
    samples = x[:, None, :] / 2 + width * np.sqrt(0.5) * rng.standard_normal((n, s, 1))
    return theta, samples


def test_ranks_count_the_samples_below():
    theta = np.array([[0.5, 10.0]])
    samples = np.array([[[0.1, 11.0], [0.7, 9.0], [0.2, 12.0]]])
    assert sbc_ranks(theta, samples).tolist() == [[2, 1]]


def test_the_exact_posterior_is_calibrated(rng):
    theta, samples = _gaussian_case(rng)
    cal = calibrate(theta, samples, ("theta",))
    assert cal.coverage[0] == pytest.approx(0.9, abs=0.05)
    assert cal.uniformity_p[0] > 0.01
    assert cal.histogram.sum() == 400
    assert cal.to_json()["parameters"]["theta"]["coverage"] == cal.coverage[0]


def test_a_too_narrow_posterior_is_caught(rng):
    theta, samples = _gaussian_case(rng, width=0.4)
    cal = calibrate(theta, samples, ("theta",))
    assert cal.coverage[0] < 0.6
    assert cal.uniformity_p[0] < 1e-6
    hist = cal.histogram[:, 0]
    assert hist[0] + hist[-1] > 3 * (hist[4] + hist[5])  # ∪-shaped


def test_a_too_wide_posterior_covers_too_much(rng):
    theta, samples = _gaussian_case(rng, width=2.5)
    assert central_coverage(theta, samples, 0.9)[0] > 0.98


def test_histogram_bins_cover_equal_rank_counts():
    ranks = np.arange(100)[:, None]  # every rank 0 … 99 once, S = 99
    assert rank_histogram(ranks, 99, 10)[:, 0].tolist() == [10] * 10
    assert rank_uniformity(ranks, 99, 10)[0] == pytest.approx(1.0)


def test_shapes_are_checked():
    with pytest.raises(ValueError, match="same N and D"):
        sbc_ranks(np.zeros((3, 2)), np.zeros((3, 5, 1)))
    with pytest.raises(ValueError, match="ranks must be"):
        rank_histogram(np.array([[6]]), 5)


def test_central_intervals_are_the_samples_quantiles():
    samples = np.arange(101.0)[None, :, None] * np.array([1.0, 10.0])  # (1, 101, 2)
    lo, hi = central_intervals(samples, 0.9)
    assert lo.shape == hi.shape == (1, 2)
    np.testing.assert_allclose(lo[0], [5.0, 50.0])
    np.testing.assert_allclose(hi[0], [95.0, 950.0])
    with pytest.raises(ValueError, match="level"):
        central_intervals(samples, 1.0)
