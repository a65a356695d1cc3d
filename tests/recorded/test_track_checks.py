"""The readers' checks of tracks (recorded/track_checks.py) in closed form."""

from __future__ import annotations

import itertools

import numpy as np

from drivestyle.envs.safety import rectangles_overlap, vehicle_corners, vehicles_overlap
from drivestyle.recorded.track_checks import course, overlaps


def test_vehicles_overlap_agrees_with_the_single_pair_test(rng):
    n = 2000
    a = np.column_stack([rng.uniform(-6, 6, n), rng.uniform(-3, 3, n), rng.uniform(-1, 1, n)])
    b = np.column_stack([rng.uniform(-6, 6, n), rng.uniform(-3, 3, n), rng.uniform(-1, 1, n)])
    size_a = np.column_stack([rng.uniform(3, 6, n), rng.uniform(1.5, 2.5, n)])
    size_b = np.column_stack([rng.uniform(3, 6, n), rng.uniform(1.5, 2.5, n)])
    want = [
        rectangles_overlap(vehicle_corners(a[k], *size_a[k]), vehicle_corners(b[k], *size_b[k]))
        for k in range(n)
    ]
    got = vehicles_overlap(a, b, size_a, size_b)
    assert got.tolist() == want and 0.2 < np.mean(want) < 0.8


def test_overlaps_finds_every_pair_the_all_pairs_test_finds(rng):
    r = 600
    key = rng.integers(0, 20, r)
    states = np.column_stack([rng.uniform(0, 150, r), rng.uniform(0, 11, r), rng.normal(0, 0.1, r)])
    length, width = rng.uniform(4, 12, r), rng.uniform(1.6, 2.6, r)
    size = np.column_stack([length, width])
    i, j = overlaps(key, states, length, width)
    got = {tuple(sorted(p)) for p in zip(i.tolist(), j.tolist(), strict=True)}
    want = {
        (a, b)
        for a, b in itertools.combinations(range(r), 2)
        if key[a] == key[b] and vehicles_overlap(states[[a]], states[[b]], size[[a]], size[[b]])[0]
    }
    assert got == want and len(want) > 20


def test_course_is_the_direction_over_a_base_along_the_road():
    t = np.arange(50) * 0.1
    x, y = 10.0 * t, 0.5 * t  # 1 m per step at an angle atan(0.05)
    np.testing.assert_allclose(course(x, y), np.arctan2(0.5, 10.0), rtol=1e-12)
    # a standing vehicle's noise does not turn it: the base is never reached
    noisy = course(np.array([0.0, 0.01, -0.01, 0.0]), np.array([0.0, 0.01, 0.0, -0.01]))
    np.testing.assert_array_equal(noisy, 0.0)


def test_a_standing_vehicles_jitter_neither_turns_its_course_nor_disputes_its_heading(rng):
    from drivestyle.recorded.track_checks import check_recording, course_disagreement
    from drivestyle.recorded.tracks import Carriageway, Recording, Track

    # 20 s standing with 0.1 m of position noise (its path grows 2 m every ≈ 1.5 s), then
    # 10 s at 10 m/s straight along +x; the recorded heading is 0 throughout
    t = np.round(np.arange(0, 30.0, 0.1), 9)
    x = np.where(t < 20, 0.0, 10.0 * (t - 20)) + rng.normal(0, 0.1, t.size)
    y = rng.normal(0, 0.1, t.size)
    np.testing.assert_allclose(course(x, y), 0.0, atol=0.2)
    off, _, _ = course_disagreement(t, x, y, np.zeros(t.size))
    assert off.size > 50 and off.max() < 0.2
    track = Track("1", t, x, y, np.arange(t.size), heading=np.zeros(t.size))
    road = Carriageway("+x", (-3.5, 0.5, 4.0), (track,))
    assert (
        check_recording(Recording("r", (road,)), warn=False).carriageways[0].tracks[0].problems
        == ()
    )
