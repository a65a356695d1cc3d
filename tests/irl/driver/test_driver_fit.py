"""A driver fit (irl/driver/driver_fit.py): which demonstrations the learned style explains."""

import numpy as np
import pytest

from drivestyle.irl.driver.driver_fit import (
    POOR_FIT_RATIO,
    REPRODUCTION_TOLERANCE,
    ClosedLoop,
    DemoFit,
    DriverFit,
    diagnose,
)
from drivestyle.irl.driver.driver_style import RESIDUAL_FLOOR, DriverStyle

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The expert's weights: SMPC(p) drivers are the style (SMPC_WEIGHTS, p)."""


def _fit_with(per_demo):
    return DriverFit(
        DriverStyle(SMPC_WEIGHTS, risk=0.5), (0.5,) * len(per_demo), 1.0, 1.0, 120, 3,
        "poor_fit", 1.0, per_demo=tuple(per_demo), optimiser_status="converged",
    )  # fmt: skip


def test_diagnosis_names_the_demonstration_no_shared_driver_explains():
    exact, off = np.zeros((30, 2)), np.full((30, 2), 4.0)
    active = np.ones(30, bool)
    ssr = np.zeros((13, 2))
    ssr[:, 1] = np.linspace(960.0, 0.0, 13)  # alone, the second is best at p = 0.99
    per_demo = diagnose([(exact, active), (off, active)], ssr, 0.5, RESIDUAL_FLOOR)
    assert [d.poor for d in per_demo] == [False, True]
    assert per_demo[1].residual_rms == pytest.approx(4.0)
    assert per_demo[1].best_risk == 0.99 and per_demo[1].best_residual_rms == 0.0
    assert per_demo[0].best_risk == 0.5 and per_demo[0].active_steps == 30
    assert per_demo[1].disagrees and not per_demo[0].disagrees
    fit = _fit_with(per_demo)
    assert fit.poor_demos == (1,)
    assert fit.poor_fit_threshold == pytest.approx(POOR_FIT_RATIO * RESIDUAL_FLOOR)
    payload = fit.to_json()
    assert payload["status"] == "poor_fit" and payload["optimiser_status"] == "converged"
    assert payload["poor_demos"] == [1] and payload["residual_floor"] == RESIDUAL_FLOOR
    assert payload["per_demo"][1]["best_risk"] == 0.99 and payload["per_demo"][1]["poor"]
    # the shared weights' compromise lifts an agreeing demonstration too: the odd one is named
    lifted = [per_demo[1], DemoFit(0, 60, 0.6, 30, 0.5, 0.6, True, False)]
    assert _fit_with(lifted).poor_demos == (1,)
    both = [DemoFit(0, 60, 0.6, 30, 0.5, 0.6, True), DemoFit(1, 60, 0.5, 30, 0.5, 0.5, True)]
    assert _fit_with(both).poor_demos == (0, 1)  # no odd one: every poorly fitted one


def test_a_residual_above_the_threshold_counts_only_where_the_closed_loop_misses():
    off, active = np.full((30, 2), 1.0), np.ones(30, bool)  # 10 floors
    near = ClosedLoop(0.002, REPRODUCTION_TOLERANCE / 2, 0.5, 0)
    far = ClosedLoop(0.2, 1.5, 0.5, 0)
    per_demo = diagnose([(off, active)] * 3, None, 0.7, RESIDUAL_FLOOR, [near, far, None])
    assert [d.reproduced for d in per_demo] == [True, False, False]
    assert [d.poor for d in per_demo] == [False, True, True]  # not driven: the residual decides
    assert per_demo[0].to_json()["closed_loop"]["rmse_xy_m"] == REPRODUCTION_TOLERANCE / 2


def test_a_larger_floor_accepts_larger_residuals():
    off = np.full((30, 2), 0.5)
    (tight,) = diagnose([(off, np.ones(30, bool))], None, 0.7, RESIDUAL_FLOOR)
    (loose,) = diagnose([(off, np.ones(30, bool))], None, 0.7, 1.0)
    assert tight.poor and not loose.poor
    assert isinstance(tight, DemoFit) and tight.best_risk == 0.7
