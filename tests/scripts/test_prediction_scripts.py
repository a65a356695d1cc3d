"""predict_trajectory.py and evaluate_prediction.py: the files they write and their keys."""

import json
from dataclasses import replace
from pathlib import Path

import pytest

from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.prediction.methods import AMORTIZED_METHODS, METHODS
from drivestyle.prediction.protocol import ForecastError
from drivestyle.recorded.benchmark import episodes_split
from drivestyle.scripts import evaluate_prediction, predict_trajectory

RUN = [m for m in METHODS if m not in AMORTIZED_METHODS]  # without --posterior
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"


@pytest.fixture(scope="module")
def files(tmp_path_factory, paper_demo):
    d = tmp_path_factory.mktemp("predict")
    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9, 0.95))
    (d / "library.json").write_text(json.dumps(lib.to_json()))
    save_demonstration(paper_demo, d / "demo.npz")
    return d


def test_predict_trajectory_writes_every_method(files, capsys):
    out = files / "out"
    payload = predict_trajectory.main(
        [str(files / "demo.npz"), "--library", str(files), "--observe", "2", "--out", str(out)]
    )
    js = json.loads((out / "prediction.json").read_text())
    assert (out / "prediction.png").stat().st_size > 0
    assert list(js["methods"]) == RUN  # an SMPC demo: the oracle too
    for m in js["methods"].values():
        assert {"ade_m", "fde_m", "path"} <= set(m)
        assert len(m["path"]) == len(js["actual"])
    assert js["t_obs_s"] == 2.0 and js["true_risk"] == 0.7 and js["recorded"] is False
    assert js["command"].endswith("--out " + str(out))
    assert payload["methods"]["oracle"]["fde_m"] < 0.05
    assert js["identified"]["verdict"] == "informative" and js["identified"]["informative"]
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("observed 2 s, predicted 4.0 s; identified risk 0.700 (90 % [")


def test_predict_trajectory_says_when_the_posterior_is_the_prior(files, capsys):
    from drivestyle.agents import generate_demonstration
    from drivestyle.envs.scenario import PAPER

    far = PAPER.with_overrides(tv_gap=-1000.0, tv_speed=25.0, ev_speed=25.0)
    save_demonstration(generate_demonstration(0.7, far)[0], files / "far.npz")
    out = files / "far_out"
    js = predict_trajectory.main(
        [str(files / "far.npz"), "--library", str(files), "--observe", "2", "--out", str(out)]
    )
    assert js["identified"]["verdict"] == "no_constraint" and not js["identified"]["informative"]
    first = capsys.readouterr().out.splitlines()[0]
    assert "; the prior: nothing in the data can move the risk; posterior mean 0.745" in first
    assert "identified risk" not in first


def test_predict_trajectory_refuses_a_jump_after_the_observed_part(files, paper_demo):
    from drivestyle.envs.demonstration import DemonstrationError

    ev = paper_demo.ev.copy()
    ev[25:, 0] += 50.0  # the scored future jumps 50 m in one step
    save_demonstration(replace(paper_demo, ev=ev), files / "jump.npz")
    with pytest.raises(DemonstrationError, match="implausible"):
        predict_trajectory.main(
            [str(files / "jump.npz"), "--library", str(files), "--observe", "2",
             "--out", str(files / "jumped")]
        )  # fmt: skip
    assert not (files / "jumped").exists()


@pytest.mark.parametrize("observe", ["0.3", "1000"])
def test_predict_trajectory_refuses_windows_the_demo_cannot_serve(files, observe):
    with pytest.raises(ForecastError):
        predict_trajectory.main(
            [str(files / "demo.npz"), "--library", str(files), "--observe", observe,
             "--out", str(files / "bad")]
        )  # fmt: skip
    assert not (files / "bad").exists()


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
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
    assert {s["method"] for s in js["summaries"]} == set(RUN)
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
    from drivestyle.recorded.benchmark import load_recorded

    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9, 0.95))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    _, raw = load_recorded(DATA, "cats")[0]
    save_demonstration(raw, tmp_path / "episode.npz")
    js = predict_trajectory.main(
        [str(tmp_path / "episode.npz"), "--library", str(tmp_path), "--observe", "2",
         "--out", str(tmp_path / "out")]
    )  # fmt: skip
    assert js["recorded"] is True and js["true_risk"] is None
    assert list(js["methods"]) == [m for m in RUN if m != "oracle"]
    assert js["v_ref_mps"] > 1.0


class _StartedError(Exception):
    """Raised instead of the work: the arguments were accepted."""


@pytest.mark.parametrize(
    ("observe", "match"),
    [
        ("100", r"100 s: no vehicle of this run lasts that long.*simulated ones 6 s"),
        ("=1e308", r"1e\+308 s: no vehicle"),
        ("0.3", r"0.3 s is not a whole number of the vehicles' T_s = 0.2 s; use 0.2 or 0.4 s"),
        ("inf", r"finite and > 0"),
        ("nan", r"finite and > 0"),
    ],
)
def test_evaluate_prediction_refuses_observe_times_before_the_work(files, monkeypatch, observe,
                                                                    match):  # fmt: skip
    from drivestyle.studies.prediction import study

    def started(*args, **kwargs):
        raise _StartedError

    monkeypatch.setattr(study, "draw_simulated", started)
    monkeypatch.setattr(evaluate_prediction, "load_driver_library", started)
    option = ["--observe" + observe] if observe.startswith("=") else ["--observe", observe]
    with pytest.raises(ValueError, match=rf"^--observe: observed time.*{match}"):
        evaluate_prediction.main(
            ["--library", str(files), "--out", str(files / "refused"), "--no-recorded", *option]
        )
    assert not (files / "refused").exists()


def test_evaluate_prediction_counts_a_repeated_observe_time_once_and_says_so(
    files, monkeypatch, capsys
):
    seen = {}

    def started(library, n, seed, data_dir, t_obs, *args, **kwargs):
        seen["t_obs"] = t_obs
        raise _StartedError

    monkeypatch.setattr(evaluate_prediction, "evaluate_prediction", started)
    with pytest.raises(_StartedError):
        evaluate_prediction.main(
            ["--library", str(files), "--out", str(files / "dup"), "--no-recorded",
             "--observe", "1,1,2,1"]
        )  # fmt: skip
    assert seen["t_obs"] == [1.0, 2.0]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["note: --observe lists 1 s more than once; each time counts once"]


@pytest.mark.slow  # reads every recorded episode: CI runs it (pytest -m slow)
@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")
def test_observe_times_reach_the_recorded_episodes():
    from drivestyle.recorded.benchmark import load_recorded
    from drivestyle.studies.prediction import check_observed_times

    recorded = [d for ds in ("ngsim", "cats") for _, d in load_recorded(DATA, ds)]
    assert check_observed_times([7.0, 7.0], recorded) == (7.0,)  # 8 s recorded windows
    with pytest.raises(ValueError, match=r"simulated ones 6 s and recorded ones at most 8 s"):
        check_observed_times([8.0], recorded)
    with pytest.raises(ValueError, match="observe less than 6 s"):
        check_observed_times([7.0], [])


def test_regions_calibrated_on_the_split_they_judge_are_refused(files, tmp_path):
    run = tmp_path / "val.json"
    run.write_text(json.dumps({"split": "validation", "records": [
        {"set": "cats", "t_obs_s": 1.0, "horizon_s": 3.0, "fde_m": {"cv": 1.0}}]}))  # fmt: skip
    argv = ["--library", str(files), "--no-simulated", "--out", str(tmp_path / "o")]
    with pytest.raises(ValueError, match="validation split itself: calibrate on another split"):
        evaluate_prediction.main([*argv, "--regions-from", str(run)])
    (tmp_path / "val").mkdir()
    run.rename(tmp_path / "val" / "prediction_eval.json")  # a run folder names its JSON
    with pytest.raises(ValueError, match="validation split itself"):
        evaluate_prediction.main([*argv, "--regions-from", str(tmp_path / "val")])
    (tmp_path / "bad.json").write_text('{"records": 3}')
    with pytest.raises(ValueError, match=r"not a prediction_eval\.json"):
        evaluate_prediction.main(
            [*argv, "--split", "test", "--regions-from", str(tmp_path / "bad.json")]
        )
    assert not (tmp_path / "o").exists()


def test_predict_trajectory_in_its_own_process_is_the_benchmarks_prediction(files, paper_demo):
    """The command, run as a user runs it, predicts a recorded episode exactly as the
    benchmark does at the same t_obs, method by method (the same view, frame and physics)."""
    import subprocess
    import sys

    import numpy as np

    from drivestyle.irl.identification.library import load_driver_library
    from drivestyle.prediction.joint_physics_calibration import (
        JOINT_PHYSICS_FILE,
        load_joint_params,
    )
    from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params
    from drivestyle.studies.prediction import predict_vehicle

    others = np.repeat(paper_demo.tv[:, None, :], 2, axis=1).copy()
    others[:, 0, 0] += 30.0  # a leader in the target lane
    others[:, 1, 0] += 60.0
    others[:, 1, 1] -= paper_demo.scenario.lane_width  # one ahead in the own lane
    meta = {k: v for k, v in paper_demo.meta.items() if k not in ("risk", "smpc")}
    recorded = replace(
        paper_demo, others=others, meta={**meta, "episode_id": "as-recorded"}, origin="recorded"
    )
    save_demonstration(recorded, files / "recorded.npz")
    out = files / "recorded_out"
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", "predict-trajectory", str(files / "recorded.npz"),
         "--library", str(files), "--observe", "1.4", "--out", str(out)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    js = json.loads((out / "prediction.json").read_text())
    (record,), skipped = predict_vehicle(
        "x", "as-recorded", recorded, load_driver_library(files, "prediction"), (1.4,),
        physics=load_params(PHYSICS_FILE), joint_physics=load_joint_params(JOINT_PHYSICS_FILE),
    )  # fmt: skip
    assert not skipped and js["recorded"] is True
    assert list(js["methods"]) == [m for m in RUN if m != "oracle"]
    for method, m in js["methods"].items():
        assert m["fde_m"] == pytest.approx(record.fde_m[method], abs=1e-9), method
        assert m["ade_m"] == pytest.approx(record.ade_m[method], abs=1e-9), method
        path = np.asarray(m["path"])  # in the observer's frame, shifted by whole lanes
        assert np.allclose(path, record.prediction.methods[method].xy, atol=1e-4), method
    # the frame's shift is a whole number of lanes and the paths are in it
    w = recorded.scenario.lane_width
    assert js["lateral_shift_m"] / w == pytest.approx(round(js["lateral_shift_m"] / w))
    k = round(1.4 / recorded.scenario.dt)
    assert js["actual"][0][1] == pytest.approx(recorded.ev[k, 1] + js["lateral_shift_m"], abs=1e-4)


def _episodes_folder(folder: Path, paper_demo, n: int = 2, kinds: tuple[str, ...] = ()) -> Path:
    """A folder as extract-episodes writes it: n recorded-like episodes of n vehicles.

    ``kinds``: the episodes' kinds in their metadata (none: as written before the kinds).
    """
    import csv

    import numpy as np

    folder.mkdir()
    rows = []
    for i in range(n):
        others = paper_demo.tv[:, None, :].copy()
        others[:, 0, 0] += 30.0 + 5 * i  # a leader in the target lane
        meta = {k: v for k, v in paper_demo.meta.items() if k not in ("risk", "smpc")}
        meta = {**meta, "episode_id": f"r_{i}_1000"} | ({"kind": kinds[i]} if kinds else {})
        demo = replace(paper_demo, others=others, meta=meta, origin="recorded")
        save_demonstration(demo, folder / f"r_{i}_1000.npz")
        rows.append([f"r_{i}_1000", f"r_{i}_1000.npz", "r", str(i), "True"])
    rows.append(["r_9_2000", "", "r", "9", "False"])  # unusable rows have no file
    with (folder / "episodes.csv").open("w", newline="") as f:
        csv.writer(f).writerows([["episode_id", "file", "carriageway", "vehicle_id", "usable"],
                                 *rows])  # fmt: skip
    assert np.isfinite(paper_demo.ev).all()
    return folder


@pytest.mark.slow  # two episodes' style rollouts at one t_obs in a fresh process (≈ 15 s)
def test_evaluate_prediction_benchmarks_an_episodes_folder(files, paper_demo, tmp_path):
    import subprocess
    import sys

    from drivestyle.envs.demonstration import load_demonstration
    from drivestyle.irl.identification.library import load_driver_library
    from drivestyle.prediction.joint_physics_calibration import (
        JOINT_PHYSICS_FILE,
        load_joint_params,
    )
    from drivestyle.prediction.methods import predict_demo
    from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params

    folder = _episodes_folder(tmp_path / "eps", paper_demo, kinds=("lane_change", "approaching"))
    out = tmp_path / "bench"
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", "evaluate-prediction", "--library", str(files),
         "--episodes", str(folder), "--split", "all", "--observe", "2", "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    js = json.loads((out / "prediction_eval.json").read_text())
    assert js["recorded_sets"] == ["episodes"] and js["n_records"] == 2
    assert {s["method"] for s in js["summaries"]} == set(RUN) - {"oracle"}
    library = load_driver_library(files, "prediction")
    for rec in js["records"]:  # each record is the prediction of its episode
        demo = load_demonstration(folder / f"{rec['vehicle_id']}.npz")
        pred = predict_demo(
            demo,
            library,
            2.0,
            physics=load_params(PHYSICS_FILE),
            joint_physics=load_joint_params(JOINT_PHYSICS_FILE),
        )
        for m, fde in rec["fde_m"].items():
            assert fde == pytest.approx(pred.methods[m].fde_m, abs=1e-9), m
    assert not (out / "split.csv").exists()  # --split all: no split was made
    # every table by kind too: each episode's kind read from its file, pooled as before
    assert [r["kind"] for r in js["records"]] == ["lane_change", "approaching"]
    assert {(s["kind"], s["n"]) for s in js["summaries_by_kind"]} == {
        ("lane_change", 1), ("approaching", 1)}  # fmt: skip
    assert {s["kind"] for s in js["summaries"]} == {"all"} and js["fde_ratios"]
    assert (out / "fde_by_kind.png").stat().st_size > 0
    assert "### approaching" in (out / "report.md").read_text()
    # no simulated vehicles: no empty section of them ("0 vehicles … never") and no bar
    assert "Online identification" not in (out / "report.md").read_text()
    assert "Online identification" not in run.stdout
    assert "simulated vehicles" not in run.stderr and "recorded vehicles" in run.stderr


def test_evaluate_prediction_splits_an_episodes_folder_by_vehicle(files, paper_demo, tmp_path):
    from drivestyle.recorded.benchmark import episodes_split, read_split

    folder = _episodes_folder(tmp_path / "eps", paper_demo, n=5)
    rows = episodes_split(folder)
    assert [r.vehicle_id for r in rows] == [f"r:{i}" for i in range(5)]
    assert {r.split for r in rows} == {"train", "validation", "test"}
    assert all(r.dataset == "episodes" for r in rows)
    evaluate_prediction.main(["--episodes", str(folder), "--write-split", "--split-file",
                              str(tmp_path / "s.csv")])  # fmt: skip
    assert read_split(tmp_path / "s.csv") == rows
    # a split without a row for one of the folder's episodes is refused, naming it
    (tmp_path / "short.csv").write_text(
        "dataset,episode_id,vehicle_id,split\n"
        + "".join(f"episodes,r_{i}_1000,r:{i},test\n" for i in range(4))
    )
    with pytest.raises(ValueError, match=r"no row for 1 of the 5.*r_4_1000"):
        evaluate_prediction.main(
            ["--library", str(files), "--episodes", str(folder), "--split-file",
             str(tmp_path / "short.csv"), "--split", "test", "--out", str(tmp_path / "o")]
        )  # fmt: skip
    with pytest.raises(ValueError, match="--split all: every episode of an --episodes folder"):
        evaluate_prediction.main(["--library", str(files), "--split", "all", "--no-simulated",
                                  "--out", str(tmp_path / "o2")])  # fmt: skip
    with pytest.raises(ValueError, match="--write-split needs --split-file"):
        evaluate_prediction.main(["--episodes", str(folder), "--write-split"])
    # never over the shipped calibrations: each file to write is named
    for flag, option in (("--calibrate-physics", "--physics"),
                         ("--calibrate-joint-physics", "--joint-physics")):  # fmt: skip
        with pytest.raises(ValueError, match=f"^--episodes {flag} needs {option} \\(the file"):
            evaluate_prediction.main(["--episodes", str(folder), flag])


@pytest.mark.slow  # two least-squares calibrations on an episodes folder's train split (≈ 20 s)
def test_calibrating_both_physics_baselines_on_an_episodes_folder(paper_demo, tmp_path):
    from drivestyle.prediction.joint_physics_calibration import load_joint_params
    from drivestyle.prediction.physics_calibration import load_params

    folder = _episodes_folder(tmp_path / "eps", paper_demo, n=5)
    physics, joint = tmp_path / "physics.json", tmp_path / "joint.json"
    out = evaluate_prediction.main(
        ["--episodes", str(folder), "--calibrate-physics", "--physics", str(physics),
         "--calibrate-joint-physics", "--joint-physics", str(joint), "--observe", "2"]
    )  # fmt: skip
    assert set(out) == {"physics", "joint_physics"}
    assert load_params(physics).to_json() == out["physics"]["params"]
    assert load_joint_params(joint).to_json() == out["joint_physics"]["params"]
    train = sum(r.split == "train" for r in episodes_split(folder))
    assert out["joint_physics"]["n_cases"] == out["physics"]["n_cases"] == train
    alone = evaluate_prediction.main(
        ["--episodes", str(folder), "--calibrate-joint-physics", "--joint-physics",
         str(tmp_path / "joint2.json"), "--observe", "2"]
    )  # fmt: skip
    assert alone == out["joint_physics"]  # one calibration asked: its JSON alone


@pytest.mark.slow  # extraction, then three NGSIM episodes predicted twice (≈ 40 s)
@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")
def test_the_ngsim_sample_as_ones_own_csv_gives_the_shipped_benchmarks_numbers(files, tmp_path):
    """The shipped NGSIM sample written as one generic CSV (a recording column) with a lanes
    file, extracted and benchmarked with --episodes, equals the shipped benchmark's path."""
    import subprocess
    import sys

    from drivestyle.irl.identification.library import load_driver_library
    from drivestyle.prediction.joint_physics_calibration import (
        JOINT_PHYSICS_FILE,
        load_joint_params,
    )
    from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params
    from drivestyle.recorded.benchmark import SPLIT_FILE, read_split, recorded_episodes
    from drivestyle.recorded.readers import read_sample, write_table
    from drivestyle.studies.prediction import predict_vehicle, summarise_records

    write_table(read_sample(DATA / "ngsim"), tmp_path / "tracks.csv", tmp_path / "lanes.json")
    env = {"cwd": tmp_path, "capture_output": True, "text": True, "timeout": 900}
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", "extract-episodes", "tracks.csv", "--format", "csv",
         "--lanes", "lanes.json", "--out", "eps"], **env,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", "evaluate-prediction", "--library", str(files),
         "--episodes", "eps", "--split-file", str(SPLIT_FILE), "--split", "validation",
         "--observe", "2", "--out", "bench"], **env,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    own = json.loads((tmp_path / "bench" / "prediction_eval.json").read_text())
    # the shipped path: the same episodes from the sample reader, the same split and physics
    rows = [r for r in read_split(SPLIT_FILE) if r.dataset == "ngsim" and r.split == "validation"]
    shipped = {e: d for e, _, d in recorded_episodes(str(DATA), "ngsim")}
    library, physics = load_driver_library(files, "prediction"), load_params(PHYSICS_FILE)
    joint = load_joint_params(JOINT_PHYSICS_FILE)
    records = []
    for r in rows:
        recs, skipped = predict_vehicle("ngsim", r.episode_id, shipped[r.episode_id], library,
                                        (2.0,), physics=physics, unit=r.vehicle_id,
                                        joint_physics=joint)  # fmt: skip
        records += recs
        assert not skipped
    assert own["recorded_sets"] == ["ngsim"] and own["n_records"] == len(records) == 3
    by_id = {rec["vehicle_id"]: rec for rec in own["records"]}
    for rec in records:
        for m, fde in rec.fde_m.items():
            assert by_id[rec.vehicle_id]["fde_m"][m] == pytest.approx(fde, abs=1e-9), m
            assert by_id[rec.vehicle_id]["ade_m"][m] == pytest.approx(rec.ade_m[m], abs=1e-9), m
    # and the tables: the same medians and bootstrap intervals over the same vehicles
    theirs = {(s.set, s.t_obs, s.method): s.to_json() for s in summarise_records(records)}
    for s in own["summaries"]:
        mine = theirs[(s["set"], s["t_obs"], s["method"])]
        assert s["n_units"] == mine["n_units"] == 3
        for metric, stat in s["stats"].items():
            assert stat == pytest.approx(mine["stats"][metric]), (s["method"], metric)


@pytest.mark.slow  # two episodes' amortized styles in two fresh worker processes (≈ 30 s)
def test_the_amortized_styles_through_the_command_in_workers(
    files, paper_demo, tmp_path, tiny_posterior
):
    """``--posterior`` with ``--workers 2``: the checked estimator must not hang the forked
    workers (it did: the parent's torch thread pool does not survive a fork)."""
    import subprocess
    import sys

    from drivestyle.envs.demonstration import load_demonstration
    from drivestyle.irl.amortized.identify import open_posterior
    from drivestyle.prediction.methods import AMORTIZED_METHODS, predict_demo

    _, posterior_file = tiny_posterior
    folder = _episodes_folder(tmp_path / "eps", paper_demo)
    out = tmp_path / "bench"
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", "evaluate-prediction", "--library", str(files),
         "--episodes", str(folder), "--split", "all", "--observe", "2", "--workers", "2",
         "--posterior", str(posterior_file), "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    js = json.loads((out / "prediction_eval.json").read_text())
    posterior = open_posterior(posterior_file)
    for rec in js["records"]:
        demo = load_demonstration(folder / f"{rec['vehicle_id']}.npz")
        pred = predict_demo(demo, None, 2.0, methods=AMORTIZED_METHODS, amortized=posterior)
        for m in AMORTIZED_METHODS:
            assert rec["fde_m"][m] == pytest.approx(pred.methods[m].fde_m, abs=1e-6), m
    assert (out / "joint_scene.png").stat().st_size > 0
