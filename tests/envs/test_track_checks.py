"""The readers' checks of tracks (envs/track_checks.py) in closed form."""

from __future__ import annotations

import itertools

import numpy as np

from drivestyle.envs.safety import rectangles_overlap, vehicle_corners, vehicles_overlap
from drivestyle.envs.track_checks import course, overlaps


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


def test_course_is_the_direction_over_a_base_of_path():
    t = np.arange(50) * 0.1
    x, y = 10.0 * t, 0.5 * t  # 1 m per step at an angle atan(0.05)
    np.testing.assert_allclose(course(x, y), np.arctan2(0.5, 10.0), rtol=1e-12)
    # a standing vehicle's noise does not turn it: the base of path is never reached
    noisy = course(np.array([0.0, 0.01, -0.01, 0.0]), np.array([0.0, 0.01, 0.0, -0.01]))
    np.testing.assert_array_equal(noisy, 0.0)
