"""Another prediction run read back to calibrate the regions (studies/prediction/runs.py)."""

import json

import pytest

from drivestyle.prediction.regions import kind_region_rates
from drivestyle.studies.prediction import calibration_records, read_prediction_run


def _write(path, records, split="validation"):
    path.write_text(json.dumps({"split": split, "records": records}))
    return path


def _row(k, **extra):
    return {"set": "cats", "t_obs_s": 1.0, "horizon_s": 2.0, "fde_m": {"cv": float(k)}} | extra


def test_a_run_written_before_the_kinds_reads_as_lane_changes(tmp_path):
    run = read_prediction_run(_write(tmp_path / "old.json", [_row(k) for k in range(1, 11)]))
    rows = calibration_records(run, [1.0])
    assert len(rows) == 10 and "kind" not in rows[0]
    rates = kind_region_rates(rows, min_records=10)
    assert not rates["lane_change", "cv", 1.0].pooled  # its ten records are lane changes
    following = rates["car_following", "cv", 1.0]
    assert following.pooled and following.n_kind == 0


def test_a_runs_kinds_are_checked(tmp_path):
    ok = [_row(k, kind="car_following", stop_and_go=k < 3) for k in range(1, 11)]
    assert len(read_prediction_run(_write(tmp_path / "ok.json", ok)).records) == 10
    with pytest.raises(ValueError, match=r"record 0, kind: 'merging' is not an episode kind"):
        read_prediction_run(_write(tmp_path / "k.json", [_row(1, kind="merging")]))
    with pytest.raises(ValueError, match=r"record 0, stop_and_go: 'yes' is not true or false"):
        read_prediction_run(_write(tmp_path / "s.json", [_row(1, stop_and_go="yes")]))
