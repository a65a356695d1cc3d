"""The driver library's posterior over p: its verdict, KL and noise floor (closed-form checks)."""

import numpy as np
import pytest


# ---------------------------------------------------------------- the verdict (DESIGN §15)
def _driver_library(temperature=1.0):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    style = DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0))
    return DriverLibrary(style, risks=(0.5, 0.7, 0.9), temperature=temperature)


def _profile(ssr, n_active=30, n_residuals=60):
    from drivestyle.irl.driver.risk_profile import RISK_EVAL, RiskProfile

    return RiskProfile(RISK_EVAL, tuple(float(s) for s in ssr), n_residuals, n_active)


def test_kl_of_the_prior_is_zero_and_of_a_point_mass_is_log_cells():
    from drivestyle.irl.identification.posterior import density_grid
    from drivestyle.irl.identification.verdict import kl_from_uniform

    n = density_grid().size
    assert kl_from_uniform(np.full(n, 1.0 / n)) == pytest.approx(0.0, abs=1e-12)
    point = np.zeros(n)
    point[17] = 1.0
    assert kl_from_uniform(point) == pytest.approx(np.log(n))
    half = np.r_[np.full(n // 2, 2.0 / (n - n % 2)), np.zeros(n - n // 2)]
    assert kl_from_uniform(half / half.sum()) == pytest.approx(np.log(n / (n // 2)))


@pytest.mark.parametrize(
    "profile",
    [
        _profile([0.6] * 13, n_active=0),  # no step where a constraint binds
        _profile([0.6 + 1e-6 * i for i in range(13)]),  # flagged active, yet flat (a far TV)
    ],
)
def test_a_demo_without_a_binding_constraint_cannot_inform_the_risk(profile):
    from drivestyle.irl.driver.driver_style import RISK_RANGE
    from drivestyle.irl.identification.posterior import driver_posterior

    res = driver_posterior([profile], _driver_library(), [95.0], [None])
    v = res.verdict
    assert not res.informative and not v.constraint_binds and not v.out_of_class
    assert v.kl_nats == pytest.approx(0.0, abs=1e-6) and v.width_ratio == pytest.approx(1.0)
    assert res.risk_interval == RISK_RANGE
    assert v.label == "no_constraint" and "no chance constraint binds" in res.reason
    assert "s_e 95.0" in res.reason and "moved" not in res.reason
    assert v.headline.startswith("the prior: nothing in the data can move the risk (")
    js = res.to_json()
    assert js["informative"] is False and js["reason"] == res.reason
    assert js["verdict"] == "no_constraint"


def test_a_posterior_that_barely_moved_is_not_informative():
    from drivestyle.irl.identification.posterior import driver_posterior
    from drivestyle.irl.identification.verdict import KL_INFORMATIVE

    # the NGSIM shape: residuals of 5 σ_u everywhere, a little worse at high risk, under
    # runs/library's calibrated temperature
    ssr = 60 * (5.0 + np.linspace(0, 1.5, 13)) ** 2
    res = driver_posterior([_profile(ssr)], _driver_library(11.0), [3.0], [None])
    v = res.verdict
    assert v.constraint_binds and v.kl_nats < KL_INFORMATIVE and not res.informative
    assert v.label == "prior" and "barely moved" in res.reason


def test_residuals_far_above_the_floor_are_out_of_class_and_near_it_in_class():
    from drivestyle.irl.identification.posterior import driver_posterior
    from drivestyle.irl.identification.verdict import OUT_OF_CLASS_FACTOR

    lib = _driver_library()
    sharp = np.full(13, 100.0)
    sharp[4] = 0.0  # the SMPC(0.7) shape: exact at its risk
    for level, out in [(0.0, False), (OUT_OF_CLASS_FACTOR * 2 * lib.noise_floor, True)]:
        res = driver_posterior([_profile(sharp + 60 * level**2)], lib, [2.0], [None])
        assert res.verdict.residual_rms == pytest.approx(level, rel=1e-6)
        assert res.out_of_class is out
        assert res.verdict.label == ("out_of_class" if out else "informative")
        assert ("noise floor" in res.reason) is out
    assert res.to_json()["residual_floors"] == pytest.approx(2 * OUT_OF_CLASS_FACTOR)


@pytest.mark.parametrize("s_e", [0.25, 0.9])
def test_a_vehicle_inside_the_safety_region_is_less_cautious_than_the_class(s_e):
    from drivestyle.irl.identification.posterior import driver_posterior

    sharp = np.full(13, 100.0)
    sharp[4] = 0.0  # a sharp minimum that would otherwise be informative
    inside = driver_posterior([_profile(sharp)], _driver_library(), [s_e], [None])
    touching = driver_posterior([_profile(sharp)], _driver_library(), [1.0], [None])
    assert touching.informative and not touching.out_of_class  # SMPC(0.5) touches s_e = 1
    v = inside.verdict
    assert v.enters_region and v.out_of_class and not inside.informative
    assert v.min_s_e == pytest.approx(s_e)
    assert v.label == "enters_region" and v.headline.startswith("less cautious than the class")
    assert f"s_e {s_e:.2f}, inside the safety region" in inside.reason
    # the posterior did move (a sharp minimum): the reason says so, the label says why
    # that is no risk of this driver (it said "barely moved" with KL 4.6 before)
    assert "the data moved the posterior" in inside.reason and "barely" not in inside.reason
    js = inside.to_json()
    assert js["enters_region"] is True and js["verdict"] == "enters_region"
    assert js["constraint_binds_per_demo"] == [True]


def test_the_noise_floor_combines_the_fit_residual_and_s_floor():
    from drivestyle.irl.driver.driver_style import RESIDUAL_FLOOR
    from drivestyle.irl.identification.library import DriverLibrary

    lib = _driver_library()
    assert lib.fit_residual == 0.0 and lib.noise_floor == pytest.approx(RESIDUAL_FLOOR)
    fitted = DriverLibrary(lib.style, lib.risks, meta={"fit": {"residual_rms": 0.3}})
    assert fitted.noise_floor == pytest.approx(np.hypot(0.3, RESIDUAL_FLOOR))
    odd = DriverLibrary(lib.style, lib.risks, meta={"fit": {"residual_rms": "x"}})
    assert odd.fit_residual == 0.0
