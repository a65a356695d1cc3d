"""Lane-change episodes of your own trajectories: reader, extraction, frame, inputs, no leak."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from drivestyle.envs.demonstration import load_demonstration
from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import PAPER
from drivestyle.recorded.episodes import (
    PHANTOM_GAP_M,
    ExtractionConfig,
    extract_episodes,
    recover_inputs,
    write_episodes,
)
from drivestyle.recorded.readers import READERS, read_table
from drivestyle.recorded.tracks import TrackError

W = 3.5
RATE = 0.1  # 10 Hz


def _lane_change(t, t_c, y_from, y_to, duration=4.0):
    """A smooth (cosine) lateral move centred on t_c."""
    s = np.clip((t - t_c) / duration + 0.5, 0.0, 1.0)
    return y_from + (y_to - y_from) * (1 - np.cos(np.pi * s)) / 2


def _table(ev_to_lane=2, ev_from_lane=1, speed=25.0, t_end=12.0, extra=None):
    """A 10 Hz long table: the lane changer 'ev' (lane 1 → ev_to_lane, crossing at 6 s) and
    a target-lane follower 'f', target-lane leader 'l', own-lane leader 'o', far car 'z'."""
    t = np.round(np.arange(0, t_end + 1e-9, RATE), 9)
    centre = lambda k: (k + 0.5) * W  # noqa: E731
    rows = []

    def add(vid, x, y, v):
        rows.append(pd.DataFrame({"id": vid, "t": t, "x": x, "y": y, "v": v}))

    add(
        "ev", 100 + speed * t, _lane_change(t, 6.0, centre(ev_from_lane), centre(ev_to_lane)), speed
    )
    add("f", 80 + 26 * t, np.full_like(t, centre(ev_to_lane)), 26.0)
    add("l", 130 + 24 * t, np.full_like(t, centre(ev_to_lane)), 24.0)
    add("o", 140 + 25 * t, np.full_like(t, centre(ev_from_lane)), 25.0)
    add("z", 600 + 25 * t, np.full_like(t, centre(ev_to_lane)), 25.0)
    for vid, x, y in extra or []:
        add(vid, x, y, 25.0)
    return pd.concat(rows, ignore_index=True)


def _extract(tmp_path, df, config=None, **reader):
    path = tmp_path / "tracks.csv"
    df.to_csv(path, index=False)
    reader.setdefault("lane_markings", [0, W, 2 * W, 3 * W])
    episodes = extract_episodes(read_table(path, **reader), config)
    return [e for e in episodes if e.vehicle_id == "ev"]


@pytest.mark.parametrize("to_lane", [2, 0])
def test_a_lane_change_either_way_goes_to_plus_y_with_its_interacting_vehicles(tmp_path, to_lane):
    (ep,) = _extract(tmp_path, _table(ev_to_lane=to_lane))
    assert ep.usable, ep.reasons
    assert ep.mirrored == (to_lane == 0) and ep.direction == ("right" if to_lane == 0 else "left")
    assert ep.t_cross == pytest.approx(6.0, abs=1e-6)
    assert dict(ep.interacting) == {"target_follower": "f", "target_leader": "l", "own_leader": "o"}
    d = ep.demo
    assert d.t[-1] == pytest.approx(8.0) and d.n == 41  # [t_c − 4, t_c + 4] at 0.2 s
    # origin lane centre at w/2, target lane centre at 3w/2, the crossed line at w
    assert d.ev[0, 1] == pytest.approx(W / 2, abs=1e-6)
    assert d.ev[-1, 1] == pytest.approx(1.5 * W, abs=1e-6)
    assert d.tv[0, 1] == pytest.approx(1.5 * W) and d.tv[0, 0] < d.ev[0, 0]  # the follower
    np.testing.assert_allclose(d.other_vehicles[:, :, 1], [[1.5 * W, 0.5 * W]] * d.n, atol=1e-9)
    assert d.ev[d.n // 2, 2] > 0  # heading towards +y
    assert ep.lateral_move == pytest.approx(W, abs=1e-9)  # lane centre to lane centre
    sc = d.scenario
    assert (sc.lane_width, sc.ev_lane, sc.target_lane, sc.tv_lane) == (W, 0, 1, 1)


def test_interacting_vehicles_are_chosen_at_the_window_start(tmp_path):
    # a target-lane car that only arrives later is not interacting; the far 'z' never is
    t = np.round(np.arange(0, 12.0 + 1e-9, RATE), 9)
    late = [("late", np.where(t < 3, np.nan, 120 + 25 * t), np.full_like(t, 2.5 * W))]
    df = _table(extra=late).dropna()
    (ep,) = _extract(tmp_path, df)
    assert "late" not in dict(ep.interacting).values() and "z" not in dict(ep.interacting).values()


def test_an_episode_without_interacting_vehicles_is_kept_and_flagged(tmp_path):
    df = _table()
    (ep,) = _extract(tmp_path, df[df.id == "ev"])
    assert ep.usable and ep.no_interaction and ep.interacting == ()
    assert ep.demo.tv[0, 0] - ep.demo.ev[0, 0] == pytest.approx(PHANTOM_GAP_M)
    assert ep.demo.meta["no_interaction"] is True


def test_too_little_track_before_the_crossing_is_unusable_with_the_reason(tmp_path):
    df = _table()
    (ep,) = _extract(tmp_path, df[df.t >= 3.5])
    assert not ep.usable and ep.demo is None
    assert "2.50 s of track before the crossing (min_before_s 3 s)" in ep.reasons[0]


def test_a_wobble_on_the_line_is_no_lane_change(tmp_path):
    df = _table()
    ev = df.id == "ev"
    t = df.loc[ev, "t"].to_numpy()
    df.loc[ev, "y"] = 1.5 * W + np.where((t > 5) & (t < 5.5), 0.2 * W + W / 2, 0.0)
    assert _extract(tmp_path, df) == []


def _drift(df, line, move, t0=4.0, t1=8.0):
    """The EV drifts linearly by ``move`` across ``line`` between t0 and t1 (crossing at 6 s)."""
    ev = df.id == "ev"
    s = np.clip((df.loc[ev, "t"] - t0) / (t1 - t0), 0.0, 1.0)
    return df.assign(y=df.y.where(~ev, line + move * (s - 0.5)))


@pytest.mark.parametrize("side", [1, -1])
def test_a_drift_across_a_line_is_kept_unusable_with_its_lateral_move(tmp_path, side):
    # 0.3 m across a line in 4 s, each lane held for 2 s: found as a change, no lane change
    line = 2 * W if side > 0 else W
    (ep,) = _extract(tmp_path, _drift(_table(), line, side * 0.3))
    assert ep.direction == ("left" if side > 0 else "right")
    assert not ep.usable and ep.demo is None
    assert ep.lateral_move == pytest.approx(0.3, abs=1e-9)
    assert ep.reasons == (
        "moved 0.30 m laterally towards the new lane across the window, below the minimum "
        "lateral move 1.75 m (half the 3.50 m lane width; min_lateral_move): a drift along the "
        "line or an aborted change, not a lane change",
    )
    # the rule's own number decides: off, the same drift is an episode
    (off,) = _extract(tmp_path, _drift(_table(), line, side * 0.3), ExtractionConfig(
        min_lateral_move=0.0))  # fmt: skip
    assert off.usable, off.reasons
    # a move of 0.4 w passes a minimum of 0.3 w, not one of 0.5 w
    drift = _drift(_table(), line, side * 0.4 * W)
    assert _extract(tmp_path, drift, ExtractionConfig(min_lateral_move=0.3))[0].usable
    (half,) = _extract(tmp_path, drift)
    assert not half.usable and "below the minimum lateral move 1.75 m" in half.reasons[0]


def test_recovered_inputs_reproduce_the_states_through_rk4():
    sc = replace(PAPER, delta_max=0.05)
    rng = np.random.default_rng(0)
    u = np.column_stack([rng.uniform(-2, 2, 20), rng.uniform(-0.03, 0.03, 20)])
    ev = [np.array([0.0, 2.6, 0.0, 25.0])]
    for k in range(20):
        ev.append(rk4_step(ev[-1], u[k], sc.dt, sc.l_f, sc.l_r))
    ev = np.array(ev)
    got = recover_inputs(ev, sc)
    np.testing.assert_allclose(got, u, atol=1e-6)
    again = [ev[0]]
    for k in range(20):
        again.append(rk4_step(again[-1], got[k], sc.dt, sc.l_f, sc.l_r))
    np.testing.assert_allclose(np.array(again), ev, atol=1e-6)


def test_nothing_after_the_observed_part_enters_the_scenario(tmp_path):
    df = _table()
    (ep,) = _extract(tmp_path, df)
    # change everything after the observed part (window start 2 s + observe_s 2 s) but the
    # crossing: the EV speeds up, ends elsewhere in the target lane, the TV brakes
    late = df.t > 4.0 + 1e-9
    changed = df.copy()
    ev, tv = changed.id == "ev", changed.id == "f"
    dt_late = (changed.t - 4.0).clip(lower=0)
    changed.loc[ev & late, "x"] += 0.5 * 0.3 * dt_late[ev & late] ** 2
    changed.loc[ev & late, "v"] += 0.3 * dt_late[ev & late]
    after = ev & (changed.t > 6.5)  # the crossing (6 s) and so the window stay
    changed.loc[after, "y"] += 0.3 * np.sin(changed.t[after] - 6.5)
    changed.loc[tv & late, "v"] -= 1.0 * dt_late[tv & late]
    (other,) = _extract(tmp_path, changed)
    assert other.usable, other.reasons
    assert other.t_cross == ep.t_cross and other.observed_until_s == pytest.approx(2.0)
    assert not np.allclose(other.demo.ev, ep.demo.ev)
    a, b = ep.demo.scenario, other.demo.scenario
    assert a == b  # v_ref, lanes, target line, ellipse, initial states, horizon


def test_write_episodes_writes_demonstrations_and_the_index(tmp_path):
    episodes = _extract(tmp_path, _table(ev_to_lane=0))
    index = write_episodes(episodes, tmp_path / "out")
    rows = pd.read_csv(index)
    assert list(rows.episode_id) == [episodes[0].episode_id]
    row = rows.iloc[0]
    assert row.direction == "right" and bool(row.mirrored) and bool(row.usable)
    assert row.tv_role == "target_follower" and row.tv_id == "f"
    assert row.interacting == "target_follower:f;target_leader:l;own_leader:o"
    assert (row.first_frame, row.last_frame) == (20, 100) and row.lane_width_m == W
    assert row.lateral_move_m == pytest.approx(W)
    demo = load_demonstration(tmp_path / "out" / row.file)
    np.testing.assert_allclose(demo.ev, episodes[0].demo.ev)


def test_read_table_turns_traffic_driving_to_minus_x(tmp_path):
    df = _table()
    flipped = df.assign(x=-df.x, y=-df.y)  # the same road seen from the other side
    (ep,) = _extract(tmp_path, flipped, lane_markings=[-3 * W, -2 * W, -W, 0])
    (ref,) = _extract(tmp_path, df)
    assert ep.carriageway == "-x" and not ep.mirrored
    np.testing.assert_allclose(ep.demo.ev, ref.demo.ev, atol=1e-9)


def test_read_table_places_lane_lines_from_the_lane_column(tmp_path):
    df = _table()
    df["lane"] = np.floor(df.y / W).astype(int) + 7  # any ids
    path = tmp_path / "t.csv"
    df.to_csv(path, index=False)
    rec = read_table(path)
    np.testing.assert_allclose(rec.carriageways[0].markings, [W, 2 * W, 3 * W], atol=0.02)
    assert READERS["csv"] is read_table


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda d: d.assign(y=d.y.where(~((d.id == "ev") & (d.t == 5.0)), np.nan)),
         r"tracks\.csv: vehicle ev, frame 50: y is missing"),
        (lambda d: d.assign(x=d.x.astype(object).where(~((d.id == "o") & (d.t == 1.0)), "abc")),
         r"tracks\.csv: vehicle o, data row \d+: column 'x' has the non-numeric value 'abc'"),
        (lambda d: pd.concat([d, d[(d.id == "l") & (d.t == 2.0)]]),
         r"tracks\.csv: vehicle l, frame 20: two rows at t = 2 s"),
        (lambda d: d.drop(columns="t"), r"tracks\.csv: missing column\(s\) 't'"),
    ],
)  # fmt: skip
def test_bad_data_is_one_line_naming_file_vehicle_and_frame(tmp_path, change, match):
    path = tmp_path / "tracks.csv"
    change(_table()).to_csv(path, index=False)
    with pytest.raises(TrackError, match=match) as info:
        read_table(path, lane_width=W)
    assert "\n" not in str(info.value)


def test_lanes_in_feet_and_parquet_without_pyarrow_are_refused_clearly(tmp_path):
    path = tmp_path / "tracks.csv"
    _table().to_csv(path, index=False)
    with pytest.raises(TrackError, match=r"lanes 12 m wide .*feet"):
        read_table(path, lane_width=12.0)
    pq = tmp_path / "tracks.parquet"
    pq.write_bytes(b"PAR1")
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        with pytest.raises(ValueError, match=r"needs pyarrow.*pip install pyarrow"):
            read_table(pq, lane_width=W)


def _ten_hz(states, u, sc):
    """States at 0.1 s: each 0.2 s step's midpoint by RK4 with the held input."""
    out = [states[0]]
    for k in range(len(u)):
        out += [rk4_step(states[k], u[k], sc.dt / 2, sc.l_f, sc.l_r), states[k + 1]]
    return np.array(out)


@pytest.mark.slow
@pytest.mark.parametrize("columns", ["xy", "xyvh"])
@pytest.mark.parametrize("risk", [0.6, 0.9])
def test_an_smpc_lane_change_as_a_10hz_csv_is_identified_like_its_npz(tmp_path, risk, columns):
    from drivestyle.agents import generate_demonstration
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.irl.identification.posterior import identify

    w = 3.75  # its own lanes; the ellipse's l_b scaled with them (the extraction's rule)
    sc = replace(PAPER, lane_width=w, l_b=3 * w / 5.25)
    demo, _ = generate_demonstration(risk, sc)
    t = np.arange(2 * demo.n - 1) * 0.1
    frames = []
    for vid, states, u in (("ev", demo.ev, demo.u), ("tv", demo.tv, np.zeros_like(demo.u))):
        s = _ten_hz(states, u, sc)
        table = pd.DataFrame({"id": vid, "t": t, "x": s[:, 0], "y": s[:, 1]})
        if columns == "xyvh":
            table["v"], table["heading"] = s[:, 3], s[:, 2]
        frames.append(table)
    path = tmp_path / "smpc.csv"
    pd.concat(frames).to_csv(path, index=False)
    # the SMPC changes lane at once (crossing after 1.5-2.3 s): a short observed part; the
    # desired speed comes from it, the ellipse is the model's (the default)
    config = ExtractionConfig(min_before_s=1.0, observe_s=1.0, after_s=6.0)
    (ep,) = [e for e in extract_episodes(read_table(path, lane_width=w), config)
             if e.vehicle_id == "ev"]  # fmt: skip
    assert ep.usable and dict(ep.interacting) == {"target_follower": "tv"}
    if columns == "xyvh":  # the recorded heading and speed: the same states and inputs
        np.testing.assert_allclose(ep.demo.ev, demo.ev, atol=1e-9)
        np.testing.assert_allclose(ep.demo.u, demo.u, atol=1e-9)
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)),
                            risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))  # fmt: skip
    from_npz = identify(demo, library).risk_interpolated
    from_csv = identify(ep.demo, library).risk_interpolated
    assert from_csv == pytest.approx(from_npz, abs=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("risk", [0.6, 0.9])
def test_an_smpc_lane_change_in_levelx_image_coordinates_is_identified_like_its_npz(tmp_path, risk):
    """highD's layout, lower direction (driving to image +x, its left is image −y)."""
    from drivestyle.agents import generate_demonstration
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.irl.identification.posterior import identify
    from drivestyle.recorded.readers import read_levelx

    w = 3.75
    sc = replace(PAPER, lane_width=w, l_b=3 * w / 5.25)
    demo, _ = generate_demonstration(risk, sc)
    rate, length, width, offset = 25.0, sc.vehicle_length, sc.vehicle_width, 40.0
    t = np.arange(0.0, demo.t[-1] + 1e-9, 1 / rate)
    rows = []
    for vid, states in ((1, demo.ev), (2, demo.tv)):
        x = np.interp(t, demo.t, states[:, 0])
        y = np.interp(t, demo.t, states[:, 1])
        vx = np.gradient(x, t)
        vy = np.gradient(y, t)
        # our frame (x along travel, y to its left) → image: x_img = x, y_img = offset − y
        rows.append(pd.DataFrame({
            "frame": np.arange(t.size) + 1, "id": vid,
            "x": x - length / 2, "y": offset - y - width / 2, "width": length, "height": width,
            "xVelocity": vx, "yVelocity": -vy, "xAcceleration": 0.0, "yAcceleration": 0.0,
            "laneId": 0,
        }))  # fmt: skip
    pd.concat(rows, ignore_index=True).to_csv(tmp_path / "01_tracks.csv", index=False)
    pd.DataFrame({"id": [1, 2], "drivingDirection": [2, 2], "class": "Car"}).to_csv(
        tmp_path / "01_tracksMeta.csv", index=False
    )
    lower = [offset - k * w for k in (3, 2, 1, 0)]  # image y of the lines, increasing
    upper = [offset - 30.0 - k * w for k in (3, 2, 1, 0)]
    pd.DataFrame({
        "id": [1], "frameRate": [rate],
        "upperLaneMarkings": [";".join(f"{m:g}" for m in upper)],
        "lowerLaneMarkings": [";".join(f"{m:g}" for m in lower)],
    }).to_csv(tmp_path / "01_recordingMeta.csv", index=False)  # fmt: skip
    recording = read_levelx(tmp_path / "01_tracks.csv")
    config = ExtractionConfig(min_before_s=1.0, observe_s=1.0, after_s=6.0)
    (ep,) = [e for e in extract_episodes(recording, config) if e.vehicle_id == "1"]
    assert ep.usable and dict(ep.interacting) == {"target_follower": "2"}
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)),
                            risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))  # fmt: skip
    from_npz = identify(demo, library).risk_interpolated
    from_levelx = identify(ep.demo, library).risk_interpolated
    assert from_levelx == pytest.approx(from_npz, abs=0.05)


def test_an_implausible_episode_names_the_lane_lines_not_metadata(tmp_path):
    # the target-lane follower, in lane 2 at the window's start (2 s), moves on to lane 3 at
    # 3 s: its median y lies in another lane than the one it was chosen in
    t = np.round(np.arange(0, 12.0 + 1e-9, RATE), 9)
    extra = [("g", 70 + 26 * t, _lane_change(t, 3.0, 2.5 * W, 3.5 * W, duration=1.0))]
    df = _table(extra=extra)
    df = df[df.id != "f"]
    (ep,) = _extract(tmp_path, df, lane_markings=[0, W, 2 * W, 3 * W, 4 * W])
    assert dict(ep.interacting)["target_follower"] == "g" and not ep.usable
    (reason,) = ep.reasons
    assert "the TV, which keeps lane 1" in reason and "metadata" not in reason
    assert reason.endswith(
        "lane_width, ev_lane and tv_lane come from the lane lines of carriageway '+x' and the "
        "TV's lane at the window's start: the TV changes lane or drives on a line in the "
        "window, or the lines are not the road's"
    )
    # a demonstration without the extraction's note (a user's .npz) keeps the metadata hint
    from drivestyle.envs.demonstration import plausibility_problems

    meta = {k: v for k, v in ep.demo.meta.items() if k != "lanes_from"}
    (problem,) = plausibility_problems(replace(ep.demo, meta=meta))
    assert problem.endswith(
        "wrong lane_width or tv_lane in the metadata, or y in another frame or unit?"
    )


def test_an_episode_is_recorded_and_says_which_states_continue_a_track(tmp_path):
    df = _table()
    # the target-lane follower's track ends at 7 s, inside the window (2 s to 10 s)
    (ep,) = _extract(tmp_path, df[(df.id != "f") | (df.t <= 7.0)])
    demo = ep.demo
    assert demo.origin == "recorded" and dict(ep.interacting)["target_follower"] == "f"
    assert demo.observed.shape == (1 + demo.other_vehicles.shape[1], demo.n)
    t_source = demo.t + 2.0  # the window starts at 2 s
    np.testing.assert_array_equal(demo.observed[0], t_source <= 7.0 + 1e-9)
    assert demo.observed[1:].all()  # the leaders are recorded throughout
    # beyond its last sample the follower is continued at its last heading and speed
    after = ~demo.observed[0]
    assert after.sum() == 15 and np.all(demo.tv[after, 3] == demo.tv[~after][-1, 3])
    (alone,) = _extract(tmp_path, df[df.id == "ev"])
    np.testing.assert_array_equal(alone.demo.observed, np.ones((1, alone.demo.n), bool))
