"""Bad inputs to ``drivestyle extract-episodes``, each met where a user meets it.

Every test writes a small table with one faulty property, runs the command in a fresh
process (``python -m drivestyle extract-episodes``) and checks that it ends clearly: a
one-line ``error: …`` naming the file, option and value with exit status 2, or the
episode kept in ``episodes.csv`` as unusable with its reason, or a documented fallback
with a warning. The healthy table (:func:`_vehicles`) gives one usable lane change, so a
test fails when a rule stops firing.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivestyle.recorded.episodes import (
    FILE_NAME_MAX,
    episode_file_name,
    episode_file_names,
    extract_episodes,
)
from drivestyle.recorded.readers import read_table

# each test runs a command in its own process, as a user meets the problem (1-6 s each):
# CI runs them with the slow set, the default run stays within its time
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
W = 3.75
"""Lane width of the tables [m]."""
T = np.round(np.arange(0.0, 12.0 + 1e-9, 0.1), 9)
"""Sample times of the tables: 12 s at 10 Hz [s]."""
SPEED = 25.0
"""Every vehicle's speed [m/s] (90 km/h)."""


def _lane_change(t_c: float = 6.0, duration: float = 4.0) -> np.ndarray:
    """y of a change from lane 0's centre to lane 1's, crossing y = W at ``t_c`` [m]."""
    s = np.clip((T - t_c) / duration + 0.5, 0, 1)
    return 0.5 * W + W * (1 - np.cos(np.pi * s)) / 2


def _vehicles(changer: str = "1", follower: str = "2") -> pd.DataFrame:
    """A lane changer and the target lane's follower 20 m behind it: one usable episode."""
    return pd.concat(
        [
            pd.DataFrame({"id": changer, "t": T, "x": SPEED * T, "y": _lane_change()}),
            pd.DataFrame({"id": follower, "t": T, "x": SPEED * T - 20.0, "y": 1.5 * W}),
        ],
        ignore_index=True,
    )


def _run(tmp_path: Path, table: pd.DataFrame | Path, *options: str) -> subprocess.CompletedProcess:
    """``python -m drivestyle extract-episodes TABLE OPTIONS --out tmp/out`` in its own process."""
    if isinstance(table, pd.DataFrame):
        path = tmp_path / "tracks.csv"
        table.to_csv(path, index=False)
    else:
        path = table
    if not any(o.startswith("--lane") for o in options) and "--format" not in options:
        options = ("--lane-width", str(W), *options)
    env = {k: v for k, v in os.environ.items() if k != "DRIVESTYLE_TRACEBACK"}
    return subprocess.run(
        [sys.executable, "-m", "drivestyle", "extract-episodes", str(path), *options,
         "--out", str(tmp_path / "out")],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120,
    )  # fmt: skip


def _error(proc: subprocess.CompletedProcess) -> str:
    """The one line ``error: …`` of a run that ended with exit status 2."""
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    lines = [line for line in _said(proc) if not line.startswith("warning: ")]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    return lines[0]


def _said(proc: subprocess.CompletedProcess) -> list[str]:
    """The lines on stderr besides the progress bars (tqdm: ``…%|…|…``)."""
    return [
        line for line in proc.stderr.splitlines() if line.strip() and not re.search(r"%\|", line)
    ]


def _episodes(tmp_path: Path, proc: subprocess.CompletedProcess) -> pd.DataFrame:
    """``episodes.csv`` of a run that succeeded."""
    assert proc.returncode == 0, proc.stderr
    return pd.read_csv(tmp_path / "out" / "episodes.csv", dtype={"vehicle_id": str})


def test_the_healthy_table_gives_one_usable_lane_change(tmp_path):
    rows = _episodes(tmp_path, _run(tmp_path, _vehicles()))
    assert rows.episode_id.tolist() == ["+x_1_6000"] and rows.usable.tolist() == [True]
    assert rows.file.tolist() == ["+x_1_6000.npz"]
    assert (tmp_path / "out" / "+x_1_6000.npz").is_file()


# ------------------------------------------------------------------ 1, 2: output paths
ESCAPES = ("../../escaped", "../" * 12 + "tmp/escaped", "/tmp/escaped", "a/b", "..", "a\x00b")
"""Vehicle ids that would leave the output folder (or the file system's rules) as file names."""


def test_a_vehicle_id_cannot_place_a_file_outside_the_output_folder(tmp_path):
    # each id changes lane 300 m after the previous one (no interaction, one process)
    table = pd.concat(
        [
            pd.DataFrame({"id": vid, "t": T, "x": SPEED * T + 300.0 * k, "y": _lane_change()})
            for k, vid in enumerate(ESCAPES)
        ],
        ignore_index=True,
    )
    rows = _episodes(tmp_path, _run(tmp_path, table))
    out = tmp_path / "out"
    assert sorted(rows.vehicle_id) == sorted(ESCAPES)  # the index keeps the ids as they are
    assert rows.usable.all() and rows.file.nunique() == len(ESCAPES)
    for vid, name in zip(rows.vehicle_id, rows.file, strict=True):
        assert Path(name).name == name and "/" not in name and "\x00" not in name
        assert not name.startswith(".") and (out / name).is_file()
        assert name == episode_file_name(f"+x_{vid}_6000")
        if vid != "..":  # "+x_.._6000" is one safe name already
            assert re.fullmatch(r"\+x_[A-Za-z0-9._+-]*_6000-[0-9a-f]{12}\.npz", name), name
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [".drivestyle-output", "episodes.csv", "extract.json", *rows.file]
    )
    assert sorted(tmp_path.rglob("*.npz")) == sorted(out / name for name in rows.file)


def test_a_300_character_vehicle_id_gets_a_bounded_file_name(tmp_path):
    vehicle = "a" * 300
    proc = _run(tmp_path, _vehicles(changer=vehicle))
    assert "partial" not in proc.stderr and "Errno" not in proc.stderr
    rows = _episodes(tmp_path, proc)
    (name,) = rows.file
    assert len(name) == FILE_NAME_MAX + len(".npz") and (tmp_path / "out" / name).is_file()
    assert rows.vehicle_id.tolist() == [vehicle]
    # cut ids keep distinct names: the hash of the whole id is in the name
    assert episode_file_name("+x_" + "a" * 300 + "b") != episode_file_name("+x_" + "a" * 301)


def test_file_names_of_ids_differing_in_unsafe_characters_or_case_differ():
    assert episode_file_name("+x_1_6000") == "+x_1_6000.npz"  # safe ids are kept
    assert episode_file_name("+x_a/b_1") != episode_file_name("+x_a_b_1")
    taken = {episode_file_name("+x_A_1").casefold()}
    other = episode_file_name("+x_a_1", taken)
    assert other.casefold() not in taken and other.startswith("+x_a_1-")


# --------------------------------------------------------------- 3: the speed limit
def test_a_fleet_at_120_mps_is_refused_with_the_likely_unit(tmp_path):
    table = _vehicles()
    table["x"] *= 120 / SPEED  # every vehicle at 120 m/s by its positions
    line = _error(_run(tmp_path, table))
    assert line.startswith(f"error: {tmp_path / 'tracks.csv'}: 2 of 2 vehicles drive at a median ")
    assert "120 m/s by their positions" in line and "beyond 70 m/s (252 km/h)" in line
    assert "positions in feet (× 0.3048: 36.6 m/s)?" in line
    assert "computed from a speed in km/h (÷ 3.6: 33.3 m/s)?" in line
    # a speed column in km/h: named as such
    table = _vehicles().assign(v=SPEED * 3.6)
    line = _error(_run(tmp_path, table))
    assert "2 of 2 vehicles drive at a median 90 m/s by the speed column" in line
    assert "km/h given as m/s (÷ 3.6: 25 m/s)?" in line


def test_one_car_at_120_mps_is_kept_unusable_with_its_speed(tmp_path):
    table = _vehicles()
    table.loc[table.id == "1", "x"] *= 120 / SPEED
    proc = _run(tmp_path, table)
    rows = _episodes(tmp_path, proc)
    assert rows.usable.tolist() == [False] and rows.file.isna().all()
    assert rows.reason[0].startswith(
        "vehicle 1 drives at a median 120 m/s by its positions, beyond 70 m/s (252 km/h), the "
        "fastest a road vehicle drives: positions in feet (× 0.3048: 36.6 m/s)?"
    )
    (warning,) = _said(proc)
    assert "1 vehicle(s) whose motion is not a road vehicle's" in warning
    assert "vehicle 1 (+x) drives" in warning


# ------------------------------------------------------------ 4: time in milliseconds
def test_times_in_milliseconds_are_refused_with_the_conversion(tmp_path):
    table = _vehicles()
    table["t"] = np.round(table.t * 1000)
    line = _error(_run(tmp_path, table))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: 2 of 2 vehicles have a median time step of 100 (read "
        "as seconds: more than 1 s, too rare to show a lane change) and drive at a median "
        "0.025 m/s: times in milliseconds? divide by 1000 (a step of 0.1 s, 10 Hz)"
    )


# ------------------------------------------------------------- 5: positions in feet
def test_positions_in_feet_are_refused_also_when_the_lanes_are_given_in_metres(tmp_path):
    table = _vehicles()
    table[["x", "y"]] /= 0.3048  # feet, and no speed column; the lanes given in metres
    line = _error(_run(tmp_path, table, "--lane-width", str(W)))
    assert line.startswith(f"error: {tmp_path / 'tracks.csv'}: 2 of 2 vehicles drive at a median ")
    assert "82 m/s by their positions" in line and "positions in feet (× 0.3048: 25 m/s)?" in line


# ------------------------------------------------------------ 6: heading in degrees
def _course(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The direction of motion of positions sampled on :data:`T` [rad]."""
    return np.arctan2(np.gradient(y, T), np.gradient(x, T))


def test_a_heading_in_degrees_is_checked_against_the_course_and_named(tmp_path):
    table = _vehicles()
    table["heading"] = 0.0
    changer = table.id == "1"
    heading = np.degrees(_course(table.x[changer].to_numpy(), table.y[changer].to_numpy()))
    table.loc[changer, "heading"] = heading  # up to 3.2 "rad" for a lane change
    proc = _run(tmp_path, table)
    rows = _episodes(tmp_path, proc)
    assert rows.usable.tolist() == [False]
    assert re.fullmatch(
        r"vehicle 1 has a recorded heading of 3\.\d+ rad where its positions' course is "
        r"0\.05\d+ rad \(\d+% of its samples differ by more than 0\.35 rad\): degrees\? "
        r"\(3\.\d+° = 0\.05\d+ rad; × π/180\)",
        rows.reason[0],
    ), rows.reason[0]
    (warning,) = _said(proc)
    assert "vehicle 1 (+x) has a recorded heading of 3." in warning
    # every vehicle's heading in degrees: the file's unit, refused
    table["id"] = np.where(changer, "1", "2")
    table.loc[~changer, "heading"] = np.degrees(0.01)  # ≈ 0.57° for a car driving straight
    line = _error(_run(tmp_path, table))
    assert line.startswith(f"error: {tmp_path / 'tracks.csv'}: 2 of 2 vehicles' recorded heading")
    assert "degrees?" in line


# ----------------------------------------------------- 7: one car under two ids
def test_the_same_car_under_two_ids_is_found_and_both_named(tmp_path):
    table = _vehicles()
    twin = table[table.id == "1"].assign(id="1b")  # the lane changer again, for all 12 s
    rows = _episodes(tmp_path, proc := _run(tmp_path, pd.concat([table, twin])))
    assert rows.episode_id.tolist() == ["+x_1_6000", "+x_1b_6000"]
    assert rows.usable.tolist() == [False, False]
    for me, other in (("1", "1b"), ("1b", "1")):
        (reason,) = rows.reason[rows.vehicle_id == me]
        assert reason == (
            f"vehicle {me} overlaps vehicle {other} from t = 0 to 12 s (121 sample(s) 0.1 s "
            "apart): two vehicles cannot share a place; the same vehicle under two ids, or "
            "positions or sizes in another unit?"
        )
    (warning,) = _said(proc)
    assert "2 vehicle(s) whose motion is not a road vehicle's" in warning


def test_an_overlap_outside_the_window_leaves_the_lane_change_usable(tmp_path, capsys):
    # vehicle 3 sits on the follower (vehicle 2) for the first second, before the window
    table = _vehicles()
    follower = table[table.id == "2"]
    path = tmp_path / "tracks.csv"
    pd.concat([table, follower.iloc[:11].assign(id="3")]).to_csv(path, index=False)
    rec = read_table(path, lane_width=W)
    assert "vehicle 2 (+x) overlaps vehicle 3 from t = 0 to 1 s" in capsys.readouterr().err
    (episode,) = extract_episodes(rec)
    assert episode.usable and episode.interacting == (("target_follower", "2"),)


# ------------------------------------------------------------ 8: a hole in a track
def test_a_hole_across_the_lane_change_keeps_it_unusable_with_the_gap(tmp_path):
    table = _vehicles()
    hole = (table.id == "1") & (table.t > 3.5) & (table.t < 8.5)  # 5 s around the crossing
    rows = _episodes(tmp_path, _run(tmp_path, table[~hole]))
    assert rows.usable.tolist() == [False] and rows.file.isna().all()
    assert rows.reason[0] == (
        "no sample for 5 s across the crossing (t = 3.5 to 8.5 s), more than max_gap_s "
        "(--max-gap) 1 s: the lane change itself is not recorded, and a spline would invent it"
    )
    # a hole before the crossing cuts the window; one in the follower's track marks it
    hole = (table.id == "1") & (table.t > 0.5) & (table.t < 3.5)
    rows = _episodes(tmp_path, _run(tmp_path, table[~hole], "--min-before", "2.4"))
    assert rows.usable.tolist() == [True] and rows.first_frame.tolist() == [35]
    hole = (table.id == "2") & (table.t > 6.5) & (table.t < 8.0)
    rows = _episodes(tmp_path, _run(tmp_path, table[~hole]))
    assert rows.usable.tolist() == [False] and rows.reason[0] == (
        "interacting vehicle 2 (target_follower) has no sample for 1.5 s (t = 6.5 to 8 s) "
        "inside the window, more than max_gap_s (--max-gap) 1 s: a spline would invent its "
        "motion"
    )


# ------------------------------------------------------ 9: time going backwards
def test_a_vehicle_whose_time_goes_back_in_file_order_is_refused_with_the_rows(tmp_path):
    table = _vehicles()
    swapped = table.index[(table.id == "1") & table.t.between(5.85, 6.15)]  # 5.9 … 6.1 s
    table.loc[swapped, ["t", "x", "y"]] = table.loc[swapped[::-1], ["t", "x", "y"]].to_numpy()
    line = _error(_run(tmp_path, table))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: vehicle 1, data row 61: t = 6 s comes after t = "
        "6.1 s (data row 60): a vehicle's rows must be in time order (rows of different "
        "vehicles may interleave); sort the table by vehicle and time if its row order means "
        "nothing"
    )
    # rows of different vehicles interleaved, each in time order: legal, the same episode
    mixed = _vehicles().sort_values(["t", "id"], kind="stable")
    rows = _episodes(tmp_path, _run(tmp_path, mixed))
    assert rows.episode_id.tolist() == ["+x_1_6000"] and rows.usable.tolist() == [True]


# ------------------------------------------------------------- 10: an empty id
def test_a_row_without_a_vehicle_id_is_refused_with_the_row(tmp_path):
    table = _vehicles()
    table.loc[130, "id"] = None  # the follower's tenth row
    line = _error(_run(tmp_path, table))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: data row 131 (line 132): no vehicle id (column 'id' "
        "is empty; 1 such row(s)): every row names its vehicle"
    )


# ------------------------------------------------------ 11: contradicting lane options
def test_lane_options_that_contradict_are_one_line_errors(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    markings = "0,3.75,7.5"
    line = _error(_run(tmp_path, table, "--lane-width", str(W), "--lane-markings", markings))
    assert line == (
        f"error: --lane-width {W:g} and --lane-markings {markings} contradict: give the lane "
        "lines once (--lane-width W puts them at multiples of W, --lane-markings at the given y)"
    )
    lanes = tmp_path / "lanes.json"
    lanes.write_text("[0, 3.75, 7.5]")
    line = _error(_run(tmp_path, table, "--lanes", str(lanes), "--lane-width", str(W)))
    assert line.startswith(f"error: --lanes {lanes} and --lane-width contradict")
    line = _error(_run(tmp_path, table, "--lane-width", str(W), "--direction", "x+"))
    assert line.startswith("error: --direction is for --format interaction")


# ------------------------------------------------ 12: --dt and the other numbers
def test_dt_and_the_numbers_are_checked_up_front_against_windows_and_sampling(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    line = _error(_run(tmp_path, table, "--dt", "10"))
    assert line == (
        "error: dt (--dt) = 10 s, T_s of the demonstrations, is longer than the observed part "
        "observe_s (--observe) = 2 s, which would hold a single sample: T_s is a fraction of a "
        "second (the model's is 0.2 s)"
    )
    line = _error(_run(tmp_path, table, "--dt", "2", "--min-before", "2", "--min-after", "1"))
    assert line.startswith("error: dt (--dt) = 2 s leaves the shortest window (3 s: ")
    line = _error(_run(tmp_path, table, "--max-gap", "0.05"))
    assert line == (
        f"error: {table}: the data's median time step is 0.1 s, longer than max_gap_s "
        "(--max-gap) = 0.05 s: every step would be a gap; give --max-gap at least the time step"
    )
    line = _error(_run(tmp_path, table, "--min-stay", "0.05"))
    assert line.startswith(f"error: {table}: the data's median time step is 0.1 s, longer than")
    line = _error(_run(tmp_path, table, "--v-ref", "100"))
    assert line == (
        "error: v_ref (--v-ref) must be in (0, 70] m/s (70 m/s = 252 km/h, the fastest a road "
        "vehicle drives), got 100.0: km/h given as m/s?"
    )
    assert not (tmp_path / "out").exists()  # nothing written


# ------------------------------------------------------------------- 13: messages
def test_unreadable_files_are_said_to_be_what_they_are(tmp_path):
    latin = tmp_path / "latin1.csv"
    latin.write_bytes("id,t,x,y\nJürgen,0,0,0\n".encode("latin-1"))
    line = _error(_run(tmp_path, latin))
    assert line == (
        f"error: {latin} is not UTF-8 text (byte 0xfc at offset 10, line 2): text in another "
        "encoding (latin-1, Windows-1252?); save it as UTF-8; expected a CSV table of tracks "
        "(columns id, t, x, y, …)"
    )
    binary = tmp_path / "tracks.xlsx"
    binary.write_bytes(b"PK\x03\x04\x14\x00\x06\x00\x08\x00\x00\x00!\x00\xb5U\x80")
    line = _error(_run(tmp_path, binary))
    assert line.startswith(f"error: {binary} is a binary file, not text (byte 0xb5 at offset 14")
    blank = tmp_path / "vehicle_tracks_000.csv"
    blank.write_text("\n  \n")
    line = _error(_run(tmp_path, blank, "--format", "interaction", "--lane-markings", "0,3.75,7.5",
                       "--direction", "x+"))  # fmt: skip
    assert line == (
        f"error: {blank} is empty (no header, no rows): expected an INTERACTION "
        "vehicle_tracks_NNN.csv"
    )


def test_a_text_file_named_npz_and_an_off_grid_observe_time_are_said_plainly(tmp_path):
    import json

    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(library.to_json()))
    env = {k: v for k, v in os.environ.items() if k != "DRIVESTYLE_TRACEBACK"}

    def predict(demo: Path, observe: str) -> str:
        return _error(subprocess.run(
            [sys.executable, "-m", "drivestyle", "predict-trajectory", str(demo), "--library",
             str(tmp_path), "--observe", observe, "--out", str(tmp_path / "p")],
            capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120,
        ))  # fmt: skip

    text = tmp_path / "episode.npz"
    text.write_text("id,t,x,y\n")
    assert predict(text, "2") == (
        f"error: {text} is a text file (it begins 'id,t,x,y'), not a demonstration: a "
        "demonstration is an .npz archive with arrays t, ev, tv, u and meta (written by "
        "drivestyle, e.g. extract-episodes or build-style-library)"
    )
    # an extracted episode's sample times are differences of floats (0.20000000000000018)
    rows = _episodes(tmp_path, _run(tmp_path, _vehicles()))
    episode = tmp_path / "out" / rows.file[0]
    assert predict(episode, "0.3") == (
        "error: the observed time 0.3 s is not a whole number of T_s = 0.2 s; use 0.2 or 0.4 s"
    )


# ---------------------------------------------- a second probe (the readers): 1 names
def test_two_recordings_that_would_share_a_carriageway_are_refused_naming_both(tmp_path):
    # recording "day" has traffic both ways (carriageways "day+x", "day-x"); a recording
    # literally named "day+x" would be merged into the first's +x traffic
    both = pd.concat(
        [
            _vehicles().assign(recording="day"),
            pd.DataFrame({"id": "9", "t": T, "x": -SPEED * T, "y": -1.5 * W, "recording": "day"}),
            _vehicles().assign(recording="day+x"),  # the same clock: the same episode ids
        ],
        ignore_index=True,
    )
    proc = _run(tmp_path, both)
    assert _error(proc) == (
        f"error: {tmp_path / 'tracks.csv'}: recording 'day' (its traffic to +x) and recording "
        "'day+x' would both be carriageway 'day+x' (a two-way recording's traffic is "
        "'<recording>+x' and '<recording>-x'): their vehicles and episode ids would mix; rename "
        "one recording"
    )
    assert "partial" not in proc.stderr and not (tmp_path / "out").exists()
    # renamed, both are read: the two-way recording's +x and -x, and the other
    rows = _episodes(tmp_path, _run(tmp_path, both.replace({"recording": {"day+x": "night"}})))
    assert rows.episode_id.tolist() == ["day+x_1_6000", "night_1_6000"]


def test_two_episodes_of_one_file_are_said_with_the_final_path(tmp_path):
    path = tmp_path / "tracks.csv"
    _vehicles().to_csv(path, index=False)
    (episode,) = extract_episodes(read_table(path, lane_width=W))
    with pytest.raises(ValueError) as info:
        episode_file_names([episode, episode], tmp_path / "out")
    assert str(info.value) == (
        f"two episodes would be written to {tmp_path / 'out' / '+x_1_6000.npz'} (episode "
        "'+x_1_6000' twice): an episode id is unique in a folder"
    )


# ------------------------------------------------- 2: --observe off the T_s grid
def test_an_observed_part_off_the_dt_grid_is_refused_up_front(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    line = _error(_run(tmp_path, table, "--observe", "0.3"))
    assert line == (
        "error: observe_s (--observe) = 0.3 s is not a whole number of T_s = dt (--dt) = 0.2 s; "
        "use 0.2 or 0.4 s"
    )
    line = _error(_run(tmp_path, table, "--dt", "0.15"))  # the default --observe 2
    assert line == (
        "error: observe_s (--observe) = 2 s is not a whole number of T_s = dt (--dt) = 0.15 s; "
        "use 1.95 or 2.1 s"
    )
    assert not (tmp_path / "out").exists()
    rows = _episodes(tmp_path, _run(tmp_path, table, "--dt", "0.15", "--observe", "1.95"))
    assert rows.observed_until_s.tolist() == [1.95]


# --------------------------------------------- 3: --dt against its cost and the data
def test_a_dt_beyond_the_sample_bound_is_refused_and_a_fine_one_noted(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    line = _error(_run(tmp_path, table, "--dt", "1e-9", "--observe", "2"))
    assert line == (
        "error: dt (--dt) = 1e-09 s gives a window of 8 s (--before 4 + --after 4) 8e+09 "
        "samples, more than 2,000 (≈ 0.6 ms of work each: the bound alone is ≈ 1.2 s per lane "
        "change); T_s is a fraction of a second (the model's is 0.2 s): give --dt 0.004 s or "
        "more"
    )
    line = _error(_run(tmp_path, table, "--dt", "0.001"))
    assert line.startswith("error: dt (--dt) = 0.001 s gives a window of 8 s (--before 4 + ")
    assert not (tmp_path / "out").exists()
    # 10x finer than the data's 0.1 s: legal, said
    proc = _run(tmp_path, table, "--dt", "0.01")
    assert _episodes(tmp_path, proc).usable.tolist() == [True]
    assert _said(proc) == [
        f"note: {table}: dt (--dt) = 0.01 s is 10× finer than the data's median time step 0.1 s: "
        "90% of a demonstration's samples lie between recorded ones (the splines', not the "
        "data's; so are the inputs recovered there); the demonstrations are written as asked"
    ]
    assert not [line for line in _said(_run(tmp_path, table, "--dt", "0.05")) if "note" in line]


# ------------------------------------------------ 4: a vehicle of one sample
def test_a_vehicle_of_one_sample_is_skipped_with_a_note(tmp_path):
    lone = pd.DataFrame({"id": ["77"], "t": [3.0], "x": [500.0], "y": [1.5 * W]})
    proc = _run(tmp_path, pd.concat([_vehicles(), lone], ignore_index=True))
    rows = _episodes(tmp_path, proc)
    assert rows.episode_id.tolist() == ["+x_1_6000"] and rows.usable.tolist() == [True]
    assert _said(proc) == [
        f"note: {tmp_path / 'tracks.csv'}: 1 vehicle(s) of a single sample skipped (one position "
        "shows no motion and no lane change): vehicle 77"
    ]
    # every row its own vehicle: the ids are not vehicles', refused
    rows_as_ids = _vehicles().assign(id=lambda d: d.index.astype(str))
    line = _error(_run(tmp_path, rows_as_ids))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: 242 of 242 vehicles have a single sample (vehicle 0, "
        "1, 10, 100, 101, …): a track needs 2 or more to show motion; is the vehicle id the "
        "same on every row of one vehicle (not a row number)?"
    )


# ------------------------------------------------ 5: a lane width beyond a road's
def test_a_lane_width_beyond_a_road_is_refused_before_any_line_is_computed(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    proc = _run(tmp_path, table, "--lane-width", "1e308")  # the lines would overflow
    assert _error(proc) == (
        f"error: {table}: lanes 1e+308 m wide (lane_width (--lane-width) 1e+308), but a road's "
        "lanes are 2–7 m wide: lane widths are in metres"
    )
    assert "Warning" not in proc.stderr
    line = _error(_run(tmp_path, table, "--lane-width", "12"))
    assert line.endswith("lanes are 2–7 m wide: positions in feet? convert to metres (× 0.3048)")
    # one wrong y: 2.7e11 lanes of lines, refused before they are allocated
    wrong = _vehicles()
    wrong.loc[30, "y"] = 1e12
    assert _error(_run(tmp_path, wrong)) == (
        f"error: {table}: the vehicles' y spans 1.875 to 1e+12 m, 266666666667 lanes of "
        "lane_width (--lane-width) 3.75 m, more than a road's 50 (vehicle 1, data row 31: y = "
        "1e+12): y in another unit, or a wrong row?"
    )


# ----------------------------------------- 6: a folder, UTF-16, a binary lanes file
def test_a_folder_utf16_and_a_binary_lanes_file_are_said_to_be_what_they_are(tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    assert _error(_run(tmp_path, folder)) == (
        f"error: {folder} is a folder, not a file (a CSV or Parquet table of tracks): pass the "
        "file itself"
    )
    utf16 = tmp_path / "tracks16.csv"
    _vehicles().to_csv(utf16, index=False, encoding="utf-16")
    assert _error(_run(tmp_path, utf16)) == (
        f"error: {utf16} is UTF-16 text (as Excel's 'Unicode text' and Windows tools save it), "
        "not UTF-8: save it as UTF-8; expected a CSV table of tracks (columns id, t, x, y, …)"
    )
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    lanes = tmp_path / "lanes.json"
    lanes.write_bytes(b"PK\x03\x04\x14\x00\x06\x00\xb5U\x80")
    assert _error(_run(tmp_path, table, "--lanes", str(lanes))) == (
        f"error: --lanes {lanes} is a binary file, not text (byte 0xb5 at offset 8, line 1); "
        "expected a JSON lanes file: each recording's lane lines' y [m]"
    )
    lanes.write_text("[0, 3.75, 7.5]", encoding="utf-16")
    line = _error(_run(tmp_path, table, "--lanes", str(lanes)))
    assert line.startswith(f"error: --lanes {lanes} is UTF-16 text (")


# ------------------------------------------------- 7: input dropped silently
def test_an_empty_lane_marking_and_a_repeated_lanes_key_are_refused(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    proc = _run(tmp_path, table, "--lane-markings", "0,,7.5")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        "drivestyle extract-episodes: error: argument --lane-markings: '0,,7.5' has an empty "
        "field (number 2 of 3): give the numbers separated by single commas, e.g. 0,3.75,7.5"
    )
    two = _vehicles().assign(recording="dayA")
    lanes = tmp_path / "lanes.json"
    lanes.write_text('{"dayA": [0, 3.75, 7.5, 11.25], "dayA": [0, 3.5, 7, 10.5]}')
    assert _error(_run(tmp_path, two, "--lanes", str(lanes))) == (
        f"error: --lanes {lanes}: the key 'dayA' appears twice (JSON would keep the second, "
        "[0, 3.5, 7, 10.5], silently): give each recording's lines once"
    )


def test_decreasing_lane_markings_are_the_options_fault_and_a_file_is_no_sample(tmp_path):
    table = tmp_path / "tracks.csv"
    _vehicles().to_csv(table, index=False)
    assert _error(_run(tmp_path, table, "--lane-markings", "11.25,7.5,3.75,0")) == (
        "error: --lane-markings: lane lines (as given) must be 3 or more increasing numbers "
        "[m], road edges included, got [11.25, 7.5, 3.75, 0.0]"
    )
    assert _error(_run(tmp_path, table, "--format", "sample")) == (
        f"error: {table}: not a shipped sample's folder (one holding tracks.csv.gz, such as "
        "shared/data/ngsim or shared/data/cats-av-lanechange); a table of tracks is read with "
        "--format csv"
    )


# ------------------------------------ 8: a heading message quotes the file's values
def test_a_heading_of_traffic_to_minus_x_is_quoted_as_the_file_holds_it(tmp_path):
    table = _vehicles()
    table[["x", "y"]] *= -1  # every vehicle drives to −x …
    table["heading"] = 0.0  # … with the heading of +x traffic
    line = _error(_run(tmp_path, table))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: 2 of 2 vehicles' recorded headings disagree with "
        "the course of their positions; vehicle 1 (-x) has a recorded heading of 0 rad where "
        "its positions' course is 3.14 rad (100% of its samples differ by more than 0.35 rad): "
        "it points against its motion: the heading of the other driving direction?"
    )
    table["heading"] = np.pi  # the right heading: the turned frame's lane change
    rows = _episodes(tmp_path, _run(tmp_path, table))
    assert rows.episode_id.tolist() == ["-x_1_6000"] and rows.usable.tolist() == [True]


# ------------------------------------------- 9: slow traffic with positions in feet
def test_slow_traffic_in_feet_is_refused_by_its_lanes(tmp_path):
    # six vehicles in three lanes at 14 m/s (46 ft/s: within the speed bound), one changing
    # lane; the lanes given in metres
    lanes = [_lane_change() if k == 0 else np.full(T.size, (k % 3 + 0.5) * W) for k in range(6)]
    slow = pd.concat(
        [
            pd.DataFrame({"id": str(k + 1), "t": T, "x": 14.0 * T + 35.0 * k, "y": y})
            for k, y in enumerate(lanes)
        ],
        ignore_index=True,
    )
    assert _episodes(tmp_path, _run(tmp_path, slow)).usable.tolist() == [True]  # in metres
    feet = slow.assign(x=slow.x / 0.3048, y=slow.y / 0.3048)
    line = _error(proc := _run(tmp_path, feet))
    assert line == (
        f"error: {tmp_path / 'tracks.csv'}: the vehicles keep to no lane: their median y lies a "
        "median 0.30 lane widths from a lane's centre (0.5: on a line or off the road), but "
        "× 0.3048 0.00: positions in feet (× 0.3048)?"
    )
    assert _said(proc) == [line]
    # the road's lines given: the vehicles outside them, refused alone (no warning first)
    proc = _run(tmp_path, feet, "--lane-markings", "0,3.75,7.5,11.25")
    assert _error(proc).endswith("but × 0.3048 0.00: positions in feet (× 0.3048)?")
    assert len(_said(proc)) == 1
