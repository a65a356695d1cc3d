import numpy as np
import pytest

from drivestyle.irl.paper.spline import (
    QuinticTrajectory,
    basis_matrix,
    demo_control_points,
    evaluate_quintic,
    quintic_coefficients,
    spline_eval,
)


def test_quintic_boundary_conditions(rng):
    for _ in range(20):
        c0, c1 = rng.normal(size=3) * [10, 3, 1], rng.normal(size=3) * [10, 3, 1]
        T = rng.uniform(0.05, 3.0)
        q = quintic_coefficients(c0, c1, T)
        for d in range(3):
            assert evaluate_quintic(q, 0.0, d) == pytest.approx(c0[d], abs=1e-9)
            assert evaluate_quintic(q, T, d) == pytest.approx(c1[d], rel=1e-9, abs=1e-8)


def test_quintic_reproduces_polynomials_of_degree_five():
    T = 0.7
    p = np.polynomial.Polynomial([1.0, -2.0, 0.5, 3.0, -1.0, 0.25])
    c = lambda t: [p(t), p.deriv(1)(t), p.deriv(2)(t)]  # noqa: E731
    q = quintic_coefficients(c(0.0), c(T), T)
    np.testing.assert_allclose(q, p.coef, atol=1e-9)


def test_spline_is_c2_at_knots(rng):
    t = np.cumsum(np.r_[0, rng.uniform(0.1, 0.4, 8)])
    C = rng.normal(size=(t.size, 6))
    for k in range(1, t.size - 1):
        for axis in (slice(0, 3), slice(3, 6)):
            left = quintic_coefficients(C[k - 1, axis], C[k, axis], t[k] - t[k - 1])
            right = quintic_coefficients(C[k, axis], C[k + 1, axis], t[k + 1] - t[k])
            for d in range(3):  # position, velocity, acceleration agree across the knot
                assert evaluate_quintic(left, t[k] - t[k - 1], d) == pytest.approx(
                    evaluate_quintic(right, 0.0, d), rel=1e-8, abs=1e-8
                )
            # the jerk generally does not: the spline is C2, not C3
    assert evaluate_quintic(left, t[-2] - t[-3], 3) != pytest.approx(
        evaluate_quintic(right, 0.0, 3)
    )
    # at the knots the spline takes the control points' values
    for d in range(3):
        np.testing.assert_allclose(spline_eval(C, t, t, d)[:, 0], C[:, d], atol=1e-9)
        np.testing.assert_allclose(spline_eval(C, t, t, d)[:, 1], C[:, 3 + d], atol=1e-9)


def test_basis_matrix_matches_direct_evaluation(rng):
    t = np.linspace(0, 2, 11)
    C = rng.normal(size=(11, 6))
    tq = rng.uniform(0, 2, 30)
    for d in range(3):
        B = basis_matrix(t, tq, d)
        direct = []
        for tt in tq:
            j = min(np.searchsorted(t, tt, side="right") - 1, 9)
            q = quintic_coefficients(C[j, :3], C[j + 1, :3], t[j + 1] - t[j])
            direct.append(evaluate_quintic(q, tt - t[j], d))
        np.testing.assert_allclose(B @ C[:, :3].ravel(), direct, atol=1e-9)


def test_trajectory_keeps_c0_and_validates():
    t = np.linspace(0, 1, 6)
    c0 = np.arange(6.0)
    traj = QuinticTrajectory(t, c0, np.ones((5, 6)))
    np.testing.assert_array_equal(traj.control_points[0], c0)
    np.testing.assert_allclose(traj(0.0)[0], [0.0, 3.0])
    with pytest.raises(ValueError, match="free"):
        QuinticTrajectory(t, c0, np.ones((4, 6)))
    with pytest.raises(ValueError, match="increasing"):
        QuinticTrajectory(t[::-1], c0, np.ones((5, 6)))


def test_demo_control_point_rules(paper_demo):
    demo = paper_demo
    Cp = demo_control_points(demo, "paper")
    _x, _y, phi, v = demo.ev.T
    np.testing.assert_allclose(Cp[:, 1], v * np.cos(phi))
    np.testing.assert_allclose(Cp[:, 4], v * np.sin(phi))
    dv = (v[2] - v[0]) / (2 * 0.2)
    assert Cp[1, 2] == pytest.approx(dv * np.cos(phi[1]))
    Ck = demo_control_points(demo, "kinematic")
    np.testing.assert_array_equal(Ck[:, [0, 3]], Cp[:, [0, 3]])
    # the kinematic rule includes the side-slip: the lateral speed starts above 0
    assert Ck[0, 4] > 0.1 and Cp[0, 4] == 0.0
    with pytest.raises(ValueError, match="unknown control-point rule"):
        demo_control_points(demo, "spline")
