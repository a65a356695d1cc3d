"""highway-env's IDM + MOBIL drivers recorded as tracks (agents/highway_drivers.py).

The caution order of the classes, the frame, a tiny simulation, determinism, bad spawns.
"""

import numpy as np
import pytest

from drivestyle.agents.highway_drivers import (
    HIGHWAY_CLASSES,
    LANE_WIDTH,
    Spawn,
    TrafficConfig,
    draw_traffic,
    highway_recording,
    project_frame,
    simulate_highway,
)
from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes

# a fast vehicle closing on a slow one far ahead on the middle lane, the other lanes empty:
# MOBIL's gain passes the threshold after ≈ 5 s, so the change has 3 s of track before it
OVERTAKE = [Spawn("moderate", 1, 0.0, 32.0, 32.0), Spawn("reckless", 1, 650.0, 20.0, 20.0)]
SHORT = TrafficConfig(duration_s=12.0)


def test_the_caution_order_is_monotone_in_every_constant():
    ranks = [c.caution for c in HIGHWAY_CLASSES]
    assert ranks == sorted(ranks) and len(set(ranks)) == len(ranks)
    for name in ("time_wanted", "distance_wanted", "politeness"):
        values = [getattr(c, name) for c in HIGHWAY_CLASSES]
        assert values == sorted(values), name
    braking = [c.max_braking_imposed for c in HIGHWAY_CLASSES]
    assert braking == sorted(braking, reverse=True)
    vehicle = HIGHWAY_CLASSES[-1].vehicle_type()
    assert vehicle.TIME_WANTED == HIGHWAY_CLASSES[-1].time_wanted


def test_highway_env_lanes_map_to_the_project_frame():
    # highway-env: lane i's centre at y = 4 i, y to the right; lane 0 is the leftmost
    y, phi, markings = project_frame(np.array([0.0, 4.0, 8.0]), np.array([0.1, 0.0, -0.2]), 3)
    assert markings == (0.0, 4.0, 8.0, 12.0)
    assert np.allclose(y, [10.0, 6.0, 2.0]) and np.allclose(phi, [-0.1, 0.0, 0.2])
    t = np.arange(3) * 0.1
    rows = {
        "left": np.column_stack([t, 20 * t, np.zeros(3), np.full(3, 20.0), np.zeros(3)]),
        "right": np.column_stack([t, 20 * t, np.full(3, 2 * LANE_WIDTH), np.full(3, 20.0),
                                  np.zeros(3)]),
    }  # fmt: skip
    road = highway_recording(rows, 3).carriageways[0]
    lanes = {tr.vehicle_id: int(road.lane_of(tr.y)[0]) for tr in road.tracks}
    assert lanes == {"left": 2, "right": 0}  # project: lane 0 rightmost


def test_a_tiny_simulation_yields_a_lane_change_of_a_known_class():
    rec, classes = simulate_highway(OVERTAKE, SHORT)
    track = rec.carriageways[0].tracks[0]
    assert np.allclose(np.diff(track.t), 0.1)  # recorded at 10 Hz
    episodes = [e for e in extract_episodes(rec, ExtractionConfig(dt=0.2, l_a=None)) if e.usable]
    assert [(classes[e.vehicle_id], abs(e.to_lane - e.from_lane)) for e in episodes] == [
        ("moderate", 1)
    ]
    assert episodes[0].demo is not None and "episode_id" in episodes[0].demo.meta


def test_traffic_is_deterministic_given_its_seed():
    cfg = TrafficConfig(vehicles_per_lane=2, duration_s=2.0)
    assert draw_traffic(cfg, 3) == draw_traffic(cfg, 3) != draw_traffic(cfg, 4)
    a, ca = simulate_highway(draw_traffic(cfg, 3), cfg)
    b, cb = simulate_highway(draw_traffic(cfg, 3), cfg)
    assert ca == cb
    for ta, tb in zip(a.carriageways[0].tracks, b.carriageways[0].tracks, strict=True):
        assert np.array_equal(ta.x, tb.x) and np.array_equal(ta.y, tb.y)


def test_bad_spawns_are_refused_with_one_line():
    with pytest.raises(ValueError, match="unknown driver class 'nobody'"):
        simulate_highway([Spawn("nobody", 0, 0.0, 20.0, 20.0)], SHORT)
    with pytest.raises(ValueError, match="lane 3 is not a lane"):
        simulate_highway([Spawn("reckless", 3, 0.0, 20.0, 20.0)], SHORT)
