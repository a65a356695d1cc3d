"""The held-out comparison with the default (receding-horizon) style model."""

import pytest

from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.studies.compare import heldout_comparison, state_metrics

DRIVER = DriverStyle((0.2, 34.0, 0.2, 1.0, 76.0), risk=0.6)
"""A p = 0.6 driver (weights of the order learn_driver finds)."""


def test_heldout_with_a_driver_style_reports_the_style_entry():
    res = heldout_comparison(None, {}, k=1, seed=3000, risk=0.6, driver=DRIVER)
    assert list(res.summary) == ["smpc", "style"]
    smpc, style = res.summary["smpc"], res.summary["style"]
    assert smpc.median_rmse_y_m == pytest.approx(0.0, abs=1e-12)
    assert smpc.median_rmse_xy_m == pytest.approx(0.0, abs=1e-12)
    assert 0 < style.median_rmse_y_m < 3 and style.median_rmse_xy_m >= style.median_rmse_y_m
    assert style.median_cost is None and style.n == 1 and style.collisions == 0
    assert style.enters_ellipse == int(style.min_d_k < 0 <= smpc.min_d_k)
    row = res.per_scenario[0]["methods"]["style"]
    assert row["decision_ms"] > 0 and row["solve_failures"] >= 0
    js = res.to_json()["summary"]["style"]
    keys = {"median_rmse_y_m", "median_rmse_xy_m", "collisions", "min_d_k", "enters_ellipse"}
    assert keys <= set(js)


def test_state_metrics_of_the_demonstration_itself(paper_demo):
    m = state_metrics(paper_demo.ev, paper_demo)
    assert m["rmse_y_m"] == 0 and m["rmse_xy_m"] == 0 and not m["collision"]
    assert m["min_d_k"] >= 0  # the SMPC keeps the nominal ellipse
    shorter = state_metrics(paper_demo.ev[:5], paper_demo)
    assert shorter["rmse_y_m"] is None and not shorter["complete"]


def test_heldout_needs_a_style():
    with pytest.raises(ValueError, match="driver style or a paper-model style"):
        heldout_comparison(None, {}, k=1, seed=1, risk=0.6)
