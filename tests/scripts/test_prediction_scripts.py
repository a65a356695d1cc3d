"""predict_trajectory.py and evaluate_prediction.py: the files they write and their keys."""

import json
from pathlib import Path

import pytest

from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.driver_style import DriverStyle
from drivestyle.irl.forecast import METHODS, ForecastError
from drivestyle.irl.library import DriverLibrary
from drivestyle.scripts import evaluate_prediction, predict_trajectory

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"


@pytest.fixture(scope="module")
def files(tmp_path_factory, paper_demo):
    d = tmp_path_factory.mktemp("predict")
    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9, 0.95))
    (d / "library.json").write_text(json.dumps(lib.to_json()))
    save_demonstration(paper_demo, d / "demo.npz")
    return d


def test_predict_trajectory_writes_every_method(files):
    out = files / "out"
    payload = predict_trajectory.main(
        [str(files / "demo.npz"), "--library", str(files), "--observe", "2", "--out", str(out)]
    )
    js = json.loads((out / "prediction.json").read_text())
    assert (out / "prediction.png").stat().st_size > 0
    assert list(js["methods"]) == list(METHODS)  # an SMPC demo: the oracle too
    for m in js["methods"].values():
        assert {"ade_m", "fde_m", "path"} <= set(m)
        assert len(m["path"]) == len(js["actual"])
    assert js["t_obs_s"] == 2.0 and js["true_risk"] == 0.7 and js["recorded"] is False
    assert js["command"].endswith("--out " + str(out))
    assert payload["methods"]["oracle"]["fde_m"] < 0.05


@pytest.mark.parametrize("observe", ["0.3", "1000"])
def test_predict_trajectory_refuses_windows_the_demo_cannot_serve(files, observe):
    with pytest.raises(ForecastError):
        predict_trajectory.main(
            [str(files / "demo.npz"), "--library", str(files), "--observe", observe,
             "--out", str(files / "bad")]
        )  # fmt: skip
    assert not (files / "bad").exists()


def test_evaluate_prediction_writes_json_report_and_figures(files):
    out = files / "eval"
    evaluate_prediction.main(
        ["--library", str(files), "--out", str(out), "--vehicles", "2", "--no-recorded",
         "--observe", "1", "--seed", "19000"]
    )  # fmt: skip
    js = json.loads((out / "prediction_eval.json").read_text())
    assert {"summaries", "goal_checks", "tracking_summary", "records", "command"} <= set(js)
    assert js["command"].endswith("--observe 1 --seed 19000") and js["seed"] == 19000
    assert js["recorded_sets"] == [] and js["n_records"] + js["n_skipped"] >= 2
    assert {s["method"] for s in js["summaries"]} == set(METHODS)
    for name in ("report.md", "fde_by_method.png", "posterior_over_time.png",
                 "example_prediction.png"):  # fmt: skip
        assert (out / name).stat().st_size > 0
    assert "## Goals" in (out / "report.md").read_text()


def test_evaluate_prediction_needs_the_data_folders(files):
    with pytest.raises(FileNotFoundError, match="--data-dir"):
        evaluate_prediction.main(
            ["--library", str(files), "--out", str(files / "e2"),
             "--data-dir", str(files)]
        )  # fmt: skip


@pytest.mark.slow  # compiles the episode's solver on a fresh machine
@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")
def test_predict_trajectory_on_a_recorded_episode(tmp_path):
    from drivestyle.agents.studies.prediction import load_recorded

    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9, 0.95))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    _, raw = load_recorded(DATA, "cats")[0]
    save_demonstration(raw, tmp_path / "episode.npz")
    js = predict_trajectory.main(
        [str(tmp_path / "episode.npz"), "--library", str(tmp_path), "--observe", "2",
         "--out", str(tmp_path / "out")]
    )  # fmt: skip
    assert js["recorded"] is True and js["true_risk"] is None
    assert list(js["methods"]) == [m for m in METHODS if m != "oracle"]
    assert js["v_ref_mps"] > 1.0
