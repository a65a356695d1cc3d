"""The INTERACTION reader (recorded/readers/interaction.py) on files written here."""

import math

import numpy as np
import pandas as pd
import pytest
from published_files import _interaction_vehicle, _one_line, _track

from drivestyle.recorded.readers import (
    READERS,
    read_interaction,
)
from drivestyle.recorded.tracks import TrackError


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
