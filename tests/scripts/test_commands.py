"""Every console command, run as a user runs it: ``python -m drivestyle <command> …`` in a
fresh process, in the smallest setting that still computes something, with a number the
computation must get right.

A test that calls a script's ``main`` in the test process shares that process's imports: a
command that crashed on every input (a registration only an import elsewhere provided)
passed such tests. Here each command starts from nothing. The inputs are written by the
commands themselves (module fixtures: a two-risk library, the paper's study, a tiny PPO
policy, a population), as the README chains them. :data:`COVERAGE` names the test of every
command, and the README's command lines are checked against the commands' own parsers.
"""

import ast
import importlib
import importlib.util
import json
import math
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivestyle.scripts import COMMANDS

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DATA = ROOT.parent / "shared" / "data"
needs_data = pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file()
    or not (DATA / "ngsim" / "tracks.csv.gz").is_file(),
    reason="the recorded datasets are absent",
)
LANE_WIDTH = 5.25  # the paper scenario's
EXPERT_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)  # the SMPC expert's cost, normalised by w_a


def _drivestyle(cwd: Path, command: str, *args, timeout: float = 900):
    """``python -m drivestyle COMMAND ARGS`` in a fresh process in ``cwd``; it must succeed."""
    env = {**os.environ, "MPLBACKEND": "Agg", "SDL_VIDEODRIVER": "dummy"}
    run = subprocess.run(
        [sys.executable, "-m", "drivestyle", command, *map(str, args)],
        cwd=cwd, capture_output=True, text=True, timeout=timeout, env=env,
    )  # fmt: skip
    assert run.returncode == 0, f"drivestyle {command}: exit {run.returncode}\n{run.stderr[-4000:]}"
    return run


def _json(path: Path) -> dict:
    return json.loads(Path(path).read_text())


def _finite(*values) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


# ---------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """The shared working folder: the fixtures' outputs under ``runs/``, as in the README."""
    return tmp_path_factory.mktemp("commands")


@pytest.fixture(scope="module")
def library(work):
    """A driver library of two risks in one scenario, two calibration scenarios (≈ 15 s)."""
    _drivestyle(work, "build-style-library", "--risks", "0.5,0.9", "--scenarios", "1",
                "--calibration", "2", "--out", "runs/library")  # fmt: skip
    return work / "runs" / "library"


@pytest.fixture(scope="module")
def paper(work):
    """The paper's whole study, as the README's first command runs it (≈ 10 s)."""
    _drivestyle(work, "reproduce-paper", "--out", "runs/paper")
    return work / "runs" / "paper"


@pytest.fixture(scope="module")
def baseline(work, paper):
    """A PPO policy on the paper's reactive style: one rollout's worth of training."""
    _drivestyle(work, "train-baseline", "--style", paper / "reactive" / "style.json",
                "--timesteps", "256", "--eval-freq", "128", "--out", "runs/baseline")  # fmt: skip
    return work / "runs" / "baseline"


@pytest.fixture(scope="module")
def population(work):
    """Three SMPC vehicles with known risks."""
    _drivestyle(work, "simulate-population", "--vehicles", "3", "--seed", "0",
                "--out", "runs/population")  # fmt: skip
    return work / "runs" / "population"


# ------------------------------------------------------------- default run (≈ 1–2 s each)
def test_generate_demo_changes_lane_at_the_papers_trigger_time(tmp_path):
    from drivestyle.envs import load_demonstration

    _drivestyle(tmp_path, "generate-demo", "--risk", "0.7", "--out", "demo")
    summary = _json(tmp_path / "demo" / "demo.json")
    assert summary["risk"] == 0.7 and summary["t_trg_s"] == pytest.approx(3.0)  # the paper's
    assert summary["collision"] is False and summary["final_lane"] == 1
    assert summary["n_solver_failures"] == 0 and summary["min_s_e"] > 1.0
    demo = load_demonstration(tmp_path / "demo" / "demo.npz")
    assert demo.meta["risk"] == 0.7 and demo.ev.shape == (31, 4)
    assert demo.ev[-1, 1] - demo.ev[0, 1] == pytest.approx(LANE_WIDTH, abs=0.1)  # one lane left
    assert np.all(np.diff(demo.ev[:, 0]) > 0)  # forward all along


def test_simulate_population_writes_vehicles_of_known_risk(population):
    from drivestyle.envs import load_demonstration

    payload = _json(population / "population.json")
    assert payload["n_ok"] == 3 and payload["n_failed"] == 0
    vehicles = payload["vehicles"]
    assert len(vehicles) == 3 and len({v["risk"] for v in vehicles}) == 3
    for v in vehicles:
        assert 0.5 <= v["risk"] <= 0.95
        demo = load_demonstration(population / v["file"])
        assert demo.meta["risk"] == pytest.approx(v["risk"])


def test_calibrate_uncertainty_triggers_at_the_papers_time_at_scale_one(tmp_path):
    _drivestyle(tmp_path, "calibrate-uncertainty", "--scales", "1", "--risks", "0.7,0.9",
                "--out", "cal")  # fmt: skip
    rows = {r["risk"]: r for r in _json(tmp_path / "cal" / "calibration.json")["rows"]}
    assert set(rows) == {0.7, 0.9} and all(r["scale"] == 1.0 for r in rows.values())
    assert rows[0.7]["t_trg_s"] == pytest.approx(3.0)  # what the scale was calibrated to
    assert rows[0.9]["min_s_e"] > rows[0.7]["min_s_e"]  # the cautious driver keeps farther
    assert not any(r["collision"] for r in rows.values())


def test_bench_env_counts_every_step_it_times(tmp_path):
    _drivestyle(tmp_path, "bench-env", "--steps", "200", "--trials", "1", "--out", "env.json")
    cases = _json(tmp_path / "env.json")["cases"]
    assert set(cases) == {"lane_change", "traffic", "style_paper", "style_driver"}
    for case in cases.values():
        assert _finite(case["steps_per_s"]) and case["steps_per_s"] > 0
        assert case["us_per_step"] == pytest.approx(1e6 / case["steps_per_s"])
        assert case["episodes_per_trial"] * case["mean_episode_steps"] == pytest.approx(200)


def test_bench_stochastic_simulates_every_episode_it_times(tmp_path):
    _drivestyle(tmp_path, "bench-stochastic", "--episodes", "2", "--workers", "1",
                "--out", "stochastic.json")  # fmt: skip
    bench = _json(tmp_path / "stochastic.json")
    assert bench["episodes"] == len(bench["per_episode"]) == 2
    assert bench["steps"] == 2 * 40  # 8 s at T_s = 0.2 s
    assert 0 <= bench["failed_solves_share"] <= 1 and 0 <= bench["plausible_share"] <= 1
    assert bench["simulations_per_s_per_core"] == pytest.approx(2 / bench["wall_s"])
    assert 0 < bench["episode_s_median"] <= bench["episode_s_p95"]


@pytest.mark.slow  # the I-80 minute's extraction (≈ 10 s) and its windows at constant velocity
@needs_data
def test_bench_scene_prediction_predicts_every_window_of_the_minute(tmp_path, tiny_posterior):
    _, posterior = tiny_posterior
    _drivestyle(tmp_path, "bench-scene-prediction", "--posterior", posterior, "--methods",
                "cv", "--observe", "2", "--workers", "1", "--data-dir", DATA,
                "--out", "scene.json")  # fmt: skip
    bench = _json(tmp_path / "scene.json")
    assert bench["recording"] == "i80_1600_first60s" and bench["methods"] == ["cv"]
    assert bench["vehicles"] > 50 and bench["windows"] >= bench["vehicles"]  # 77 tracks
    assert bench["predictions"] == bench["windows"]  # every window at t_obs = 2 s
    assert bench["met"] == (bench["wall_s"] + bench["extract_s"] <= bench["goal_s"] == 300)
    assert 0 < bench["prediction_s"]["median"] <= bench["prediction_s"]["p95"]


@pytest.mark.slow  # ≈ 6 s: torch's import, 12 episodes, training
def test_build_posterior_writes_a_verified_estimator_and_its_calibration(tmp_path):
    pytest.importorskip("zuko")
    from drivestyle.irl.amortized.estimator import EstimatorFileError, load_posterior

    _drivestyle(tmp_path, "build-posterior", "--simulations", "8", "--held-out", "4",
                "--epochs", "2", "--hidden", "4", "--embedding", "4", "--transforms", "1",
                "--flow-hidden", "8", "--samples", "20", "--out", "post")  # fmt: skip
    build, cal = _json(tmp_path / "post/build.json"), _json(tmp_path / "post/calibration.json")
    assert build["simulations"] == 8 and build["held_out"] == 4
    assert build["training_rows"] == 16  # each episode whole and one prefix
    assert _finite(build["simulations_per_s_per_core"], build["training"]["validation_loss"],
                   build["training"]["seconds"])  # fmt: skip
    assert set(build["versions"]) >= {"drivestyle", "torch", "zuko"}
    assert cal["n_simulations"] == 4 and len(cal["parameters"]) == 9
    for row in cal["parameters"].values():
        assert _finite(row["mae"], row["mae_relative"], row["prior_mean_mae"], row["uniformity_p"])
        assert 0 <= row["coverage"] <= 1 and sum(row["rank_histogram"]) == 4
    assert 0 < cal["identification_ms"]["median"] <= cal["identification_ms"]["p95"]
    posterior = load_posterior(tmp_path / "post/posterior.npz")
    assert posterior.config.names[0] == "risk"
    # the file verifies: one flipped byte inside it is refused
    raw = bytearray((tmp_path / "post/posterior.npz").read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    (tmp_path / "bad.npz").write_bytes(bytes(raw))
    with pytest.raises(EstimatorFileError, match=r"bad\.npz"):
        load_posterior(tmp_path / "bad.npz")
    # another network on the kept simulations: the same set, not simulated again
    again = _drivestyle(tmp_path, "build-posterior", "--simulations", "8", "--held-out", "4",
                        "--epochs", "2", "--hidden", "4", "--embedding", "4", "--passes", "2",
                        "--flow-hidden", "8", "--samples", "20", "--out", "coupled",
                        "--reuse-simulations", "post/simulations.npz")  # fmt: skip
    assert "reused from post/simulations.npz" in again.stdout
    coupled = _json(tmp_path / "coupled/calibration.json")
    assert coupled["n_simulations"] == 4
    assert load_posterior(tmp_path / "coupled/posterior.npz").config.passes == 2
    refused = subprocess.run(
        [sys.executable, "-m", "drivestyle", "build-posterior", "--simulations", "8",
         "--held-out", "4", "--seed", "1", "--out", "other",
         "--reuse-simulations", "post/simulations.npz"],
        cwd=tmp_path, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert refused.returncode != 0 and "Traceback" not in refused.stderr
    assert "--reuse-simulations" in refused.stderr and "another seed" in refused.stderr


def test_bench_smpc_times_every_step_of_its_closed_loops(tmp_path):
    _drivestyle(tmp_path, "bench-smpc", "--repeats", "1", "--random", "1", "--trials", "1",
                "--no-jit", "--out", "smpc.json")  # fmt: skip
    bench = _json(tmp_path / "smpc.json")
    assert bench["n_steps"] == bench["random_n_steps"] == 30 and bench["failures"] == 0
    assert 0 < bench["median_ms"] <= bench["p95_ms"] <= bench["max_ms"]
    assert bench["speedup_vs_ipopt"] == pytest.approx(bench["ipopt_median_ms"] / bench["median_ms"])


# ----------------------------------------------------------------------- the slow ones
@pytest.mark.slow
def test_build_style_library_learns_the_experts_cost(library):
    lib = _json(library / "library.json")
    assert lib["kind"] == "driver-library" and lib["risks"] == [0.5, 0.9]
    assert lib["fit"]["status"] == "converged" and lib["fit"]["residual_rms"] < 1e-6
    assert np.allclose(lib["style"]["weights"], EXPERT_WEIGHTS, rtol=1e-6)  # the SMPC's own
    assert lib["calibration"]["n_demos"] == 2 and lib["temperature"] > 0
    assert sorted(p.name for p in (library / "demos").iterdir()) == ["p0.5_s0.npz", "p0.9_s0.npz"]


@pytest.mark.slow
def test_reproduce_paper_the_reactive_features_reproduce_closer(paper):
    results = _json(paper / "results.json")
    assert results["demo"]["t_trg_s"] == pytest.approx(3.0) and results["demo"]["risk"] == 0.7
    base, reactive = results["learning"]["base"], results["learning"]["reactive"]
    assert reactive["converged"] and base["converged"]
    assert reactive["rmse_y_m"] < 0.25 < base["rmse_y_m"]  # README: 0.17 m against 0.82 m
    assert reactive["rmse_y_reaction_m"] < base["rmse_y_reaction_m"]
    assert results["reactive_closer_in_reaction_window"] and results["reactive_closer_overall"]
    for name in ("fig3_reproductions.png", "fig4_lateral.png", "demo/demo.npz"):
        assert (paper / name).stat().st_size > 1000, name


@pytest.mark.slow
def test_learn_style_recovers_the_risk_and_reproduces_the_demonstration(library, paper, tmp_path):
    # the default (driver) model from one SMPC(0.5) demonstration of the library (≈ 20 s)
    _drivestyle(tmp_path, "learn-style", library / "demos" / "p0.5_s0.npz", "--out", "driver")
    style = _json(tmp_path / "driver" / "style.json")
    assert style["kind"] == "driver-style" and style["status"] == "converged"
    assert style["style"]["risk"] == pytest.approx(0.5, abs=0.01)
    (reproduction,) = style["reproductions"]
    assert reproduction["rmse_y_m"] < 0.05 and reproduction["failures"] == 0
    # the paper's model learns what reproduce-paper learned from the same demonstration
    _drivestyle(tmp_path, "learn-style", paper / "demo" / "demo.npz", "--model", "paper",
                "--features", "reactive", "--out", "style")  # fmt: skip
    learned = _json(tmp_path / "style" / "style.json")
    reactive = _json(paper / "results.json")["learning"]["reactive"]
    assert learned["converged"] and learned["rmse_y_m"] == pytest.approx(reactive["rmse_y_m"])


@pytest.mark.slow
def test_identify_style_finds_the_risk_between_the_librarys_risks(library, paper, tmp_path):
    _drivestyle(tmp_path, "identify-style", paper / "demo" / "demo.npz", "--library", library,
                "--out", "identify")  # fmt: skip
    result = _json(tmp_path / "identify" / "identify.json")
    assert result["true_risk"] == [0.7] and result["verdict"] == "informative"
    assert result["risk_interpolated"] == pytest.approx(0.7, abs=0.02)
    lo, hi = result["risk_interval"]
    assert lo <= 0.7 <= hi and hi - lo < 0.1


@pytest.mark.slow
def test_evaluate_identification_identifies_held_out_demonstrations(library, tmp_path):
    _drivestyle(tmp_path, "evaluate-identification", "--library", library, "--scenarios", "1",
                "--seed", "2000", "--noise", "0,0.1", "--references", "--out", "test")  # fmt: skip
    evaluation = _json(tmp_path / "test" / "evaluation.json")
    assert evaluation["grid_risks"] == [0.5, 0.9] and evaluation["between_risks"] == [0.7]
    summary = evaluation["summary"]["driver"]
    assert summary["n"] == 3 and summary["n_failed"] == 0
    assert summary["likelihood"]["grid_accuracy"] == 1.0
    assert summary["likelihood"]["between_mae_interpolated"] < 0.05  # 0.7 found between
    curve = evaluation["noise_curve"]["driver"]
    assert [c["noise_sigma_m"] for c in curve] == [0.0, 0.1]
    assert evaluation["references"]["ceiling"]["grid_accuracy"] == 1.0
    assert (tmp_path / "test" / "evaluation.md").stat().st_size > 0
    assert "amortized" not in evaluation  # only with --posterior
    assert not (tmp_path / "test" / "estimates_amortized.png").exists()


@pytest.mark.slow  # ≈ 25 s: a tiny estimator, then 2 noise levels of 4 demonstrations
def test_evaluate_identification_puts_an_amortized_posterior_beside_the_exact(library, tmp_path):
    pytest.importorskip("zuko")
    _drivestyle(tmp_path, "build-posterior", "--simulations", "8", "--held-out", "2",
                "--epochs", "2", "--hidden", "4", "--embedding", "4", "--transforms", "1",
                "--flow-hidden", "8", "--samples", "10", "--out", "post")  # fmt: skip
    _drivestyle(tmp_path, "evaluate-identification", "--library", library, "--scenarios", "1",
                "--continuous", "1", "--seed", "2000", "--noise", "0,0.1", "--workers", "1",
                "--posterior", "post/posterior.npz", "--out", "beside")  # fmt: skip
    evaluation = _json(tmp_path / "beside" / "evaluation.json")
    section = evaluation["amortized"]
    assert section["posterior"] == "post/posterior.npz" and section["samples"] == 200
    assert section["parameters"][0] == "risk" and len(section["parameters"]) == 9
    exact_curve = evaluation["noise_curve"]["driver"]
    by_noise = section["by_noise"]
    assert [b["noise_sigma_m"] for b in by_noise] == [0.0, 0.1]
    for b, ex in zip(by_noise, exact_curve, strict=True):
        # grid 0.5, 0.9, midpoint 0.7, one continuous; the exact refused none
        assert (b["n"], b["n_exact_refused"]) == (4, 0)
        # the exact beside it is the exact's own evaluation, by its own rules
        assert b["exact"]["grid_accuracy"] == ex["grid_accuracy"]
        assert b["exact"]["identifiable_accuracy"] == ex["grid_accuracy_identifiable"]
        assert b["exact"]["coverage"] == pytest.approx(ex["interval_coverage"])
        assert b["exact"]["continuous_mae"] == pytest.approx(ex["continuous_mae_interpolated"])
        a = b["amortized"]
        assert 0 <= a["risk_error"]["mean"] <= 0.49 and 0 <= a["coverage"] <= 1
        assert a["risk_error"]["mean_lo"] <= a["risk_error"]["mean"] <= a["risk_error"]["mean_hi"]
        assert 0 < a["identify_ms_median"] <= a["identify_ms_p95"]
        assert b["parameters"]["time_gap"]["expert_mean"] == 0.0  # the SMPC expert's T
        assert b["parameters"]["tau"]["mae"] is None  # which has no τ
    records = section["records"]  # σ = 0, in the exact's order
    exact_records = evaluation["records"]["driver"]
    assert [r["risk"] for r in records] == [r["risk"] for r in exact_records]
    for r, ex in zip(records, exact_records, strict=True):
        assert r["exact"]["mean"] == ex["likelihood_interpolated"]
        assert r["exact"]["estimate"] == ex["likelihood_estimate"]
        assert 0.5 <= r["lo"]["risk"] <= r["hi"]["risk"] <= 0.99  # inside the prior's box
        assert r["estimate"] in evaluation["grid_risks"]
        assert r["expert"]["risk"] == r["risk"] and r["expert"]["sigma_a"] == 0.0
    head = by_noise[0]
    errors = [abs(r["mean"]["risk"] - r["risk"]) for r in records]
    assert head["amortized"]["risk_error"]["mean"] == pytest.approx(np.mean(errors))
    gaps = [abs(r["mean"]["risk"] - r["exact"]["mean"]) for r in records]
    assert head["agreement"]["mae"] == pytest.approx(np.mean(gaps))
    (cost,) = section["noise_cost"]
    assert cost["amortized_mae_change"] == pytest.approx(
        by_noise[1]["amortized"]["risk_error"]["mean"] - head["amortized"]["risk_error"]["mean"]
    )
    markdown = (tmp_path / "beside" / "evaluation.md").read_text()
    assert "## Amortized posterior beside the exact" in markdown
    assert (tmp_path / "beside" / "estimates_amortized.png").stat().st_size > 1000
    # a missing or damaged estimator: one line naming --posterior and the file, before any work
    raw = bytearray((tmp_path / "post/posterior.npz").read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    (tmp_path / "bad.npz").write_bytes(bytes(raw))
    for name in ("bad.npz", "missing.npz"):
        run = subprocess.run(
            [sys.executable, "-m", "drivestyle", "evaluate-identification", "--library",
             str(library), "--posterior", name, "--out", "refused"],
            cwd=tmp_path, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert run.returncode == 2 and "Traceback" not in run.stderr
        (line,) = run.stderr.strip().splitlines()
        assert line.startswith(f"error: --posterior {name}: ")
        assert not (tmp_path / "refused").exists()


@pytest.mark.slow
def test_predict_trajectory_of_an_smpc_vehicle_beats_constant_velocity(library, tmp_path):
    _drivestyle(tmp_path, "predict-trajectory", library / "demos" / "p0.9_s0.npz", "--library",
                library, "--observe", "2", "--out", "predict")  # fmt: skip
    prediction = _json(tmp_path / "predict" / "prediction.json")
    methods = prediction["methods"]
    assert prediction["true_risk"] == 0.9 and prediction["horizon_s"] == pytest.approx(4.0)
    assert prediction["identified"]["risk_mean"] == pytest.approx(0.9, abs=0.02)
    assert methods["oracle"]["fde_m"] < 0.05 and methods["mode"]["fde_m"] < 0.05
    assert methods["cv"]["fde_m"] > 1.0  # a lane change is no straight line
    assert all(len(m["path"]) == len(prediction["actual"]) for m in methods.values())


@pytest.mark.slow
@needs_data
def test_evaluate_prediction_simulated_and_recorded_benchmark(library, tmp_path):
    # one simulated vehicle and the shipped validation split, at one observed time (≈ 20 s)
    _drivestyle(tmp_path, "evaluate-prediction", "--library", library, "--vehicles", "1",
                "--observe", "2", "--data-dir", DATA, "--out", "prediction")  # fmt: skip
    result = _json(tmp_path / "prediction" / "prediction_eval.json")
    split = (ROOT / "drivestyle" / "data" / "benchmark_split.csv").read_text().splitlines()
    validation = sum(line.endswith(",validation") for line in split)
    records = result["records"]
    assert result["split"] == "validation" and result["recorded_sets"] == ["ngsim", "cats"]
    assert len(records) == result["n_records"] == 1 + validation - result["n_skipped"]
    (simulated,) = [r for r in records if r["set"] == "simulated"]
    assert simulated["fde_m"]["oracle"] < 0.05  # the vehicle's own SMPC
    assert simulated["fde_m"]["mode"] < simulated["fde_m"]["cv"]
    for r in records:
        assert _finite(*r["fde_m"].values()) and min(r["fde_m"].values()) >= 0, r["vehicle_id"]
    for summary in result["summaries"]:  # (one vehicle's interval has width 0, up to rounding)
        fde = summary["stats"]["fde"]
        assert fde["mean_lo"] - 1e-9 <= fde["mean"] <= fde["mean_hi"] + 1e-9, summary


@pytest.mark.slow
def test_evaluate_out_of_class_orders_the_smpc_variants_by_risk(library, tmp_path):
    # one lane change per highway-env class from one traffic run; each SMPC variant at two
    # risks in one scenario (≈ 30 s)
    _drivestyle(tmp_path, "evaluate-out-of-class", "--library", library, "--per-class", "1",
                "--max-runs", "1", "--risks", "0.5,0.95", "--scenarios", "1", "--observe", "2",
                "--out", "ooc")  # fmt: skip
    result = _json(tmp_path / "ooc" / "out_of_class.json")
    assert result["highway"]["runs"] == 1 and result["highway"]["usable"] > 0
    groups = result["groups"]
    smpc: dict[str, dict[float, float]] = {}
    for g in groups:
        if g["family"] == "smpc":
            smpc.setdefault(g["group"], {})[g["caution"]] = g["risk_median"]
    assert set(smpc) == {"horizon-15", "uncertainty-x0.5", "weights"}
    for variant, by_risk in smpc.items():  # more cautious, identified as more cautious
        assert by_risk[0.95] > by_risk[0.5], variant
    highway = [g for g in groups if g["family"] == "highway-env"]
    assert sum(g["n"] for g in highway) == sum(result["highway"]["kept_per_class"].values())
    fde = [s["fde_mean_m"] for s in result["prediction"]["summaries"]]
    assert fde and _finite(*fde)


@pytest.mark.slow
@needs_data
def test_learn_population_does_not_lose_to_its_start(library, tmp_path):
    # one train episode, four closed-loop evaluations
    (tmp_path / "split.csv").write_text(
        "dataset,episode_id,vehicle_id,split\ncats,AV-04-W_2_35453703,cats:AV:2,train\n"
    )
    _drivestyle(tmp_path, "learn-population", "--library", library, "--data-dir", DATA,
                "--split-file", "split.csv", "--max-evals", "4", "--out", "people")  # fmt: skip
    people = _json(tmp_path / "people" / "library.json")
    assert people["kind"] == "driver-library" and people["risks"] == [0.5, 0.9]
    fit = people["fit"]
    assert fit["objective"] == "closed-loop" and fit["evaluations"] == 4
    assert _finite(fit["closed_loop_rmse_xy_m"], fit["start_rmse_xy_m"])
    assert fit["closed_loop_rmse_xy_m"] <= fit["start_rmse_xy_m"] < 50
    assert people["split"]["episodes"] == ["AV-04-W_2_35453703"]


@pytest.mark.slow
def test_mine_styles_finds_a_populations_risks(library, population, work):
    _drivestyle(work, "mine-styles", "runs/population", "--library", library,
                "--out", "runs/mined")  # fmt: skip
    summary = _json(work / "runs" / "mined" / "summary.json")
    assert summary["n"] == summary["n_ok"] == summary["n_with_truth"] == 3
    assert summary["n_failed"] == 0 and summary["engine"] == "local"
    assert summary["mae_posterior_mean"] < 0.1  # the library's cost is the vehicles' own
    rows = (work / "runs" / "mined" / "styles.csv").read_text().splitlines()
    assert len(rows) == 1 + 3


@pytest.mark.slow
@needs_data
def test_compare_av_human_on_a_mining_of_the_cats_sample(library, work):
    # the README's pair: every CATS lane change mined (≈ 35 s on 2 idle cores), then compared
    _drivestyle(work, "mine-styles", "--dataset", "cats", "--data",
                DATA / "cats-av-lanechange", "--library", library,
                "--out", "runs/mined_cats")  # fmt: skip
    mined = _json(work / "runs" / "mined_cats" / "summary.json")
    assert mined["n_ok"] == mined["n"] > 50 and mined["n_failed"] == 0
    assert sum(mined["verdicts"].values()) == mined["n"]
    _drivestyle(work, "compare-av-human", "--mined", "runs/mined_cats", "--data-dir", DATA,
                "--samples", "200", "--out", "runs/av_vs_human")  # fmt: skip
    comparison = _json(work / "runs" / "av_vs_human" / "av_vs_human.json")
    assert comparison["bootstrap"]["samples"] == 200
    assert len(comparison["episodes"]) == mined["n"]  # each mined lane change compared
    counted = sum(n for group in comparison["verdicts"].values() for n in group.values())
    assert counted == mined["n"] and "not mined" not in json.dumps(comparison["verdicts"])
    for s in comparison["stats"]:
        if s["lo"] is not None:
            assert s["lo"] <= s["median"] <= s["hi"], s
    speeds = [s for s in comparison["stats"] if s["quantity"] == "median_speed_mps"]
    assert all(s["n"] > 0 and 0 < s["median"] < 40 for s in speeds)


@pytest.mark.slow
@needs_data
def test_real_traffic_styles_beat_constant_velocity(tmp_path):
    # two NGSIM lane changes, both models, the driver model's search cut to one start
    _drivestyle(tmp_path, "real-traffic", "--dataset", "ngsim", "--data", DATA / "ngsim",
                "--limit", "2", "--screen", "1", "--restarts", "1", "--max-iter", "3",
                "--out", "ngsim")  # fmt: skip
    result = _json(tmp_path / "ngsim" / "real_traffic.json")
    assert result["n_used"] == 2 and result["model"] == "both"
    cv = result["medians"]["constant_velocity"]["rmse_y_m"]
    assert _finite(cv) and result["medians"]["personal_reactive"]["rmse_y_m"] < cv
    assert result["driver"]["medians"]["personal"]["rmse_y_m"] < cv


@pytest.mark.slow
def test_train_baseline_trains_and_evaluates_a_policy(baseline):
    summary = _json(baseline / "train.json")
    assert summary["algo"] == "ppo" and summary["timesteps"] == 256
    assert _finite(summary["final_eval_return"]) and summary["final_eval_return"] < 0
    assert (baseline / "model.zip").stat().st_size > 1000


@pytest.mark.slow
def test_compare_baseline_compares_policy_smpc_and_spline(paper, baseline, tmp_path):
    _drivestyle(tmp_path, "compare-baseline", "--style", paper / "reactive" / "style.json",
                "--model", baseline, "--out", "compare")  # fmt: skip
    methods = _json(tmp_path / "compare" / "compare.json")["methods"]
    assert set(methods) == {"smpc", "spline", "sb3"}
    assert methods["smpc"]["rmse_y_m"] == 0.0 and not methods["smpc"]["collision"]
    reactive = _json(paper / "results.json")["learning"]["reactive"]
    assert methods["spline"]["rmse_y_m"] == pytest.approx(reactive["rmse_y_m"], abs=1e-6)
    assert _finite(methods["sb3"]["min_d_k"]) and methods["sb3"]["n_samples"] >= 1


@pytest.mark.slow
def test_deviating_tv_drives_every_method_against_a_braking_tv(paper, baseline, tmp_path):
    _drivestyle(tmp_path, "deviating-tv", "--style", paper / "reactive" / "style.json",
                "--model", baseline, "--no-videos", "--out", "deviating")  # fmt: skip
    result = _json(tmp_path / "deviating" / "deviation.json")
    assert result["deviation"] == {"t_start": 1.5, "accel": -4.0, "duration": 1.5}
    methods = result["methods"]
    assert set(methods) == {"smpc", "policy", "spline_open_loop", "spline_receding"}
    assert not methods["smpc"]["collision"] and methods["smpc"]["n_samples"] == 31
    assert methods["smpc"]["rmse_y_vs_smpc_m"] == 0.0
    assert 0 < methods["spline_open_loop"]["rmse_y_vs_smpc_m"] < 1.0


@pytest.mark.slow
def test_render_rollout_writes_a_video_of_the_moving_scene(tmp_path):
    import imageio.v2 as imageio

    _drivestyle(tmp_path, "render-rollout", "--policy", "expert", "--video", "videos/expert.mp4")
    summary = _json(tmp_path / "videos" / "expert.json")
    with imageio.get_reader(str(tmp_path / "videos" / "expert.mp4"), "ffmpeg") as reader:
        frames = list(reader.iter_data())  # (list(reader) asks its length: inf)
    assert summary["frames"] == len(frames) == 31
    assert list(frames[0].shape) == summary["frame_shape"]
    assert frames[0].std() > 10  # a drawn road, not a blank frame
    assert np.abs(frames[0].astype(int) - frames[-1]).mean() > 1  # the scene moves


@pytest.mark.slow
def test_evaluate_planning_the_style_aware_ego_brakes_less(library, tmp_path):
    _drivestyle(tmp_path, "evaluate-planning", "--library", library, "--scenes", "1", "--seed",
                "20000", "--videos", "--out", "planning")  # fmt: skip
    result = _json(tmp_path / "planning" / "planning.json")
    summaries = result["summaries"]
    assert result["seeds"] == [20000] and set(summaries) == {"cv", "style", "oracle"}
    assert all(s["n"] == 1 and s["collisions"] == 0 for s in summaries.values())
    assert summaries["style"]["hardest_braking_mean"] < summaries["cv"]["hardest_braking_mean"]
    for method in summaries:
        assert (tmp_path / "planning" / "videos" / f"{method}.mp4").stat().st_size > 1000


@pytest.mark.slow
def test_capacity_study_the_receding_horizon_class_fits_its_driver(tmp_path):
    _drivestyle(tmp_path, "capacity-study", "--risks", "0.6", "--train", "1", "--test", "1",
                "--budget", "5", "--out", "capacity")  # fmt: skip
    (row,) = _json(tmp_path / "capacity" / "capacity.json")["rows"]
    classes = row["classes"]
    assert row["risk"] == 0.6 and classes["rh_learned"]["train_rmse_y_m"] < 0.05
    assert classes["rh_chance_nm"]["objective_m"] < classes["paper_nm"]["objective_m"]
    assert all(_finite(c["test_rmse_y_m"]) for c in classes.values())


@pytest.mark.slow
def test_bench_irl_times_learning_and_identification_with_the_default_library(
    library, paper, tmp_path
):
    _drivestyle(tmp_path, "bench-irl", "--demo", paper / "demo" / "demo.npz", "--repeats", "1",
                "--library", library, "--identify", "1", "--out", "irl.json")  # fmt: skip
    bench = _json(tmp_path / "irl.json")
    assert bench["base"]["iterations"] > 0 and bench["reactive"]["iterations"] > 0
    assert _finite(bench["reactive"]["learn_wall_s"]) and bench["reactive"]["learn_wall_s"] > 0
    assert bench["identification"]["n"] == 1 and bench["identification"]["identify_s_median"] > 0
    driver = bench["driver"]
    assert driver["ipopt_over_product"] == pytest.approx(
        driver["ipopt_solve_ms_median"] / driver["inner_solve_ms_median"]
    )
    assert driver["second_process"]["peak_rss_mb"] > 0


@pytest.mark.slow
def test_bench_population_measures_the_mining_rate(library, tmp_path):
    _drivestyle(tmp_path, "bench-population", "--vehicles", "2", "--library", library,
                "--runs", "local:1", "--out", "population.json")  # fmt: skip
    bench = _json(tmp_path / "population.json")
    (run,) = bench["runs"]
    assert run["n_ok"] == 2 and run["n_failed"] == 0
    assert run["demos_per_s"] == pytest.approx(2 / run["wall_s"])
    assert bench["hours_for_110k"]["1"] == pytest.approx(110_000 / run["demos_per_s"] / 3600)


@pytest.mark.slow
def test_bench_tracker_times_one_update_per_sample(library, tmp_path):
    _drivestyle(tmp_path, "bench-tracker", "--library", library, "--vehicles", "1",
                "--out", "tracker.json")  # fmt: skip
    bench = _json(tmp_path / "tracker.json")
    assert bench["vehicles"] == 1 and bench["updates"] == 31  # one per sample of 6 s
    assert 0 < bench["median_ms"] <= bench["p95_ms"] <= bench["max_ms"]


@pytest.mark.slow
def test_bench_solver_paths_the_interpreted_fatrop_path_equals_the_product(tmp_path):
    _drivestyle(tmp_path, "bench-solver-paths", "--demos", "1", "--out", "paths.json")
    bench = _json(tmp_path / "paths.json")
    assert bench["demos"] == 1 and len(bench["per_demo"]) == 1
    fatrop = bench["summary"]["fatrop"]
    assert fatrop["demos_equal"] == 1 and fatrop["max_rel_change"] <= bench["equal_tolerance"]
    for path in bench["summary"].values():
        ratio = path["wall_over_reference_median"]
        assert _finite(ratio) and ratio > 0


@pytest.mark.slow
def test_profile_inner_accounts_for_every_second(tmp_path):
    recorded = ["--recorded", "1", "--data-dir", DATA] if DATA.is_dir() else []
    _drivestyle(tmp_path, "profile-inner", "--repeats", "1", "--identify", "1", "--no-jit",
                *recorded, "--out", "profile.json")  # fmt: skip
    profile = _json(tmp_path / "profile.json")
    parts = [profile["paper"], *profile["driver"]["no_jit"].values()]
    if recorded:
        parts.append(profile["recorded"])
        assert len(profile["recorded"]["episodes"]) == 1
    for part in parts:
        assert sum(v["share"] for v in part["breakdown"].values()) == pytest.approx(1.0, abs=1e-3)
    assert profile["driver"]["no_jit"]["step_residuals"]["solves"] == 30


# ------------------------------------------------------ every command, and the README's lines
COVERAGE = {
    "reproduce-paper": "test_reproduce_paper_the_reactive_features_reproduce_closer",
    "generate-demo": "test_generate_demo_changes_lane_at_the_papers_trigger_time",
    "learn-style": "test_learn_style_recovers_the_risk_and_reproduces_the_demonstration",
    "build-style-library": "test_build_style_library_learns_the_experts_cost",
    "identify-style": "test_identify_style_finds_the_risk_between_the_librarys_risks",
    "evaluate-identification": "test_evaluate_identification_identifies_held_out_demonstrations",
    "predict-trajectory": "test_predict_trajectory_of_an_smpc_vehicle_beats_constant_velocity",
    # (and --episodes without the recorded data: test_prediction_scripts.py)
    "evaluate-prediction": "test_evaluate_prediction_simulated_and_recorded_benchmark",
    "evaluate-out-of-class": "test_evaluate_out_of_class_orders_the_smpc_variants_by_risk",
    "learn-population": "test_learn_population_does_not_lose_to_its_start",
    "compare-av-human": "test_compare_av_human_on_a_mining_of_the_cats_sample",
    "mine-styles": "test_mine_styles_finds_a_populations_risks",
    "simulate-population": "test_simulate_population_writes_vehicles_of_known_risk",
    "real-traffic": "test_real_traffic_styles_beat_constant_velocity",
    "extract-episodes": "tests/scripts/test_extract_episodes.py::"
    "test_a_table_of_recordings_with_a_lanes_file_through_the_command",
    "train-baseline": "test_train_baseline_trains_and_evaluates_a_policy",
    "compare-baseline": "test_compare_baseline_compares_policy_smpc_and_spline",
    "deviating-tv": "test_deviating_tv_drives_every_method_against_a_braking_tv",
    "render-rollout": "test_render_rollout_writes_a_video_of_the_moving_scene",
    "replay-recorded": "tests/scripts/test_replay_recorded.py::"
    "test_three_episodes_replayed_as_the_study_replays_them",
    "evaluate-planning": "test_evaluate_planning_the_style_aware_ego_brakes_less",
    "calibrate-uncertainty": "test_calibrate_uncertainty_triggers_at_the_papers_time_at_scale_one",
    "capacity-study": "test_capacity_study_the_receding_horizon_class_fits_its_driver",
    "bench-smpc": "test_bench_smpc_times_every_step_of_its_closed_loops",
    "bench-irl": "test_bench_irl_times_learning_and_identification_with_the_default_library",
    "bench-population": "test_bench_population_measures_the_mining_rate",
    "bench-tracker": "test_bench_tracker_times_one_update_per_sample",
    "bench-solver-paths": "test_bench_solver_paths_the_interpreted_fatrop_path_equals_the_product",
    "bench-env": "test_bench_env_counts_every_step_it_times",
    "bench-stochastic": "test_bench_stochastic_simulates_every_episode_it_times",
    "bench-scene-prediction": "test_bench_scene_prediction_predicts_every_window_of_the_minute",
    "build-posterior": "test_build_posterior_writes_a_verified_estimator_and_its_calibration",
    "profile-inner": "test_profile_inner_accounts_for_every_second",
}
"""Command → the test that runs it in its own process: here, or ``path::test`` elsewhere."""


def _functions(path: Path) -> dict[str, ast.FunctionDef]:
    tree = ast.parse(path.read_text())
    return {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}


def _runs_here(command: str, name: str, functions: dict[str, ast.FunctionDef]) -> bool:
    """Whether test ``name`` (or a fixture it takes, transitively) calls ``_drivestyle(cwd,
    command, …)``."""
    seen, todo = set(), [name]
    while todo:
        fn = functions.get(todo.pop())
        if fn is None or fn.name in seen:
            continue
        seen.add(fn.name)
        for node in ast.walk(fn):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Name)
                and node.func.id == "_drivestyle"
                and len(node.args) >= 2
                and isinstance(node.args[1], ast.Constant)
                and node.args[1].value == command
            ):
                return True
        todo += [a.arg for a in fn.args.args]
    return False


def _runs_elsewhere(command: str, where: str) -> bool:
    """Whether ``path::test`` exists and its file runs ``-m drivestyle command``."""
    path, name = where.split("::")
    text = (ROOT / path).read_text()
    runs = '"-m", "drivestyle"' in text and f'"{command}"' in text
    return runs and name in _functions(ROOT / path)


def _uncovered(coverage: dict[str, str]) -> list[str]:
    here = _functions(Path(__file__))
    return [
        f"{command}: {where}"
        for command, where in coverage.items()
        if not (
            _runs_elsewhere(command, where) if "::" in where else _runs_here(command, where, here)
        )
    ]


def test_every_command_has_a_test_that_runs_it_in_its_own_process():
    assert set(COVERAGE) == set(COMMANDS), set(COVERAGE) ^ set(COMMANDS)
    assert not _uncovered(COVERAGE)


def test_the_coverage_check_finds_a_test_that_does_not_run_its_command():
    assert _uncovered({"bench-env": "test_bench_smpc_times_every_step_of_its_closed_loops"})
    assert _uncovered({"bench-env": "test_no_such_test"})
    assert _uncovered({"learn-style": COVERAGE["extract-episodes"]})


def _readme_command_lines() -> list[list[str]]:
    """Every ``drivestyle <command> …`` line of the README: its bash blocks (the parsing of
    tests/test_readme.py) and the commands quoted in its text."""
    path = ROOT / "tests" / "test_readme.py"
    spec = importlib.util.spec_from_file_location("_readme_steps", path)
    readme = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(readme)
    lines = [t for t in readme._commands() if t[:1] == ["drivestyle"]]
    prose = re.sub(r"(?ms)^```.*?^```", "", README.read_text())
    return lines + [shlex.split(m) for m in re.findall(r"`(drivestyle [a-z][^`]*)`", prose)]


def _unparsed(lines: list[list[str]]) -> list[str]:
    """The lines the command's own parser refuses (unknown command, option or value)."""
    bad = []
    for tokens in lines:
        if tokens[1] not in COMMANDS:
            bad.append(f"{shlex.join(tokens)}: no such command")
            continue
        module = importlib.import_module(f"drivestyle.scripts.{tokens[1].replace('-', '_')}")
        try:
            module.parse_args(tokens[2:])
        except SystemExit as exc:
            bad.append(f"{shlex.join(tokens)}: exit {exc.code}")
    return bad


@pytest.mark.slow  # imports every script (the RL ones pull stable-baselines3 and torch)
def test_every_readme_command_line_parses_and_its_command_runs_here():
    lines = _readme_command_lines()
    assert len(lines) > 40, "the README's command lines were not found"
    assert not _unparsed(lines)
    named = {tokens[1] for tokens in lines}
    assert named <= set(COVERAGE), named - set(COVERAGE)


def test_the_readme_check_refuses_a_line_its_parser_refuses():
    bad = _unparsed([["drivestyle", "bench-env", "--steps", "0"],
                     ["drivestyle", "bench-env", "--no-such-option"],
                     ["drivestyle", "no-such-command"], ["drivestyle", "bench-env"]])  # fmt: skip
    assert [line.split(":")[0] for line in bad] == [
        "drivestyle bench-env --steps 0",
        "drivestyle bench-env --no-such-option",
        "drivestyle no-such-command",
    ]
