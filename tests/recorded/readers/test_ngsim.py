"""The raw NGSIM reader (recorded/readers/ngsim.py) on files written here."""

import numpy as np
import pandas as pd
import pytest
from published_files import (
    FT,
    LANE_X_FT,
    T0_MS,
    _ngsim_table,
    _ngsim_vehicle,
    _one_line,
    _track,
    _write_classic,
)

from drivestyle.recorded.readers import (
    READERS,
    read_ngsim,
)
from drivestyle.recorded.tracks import TrackError


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
