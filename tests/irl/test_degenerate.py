"""Degenerate demonstrations are rejected with a message that names the problem."""

import inspect
import json
import os
import runpy
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs.demonstration import DemonstrationError
from drivestyle.envs.scenario import PAPER
from drivestyle.irl import FeatureConfig, IRLConfig, MaxEntIRL
from drivestyle.irl.identification.library import LibraryError, StyleLibrary, load_library
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.paper.learner import check_learnable

ROOT = Path(__file__).resolve().parents[2]


def _no_lane_change(demo):
    ev = demo.ev.copy()
    ev[:, 1] = ev[0, 1] + 0.3 * np.sin(np.linspace(0, np.pi, demo.n))  # drifts, stays in lane
    return replace(demo, ev=ev)


def _standing(demo):
    ev = np.repeat(demo.ev[:1], demo.n, axis=0)
    ev[:, 3] = 0.0
    return replace(demo, ev=ev)


def _rescaled_time(demo):
    return replace(demo, t=demo.t * 2.0)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (_no_lane_change, "no lane change"),
        (_standing, "moves only"),
        (_rescaled_time, "sampled every 0.4 s"),
    ],
)
def test_degenerate_demonstrations_are_rejected(paper_demo, make, message):
    check_learnable(paper_demo)  # the real demonstration passes
    bad = make(paper_demo)
    with pytest.raises(DemonstrationError, match=message):
        check_learnable(bad)
    with pytest.raises(DemonstrationError, match=message):
        MaxEntIRL(bad, FeatureConfig(), IRLConfig(max_iter=2))
    library = StyleLibrary(
        "reactive",
        (0.5, 0.9),
        ((1.0,) * 10, (2.0,) * 10),
        members=(((1.0,) * 10,),) * 2,
        training_scenarios=(PAPER.to_dict(),),
    )
    with pytest.raises(LibraryError, match=message):
        identify(bad, library)


def test_learn_style_cli_refuses_a_demo_without_lane_change(tmp_path, paper_demo):
    from drivestyle.envs import save_demonstration

    path = save_demonstration(_no_lane_change(paper_demo), tmp_path / "flat.npz")
    out = tmp_path / "style"
    run = subprocess.run(
        [sys.executable, "scripts/learn_style.py", str(path), "--out", str(out)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    assert run.returncode != 0
    assert "Traceback" not in run.stderr
    assert "no lane change" in run.stderr.strip().splitlines()[-1]
    assert not out.exists()


def test_library_without_members_is_rejected(tmp_path):
    lib = StyleLibrary(
        "reactive",
        (0.5, 0.9),
        ((1.0,) * 10, (2.0,) * 10),
        members=(((1.0,) * 10,),) * 2,
        training_scenarios=(PAPER.to_dict(),),
    )
    raw = lib.to_json()
    raw["members"] = {}
    (tmp_path / "library.json").write_text(json.dumps(raw))
    with pytest.raises(LibraryError, match="members"):
        load_library(tmp_path)


def test_one_default_scorer_for_the_api_and_the_cli():
    assert inspect.signature(identify).parameters["scorer"].default == DEFAULT_SCORER
    parse = runpy.run_path(str(ROOT / "scripts" / "identify_style.py"), run_name="x")["parse_args"]
    assert parse(["demo.npz", "--library", "lib"]).scorer == DEFAULT_SCORER
