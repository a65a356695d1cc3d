import numpy as np
import pytest

from drivestyle.planning.chance import chance_margin, risk_quantile
from drivestyle.planning.tv_gaussian import TVUncertainty, tv_covariance, tv_mean_prediction

L_A, L_B = 15.0, 3.0


def _boundary_point(direction, sigma, kappa):
    """Point along ``direction`` (from the TV mean) where the chance margin is exactly 0."""
    lo, hi = 1e-3, 1e3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        g = chance_margin(
            mid * direction[0],
            mid * direction[1],
            sigma[0, 0],
            sigma[0, 1],
            sigma[1, 1],
            L_A,
            L_B,
            kappa,
        )
        lo, hi = (mid, hi) if g < 0 else (lo, mid)
    return hi * np.asarray(direction)


@pytest.mark.parametrize("p", [0.7, 0.9, 0.95])
@pytest.mark.parametrize(
    "sigma",
    [
        np.diag([1.0, 0.1]),
        np.diag([9.0, 0.5]),  # σ_x/l_a ≠ σ_y/l_b: where axis inflation fails
        np.diag([0.2, 1.5]),
        np.array([[4.0, 0.9], [0.9, 0.6]]),  # correlated
    ],
)
@pytest.mark.parametrize("angle", [0.0, 0.4, 1.2, np.pi / 2, 2.5])
def test_monte_carlo_backoff_is_conservative(p, sigma, angle):
    rng = np.random.default_rng(0)
    kappa = risk_quantile(p)
    ev = _boundary_point((np.cos(angle), np.sin(angle)), sigma, kappa)
    tv = rng.multivariate_normal(np.zeros(2), sigma, size=200_000)
    d = ((ev[0] - tv[:, 0]) / L_A) ** 2 + ((ev[1] - tv[:, 1]) / L_B) ** 2 - 1
    empirical = np.mean(d >= 0)
    # standard error ≈ 0.001; the tangent bound is exact for the half-space, so ≥ p − 3σ
    assert empirical >= p - 0.003, (empirical, p)


def test_axis_inflation_would_fail_where_tangent_holds():
    # DESIGN §3: inflating the axes by κσ is not safe when σ_x/l_a and σ_y/l_b differ
    rng = np.random.default_rng(1)
    p, sigma = 0.95, np.diag([8.0**2, 0.2**2])
    kappa = risk_quantile(p)
    angle = 0.6
    a_in, b_in = L_A + kappa * 8.0, L_B + kappa * 0.2
    ev = np.array([a_in * np.cos(angle), b_in * np.sin(angle)])
    tv = rng.multivariate_normal(np.zeros(2), sigma, size=200_000)
    d = ((ev[0] - tv[:, 0]) / L_A) ** 2 + ((ev[1] - tv[:, 1]) / L_B) ** 2 - 1
    assert np.mean(d >= 0) < p  # inflation violates the chance constraint here
    g = chance_margin(ev[0], ev[1], sigma[0, 0], 0.0, sigma[1, 1], L_A, L_B, kappa)
    assert g < 0  # ... and the tangent constraint correctly rejects the point


def test_p_half_is_the_nominal_ellipse():
    dx, dy = 12.0, 2.5
    g = chance_margin(dx, dy, 4.0, 0.0, 1.0, L_A, L_B, risk_quantile(0.5))
    assert g == pytest.approx(np.hypot(dx / L_A, dy / L_B) - 1)


@pytest.mark.parametrize("p", [0.0, 1.0, -0.1, 1.5, float("nan"), "0.7"])
def test_risk_outside_open_interval_raises(p):
    with pytest.raises(ValueError, match="open interval"):
        risk_quantile(p)


def test_prediction_model():
    mean = tv_mean_prediction([60.0, 7.875, 0.0, 28.0], 0.2, 10)
    np.testing.assert_allclose(mean[-1], [60 + 28 * 2.0, 7.875])
    cov = tv_covariance(TVUncertainty(1.0, 2.0, 0.5, 0.5), 0.2, 10)
    assert cov.shape == (11, 2, 2)
    assert cov[0, 0, 0] == pytest.approx(1.0) and cov[10, 0, 0] == pytest.approx(1 + 16)
    assert np.all(np.diff(cov[:, 1, 1]) > 0)
    with pytest.raises(ValueError, match="sigma_vx"):
        TVUncertainty(sigma_vx=-1.0)
