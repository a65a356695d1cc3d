"""The prediction study's statistics by kind of episode (studies/prediction/summaries.py)."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.recorded.kinds import ALL_KINDS, STOP_AND_GO
from drivestyle.studies.prediction import predict_vehicle, summarise_records
from drivestyle.studies.prediction.summaries import (
    RATIO_GOALS,
    kind_groups,
    median_ratios,
    ratio_stats,
    report_set,
    shown_kinds,
    summarise_by_kind,
)


def _mixed(mixed_kinds):
    """The fixture's records at t_obs = 1 s."""
    return [r for r in mixed_kinds if r.t_obs == 1.0]


def test_a_kind_travels_from_the_demonstration_to_its_record(paper_demo, as_recorded):
    demo = as_recorded(paper_demo)
    demo = replace(demo, meta={**demo.meta, "kind": "approaching", "stop_and_go": True})
    (record,), skipped = predict_vehicle("ngsim", "e", demo, None, (1.0,), methods=("cv",))
    assert not skipped and record.kind == "approaching" and record.stop_and_go is True
    assert record.to_json()["kind"] == "approaching" and record.to_json()["stop_and_go"] is True
    (old,), _ = predict_vehicle("ngsim", "e", as_recorded(paper_demo), None, (1.0,),
                                methods=("cv",))  # fmt: skip
    assert (old.kind, old.stop_and_go) == ("lane_change", False)  # an older file: a lane change
    with pytest.raises(ValueError, match=r"episode kind 'merging' .* is not one of"):
        replace(record, kind="merging")


def test_records_of_different_kinds_summarise_by_kind(mixed_kinds):
    recs = _mixed(mixed_kinds)
    assert list(kind_groups(recs)) == ["lane_change", "car_following", STOP_AND_GO]
    by_kind = summarise_by_kind(recs, samples=200)
    keys = {(s.set, s.kind) for s in by_kind}
    assert keys == {("ngsim", "lane_change"), ("cats", "lane_change"), ("recorded", "lane_change"),
                    ("ngsim", "car_following"), ("recorded", "car_following"),
                    ("ngsim", STOP_AND_GO), ("recorded", STOP_AND_GO)}  # fmt: skip
    cf = next(s for s in by_kind
              if (s.set, s.kind, s.method) == ("recorded", "car_following", "mode"))  # fmt: skip
    assert cf.n == 5 and cf.n_units == 5 and cf.fde_median_m == pytest.approx(4.5)
    assert cf.stats["fde"].median == pytest.approx(4.5)
    assert cf.fde_reduction_vs_cv == pytest.approx(1 - 4.5 / 4.0)
    sg = next(s for s in by_kind if (s.set, s.kind, s.method) == ("recorded", STOP_AND_GO, "cv"))
    assert sg.n == 2 and sg.fde_mean_m == pytest.approx(2.5)
    # pooled: every kind together, a vehicle's two kinds one unit of the bootstrap
    pooled = next(s for s in summarise_records(recs, samples=200)
                  if (s.set, s.method) == ("recorded", "cv"))  # fmt: skip
    assert pooled.kind == ALL_KINDS and pooled.n == 12 and pooled.n_units == 8
    assert report_set([s.set for s in by_kind]) == "recorded"
    assert shown_kinds(by_kind) == [ALL_KINDS, "lane_change", "car_following", STOP_AND_GO]


def test_on_lane_changes_only_the_pooled_summaries_are_the_kinds_and_unchanged(mixed_kinds):
    """With one kind (the shipped benchmark), by kind = pooled, number for number."""
    recs = [r for r in mixed_kinds if r.kind == "lane_change"]
    pooled = summarise_records(recs, samples=300)
    by_kind = summarise_by_kind(recs, samples=300)
    assert [replace(s, kind=ALL_KINDS) for s in by_kind] == pooled
    assert {s.kind for s in pooled} == {ALL_KINDS} and {s.kind for s in by_kind} == {"lane_change"}
    assert shown_kinds(by_kind) == ["lane_change"]  # the pooled numbers would repeat it
    js = pooled[0].to_json()
    assert js["kind"] == ALL_KINDS and js["t_obs_s"] == 1.0 and "stats" in js


def test_simulated_vehicles_are_not_grouped_by_kind(mixed_kinds, record_of_kind):
    recs = [record_of_kind("simulated", "s0", "lane_change", 3.0, 1.0), *mixed_kinds[:2]]
    assert {s.set for s in summarise_by_kind(recs, samples=50)} == {"ngsim"}
    assert {r.set for r in ratio_stats(recs, samples=50)} == {"ngsim"}
    assert report_set(["simulated"]) is None and report_set(["simulated", "cats"]) == "cats"


def test_the_median_ratio_and_its_interval_on_a_known_case():
    # two vehicles, ratios 1 and 3: replicates draw {1,1}, {1,3}, {3,3} → medians 1, 2, 3
    ((med, lo, hi, n, n_units),) = median_ratios([2.0, 9.0], [2.0, 3.0], ["a", "b"], 4000)
    assert (med, lo, hi, n, n_units) == (2.0, 1.0, 3.0, 2, 2)
    # the vehicle is resampled, not the record: a's three records come and go together
    ((med, lo, hi, n, n_units),) = median_ratios(
        [1.0, 1.0, 1.0, 3.0], [1.0] * 4, list("aaab"), 4000
    )
    assert (med, lo, hi, n, n_units) == (1.0, 1.0, 3.0, 4, 2)  # P(only b drawn) = 1/4
    # columns share the replicates; a reference of 0 has nothing to reduce: left out
    values = [[1.0, 2.0], [2.0, 2.0], [5.0, 2.0]]
    both = median_ratios(values, [[2.0, 1.0], [4.0, 1.0], [0.0, 1.0]], list("abc"), 100)
    assert both == [(0.5, 0.5, 0.5, 2, 2), (2.0, 2.0, 2.0, 3, 3)]
    assert np.isnan(median_ratios([1.0], [0.0], ["a"], 10)[0][0])
    # paired: a method's ratio and twice it move together, replicate by replicate
    rng = np.random.default_rng(3)
    cv = rng.uniform(1.0, 5.0, 30)
    values = np.column_stack([cv * rng.uniform(0.5, 1.5, 30)] * 2) * [1.0, 2.0]
    one, two = median_ratios(values, cv, [f"v{i // 3}" for i in range(30)], 500)
    assert two[:3] == pytest.approx([2 * x for x in one[:3]])


def test_ratio_stats_per_kind_and_pooled_with_the_goals(mixed_kinds):
    ratios = ratio_stats(_mixed(mixed_kinds), samples=300)
    got = {(r.set, r.kind, r.method, r.metric): r for r in ratios}
    assert all(r.method == "mode" for r in ratios)  # every method but the reference
    lc = got["recorded", "lane_change", "mode", "fde"]
    each = [(6.0 + i) / (10.0 + i) for i in range(4)] + [7.0 / (8.0 + i) for i in range(3)]
    expect = np.median(each)
    assert lc.median == pytest.approx(expect) and lc.n == 7 and lc.n_units == 7
    assert lc.lo <= lc.median <= lc.hi and lc.goal == RATIO_GOALS["fde"]
    lat = got["recorded", "lane_change", "mode", "fde_lat"]  # the lateral goal: lane changes
    assert lat.median == pytest.approx(expect / 2) and lat.goal == RATIO_GOALS["fde_lat"]
    assert lat.below_goal is True and lat.to_json()["below_goal"] is True
    assert ("recorded", "car_following", "mode", "fde_lat") not in got
    assert got["recorded", "car_following", "mode", "fde"].goal is None  # no goal set there
    pooled = got["recorded", ALL_KINDS, "mode", "fde"]
    assert pooled.n == 12 and pooled.n_units == 8 and pooled.goal == RATIO_GOALS["fde"]
    assert got["recorded", STOP_AND_GO, "mode", "fde"].n == 2
