"""The held-out identification evaluation: typed records and summary, their JSON, Markdown."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.agents.studies.ceiling import CeilingSummary, References
from drivestyle.agents.studies.identification import evaluate_identification, noise_curve_json
from drivestyle.agents.studies.reports import (
    evaluation_markdown,
    noise_markdown,
    references_markdown,
)
from drivestyle.irl.identification import DEFAULT_SCORER, SCORERS

RECORD_KEYS = {"risk", "scenario", "grid", "identify_s", "informative", "min_s_e"}
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
