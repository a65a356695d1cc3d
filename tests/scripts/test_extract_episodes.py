"""drivestyle extract-episodes: a CSV in, demonstrations and episodes.csv out."""

from __future__ import annotations

import json
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
        (["--observe", "5"], "observe_s = 5 s exceeds min_before_s"),
        (["--format", "ngsim", "--lane-width", "3"], "--lane-width and --lane-markings are for"),
    ],
)
def test_bad_input_is_one_error_line(tmp_path, args, message):
    data = _csv(tmp_path / "tracks.csv")
    cmd = [sys.executable, "scripts/extract_episodes.py", str(data), *args]
    proc = subprocess.run(
        [*cmd, "--out", str(tmp_path / "o")], capture_output=True, text=True, cwd=ROOT
    )
    assert proc.returncode == 2 and proc.stderr.startswith("error:"), proc.stderr
    assert message in proc.stderr and proc.stderr.count("\n") == 1


def test_the_shipped_ngsim_sample_goes_through_the_command(tmp_path):
    data = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "ngsim"
    if not data.is_dir():
        pytest.skip("../shared/data not beside the checkout")
    from drivestyle.scripts import extract_episodes

    extract_episodes.main([str(data), "--format", "sample", "--out", str(tmp_path / "out")])
    rows = (tmp_path / "out" / "episodes.csv").read_text().splitlines()
    assert (
        len(rows) - 1 == 19
    )  # every lane change of the sample (tests/envs/test_sample_extraction.py)
