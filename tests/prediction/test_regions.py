"""Split-conformal prediction regions (prediction/regions.py)."""

import pytest

from drivestyle.prediction.regions import region_coverage, region_rates


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
