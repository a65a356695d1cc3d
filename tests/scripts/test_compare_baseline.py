"""compare_baseline.py --heldout with a driver-style file (the default style model)."""

import json
import runpy
from pathlib import Path

import pytest

from drivestyle.common.io import write_json
from drivestyle.irl.driver.driver_style import DRIVER_STYLE_KIND, DriverStyle
from drivestyle.irl.paper.style import StyleError

ROOT = Path(__file__).resolve().parents[2]


def _main(name):
    return runpy.run_path(str(ROOT / "scripts" / f"{name}.py"), run_name="not_main")["main"]


@pytest.fixture()
def driver_file(tmp_path):
    style = DriverStyle((0.2, 34.0, 0.2, 1.0, 76.0), risk=0.6)
    return write_json(tmp_path / "driver" / "style.json",
                      {"kind": DRIVER_STYLE_KIND, "style": style.to_json()})  # fmt: skip


def test_heldout_with_a_driver_style_writes_the_style_entry(tmp_path, driver_file):
    out = tmp_path / "cmp"
    args = ["--style", str(driver_file.parent), "--heldout", "1", "--risk", "0.6"]
    payload = _main("compare_baseline")([*args, "--seed", "3000", "--out", str(out)])
    js = json.loads((out / "heldout.json").read_text())
    assert list(js["summary"]) == ["smpc", "style"] == list(payload["summary"])
    assert js["driver_style"]["risk"] == 0.6 and js["risk"] == 0.6
    for key in ("median_rmse_y_m", "median_rmse_xy_m", "collisions", "min_d_k", "n"):
        assert key in js["summary"]["style"]
    assert (out / "heldout.png").stat().st_size > 5_000


def test_spline_style_must_be_a_paper_style(tmp_path, driver_file):
    args = ["--style", str(driver_file), "--spline-style", str(driver_file), "--heldout", "1"]
    with pytest.raises(StyleError, match="not a paper-model style"):
        _main("compare_baseline")([*args, "--out", str(tmp_path / "cmp")])
