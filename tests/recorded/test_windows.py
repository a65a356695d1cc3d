"""Every vehicle's windows without a lane change: where they are cut, their frame and kind."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from drivestyle.envs.demonstration import check_plausible
from drivestyle.recorded.episodes import extract_episodes
from drivestyle.recorded.kinds import EPISODE_KINDS, episode_kind, is_stop_and_go, is_window_id
from drivestyle.recorded.readers import read_table
from drivestyle.recorded.windows import (
    APPROACH_CLOSING_MPS,
    FOLLOWING_HEADWAY_S,
    stop_and_go,
    window_kind,
)

W = 3.5
RATE = 0.1


def _states(x0, v, n=41, dt=0.2, y=1.75):
    t = np.arange(n) * dt
    v = np.broadcast_to(np.asarray(v, float), t.shape)
    x = x0 + np.concatenate([[0.0], np.cumsum((v[1:] + v[:-1]) / 2 * dt)])
    return np.column_stack([x, np.full(n, y), np.zeros(n), v])


def test_the_kind_follows_the_leader():
    ev = _states(0.0, 20.0)
    assert window_kind(ev, None, 4.5) == "lane_keeping"
    # 20 m behind at the same speed: a 0.8 s headway
    assert window_kind(ev, _states(24.5, 20.0), 4.5) == "car_following"
    # far ahead at the same speed: a free driver
    far = 4.5 + 20.0 * (FOLLOWING_HEADWAY_S + 1.0)
    assert window_kind(ev, _states(far, 20.0), 4.5) == "lane_keeping"
    # a slower leader: the gap shrinks by 8 s × the closing speed
    slower = _states(60.0, 20.0 - 2 * APPROACH_CLOSING_MPS)
    assert window_kind(ev, slower, 4.5) == "approaching"
    # a hair slower than the threshold: following
    creeping = _states(24.5, 20.0 - 0.5 * APPROACH_CLOSING_MPS)
    assert window_kind(ev, creeping, 4.5) == "car_following"


def test_stop_and_go_needs_slow_and_swinging_speeds():
    wave = _states(30.0, 6.0 + 4.0 * np.sin(np.linspace(0, 2 * np.pi, 41)))
    assert stop_and_go(_states(0.0, 8.0), wave)
    assert not stop_and_go(_states(0.0, 8.0), _states(30.0, 5.0))  # a slow queue, no wave
    assert not stop_and_go(_states(0.0, 25.0), None)


def _table(t_end=30.0):
    """A vehicle 'k' keeping lane 1 for 30 s behind a slower 'o', and 'c' changing from lane 0
    to 1 at 15 s (crossing its line: its windows around it are left out)."""
    t = np.round(np.arange(0, t_end + 1e-9, RATE), 9)
    rows = [
        pd.DataFrame({"id": "k", "t": t, "x": 100 + 22 * t, "y": 1.5 * W, "v": 22.0}),
        pd.DataFrame({"id": "o", "t": t, "x": 160 + 20 * t, "y": 1.5 * W, "v": 20.0}),
    ]
    s = np.clip((t - 15.0) / 4.0 + 0.5, 0.0, 1.0)
    y = 0.5 * W + W * (1 - np.cos(np.pi * s)) / 2
    rows.append(pd.DataFrame({"id": "c", "t": t, "x": 300 + 25 * t, "y": y, "v": 25.0}))
    return pd.concat(rows, ignore_index=True)


@pytest.fixture(scope="module")
def episodes(tmp_path_factory):
    path = tmp_path_factory.mktemp("windows") / "tracks.csv"
    _table().to_csv(path, index=False)
    recording = read_table(path, lane_markings=[0, W, 2 * W, 3 * W])
    return extract_episodes(recording, all_vehicles=True)


def test_windows_tile_each_track_and_leave_out_the_lane_change(episodes):
    k = [e for e in episodes if e.vehicle_id == "k"]
    assert len(k) == 3  # 30 s in windows of 8 s
    assert all(is_window_id(e.episode_id) and e.usable for e in k)
    c = [e for e in episodes if e.vehicle_id == "c"]
    kinds = sorted(e.kind for e in c)
    # the lane change at 15 s and its window [11, 19] s; of the windows [0, 8], [8, 16],
    # [16, 24], [24, 32) only the first lies clear of it (the last leaves the track)
    assert kinds == ["lane_change", "lane_keeping"]
    window = next(e for e in c if e.kind != "lane_change")
    assert window.demo is not None and window.demo.t[-1] == pytest.approx(8.0)


def test_a_window_is_in_its_own_lane_with_the_neighbour_at_plus_y(episodes):
    for e in episodes:
        if e.kind == "lane_change" or e.demo is None:
            continue
        check_plausible(e.demo)
        y = e.demo.ev[:, 1]
        assert 0.0 <= y.min() and y.max() < e.lane_width  # lane 0 = [0, w)
        assert episode_kind(e.demo) == e.kind in EPISODE_KINDS
        assert e.direction == ""


def test_the_follower_of_a_slower_leader_approaches_then_follows(episodes):
    k = [e for e in episodes if e.vehicle_id == "k"]
    # 60 m minus its length ahead, 2 m/s slower: approaching (16 m closer per window)
    assert k[0].kind == "approaching"
    assert all(not is_stop_and_go(e.demo) for e in k)


def test_without_the_flag_only_lane_changes(tmp_path):
    path = tmp_path / "tracks.csv"
    _table().to_csv(path, index=False)
    found = extract_episodes(read_table(path, lane_markings=[0, W, 2 * W, 3 * W]))
    assert [e.kind for e in found] == ["lane_change"]
    assert found[0].demo is not None and episode_kind(found[0].demo) == "lane_change"
