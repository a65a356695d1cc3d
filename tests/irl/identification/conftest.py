"""Shared rows of the mining tests."""

import pytest

from drivestyle.irl.identification.mined_row import MinedRow


@pytest.fixture()
def ok_row() -> MinedRow:
    """A complete ok row (paper-model mining, no verdict columns)."""
    return MinedRow(
        id="v1",
        source="pop",
        status="ok",
        true_risk=0.7,
        risk_estimate=0.75,
        risk_lo=0.6,
        risk_hi=0.9,
        risk_mean=0.731,
        informative=True,
        trigger_fired=False,
        theta_normalised=(0.25, 1.5e-05, 3.0),
        rmse_y_m=0.012,
        rmse_xy_m=0.034,
        iterations=12,
        converged=True,
        learn_s=1.25,
        identify_s=0.5,
    )
