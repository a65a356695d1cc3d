"""The no-leak view of a recorded episode (recorded/observed.py): nothing after t_obs is read."""

import math
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.recorded.observed import observed_view


def test_the_observed_scenario_uses_the_observed_speeds_only(paper_demo, as_recorded):
    demo = as_recorded(paper_demo)
    sc = observed_view(demo, 1.0)[1]
    k = round(1.0 / demo.scenario.dt)
    assert sc.v_ref == pytest.approx(max(np.percentile(demo.ev[: k + 1, 3], 90), 1.0))
    changed = demo.ev.copy()
    changed[k + 1 :, 3] += 10.0  # the future is not looked at
    assert observed_view(replace(demo, ev=changed), 1.0)[1].v_ref == sc.v_ref


def test_the_recorded_bounds_are_chosen_from_the_observed_heading_only(paper_demo, as_recorded):
    from drivestyle.recorded.real_data import RECORDED_PHI_MAX

    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    ev = demo.ev.copy()
    ev[k + 1 :, 2] *= 4.0  # the future turns beyond the heading bound
    turning = replace(demo, ev=ev)
    assert observed_view(turning, 2.0)[1].phi_max == demo.scenario.phi_max
    assert observed_view(turning, 2.0)[1] == observed_view(demo, 2.0)[1]
    late = round(5.0 / demo.scenario.dt)  # once observed, the turn does count
    assert observed_view(turning, 5.0)[1].phi_max == RECORDED_PHI_MAX
    assert observed_view(demo, 5.0)[1].phi_max == demo.scenario.phi_max
    assert late > k


def test_the_observed_view_does_not_read_the_future(paper_demo, as_recorded, change_the_future):
    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    seen, sc = observed_view(demo, 2.0)
    seen2, sc2 = observed_view(change_the_future(demo, k), 2.0)
    assert sc2 == sc
    assert np.array_equal(seen.ev[: k + 1], seen2.ev[: k + 1])
    assert np.array_equal(seen.vehicles[: k + 1], seen2.vehicles[: k + 1])
    # the EV's current lane is the middle one; the target the next in the observed direction
    assert math.floor(seen.ev[k, 1] / sc.lane_width) == 1 and sc.target_lane in (0, 2)
    # a vehicle first recorded after t_obs (held constant before it, as the loader does) is
    # replaced by a phantom far behind
    late = demo.other_vehicles.copy()
    late[: k + 3, 0, 2:] = late[k + 3, 0, 2:]
    seen3, _ = observed_view(replace(demo, others=late), 2.0)
    assert np.min(seen3.vehicles[k, :, 0] - seen3.ev[k, 0]) < -900
