"""The stage-1 reachable rectangle and the certificate that no plan exists (DESIGN §16)."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.driver.risk_profile import risk_profile
from drivestyle.irl.driver.style_planner import _PLANNERS, StylePlanner
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.posterior import identify_driver
from drivestyle.planning.reachability import (
    MARGIN_SLACK,
    POSITION_SLACK,
    box_blocked,
    coasting_stages,
    covered,
    reachable_boxes,
    stage_one_blocked,
    stage_one_box,
)
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR, recorded_episodes
from drivestyle.recorded.real_data import RECORDED_DELTA_MAX, recorded_view

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)


def _local(point: np.ndarray, corners: np.ndarray) -> tuple[float, float]:
    """The point's coordinates in the rectangle's frame, in [0, 1]² when inside."""
    rel = point - corners[0]
    e_along, e_cross = corners[2] - corners[0], corners[1] - corners[0]
    return float(rel @ e_along / (e_along @ e_along)), float(rel @ e_cross / (e_cross @ e_cross))


@pytest.mark.parametrize("delta_max", [PAPER.delta_max, RECORDED_DELTA_MAX])
@pytest.mark.parametrize("T_s", [0.1, 0.2])
def test_every_rk4_step_inside_the_bounds_lands_in_the_rectangle(rng, delta_max, T_s):
    u_lo, u_hi = np.array([PAPER.a_min, -delta_max]), np.array([PAPER.a_max, delta_max])
    # input corners (the extremes) and random inputs, from random states incl. standstill
    corners_u = np.array([[a, d] for a in (u_lo[0], u_hi[0]) for d in (u_lo[1], 0.0, u_hi[1])])
    for _ in range(200):
        xi0 = np.array([rng.uniform(-50, 50), rng.uniform(-5, 5), rng.uniform(-0.4, 0.4),
                        rng.choice([0.0, 0.3, rng.uniform(0, 40)])])  # fmt: skip
        box = stage_one_box(xi0, u_lo, u_hi, T_s, PAPER.l_f, PAPER.l_r)
        inputs = np.vstack([corners_u, rng.uniform(u_lo, u_hi, size=(20, 2))])
        reached = np.array([rk4_step(xi0, u, T_s, PAPER.l_f, PAPER.l_r)[:2] for u in inputs])
        for point in reached:
            s, t = _local(point, box)
            assert -1e-12 <= s <= 1 + 1e-12 and -1e-12 <= t <= 1 + 1e-12, (xi0, point, box)
        # and not much larger than what is reached (else it would certify nothing)
        along = np.ptp([_local(p, box)[0] for p in reached])
        assert along > 0.4 or xi0[3] * T_s < 0.5


def test_the_rectangle_is_small_at_speed():
    xi0 = np.array([0.0, 0.0, 0.0, 25.0])
    lo = np.array([PAPER.a_min, -RECORDED_DELTA_MAX])
    hi = np.array([PAPER.a_max, RECORDED_DELTA_MAX])
    box = stage_one_box(xi0, lo, hi, 0.1, PAPER.l_f, PAPER.l_r)
    along, cross = np.ptp(box[:, 0]), np.ptp(box[:, 1])
    # speed range × T_s² scale along, β_max·v·T_s across (a loose rectangle would certify
    # nothing: the region's semi-minor axis is 2 m)
    assert along < 0.5 * (PAPER.a_max - PAPER.a_min) * 0.1**2 + 0.1 + 2 * POSITION_SLACK
    assert cross < 2 * 25.0 * 0.1 * 0.25


def test_a_vehicle_over_the_next_position_blocks_and_a_far_one_does_not():
    xi0 = np.array([0.0, 0.0, 0.0, 25.0])
    lo, hi = np.array([PAPER.a_min, -PAPER.delta_max]), np.array([PAPER.a_max, PAPER.delta_max])
    box = stage_one_box(xi0, lo, hi, 0.2, PAPER.l_f, PAPER.l_r)
    ahead = np.array([[8.0, 0.5, 0.0, 25.0]])  # 3 m ahead of the EV's next position
    far = np.array([[60.0, 0.0, 0.0, 25.0]])
    placeholder = np.array([[-1e4, 0.0, 0.0, 0.0]])
    assert stage_one_blocked(box, ahead, 0.2, PAPER.l_a, PAPER.l_b)
    assert stage_one_blocked(box, np.vstack([far, ahead, placeholder]), 0.2, PAPER.l_a, PAPER.l_b)
    assert not stage_one_blocked(box, np.vstack([far, placeholder]), 0.2, PAPER.l_a, PAPER.l_b)
    # at the rim: a corner reaches the boundary, so some plan may exist
    # (a vehicle standing still ahead: its stage-1 centre is its position)
    rim = np.array([[box[:, 0].min() + PAPER.l_a * (1 - MARGIN_SLACK / 2), 0.0, 0.0, 0.0]])
    assert not stage_one_blocked(box, rim, 0.2, PAPER.l_a, PAPER.l_b)


def test_coasting_inside_at_stage_one_is_necessary_for_a_blocked_row(rng):
    # u = 0 is an admissible input: its (exact) stage-1 position is in the rectangle
    lo, hi = np.array([PAPER.a_min, -PAPER.delta_max]), np.array([PAPER.a_max, PAPER.delta_max])
    blocked = 0
    for _ in range(2000):
        xi0 = np.array([0.0, rng.uniform(-3, 3), rng.uniform(-0.1, 0.1), rng.uniform(0, 35)])
        others = np.column_stack([rng.uniform(-10, 25, 3), rng.uniform(-4, 4, 3),
                                  rng.uniform(-0.1, 0.1, 3), rng.uniform(0, 35, 3)])  # fmt: skip
        box = stage_one_box(xi0, lo, hi, 0.2, PAPER.l_f, PAPER.l_r)
        if stage_one_blocked(box, others, 0.2, 12.0, PAPER.l_b):
            blocked += 1
            assert coasting_stages(xi0, others, 0.2, 12.0, PAPER.l_b, 1) == [1]
        assert coasting_stages(xi0, others, 0.2, 12.0, PAPER.l_b, 3) == coasting_stages(
            xi0, others.ravel(), 0.2, 12.0, PAPER.l_b, 3
        )
    assert blocked > 50  # the draw exercises the implication


@pytest.mark.parametrize("phi_max", [PAPER.phi_max, 0.3])
def test_every_rollout_inside_the_bounds_stays_in_the_stage_boxes(rng, phi_max):
    # random input sequences from random states; the rollouts that keep the state bounds
    # (every plan does) lie in each stage's box
    u_lo, u_hi = np.array([PAPER.a_min, -0.25]), np.array([PAPER.a_max, 0.25])
    s_lo = np.array([-np.inf, PAPER.y_bounds[0], -phi_max, 0.0])
    s_hi = np.array([np.inf, PAPER.y_bounds[1], phi_max, PAPER.v_max])
    kept = 0
    for _ in range(60):
        xi0 = np.array([0.0, rng.uniform(*PAPER.y_bounds), rng.uniform(-phi_max, phi_max),
                        rng.uniform(0, 35)])  # fmt: skip
        boxes = reachable_boxes(xi0, u_lo, u_hi, s_lo, s_hi, 0.2, PAPER.l_f, PAPER.l_r, 10)
        for _ in range(20):
            xi, path = xi0, []
            for u in rng.uniform(u_lo, u_hi, size=(10, 2)) * rng.choice([0.2, 1.0]):
                xi = rk4_step(xi, u, 0.2, PAPER.l_f, PAPER.l_r)
                path.append(xi)
            path = np.array(path)
            if np.any(path < s_lo) or np.any(path > s_hi):
                continue
            kept += 1
            assert np.all(path[:, 0] >= boxes[:, 0, 0]) and np.all(path[:, 0] <= boxes[:, 0, 1])
            assert np.all(path[:, 1] >= boxes[:, 1, 0]) and np.all(path[:, 1] <= boxes[:, 1, 1])
    assert kept > 100


def test_a_heading_beyond_reach_of_the_bounds_empties_the_boxes():
    u_lo, u_hi = np.array([PAPER.a_min, -0.25]), np.array([PAPER.a_max, 0.25])
    s_lo, s_hi = np.array([-np.inf, -10, -0.3, 0.0]), np.array([np.inf, 10, 0.3, 70.0])
    slow = reachable_boxes(np.array([0, 0, 0.45, 4.0]), u_lo, u_hi, s_lo, s_hi, 0.2, 1.0, 1.5, 10)
    assert slow[-1, 0, 0] > slow[-1, 0, 1] and box_blocked(slow[-1], np.zeros(4), 2.0, 15, 2)
    fast = reachable_boxes(np.array([0, 0, 0.45, 25.0]), u_lo, u_hi, s_lo, s_hi, 0.2, 1.0, 1.5, 10)
    assert np.all(fast[:, 0, 0] <= fast[:, 0, 1])  # at speed it can turn back within bounds


def test_two_overlapping_ellipses_cover_what_neither_covers_alone():
    # a 2 m × 1 m cell between two ellipses centred 1.5 m either side of its middle
    origin, e1, e2 = np.array([-1.0, -0.5]), np.array([2.0, 0.0]), np.array([0.0, 1.0])
    pair = np.array([[0.0, -1.5], [0.0, 1.5]])
    assert covered(origin, e1, e2, pair, l_a=10.0, l_b=1.8)
    assert not covered(origin, e1, e2, pair[:1], l_a=10.0, l_b=1.8)
    assert not covered(origin, e1, e2, pair[1:], l_a=10.0, l_b=1.8)
    assert not covered(origin, e1, e2, pair, l_a=10.0, l_b=1.8, depth=0)
    # a gap between them: never covered, however fine the cells
    assert not covered(origin, e1, e2, np.array([[0.0, -3.0], [0.0, 3.0]]), 10.0, 1.8, depth=5)


def test_coasting_stages_are_the_stages_whose_coasting_position_is_inside(rng):
    for _ in range(500):
        xi0 = np.array([0.0, rng.uniform(-3, 3), rng.uniform(-0.1, 0.1), rng.uniform(0, 35)])
        others = np.column_stack([rng.uniform(-30, 60, 2), rng.uniform(-4, 4, 2),
                                  rng.uniform(-0.1, 0.1, 2), rng.uniform(0, 35, 2)])  # fmt: skip
        t = 0.2 * np.arange(1, 11)[:, None]
        ev = xi0[:2] + xi0[3] * t * [np.cos(xi0[2]), np.sin(xi0[2])]  # (10, 2)
        expected = []
        for k in range(10):
            centres = others[:, :2] + others[:, 3:4] * t[k] * np.column_stack(
                (np.cos(others[:, 2]), np.sin(others[:, 2]))
            )
            z = (ev[k] - centres) / [15.0, 2.0]
            if np.any(np.hypot(z[:, 0], z[:, 1]) < 1 - MARGIN_SLACK):
                expected.append(k + 1)
        assert coasting_stages(xi0, others, 0.2, 15.0, 2.0, 10) == expected


def test_coasting_stages_lists_the_stages_inside():
    xi0 = np.array([0.0, 0.0, 0.0, 20.0])
    leader = np.array([30.0, 0.0, 0.0, 10.0])  # closing at 10 m/s, region 15 m
    # gap 30 − 2k m at stage k (T_s 0.2): inside once below 15 m, from k = 8
    assert coasting_stages(xi0, leader, 0.2, 15.0, 2.0, 10) == [8, 9, 10]
    assert coasting_stages(xi0, leader + np.array([0, 50, 0, 0]), 0.2, 15.0, 2.0, 10) == []


def test_a_blocked_plan_is_the_failed_plan_the_solvers_give():
    planner = StylePlanner(PAPER, 10, 1)
    xi0 = np.array([0.0, PAPER.y_ref, 0.0, 25.0])
    inside = np.array([[6.0, PAPER.y_ref, 0.0, 24.0]])
    style = DriverStyle(SMPC_WEIGHTS, risk=0.8)
    fast = planner.plan(xi0, inside, style, PAPER)
    assert planner.blocked == 1
    planner._blocked = lambda p, bounds: False  # the solvers' own answer
    slow = planner.plan(xi0, inside, style, PAPER)
    assert not fast.ok and not slow.ok
    assert fast.chance_active == slow.chance_active and fast.point is slow.point is None
    np.testing.assert_array_equal(fast.u0, slow.u0)


def test_profiles_are_the_same_with_and_without_the_certificate(paper_demo):
    # the TV drives into the EV's path for steps 8–13: the hard ellipse holds no plan there
    tv = paper_demo.tv.copy()
    ev = paper_demo.ev
    tv[8:14, 0] = ev[8:14, 0] + 4.0
    tv[8:14, 1] = ev[8:14, 1]
    tv[8:14, 2] = 0.0
    tv[8:14, 3] = ev[8:14, 3]
    demo = replace(paper_demo, tv=tv)
    style = DriverStyle(SMPC_WEIGHTS)
    risks = (0.5, 0.8, 0.99)
    certified = StylePlanner(PAPER, 10, 1)
    plain = StylePlanner(PAPER, 10, 1)
    plain._blocked = lambda p, bounds: False
    a = risk_profile(style, demo, risks, planner=certified)
    b = risk_profile(style, demo, risks, planner=plain)
    assert certified.blocked >= 6 * len(risks)  # every entered step, at every risk
    assert a == b


@pytest.mark.slow  # ≈ 30 s: two recorded lane changes identified twice
@pytest.mark.skipif(not DEFAULT_DATA_DIR.is_dir(), reason="../shared/data not beside the checkout")
def test_recorded_identifications_are_the_same_with_and_without_the_certificate(monkeypatch):
    # CATS lane changes another vehicle drives into the region of: the certificate answers
    # most of their failing rows (RESULTS §15); posteriors, residuals and verdicts are equal
    episodes = {e: d for e, _, d in recorded_episodes(str(DEFAULT_DATA_DIR), "cats")}
    library = DriverLibrary(style=DriverStyle(SMPC_WEIGHTS, time_gap=1.0, min_gap=5.0),
                            risks=(0.5, 0.7, 0.9, 0.99))  # fmt: skip
    demos = [recorded_view(episodes[e]) for e in ("AV-21-W_3_37277028", "AV-10-W_4_36189394")]
    before = sum(p.blocked for p in _PLANNERS.values())
    certified = [identify_driver([d], library) for d in demos]
    assert sum(p.blocked for p in _PLANNERS.values()) - before > 50
    monkeypatch.setattr(StylePlanner, "_blocked", lambda self, p, bounds: False)
    plain = [identify_driver([d], library) for d in demos]
    for a, b in zip(certified, plain, strict=True):
        assert a.posterior == b.posterior and a.density == b.density
        assert a.verdict == b.verdict
