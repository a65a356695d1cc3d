"""Fixtures of the prediction study's tests: records of several kinds of episode."""

import pytest

from drivestyle.studies.prediction import PredictionRecord


def kind_record(set_name, vehicle, kind, cv, mode, t=1.0, stop_and_go=False):
    """A record whose ADE is its FDE, lateral parts ½ (CV) and ¼ (mode), longitudinal ¾."""
    fde = {"cv": cv, "mode": mode}
    lat = {"cv": cv / 2, "mode": mode / 4}
    lon = {m: 0.75 * v for m, v in fde.items()}
    return PredictionRecord(
        set_name, f"{vehicle}-{kind}", t, 3.0, None, None, 0.7, dict(fde), fde,
        fde_lat_m=lat, fde_lon_m=lon, ade_lat_m=dict(lat), ade_lon_m=dict(lon), unit=vehicle,
        kind=kind, stop_and_go=stop_and_go,
    )  # fmt: skip


@pytest.fixture
def record_of_kind():
    """:func:`kind_record`: one synthetic record of a kind."""
    return kind_record


@pytest.fixture
def mixed_kinds():
    """Lane changes in NGSIM (4 vehicles) and CATS (3), car following in NGSIM (5 windows of
    5 vehicles, 4 of them also changing lane), two car-following windows stop-and-go; at
    t_obs = 1 s and, one metre worse, 2 s."""
    out = []
    for t, more in ((1.0, 0.0), (2.0, 1.0)):
        out += [kind_record("ngsim", f"n{i}", "lane_change", 10.0 + i + more, 6.0 + i + more, t)
                for i in range(4)]  # fmt: skip
        out += [kind_record("cats", f"c{i}", "lane_change", 8.0 + i + more, 7.0 + more, t)
                for i in range(3)]  # fmt: skip
        out += [kind_record("ngsim", f"n{i}", "car_following", 2.0 + i + more, 2.5 + i + more, t,
                            stop_and_go=i < 2) for i in range(5)]  # fmt: skip
    return out
