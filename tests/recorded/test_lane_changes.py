"""Lane changes of a track: the lateral move across a window (recorded/lane_changes.py)."""

import numpy as np
import pytest

from drivestyle.recorded.lane_changes import lateral_move


def test_lateral_move_in_closed_form_robust_to_one_bad_sample():
    t = np.round(np.arange(0, 8.0 + 1e-9, 0.1), 9)
    y = 0.5 * t
    # the medians over the first and last 0.5 s: y(0.25) and y(7.75) on a straight line
    assert lateral_move(t, y, 0.0, 8.0) == pytest.approx(3.75, abs=1e-12)
    spike = y.copy()
    spike[-1] += 5.0  # one bad fix at the window's end does not decide
    assert lateral_move(t, spike, 0.0, 8.0) == pytest.approx(3.75, abs=1e-12)
    assert abs(spike[-1] - spike[0] - 3.75) > 1  # the end samples alone would
    sparse = np.arange(0, 8.0 + 1e-9, 0.5)  # 2 Hz: no sample inside a span, interpolated
    assert lateral_move(sparse, 0.5 * sparse, 0.0, 8.0) == pytest.approx(3.75, abs=1e-12)
    assert lateral_move(t, y, 2.0, 2.6) == pytest.approx(0.15, abs=1e-12)  # spans ≤ half
    assert lateral_move(t, -y, 0.0, 8.0) == pytest.approx(-3.75, abs=1e-12)
