"""The prediction comparison (studies/prediction.py): a tiny run, summaries, goals."""

import math
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.driver.driver_style import DriverStyle, expert_style
from drivestyle.irl.forecast import METHODS
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.planning.description import SMPCConfig
from drivestyle.studies.prediction import (
    DEFAULT_DATA_DIR,
    GOALS,
    RISK_RANGE,
    SPLIT_FILE,
    SPLITS,
    T_OBS,
    TEST_SEED,
    VALIDATION_SEED,
    MethodSummary,
    PredictionRecord,
    SplitRow,
    benchmark_split,
    bootstrap_stats,
    draw_simulated,
    evaluate_prediction,
    example_record,
    goal_checks,
    observed_view,
    oracle_style,
    predict_vehicle,
    read_split,
    spanning_tracks,
    summarise_records,
    write_split,
)

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
        assert list(r.fde_m) == list(METHODS)  # the oracle too: the risk is known
        assert r.true_risk in {v.risk for v in study.vehicles}
    assert len(study.tracks) == 2 and study.tracking.n == 2
    js = study.to_json()
    assert js["seed"] == VALIDATION_SEED and js["n_records"] == len(study.records)
    assert {"summaries", "goal_checks", "tracking_summary", "records", "skipped"} <= set(js)


@pytest.mark.slow  # a tiny end-to-end study run (module fixture): CI runs it
def test_summaries_are_consistent_with_the_records(study):
    recs = study.records
    for method in METHODS:
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


def test_the_observed_scenario_uses_the_observed_speeds_only(paper_demo):
    demo = _as_recorded(paper_demo)
    sc = observed_view(demo, 1.0)[1]
    k = round(1.0 / demo.scenario.dt)
    assert sc.v_ref == pytest.approx(max(np.percentile(demo.ev[: k + 1, 3], 90), 1.0))
    changed = demo.ev.copy()
    changed[k + 1 :, 3] += 10.0  # the future is not looked at
    assert observed_view(replace(demo, ev=changed), 1.0)[1].v_ref == sc.v_ref


def test_the_recorded_bounds_are_chosen_from_the_observed_heading_only(paper_demo):
    from drivestyle.recorded.real_data import RECORDED_PHI_MAX

    demo = _as_recorded(paper_demo)
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


def test_oracle_style_is_the_experts(paper_demo):
    assert oracle_style(paper_demo.meta) == expert_style(SMPCConfig(risk=0.7))
    assert oracle_style({"episode_id": "x"}) is None


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
    from drivestyle.studies import prediction as study

    assert study.check_observed_times([1.0, 1.0, 2.0, 1.0]) == (1.0, 2.0)

    def simulated(*args, **kwargs):
        raise AssertionError("simulated before checking the observed times")

    monkeypatch.setattr(study, "draw_simulated", simulated)
    for bad, match in (((100.0,), "no vehicle of this run"), ((0.3,), "whole number"),
                       ((float("nan"),), "finite")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            study.evaluate_prediction(LIBRARY, 2, 5, None, bad, workers=1)


# ---------------------------------------------------------------------------- the benchmark
DATA = DEFAULT_DATA_DIR
needs_data = pytest.mark.skipif(
    not (DATA / "ngsim" / "episodes.csv").is_file(), reason="the shipped datasets are absent"
)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
@needs_data
def test_the_committed_split_is_the_functions_and_no_vehicle_is_in_two_splits():
    rows = benchmark_split(DATA)
    assert read_split(SPLIT_FILE) == rows
    split_of: dict[str, set[str]] = {}
    for r in rows:
        split_of.setdefault(r.vehicle_id, set()).add(r.split)
    assert all(len(s) == 1 for s in split_of.values())
    assert {r.split for r in rows} == set(SPLITS)
    assert {r.dataset for r in rows if r.split == "test"} == {"ngsim", "cats"}
    assert len({r.episode_id for r in rows}) == len(rows)


def test_write_and_read_split_round_trip(tmp_path):
    rows = [
        SplitRow("ngsim", "e1", "ngsim:i80:1", "train"),
        SplitRow("cats", "e2", "cats:AV", "test"),
    ]
    write_split(rows, tmp_path / "s.csv")
    assert read_split(tmp_path / "s.csv") == rows
    (tmp_path / "bad.csv").write_text("dataset,episode_id,vehicle_id,split\nngsim,e,v,holdout\n")
    with pytest.raises(ValueError, match="malformed"):
        read_split(tmp_path / "bad.csv")


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


def _as_recorded(demo):
    """A simulated demonstration presented as a recorded episode (observed_view applies)."""
    rng = np.random.default_rng(0)
    others = np.repeat(demo.tv[:, None, :], 2, axis=1).copy()
    others[:, 0, 0] += 30.0  # a leader in the target lane, speed varying (as recorded)
    others[:, 1, 0] += 60.0
    others[:, 1, 1] -= demo.scenario.lane_width
    others[:, :, 3] += 0.01 * rng.standard_normal(others.shape[:2])
    meta = {**demo.meta, "episode_id": "sim-as-recorded"}
    return replace(demo, meta=meta, others=others, origin="recorded")


def _change_the_future(demo, k):
    ev, tv, others = demo.ev.copy(), demo.tv.copy(), demo.other_vehicles.copy()
    ev[k + 1 :, 0] += np.linspace(0, 30, demo.n - k - 1)
    ev[k + 1 :, 1] -= 2.0
    ev[k + 1 :, 3] *= 0.5
    tv[k + 1 :, :2] += 7.0
    others[k + 1 :, :, 0] -= 12.0
    others[k + 1 :, :, 3] += 5.0
    return replace(demo, ev=ev, tv=tv, others=others)


def test_the_observed_view_does_not_read_the_future(paper_demo):
    demo = _as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    seen, sc = observed_view(demo, 2.0)
    seen2, sc2 = observed_view(_change_the_future(demo, k), 2.0)
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


def test_cv_ca_and_physics_predictions_do_not_read_the_future(paper_demo):
    demo = _as_recorded(paper_demo)
    for t_obs in T_OBS:
        k = round(t_obs / demo.scenario.dt)
        a = predict_vehicle("ngsim", "e", demo, LIBRARY, (t_obs,), methods=("cv", "ca", "physics"))
        b = predict_vehicle("ngsim", "e", _change_the_future(demo, k), LIBRARY, (t_obs,),
                            methods=("cv", "ca", "physics"))  # fmt: skip
        pa, pb = a[0][0].prediction, b[0][0].prediction
        for m in ("cv", "ca", "physics"):
            assert np.array_equal(pa.methods[m].xy, pb.methods[m].xy), (t_obs, m)
        assert not np.array_equal(pa.actual, pb.actual)  # the scored truth did change


@pytest.mark.slow  # the style methods' rollouts (≈ 10–20 s)
def test_no_method_reads_the_future(paper_demo):
    demo = _as_recorded(paper_demo)
    k = round(2.0 / demo.scenario.dt)
    a = predict_vehicle("ngsim", "e", demo, LIBRARY, (2.0,))
    b = predict_vehicle("ngsim", "e", _change_the_future(demo, k), LIBRARY, (2.0,))
    assert a[1] == b[1] == []
    pa, pb = a[0][0].prediction, b[0][0].prediction
    assert list(pa.methods) == [m for m in METHODS if m != "oracle"]
    for m in pa.methods:
        assert np.array_equal(pa.methods[m].xy, pb.methods[m].xy), m


@needs_data
@pytest.mark.slow  # extracts the whole CATS sample (≈ 7 s): CI runs it (-m slow)
def test_a_split_naming_an_episode_the_sample_lacks_is_a_clear_error():
    from drivestyle.studies.prediction import load_recorded

    with pytest.raises(ValueError, match=r"cats: episode\(s\) \['nope'\].*--write-split"):
        load_recorded(DATA, "cats", ["nope"])


def _region_row(set_name: str, t_obs: float, fde: float, horizon: float = 2.0) -> dict:
    return {"set": set_name, "t_obs_s": t_obs, "horizon_s": horizon, "fde_m": {"cv": fde}}


def test_the_region_rate_is_the_split_conformal_quantile_per_second_of_horizon():
    from drivestyle.studies.prediction import region_coverage, region_rates

    cal = [_region_row("ngsim", 1.0, 2.0 * k) for k in range(1, 11)]  # FDE/horizon 1 … 10
    assert region_rates(cal) == {("cv", 1.0): (10.0, 10)}  # ⌈11·0.9⌉ = 10th smallest
    assert region_rates(cal[:9]) == {("cv", 1.0): (9.0, 9)}  # ⌈10·0.9⌉ = 9th
    assert region_rates(cal[:5]) == {}  # ⌈6·0.9⌉ = 6 > 5: too few for 90 %
    with pytest.raises(ValueError, match=r"level must lie in \(0, 1\)"):
        region_rates(cal, level=1.0)
    new = [
        _region_row("ngsim", 1.0, 19.0),
        _region_row("cats", 1.0, 21.0, 2.0),
        _region_row("cats", 1.0, 30.0, 4.0),
    ]
    checks = {g.set: g for g in region_coverage(new, region_rates(cal))}
    assert checks["ngsim"].coverage == 1.0 and checks["cats"].coverage == 0.5
    assert checks["recorded"].coverage == pytest.approx(2 / 3) and checks["recorded"].n == 3
    assert checks["cats"].median_radius_m == pytest.approx(30.0)  # 10 m/s × 2 and × 4 s
