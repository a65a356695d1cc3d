"""The CATS automated car against human drivers (studies/av_vs_human/)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.identification import mined_row
from drivestyle.studies.av_vs_human import (
    MinedRow,
    av_human_markdown,
    closest_distance,
    compare_av_human,
    group_of,
    read_mined,
    time_gaps,
)

DATA = Path(__file__).resolve().parents[3].parent / "shared" / "data"  # beside a checkout
W = PAPER.lane_width


def _demo(lead_dx: float, lead_dy: float = 0.0, v: float = 10.0, lateral: float = 1.0):
    """EV at constant speed v changing lane by ``lateral`` m; a TV lead_dx ahead, same speed."""
    t = np.arange(0.0, 6.01, 0.2)
    n = t.size
    y = W / 2 + lateral * np.clip((t - 1.0) / 4.0, 0, 1)
    ev = np.column_stack([v * t, y, np.zeros(n), np.full(n, v)])
    tv = np.column_stack([v * t + lead_dx, np.full(n, W / 2 + lead_dy), np.zeros(n), np.full(n, v)])
    return Demonstration(t=t, ev=ev, tv=tv, u=np.zeros((n - 1, 2)),
                         meta={"scenario": PAPER.to_dict()})  # fmt: skip


def test_the_time_gap_is_bumper_to_bumper_over_the_ev_speed_in_its_own_lane():
    gaps = time_gaps(_demo(lead_dx=25.0, lateral=0.0))
    assert gaps == pytest.approx(np.full(gaps.size, (25.0 - PAPER.vehicle_length) / 10.0))
    assert np.isinf(time_gaps(_demo(lead_dx=25.0, lead_dy=W, lateral=0.0))).all()  # next lane
    assert np.isinf(time_gaps(_demo(lead_dx=-25.0, lateral=0.0))).all()  # behind


def test_the_closest_approach_ignores_vehicles_far_away():
    near = _demo(lead_dx=30.0, lead_dy=4.0, lateral=0.0)
    assert closest_distance(near) == pytest.approx(np.hypot(30, 4))
    assert closest_distance(_demo(lead_dx=500.0)) is None


def test_groups_and_a_clear_error_for_another_dataset():
    assert group_of("cats:AV:3") == "AV"
    assert group_of("cats:HV:3") == "same car, human"
    assert group_of("cats:AV:1") == group_of("cats:HV:4") == "other humans"
    with pytest.raises(ValueError, match="not a CATS vehicle"):
        group_of("ngsim:i80:54")


def _episodes():
    # the AV keeps 1.5 s, the humans 3 s; its lane changes are quicker (1 m/s against 0.5)
    av = [(f"a{i}", "cats:AV:3", _demo(10 + 15 + 0.2 * i, lateral=4.0)) for i in range(6)]
    hv = [(f"h{i}", "cats:HV:3", _demo(10 + 30 + 0.2 * i, lateral=2.0)) for i in range(6)]
    other = [(f"o{i}", "cats:AV:1", _demo(10 + 30 + 0.2 * i, lateral=2.0)) for i in range(6)]
    return av + hv + other


def test_a_real_difference_excludes_zero_and_equal_groups_do_not():
    mined = {f"a{i}": MinedRow(0.6, 0.55, 0.7, True, False) for i in range(6)}
    mined |= {f"h{i}": MinedRow(0.9, 0.5, 0.99, False, False) for i in range(5)}
    mined["h4"] = MinedRow(0.9, 0.5, 0.99, False, False, constraint_binds=False)
    mined["h5"] = MinedRow(0.2, 0.1, 0.3, True, True)  # moved, but out of class: no risk
    c = compare_av_human(_episodes(), mined, samples=300, seed=1)
    d = {(x.quantity, x.against): x for x in c.differences}
    gap = d["min_time_gap_s", "same car, human"]
    assert gap.median == pytest.approx(-1.5, abs=0.05) and gap.excludes_zero
    assert d["peak_lateral_speed_mps", "other humans"].median > 0
    assert d["median_speed_mps", "other humans"].median == 0.0
    assert not d["median_speed_mps", "other humans"].excludes_zero
    assert d["risk_mean", "same car, human"].median == pytest.approx(-0.3)
    assert d["risk_mean", "other humans"].median is None  # not mined
    assert c.verdicts == {"AV": {"informative": 6},
                          "same car, human": {"prior": 4, "no_constraint": 1,
                                              "out_of_class": 1},
                          "other humans": {"not mined": 6}}  # fmt: skip
    hv = next(s for s in c.stats if s.quantity == "risk_mean" and s.group == "same car, human")
    assert hv.n == 5 and hv.median == 0.9
    again = compare_av_human(_episodes(), mined, samples=300, seed=1)
    assert again.differences == c.differences  # deterministic given the seed
    text = av_human_markdown(c, "drivestyle compare-av-human")
    assert "**" in text and "informative 6" in text


def test_a_group_of_fewer_than_three_gets_no_interval_and_no_difference():
    eps = _episodes()[:8]  # 6 AV, 2 of the same car driven by a human
    c = compare_av_human(eps, samples=200, seed=1)
    hv = next(
        s for s in c.stats if s.quantity == "median_speed_mps" and s.group == "same car, human"
    )
    assert hv.n == 2 and hv.median == 10.0 and hv.lo is None and hv.hi is None
    d = next(d for d in c.differences if d.quantity == "median_speed_mps")
    assert d.median is None and not d.excludes_zero


def test_the_json_reports_the_bootstrap_it_was_drawn_with():
    # it reported the default 2000 replicates and seed whatever --samples said
    c = compare_av_human(_episodes(), samples=300, seed=1)
    assert c.to_json()["bootstrap"] == {
        "samples": 300, "seed": 1, "unit": "episode (lane change)"
    }  # fmt: skip


def test_without_the_av_or_without_humans_it_refuses():
    with pytest.raises(ValueError, match="need lane changes of the AV"):
        compare_av_human(_episodes()[6:])
    with pytest.raises(ValueError, match="need lane changes of the AV"):
        compare_av_human(_episodes()[:6])


def _styles_csv(folder, *rows) -> None:
    """``folder/styles.csv`` as mine-styles writes it."""
    with (folder / "styles.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=mined_row.COLUMNS)
        writer.writeheader()
        writer.writerows(r.to_csv() for r in rows)


def _mined_row(i, mean, lo, hi, informative, out_of_class, binds=None, enters=None):
    """An ok row of a mining run (the columns the comparison reads as given)."""
    return mined_row.MinedRow(
        i, "cats", "ok", risk_estimate=mean, risk_lo=lo, risk_hi=hi, risk_mean=mean,
        informative=informative, out_of_class=out_of_class, theta_normalised=(1.0,),
        constraint_binds=binds, enters_region=enters,
    )  # fmt: skip


def test_the_mined_table_is_read_and_a_foreign_table_refused(tmp_path):
    _styles_csv(
        tmp_path,
        _mined_row("x", 0.7, 0.6, 0.8, True, False),
        mined_row.MinedRow.failed("y", "cats", "DemonstrationError: y: no lane change"),
    )
    assert read_mined(tmp_path) == {"x": MinedRow(0.7, 0.6, 0.8, True, False)}
    assert read_mined(tmp_path)["x"].verdict == "informative"
    # a table with the label's flags: the same function labels its rows
    _styles_csv(
        tmp_path,
        _mined_row("x", 0.7, 0.6, 0.8, False, True, True, True),
        _mined_row("z", 0.745, 0.5, 0.99, False, False, False, False),
    )
    read = read_mined(tmp_path)
    assert read["x"] == MinedRow(0.7, 0.6, 0.8, False, True, True, True)
    assert (read["x"].verdict, read["z"].verdict) == ("enters_region", "no_constraint")
    (tmp_path / "styles.csv").write_text("id,status\nx,ok\n")
    with pytest.raises(ValueError, match="no column informative"):
        read_mined(tmp_path)
    with pytest.raises(FileNotFoundError, match="mine-styles"):
        read_mined(tmp_path / "nowhere")


@pytest.mark.slow  # the whole CATS sample is extracted (≈ 15 s): CI runs it
@pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file(),
    reason="the CATS sample is absent",
)
def test_the_command_writes_the_comparison_of_the_shipped_sample(tmp_path):
    from drivestyle.scripts.compare_av_human import main

    payload = main(["--samples", "200", "--data-dir", str(DATA), "--out", str(tmp_path / "o")])
    assert (tmp_path / "o" / "av_vs_human.png").stat().st_size > 10_000
    groups = {s["group"] for s in payload["stats"]}
    assert groups == {"AV", "same car, human", "other humans"}
    n_av = sum(payload["verdicts"]["AV"].values())
    assert n_av > 10
