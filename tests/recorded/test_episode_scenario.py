"""An episode's scenario from its observed part (recorded/episode_scenario.py)."""

import numpy as np
import pytest

from drivestyle.recorded.episode_scenario import speed_constants


def test_v_max_is_the_road_vehicles_bound_whatever_the_observed_speeds():
    from drivestyle.envs.units import ROAD_SPEED_MAX_MPS

    for top in (20.0, 60.0, 120.0):
        level, v_max, _ = speed_constants(np.array([top / 2, top]))
        assert v_max == ROAD_SPEED_MAX_MPS == 70.0 and level == pytest.approx(0.95 * top)
