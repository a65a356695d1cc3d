"""Split-conformal prediction regions (prediction/regions.py)."""

import pytest

from drivestyle.prediction.regions import (
    KIND_MIN_CALIBRATION,
    kind_region_coverage,
    kind_region_rates,
    region_coverage,
    region_rates,
)
from drivestyle.recorded.kinds import ALL_KINDS, EPISODE_KINDS, STOP_AND_GO


def _region_row(set_name: str, t_obs: float, fde: float, horizon: float = 2.0) -> dict:
    return {"set": set_name, "t_obs_s": t_obs, "horizon_s": horizon, "fde_m": {"cv": fde}}


def test_the_region_rate_is_the_split_conformal_quantile_per_second_of_horizon():
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


def _kind_row(kind, t_obs, fde, horizon=2.0, stop_and_go=False, set_name="ngsim"):
    row = _region_row(set_name, t_obs, fde, horizon)
    return row | ({} if kind is None else {"kind": kind, "stop_and_go": stop_and_go})


def test_a_kind_with_enough_calibration_records_gets_its_own_rate_else_the_pooled_one():
    lane_changes = [_kind_row(None, 1.0, 2.0 * k) for k in range(1, 21)]  # an older run: no kind
    following = [_kind_row("car_following", 1.0, 200.0 * k) for k in range(1, 6)]
    rates = kind_region_rates(lane_changes + following)  # scores 1 … 20 and 100 … 500 m/s
    pooled_rate, pooled_n = region_rates(lane_changes + following)[("cv", 1.0)]
    assert pooled_n == 25 and pooled_rate == 400.0  # ⌈26·0.9⌉ = 24th smallest of the 25
    own = rates["lane_change", "cv", 1.0]  # 20 ≥ KIND_MIN_CALIBRATION: its own quantile
    assert KIND_MIN_CALIBRATION == 20
    assert (own.rate_m_per_s, own.n_calibration, own.n_kind, own.pooled) == (19.0, 20, 20, False)
    few = rates["car_following", "cv", 1.0]  # 5 < 20: the pooled rate, said so
    assert (few.rate_m_per_s, few.n_calibration, few.n_kind, few.pooled) == (400.0, 25, 5, True)
    none = rates["approaching", "cv", 1.0]
    assert (none.rate_m_per_s, none.n_kind, none.pooled) == (400.0, 0, True)
    assert set(rates) == {(k, "cv", 1.0) for k in EPISODE_KINDS}
    # a lower minimum takes the kind's own quantile once the level allows one (n ≥ 9)
    lower = kind_region_rates(lane_changes + following, min_records=5)
    assert lower["car_following", "cv", 1.0].pooled  # 5 < ⌈6·0.9⌉: no 90 % quantile of 5
    nine = [_kind_row("car_following", 1.0, 200.0 * k) for k in range(1, 10)]
    lower = kind_region_rates(lane_changes + nine, min_records=5)["car_following", "cv", 1.0]
    assert (lower.pooled, lower.rate_m_per_s) == (False, 900.0)


def test_each_record_is_judged_by_its_kinds_region_and_coverage_is_per_kind_and_pooled():
    cal = [_kind_row("lane_change", 1.0, 2.0 * k) for k in range(1, 21)]  # rate 19 m/s
    cal += [_kind_row("car_following", 1.0, 0.2 * k) for k in range(1, 21)]  # rate 1.9 m/s
    new = [
        _kind_row("lane_change", 1.0, 37.0),  # radius 38 m: inside
        _kind_row("lane_change", 1.0, 39.0, stop_and_go=True),  # outside
        _kind_row("car_following", 1.0, 3.0),  # radius 3.8 m: inside
        _kind_row("car_following", 1.0, 4.0, stop_and_go=True),  # outside
    ]
    checks = {g.kind: g for g in kind_region_coverage(new, kind_region_rates(cal))}
    assert list(checks) == ["lane_change", "car_following", ALL_KINDS, STOP_AND_GO]
    lc, cf = checks["lane_change"], checks["car_following"]
    assert (lc.coverage, lc.n, lc.rate_m_per_s, lc.calibrated_on) == (0.5, 2, 19.0, "kind")
    assert (cf.coverage, cf.rate_m_per_s) == (0.5, pytest.approx(1.9))
    assert cf.median_radius_m == pytest.approx(3.8)
    pooled = checks[ALL_KINDS]
    assert (pooled.coverage, pooled.n, pooled.rate_m_per_s) == (0.5, 4, None)
    assert pooled.calibrated_on == "each kind's" and pooled.median_radius_m == pytest.approx(20.9)
    assert (checks[STOP_AND_GO].coverage, checks[STOP_AND_GO].n) == (0.0, 2)
    assert pooled.to_json()["calibrated_on"] == "each kind's"
    few = kind_region_coverage(new[2:], kind_region_rates(cal[:20] + cal[20:25]))
    assert few[0].kind == "car_following" and few[0].calibrated_on == "pooled"
    assert few[0].n_kind_calibration == 5 and few[0].n_calibration == 25
