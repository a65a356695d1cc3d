"""The published-format readers (raw NGSIM, levelX/highD, INTERACTION) on files written here.

No licensed data is in the repository: every test writes a few synthetic vehicles in the
published layout and checks the road frame in closed form (x along travel, y to the left,
lane 0 rightmost, centres, SI units).
"""

import math

import numpy as np
import pandas as pd
import pytest

from drivestyle.recorded.readers import (
    NGSIM_COLUMNS,
    READERS,
    read_interaction,
    read_levelx,
    read_ngsim,
)
from drivestyle.recorded.tracks import TrackError

FT = 0.3048
T0_MS = 1_118_846_980_000  # an NGSIM-like epoch time stamp [ms]


def _smoothstep(s):
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s), 6 * s * (1 - s)


def _track(pick, vid):
    [track] = [t for t in pick.tracks if t.vehicle_id == vid]
    return track


# ------------------------------------------------------------------------------------ NGSIM
LANE_X_FT = {1: 6.0, 2: 18.0, 3: 30.0, 4: 42.0, 5: 54.0, 6: 66.0}
"""Lane centres' Local_X [ft]: 12 ft lanes from the left road edge."""


def _ngsim_vehicle(
    vid, frames, local_x, lane_id, y0=100.0, vel=50.0, length=15.0, width=6.0, t0_ms=T0_MS
):
    frames = np.asarray(frames)
    n = frames.size
    local_y = y0 + vel * 0.1 * (frames - frames[0])
    return pd.DataFrame(
        {
            "Vehicle_ID": vid,
            "Frame_ID": frames,
            "Total_Frames": n,
            "Global_Time": t0_ms + 100 * frames,
            "Local_X": np.broadcast_to(local_x, n),
            "Local_Y": local_y,
            "Global_X": 6_451_000.0 + local_y,
            "Global_Y": 1_873_000.0 + np.broadcast_to(local_x, n),
            "v_Length": length,
            "v_Width": width,
            "v_Class": 2,
            "v_Vel": vel,
            "v_Acc": 0.0,
            "Lane_ID": np.broadcast_to(lane_id, n),
            "Preceding": 0,
            "Following": 0,
            "Space_Headway": 0.0,
            "Time_Headway": 0.0,
        }
    )


def _lane_change(from_lane, to_lane, n=20, cross=(8, 12)):
    """Local_X [ft] and Lane_ID of a lane change: at the centre, a quick cross, the centre."""
    a, b = LANE_X_FT[from_lane], LANE_X_FT[to_lane]
    s, _ = _smoothstep((np.arange(n) - cross[0] + 1) / (cross[1] - cross[0] + 1))
    x = a + (b - a) * s
    lane = np.where(np.abs(x - a) < np.abs(x - b), from_lane, to_lane)
    return x, lane


def _ngsim_table():
    frames = np.arange(10, 30)
    left_x, left_lane = _lane_change(3, 2)  # toward lane 1: the driver's left
    right_x, right_lane = _lane_change(4, 5)
    return pd.concat(
        [
            _ngsim_vehicle(1, frames, LANE_X_FT[2], 2),
            _ngsim_vehicle(2, frames, left_x, left_lane, y0=200.0),
            _ngsim_vehicle(3, frames, right_x, right_lane, y0=300.0),
            _ngsim_vehicle(4, frames, LANE_X_FT[1], 1, y0=150.0),
            _ngsim_vehicle(5, frames, LANE_X_FT[5], 5, y0=250.0),
            _ngsim_vehicle(6, frames + 5, LANE_X_FT[6], 6, y0=50.0, length=40.0, width=8.5),
        ],
        ignore_index=True,
    )


def _write_classic(df, path):
    """The classic text layout: the 18 columns, whitespace separated, no header."""
    df = df[list(NGSIM_COLUMNS)]
    path.write_text(
        "\n".join("   ".join(f"{v:.15g}" for v in row) for row in df.to_numpy(float)) + "\n"
    )
    return path


def test_ngsim_classic_text_file_feet_to_metres_and_front_to_centre(tmp_path):
    rec = read_ngsim(_write_classic(_ngsim_table(), tmp_path / "trajectories-0750am-0805am.txt"))
    [cw] = rec.carriageways
    assert rec.meta["format"] == "ngsim" and rec.meta["rate_hz"] == 10.0
    # 12 ft lanes from the left edge, in increasing y = −Local_X: lane 0 is Lane_ID 5
    np.testing.assert_allclose(cw.markings, -FT * np.array([60, 48, 36, 24, 12, 0]), atol=1e-9)
    one = _track(cw, "1")
    np.testing.assert_allclose(one.t, 0.1 * np.arange(20))  # Global_Time from the first row
    np.testing.assert_array_equal(one.frames, np.arange(10, 30))
    # front centre 100 ft + 5 ft per frame → centre: half of the 15 ft length behind
    np.testing.assert_allclose(one.x, FT * (100 + 5 * np.arange(20)) - FT * 15 / 2)
    np.testing.assert_allclose(one.y, -FT * 18)
    np.testing.assert_allclose(one.v, 50 * FT)
    assert one.length == pytest.approx(15 * FT) and one.width == pytest.approx(6 * FT)
    np.testing.assert_array_equal(one.lane, 3)  # Lane_ID 2 of 5 → 3 (0 is rightmost)
    assert np.all(cw.lane_of(one.y) == 3)
    assert _track(cw, "5").lane[0] == 0 and _track(cw, "4").lane[0] == 4
    aux = _track(cw, "6")  # the auxiliary lane, right of the main lanes
    assert np.all(aux.lane == -1) and np.all(cw.lane_of(aux.y) == -1)
    assert aux.t[0] == pytest.approx(0.5)  # 5 frames after the file's first time


def test_ngsim_lane_changes_left_raise_y_and_right_lower_it(tmp_path):
    rec = read_ngsim(_write_classic(_ngsim_table(), tmp_path / "t.txt"))
    [cw] = rec.carriageways
    left, right = _track(cw, "2"), _track(cw, "3")
    assert np.all(np.diff(left.y) >= 0) and left.y[-1] - left.y[0] == pytest.approx(12 * FT)
    assert (left.lane[0], left.lane[-1]) == (2, 3)
    assert np.all(np.diff(right.y) <= 0) and right.y[-1] - right.y[0] == pytest.approx(-12 * FT)
    assert (right.lane[0], right.lane[-1]) == (1, 0)
    # the recorded lane agrees with the lane lines wherever the vehicle is clear of a line
    for tr in (left, right):
        clear = np.min(np.abs(tr.y[:, None] - np.asarray(cw.markings)[None]), axis=1) > 0.3
        np.testing.assert_array_equal(cw.lane_of(tr.y)[clear], tr.lane[clear])


def test_ngsim_csv_with_location_keeps_the_freeways_and_drops_exact_duplicates(tmp_path):
    us101 = _ngsim_table().assign(Location="us-101")
    i80 = _ngsim_table().assign(Location="i-80", Global_Time=lambda d: d.Global_Time + 5000)
    arterial = _ngsim_table().assign(Location="lankershim")
    df = pd.concat([us101, i80, arterial, us101.iloc[:3]], ignore_index=True)
    df = df.sample(frac=1.0, random_state=0)  # the CSV's rows come in any order
    df = df.rename(columns={"v_Length": "v_length", "Local_X": "local_x"})  # any case
    path = tmp_path / "Next_Generation_Simulation__NGSIM__Vehicle_Trajectories.csv"
    df.to_csv(path, index=False)
    rec = READERS["ngsim"](path)
    assert [c.name for c in rec.carriageways] == ["i-80", "us-101"]
    assert rec.meta["rows_dropped_not_freeway"] == {"lankershim": len(arterial)}
    assert rec.meta["duplicate_rows_dropped"] == 3
    for cw in rec.carriageways:
        assert len(cw.tracks) == 6
        np.testing.assert_allclose(_track(cw, "1").y, -FT * 18)
    assert rec.meta["global_time_origin_ms"]["i-80"] == T0_MS + 1000 + 5000


def test_ngsim_reused_vehicle_id_after_a_gap_is_another_track(tmp_path):
    df = _ngsim_table()
    # the next 15-minute period: frames start again, the id is another vehicle's
    later = _ngsim_vehicle(1, np.arange(5, 15), LANE_X_FT[3], 3, t0_ms=T0_MS + 900_000)
    path = _write_classic(pd.concat([later, df], ignore_index=True), tmp_path / "t.txt")
    [cw] = read_ngsim(path).carriageways
    first, second = _track(cw, "1"), _track(cw, "1@5")
    assert first.n == 20 and second.n == 10
    assert second.t[0] == pytest.approx(900.0 - 0.5) and np.all(second.lane == 2)


def test_ngsim_nominal_markings_are_12_ft_from_the_left_edge(tmp_path):
    df = _ngsim_table()
    df["Local_X"] += 1.0  # everyone a foot right of the lane centre
    path = _write_classic(df, tmp_path / "t.txt")
    nominal = read_ngsim(path, markings="nominal").carriageways[0].markings
    np.testing.assert_allclose(nominal, -FT * np.array([60, 48, 36, 24, 12, 0]), atol=1e-9)
    data = read_ngsim(path).carriageways[0].markings
    np.testing.assert_allclose(data, -FT * (np.array([60, 48, 36, 24, 12, 0]) + 1), atol=1e-9)


def test_ngsim_file_in_metres_is_refused_with_the_conversion(tmp_path):
    df = _ngsim_table()
    for c in ("Local_X", "Local_Y", "v_Length", "v_Width", "v_Vel"):
        df[c] *= FT
    path = _write_classic(df, tmp_path / "metres.txt")
    with pytest.raises(TrackError, match=r"metres.*3\.2808") as err:
        read_ngsim(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def _one_line(err, *parts):
    msg = str(err.value)
    assert "\n" not in msg, msg
    for p in parts:
        assert p in msg, (p, msg)


def test_ngsim_bad_data_names_file_vehicle_and_frame(tmp_path):
    df = _ngsim_table()
    path = tmp_path / "bad.csv"
    df.drop(columns="Local_Y").to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_ngsim(path)
    _one_line(err, str(path), "'Local_Y'")

    nan = df.copy()
    nan.loc[(nan.Vehicle_ID == 2) & (nan.Frame_ID == 15), "Local_X"] = np.nan
    nan.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_ngsim(path)
    _one_line(err, str(path), "vehicle 2", "frame 15", "Local_X")

    repeated = df.copy()
    row = (repeated.Vehicle_ID == 3) & (repeated.Frame_ID == 13)
    repeated = pd.concat([repeated, repeated[row].assign(Local_Y=1.0)], ignore_index=True)
    repeated.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_ngsim(path)
    _one_line(err, str(path), "vehicle 3", "frame 13", "twice")

    backwards = df.copy()
    backwards.loc[(backwards.Vehicle_ID == 4) & (backwards.Frame_ID == 20), "Frame_ID"] = 12
    backwards.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_ngsim(path)
    _one_line(err, str(path), "vehicle 4", "frame 12")


# ----------------------------------------------------------------------------------- levelX
UPPER = (13.0, 16.5, 20.0, 23.5)
"""Image y of the upper (−x) carriageway's lane lines [m]: its right edge is at the top."""
LOWER = (27.0, 30.5, 34.0, 37.5)
"""Image y of the lower (+x) carriageway's lane lines [m]: its right edge is at the bottom."""
RATE = 25.0


def _levelx_vehicle(vid, x0, y_from, y_to, vx, n=50, w=4.5, h=1.8):
    """Rows of one vehicle: box corner from (x0, y_from) at speed vx, moving to y_to."""
    frame = np.arange(1, n + 1) + 10 * vid
    tau = (frame - frame[0]) / RATE
    s, ds = _smoothstep((tau - 0.4) / 1.2)
    return pd.DataFrame(
        {
            "frame": frame,
            "id": vid,
            "x": x0 + vx * tau,
            "y": y_from + (y_to - y_from) * s,
            "width": w,
            "height": h,
            "xVelocity": vx,
            "yVelocity": (y_to - y_from) * ds / 1.2,
            "xAcceleration": 0.0,
            "yAcceleration": 0.0,
            "laneId": 0,
        }
    )


def _write_levelx(tmp_path, vehicles, directions, nn="01"):
    pd.concat(vehicles, ignore_index=True).to_csv(tmp_path / f"{nn}_tracks.csv", index=False)
    pd.DataFrame(
        {"id": list(directions), "drivingDirection": list(directions.values()), "class": "Car"}
    ).to_csv(tmp_path / f"{nn}_tracksMeta.csv", index=False)
    pd.DataFrame(
        {
            "id": [int(nn)],
            "frameRate": [RATE],
            "upperLaneMarkings": [";".join(map(str, UPPER))],
            "lowerLaneMarkings": [";".join(map(str, LOWER))],
        }
    ).to_csv(tmp_path / f"{nn}_recordingMeta.csv", index=False)
    return tmp_path / f"{nn}_tracks.csv"


def _levelx_files(tmp_path):
    # box corners y = lane centre − h/2; upper centres 14.75, 18.25, 21.75; lower 28.75, …
    vehicles = [
        _levelx_vehicle(1, 100.0, 20.0, 20.0, -30.0),  # upper, straight: the closed-form one
        _levelx_vehicle(2, 300.0, 17.35, 20.85, -28.0),  # upper, image +y: its left
        _levelx_vehicle(3, 320.0, 17.35, 13.85, -28.0),  # upper, image −y: its right
        _levelx_vehicle(4, 10.0, 31.35, 27.85, 25.0),  # lower, image −y: its left
        _levelx_vehicle(5, 30.0, 31.35, 34.85, 25.0),  # lower, image +y: its right
    ]
    return _write_levelx(tmp_path, vehicles, {1: 1, 2: 1, 3: 1, 4: 2, 5: 2})


def test_levelx_upper_vehicle_box_to_centre_in_its_travel_frame(tmp_path):
    rec = read_levelx(_levelx_files(tmp_path))
    upper, lower = rec.carriageways
    assert (upper.name, lower.name) == ("upper", "lower")
    assert rec.meta["format"] == "highd" and rec.meta["rate_hz"] == RATE
    one = _track(upper, "1")
    # box (x = 100, y = 20, w = 4.5, h = 1.8) driving to −x: centre (102.25, 20.9) in the
    # image; along its travel x = −102.25 and growing, its left (image +y) is +y
    assert one.x[0] == pytest.approx(-102.25) and one.y[0] == pytest.approx(20.9)
    np.testing.assert_allclose(np.diff(one.x), 30.0 / RATE)
    np.testing.assert_allclose(one.v, 30.0)
    np.testing.assert_allclose(one.heading, 0.0, atol=1e-12)
    np.testing.assert_allclose(one.t, (np.arange(1, 51) + 10) / RATE)
    assert (one.length, one.width) == (4.5, 1.8)
    assert upper.markings == UPPER and upper.lane_of(one.y[0]) == 2  # next to the median
    assert lower.markings == tuple(-m for m in reversed(LOWER))


@pytest.mark.parametrize(
    ("side", "vid", "lanes", "left"),
    [
        ("upper", "2", (1, 2), True),
        ("upper", "3", (1, 0), False),
        ("lower", "4", (1, 2), True),
        ("lower", "5", (1, 0), False),
    ],
)
def test_levelx_lane_change_to_the_drivers_left_raises_y(tmp_path, side, vid, lanes, left):
    rec = read_levelx(_levelx_files(tmp_path))
    cw = {c.name: c for c in rec.carriageways}[side]
    tr = _track(cw, vid)
    sign = 1.0 if left else -1.0
    assert sign * (tr.y[-1] - tr.y[0]) == pytest.approx(3.5)
    assert np.all(sign * np.diff(tr.y) >= -1e-12) and np.all(np.diff(tr.x) > 0)
    assert (cw.lane_of(tr.y[0]), cw.lane_of(tr.y[-1])) == lanes
    mid = tr.n // 2  # mid-change: heading toward the new lane
    assert sign * tr.heading[mid] > 0.01
    # the velocity's heading is the positions' direction of motion (same frame)
    motion = np.arctan2(np.gradient(tr.y), np.gradient(tr.x))
    np.testing.assert_allclose(tr.heading, motion, atol=1e-2)
    speed = 28.0 if side == "upper" else 25.0
    assert tr.v[0] == pytest.approx(speed) and np.all(tr.v >= speed - 1e-9)


def test_levelx_bad_files_name_file_vehicle_and_frame(tmp_path):
    path = _levelx_files(tmp_path)
    tracks = pd.read_csv(path)
    (tmp_path / "01_tracksMeta.csv").rename(tmp_path / "keep.csv")
    with pytest.raises(FileNotFoundError, match=r"01_tracksMeta\.csv"):
        read_levelx(path)
    (tmp_path / "keep.csv").rename(tmp_path / "01_tracksMeta.csv")

    tracks.drop(columns="yVelocity").to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_levelx(path)
    _one_line(err, str(path), "'yVelocity'")

    nan = tracks.copy()
    nan.loc[(nan.id == 4) & (nan.frame == 45), "x"] = np.nan
    nan.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_levelx(path)
    _one_line(err, str(path), "vehicle 4", "frame 45", "x is nan")

    repeated = pd.concat([tracks, tracks[(tracks.id == 2) & (tracks.frame == 40)]])
    repeated.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_levelx(path)
    _one_line(err, str(path), "vehicle 2", "frame 40", "twice")

    wrong_way = tracks.copy()
    wrong_way.loc[wrong_way.id == 5, "xVelocity"] *= -1
    wrong_way.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_levelx(path)
    _one_line(err, str(path), "vehicle 5", "frame 51", "drivingDirection 2")

    exid = tracks.rename(columns={"id": "trackId", "x": "xCenter"})
    exid.to_csv(path, index=False)
    with pytest.raises(TrackError, match="highD layout"):
        read_levelx(path)


# ------------------------------------------------------------------------------ INTERACTION
def _interaction_vehicle(case, track, p0, velocity, lateral, n=30, agent="car", psi=None):
    """Rows of one agent at p0 + velocity·t + lateral·s(t) (map frame, 10 Hz)."""
    frame = np.arange(1, n + 1)
    t = (frame - 1) * 0.1
    s, ds = _smoothstep((t - 0.8) / 1.2)
    pos = np.asarray(p0) + np.outer(t, velocity) + np.outer(s, lateral)
    vel = np.asarray(velocity) + np.outer(ds / 1.2, lateral)
    return pd.DataFrame(
        {
            "case_id": float(case),
            "track_id": track,
            "frame_id": frame,
            "timestamp_ms": 100 * frame,
            "agent_type": agent,
            "x": pos[:, 0],
            "y": pos[:, 1],
            "vx": vel[:, 0],
            "vy": vel[:, 1],
            "psi_rad": np.arctan2(vel[:, 1], vel[:, 0]) if psi is None else psi,
            "length": 4.8,
            "width": 1.9,
        }
    )


def test_interaction_northbound_road_left_change_raises_y(tmp_path):
    # a road driven to map +y; lane lines at map x = 10, 13.5, 17, 20.5; a driver's left
    # is map −x, so a left change goes from x = 15.25 to 11.75
    rows = [
        _interaction_vehicle(1, 1, (15.25, 900.0), (0.0, 20.0), (0.0, 0.0)),
        _interaction_vehicle(1, 2, (15.25, 950.0), (0.0, 20.0), (-3.5, 0.0)),
        _interaction_vehicle(1, 3, (15.25, 1000.0), (0.0, 20.0), (3.5, 0.0)),
        _interaction_vehicle(1, 4, (0.0, 980.0), (0.0, 1.3), (0.0, 0.0), agent="pedestrian"),
        _interaction_vehicle(1, 5, (30.0, 1200.0), (0.0, -20.0), (0.0, 0.0)),  # other way
        _interaction_vehicle(2, 1, (18.75, 700.0), (0.0, 15.0), (0.0, 0.0), agent="truck"),
    ]
    path = tmp_path / "vehicle_tracks_000.csv"
    pd.concat(rows, ignore_index=True).to_csv(path, index=False)
    rec = READERS["interaction"](path, [10.0, 13.5, 17.0, 20.5], direction="y+")
    assert [c.name for c in rec.carriageways] == ["case 1", "case 2"]
    assert rec.meta["agents_dropped"] == {"pedestrian": 30}
    assert rec.meta["tracks_against_direction_dropped"] == ["1:5"]
    case1, case2 = rec.carriageways
    np.testing.assert_allclose(case1.markings, [-20.5, -17.0, -13.5, -10.0])
    straight = _track(case1, "1:1")
    np.testing.assert_allclose(straight.x, 900.0 + 2.0 * np.arange(30))  # x = map y
    np.testing.assert_allclose(straight.y, -15.25)  # y = −map x
    np.testing.assert_allclose(straight.heading, 0.0, atol=1e-12)  # psi π/2 − θ π/2
    np.testing.assert_allclose(straight.v, 20.0)
    np.testing.assert_allclose(straight.t, 0.1 * np.arange(1, 31))
    assert case1.lane_of(straight.y[0]) == 1
    left, right = _track(case1, "1:2"), _track(case1, "1:3")
    assert left.y[-1] - left.y[0] == pytest.approx(3.5) and left.heading[15] > 0.01
    assert (case1.lane_of(left.y[0]), case1.lane_of(left.y[-1])) == (1, 2)
    assert right.y[-1] - right.y[0] == pytest.approx(-3.5) and right.heading[15] < -0.01
    assert (case1.lane_of(right.y[0]), case1.lane_of(right.y[-1])) == (1, 0)
    assert [t.vehicle_id for t in case2.tracks] == ["2:1"] and case2.lane_of(-18.75) == 0


def test_interaction_road_at_an_angle_with_lines_given_as_points(tmp_path):
    theta = math.radians(30.0)
    u, n = (
        np.array([math.cos(theta), math.sin(theta)]),
        np.array([-math.sin(theta), math.cos(theta)]),
    )
    origin = np.array([1000.0, 500.0])
    lines = [tuple(origin + d * n) for d in (-3.6, 0.0, 3.6, 7.2)]
    start = origin + 1.8 * n + 50.0 * u
    rows = _interaction_vehicle(7, 3, start, 22.0 * u, 3.6 * n)  # a left change
    path = tmp_path / "vehicle_tracks_007.csv"
    rows.to_csv(path, index=False)
    [cw] = read_interaction(path, lines, direction=theta).carriageways
    off = float(origin @ n)
    np.testing.assert_allclose(cw.markings, off + np.array([-3.6, 0.0, 3.6, 7.2]))
    tr = cw.tracks[0]
    assert tr.vehicle_id == "7:3"
    assert tr.x[0] == pytest.approx(float(origin @ u) + 50.0)
    assert tr.y[0] == pytest.approx(off + 1.8) and tr.y[-1] == pytest.approx(off + 5.4)
    assert (cw.lane_of(tr.y[0]), cw.lane_of(tr.y[-1])) == (1, 2)
    np.testing.assert_allclose(np.diff(tr.x), 2.2)
    assert tr.heading[0] == pytest.approx(0.0, abs=1e-12) and tr.heading[15] > 0.01


def test_interaction_bad_inputs(tmp_path):
    rows = _interaction_vehicle(3, 8, (0.0, 2.0), (20.0, 0.0), (0.0, 0.0))
    path = tmp_path / "vehicle_tracks_003.csv"
    nan = rows.copy()
    nan.loc[nan.frame_id == 12, "psi_rad"] = np.nan
    nan.to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_interaction(path, [0.0, 3.5, 7.0], direction="x+")
    _one_line(err, str(path), "vehicle 3:8", "frame 12", "psi_rad")

    pd.concat([rows, rows.iloc[[5]]]).to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_interaction(path, [0.0, 3.5, 7.0], direction="x+")
    _one_line(err, str(path), "vehicle 3:8", "frame 6", "twice")

    rows.drop(columns="vy").to_csv(path, index=False)
    with pytest.raises(TrackError) as err:
        read_interaction(path, [0.0, 3.5, 7.0], direction="x+")
    _one_line(err, str(path), "'vy'")

    rows.to_csv(path, index=False)
    with pytest.raises(TrackError, match="feet"):
        read_interaction(path, [0.0, 12.0, 24.0], direction="x+")
    with pytest.raises(ValueError, match=r"\(x, y\) map point"):
        read_interaction(path, [0.0, 3.5, 7.0], direction=0.0)
    with pytest.raises(ValueError, match="direction"):
        read_interaction(path, [0.0, 3.5, 7.0], direction="north")
    # 'x-': numbers are each line's map y; the road frame's y is −map y
    west = _interaction_vehicle(3, 9, (500.0, -5.25), (-20.0, 0.0), (0.0, 0.0))
    west.to_csv(path, index=False)
    [cw] = read_interaction(path, [-7.0, -3.5, 0.0], direction="x-").carriageways
    assert cw.markings == (0.0, 3.5, 7.0)
    tr = cw.tracks[0]
    assert tr.x[0] == pytest.approx(-500.0) and np.all(np.diff(tr.x) > 0)
    np.testing.assert_allclose(tr.y, 5.25)
    np.testing.assert_allclose(tr.heading, 0.0, atol=1e-12)
    assert cw.lane_of(tr.y[0]) == 1


def test_readers_are_registered():
    assert READERS["ngsim"] is read_ngsim
    assert READERS["highd"] is read_levelx
    assert READERS["interaction"] is read_interaction


def test_ngsim_i80_has_six_main_lanes_and_us101_five(tmp_path):
    df = pd.concat(
        [_ngsim_table().assign(Location="us-101"), _ngsim_table().assign(Location="i-80")],
        ignore_index=True,
    )
    path = tmp_path / "ngsim.csv"
    df.to_csv(path, index=False)
    i80, us101 = read_ngsim(path).carriageways
    assert (len(i80.markings), len(us101.markings)) == (7, 6)
    assert np.all(_track(i80, "6").lane == 0)  # I-80's Lane_ID 6: its rightmost main lane
    assert np.all(_track(us101, "6").lane == -1)  # US-101's: the auxiliary lane
    # a headerless file with an on-ramp (7) and no off-ramp (8) is I-80
    ramp = _ngsim_vehicle(7, np.arange(10, 30), 78.0, 7, y0=20.0)
    [cw] = read_ngsim(
        _write_classic(pd.concat([_ngsim_table(), ramp]), tmp_path / "i80.txt")
    ).carriageways
    assert len(cw.markings) == 7 and np.all(_track(cw, "7").lane == -1)


def test_ngsim_a_gap_across_a_lane_change_keeps_it_unusable_not_lost(tmp_path):
    from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes

    df = _ngsim_table()
    hole = (df.Vehicle_ID == 2) & df.Frame_ID.between(15, 26)  # 1.3 s across its crossing
    [cw] = read_ngsim(_write_classic(df[~hole], tmp_path / "t.txt")).carriageways
    changer = _track(cw, "2")  # one track: a gap is not a reused id
    assert changer.n == 8 and not any(tr.vehicle_id.startswith("2@") for tr in cw.tracks)
    config = ExtractionConfig(dt=0.1, before_s=1, after_s=1, min_before_s=0.3, min_after_s=0.3,
                              min_stay_s=0.1, observe_s=0.2, min_lateral_move=0)  # fmt: skip
    [episode] = [e for e in extract_episodes(read_ngsim(tmp_path / "t.txt"), config)
                 if e.vehicle_id == "2"]  # fmt: skip
    assert not episode.usable
    assert episode.reasons[0].startswith(
        "no sample for 1.3 s across the crossing (t = 0.4 to 1.7 s), more than max_gap_s "
        "(--max-gap) 1 s: the lane change itself is not recorded"
    )


def _cats_sample(folder, **changes):
    """A shipped-sample folder in the CATS layout: two vehicles, 10 Hz, 12 s."""
    t = np.round(np.arange(0, 12.0 + 1e-9, 0.1), 9)
    rows = pd.concat(
        [
            pd.DataFrame(
                {
                    "run_id": "run",
                    "vehicle_id": v,
                    "t_s": t,
                    "x_m": x0 + 25.0 * t,
                    "y_m": y,
                    "v_mps": 25.0,
                    "lane": lane,
                }
            )
            for v, x0, y, lane in ((1, 0.0, 2.0, 0), (2, 40.0, 6.0, 1))
        ],
        ignore_index=True,
    )
    for column, change in changes.items():
        rows[column] = change(rows[column])
    folder.mkdir()
    rows.to_csv(folder / "tracks.csv.gz", index=False)
    return folder


@pytest.mark.parametrize(
    ("fmt", "unit"),
    [("ngsim", "6 of 6 vehicles drive at a median 152 m/s by the speed column"),
     ("highd", "km/h given as m/s (÷ 3.6: 30 m/s)?"),
     ("interaction", "degrees?"), ("sample", "times in milliseconds? divide by 1000")],
)  # fmt: skip
def test_every_reader_applies_the_readers_checks(tmp_path, fmt, unit):
    """One home for the rules: a fleet in another unit is refused whatever the format."""
    if fmt == "ngsim":
        df = _ngsim_table()
        df["v_Vel"] *= 10  # 500 ft/s
        read = lambda: read_ngsim(_write_classic(df, tmp_path / "t.txt"))  # noqa: E731
    elif fmt == "highd":
        vehicles = [_levelx_vehicle(k, 100.0 + 20 * k, 20.0, 20.0, -30.0 * 3.6) for k in (1, 2)]
        path = _write_levelx(tmp_path, vehicles, {1: 1, 2: 1})
        read = lambda: read_levelx(path)  # noqa: E731
    elif fmt == "interaction":
        rows = [_interaction_vehicle(1, k, (15.25, 900.0 + 50 * k), (0.0, 20.0), (-3.5, 0.0))
                for k in (1, 2)]  # fmt: skip
        df = pd.concat(rows, ignore_index=True)
        df["psi_rad"] = np.degrees(df["psi_rad"])
        path = tmp_path / "vehicle_tracks_000.csv"
        df.to_csv(path, index=False)
        read = lambda: read_interaction(path, [10.0, 13.5, 17.0, 20.5], direction="y+")  # noqa: E731
    else:
        folder = _cats_sample(tmp_path / "sample", t_s=lambda t: t * 1000)
        read = lambda: READERS["sample"](folder)  # noqa: E731
    with pytest.raises(TrackError) as info:
        read()
    assert unit in str(info.value) and "\n" not in str(info.value)
