"""The speed-scaled safety region of the style class (DESIGN §18) and the refined risk
profile (DESIGN §18)."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.envs.scenario import PAPER
from drivestyle.irl.driver.driver_style import DriverStyle, DriverStyleError
from drivestyle.irl.driver.risk_profile import REFINE_PER_SIDE, refined_profile, risk_profile
from drivestyle.irl.driver.style_planner import StylePlanner, planner_for
from drivestyle.planning.description import nlp_parameters

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)


def test_the_region_grows_with_speed_and_defaults_to_the_scenarios_ellipse():
    fixed = DriverStyle(SMPC_WEIGHTS)
    assert fixed.region(30.0, PAPER) == PAPER.l_a  # the SMPC expert's ellipse
    headway = DriverStyle(SMPC_WEIGHTS, time_gap=1.5, min_gap=4.0)
    assert headway.region(20.0, PAPER) == pytest.approx(4.0 + 1.5 * 20.0)
    assert headway.region(-3.0, PAPER) == pytest.approx(4.0)  # reversing is standstill
    back = DriverStyle.from_json(headway.to_json())
    assert back == headway
    old = {k: v for k, v in fixed.to_json().items() if k not in ("time_gap", "min_gap")}
    assert DriverStyle.from_json(old) == fixed  # a style.json from before the region


@pytest.mark.parametrize(
    ("field", "value"), [("time_gap", -0.1), ("time_gap", 9.0), ("min_gap", 0.2), ("min_gap", 1e3)]
)
def test_a_region_outside_the_class_is_refused(field, value):
    with pytest.raises(DriverStyleError, match=field):
        DriverStyle(SMPC_WEIGHTS, **{field: value})


def test_the_parametric_nlp_takes_the_region_and_only_it_does():
    xi0, tv = np.zeros(4), np.ones((1, 4))
    p = nlp_parameters(xi0, tv, 5.4, 30.0, 0.5, SMPC_WEIGHTS, 12.0)
    assert p[-1] == 12.0 and p.size == 4 + 4 + 3 + 5 + 1
    with pytest.raises(ValueError, match="semi-major axis l_a"):
        nlp_parameters(xi0, tv, 5.4, 30.0, 0.5, SMPC_WEIGHTS)
    with pytest.raises(ValueError, match="parametric"):
        nlp_parameters(xi0, tv, 5.4, 30.0, 0.5, None, 12.0)


def test_one_planner_serves_every_region():
    assert planner_for(PAPER, 10, 1) is planner_for(replace(PAPER, l_a=40.0), 10, 1)


def test_a_longer_time_gap_keeps_a_longer_distance_to_a_slower_leader():
    # the EV already in the target lane at 25 m/s, 35 m behind a vehicle there at 20 m/s
    sc = PAPER
    planner = StylePlanner(sc, 10, 1)
    xi0 = np.array([0.0, sc.y_ref, 0.0, 25.0])
    leader = np.array([[35.0, sc.y_ref, 0.0, 20.0]])
    short = DriverStyle(SMPC_WEIGHTS, risk=0.5, time_gap=0.5, min_gap=4.0)  # 16.5 m region
    long = replace(short, time_gap=2.0)  # 54 m: already inside, must brake
    a_short = planner.plan(xi0, leader, short, sc).u0[0]
    a_long = planner.plan(xi0, leader, long, sc).u0[0]
    assert a_long < a_short - 0.5


def test_the_refined_profile_adds_risks_beside_the_minimum_and_keeps_the_grid(paper_demo):
    style = DriverStyle(SMPC_WEIGHTS)
    coarse = risk_profile(style, paper_demo)
    fine = refined_profile(style, paper_demo)
    assert set(coarse.risks) < set(fine.risks)
    assert len(fine.risks) == len(coarse.risks) + 2 * REFINE_PER_SIDE
    assert list(fine.risks) == sorted(fine.risks)
    by_risk = dict(zip(fine.risks, fine.ssr, strict=True))
    for p, s in zip(coarse.risks, coarse.ssr, strict=True):
        assert by_risk[p] == pytest.approx(s, rel=1e-9, abs=1e-12)
    j = int(np.argmin(coarse.ssr))
    lo, hi = coarse.risks[max(j - 1, 0)], coarse.risks[min(j + 1, len(coarse.risks) - 1)]
    added = sorted(set(fine.risks) - set(coarse.risks))
    assert all(lo < p < hi for p in added)
    # the paper demonstration is SMPC(0.7): its refined minimum stays at 0.7
    assert fine.risks[int(np.argmin(fine.ssr))] == pytest.approx(0.7)


@pytest.mark.slow  # ≈ 40 s: one learning run over 7 coordinates
def test_learning_recovers_the_region_a_driver_keeps(paper_demo):
    from drivestyle.irl.driver.driver_learning import learn_driver
    from drivestyle.irl.driver.driver_style import reproduce

    truth = DriverStyle(SMPC_WEIGHTS, risk=0.7, time_gap=0.8, min_gap=6.0)  # 30 m at 30 m/s
    rep = reproduce(truth, paper_demo)
    assert rep.failures == 0
    demo = replace(paper_demo, ev=rep.states, u=rep.inputs)
    fit = learn_driver([demo], initial=DriverStyle(SMPC_WEIGHTS, risk=0.7), fit_region=True,
                       screen=1, restarts=1, max_iter=30)  # fmt: skip
    # at one speed level only s_0 + T·v is seen: the region at the driven speeds is learned
    v = float(np.median(demo.ev[:, 3]))
    sc = demo.scenario
    assert fit.style.region(v, sc) == pytest.approx(truth.region(v, sc), abs=1.0)
    assert fit.style.region(v, sc) > sc.l_a + 10  # far from the fixed ellipse it started at
    assert fit.residual_rms < 0.1
