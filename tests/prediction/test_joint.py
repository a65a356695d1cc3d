"""Joint prediction: each vehicle's own view, its lane intent, and rollouts that react."""

from __future__ import annotations

import numpy as np
import pytest

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.stochastic import StochasticStyle
from drivestyle.prediction.joint import (
    JointStyle,
    joint_rollout,
    lane_intent,
    own_view,
    scene_states,
)
from drivestyle.prediction.protocol import Observation

SC = ScenarioConfig()
W = SC.lane_width


def _straight(x0: float, y: float, v: float, n: int = 11) -> np.ndarray:
    t = np.arange(n) * SC.dt
    return np.column_stack([x0 + v * t, np.full(n, y), np.zeros(n), np.full(n, v)])


def test_lane_intent_keeps_the_position_unless_the_vehicle_moves_sideways():
    y = np.full(11, 0.4 * W)
    assert lane_intent(y, SC.dt, W) == pytest.approx(0.4 * W)
    moving = 0.5 * W + 0.5 * np.arange(11) * SC.dt  # 0.5 m/s to the left
    assert lane_intent(moving, SC.dt, W) == pytest.approx(1.5 * W)
    assert lane_intent(1.5 * W - 0.5 * np.arange(11) * SC.dt, SC.dt, W) == pytest.approx(0.5 * W)


def test_each_vehicle_sees_itself_in_lane_zero_with_the_others_nearest_first():
    states = np.stack(
        [_straight(100, 0.5 * W, 20), _straight(160, 1.5 * W, 20), _straight(120, 1.5 * W, 22)],
        axis=1,
    )
    view = own_view(states, 1, SC, "recorded")
    assert view.ev[:, 1] == pytest.approx(np.full(11, 0.5 * W))  # lane 1 moved to lane 0
    assert view.tv[-1, 0] == pytest.approx(states[-1, 2, 0])  # the nearest: vehicle 2
    assert view.others is not None and view.others[-1, 0, 0] == pytest.approx(states[-1, 0, 0])
    assert view.others[0, 0, 1] == pytest.approx(-0.5 * W)  # the old lane 0 is now −1
    assert view.scenario.ev_speed == pytest.approx(20.0) and view.u.shape == (10, 2)
    # one moving to −y is mirrored: it changes lane to +y in its own view
    right = states.copy()
    right[:, 0, 1] = 1.5 * W - 0.5 * np.arange(11) * SC.dt
    mirrored = own_view(right, 0, SC, "recorded")
    assert np.all(np.diff(mirrored.ev[:, 1]) > 0)
    assert 0 <= mirrored.ev[0, 1] < W
    alone = own_view(states[:, :1], 0, SC, "recorded")
    assert alone.tv[0, 0] == pytest.approx(100 - 1000.0)  # the phantom


def test_without_reaction_the_others_keep_their_velocity():
    start = np.array([[100, 0.5 * W, 0, 20], [140, 0.5 * W, 0, 15], [90, 1.5 * W, 0.01, 25]])
    styles = [[StochasticStyle(v_ref=20.0, time_gap=1.0, min_gap=5.0)] * 2] * 3
    xs, _ = joint_rollout(start, styles, [0.5 * W, 0.5 * W, 1.5 * W], SC, 10, 0, react=False)
    t = np.arange(11) * SC.dt
    for i in (1, 2):
        v, phi = start[i, 3], start[i, 2]
        assert xs[0, :, i, 0] == pytest.approx(start[i, 0] + v * np.cos(phi) * t)
        assert xs[0, :, i, 1] == pytest.approx(start[i, 1] + v * np.sin(phi) * t)
        assert xs[0, :, i, 3] == pytest.approx(np.full(11, v))


def test_the_braking_of_the_car_ahead_reaches_the_car_behind():
    # a chain 0 → 1 → 2, 40 m apart: 2 drives 10 m/s, 0 and 1 want 20. Together 1 brakes
    # for 2 and 0 for 1 within the first seconds; with 1 at constant velocity 0 keeps 20 m/s
    # until it nears 2 itself
    start = np.array([[60, 0.5 * W, 0, 20], [100, 0.5 * W, 0, 20], [140, 0.5 * W, 0, 10]])
    free = StochasticStyle(v_ref=20.0, time_gap=1.0, min_gap=5.0)
    slow = StochasticStyle(v_ref=10.0, time_gap=1.0, min_gap=5.0)
    styles, y = [[free], [free], [slow]], [0.5 * W] * 3
    joint, fails = joint_rollout(start, styles, y, SC, 30, 0, react=True)
    alone, _ = joint_rollout(start, styles, y, SC, 30, 0, react=False)
    assert fails == 0
    assert joint[0, 10, 1, 3] < 15.0  # 1 brakes for 2 …
    assert joint[0, 10, 0, 3] < 18.0 and alone[0, 10, 0, 3] == pytest.approx(20.0, abs=0.1)
    assert alone[0, :, 1, 3] == pytest.approx(np.full(31, 20.0))  # … which alone never reaches
    for rear, front in ((0, 1), (1, 2)):
        gap = joint[0, :, front, 0] - joint[0, :, rear, 0]
        assert gap.min() > 2 * SC.vehicle_length  # and no one runs into the car ahead


def test_the_prediction_reads_only_the_observation(tiny_posterior):
    posterior, _ = tiny_posterior
    states = np.stack([_straight(100, 0.5 * W, 20), _straight(140, 0.5 * W, 18)], axis=1)
    seen = Observation(states[:, 0], states[:, 1:], SC)
    scene = JointStyle(posterior, samples=4, seed=3).predict_scene(seen, 5)
    assert scene.paths.shape == (5, 6, 2, 2)  # the point prediction and 4 draws
    assert scene.paths[:, 0] == pytest.approx(np.broadcast_to(states[-1, :, :2], (5, 2, 2)))
    again = JointStyle(posterior, samples=4, seed=3).predict(seen, 5)
    assert again.xy == pytest.approx(scene.point[:, 0])  # deterministic given the seed
    assert again.radius is not None and again.radius >= 0
    assert scene_states(seen).shape == (11, 2, 4)
