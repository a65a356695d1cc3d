"""The prediction comparison (studies/prediction/): a tiny run, summaries, goals."""

import numpy as np
import pytest

from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.prediction.methods import AMORTIZED_METHODS, METHODS
from drivestyle.studies.prediction import (
    GOALS,
    RISK_RANGE,
    T_OBS,
    TEST_SEED,
    VALIDATION_SEED,
    MethodSummary,
    PredictionRecord,
    bootstrap_stats,
    draw_simulated,
    evaluate_prediction,
    example_record,
    goal_checks,
    predict_vehicle,
    spanning_tracks,
    summarise_records,
)

RUN = [m for m in METHODS if m not in AMORTIZED_METHODS]  # no posterior given
LIBRARY = DriverLibrary(
    DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
)


def test_the_validation_and_test_seeds_differ():
    assert VALIDATION_SEED != TEST_SEED


@pytest.fixture(scope="module")
def study():
    return evaluate_prediction(LIBRARY, 2, VALIDATION_SEED, data_dir=None, t_obs=(1.0,))


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_a_tiny_run_has_one_record_per_vehicle_and_t_obs(study):
    assert [v.vehicle_id for v in study.vehicles] == ["random-0", "traffic-0"]
    assert all(RISK_RANGE[0] <= v.risk <= RISK_RANGE[1] for v in study.vehicles)
    assert len(study.records) + len(study.skipped) == 2
    for r in study.records:
        assert r.set == "simulated" and r.t_obs == 1.0
        assert list(r.fde_m) == RUN  # the oracle too: the risk is known
        assert r.true_risk in {v.risk for v in study.vehicles}
    assert len(study.tracks) == 2 and study.tracking.n == 2
    js = study.to_json()
    assert js["seed"] == VALIDATION_SEED and js["n_records"] == len(study.records)
    assert {"summaries", "goal_checks", "tracking_summary", "records", "skipped"} <= set(js)


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_summaries_are_consistent_with_the_records(study):
    recs = study.records
    for method in RUN:
        s = study.summary("simulated", 1.0, method)
        assert s is not None and s.n == len(recs)
        fde = [r.fde_m[method] for r in recs]
        assert s.fde_mean_m == pytest.approx(np.mean(fde))
        assert s.fde_median_m == pytest.approx(np.median(fde))
        assert s.ade_mean_m == pytest.approx(np.mean([r.ade_m[method] for r in recs]))
        cv = np.mean([r.fde_m["cv"] for r in recs])
        assert s.fde_reduction_vs_cv == pytest.approx(1 - np.mean(fde) / cv)
    assert study.summary("simulated", 1.0, "cv").fde_reduction_vs_cv == pytest.approx(0.0)
    goals = {(g.goal, g.method) for g in study.goals}
    assert goals == {(g, m) for g in ("simulated_vs_cv", "simulated_vs_oracle")
                     for m in ("mode", "mixture")}  # fmt: skip


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_the_tracking_record_follows_the_interval(study):
    for tr in study.tracks:
        widths = np.asarray(tr.hi) - np.asarray(tr.lo)
        narrow = np.flatnonzero(widths < 0.2)
        assert tr.t_narrow == (None if narrow.size == 0 else pytest.approx(tr.t[narrow[0]]))
        assert len(tr.t) == len(tr.mean) == len(tr.update_ms)
    assert spanning_tracks(study.tracks, 4) == sorted(study.tracks, key=lambda r: r.true_risk)
    assert example_record(study) in study.records


def _rec(set_name, fde, t=1.0):
    return PredictionRecord(set_name, "v", t, 3.0, None, None, 0.7, dict(fde), dict(fde))


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_goals_are_checked_against_their_thresholds():
    recs = [
        _rec("simulated", {"cv": 10.0, "mode": 6.0, "mixture": 8.0, "oracle": 5.0}),
        _rec("ngsim", {"cv": 2.0, "mode": 1.6, "mixture": 1.8}),
        _rec("cats", {"cv": 2.0, "mode": 1.4, "mixture": 1.9}),
    ]
    summaries = summarise_records(recs)
    assert {s.set for s in summaries} == {"simulated", "ngsim", "cats", "recorded"}
    pooled = next(s for s in summaries if s.set == "recorded" and s.method == "mode")
    assert pooled.fde_reduction_vs_cv == pytest.approx(1 - 3.0 / 4.0)
    mode = next(s for s in summaries if s.set == "simulated" and s.method == "mode")
    assert isinstance(mode, MethodSummary)
    assert mode.fde_ratio_to_oracle == pytest.approx(1.2)
    assert mode.oracle_gain_share == pytest.approx(0.8)
    met = {(g.goal, g.set, g.method): g.met for g in goal_checks(summaries)}
    assert met[("simulated_vs_cv", "simulated", "mode")]  # 40 % ≥ 30 %
    assert not met[("simulated_vs_cv", "simulated", "mixture")]  # 20 %
    assert met[("simulated_vs_oracle", "simulated", "mode")]  # 1.2 ≤ 1.25
    assert not met[("simulated_vs_oracle", "simulated", "mixture")]  # 1.6
    assert met[("recorded_vs_cv", "ngsim", "mode")]  # 20 % ≥ 15 %
    assert not met[("recorded_vs_cv", "ngsim", "mixture")]  # 10 %
    assert GOALS["recorded_vs_cv"] == 0.15
    assert met[("recorded_vs_cv", "recorded", "mode")]  # 25 %
    assert not met[("recorded_vs_cv", "recorded", "mixture")]  # 1 − 3.7 / 4 < 15 %


def test_draw_simulated_is_deterministic_and_refuses_zero():
    a = draw_simulated(3, VALIDATION_SEED)
    assert a == draw_simulated(3, VALIDATION_SEED)
    assert [v.scenario is None for v in a] == [False, False, True]
    with pytest.raises(ValueError, match=">= 1"):
        draw_simulated(0, VALIDATION_SEED)


def test_the_librarys_training_seed_is_refused():
    lib = DriverLibrary(LIBRARY.style, LIBRARY.risks, meta={"seed": 5})
    with pytest.raises(ValueError, match="training seed"):
        evaluate_prediction(lib, 1, 5, data_dir=None)


def test_observed_times_are_checked_before_any_vehicle_is_simulated(monkeypatch):
    from drivestyle.studies.prediction import study

    assert study.check_observed_times([1.0, 1.0, 2.0, 1.0]) == (1.0, 2.0)

    def simulated(*args, **kwargs):
        raise AssertionError("simulated before checking the observed times")

    monkeypatch.setattr(study, "draw_simulated", simulated)
    for bad, match in (((100.0,), "no vehicle of this run"), ((0.3,), "whole number"),
                       ((float("nan"),), "finite")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            study.evaluate_prediction(LIBRARY, 2, 5, None, bad, workers=1)


def test_bootstrap_resamples_vehicles_with_a_fixed_seed():
    values = np.array([[1.0, 10.0], [1.0, 12.0], [5.0, 0.0], [3.0, 1.0]])
    units = ["a", "a", "b", "c"]
    stats = bootstrap_stats(values, units, samples=500, seed=1)
    assert stats == bootstrap_stats(values, units, samples=500, seed=1)
    assert stats[0].mean == pytest.approx(2.5) and stats[0].median == pytest.approx(2.0)
    for st in stats:
        assert st.mean_lo <= st.mean <= st.mean_hi and st.median_lo <= st.median_hi
    # a replicate takes every record of a drawn vehicle: the mean stays within the units' means
    assert stats[0].mean_lo >= 1.0 and stats[0].mean_hi <= 5.0
    one = bootstrap_stats(values[:2], units[:2], samples=50, seed=1)[0]
    assert one.mean_lo == one.mean_hi == 1.0  # one vehicle: nothing to resample


def test_cv_ca_and_physics_predictions_do_not_read_the_future(
    paper_demo, as_recorded, change_the_future
):
    demo = as_recorded(paper_demo)
    methods = ("cv", "ca", "physics", "joint_physics")
    for t_obs in T_OBS:
        k = round(t_obs / demo.scenario.dt)
        a = predict_vehicle("ngsim", "e", demo, LIBRARY, (t_obs,), methods=methods)
        b = predict_vehicle("ngsim", "e", change_the_future(demo, k), LIBRARY, (t_obs,),
                            methods=methods)  # fmt: skip
        pa, pb = a[0][0].prediction, b[0][0].prediction
        for m in methods:
            assert np.array_equal(pa.methods[m].xy, pb.methods[m].xy), (t_obs, m)
        assert not np.array_equal(pa.actual, pb.actual)  # the scored truth did change


@pytest.mark.slow  # the style methods' rollouts (≈ 10–20 s)
def test_no_method_reads_the_future(paper_demo, as_recorded, change_the_future):
    demo = as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    a = predict_vehicle("ngsim", "e", demo, LIBRARY, (2.0,))
    b = predict_vehicle("ngsim", "e", change_the_future(demo, k), LIBRARY, (2.0,))
    assert a[1] == b[1] == []
    pa, pb = a[0][0].prediction, b[0][0].prediction
    assert list(pa.methods) == [m for m in RUN if m != "oracle"]
    for m in pa.methods:
        assert np.array_equal(pa.methods[m].xy, pb.methods[m].xy), m
