"""Calibrating the physics predictor (prediction/physics_calibration.py) and its file."""

import json
import re

import numpy as np
import pytest

from drivestyle.prediction.physics import PhysicsParams, physics_forecast
from drivestyle.prediction.physics_calibration import (
    PHYSICS_FILE,
    PhysicsCase,
    calibrate_physics,
    load_params,
    save_params,
)


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


def test_the_shipped_calibration_loads():
    assert isinstance(load_params(PHYSICS_FILE), PhysicsParams)
