"""``drivestyle identify-style`` in its own process: the verdict is said first, as it is."""

import json
import os
import subprocess
import sys

import pytest

from drivestyle.agents import generate_demonstration
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary

EXPERT = (0.2, 50.0, 0.2, 1.0, 10.0)  # the SMPC expert's weights: its demos fit exactly


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    folder = tmp_path_factory.mktemp("library")
    lib = DriverLibrary(DriverStyle(EXPERT), risks=(0.5, 0.7, 0.9))
    (folder / "library.json").write_text(json.dumps(lib.to_json()))
    return folder


def _identify(demo, library, tmp_path):
    path = tmp_path / "demo.npz"
    save_demonstration(demo, path)
    out = tmp_path / "out"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env.pop("DRIVESTYLE_TRACEBACK", None)
    done = subprocess.run(
        [sys.executable, "-m", "drivestyle", "identify-style", str(path), "--library",
         str(library), "--out", str(out)],
        capture_output=True, text=True, timeout=120, env=env,
    )  # fmt: skip
    payload = json.loads((out / "identify.json").read_text()) if done.returncode == 0 else None
    return done, payload


def test_an_smpc_demonstration_is_informative_and_headed_by_its_risk(library, paper_demo, tmp_path):
    done, payload = _identify(paper_demo, library, tmp_path)
    assert done.returncode == 0, done.stderr
    first, numbers = done.stdout.splitlines()[:2]
    assert first.startswith("informative: the data identify the risk (the data moved the ")
    assert numbers.startswith("  risk estimate 0.7, 90 % interval [")
    assert payload["verdict"] == "informative"
    assert payload["informative"] is True and payload["out_of_class"] is False
    assert payload["constraint_binds_per_demo"] == [True]


def test_a_demonstration_nobody_comes_near_is_the_prior_and_says_so_first(library, tmp_path):
    # the TV 1 km behind: no chance constraint ever binds, the posterior is the prior
    far = PAPER.with_overrides(tv_gap=-1000.0, tv_speed=25.0, ev_speed=25.0)
    demo, summary = generate_demonstration(0.7, far)
    assert summary["min_s_e"] > 1000
    done, payload = _identify(demo, library, tmp_path)
    assert done.returncode == 0, done.stderr
    first, numbers = done.stdout.splitlines()[:2]
    assert first.startswith(
        "the prior: nothing in the data can move the risk (no chance constraint binds at any "
        "risk, the other vehicles never come near: closest s_e "
    )
    assert numbers.startswith("  posterior ≈ the prior: 90 % interval [0.5, 0.99], ")
    assert "risk estimate" not in done.stdout  # the prior's mode is no answer
    assert payload["verdict"] == "no_constraint"
    assert payload["informative"] is False and payload["out_of_class"] is False
    assert payload["constraint_binds"] is False and payload["constraint_binds_per_demo"] == [False]
    assert payload["reason"] in first
