"""What an observer has seen: the extracted mask and its fallback, the no-leak view after t_obs."""

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs.demonstration import Demonstration
from drivestyle.recorded.observed import mask_from_repeats, observed_mask, observed_view

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"


def _vehicle(n=8, first=None, last=None):
    """A vehicle at a varying speed, continued (φ, v held) before ``first``/after ``last``."""
    t = np.arange(n) * 0.2
    states = np.column_stack([20 * t, np.full(n, 5.0), 0.01 * t, 20 + 0.5 * t])
    if first is not None:
        states[:first, 2:] = states[first, 2:]
    if last is not None:
        states[last + 1 :, 2:] = states[last, 2:]
    return states


def test_the_fallback_rule_in_closed_form():
    vehicles = np.stack(
        [_vehicle(), _vehicle(first=3), _vehicle(last=5), _vehicle(first=2, last=4),
         _vehicle(first=7), _vehicle(first=1)],
        axis=1,
    )  # fmt: skip
    mask = mask_from_repeats(vehicles)
    assert mask.shape == (6, 8)
    np.testing.assert_array_equal(mask[0], [True] * 8)
    np.testing.assert_array_equal(mask[1], [False] * 3 + [True] * 5)  # first recorded: 3
    np.testing.assert_array_equal(mask[2], [True] * 6 + [False] * 2)  # last recorded: 5
    np.testing.assert_array_equal(mask[3], [False] * 2 + [True] * 3 + [False] * 3)
    np.testing.assert_array_equal(mask[4], [False] * 8)  # (φ, v) never change: continued
    np.testing.assert_array_equal(mask[5], [False] + [True] * 7)


def _demo(vehicles, **fields):
    n = vehicles.shape[0]
    t = np.arange(n) * 0.2
    ev = np.column_stack([20 * t + 30, np.full(n, 1.5), np.zeros(n), np.full(n, 20.0)])
    others = vehicles[:, 1:] if vehicles.shape[1] > 1 else None
    return Demonstration(t, ev, vehicles[:, 0], np.zeros((n - 1, 2)), others=others, **fields)


def test_observed_mask_is_the_carried_mask_else_all_for_simulated_else_the_fallback():
    vehicles = np.stack([_vehicle(), _vehicle(first=3)], axis=1)
    simulated = _demo(vehicles)
    np.testing.assert_array_equal(observed_mask(simulated), np.ones((2, 8), bool))
    recorded = replace(simulated, origin="recorded")
    np.testing.assert_array_equal(observed_mask(recorded), mask_from_repeats(vehicles))
    carried = np.ones((2, 8), bool)
    carried[1, :2] = False  # the mask carried wins over the states
    np.testing.assert_array_equal(observed_mask(replace(recorded, observed=carried)), carried)


def _extracted(dataset):
    """Every extracted lane change with a demonstration, as the benchmark extracts them
    (``studies.prediction.recorded_episodes``: the sample read, the default config)."""
    from drivestyle.recorded.episodes import extract_episodes
    from drivestyle.recorded.readers import read_sample
    from drivestyle.recorded.real_data import DATASETS

    return [e for e in extract_episodes(read_sample(DATA / DATASETS[dataset])) if e.demo]


def _not_yet_observed(states, k):
    """The rule the prediction study's observed view applies today (verbatim)."""
    head = states[: k + 1]
    return bool(np.all(head[:, 2] == head[0, 2]) and np.all(head[:, 3] == head[0, 3]))


@pytest.mark.skipif(not (DATA / "ngsim").is_dir(), reason="../shared/data not beside the checkout")
@pytest.mark.parametrize("dataset", ["ngsim", pytest.param("cats", marks=pytest.mark.slow)])
def test_the_extractions_mask_is_the_fallback_rule_on_every_shipped_episode(dataset):
    episodes = _extracted(dataset)
    partial = 0
    for e in episodes:
        demo = e.demo
        assert demo.origin == "recorded" and demo.observed is not None
        np.testing.assert_array_equal(
            demo.observed, mask_from_repeats(demo.vehicles), err_msg=e.episode_id
        )
        # and the observer's rule today, at every observed sample k: a vehicle is not yet
        # observed at k exactly when none of its samples before k is a recorded one
        vehicles = demo.vehicles
        for j in range(vehicles.shape[1]):
            for k in range(demo.n):
                assert _not_yet_observed(vehicles[:, j], k) == (not demo.observed[j, :k].any())
        partial += int((~demo.observed).any(axis=1).sum())
    assert partial >= 1  # the shipped samples hold vehicles recorded for part of a window


@pytest.mark.skipif(not (DATA / "ngsim").is_dir(), reason="../shared/data not beside the checkout")
def test_a_file_written_before_the_mask_gets_the_extractions_mask_back(tmp_path):
    from drivestyle.envs.demonstration import load_demonstration

    demo = next(e.demo for e in _extracted("ngsim") if (~e.demo.observed).any())
    meta = np.array(json.dumps(demo.meta))
    np.savez(tmp_path / "old.npz", t=demo.t, ev=demo.ev, tv=demo.tv, u=demo.u,
             others=demo.other_vehicles, meta=meta)  # fmt: skip
    old = load_demonstration(tmp_path / "old.npz")
    assert old.origin == "recorded" and old.observed is None
    np.testing.assert_array_equal(observed_mask(old), demo.observed)


def test_the_observed_scenario_uses_the_observed_speeds_only(paper_demo, as_recorded):
    demo = as_recorded(paper_demo)
    sc = observed_view(demo, 1.0)[1]
    k = round(1.0 / demo.scenario.dt)
    assert sc.v_ref == pytest.approx(max(np.percentile(demo.ev[: k + 1, 3], 90), 1.0))
    changed = demo.ev.copy()
    changed[k + 1 :, 3] += 10.0  # the future is not looked at
    assert observed_view(replace(demo, ev=changed), 1.0)[1].v_ref == sc.v_ref


def test_the_recorded_bounds_are_chosen_from_the_observed_heading_only(paper_demo, as_recorded):
    from drivestyle.recorded.real_data import RECORDED_PHI_MAX

    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    ev = demo.ev.copy()
    ev[k + 1 :, 2] *= 4.0  # the future turns beyond the heading bound
    turning = replace(demo, ev=ev)
    assert observed_view(turning, 2.0)[1].phi_max == demo.scenario.phi_max
    assert observed_view(turning, 2.0)[1] == observed_view(demo, 2.0)[1]
    late = round(5.0 / demo.scenario.dt)  # once observed, the turn does count
    assert observed_view(turning, 5.0)[1].phi_max == RECORDED_PHI_MAX
    assert observed_view(demo, 5.0)[1].phi_max == demo.scenario.phi_max
    assert late > k


def test_the_observed_view_does_not_read_the_future(paper_demo, as_recorded, change_the_future):
    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    seen, sc = observed_view(demo, 2.0)
    seen2, sc2 = observed_view(change_the_future(demo, k), 2.0)
    assert sc2 == sc
    assert np.array_equal(seen.ev[: k + 1], seen2.ev[: k + 1])
    assert np.array_equal(seen.vehicles[: k + 1], seen2.vehicles[: k + 1])
    # the EV's current lane is the middle one; the target the next in the observed direction
    assert math.floor(seen.ev[k, 1] / sc.lane_width) == 1 and sc.target_lane in (0, 2)
    # a vehicle first recorded after t_obs (held constant before it, as the loader does) is
    # replaced by a phantom far behind
    late = demo.other_vehicles.copy()
    late[: k + 3, 0, 2:] = late[k + 3, 0, 2:]
    seen3, _ = observed_view(replace(demo, others=late), 2.0)
    assert np.min(seen3.vehicles[k, :, 0] - seen3.ev[k, 0]) < -900


def test_the_observed_view_carries_the_origin_and_the_mask_with_phantoms_unobserved(
    paper_demo, as_recorded
):
    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    late = demo.other_vehicles.copy()
    late[: k + 3, 0, 2:] = late[k + 3, 0, 2:]  # first recorded after t_obs
    seen, _ = observed_view(replace(demo, others=late), 2.0)
    assert seen.origin == "recorded"
    mask = observed_mask(seen)
    phantom = np.flatnonzero(seen.vehicles[k, :, 0] < seen.ev[k, 0] - 500.0)
    # the late vehicle is a phantom (so is the paper's TV: a constant-velocity vehicle repeats
    # its (φ, v) bitwise, and a recorded one without a mask falls back on that rule)
    assert phantom.size >= 1 and not mask[phantom].any()
    assert mask[np.setdiff1d(np.arange(mask.shape[0]), phantom)].all()
