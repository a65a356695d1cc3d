"""``drivestyle replay-recorded`` in its own process, on a folder of three episodes."""

import csv
import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs import save_demonstration
from drivestyle.envs.traffic import IDM
from drivestyle.studies.replay import replay_episode

ROOT = Path(__file__).resolve().parents[2]


def _command(cwd, *args):
    """``python -m drivestyle replay-recorded ARGS`` in its own process."""
    env = {k: v for k, v in os.environ.items() if k != "DRIVESTYLE_TRACEBACK"}
    return subprocess.run(
        [sys.executable, "-m", "drivestyle", "replay-recorded", *map(str, args)],
        capture_output=True, text=True, cwd=cwd, env=env, timeout=300,
    )  # fmt: skip


def _folder(tmp_path, demos):
    """An extract-episodes folder holding ``demos`` (id → demonstration)."""
    folder = tmp_path / "episodes"
    folder.mkdir()
    with (folder / "episodes.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["episode_id", "file", "carriageway", "vehicle_id", "usable"])
        for i, (eid, demo) in enumerate(demos.items()):
            save_demonstration(demo, folder / f"{eid}.npz")
            writer.writerow([eid, f"{eid}.npz", "road", str(i), "True"])
    return folder


def test_three_episodes_replayed_as_the_study_replays_them(recorded_scene, tmp_path):
    others = recorded_scene.others.copy()
    others[:, 0, :2] = recorded_scene.ev[:, :2] + [3.0, 0.0]  # a collision in the log
    demos = {
        "scene": recorded_scene,
        "crashed": dataclasses.replace(recorded_scene, others=others),
        "phantom": dataclasses.replace(
            recorded_scene, meta={**recorded_scene.meta, "no_interaction": True}
        ),
    }
    folder = _folder(tmp_path, demos)
    done = _command(tmp_path, "--episodes", folder, "--idm", "highway-env", "--out", "replay")
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "replay" / "replay.json").read_text())
    assert result["command"].startswith("drivestyle replay-recorded --episodes")
    assert [e["episode_id"] for e in result["episodes"]] == list(demos)
    for record, demo in zip(result["episodes"], demos.values(), strict=True):
        expected = replay_episode("episodes", record["episode_id"], demo, IDM, 1.0)
        for key in ("start", "steps", "vehicles", "ended"):
            assert record[key] == getattr(expected, key)
        got = [(s["replayed_min"], s["replayed_max"]) for s in record["speeds"]]
        want = [(s.replayed_min, s.replayed_max) for s in expected.speeds]
        np.testing.assert_allclose(got, want, rtol=1e-12)
    summary = result["summary"]
    assert summary["episodes"] == 3 and summary["vehicles"] == 4 + 3 + 3  # no phantom TV
    # (the crashed replay ends at its first step, before vehicle 3 enters)
    assert summary["log_collision_pairs"] == summary["replay_collision_pairs"] == 1
    assert summary["new_collision_pairs"] == 0 and summary["ended_early"] == 1
    assert 0 < summary["speeds_within_share"] < 1
    report = (tmp_path / "replay" / "replay.md").read_text()
    assert "| 3 | 10 | 1 | 1 | 1 | 0 (0) |" in report and "0–2 @ 0.0 s (26)" in report


def test_every_vehicle_driving_its_identified_style(recorded_scene, tiny_posterior, tmp_path):
    _, posterior = tiny_posterior
    demos = {
        "scene": recorded_scene,
        "phantom": dataclasses.replace(
            recorded_scene, meta={**recorded_scene.meta, "no_interaction": True}
        ),
    }
    folder = _folder(tmp_path, demos)
    done = _command(tmp_path, "--episodes", folder, "--others", "style", "--posterior", posterior,
                    "--attend", "lanes", "--out", "replay")  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((tmp_path / "replay" / "replay.json").read_text())
    assert (result["others"], result["attend"]) == ("style", "lanes")
    assert result["posterior"] == str(posterior.resolve())
    for record, demo in zip(result["episodes"], demos.values(), strict=True):
        expected = replay_episode("episodes", record["episode_id"], demo, IDM, 1.0,
                                  posterior=str(posterior), attend="lanes")  # fmt: skip
        assert (record["steps"], record["ended"]) == (expected.steps, expected.ended)
        got = [(s["replayed_min"], s["replayed_max"]) for s in record["speeds"]]
        want = [(s.replayed_min, s.replayed_max) for s in expected.speeds]
        np.testing.assert_allclose(got, want, rtol=1e-9)
        # every vehicle in the scene at the start plans at every step (the late one follows
        # its log; the phantom TV is none)
        drivers = 3 if record["episode_id"] == "scene" else 2
        assert record["plans"] == expected.plans == drivers * record["steps"]
    summary = result["summary"]
    assert summary["plans"] == sum(e["plans"] for e in result["episodes"]) == 25 * (3 + 2)
    assert summary["failed_plans"] == sum(e["failed_plans"] for e in result["episodes"])
    report = (tmp_path / "replay" / "replay.md").read_text()
    assert "Every vehicle, the EV included, drives its own style" in report
    assert f"{summary['plans']} plans, {summary['failed_plans']} failed" in report


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--others", "style"], "--others style drives every vehicle by its identified style"),
        (["--posterior", "p.npz"], "--posterior identifies the styles of --others style"),
        (["--attend", "lanes"], "--attend chooses whom the style drivers plan around"),
        (
            ["--others", "style", "--posterior", "p.npz", "--idm", "highway-env"],
            "--idm sets the IDM of --others idm",
        ),
        (
            ["--others", "style", "--posterior", "missing.npz"],
            "--posterior missing.npz: no such estimator file",
        ),
        (["--episodes", "missing"], "--episodes missing: no such folder"),
        (["--episodes", "x", "--split", "test"], "--episodes and --split contradict"),
        (["--idm", "highway-env", "--physics", "p.json"], "--physics sets --idm calibrated's"),
        (["--episodes", "x", "--split-file", "s.csv"], "--episodes and --split-file contradict"),
    ],
)
def test_bad_options_are_refused_in_one_line(refused, args, message):
    assert message in refused("replay-recorded", *args, "--out", "out")
