"""The levelX (highD) reader (recorded/readers/levelx.py) on files written here."""

import numpy as np
import pandas as pd
import pytest
from published_files import LOWER, RATE, UPPER, _levelx_files, _one_line, _track

from drivestyle.recorded.readers import (
    read_levelx,
)
from drivestyle.recorded.tracks import TrackError


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
