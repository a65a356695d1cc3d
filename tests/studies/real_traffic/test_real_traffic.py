"""The recorded-traffic study, paper model (studies/real_traffic/study.py) and its command."""

import json
import runpy
from pathlib import Path

import numpy as np
import pytest

from drivestyle.irl.metrics import trajectory_errors
from drivestyle.recorded.real_data import load_cats, load_ngsim
from drivestyle.studies.real_traffic import (
    classify_loo,
    constant_velocity,
    episode_feature_config,
    learn_personal,
)

ROOT = Path(__file__).resolve().parents[3]
DATA = ROOT.parent / "shared" / "data"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")


def test_learning_one_real_episode_beats_constant_velocity():
    episode = next(e for e in load_ngsim(DATA / "ngsim") if e.used)
    demo = episode.demo
    personal = learn_personal(demo, "reactive")
    cv = trajectory_errors(constant_velocity(demo), demo)
    assert personal["rmse_y_m"] < cv["rmse_y_m"]
    assert personal["rmse_y_m"] < 0.5


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_feature_constants_come_from_the_episode():
    episode = next(e for e in load_cats(DATA / "cats-av-lanechange") if e.used)
    cfg = episode_feature_config(episode.demo)
    d = episode.demo
    assert cfg.l_initial == pytest.approx(d.ev[:5, 1].mean())
    assert cfg.l_des == pytest.approx(d.ev[-5:, 1].mean())
    assert cfg.v_des == pytest.approx(d.ev[-5:, 3].mean()) and cfg.v_des < 10


def test_constant_velocity_is_exact_on_a_straight_line():
    episode = next(e for e in load_ngsim(DATA / "ngsim") if e.used)
    d = episode.demo
    xy = constant_velocity(d)
    np.testing.assert_allclose(xy[0], d.ev[0, :2])
    np.testing.assert_allclose(np.diff(xy[:, 0]), d.ev[0, 3] * np.cos(d.ev[0, 2]) * 0.2)


def test_classify_loo_separates_separable_styles():
    rng = np.random.default_rng(0)
    names = ("ax", "v", "ay", "l")
    a = np.abs(rng.normal([5, 1, 1, 1], 0.1, size=(5, 4)))
    b = np.abs(rng.normal([1, 5, 1, 5], 0.1, size=(5, 4)))
    res = classify_loo(np.vstack([a, b]), ["A"] * 5 + ["B"] * 5, names)
    assert res["accuracy"] == 1.0 and res["p_value_vs_majority"] < 0.01


@pytest.mark.slow  # end to end: the whole command
def test_real_traffic_script_quick(tmp_path):
    main = runpy.run_path(str(ROOT / "scripts" / "real_traffic.py"), run_name="x")["main"]
    res = main(
        [
            "--dataset",
            "cats",
            "--data",
            str(DATA / "cats-av-lanechange"),
            "--out",
            str(tmp_path),
            "--limit",
            "3",
            "--workers",
            "1",
            "--model",
            "paper",  # the driver model's fits are tested above, one by one
        ]
    )
    js = json.loads((tmp_path / "real_traffic.json").read_text())
    assert js["model"] == "paper" and "driver" not in js
    assert set(js["median_rmse_y_m"]) == {
        "personal_reactive",
        "personal_base",
        "general",
        "constant_velocity",
    }
    used = [e for e in js["episodes"] if e["used"]]
    assert len(used) == 3 and all("rmse_y_m" in e["methods"]["general"] for e in used)
    assert all({"episode_id", "used"} <= set(e) for e in js["episodes"])
    assert "av_vs_hv" in res and (tmp_path / "real_traffic.md").is_file()
    assert len(list((tmp_path / "episodes").glob("*.png"))) == 3


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_real_traffic_bad_data_dir(tmp_path):
    import subprocess
    import sys

    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "scripts" / "real_traffic.py"),
            "--dataset",
            "ngsim",
            "--data",
            str(tmp_path),
            "--out",
            str(tmp_path / "o"),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode != 0 and proc.stderr.startswith("error:")
    assert "Traceback" not in proc.stderr
