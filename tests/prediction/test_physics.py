"""The physics predictor (prediction/physics.py): IDM, the quintic lane change."""

import numpy as np
import pytest

from drivestyle.envs.scenario import PAPER
from drivestyle.prediction.physics import (
    PhysicsBaseline,
    PhysicsParams,
    idm_acceleration,
    lateral_forecast,
    physics_forecast,
    quintic_progress,
)
from drivestyle.prediction.protocol import Observation

P = PhysicsParams()


def test_idm_is_still_at_the_desired_speed_and_brakes_behind_a_close_leader():
    assert idm_acceleration(20.0, None, 0.0, 20.0, P) == pytest.approx(0.0)
    assert idm_acceleration(10.0, None, 0.0, 20.0, P) == pytest.approx(P.accel_mps2 * (1 - 0.5**4))
    assert idm_acceleration(10.0, 5.0, 10.0, 20.0, P) < -P.decel_mps2  # closing on a stopped car


def test_the_quintic_runs_from_0_to_1_with_zero_slope_at_both_ends():
    u = np.linspace(0, 1, 101)
    s = quintic_progress(u)
    assert s[0] == 0 and s[-1] == 1 and np.all(np.diff(s) > 0)
    assert quintic_progress(1e-4) < 1e-10 and 1 - quintic_progress(1 - 1e-4) < 1e-10


def test_lateral_keeps_its_line_below_the_trigger_and_else_reaches_the_next_lane():
    w, dt = 3.7, 0.2
    still = np.full(11, 1.7) + np.linspace(0, 0.01, 11)
    assert np.allclose(lateral_forecast(still, dt, 20, w, P), still[-1])
    moving = np.linspace(1.6, 2.6, 11)  # lane 0, 0.5 m/s to +y
    y = lateral_forecast(moving, dt, 60, w, P)
    assert y[0] == moving[-1] and y[-1] == pytest.approx(1.5 * w)
    assert np.all(np.diff(y) >= 0)
    down = lateral_forecast(moving[::-1] + 3.7, dt, 60, w, P)  # lane 1, to −y: lane 0's centre
    assert down[-1] == pytest.approx(0.5 * w)
    crossed = np.linspace(3.0, 4.2, 11)  # crossed into lane 1 while observed: its centre
    assert lateral_forecast(crossed, dt, 60, w, P)[-1] == pytest.approx(1.5 * w)


def test_physics_follows_a_slow_leader_in_its_lane_only():
    ev = np.column_stack([np.arange(6) * 2.0, np.full(6, 1.8), np.zeros(6), np.full(6, 10.0)])
    slow_ahead = np.array([[30.0, 1.8, 0.0, 3.0]])
    other_lane = np.array([[30.0, 5.5, 0.0, 3.0]])
    free = physics_forecast(ev, np.zeros((0, 4)), 0.2, 30, 3.7, 4.5, P)
    assert np.allclose(physics_forecast(ev, other_lane, 0.2, 30, 3.7, 4.5, P), free)
    assert physics_forecast(ev, slow_ahead, 0.2, 30, 3.7, 4.5, P)[-1, 0] < free[-1, 0] - 5


def test_parameters_must_be_positive():
    with pytest.raises(ValueError, match="time_gap_s"):
        PhysicsParams(time_gap_s=0.0)


def test_the_physics_predictor_is_the_forecast_of_the_observation():
    ev = np.column_stack([np.arange(6) * 2.0, np.full(6, 1.8), np.zeros(6), np.full(6, 10.0)])
    others = np.repeat(np.array([[[30.0, 1.8, 0.0, 3.0]]]), 6, axis=0)
    seen = Observation(ev, others, PAPER)
    path = PhysicsBaseline(P).predict(seen, 30)
    expected = physics_forecast(ev, others[-1], PAPER.dt, 30, PAPER.lane_width,
                                PAPER.vehicle_length, P)  # fmt: skip
    assert np.array_equal(path.xy, expected) and path.risk is None
