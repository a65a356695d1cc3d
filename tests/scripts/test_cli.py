"""Every script: help on every option, and bad input ends in one `error:` line, no traceback."""

import argparse
import contextlib
import importlib
import importlib.util
import io
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from drivestyle.common.output_paths import OutputPathError

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p for p in (ROOT / "scripts").glob("*.py") if p.name != "__init__.py")
NO_SEED = {
    "bench_scene_prediction",  # its predictions are the benchmark's (their seed fixed)
    "capacity_study",
    "compare_av_human",
    "deviating_tv",
    "extract_episodes",
    "identify_style",
    "learn_population",
    "learn_style",
    "mine_styles",
    "predict_trajectory",
    "real_traffic",
    "replay_recorded",
}
"""Deterministic scripts: a --seed there would do nothing, so they have none."""


class _ParserCapturedError(Exception):
    def __init__(self, parser: argparse.ArgumentParser) -> None:
        self.parser = parser


def _parser(script: Path, monkeypatch) -> argparse.ArgumentParser:
    spec = importlib.util.spec_from_file_location(f"_script_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    def capture(self, *args, **kwargs):
        raise _ParserCapturedError(self)

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", capture)
    with pytest.raises(_ParserCapturedError) as info:
        module.parse_args([])
    return info.value.parser


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_every_option_says_what_it_does(script, monkeypatch):
    parser = _parser(script, monkeypatch)
    assert parser.description, f"{script.name} has no description"
    undocumented = [
        a.option_strings or a.dest
        for a in parser._actions
        if not isinstance(a, argparse._HelpAction) and not a.help
    ]
    assert not undocumented, f"{script.name}: options without help: {undocumented}"
    has_seed = any("--seed" in a.option_strings for a in parser._actions)
    assert has_seed == (script.stem not in NO_SEED), script.name


def _run(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "MPLBACKEND": "Agg"}
    env.pop("DRIVESTYLE_TRACEBACK", None)
    return subprocess.run(
        [sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=120, env=env
    )


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    np.savez(d / "empty.npz")
    (d / "a_file").write_text("not a folder")
    (d / "library").mkdir()
    (d / "library" / "library.json").write_text('{"risks": [0.5], "styles": ')
    return d


CASES = {
    "missing demo": ["scripts/learn_style.py", "{d}/nope.npz", "--out", "{d}/o1"],
    "empty npz": ["scripts/learn_style.py", "{d}/empty.npz", "--out", "{d}/o2"],
    "--out is a file": ["scripts/generate_demo.py", "--out", "{d}/a_file"],
    "--max-iter 0": ["scripts/learn_style.py", "{d}/empty.npz", "--max-iter", "0"],
    "--risk 1.5": ["scripts/generate_demo.py", "--risk", "1.5", "--out", "{d}/o3"],
    "--risks 1.5": ["scripts/build_style_library.py", "--risks", "0.5,1.5", "--out", "{d}/o4"],
    "--scenarios 0": ["scripts/evaluate_identification.py", "--scenarios", "0"],
    "--limit 0": ["scripts/real_traffic.py", "--dataset", "ngsim", "--limit", "0"],
    "--limit -1": ["scripts/real_traffic.py", "--dataset", "ngsim", "--limit", "-1"],
    "malformed library": [
        "scripts/identify_style.py",
        "{d}/empty.npz",
        "--library",
        "{d}/library",
        "--out",
        "{d}/o5",
    ],
    "--video bad suffix": ["scripts/render_rollout.py", "--policy", "expert", "--video", "v.txt"],
    "--scales 0": ["scripts/calibrate_uncertainty.py", "--scales", "0", "--out", "{d}/o6"],
    "--timesteps -5": ["scripts/train_baseline.py", "--style", "s.json", "--timesteps", "-5"],
    "missing style": ["scripts/compare_baseline.py", "--style", "{d}/nope.json"],
    "--repeats 0": ["scripts/bench_irl.py", "--repeats", "0"],
    "--trials 0": ["scripts/bench_smpc.py", "--trials", "0"],
    "--steps 0": ["scripts/bench_env.py", "--steps", "0"],
    "--cases bad": ["scripts/bench_env.py", "--cases", "lane_change,nope"],
    "--identify 0": ["scripts/profile_inner.py", "--identify", "0"],
    "predict: missing demo": [
        "scripts/predict_trajectory.py",
        "{d}/nope.npz",
        "--library",
        "{d}/library",
        "--out",
        "{d}/o7",
    ],
    "predict: --observe 0": [
        "scripts/predict_trajectory.py",
        "{d}/empty.npz",
        "--library",
        "{d}/library",
        "--observe",
        "0",
    ],
    "evaluate prediction: --vehicles 0": [
        "scripts/evaluate_prediction.py",
        "--library",
        "{d}/library",
        "--vehicles",
        "0",
    ],
    "evaluate prediction: malformed library": [
        "scripts/evaluate_prediction.py",
        "--library",
        "{d}/library",
        "--no-recorded",
        "--out",
        "{d}/o8",
    ],
}


def _run_in_process(script: str, *args: str) -> tuple[int, str]:
    """(exit status, stderr) of ``python SCRIPT ARGS`` run through run_cli in this process.

    The same handler as the installed command, without an interpreter start-up per case:
    an exception that run_cli does not turn into one line propagates and fails the test.
    """
    from drivestyle.common.cli import run_cli

    name = Path(script).stem
    main = importlib.import_module(f"drivestyle.scripts.{name}").main
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as info:
        run_cli(main, list(args))
    return int(info.value.code or 0), err.getvalue()


def test_the_in_process_runner_sees_what_the_interpreter_sees(bad_files):
    args = ["scripts/learn_style.py", str(bad_files / "nope.npz"), "--out", str(bad_files / "x")]
    run = _run(*args)
    assert (run.returncode, run.stderr.strip().splitlines()[-1]) == (
        (lambda code, err: (code, err.strip().splitlines()[-1]))(*_run_in_process(*args))
    )


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_bad_input_ends_in_one_error_line(case, bad_files, monkeypatch):
    monkeypatch.chdir(ROOT)
    monkeypatch.delenv("DRIVESTYLE_TRACEBACK", raising=False)
    args = [a.format(d=bad_files) for a in CASES[case]]
    code, stderr = _run_in_process(*args)
    assert code == 2, (code, stderr)  # cli.py: 2 for bad input
    assert "Traceback" not in stderr, stderr
    last = stderr.strip().splitlines()[-1]
    assert "error:" in last, stderr
    assert not any(p.name.startswith(".o") and "partial" in p.name for p in bad_files.iterdir())


# ------------------------------------------------------------ outputs checked before the work
UNWRITABLE = Path("/sys")  # no one, root included, can create files there
MISSING = "/nonexistent/drivestyle-input"
# every script that writes, with its output option pointing into UNWRITABLE and its inputs
# missing: the output must be reported first (a later check would report the input, or run)
WRITES = {
    "bench_env": ("--out", "b.json", []),
    "bench_irl": ("--out", "b.json", ["--demo", MISSING]),
    "bench_population": ("--out", "b.json", ["--library", MISSING]),
    "bench_smpc": ("--out", "b.json", []),
    "bench_solver_paths": ("--out", "b.json", []),
    "bench_scene_prediction": ("--out", "b.json", ["--posterior", MISSING]),
    "bench_stochastic": ("--out", "b.json", []),
    "bench_tracker": ("--out", "b.json", ["--library", MISSING]),
    "build_posterior": ("--out", "post", []),
    "build_style_library": ("--out", "lib", []),
    "calibrate_uncertainty": ("--out", "cal", []),
    "capacity_study": ("--out", "cap", []),
    "compare_av_human": ("--out", "avh", ["--mined", MISSING]),
    "compare_baseline": ("--out", "cmp", ["--style", MISSING]),
    "deviating_tv": ("--out", "dev", ["--style", MISSING]),
    "evaluate_identification": ("--out", "ev", ["--library", MISSING]),
    "evaluate_out_of_class": ("--out", "ooc", ["--library", MISSING]),
    "evaluate_planning": ("--out", "plan", ["--library", MISSING]),
    "evaluate_prediction": ("--out", "pe", ["--library", MISSING]),
    "extract_episodes": ("--out", "ep", [MISSING]),
    "generate_demo": ("--out", "demo", []),
    "identify_style": ("--out", "id", [f"{MISSING}.npz", "--library", MISSING]),
    "learn_population": ("--out", "people", ["--library", MISSING]),
    "learn_style": ("--out", "style", [f"{MISSING}.npz"]),
    "mine_styles": ("--out", "mined", [MISSING, "--library", MISSING]),
    "predict_trajectory": ("--out", "pt", [f"{MISSING}.npz", "--library", MISSING]),
    "profile_inner": ("--out", "p.json", []),
    "real_traffic": ("--out", "rt", ["--dataset", "ngsim", "--data", MISSING]),
    "render_rollout": ("--video", "v.gif", ["--policy", "expert"]),
    "replay_recorded": ("--out", "replay", ["--episodes", MISSING]),
    "reproduce_paper": ("--out", "paper", []),
    "simulate_population": ("--out", "pop", ["--vehicles", "2"]),
    "train_baseline": ("--out", "model", ["--style", MISSING]),
}


def test_every_script_that_writes_is_listed():
    assert sorted(WRITES) == [p.stem for p in SCRIPTS]


@pytest.fixture
def time_limit():
    """Fail (instead of running a whole job) when a script starts its work."""

    def expire(signum, frame):
        raise TimeoutError("the script started its work before checking its output")

    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def _partials(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir() if "partial" in p.name}


@pytest.mark.parametrize("name", sorted(WRITES))
def test_an_unwritable_output_is_reported_before_the_work(name, time_limit):
    try:
        os.rmdir(tempfile.mkdtemp(dir=UNWRITABLE))
        pytest.skip(f"{UNWRITABLE} is writable here")
    except OSError:
        pass
    option, leaf, rest = WRITES[name]
    target = UNWRITABLE / f"drivestyle-test-{leaf}"
    main = importlib.import_module(f"drivestyle.scripts.{name}").main
    before = _partials(Path("/"))
    with pytest.raises(OutputPathError) as info:
        main([*rest, option, str(target)])
    message = str(info.value)
    assert message.startswith(f"{option} {target}: cannot create files in"), message
    assert "partial" not in message  # the user's path, not a temporary one
    assert _partials(Path("/")) == before  # nothing left at the root


@pytest.mark.parametrize("name", sorted(WRITES))
def test_an_output_another_run_writes_is_refused_before_the_work(name, time_limit, tmp_path):
    # every script takes its output's lock where it checks it, first thing: with the lock
    # held (here by this process, as another run would hold it), it stops at once
    from drivestyle.common.output_lock import OutputLock

    option, leaf, rest = WRITES[name]
    target = tmp_path / leaf
    with OutputLock(target, option):
        code, stderr = _run_in_process(f"scripts/{name}.py", *rest, option, str(target))
    assert code == 2, stderr
    assert stderr.strip().splitlines()[-1] == (
        f"error: {option} {target} is in use by another run (pid {os.getpid()}); wait for it "
        f"to finish or choose another {option}"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing made, nothing left
