"""The extraction's numbers checked on construction (recorded/extraction_config.py)."""

import math

import pytest

from drivestyle.recorded.extraction_config import ExtractionConfig


def test_the_config_refuses_an_observed_part_past_the_crossing():
    with pytest.raises(ValueError, match="observed part must end before the lane crossing"):
        ExtractionConfig(observe_s=3.5)
    assert math.isclose(ExtractionConfig().dt, 0.2)


@pytest.mark.parametrize("value", [-0.1, 1.5, math.nan])
def test_the_config_refuses_a_min_lateral_move_outside_a_lane(value):
    with pytest.raises(ValueError, match=r"min_lateral_move must be a fraction of the lane width"):
        ExtractionConfig(min_lateral_move=value)
