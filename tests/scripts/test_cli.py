"""Every script: help on every option, and bad input ends in one `error:` line, no traceback."""

import argparse
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivestyle.common.io import atomic_output_dir

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p for p in (ROOT / "scripts").glob("*.py") if p.name != "__init__.py")


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
    assert any("--seed" in a.option_strings for a in parser._actions), script.name


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
}


@pytest.mark.parametrize("case", CASES, ids=list(CASES))
def test_bad_input_ends_in_one_error_line(case, bad_files):
    args = [a.format(d=bad_files) for a in CASES[case]]
    run = _run(*args)
    assert run.returncode != 0, run.stdout
    assert "Traceback" not in run.stderr, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert "error:" in last, run.stderr
    assert not any(p.name.startswith(".o") and "partial" in p.name for p in bad_files.iterdir())


def test_an_interrupted_output_leaves_the_previous_folder(tmp_path):
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("new, half")
        raise KeyboardInterrupt
    assert (out / "a.json").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_merged_output_keeps_other_files(tmp_path):
    (tmp_path / "demo.npz").write_text("demo")
    with atomic_output_dir(tmp_path, replace=False) as tmp:
        (tmp / "style.json").write_text("{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.npz", "style.json"]
