"""A track's states on an episode's grid (recorded/resampling.py)."""

import numpy as np

from drivestyle.recorded.resampling import resample_states


def test_resampling_a_straight_line_and_a_circle_arc_in_closed_form():
    t = np.arange(0, 4.0 + 1e-9, 0.1)
    t_new = np.arange(0, 4.0 + 1e-9, 0.2)
    phi0, v = 0.1, 20.0
    line = resample_states(t, v * t * np.cos(phi0), v * t * np.sin(phi0), t_new)
    np.testing.assert_allclose(line[:, 2], phi0, atol=1e-9)
    np.testing.assert_allclose(line[:, 3], v, atol=1e-9)
    r, omega = 200.0, 0.1  # 20 m/s on a 200 m circle
    arc = resample_states(t, r * np.sin(omega * t), r * (1 - np.cos(omega * t)), t_new)
    np.testing.assert_allclose(arc[:, 0], r * np.sin(omega * t_new), atol=1e-9)
    inner = slice(2, -2)  # the spline's free ends bend its derivative at the ends
    np.testing.assert_allclose(arc[inner, 2], omega * t_new[inner], atol=1e-4)
    np.testing.assert_allclose(arc[inner, 3], r * omega, atol=1e-3)
    assert np.max(np.abs(arc[:, 2] - omega * t_new)) < 2e-3
