import json
import runpy
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs import load_demonstration, save_demonstration

ROOT = Path(__file__).resolve().parents[2]
SPEC_KEYS = (
    "features",
    "theta",
    "iterations",
    "converged",
    "learning_error",
    "rmse_y_m",
    "rmse_xy_m",
    "rmse_y_reaction_m",
    "wall_time_s",
    "inner_solve_ms_median",
    "t_trg_s",
    "t_rct_s",
    "omega",
    "feature_values_demo",
    "feature_values_reproduced",
    "history",
    "reproduced",
)


def _main(name):
    return runpy.run_path(str(ROOT / "scripts" / f"{name}.py"), run_name="not_main")["main"]


def _run(name, *args):
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / f"{name}.py"), *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )


@pytest.fixture(scope="module")
def demo_file(tmp_path_factory, request):
    from drivestyle.agents import generate_demonstration

    path = tmp_path_factory.mktemp("demo") / "demo.npz"
    save_demonstration(generate_demonstration(0.7, "paper")[0], path)
    return path


def test_learn_style_writes_spec_fields(tmp_path, demo_file):
    out = tmp_path / "style"
    _main("learn_style")(
        [str(demo_file), "--model", "paper", "--features", "reactive", "--out", str(out), "--plot"]
    )
    js = json.loads((out / "style.json").read_text())
    for key in SPEC_KEYS:
        assert key in js, key
    assert len(js["features"]) == len(js["theta"]) == len(js["omega"]) == 10
    assert set(js["reproduced"]) == {"t", "x", "y", "vx", "vy", "ax", "ay"}
    assert len(js["reproduced"]["t"]) == 31
    assert js["history"][0]["iteration"] == 1 and "epsilon" in js["history"][-1]
    assert js["t_trg_s"] == pytest.approx(3.0) and js["converged"] and js["status"] == "converged"
    assert (out / "reproduction.png").exists() and (out / "lateral.png").exists()


def test_a_learned_style_finds_its_demonstration_from_any_working_directory(
    tmp_path, demo_file, monkeypatch
):
    # style.json recorded the path as given (relative to the learning run's folder):
    # compare-baseline, deviating-tv and render-rollout run elsewhere did not find it
    import shutil

    from drivestyle.irl.paper.style import load_style

    (tmp_path / "runs").mkdir()
    shutil.copy(demo_file, tmp_path / "runs" / "demo.npz")
    monkeypatch.chdir(tmp_path)
    _main("learn_style")(["runs/demo.npz", "--model", "paper", "--out", "runs/style"])
    js = json.loads((tmp_path / "runs" / "style" / "style.json").read_text())
    assert js["demos"][0]["path"] == "runs/demo.npz"  # as given
    assert js["demos"][0]["path_from_style"] == "../demo.npz"
    monkeypatch.chdir(tmp_path / "runs")
    found = load_style("style").demo_path()
    assert found.resolve() == (tmp_path / "runs" / "demo.npz").resolve()


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda a: a.pop("ev"), "missing array"),
        (lambda a: a.__setitem__("tv", a["tv"][:-1]), "'tv' must have shape"),
        (lambda a: a["ev"].__setitem__((3, 1), np.nan), "NaN"),
        (lambda a: a["t"].__setitem__(5, 0.0), "strictly increasing"),
        (
            lambda a: (
                [a.__setitem__(k, a[k][:2]) for k in ("t", "ev", "tv")]
                or a.__setitem__("u", a["u"][:1])
            ),
            "at least 3 samples",
        ),
    ],
)
def test_learn_style_bad_demo_file(tmp_path, demo_file, mutate, message):
    with np.load(demo_file) as data:
        arrays = {k: data[k].copy() for k in data.files}
    mutate(arrays)
    bad = tmp_path / "bad.npz"
    np.savez(bad, **arrays)
    proc = _run("learn_style", str(bad), "--out", str(tmp_path / "o"))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert proc.stderr.startswith("error:") and message in proc.stderr, proc.stderr


@pytest.mark.slow  # end to end: the whole command
def test_reproduce_paper(tmp_path):
    out = tmp_path / "paper"
    res = _main("reproduce_paper")(["--out", str(out)])
    for f in (
        "demo/demo.npz",
        "demo/demo.png",
        "base/style.json",
        "reactive/style.json",
        "fig3_reproductions.png",
        "fig4_lateral.png",
        "results.json",
        "results.md",
    ):
        assert (out / f).exists(), f
    js = json.loads((out / "results.json").read_text())
    assert js["demo"]["t_trg_s"] == pytest.approx(3.0)
    for fs in ("base", "reactive"):
        for key in ("iterations", "learning_error", "rmse_y_m", "rmse_y_reaction_m", "wall_time_s"):
            assert key in js["learning"][fs]
    assert js["reactive_closer_in_reaction_window"] and res["reactive_closer_overall"]
    assert "paper_rule" in js and "control_point_rule" in js
    assert "| reactive |" in (out / "results.md").read_text()


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_bench_irl(tmp_path, demo_file):
    out = tmp_path / "bench.json"
    argv = ["--out", str(out), "--demo", str(demo_file), "--repeats", "1", "--identify", "1",
            "--learn"]  # fmt: skip
    _main("bench_irl")(argv)
    js = json.loads(out.read_text())
    for fs in ("base", "reactive"):
        assert js[fs]["learn_wall_s"] > 0 and js[fs]["inner_solve_ms_median"] > 0
    # the default model: product vs IPOPT on the same problems, the floor, a second process
    drv = js["driver"]
    assert drv["inner_solve_ms_median"] > 0 and drv["ipopt_over_product"] > 0
    if shutil.which("gcc"):  # the floor is the compiled Newton step
        assert 0 < drv["newton_step_floor_ms"] < drv["inner_solve_ms_median"]
    assert drv["identify_s_median"] > 0
    second = drv["second_process"]
    assert 0 < second["ready_s"] <= second["first_identification_s"] and second["peak_rss_mb"] > 0
    # the risk of SMPC drivers with the expert's cost given: recovered (the class holds them)
    assert drv["learn_risk_cost_given_s_median"] > 0
    assert drv["learn_risk_cost_given_abs_error_max"] < 0.01


@pytest.mark.parametrize(
    ("name", "seeded"), [("learn_style", False), ("reproduce_paper", True), ("bench_irl", True)]
)
def test_help(name, seeded, capsys):
    with pytest.raises(SystemExit) as info:
        _main(name)(["--help"])
    assert info.value.code == 0 and ("--seed" in capsys.readouterr().out) == seeded


def test_learn_style_says_when_learning_stalled(tmp_path, demo_file, monkeypatch, capsys):
    from drivestyle.common.cli import run_cli
    from drivestyle.irl.paper.inner import InnerProblem, InnerSolveError

    solve, calls = InnerProblem.solve, {"n": 0}

    def fail_after_the_initial_theta(self, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 1:
            raise InnerSolveError("Newton did not converge (forced)")
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(InnerProblem, "solve", fail_after_the_initial_theta)
    out = tmp_path / "style"
    with pytest.raises(SystemExit) as info:
        run_cli(
            _main("learn_style"),
            [str(demo_file), "--model", "paper", "--features", "base", "--out", str(out)],
        )
    assert info.value.code != 0
    printed = capsys.readouterr()
    assert "(STALLED)" in printed.out
    error = printed.err.strip().splitlines()[-1]
    assert error.startswith("error: learning stalled after 1 iterations") and "forced" in error
    js = json.loads((out / "style.json").read_text())
    assert js["status"] == "stalled" and js["converged"] is False


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--features", "reactive"], "--features applies to --model paper only"),
        (["--plot", "--t-rct", "1.5"], "--t-rct, --plot apply to --model paper only"),
        (["--model", "paper", "--fit-speed"], "--fit-speed applies to --model driver only"),
        (["--model", "paper", "--residual-floor", "0.5"], "--residual-floor applies to"),
        (["--model", "paper", "--cost-from", "lib"], "--cost-from applies to --model driver"),
    ],
)
def test_learn_style_refuses_options_of_the_other_model(
    tmp_path, demo_file, capsys, options, message
):
    from drivestyle.common.cli import run_cli

    out = tmp_path / "style"
    with pytest.raises(SystemExit) as info:
        run_cli(_main("learn_style"), [str(demo_file), *options, "--out", str(out)])
    assert info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and message in err and len(err.splitlines()) == 1, err
    assert not out.exists()  # refused before any work


def test_learn_style_exits_3_on_a_poor_fit_and_names_the_demonstration(tmp_path, demo_file, capsys):
    from drivestyle.common.cli import run_cli
    from drivestyle.irl.driver.driver_fit import ClosedLoop, DemoFit, DriverFit
    from drivestyle.irl.driver.driver_style import DriverStyle

    def poor_fit(demos, **kwargs):  # two drivers' demonstrations: the second unexplained
        per_demo = (
            DemoFit(0, 60, 0.01, 30, 0.5, 0.01, False, closed_loop=ClosedLoop(0, 0, 0.1, 0)),
            DemoFit(1, 60, 9.5, 30, 0.9, 0.02, True, True, ClosedLoop(1.2, 7.5, 2.0, 0)),
        )
        style = DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0), risk=0.5)
        return DriverFit(style, (0.5, 0.5), 2700.0, 6.7, 120, 12, "poor_fit", 1.0,
                         per_demo=per_demo, optimiser_status="converged")  # fmt: skip

    script = runpy.run_path(str(ROOT / "scripts" / "learn_style.py"), run_name="not_main")
    script["main"].__globals__["learn_driver"] = poor_fit  # run_path returns a copy
    other = tmp_path / "other.npz"  # another driver's: other bytes (a copy counts once)
    demo = load_demonstration(demo_file)
    save_demonstration(replace(demo, meta={**demo.meta, "driver": "other"}), other)
    out = tmp_path / "style"
    with pytest.raises(SystemExit) as info:
        run_cli(script["main"], [str(demo_file), str(other), "--out", str(out)])
    assert info.value.code == 3
    printed = capsys.readouterr()
    assert "poor_fit after 12 iterations" in printed.out
    err = printed.err.strip().splitlines()[-1]  # after the progress bar's
    assert (
        printed.err.count("error:") == 1
        and err.startswith("error: poor fit")
        and "other.npz (rms 9.5, alone best at p 0.90, closed loop rmse_xy 7.50 m)" in err
    )
    assert "demo.npz" not in err
    js = json.loads((out / "style.json").read_text())  # written: nothing is lost
    assert js["status"] == "poor_fit" and js["optimiser_status"] == "converged"
    assert js["poor_demos"] == [1] and js["per_demo"][1]["path"] == str(other)
    assert js["residual_floor"] == 0.1 and js["per_demo"][1]["best_risk"] == 0.9
    assert [r["rmse_xy_m"] for r in js["reproductions"]] == [0, 7.5]  # the fit's closed loops


@pytest.mark.slow  # five demonstrations, the default search (≈ 1–3 min)
def test_learn_style_learns_five_p09_demonstrations_it_once_called_a_poor_fit(tmp_path):
    # least squares alone stopped at w_δ 65.6 against the driver's 10, four demonstrations
    # at 4.4–8 noise floors: exit 3, poor_fit
    from drivestyle.agents import generate_demonstration
    from drivestyle.agents.demo_generation import draw_interactive_scenarios
    from drivestyle.agents.smpc import SMPCConfig

    paths = []
    for i, scenario in enumerate(draw_interactive_scenarios(5, seed=2)):
        paths.append(tmp_path / f"d{i + 1}.npz")
        save_demonstration(
            generate_demonstration(0.9, scenario, SMPCConfig(risk=0.9))[0], paths[-1]
        )
    out = tmp_path / "style"
    proc = subprocess.run(
        [sys.executable, "-m", "drivestyle", "learn-style", *map(str, paths), "--out", str(out)],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    js = json.loads((out / "style.json").read_text())
    assert js["status"] == "converged" and not js["poor_demos"] and not js["notes"]
    steer = js["style"]["weights"][4] / js["style"]["weights"][3]
    assert steer == pytest.approx(10.0, rel=0.02) and js["style"]["risk"] == pytest.approx(
        0.9, abs=0.002
    )
    assert max(d["residual_rms"] for d in js["per_demo"]) < 0.1 * js["residual_floor"]
    assert max(r["rmse_xy_m"] for r in js["reproductions"]) < 1e-3


def test_learn_style_help_names_the_exit_status_of_a_poor_fit():
    proc = _run("learn_style", "--help")
    assert proc.returncode == 0 and "3 driver model poor_fit" in " ".join(proc.stdout.split())


@pytest.mark.slow  # end to end: the whole command
def test_reproduce_paper_with_baseline(tmp_path):
    out = tmp_path / "paper"
    res = _main("reproduce_paper")(
        [
            "--out",
            str(out),
            "--skip-ablations",
            "--with-baseline",
            "--baseline-algo",
            "ppo",
            "--baseline-timesteps",
            "256",
        ]
    )
    for f in (
        "baseline/model.zip",
        "compare/compare.json",
        "compare/compare.md",
        "compare/compare.png",
        "videos/expert.mp4",
        "videos/spline.mp4",
        "videos/sb3.mp4",
        "videos/expert.gif",
    ):
        assert (out / f).is_file(), f
    assert set(res["baseline"]["compare"]) == {"smpc", "spline", "sb3"}
    assert "baseline" in json.loads((out / "results.json").read_text())


def test_learn_style_with_a_populations_cost_learns_only_the_risk(tmp_path, demo_file, capsys):
    # the paper demonstration is an SMPC(0.7) driver; the library holds the expert's cost
    from drivestyle.common.cli import run_cli
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    weights = (0.2, 50.0, 0.2, 1.0, 10.0)
    lib = DriverLibrary(style=DriverStyle(weights, risk=0.9), risks=(0.5, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    out = tmp_path / "style"
    payload = _main("learn_style")([str(demo_file), "--cost-from", str(tmp_path), "--out",
                                    str(out)])  # fmt: skip
    learned = DriverStyle.from_json(payload["style"])
    assert learned.weights == weights and learned.risk == pytest.approx(0.7, abs=1e-3)
    # a file that is no driver library: one line naming it, exit 2
    paper = tmp_path / "paper"
    paper.mkdir()
    (paper / "library.json").write_text(json.dumps({"risks": [0.5], "members": []}))
    with pytest.raises(SystemExit) as info:
        run_cli(_main("learn_style"), [str(demo_file), "--cost-from", str(paper), "--out",
                                       str(tmp_path / "o2")])  # fmt: skip
    err = capsys.readouterr().err.strip().split("\r")[-1]
    assert info.value.code == 2 and err.startswith("error: ") and "paper/library.json" in err


@pytest.mark.slow  # six paths on one demonstration (≈ 1 min)
def test_bench_solver_paths_measures_each_path_against_the_product(tmp_path):
    res = _main("bench_solver_paths")(["--demos", "1", "--out", str(tmp_path / "paths.json")])
    summary = res["summary"]
    assert {"fatrop", "warm_duals", "warm_duals_mu", "continuation"} <= summary.keys()
    # the interpreted product is the compiled one: S(p) equal to 1e-6 (bench_solver_paths.EQUAL)
    assert summary["fatrop"]["demos_equal"] == 1 and summary["fatrop"]["reference"] == "product"
    assert summary["warm_duals"]["reference"] == "fatrop"
    for s in summary.values():
        assert s["wall_over_reference_median"] > 0 and s["max_rel_change"] >= 0
    assert json.loads((tmp_path / "paths.json").read_text())["demos"] == 1


def test_bench_irl_times_identification_with_the_default_driver_library(tmp_path):
    # build-style-library's default library was refused: "no 'feature_config'"
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.scripts.bench_irl import time_identification

    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(library.to_json()))
    timing = time_identification(tmp_path, 1, 0)
    assert timing["n"] == 1 and 0 < timing["identify_s_median"] == timing["identify_s_p95"]
