"""The held-out identification evaluation: typed records and summary, their JSON, Markdown."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER, SCORERS
from drivestyle.studies.identification import (
    CeilingSummary,
    References,
    evaluate_identification,
    evaluation_markdown,
    noise_curve_json,
    noise_markdown,
    references_markdown,
)

RECORD_KEYS = {"risk", "scenario", "grid", "identify_s", "constraint_binds", "min_s_e"}
RECORD_KEYS |= {"trigger_fired", "scores", "posterior"}
RECORD_KEYS |= {f"{s}_{k}" for s in SCORERS for k in ("estimate", "interpolated", "interval")}
RECORD_KEYS |= {f"{s}_covered" for s in SCORERS}


@pytest.fixture(scope="module")
def evaluation(style_library):
    scenarios = draw_interactive_scenarios(2, seed=321)
    by_risk = generate_demonstrations([0.5, 0.725, 0.95], scenarios, workers=1)
    demos = [d for ds in by_risk.values() for d in ds]
    flat = demos[0].ev.copy()
    flat[:, 1] = flat[0, 1]  # no lane change: refused, becomes a record with the error
    demos.append(replace(demos[0], ev=flat))
    return evaluate_identification(style_library, demos, style_library.risks, workers=1)


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_records_are_typed_per_scorer(evaluation):
    records = evaluation.records
    assert len(records) == 7 and [r.ok for r in records] == [True] * 6 + [False]
    assert "no lane change" in records[-1].error
    for r in records[:6]:
        assert set(r.by_scorer) == set(SCORERS)
        assert r.grid == (r.risk in (0.5, 0.95))
        for s in SCORERS:
            assert r.by_scorer[s].true_risks == (r.risk,)
            assert r.correct(s) == (r.estimate(s) == r.risk)


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_the_json_keeps_its_keys_and_the_summary_counts(evaluation):
    js = evaluation.to_json()
    assert set(js["records"][0]) == RECORD_KEYS
    assert set(js["records"][-1]) == {"risk", "scenario", "grid", "identify_s", "error"}
    sm = js["summary"]
    assert (sm["n"], sm["n_failed"], sm["n_grid"], sm["n_between"]) == (7, 1, 4, 2)
    for s in SCORERS:
        acc = np.mean([r.correct(s) for r in evaluation.records if r.ok and r.grid])
        assert sm[s]["grid_accuracy"] == pytest.approx(acc)
        assert 0 <= sm[s]["interval_coverage"] <= 1
    assert sm["pooled"]["n_pool"] == 3 and sm["pooled"]["n_pools"] == 0  # 2 demos per risk
    curve = noise_curve_json([evaluation])
    assert curve == [{"noise_sigma_m": 0.0, **sm[DEFAULT_SCORER]}]


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_markdown_is_written_from_the_typed_results(evaluation):
    refs = References(CeilingSummary(1.0, 0.5, None), {})
    extra = noise_markdown({"reactive": [evaluation]}) + references_markdown(
        refs, {"reactive": evaluation}
    )
    md = evaluation_markdown({"reactive": evaluation}, extra)
    assert "reactive 1 of 7" in md
    assert all(f"| reactive | {s} |" in md for s in SCORERS)
    assert "| reactive | 0 |" in md  # σ = 0 in the noise table
    assert "(0.50 of demos tied with a neighbour; untied —)" in md


# ---------------------------------------------------------------------------- driver libraries
from drivestyle.envs.scenario import get_scenario  # noqa: E402
from drivestyle.envs.tracking import observe  # noqa: E402
from drivestyle.irl.driver.driver_style import DriverStyle  # noqa: E402
from drivestyle.irl.identification.library import DriverLibrary  # noqa: E402
from drivestyle.irl.identification.posterior import grid_estimate  # noqa: E402
from drivestyle.studies.identification import (  # noqa: E402
    CONTINUOUS_RANGE,
    IDENTIFIABLE_GAP_M,
    ceiling_identify,
    continuous_demonstrations,
    draw_continuous_risks,
    driver_evaluation_markdown,
    pooled_accuracy,
)
from drivestyle.studies.identification.study import observation  # noqa: E402

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The expert's own cost: a driver library with it must identify SMPC demonstrations."""
DRIVER_GRID = (0.5, 0.7, 0.9)


def test_continuous_risks_are_uniform_seeded_and_leave_the_scenario_draws_alone():
    a = draw_continuous_risks(4, 3, seed=500)
    assert a == draw_continuous_risks(4, 3, seed=500) != draw_continuous_risks(4, 3, seed=2000)
    assert len(a) == 4 and all(len(r) == 3 for r in a)
    lo, hi = CONTINUOUS_RANGE
    assert all(lo <= p <= hi for r in a for p in r)
    assert draw_continuous_risks(3, 0, seed=1) == [[], [], []]


@pytest.fixture(scope="module")
def driver_evaluation():
    """SMPC demonstrations in the paper scenario: the grid risks, one continuous risk, and
    a driver library holding the expert's own cost (it must identify them)."""
    sc = get_scenario("paper")
    by_risk = generate_demonstrations(DRIVER_GRID, [sc], workers=1)
    demos = [by_risk[p][0] for p in DRIVER_GRID]
    demos += continuous_demonstrations([sc], [[0.8]], workers=1)
    library = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=DRIVER_GRID)
    evaluation = evaluate_identification(library, demos, DRIVER_GRID, workers=1, ceiling=True)
    return library, demos, evaluation


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_a_driver_library_with_the_experts_cost_identifies_its_demonstrations(driver_evaluation):
    _, _, evaluation = driver_evaluation
    records = evaluation.records
    assert evaluation.scorer == "likelihood"
    assert [r.ok for r in records] == [True] * 4
    assert [r.grid for r in records] == [True, True, True, False]
    assert [r.continuous for r in records] == [False, False, False, True]
    for r in records:
        assert set(r.by_scorer) == {"likelihood"}  # no scorer loop
        assert r.profile is not None and r.profile.n_active > 0
        ident = r.by_scorer["likelihood"]
        assert abs(ident.risk_interpolated - r.risk) < 0.03
        assert ident.covers(r.risk)
    assert all(r.correct("likelihood") for r in records[:3])
    # the profile computed once is the one the identification used
    assert records[0].scores.scores["likelihood"] == pytest.approx(
        np.interp(DRIVER_GRID, records[0].profile.risks, records[0].profile.ssr)
    )
    sm = evaluation.summary
    m = sm.by_scorer["likelihood"]
    assert set(sm.by_scorer) == {"likelihood"}
    assert (sm.n, sm.n_grid, sm.n_continuous, sm.n_between) == (4, 3, 1, 1)
    assert m.grid_accuracy == 1.0 and m.grid_coverage == 1.0
    assert m.continuous_mae_interpolated == pytest.approx(
        abs(records[3].by_scorer["likelihood"].risk_interpolated - 0.8)
    )
    assert m.between_mae_interpolated is None  # the only off-grid demo is continuous
    assert sm.transfer_own_risk_best is None and sm.own_style_rmse_y_median_m is None


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_the_path_ceiling_is_the_re_simulating_ceiling(driver_evaluation):
    _, demos, evaluation = driver_evaluation
    rec = evaluation.records[1]  # p = 0.7, both neighbours on the grid
    assert rec.ceiling is not None and evaluation.records[3].ceiling is None
    resim = ceiling_identify(demos[1], DRIVER_GRID)
    assert rec.ceiling.estimate == resim.risk_estimate == 0.7
    for p in DRIVER_GRID:
        assert rec.ceiling.distances[p] == pytest.approx(resim.distances[p], abs=1e-9)
    gap = min(rec.ceiling.distances[0.5], rec.ceiling.distances[0.9])
    assert rec.ceiling.neighbour_gap_m == pytest.approx(gap)
    assert rec.identifiable == (gap >= IDENTIFIABLE_GAP_M)
    c = evaluation.summary.ceiling
    assert c is not None and c.grid_accuracy == 1.0
    assert c.n_identifiable == sum(r.identifiable for r in evaluation.records)


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_driver_records_json_pooling_and_markdown(driver_evaluation):
    library, _, evaluation = driver_evaluation
    js = evaluation.to_json()
    rec = js["records"][1]
    assert {"likelihood_estimate", "likelihood_interval", "likelihood_covered"} <= set(rec)
    assert {"ceiling_estimate", "ceiling_correct", "neighbour_gap_m", "identifiable"} <= set(rec)
    assert len(rec["risk_profile"]["ssr"]) == len(rec["risk_profile"]["risks"])
    assert "continuous" not in rec and js["records"][3]["continuous"] is True
    assert js["summary"]["scorer"] == "likelihood" and "ceiling" in js["summary"]
    curve = noise_curve_json([evaluation])
    assert (
        curve[0]["grid_accuracy_identifiable"]
        == js["summary"]["likelihood"]["grid_accuracy_identifiable"]
    )
    assert curve[0]["ceiling"]["grid_accuracy"] == 1.0
    # a pool of one is the single demonstration; pooling needs the library
    one = pooled_accuracy(evaluation.records, DRIVER_GRID, 1, "likelihood", library)
    assert one.n_pools == 3 and one.pooled_accuracy == one.single_accuracy == 1.0
    with pytest.raises(ValueError, match="needs the library"):
        pooled_accuracy(evaluation.records, DRIVER_GRID, 1, "likelihood")
    md = driver_evaluation_markdown([evaluation])
    assert "## Driver library" in md
    assert "| 0 | 1.00 (3) | 1.00 |" in md  # σ, grid accuracy (n), ceiling


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_the_exacts_grid_risk_is_the_one_rule_every_posterior_is_scored_by(driver_evaluation):
    library, _, evaluation = driver_evaluation
    for r in evaluation.records:
        ident = r.by_scorer["likelihood"]
        rule = grid_estimate(np.array(ident.density_risks), np.array(ident.density), library.risks)
        assert rule == ident.risk_estimate


def test_every_identification_of_an_evaluation_reads_one_observation(paper_demo):
    library = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=DRIVER_GRID)
    assert observation(paper_demo, library, 0.0, 7) is paper_demo  # no noise: as it is
    seen = observation(paper_demo, library, 0.1, 7)
    again = observation(paper_demo, library, 0.1, 7)
    want = observe(paper_demo, 0.1, np.random.default_rng(7))
    np.testing.assert_array_equal(seen.ev, want.ev)
    np.testing.assert_array_equal(seen.ev, again.ev)
    assert not np.array_equal(seen.ev, observation(paper_demo, library, 0.1, 8).ev)
    tracked = replace(library, meta={"observation": "tracked"})  # sees every demo tracked
    np.testing.assert_array_equal(
        observation(paper_demo, tracked, 0.0, 7).ev,
        observe(paper_demo, 0.0, np.random.default_rng(7)).ev,
    )
