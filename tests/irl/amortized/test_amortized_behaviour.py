"""The behaviour statistics of an episode, checked in closed form on hand-built drives."""

import math

import numpy as np
import pytest

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.tracking import observe
from drivestyle.irl.amortized.behaviour import (
    DISTANCE_CAP_M,
    LATERAL_BAND_M,
    STATISTICS,
    behaviour,
    box_distance,
    smoothed,
)

SC = ScenarioConfig(lane_width=3.5, horizon_s=8.0, check_start=False)  # L 5 m, W 2 m, T_s 0.2 s
T = np.arange(41) * SC.dt
W = SC.lane_width
LANE0, LANE1 = 0.5 * W, 1.5 * W


def cruise(y: np.ndarray, speed: float = 20.0, x0: float = 80.0) -> np.ndarray:
    """EV states at constant speed along x with the lateral positions ``y``."""
    return np.column_stack([x0 + speed * T, y, np.zeros_like(T), np.full_like(T, speed)])


def demo(ev: np.ndarray, vehicles: list[np.ndarray], **kw) -> Demonstration:
    others = np.stack(vehicles[1:], axis=1) if len(vehicles) > 1 else None
    return Demonstration(T, ev, vehicles[0], np.zeros((40, 2)), {"scenario": SC.to_dict()},
                         others=others, **kw)  # fmt: skip


def ramp(t_start: float, duration: float, y0: float = LANE0, y1: float = LANE1) -> np.ndarray:
    """y moving from y0 to y1 at a constant lateral speed over [t_start, t_start + duration].

    The band's edges are 0.6 s or more inside the ramp, so the smoothing window (±0.4 s)
    of both samples around each is on the line: the statistics are exact there.
    """
    return y0 + (y1 - y0) * np.clip((T - t_start) / duration, 0.0, 1.0)


def test_a_straight_constant_speed_drive_changes_no_lane_and_no_speed():
    tv = cruise(np.full_like(T, LANE1), x0=100.0)  # beside, 20 m ahead, same speed
    b = behaviour(demo(cruise(np.full_like(T, LANE0)), [tv]))
    assert b.speed_change == 0.0
    assert math.isnan(b.lane_change_start) and math.isnan(b.lane_change_duration)
    assert math.isnan(b.accepted_gap) and math.isnan(b.crossing_time)
    # bumper 15 m ahead, side 3.25 m apart: the rectangles' corner distance
    assert b.closest_approach == pytest.approx(math.hypot(20 - 5, W - 2))  # 15 m, 1.5 m
    assert set(b.to_json()) == {*STATISTICS, "crossing_time"}
    assert b.to_json()["accepted_gap"] is None


def test_a_hand_built_lane_change_has_its_known_start_crossing_and_duration():
    t_s, dur = 1.0, 4.5
    lead = cruise(np.full_like(T, LANE1), x0=110.0)  # 30 m ahead in the target lane
    lag = cruise(np.full_like(T, LANE1), x0=63.0)  # 17 m behind
    b = behaviour(demo(cruise(ramp(t_s, dur)), [lead, lag]))
    # the offset leaves the band b after b/Δ of the move, settles b before its end
    assert b.lane_change_start == pytest.approx(t_s + LATERAL_BAND_M / W * dur)
    assert b.crossing_time == pytest.approx(t_s + dur / 2)  # the line is half-way
    assert b.lane_change_duration == pytest.approx(dur * (1 - 2 * LATERAL_BAND_M / W))
    assert b.accepted_gap == pytest.approx(17 - 5)  # the lag gap is the tighter
    assert b.speed_change == 0.0


def test_a_lane_change_that_does_not_settle_has_a_start_but_no_duration():
    late = behaviour(demo(cruise(ramp(3.8, 4.2)), [cruise(np.full_like(T, LANE1), x0=0.0)]))
    assert late.lane_change_start == pytest.approx(3.8 + LATERAL_BAND_M / W * 4.2)
    assert math.isnan(late.lane_change_duration)  # still moving over the last second
    assert late.accepted_gap == pytest.approx(75.0)  # the TV 80 m behind
    y = np.where(T < 5.0, ramp(0.4, 4.5), ramp(5.0, 2.0, LANE1, LANE0))  # and back again
    aborted = behaviour(demo(cruise(y), [cruise(np.full_like(T, LANE1), x0=-100.0)]))
    assert aborted.lane_change_start == pytest.approx(0.4 + LATERAL_BAND_M / W * 4.5)
    assert math.isnan(aborted.lane_change_duration)
    assert aborted.accepted_gap == DISTANCE_CAP_M  # nothing within 100 m in the target lane


def test_the_closest_approach_is_the_least_gap_to_an_observed_vehicle():
    ev = cruise(np.full_like(T, LANE0))
    leader = cruise(np.full_like(T, LANE0), speed=18.0, x0=110.0)  # 30 m ahead, closing 2 m/s
    ghost = ev.copy()  # a recorded episode's continuation on top of the EV: not observed
    observed = np.ones((2, 41), bool)
    observed[1] = False
    b = behaviour(demo(ev, [leader, ghost], origin="recorded", observed=observed))
    assert b.closest_approach == pytest.approx(30 - 2 * 8 - 5)  # bumper to bumper at 8 s
    seen = behaviour(demo(ev, [leader, ghost]))  # the same vehicle observed overlaps
    assert seen.closest_approach == pytest.approx(-2.0)  # minus the depth to separate (W)


def test_box_distance_is_signed_bumper_side_or_corner_distance():
    d = box_distance(np.array([10.0, 0.0, 8.0, 1.0]), np.array([0.0, 3.0, 6.0, 0.5]), 5.0, 2.0)
    np.testing.assert_allclose(d, [5.0, 1.0, math.hypot(3, 4), -1.5])


def test_smoothing_keeps_a_line_and_damps_noise(rng):
    line = 0.3 * np.arange(20.0)
    np.testing.assert_allclose(smoothed(line, 5)[2:-2], line[2:-2])
    assert np.std(smoothed(rng.normal(size=4000), 5)) < 0.5


def test_position_noise_through_the_tracker_moves_the_lane_change_by_a_few_samples(rng):
    smooth = LANE0 + W / 2 * (1 - np.cos(np.pi * np.clip((T - 1.0) / 4.5, 0.0, 1.0)))
    clean = demo(cruise(smooth), [cruise(np.full_like(T, LANE1), x0=0.0)])
    truth = behaviour(clean)
    for _ in range(20):  # 0.2 m, the prior's most (300 draws: 90 % within 0.22 s and 0.33 s)
        b = behaviour(observe(clean, 0.2, rng, recover=False))
        assert abs(b.lane_change_start - truth.lane_change_start) < 0.7
        assert abs(b.lane_change_duration - truth.lane_change_duration) < 0.8
        assert abs(b.speed_change) < 0.5
