"""drivestyle extract-episodes: a CSV in, demonstrations and episodes.csv out."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivestyle.envs.demonstration import check_plausible, load_demonstration
from drivestyle.scripts.extract_episodes import main

ROOT = Path(__file__).resolve().parents[2]
W = 3.6


def _csv(path: Path) -> Path:
    """Two lane changes at 10 Hz (one left, one right, the right one driving to −x)."""
    t = np.round(np.arange(0, 10.0 + 1e-9, 0.1), 9)
    s = np.clip((t - 5.0) / 4.0 + 0.5, 0, 1)
    move = (1 - np.cos(np.pi * s)) / 2
    rows = [
        pd.DataFrame({"id": 1, "t": t, "x": 20 * t, "y": 0.5 * W + W * move, "v": 20.0}),
        pd.DataFrame({"id": 2, "t": t, "x": -20 + 21 * t, "y": 1.5 * W, "v": 21.0}),
        pd.DataFrame({"id": 3, "t": t, "x": 900 - 20 * t, "y": -1.5 * W + W * move, "v": 20.0}),
    ]
    pd.concat(rows).to_csv(path, index=False)
    return path


def _recordings(folder: Path) -> tuple[Path, Path]:
    """A table of two recordings whose ids and clocks restart, and their lanes file.

    'day1' (lines 0 … 3W): vehicle 1 changes left at 6 s, vehicle 2 keeps lane 0 ahead.
    'day2' (lines 20 … 20 + 3·3.3 m, narrower lanes): vehicle 1 changes right at 5 s,
    vehicle 2 drifts 0.3 m across a line (crossing at 6 s): found, not a lane change.
    """
    t = np.round(np.arange(0, 10.0 + 1e-9, 0.1), 9)

    def move(t_c, a, b, duration=4.0):
        s = np.clip((t - t_c) / duration + 0.5, 0, 1)
        return a + (b - a) * (1 - np.cos(np.pi * s)) / 2

    w2 = 3.3
    rows = [
        ("day1", 1, 20 * t, move(6.0, 0.5 * W, 1.5 * W)),
        ("day1", 2, 40 + 20 * t, np.full_like(t, 0.5 * W)),
        ("day2", 1, 20 * t, move(5.0, 20 + 2.5 * w2, 20 + 1.5 * w2)),
        ("day2", 2, 200 + 20 * t, 20 + w2 + 0.3 * (np.clip((t - 4) / 4, 0, 1) - 0.5)),
    ]
    table = pd.concat(
        pd.DataFrame({"recording": r, "id": i, "t": t, "x": x, "y": y, "v": 20.0})
        for r, i, x, y in rows
    )
    table.to_csv(folder / "freeway.csv", index=False)
    lanes = {"day1": [0, W, 2 * W, 3 * W], "day2": [20 + k * w2 for k in range(4)]}
    (folder / "lanes.json").write_text(json.dumps(lanes))
    return folder / "freeway.csv", folder / "lanes.json"


def _command(*args: str) -> subprocess.CompletedProcess:
    """``python -m drivestyle extract-episodes ARGS`` in its own process."""
    env = {k: v for k, v in os.environ.items() if k != "DRIVESTYLE_TRACEBACK"}
    return subprocess.run(
        [sys.executable, "-m", "drivestyle", "extract-episodes", *args],
        capture_output=True, text=True, cwd=ROOT, env=env, timeout=120,
    )  # fmt: skip


def test_a_table_of_recordings_with_a_lanes_file_through_the_command(tmp_path):
    table, lanes = _recordings(tmp_path)
    out = tmp_path / "episodes"
    proc = _command(str(table), "--lanes", str(lanes), "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stderr
    assert "3 lane change(s) in 4 vehicles, 2 usable (1 mirrored" in proc.stdout
    rows = pd.read_csv(out / "episodes.csv")
    assert list(rows.episode_id) == ["day1_1_6000", "day2_1_5000", "day2_2_6000"]
    assert list(rows.carriageway) == ["day1", "day2", "day2"]
    assert list(rows.usable) == [True, True, False]
    assert list(rows.t_cross_s) == [6.0, 5.0, 6.0] and list(rows.lane_width_m) == [W, 3.3, 3.3]
    assert rows.lateral_move_m.tolist() == pytest.approx([W, 3.3, 0.3], abs=1e-3)
    assert rows.reason[2].startswith(
        "moved 0.30 m laterally towards the new lane across the window, below the minimum "
        "lateral move 1.65 m (half the 3.30 m lane width"
    )
    assert rows.tv_id[0] == 2 and rows.tv_role[0] == "own_leader"  # day1's vehicle 2
    payload = json.loads((out / "extract.json").read_text())
    assert payload["carriageways"] == ["day1", "day2"] and payload["n_usable"] == 2
    assert payload["config"]["min_lateral_move"] == 0.5
    # the same lines without the road edges: vehicles outside are named, changes lost
    inner = tmp_path / "inner.json"
    inner.write_text(json.dumps({"day1": [0, W, 2 * W], "day2": [20 + k * 3.3 for k in range(3)]}))
    proc = _command(str(table), "--lanes", str(inner), "--out", str(tmp_path / "inner"))
    assert proc.returncode == 0, proc.stderr
    (warning,) = [line for line in proc.stderr.splitlines() if line.startswith("warning")]
    assert warning.startswith(f"warning: {inner}: 1 vehicle(s) drive outside the outermost")
    assert "vehicle 1 (day2): 50 sample(s), up to 1.65 m out" in warning  # until 5 s
    assert "2 lane change(s) in 4 vehicles, 1 usable" in proc.stdout


def test_extract_episodes_writes_usable_demonstrations_and_the_index(tmp_path, capsys):
    data = _csv(tmp_path / "tracks.csv")
    out = tmp_path / "episodes"
    payload = main([str(data), "--format", "csv", "--lane-width", str(W), "--out", str(out)])
    assert payload["n_episodes"] == payload["n_usable"] == 2 and payload["n_mirrored"] == 1
    assert "2 lane change(s) in 3 vehicles, 2 usable (1 mirrored" in capsys.readouterr().out
    rows = pd.read_csv(out / "episodes.csv")
    assert sorted(rows.direction) == ["left", "right"]
    assert set(rows.carriageway) == {"+x", "-x"}
    left = rows[rows.direction == "left"].iloc[0]
    assert left.tv_id == 2 and left.tv_role == "target_follower" and not left.no_interaction
    assert bool(rows[rows.direction == "right"].iloc[0].no_interaction)
    for name in rows.file:
        check_plausible(load_demonstration(out / name))
    assert json.loads((out / "extract.json").read_text())["n_usable"] == 2


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--lane-width", "12"], "lanes 12 m wide"),
        (["--observe", "5"], "observe_s (--observe) = 5 s exceeds min_before_s (--min-before)"),
        (["--format", "ngsim", "--lane-width", "3"], "--lane-width, --lane-markings and --lanes"),
        (["--lanes", "{d}/lanes.json", "--lane-width", "3.5"],
         "--lanes {d}/lanes.json and --lane-width contradict: give the lane lines once"),
        (["--lanes", "{d}/lanes.json", "--lane-markings", "0,3.5,7"], "and --lane-markings contra"),
        (["--lanes", "{d}/day1.json"], "{d}/day1.json: no lane lines for recording 'day2' (1 of"),
        (["--lanes", "{d}/extra.json"], "{d}/extra.json: recording 'day3' is not in the table"),
        (["--lanes", "{d}/down.json"],
         "{d}/down.json: lane lines (lanes, recording 'day2') must be 3 or more increasing "
         "numbers [m], road edges included, got [26.6, 23.3, 20.0]"),
        (["--lanes", "{d}/nope.json"], "{d}/nope.json: no such file"),
    ],
)  # fmt: skip
def test_bad_input_is_one_error_line(tmp_path, args, message):
    table, lanes = _recordings(tmp_path)
    day1 = {"day1": json.loads(lanes.read_text())["day1"]}
    (tmp_path / "day1.json").write_text(json.dumps(day1))
    (tmp_path / "extra.json").write_text(json.dumps({**json.loads(lanes.read_text()), "day3": []}))
    (tmp_path / "down.json").write_text(json.dumps({**day1, "day2": [26.6, 23.3, 20.0]}))
    data = table if "--lanes" in args else _csv(tmp_path / "tracks.csv")
    args = [a.format(d=tmp_path) for a in args]
    cmd = [sys.executable, "scripts/extract_episodes.py", str(data), *args]
    proc = subprocess.run(
        [*cmd, "--out", str(tmp_path / "o")], capture_output=True, text=True, cwd=ROOT
    )
    assert proc.returncode == 2 and proc.stderr.startswith("error:"), proc.stderr
    assert message.format(d=tmp_path) in proc.stderr and proc.stderr.count("\n") == 1


@pytest.mark.parametrize("value", ["2", "-0.1", "half"])
def test_a_min_lateral_move_outside_a_lane_is_refused_by_the_parser(tmp_path, value):
    data = _csv(tmp_path / "tracks.csv")
    proc = _command(str(data), "--lane-width", str(W), "--min-lateral-move", value)
    assert proc.returncode == 2 and "argument --min-lateral-move:" in proc.stderr


def test_the_shipped_ngsim_sample_goes_through_the_command(tmp_path):
    data = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ngsim"
    if not data.is_dir():
        pytest.skip("../shared/data not beside the checkout")
    from drivestyle.scripts import extract_episodes

    extract_episodes.main([str(data), "--format", "sample", "--out", str(tmp_path / "out")])
    rows = (tmp_path / "out" / "episodes.csv").read_text().splitlines()
    assert (
        len(rows) - 1 == 19
    )  # every lane change of the sample (tests/recorded/test_sample_extraction.py)


def test_every_vehicles_windows_through_the_command(tmp_path):
    table, lanes = _recordings(tmp_path)
    out = tmp_path / "all"
    proc = _command(str(table), "--lanes", str(lanes), "--all-vehicles", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    rows = pd.read_csv(out / "episodes.csv")
    changes = rows[rows.kind == "lane_change"]
    assert list(changes.episode_id) == ["day1_1_6000", "day2_1_5000", "day2_2_6000"]
    windows = rows[rows.kind != "lane_change"]
    assert len(windows) > 0 and windows.episode_id.str.endswith("_w").all()
    assert set(windows.kind) <= {"lane_keeping", "car_following", "approaching"}
    for _, row in windows[windows.usable].iterrows():
        assert (out / row.file).is_file()
    payload = json.loads((out / "extract.json").read_text())
    by_kind = payload["by_kind"]
    assert sum(n["episodes"] for n in by_kind.values()) == len(rows)
    assert by_kind["lane_change"] == {"episodes": 3, "usable": 2}
    assert "windows without one:" in proc.stdout
