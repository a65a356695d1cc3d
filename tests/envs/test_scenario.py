import dataclasses

import numpy as np
import pytest

from drivestyle.envs.scenario import PAPER, ScenarioConfig, ScenarioRanges, get_scenario


def test_paper_numbers():
    assert PAPER.n_steps == 30
    np.testing.assert_allclose(PAPER.lane_centres, [2.625, 7.875, 13.125])
    np.testing.assert_allclose(PAPER.ev_initial_state, [80, 2.625, 0, 25])
    np.testing.assert_allclose(PAPER.tv_initial_state, [60, 7.875, 0, 28])
    assert PAPER.y_bounds == (1.0, 14.75)  # DESIGN §1 erratum
    assert PAPER.y_ref == 7.875


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("lane_width", -1.0, "lane_width"),
        ("dt", 0.0, "dt"),
        ("ev_lane", 5, "ev_lane"),
        ("target_lane", 0, "no lane change"),
        ("horizon_s", 6.1, "whole number"),
        ("ev_speed", float("nan"), "finite"),
        ("tv_gap", -5.0, "inside the TV's safety ellipse"),
    ],
)
def test_bad_values_raise(field, value, match):
    kwargs = {field: value}
    if field == "tv_gap":
        kwargs["tv_lane"] = 0  # same lane, 5 m behind
    with pytest.raises(ValueError, match=match):
        dataclasses.replace(PAPER, **kwargs)


def test_unknown_override_and_scenario_name():
    with pytest.raises(TypeError, match="unknown scenario parameter"):
        PAPER.with_overrides(ev_sped=3)
    with pytest.raises(KeyError, match="unknown scenario 'highway'"):
        get_scenario("highway")
    assert get_scenario(PAPER) is PAPER


def test_random_family_is_seeded_and_feasible():
    ranges = ScenarioRanges(tv_lanes=(0, 1))
    a = [ranges.sample(np.random.default_rng(3)) for _ in range(2)]
    assert a[0] == a[1]
    draws = [ranges.sample(np.random.default_rng(i)) for i in range(50)]
    for sc in draws:
        assert isinstance(sc, ScenarioConfig)
        assert sc.initial_elliptical_index > 1
        assert 22 <= sc.ev_speed <= 28 and -30 <= sc.tv_gap <= -10
    with pytest.raises(ValueError, match="low <= high"):
        ScenarioRanges(ev_speed=(30.0, 20.0))
