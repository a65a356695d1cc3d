"""The amortized posterior beside the exact one: its summaries on hand-made records."""

import json

import numpy as np
import pytest

from drivestyle.irl.amortized.simulations import PARAMETERS
from drivestyle.irl.identification.posterior import grid_estimate, grid_mass
from drivestyle.studies.identification.amortized import (
    NO_TRUTH,
    noise_costs,
    summarise_beside_exact,
)
from drivestyle.studies.identification.amortized_results import (
    AmortizedRecord,
    BesideExact,
    ExactAnswer,
)
from drivestyle.studies.identification.figures import plot_beside_exact
from drivestyle.studies.identification.report import amortized_markdown

LOW = (0.5, 0.9, 0.0, 2.0, 0.25, 0.0, 0.0, 0.0, 0.2)
HIGH = (0.99, 1.3, 2.0, 20.0, 4.0, 2.0, 0.5, 0.004, 3.0)
GRID = (0.5, 0.6, 0.7, 0.8, 0.9)


def _record(risk, scenario, mean, lo, hi, estimate, exact, *, grid=True, identifiable=True,
            continuous=False, time_gap=0.2, t=0.01, exact_t=1.0):  # fmt: skip
    """A record whose risk is (mean, lo, hi, estimate); T's posterior mean ``time_gap``
    (interval ±0.15) against the expert's 0; every other parameter at its box's centre."""
    centre = [(a + b) / 2 for a, b in zip(LOW, HIGH, strict=True)]
    means = [mean, *centre[1:]]
    means[2] = time_gap
    los = [lo, *LOW[1:]]
    his = [hi, *HIGH[1:]]
    los[2], his[2] = time_gap - 0.15, time_gap + 0.15
    expert = [risk, 1.2, 0.0, 15.0, 1.0, 0.0, 0.0, 0.0, None]
    return AmortizedRecord(
        risk=risk, scenario=scenario, grid=grid, continuous=continuous,
        identifiable=identifiable, mean=tuple(means), lo=tuple(los), hi=tuple(his),
        estimate=estimate, identify_s=t, expert=tuple(expert),
        exact=None if exact is None else ExactAnswer(*exact), exact_identify_s=exact_t,
    )  # fmt: skip


# p, scenario, amortized mean, its interval, its grid risk; the exact's (mean, interval,
# grid risk)
# fmt: off
RECORDS = (
    _record(0.5, 0, 0.52, 0.45, 0.60, 0.5, (0.50, (0.50, 0.55), 0.5), time_gap=0.1, t=0.02),
    _record(0.9, 0, 0.80, 0.70, 0.85, 0.8, (0.88, (0.85, 0.95), 0.9), time_gap=0.3, t=0.04),
    _record(0.7, 1, 0.74, 0.60, 0.80, 0.7, (0.71, (0.65, 0.75), 0.7), grid=False,
            identifiable=False, continuous=True, time_gap=0.1, t=0.01),
    _record(0.6, 1, 0.60, 0.55, 0.65, 0.6, (0.65, (0.60, 0.70), 0.7), identifiable=False,
            time_gap=0.3, t=0.03),
    _record(0.8, 2, 0.30, 0.20, 0.40, 0.5, None),  # refused by the exact: left out
)
# fmt: on


@pytest.fixture(scope="module")
def summary():
    return summarise_beside_exact(RECORDS, 0.0, LOW, HIGH, bootstrap_samples=500)


def test_both_posteriors_are_scored_on_the_demonstrations_both_identified(summary):
    assert (summary.n, summary.n_exact_refused, summary.n_identifiable) == (5, 1, 2)
    a, e = summary.amortized, summary.exact
    assert a.n == e.n == 4
    # |mean − p|: amortized 0.02, 0.10, 0.04, 0.00; exact 0.00, 0.02, 0.01, 0.05
    assert a.risk_error.mean == pytest.approx(0.04)
    assert a.risk_error.median == pytest.approx(0.03)
    assert e.risk_error.mean == pytest.approx(0.02)
    assert e.risk_error.median == pytest.approx(0.015)
    for err in (a.risk_error, e.risk_error):
        assert err.mean_lo <= err.mean <= err.mean_hi
        assert err.median_lo <= err.median <= err.median_hi
    assert a.coverage == pytest.approx(0.75) and e.coverage == pytest.approx(1.0)  # 0.9 ∉ [.7, .85]
    assert a.interval_width == pytest.approx((0.15 + 0.15 + 0.20 + 0.10) / 4)
    # grid: p = 0.5, 0.9, 0.6 (0.7 is continuous); identifiable: 0.5 and 0.9
    assert a.grid_accuracy == pytest.approx(2 / 3) and e.grid_accuracy == pytest.approx(2 / 3)
    assert a.identifiable_accuracy == pytest.approx(0.5) and e.identifiable_accuracy == 1.0
    assert a.continuous_mae == pytest.approx(0.04) and e.continuous_mae == pytest.approx(0.01)
    assert a.identify_ms_median == pytest.approx(25.0)  # 10, 20, 30, 40 ms
    assert e.identify_ms_median == pytest.approx(1000.0)


def test_agreement_is_between_the_two_posterior_means(summary):
    ag = summary.agreement
    diff = np.array([0.02, 0.08, 0.03, 0.05])
    assert ag.n == 4
    assert ag.mae == pytest.approx(diff.mean()) and ag.median == pytest.approx(0.04)
    assert ag.max == pytest.approx(0.08)
    amortized, exact = [0.52, 0.80, 0.74, 0.60], [0.50, 0.88, 0.71, 0.65]
    assert ag.correlation == pytest.approx(np.corrcoef(amortized, exact)[0, 1])


def test_the_other_parameters_are_measured_against_the_experts_values(summary):
    by_name = {p.name: p for p in summary.parameters}
    assert list(by_name) == list(PARAMETERS[1:])  # every parameter but p
    t = by_name["time_gap"]  # posterior means 0.1, 0.3, 0.1, 0.3 against the expert's 0
    assert t.mean == pytest.approx(0.2) and t.median == pytest.approx(0.2)
    assert t.expert_mean == 0.0 and t.mae == pytest.approx(0.2)
    assert t.mae_relative == pytest.approx(0.1) and t.box_position == pytest.approx(0.1)
    assert t.centre_mae_relative == pytest.approx(0.5)  # the box's centre is 1 s away
    assert t.coverage == pytest.approx(0.5)  # [−0.05, 0.25] holds 0; [0.15, 0.45] does not
    m = by_name["min_gap"]  # at the centre, 11 m, against 15 m
    assert m.mae == pytest.approx(4.0) and m.coverage == 1.0
    for name in NO_TRUTH:  # τ: the expert has none
        q = by_name[name]
        assert q.expert_mean is q.mae is q.coverage is q.centre_mae_relative is None
        assert q.box_position == pytest.approx(0.5)


def test_the_noise_cost_is_in_points_against_the_first_level(summary):
    worse = [
        r if r.exact is None else _record(
            r.risk, r.scenario, r.mean[0] + 0.05, r.lo[0], r.hi[0],
            r.risk if r.risk == 0.6 else 0.8, (r.exact.mean, r.exact.interval, r.risk),
            grid=r.grid, identifiable=r.identifiable, continuous=r.continuous,
        )
        for r in RECORDS
    ]  # fmt: skip
    noisy = summarise_beside_exact(worse, 0.1, LOW, HIGH, bootstrap_samples=500)
    (cost,) = noise_costs([summary, noisy])
    assert (cost.noise_sigma_m, cost.baseline_sigma_m) == (0.1, 0.0)
    assert cost.amortized_identifiable_points == pytest.approx(-50.0)  # 0.5 → 0
    assert cost.exact_identifiable_points == pytest.approx(0.0)  # 1 → 1
    assert cost.amortized_grid_points == pytest.approx(100 * (1 / 3 - 2 / 3))
    assert cost.exact_grid_points == pytest.approx(100 * (1 - 2 / 3))
    assert cost.exact_mae_change == pytest.approx(0.0)
    assert cost.amortized_mae_change == pytest.approx(
        noisy.amortized.risk_error.mean - summary.amortized.risk_error.mean
    )
    assert noise_costs([summary]) == () and noise_costs([]) == ()


def test_the_grid_risk_is_the_cell_with_most_mass_for_draws_as_for_a_density():
    # draws of mean 0.70 whose most common cell is 0.6's: the estimate is 0.6, not the
    # grid risk nearest the mean
    draws = np.array([0.58, 0.61, 0.63, 0.64, 0.82, 0.95, 0.97])
    mass = np.full(draws.size, 1 / draws.size)
    assert draws.mean() == pytest.approx(0.743, abs=1e-3)
    assert grid_mass(draws, mass, GRID) == pytest.approx(np.array([0, 4, 0, 1, 2]) / 7)
    assert grid_estimate(draws, mass, GRID) == 0.6
    # equal masses: the first (as the exact's stable ranking)
    assert grid_estimate(np.array([0.5, 0.9]), np.array([0.5, 0.5]), GRID) == 0.5


def test_the_section_its_markdown_and_its_figure(summary, drawn, tmp_path):
    beside = BesideExact("post.npz", 200, LOW, HIGH, (RECORDS,), (summary,), ())
    section = json.loads(json.dumps(beside.to_json()))  # JSON-ready
    assert section["parameters"] == list(PARAMETERS) and section["level"] == 0.9
    assert len(section["records"]) == 5 and section["records"][4]["exact"] is None
    rec = section["records"][0]
    assert rec["mean"]["risk"] == 0.52 and rec["expert"]["tau"] is None
    assert rec["exact"] == {"mean": 0.5, "interval": [0.5, 0.55], "estimate": 0.5}
    by = section["by_noise"][0]
    assert by["amortized"]["risk_error"]["mean"] == pytest.approx(0.04)
    assert set(by["parameters"]) == set(PARAMETERS[1:])
    md = amortized_markdown(beside)
    assert "| 0 | amortized | 0.040 [" in md and "| 0 | exact | 0.020 [" in md
    assert "| time_gap | [0, 2] | 0.0000 | 0.2000 / 0.2000 | 0.10 |" in md
    plot_beside_exact(beside, tmp_path / "x.png")
    (ax,) = drawn[0].axes
    assert "4 demonstrations" in ax.get_title()  # the refused one is not drawn
