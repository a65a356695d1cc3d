"""Calibrating the joint physics predictor (prediction/joint_physics_calibration.py), its file."""

import json
import re

import numpy as np
import pytest

from drivestyle.prediction.joint_physics import JointPhysicsParams, joint_physics_forecast
from drivestyle.prediction.joint_physics_calibration import (
    JOINT_PHYSICS_FILE,
    JointPhysicsCase,
    calibrate_joint_physics,
    joint_residuals,
    load_joint_params,
    save_joint_params,
)

W, DT, LENGTH = 3.7, 0.2, 4.5


def _cruising(x: float, y: float, v: float, vy: float = 0.0) -> np.ndarray:
    t = (np.arange(6) - 5) * DT
    return np.column_stack([x + v * t, y + vy * t, np.zeros(6), np.full(6, v)])


SCENES = [  # (the predicted vehicle, the others), lanes
    ((_cruising(0, 1.85, 12.0), _cruising(22, 1.85, 8.0)), 1),  # following
    ((_cruising(0, 1.85, 10.0, vy=0.6), _cruising(30, 5.55, 7.0), _cruising(35, 1.85, 9.0)), 3),
    ((_cruising(0, 5.55, 10.0, vy=-0.5), _cruising(25, 1.85, 8.0)), 3),  # changing lane
    ((_cruising(0, 1.85, 12.0), _cruising(30, 1.85, 10.0)), 2),  # MOBIL: a small gain
    ((_cruising(0, 1.85, 14.0), _cruising(28, 1.85, 8.0)), 2),  # MOBIL: a large one
]


def _cases(truth: JointPhysicsParams, steps: int = 20) -> list[JointPhysicsCase]:
    out = []
    for (ev, *others), lanes in SCENES:
        vehicles = np.stack(others, axis=1)
        actual = joint_physics_forecast(ev, vehicles, DT, steps, W, LENGTH, lanes, truth)[:, 0]
        out.append(JointPhysicsCase(ev, vehicles, actual, DT, W, LENGTH, lanes))
    return out


def test_the_residuals_are_each_cases_errors_rolled_out_at_once():
    truth = JointPhysicsParams(time_gap_s=1.8)
    cases = _cases(truth, 20)[:2] + _cases(truth, 12)[2:]  # horizons differ, scenes' sizes too
    params = JointPhysicsParams()
    alone = []
    for c in cases:
        h = len(c.actual) - 1
        xy = joint_physics_forecast(c.ev, c.vehicles, DT, h, W, LENGTH, c.n_lanes, params)
        alone.append(((xy[1:, 0] - c.actual[1:]) / np.sqrt(h)).ravel())
    assert np.allclose(joint_residuals(params, cases), np.concatenate(alone), rtol=0, atol=1e-9)
    assert np.allclose(joint_residuals(truth, cases), 0.0, atol=1e-9)


@pytest.mark.slow  # ≈ 10–30 s: least squares and MOBIL's grid, twice
def test_calibration_recovers_the_parameters_that_made_the_data(tmp_path):
    # MOBIL's choice differs from the start's: no politeness, a high threshold
    truth = JointPhysicsParams(time_gap_s=1.8, lc_duration_s=4.0, politeness=0.0,
                               threshold_mps2=0.8)  # fmt: skip
    cases = _cases(truth)
    cal = calibrate_joint_physics(cases)
    assert cal.rmse_m < 0.1 < cal.rmse_initial_m
    assert cal.params.lc_duration_s == pytest.approx(4.0, abs=0.1)
    for c in cases:  # the same lane changes, to the same lines
        xy = joint_physics_forecast(c.ev, c.vehicles, DT, 20, W, LENGTH, c.n_lanes, cal.params)
        assert xy[-1, 0, 1] == pytest.approx(c.actual[-1, 1], abs=0.05)
    assert calibrate_joint_physics(cases) == cal  # deterministic
    save_joint_params(cal, tmp_path / "p.json")
    assert load_joint_params(tmp_path / "p.json") == cal.params
    assert json.loads((tmp_path / "p.json").read_text())["n_cases"] == len(cases)


FULL = JointPhysicsParams().to_json()


@pytest.mark.parametrize(
    ("content", "said"),
    [
        ({"rmse_m": 1.0}, r': no "params" object: not a joint physics parameters file '
                          r"\(drivestyle evaluate-prediction --calibrate-joint-physics"),
        ({"params": {**FULL, "headway_s": 1.0}}, r": params: unknown headway_s \(expected "),
        ({"params": {**FULL, "politeness": -0.5}},
         r": params\.politeness -0\.5 is not a finite number ≥ 0$"),
        ({"params": {**FULL, "time_gap_s": 0.0}},
         r": params\.time_gap_s 0\.0 is not a finite number > 0$"),
        ({"params": {**FULL, "threshold_mps2": 5.0}},
         r": params\.threshold_mps2 5 lies outside \[0, 2\], the range calibration keeps to$"),
    ],
    ids=["no-params", "unknown", "negative-politeness", "zero-gap", "out-of-range"],
)  # fmt: skip
def test_a_bad_parameters_file_is_one_line_naming_it_and_the_problem(tmp_path, content, said):
    path = tmp_path / "joint.json"
    path.write_text(json.dumps(content))
    with pytest.raises(ValueError, match=re.escape(str(path)) + said) as info:
        load_joint_params(path)
    assert "\n" not in str(info.value)


def test_a_politeness_of_zero_is_a_valid_file(tmp_path):
    path = tmp_path / "joint.json"
    path.write_text(json.dumps({"params": {**FULL, "politeness": 0}}))
    assert load_joint_params(path).politeness == 0


def test_the_shipped_calibration_loads():
    assert isinstance(load_joint_params(JOINT_PHYSICS_FILE), JointPhysicsParams)
