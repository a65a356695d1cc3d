import json
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"  # the recorded samples beside a checkout


def _main(name):
    return runpy.run_path(str(ROOT / "scripts" / f"{name}.py"), run_name="not_main")["main"]


def test_generate_demo_writes_spec_files(tmp_path):
    out = tmp_path / "demo"
    summary = _main("generate_demo")(
        ["--risk", "0.7", "--scenario", "paper", "--out", str(out), "--plot"]
    )
    data = np.load(out / "demo.npz")
    assert data["t"].shape == (31,) and data["ev"].shape == (31, 4)
    assert data["tv"].shape == (31, 4) and data["u"].shape == (30, 2)
    js = json.loads((out / "demo.json").read_text())
    for key in (
        "risk",
        "t_trg_s",
        "min_s_e",
        "min_d_k",
        "collision",
        "solve_ms_median",
        "solve_ms_p95",
        "n_steps",
        "command",
    ):
        assert key in js
    assert js["risk"] == 0.7 and js["n_steps"] == 30 and js["min_d_k"] >= 0
    assert not js["collision"] and js["final_lane"] == 1
    assert (out / "demo.png").stat().st_size > 20_000
    assert summary["t_trg_s"] == js["t_trg_s"]


def test_generate_demo_scenario_flags(tmp_path):
    _main("generate_demo")(
        ["--out", str(tmp_path), "--ev-speed", "24", "--tv-gap", "-25", "--horizon-s", "4"]
    )
    js = json.loads((tmp_path / "demo.json").read_text())
    assert js["scenario"]["ev_speed"] == 24 and js["scenario"]["tv_gap"] == -25
    assert js["n_steps"] == 20


def test_generate_demo_replaces_its_folder_whole(tmp_path):
    out = tmp_path / "demo"
    short = ["--out", str(out), "--horizon-s", "2"]
    _main("generate_demo")([*short, "--risk", "0.5", "--plot"])
    assert (out / "demo.png").is_file()
    _main("generate_demo")([*short, "--risk", "0.7"])
    # no demo.png of p = 0.5 beside the p = 0.7 demonstration
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "demo.json",
        "demo.npz",
    ]
    assert json.loads((out / "demo.json").read_text())["risk"] == 0.7
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]  # no temporary folder
    mode = 0o666 & ~_umask()
    assert (out / "demo.json").stat().st_mode & 0o777 == mode  # not private
    assert (out / "demo.npz").stat().st_mode & 0o777 == mode


def _umask() -> int:
    import os

    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_generate_demo_bad_input_exits_cleanly(tmp_path):
    for args in (["--risk", "1.2"], ["--horizon-s", "-1"], ["--tv-lane", "0", "--tv-gap", "-3"]):
        proc = subprocess.run(
            [
                sys.executable,
                str(ROOT / "scripts" / "generate_demo.py"),
                "--out",
                str(tmp_path),
                *args,
            ],
            capture_output=True,
            text=True,
            cwd=ROOT,
        )
        assert proc.returncode != 0
        assert "error:" in proc.stderr.strip().splitlines()[-1], proc.stderr
        assert "Traceback" not in proc.stderr


def test_bench_smpc_json(tmp_path):
    out = tmp_path / "bench.json"
    res = _main("bench_smpc")(
        ["--out", str(out), "--repeats", "1", "--random", "1", "--trials", "1", "--no-jit"]
    )
    js = json.loads(out.read_text())
    for key in ("median_ms", "p95_ms", "n_steps", "solver", "ipopt_median_ms", "speedup_vs_ipopt"):
        assert key in js
    assert js["solver"] == "fatrop" and js["n_steps"] == 30 and js["median_ms"] > 0
    assert res["failures"] == 0


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
@pytest.mark.skipif(
    not (DATA / "ngsim" / "tracks.csv.gz").is_file(), reason="the NGSIM sample is absent"
)
def test_profile_inner_json_shares_add_up_and_patches_are_undone(tmp_path):
    from drivestyle.irl.driver import style_planner
    from drivestyle.irl.paper import inner
    from drivestyle.planning import smpc_problem
    from drivestyle.planning.buffered import BufferedFunction

    originals = {
        (obj, name): getattr(obj, name)
        for obj, name in (
            (inner.InnerProblem, "solve"),
            (BufferedFunction, "__call__"),
            (inner, "cho_factor"),
            (inner, "newton_minimize"),
            (style_planner.StylePlanner, "plan"),
            (style_planner, "warm_start"),
            (smpc_problem.SMPCProblem, "solve"),
            (smpc_problem.SMPCProblem, "_solver_call"),
        )
    }
    out = tmp_path / "profile.json"
    res = _main("profile_inner")(
        [
            "--out",
            str(out),
            "--repeats",
            "1",
            "--identify",
            "1",
            "--no-jit",
            "--recorded",
            "1",
            "--data-dir",
            str(DATA),
        ]
    )
    js = json.loads(out.read_text())
    assert "command" in js and len(js["load_average_before"]) == 3
    paper = js["paper"]
    assert sum(v["share"] for v in paper["breakdown"].values()) == pytest.approx(1.0)
    assert paper["inner_solves_per_learn"] > 0 and paper["newton_steps_per_solve_median"] >= 1
    assert list(js["driver"]) == ["no_jit"]
    b1, b2 = js["driver"]["no_jit"]["step_residuals"], js["driver"]["no_jit"]["identification"]
    assert b1["solves_per_call"] == b1["steps"] == 30 and b1["iterations_median"] >= 1
    assert b2["solves_per_identification"][0] >= 30 and b2["demo_risks"] == [0.6]
    for part in (b1, b2):  # every second of the region is in a category
        assert sum(v["share"] for v in part["breakdown"].values()) == pytest.approx(1.0, abs=1e-3)
    b3 = js["recorded"]  # one CATS lane change, under the recorded bounds
    assert len(b3["episodes"]) == 1 and b3["solves_per_identification"][0] >= 30
    assert sum(v["share"] for v in b3["breakdown"].values()) == pytest.approx(1.0, abs=1e-3)
    assert res["paper"]["features"] == paper["features"]
    # the timers are gone: later calls in the process run the solvers' own code
    for (obj, name), fn in originals.items():
        assert getattr(obj, name) is fn, name


def test_profile_inner_reads_the_recorded_data_from_data_dir_and_checks_it_first(
    tmp_path, monkeypatch
):
    # it read ../shared/data of the working directory, and only after the profile's work
    from drivestyle.scripts import profile_inner

    def no_work(*args, **kwargs):
        raise AssertionError("the data folder is checked before any work")

    monkeypatch.setattr(profile_inner, "generate_demonstration", no_work)
    with pytest.raises(FileNotFoundError, match=rf"--data-dir {tmp_path}: no cats-av-lanechange/"):
        profile_inner.main(["--recorded", "1", "--data-dir", str(tmp_path), "--out",
                            str(tmp_path / "p.json")])  # fmt: skip
    assert not (tmp_path / "p.json").exists()


@pytest.mark.parametrize("name", ["generate_demo", "bench_smpc", "profile_inner"])
def test_help(name):
    proc = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / f"{name}.py"), "--help"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 0 and "--seed" in proc.stdout


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_bench_population_mines_with_a_driver_library(tmp_path):
    # the default model's library: mining throughput is measured on it (DESIGN §16)
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    lib = DriverLibrary(style=DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0), risk=0.7),
                        risks=(0.5, 0.7, 0.9))  # fmt: skip
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    out = tmp_path / "bench.json"
    res = _main("bench_population")(
        ["--vehicles", "2", "--library", str(tmp_path), "--no-ray", "--out", str(out)]
    )
    js = json.loads(out.read_text())
    assert js["vehicles"] == 2 and js["inner_solve_ms_median"] is None
    assert all(r["n_ok"] + r["n_failed"] == 2 for r in res["runs"])
    assert res["runs"][0]["demos_per_s_per_core"] > 0 and js["goal"]["demos_per_s_per_core"] == 20
    assert [(r["engine"], r["workers"]) for r in res["runs"]] == [("local", 1), ("local", 2)]
    assert res["scaling_1_to_2_by_engine"].keys() == {"local"}
    # a --demos folder without demonstrations: one line, the user-error status
    from drivestyle.common.cli import run_cli

    (tmp_path / "empty").mkdir()
    with pytest.raises(SystemExit) as info:
        run_cli(_main("bench_population"), ["--library", str(tmp_path), "--demos",
                str(tmp_path / "empty"), "--out", str(tmp_path / "b2.json")])  # fmt: skip
    assert info.value.code == 2


@pytest.mark.slow  # starts Ray: CI runs it (pytest -m slow)
def test_bench_population_scales_out_on_ray_and_reports_each_workers_memory(tmp_path):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    lib = DriverLibrary(style=DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0), risk=0.7),
                        risks=(0.5, 0.9))  # fmt: skip
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    res = _main("bench_population")(
        ["--vehicles", "3", "--library", str(tmp_path), "--runs", "ray:1,ray:2",
         "--out", str(tmp_path / "bench.json")]
    )  # fmt: skip
    one, two = res["runs"]
    assert (one["workers"], two["workers"]) == (1, 2) and one["n_ok"] == two["n_ok"] == 3
    # one sampled Ray actor per worker, each a Python process holding the planner
    assert [len(r["worker_memory"]["workers"]) for r in res["runs"]] == [1, 2]
    assert all(w["peak_mb"] > 50 for r in res["runs"] for w in r["worker_memory"]["workers"])
    assert res["parallel_efficiency_by_engine"]["ray"] == pytest.approx(
        two["demos_per_s"] / (2 * one["demos_per_s"])
    )
    with pytest.raises(SystemExit):
        _main("bench_population")(["--library", str(tmp_path), "--runs", "ray:0"])
