"""The physics baseline (irl/physics.py): IDM, the quintic lane change, calibration."""

import json
import re

import numpy as np
import pytest

from drivestyle.irl.physics import (
    PhysicsCase,
    PhysicsParams,
    calibrate_physics,
    idm_acceleration,
    lateral_forecast,
    load_params,
    physics_forecast,
    quintic_progress,
    save_params,
)

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


@pytest.mark.slow  # ≈ 4–6 s: two least-squares fits
def test_calibration_recovers_the_parameters_that_made_the_data(tmp_path):
    truth = PhysicsParams(time_gap_s=1.8, lc_duration_s=4.0)
    cases = []
    for gap, vy in ((25.0, 0.6), (40.0, -0.5), (18.0, 0.8)):
        ev = np.column_stack([np.arange(6) * 2.0, 5.0 + vy * 0.2 * np.arange(6),
                              np.zeros(6), np.full(6, 10.0)])  # fmt: skip
        others = np.array([[ev[-1, 0] + gap, 5.5 + np.sign(vy) * 3.7, 0.0, 6.0],
                           [ev[-1, 0] + gap + 5, 5.5, 0.0, 7.0]])  # fmt: skip
        actual = physics_forecast(ev, others, 0.2, 25, 3.7, 4.5, truth)
        cases.append(PhysicsCase(ev, others, actual, 0.2, 3.7, 4.5))
    cal = calibrate_physics(cases)
    assert cal.rmse_m < 0.05 < cal.rmse_initial_m
    assert cal.params.lc_duration_s == pytest.approx(4.0, abs=0.1)
    assert calibrate_physics(cases) == cal  # deterministic
    save_params(cal, tmp_path / "p.json")
    assert load_params(tmp_path / "p.json") == cal.params


def test_parameters_must_be_positive():
    with pytest.raises(ValueError, match="time_gap_s"):
        PhysicsParams(time_gap_s=0.0)


FULL = PhysicsParams().to_json()


@pytest.mark.parametrize(
    ("content", "said"),
    [
        ('{"params": {"v0_factor": 1.1', r": not JSON \(Expecting ',' delimiter at line 1, "
                                         r"column 29\)$"),
        ({"rmse_m": 1.0}, r': no "params" object: not a physics parameters file'),
        ({"params": {"v0_factor": 1.1}}, r": params: no time_gap_s, min_gap_m, .*trigger_mps "
                                         r"\(expected v0_factor, "),
        ({"params": {**FULL, "headway_s": 1.0}}, r": params: unknown headway_s \(expected "),
        ({"params": {**FULL, "time_gap_s": "1.2"}},
         r": params\.time_gap_s '1.2' is not a finite number > 0$"),
        ({"params": {**FULL, "time_gap_s": True}},
         r": params\.time_gap_s True is not a finite number > 0$"),
        ({"params": {**FULL, "time_gap_s": 30.0}},
         r": params\.time_gap_s 30 lies outside \[0\.3, 3\], the range calibration keeps to$"),
    ],
    ids=["torn-json", "no-params", "missing", "unknown", "text-number", "bool", "out-of-range"],
)  # fmt: skip
def test_a_bad_parameters_file_is_one_line_naming_it_and_the_problem(tmp_path, content, said):
    path = tmp_path / "physics.json"
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    with pytest.raises(ValueError, match=re.escape(str(path)) + said) as info:
        load_params(path)
    assert "\n" not in str(info.value)


def test_a_missing_or_folder_parameters_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match=f"^{re.escape(str(tmp_path))}/no.json: no such"):
        load_params(tmp_path / "no.json")
    with pytest.raises(ValueError, match="is a folder, not a physics parameters file"):
        load_params(tmp_path)
