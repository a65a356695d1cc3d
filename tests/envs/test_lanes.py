"""The lane rules every layer applies: lane of a position, the leader, the target line."""

import numpy as np
import pytest

from drivestyle.envs.lanes import lane_change_target, lane_index, leaders


def test_lane_i_covers_i_w_to_i_plus_one_w():
    assert lane_index([-0.1, 0.0, 3.99, 4.0, 11.9], 4.0).tolist() == [-1, 0, 0, 1, 2]


def test_the_leader_is_the_nearest_vehicle_ahead_in_the_same_lane():
    w = 4.0
    x, y = np.array([0.0, 0.0, 50.0]), np.array([2.0, 6.0, 2.0])
    ox = np.array([[30.0, 20.0, -5.0, 40.0]] * 3)
    oy = np.array([[2.5, 6.5, 1.0, 3.9]] * 3)
    # sample 0: lane 0 has 30 (2.5), -5 (behind) and 40 (3.9): the nearest ahead is 30
    # sample 1: lane 1 has 20; sample 2: nobody ahead of x = 50 in lane 0
    assert leaders(x, y, ox, oy, w).tolist() == [0, 1, -1]
    # a vehicle a metre beside the lane line is in the other lane, whatever its offset
    assert leaders([0.0], [3.9], [[10.0]], [[4.1]], w).tolist() == [-1]
    assert leaders([0.0], [0.0], np.empty((1, 0)), np.empty((1, 0)), w).tolist() == [-1]


@pytest.mark.parametrize(
    ("y", "expected"),
    [
        ([1.8, 1.9, 2.2, 2.6, 3.0], (1, 1)),  # moving left in lane 0: the next lane
        ([3.0, 3.5, 3.9, 4.3, 4.8], (1, 1)),  # crossed into lane 1 moving left: lane 1
        ([6.0, 5.6, 5.1, 4.6, 4.2], (0, -1)),  # moving right in lane 1: lane 0
        ([2.0, 2.0, 2.0, 2.0, 2.0], (1, 1)),  # no lateral motion counts as +y
    ],
)
def test_the_target_line_reads_the_observed_lateral_velocity(y, expected):
    assert lane_change_target(np.array(y), 0.2, 4.0) == expected


def test_the_target_line_reads_only_the_last_lateral_window():
    # an early move right, then left over the last 0.6 s: left counts
    y = np.array([3.0, 2.5, 2.0, 1.5, 1.6, 1.8, 2.0])
    assert lane_change_target(y, 0.2, 4.0) == (1, 1)
