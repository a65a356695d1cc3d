"""The generic table with several recordings, lanes files, the outside-the-road warning and
:func:`write_table`'s round trip (to the shipped NGSIM sample's episodes)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from drivestyle.recorded.episodes import extract_episodes
from drivestyle.recorded.readers import (
    load_lanes,
    outside_road,
    read_sample,
    read_table,
    write_table,
)
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

W = 3.5
T = np.round(np.arange(0, 12.0 + 1e-9, 0.1), 9)  # 10 Hz, 12 s
DATA = Path(__file__).resolve().parents[4] / "shared" / "data"


def _move(t_c: float, y_from: float, y_to: float, duration: float = 4.0) -> np.ndarray:
    """A smooth (cosine) lateral move centred on t_c, on :data:`T`."""
    s = np.clip((T - t_c) / duration + 0.5, 0.0, 1.0)
    return y_from + (y_to - y_from) * (1 - np.cos(np.pi * s)) / 2


def _vehicle(recording: str | None, vid: object, x: np.ndarray, y: np.ndarray) -> pd.DataFrame:
    df = pd.DataFrame({"id": vid, "t": T, "x": x, "y": y, "v": 20.0})
    if recording is not None:
        df.insert(0, "recording", recording)
    return df


def _two_recordings() -> pd.DataFrame:
    """Recordings 'r1' and 'r2' with the same ids and clocks (both start at t = 0).

    r1: vehicle 1 changes from lane 0 to lane 1 of lines 0, W, 2W (crossing at 6 s),
    vehicle 2 keeps lane 0. r2 lies 10 m to the left (lines 10, 10 + W, 10 + 2W): its
    vehicle 1 changes from lane 1 to lane 0 (at 5 s), vehicle 2 keeps lane 1, and vehicle 3
    drives to −x at y = −0.5W, whose own road (lines −2W, −W, 0) turns into 0, W, 2W.
    """
    return pd.concat(
        [
            _vehicle("r1", 1, 20 * T, _move(6.0, 0.5 * W, 1.5 * W)),
            _vehicle("r1", 2, 30 + 20 * T, np.full_like(T, 0.5 * W)),
            _vehicle("r2", 1, 20 * T, _move(5.0, 10 + 1.5 * W, 10 + 0.5 * W)),
            _vehicle("r2", 2, -10 + 20 * T, np.full_like(T, 10 + 1.5 * W)),
            _vehicle("r2", 3, 900 - 20 * T, np.full_like(T, -0.5 * W)),
        ],
        ignore_index=True,
    )


R1 = [0.0, W, 2 * W]
R2 = {"+x": [10.0, 10 + W, 10 + 2 * W], "-x": [-2 * W, -W, 0.0]}  # each road of r2, in the
# file's y, road edges included (the median between them is no lane)


def _write(tmp_path: Path, df: pd.DataFrame, lanes: object = None) -> tuple[Path, Path]:
    table, lanes_file = tmp_path / "tracks.csv", tmp_path / "lanes.json"
    df.to_csv(table, index=False)
    lanes_file.write_text(json.dumps(lanes if lanes is not None else {"r1": R1, "r2": R2}))
    return table, lanes_file


def test_recordings_whose_ids_restart_read_into_their_own_carriageways(tmp_path, capsys):
    table, lanes = _write(tmp_path, _two_recordings())
    rec = read_table(table, lanes=lanes)
    # r1 is driven to +x only: named by the recording (as read_sample names them); r2 has
    # traffic both ways: one carriageway per direction
    assert [c.name for c in rec.carriageways] == ["r1", "r2+x", "r2-x"]
    r1, r2, back = rec.carriageways
    assert r1.markings == tuple(R1)
    assert r2.markings == (10.0, 10 + W, 10 + 2 * W)
    assert back.markings == (0.0, W, 2 * W)  # turned by 180°
    assert [t.vehicle_id for t in r1.tracks] == ["1", "2"] == [t.vehicle_id for t in r2.tracks]
    np.testing.assert_allclose(back.tracks[0].x, -(900 - 20 * T))
    np.testing.assert_allclose(back.tracks[0].y, 0.5 * W)
    assert rec.meta["recordings"] == ["r1", "r2"] and rec.meta["outside_road"] == []
    assert capsys.readouterr().err == ""
    episodes = extract_episodes(rec)
    assert [(e.episode_id, e.usable, e.direction) for e in episodes] == [
        ("r1_1_6000", True, "left"),
        ("r2+x_1_5000", True, "right"),
    ]
    assert dict(episodes[0].interacting) == {"own_leader": "2"}  # r1's 2, not r2's


def test_the_same_table_without_lanes_files_keeps_ids_as_text_and_lanes_per_recording(tmp_path):
    df = _two_recordings()
    df["id"] = df["id"].map({1: "007", 2: "7", 3: "3"})  # '007' and '7' are two vehicles
    table, _ = _write(tmp_path, df)
    rec = read_table(table, lane_width=W)
    r1, r2, _ = rec.carriageways
    assert [t.vehicle_id for t in r1.tracks] == ["007", "7"]
    # lines at multiples of W over each recording's own y
    assert r1.markings == (0.0, W, 2 * W)
    assert r2.markings[0] == pytest.approx(-W) and r2.markings[-1] == pytest.approx(5 * W)


def test_a_lanes_list_applies_to_every_recording(tmp_path):
    df = _two_recordings().query("recording == 'r1'")
    df = pd.concat([df, df.assign(recording="r3")], ignore_index=True)
    table, lanes = _write(tmp_path, df, lanes=R1)
    assert load_lanes(lanes) == R1
    rec = read_table(table, lanes=lanes)
    assert [(c.name, c.markings) for c in rec.carriageways] == [
        ("r1", tuple(R1)),
        ("r3", tuple(R1)),
    ]
    assert [e.episode_id for e in extract_episodes(rec)] == ["r1_1_6000", "r3_1_6000"]


@pytest.mark.parametrize(
    ("lanes", "match"),
    [
        ({"r1": R1}, r"lanes\.json: no lane lines for recording 'r2' \(1 of the table's 2"),
        ({"r1": R1, "r2": R2, "r9": R1},
         r"lanes\.json: recording 'r9' is not in the table \(its recordings: 'r1', 'r2'\)"),
        ({"r1": R1, "r2": {"+x": [10.0, 13.5, 13.5, 17.0], "-x": R1}},
         r"lanes\.json: lane lines \(lanes, recording 'r2', \+x\) must be 3 or more "
         r"increasing numbers \[m\], road edges included, got \[10.0, 13.5, 13.5, 17.0\]"),
        ({"r1": [0, "3.5", 7], "r2": R2}, r"lanes\.json: recording 'r1': \"3.5\" is not a number"),
        ({"r1": 3.5, "r2": R2}, r"lanes\.json: recording 'r1': expected a list of the lane"),
        ({"r1": R1, "r2": {"x+": R1}}, r"lanes\.json: recording 'r2': an object of lane lines "
         r"has the keys '\+x' and/or '-x'"),
        ({"r1": R1, "r2": {"+x": R2["+x"]}},
         r"lanes\.json: recording 'r2' has vehicles driving to -x \(vehicle 3, …\) but lane "
         r"lines only for \+x"),
        ({"r1": R1, "r2": [0, W, 2 * W, 17, 17 + W]}, r"lanes\.json: lanes 10 m wide \(lanes, "),
        ({"r1": [0, 12, 24], "r2": R2}, r"lanes\.json: lanes 12 m wide \(lanes, recording 'r1'\)"),
        ("r1", r"lanes\.json: expected an object mapping each recording to its lane lines"),
    ],
)  # fmt: skip
def test_bad_lanes_files_are_one_line_naming_file_recording_and_value(tmp_path, lanes, match):
    table, lanes_file = _write(tmp_path, _two_recordings(), lanes=lanes)
    with pytest.raises(TrackError, match=match) as info:
        read_table(table, lanes=lanes_file)
    assert "\n" not in str(info.value)


def test_lanes_contradicting_options_and_tables_are_refused(tmp_path):
    table, lanes = _write(tmp_path, _two_recordings())
    with pytest.raises(TrackError, match=r"lanes\.json: lanes and lane_width / lane_markings"):
        read_table(table, lanes=lanes, lane_width=W)
    with pytest.raises(TrackError, match=r"tracks\.csv: lane_width \(--lane-width\) and "):
        read_table(table, lane_width=W, lane_markings=R1)
    (tmp_path / "bad.json").write_text("{'r1': [0, 3.5]}")
    with pytest.raises(TrackError, match=r"bad\.json is not valid JSON"):
        read_table(table, lanes=tmp_path / "bad.json")
    one = tmp_path / "one.csv"
    _two_recordings().query("id != 3").drop(columns="recording").to_csv(one, index=False)
    with pytest.raises(TrackError, match=r"lanes\.json: lane lines per recording \(lanes\), but"):
        read_table(one, lanes=lanes)
    # a restarting id in a table without a recording column: the rows collide
    with pytest.raises(TrackError, match=r"one\.csv: vehicle 1, frame 0: two rows at t = 0 s"):
        read_table(one, lane_width=W)
    df = _two_recordings()
    df.loc[3, "recording"] = np.nan
    df.to_csv(table, index=False)
    with pytest.raises(TrackError, match=r"tracks\.csv: vehicle 1, data row 4: no recording"):
        read_table(table, lanes=lanes)
    df = pd.concat([_two_recordings(), _two_recordings().iloc[[130]]])
    df.to_csv(table, index=False)
    with pytest.raises(TrackError, match=r"recording r1, vehicle 2, frame 9: two rows at t = 0.9"):
        read_table(table, lanes=lanes)


def test_lines_without_the_road_edges_warn_of_the_vehicles_outside(tmp_path, capsys):
    # a three-lane road (lines 0 … 3W); the user gives only the lines between lanes and
    # one edge, so lane 2's vehicle and the change into it are off the road
    df = pd.concat(
        [
            _vehicle(None, "a", 20 * T, _move(6.0, 0.5 * W, 1.5 * W)),
            _vehicle(None, "b", 20 * T + 50, _move(6.0, 1.5 * W, 2.5 * W)),
            _vehicle(None, "c", 20 * T - 50, np.full_like(T, 2.5 * W)),
        ],
        ignore_index=True,
    )
    table = tmp_path / "tracks.csv"
    df.to_csv(table, index=False)
    full = read_table(table, lane_markings=[0, W, 2 * W, 3 * W])
    assert capsys.readouterr().err == "" and full.meta["outside_road"] == []
    assert len(extract_episodes(full)) == 2
    part = read_table(table, lane_markings=[0, W, 2 * W])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("warning: lane_markings (--lane-markings): ")
    # c: all 121 samples 0.5 W outside; b: from the moment it crosses 2W (6 s) on
    assert "2 vehicle(s) drive outside the outermost lane lines (the road edges)" in err
    assert "vehicle c (+x): 121 sample(s), up to 1.75 m out; vehicle b (+x): 60 sample(s)" in err
    assert [o["vehicle_id"] for o in part.meta["outside_road"]] == ["b", "c"]
    assert [e.vehicle_id for e in extract_episodes(part)] == ["a"]  # b's change is lost


def test_outside_road_in_closed_form():
    d = outside_road(np.array([-1.0, 0.0, 3.0, 7.0, 7.5]), [0.0, 3.5, 7.0])
    np.testing.assert_allclose(d, [1.0, 0.0, 0.0, 0.0, 0.5])


# ------------------------------------------------------------------------------ write_table
def test_write_table_round_trip_keeps_carriageways_tracks_and_lines(tmp_path, capsys):
    df = _two_recordings()
    # headings along each vehicle's motion (vehicle 3 of r2 drives to −x: heading π)
    df["heading"] = np.where((df.recording == "r2") & (df.id == 3), np.pi, 0.0)
    table, _ = _write(tmp_path, df)
    rec = read_table(table, lane_markings={"r1": R1, "r2": R2})
    csv_path, lanes_path = write_table(rec, tmp_path / "out.csv", tmp_path / "out.json")
    assert set(json.loads(lanes_path.read_text())) == {"r1", "r2+x", "r2-x"}
    assert list(pd.read_csv(csv_path).columns) == [
        "recording", "id", "t", "x", "y", "v", "heading", "length", "width", "frame",
    ]  # fmt: skip
    back = read_table(csv_path, lanes=lanes_path)
    assert capsys.readouterr().err == ""
    # the turned carriageway is written in its road frame: all to +x, so it keeps its name
    assert [(c.name, c.markings) for c in back.carriageways] == [
        (c.name, c.markings) for c in rec.carriageways
    ]
    for a, b in zip(rec.carriageways, back.carriageways, strict=True):
        for ta, tb in zip(a.tracks, b.tracks, strict=True):
            assert ta.vehicle_id == tb.vehicle_id
            for field in ("t", "x", "y", "v", "heading", "frames"):
                np.testing.assert_array_equal(getattr(ta, field), getattr(tb, field))


def test_write_table_refuses_what_it_cannot_write_back(tmp_path):
    def track(vid, x, **kw):
        return Track(vid, T[:3], np.asarray(x, float), np.full(3, 1.0), np.arange(3), **kw)

    lines = (0.0, W, 2 * W)
    backwards = Recording("r", (Carriageway("c", lines, (track("1", [5, 4, 3]),)),))
    with pytest.raises(ValueError, match=r"'c', vehicle 1 ends behind its start"):
        write_table(backwards, tmp_path / "a.csv", tmp_path / "a.json")
    mixed = (track("1", [0, 1, 2], v=np.ones(3)), track("2", [0, 1, 2]))
    with pytest.raises(ValueError, match=r"'c', vehicle 2 has no v while others have one"):
        write_table(Recording("r", (Carriageway("c", lines, mixed),)), tmp_path / "b.csv", "b")
    # two carriageways of one name are no recording at all (every reader's rule)
    with pytest.raises(ValueError, match=r"r: two carriageways named 'c': a carriageway's name"):
        Recording("r", (Carriageway("c", lines, mixed[1:]),) * 2)


@pytest.mark.skipif(not (DATA / "ngsim").is_dir(), reason="../shared/data not beside the checkout")
def test_the_ngsim_sample_as_one_generic_csv_gives_read_samples_episodes(tmp_path):
    sample = read_sample(DATA / "ngsim")
    csv_path, lanes_path = write_table(sample, tmp_path / "ngsim.csv", tmp_path / "lanes.json")
    table = pd.read_csv(csv_path)
    assert list(table.columns) == [
        "recording", "id", "t", "x", "y", "v", "length", "width", "lane", "frame",
    ]  # fmt: skip
    assert table.recording.nunique() == 5 and len(table) == 42_657
    lanes = json.loads(lanes_path.read_text())
    assert lanes == {c.name: list(c.markings) for c in sample.carriageways}
    rec = read_table(csv_path, lanes=lanes_path)
    # its ramps and auxiliary lane lie outside the main lanes' lines: warned of, kept
    assert len(rec.meta["outside_road"]) == 11
    assert [c.name for c in rec.carriageways] == [c.name for c in sample.carriageways]
    want, got = extract_episodes(sample), extract_episodes(rec)
    assert len(want) == 19 and sum(e.usable for e in want) == 14
    assert [(e.episode_id, e.t_cross, e.usable, e.interacting) for e in got] == [
        (e.episode_id, e.t_cross, e.usable, e.interacting) for e in want
    ]
    for a, b in zip(want, got, strict=True):
        assert (a.demo is None) == (b.demo is None), a.episode_id
        if a.demo is not None:
            for field in ("t", "ev", "tv", "u"):
                np.testing.assert_allclose(
                    getattr(b.demo, field), getattr(a.demo, field), rtol=0, atol=1e-9
                )
