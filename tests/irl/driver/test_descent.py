"""The learner's descent (irl/driver/descent.py): projected Levenberg–Marquardt in a box."""

import numpy as np
import pytest

from drivestyle.irl.driver.descent import Box, levenberg_marquardt


def test_projected_lm_reaches_a_bound_exactly():
    # r(z) = z − (−1, 2): the minimum of the first coordinate lies below its bound 0
    def residuals(z):
        return z - np.array([-1.0, 2.0])

    box = Box(np.full(2, 1e-3), np.full(2, 0.4), np.array([0.0, -np.inf]), np.full(2, np.inf))
    z0 = np.array([0.7, 0.0])
    r0 = residuals(z0)
    z, _, cost, _, _, status = levenberg_marquardt(
        residuals, z0, r0, 0.5 * float(r0 @ r0), box, 50, 1e-10, None
    )
    assert z[0] == 0.0  # on the bound, not approaching it (a sigmoid never gets there)
    assert z[1] == pytest.approx(2.0, abs=1e-6)
    assert cost == pytest.approx(0.5) and status == "converged"
