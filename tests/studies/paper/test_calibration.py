"""The TV-uncertainty scan returns a typed result that keeps calibration.json's keys."""

import pytest

from drivestyle.studies.paper.calibration import SCAN_KEYS, UncertaintyScan, uncertainty_scan


def test_uncertainty_scan_is_typed_and_keeps_the_calibration_keys():
    scan = uncertainty_scan([1.0], [0.7])
    assert isinstance(scan, UncertaintyScan) and list(scan.demos) == [0.7]
    js = scan.to_json()
    assert list(js) == ["base_uncertainty", "rows", "paper"]
    assert set(js["rows"][0]) == {"scale", "risk", *SCAN_KEYS, "final_y"}
    assert js["rows"][0]["t_trg_s"] == pytest.approx(3.0)
