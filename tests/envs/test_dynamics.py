import casadi as ca
import numpy as np
import pytest

from drivestyle.envs.dynamics import bicycle_ode, rk4_step

L_F = L_R = 2.0


def test_straight_line_constant_speed():
    # 2 s at 20 m/s straight ahead: 40 m, nothing else changes
    xi = np.array([0.0, 1.0, 0.0, 20.0])
    for _ in range(10):
        xi = rk4_step(xi, np.zeros(2), 0.2, L_F, L_R)
    np.testing.assert_allclose(xi, [40.0, 1.0, 0.0, 20.0], atol=1e-12)


def test_constant_acceleration_along_heading():
    phi, v0, a, T = 0.03, 25.0, 2.0, 3.0
    xi = np.array([5.0, 2.0, phi, v0])
    for _ in range(15):
        xi = rk4_step(xi, np.array([a, 0.0]), 0.2, L_F, L_R)
    s = v0 * T + 0.5 * a * T**2
    np.testing.assert_allclose(
        xi, [5 + s * np.cos(phi), 2 + s * np.sin(phi), phi, v0 + a * T], atol=1e-9
    )


def test_constant_steering_follows_circle():
    # constant v and δ: the centre of mass moves on a circle of radius l_r / sin β
    v, delta, T = 20.0, 0.05, 4.0
    beta = np.arctan(L_R / (L_F + L_R) * np.tan(delta))
    omega = v * np.sin(beta) / L_R
    radius = v / omega
    xi = np.array([0.0, 0.0, 0.0, v])
    for _ in range(20):
        xi = rk4_step(xi, np.array([0.0, delta]), 0.2, L_F, L_R)
    psi = omega * T  # travelled angle; velocity direction is φ + β
    # centre of the circle relative to the start: perpendicular to the initial velocity
    centre = radius * np.array([-np.sin(beta), np.cos(beta)])
    expected = centre + radius * np.array([np.sin(beta + psi), -np.cos(beta + psi)])
    np.testing.assert_allclose(xi[:2], expected, atol=1e-6)
    assert xi[2] == pytest.approx(omega * T, abs=1e-9)


def test_numpy_and_casadi_maps_are_identical(rng):
    x = ca.SX.sym("x", 4)
    u = ca.SX.sym("u", 2)
    F = ca.Function("F", [x, u], [rk4_step(x, u, 0.2, L_F, L_R)])
    for _ in range(20):
        xi = rng.uniform([0, 0, -0.05, 0], [300, 15, 0.05, 40])
        uu = rng.uniform([-9, -0.05], [6, 0.05])
        np.testing.assert_allclose(
            np.asarray(F(xi, uu)).ravel(), rk4_step(xi, uu, 0.2, L_F, L_R), rtol=1e-14, atol=1e-12
        )


def test_ode_matches_definition():
    xi = np.array([0.0, 0.0, 0.02, 30.0])
    u = np.array([1.5, 0.04])
    beta = np.arctan(0.5 * np.tan(0.04))
    np.testing.assert_allclose(
        bicycle_ode(xi, u, L_F, L_R),
        [30 * np.cos(0.02 + beta), 30 * np.sin(0.02 + beta), 30 / 2 * np.sin(beta), 1.5],
    )


def test_the_scalar_fast_path_equals_the_array_map():
    from drivestyle.envs.dynamics import rk4_step_scalar

    rng = np.random.default_rng(0)
    for i in range(2000):
        xi = rng.uniform([0, -2, -0.3, 0], [300, 18, 0.3, 70])
        u = rng.uniform([-9, -0.5], [6, 0.5])
        n_sub = 1 + i % 3
        want = rk4_step(xi, u, 0.2, L_F, 1.7, n_sub)
        got = rk4_step_scalar(*xi.tolist(), *u.tolist(), 0.2, L_F, 1.7, n_sub)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_inverse_step_recovers_the_input_and_respects_its_bounds():
    from drivestyle.envs.dynamics import inverse_step

    xi = np.array([3.0, 1.5, 0.02, 25.0])
    for u in ([0.8, -0.018], [-2.7, 0.039], [0.0, 0.0]):
        nxt = rk4_step(xi, np.array(u), 0.2, 2.0, 2.0)
        got = inverse_step(xi, nxt, 0.2, 2.0, 2.0, (-9.0, -0.05), (6.0, 0.05))
        np.testing.assert_allclose(got, u, atol=1e-9)
    # an input beyond the bounds is answered with the bound, not extrapolated past it
    nxt = rk4_step(xi, np.array([0.0, 0.08]), 0.2, 2.0, 2.0)
    got = inverse_step(xi, nxt, 0.2, 2.0, 2.0, (-9.0, -0.05), (6.0, 0.05))
    assert got[1] == pytest.approx(0.05)


def test_inverse_step_on_a_pair_no_bounded_input_reaches_equals_bounded_least_squares():
    from scipy.optimize import least_squares

    from drivestyle.envs.dynamics import INPUT_FIT_SCALE, inverse_step, rk4_step_scalar

    rng = np.random.default_rng(3)
    lo, hi = (-9.0, -0.05), (6.0, 0.05)
    held = 0
    for _ in range(20):
        xi = np.array([100.0, 3.0, rng.uniform(-0.05, 0.05), rng.uniform(8.0, 30.0)])
        u = (rng.uniform(-3.0, 3.0), rng.choice([-1, 1]) * rng.uniform(0.06, 0.15))  # beyond δ_max
        nxt = np.array(rk4_step_scalar(*xi, *u, 0.2, 2.0, 2.0)) + rng.normal(0, 0.05, 4)

        def mismatch(w, xi=xi, nxt=nxt):
            return (
                np.array(rk4_step_scalar(*xi, w[0], w[1], 0.2, 2.0, 2.0)) - nxt
            ) / INPUT_FIT_SCALE

        expected = least_squares(mismatch, [0.0, 0.0], bounds=(lo, hi), xtol=1e-12).x
        got = inverse_step(xi, nxt, 0.2, 2.0, 2.0, lo, hi)
        np.testing.assert_allclose(got, expected, atol=1e-5)  # [m/s², rad]
        cost = (mismatch(got) @ mismatch(got), mismatch(expected) @ mismatch(expected))
        assert cost[0] <= cost[1] * (1 + 1e-9)  # never a worse fit than SciPy's
        held += abs(got[1]) == pytest.approx(0.05)
    assert held >= 10  # most of these pairs need more steering than the bound allows
