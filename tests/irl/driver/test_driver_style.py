"""The receding-horizon style model (irl/driver/driver_style.py), driver libraries and continuous
identification (DESIGN §15)."""

import json
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.driver.driver_fit import DriverFit, save_driver_style
from drivestyle.irl.driver.driver_learning import learn_driver, step_residuals
from drivestyle.irl.driver.driver_style import (
    INPUT_SCALE,
    DriverStyle,
    DriverStyleError,
    load_driver_style,
    reproduce,
)
from drivestyle.irl.driver.risk_profile import risk_profile
from drivestyle.irl.identification.library import DriverLibrary, LibraryError, load_any_library
from drivestyle.irl.identification.posterior import (
    calibrate_temperature,
    identify,
    identify_driver,
    risk_log_likelihood,
)

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The expert's Q (y, φ, v) and R (a, δ) diagonal: the SMPC is a member of the class."""


def test_the_smpc_expert_is_a_member_of_the_style_class(paper_demo):
    # the parametric NLP with the expert's weights and risk plans the expert's inputs
    truth = DriverStyle(SMPC_WEIGHTS, risk=0.7)
    r, active = step_residuals(truth, paper_demo)
    assert r.shape == (paper_demo.n - 1, 2)
    assert np.max(np.abs(r)) * max(INPUT_SCALE) < 1e-6
    assert active.any()  # the TV's chance constraint binds somewhere
    rep = reproduce(truth, paper_demo)
    assert rep.failures == 0
    rmse_y, rmse_xy = rep.errors(paper_demo)
    assert rmse_xy < 1e-4 and rmse_y < 1e-4
    assert rep.min_d >= -1e-6  # the nominal ellipse is never entered


def test_other_weights_plan_other_inputs(paper_demo):
    r, _ = step_residuals(DriverStyle((1.0, 1.0, 1.0, 1.0, 1.0), risk=0.7), paper_demo)
    assert np.sqrt(np.mean(r**2)) > 0.1


def test_the_risk_profile_is_least_at_the_true_risk(paper_demo):
    profile = risk_profile(DriverStyle(SMPC_WEIGHTS), paper_demo, risks=(0.5, 0.6, 0.7, 0.8, 0.9))
    assert profile.n_active > 0
    assert int(np.argmin(profile.ssr)) == 2
    assert profile.ssr[2] < 1e-8 < min(profile.ssr[1], profile.ssr[3])


def test_a_far_tv_is_uninformative_and_leaves_the_prior(paper_demo):
    far = replace(paper_demo, tv=paper_demo.tv - np.array([400.0, 0.0, 0.0, 0.0]))
    library = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.7, 0.9))
    ident = identify_driver(far, library)
    assert not ident.informative
    assert ident.risk_interval[0] <= 0.505 and ident.risk_interval[1] >= 0.985
    assert np.allclose(ident.density, 1.0 / len(ident.density))


def test_identification_finds_the_true_risk_with_a_continuous_posterior(paper_demo):
    library = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))
    ident = identify(paper_demo, library)
    assert ident.scorer == "likelihood"
    assert ident.risk_estimate == 0.7
    assert ident.covers(0.7)
    assert abs(ident.risk_interpolated - 0.7) < 0.03
    assert sum(ident.posterior) == pytest.approx(1.0)
    assert sum(ident.density) == pytest.approx(1.0)
    payload = ident.to_json()
    for key in ("risk_estimate", "risk_interpolated", "risk_interval", "posterior", "informative"):
        assert key in payload
    assert len(payload["posterior_density"]["risks"]) == len(ident.density)


def test_the_likelihood_widens_with_the_residual_left_at_the_best_risk():
    from drivestyle.irl.driver.risk_profile import RiskProfile

    grid = np.array([0.5, 0.6, 0.7])
    exact = RiskProfile((0.5, 0.6, 0.7), (4.0, 0.0, 4.0), 100, 5)
    noisy = RiskProfile((0.5, 0.6, 0.7), (104.0, 100.0, 104.0), 100, 5)
    ll_exact = risk_log_likelihood([exact], 1.0, grid)
    ll_noisy = risk_log_likelihood([noisy], 1.0, grid)
    # s² = min S / n + 0.1² = 0.01 (exact) or 1.01 (noisy): ℓ(0.5) = −4 / (2 s²)
    assert ll_exact[0] == pytest.approx(-4 / (2 * 0.01))
    assert ll_noisy[0] == pytest.approx(-4 / (2 * 1.01))
    assert ll_exact[1] == ll_noisy[1] == 0.0
    silent = RiskProfile((0.5, 0.6, 0.7), (1.0, 2.0, 3.0), 100, 0)
    assert np.all(risk_log_likelihood([silent], 1.0, grid) == 0.0)


def test_calibration_picks_the_smallest_covering_temperature(paper_demo):
    library = DriverLibrary(DriverStyle((0.25, 40.0, 0.2, 1.0, 12.0)), risks=(0.5, 0.7, 0.9))
    cal = calibrate_temperature(library, [paper_demo], candidates=(0.01, 100.0))
    assert cal.n_demos == 1
    assert cal.coverage[100.0] == 1.0
    assert cal.temperature == (0.01 if cal.coverage[0.01] >= 0.9 else 100.0)


def test_driver_style_validation_and_files(tmp_path):
    with pytest.raises(DriverStyleError, match="weights"):
        DriverStyle((1.0, 2.0))
    with pytest.raises(DriverStyleError, match="risk"):
        DriverStyle(SMPC_WEIGHTS, risk=0.3)
    style = DriverStyle(SMPC_WEIGHTS, risk=0.8, v_ref=27.0)
    assert DriverStyle.from_json(style.to_json()) == style
    assert np.allclose(style.normalised(), SMPC_WEIGHTS)
    fit = DriverFit(style, (0.8,), 0.0, 0.0, 2, 1, "converged", 0.1)
    path = save_driver_style(fit, tmp_path / "style.json", ["a.npz"])
    assert load_driver_style(tmp_path) == style
    paper = tmp_path / "paper" / "style.json"
    paper.parent.mkdir()
    paper.write_text(json.dumps({"features": ["f_a"], "theta": [1.0]}))
    with pytest.raises(DriverStyleError, match=r"paper-model style.*learn-style"):
        load_driver_style(paper)
    assert path.exists()


def test_driver_library_round_trip_and_dispatch(tmp_path):
    library = DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.7), temperature=2.0)
    (tmp_path / "library.json").write_text(json.dumps(library.to_json()))
    loaded = load_any_library(tmp_path)
    assert isinstance(loaded, DriverLibrary)
    assert loaded.style.weights == library.style.weights and loaded.temperature == 2.0
    with pytest.raises(LibraryError, match="increasing"):
        DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.7, 0.5))
    with pytest.raises(LibraryError, match="temperature"):
        DriverLibrary(DriverStyle(SMPC_WEIGHTS), risks=(0.5, 0.7), temperature=0.0)


def test_learning_refuses_bad_input(paper_demo):
    with pytest.raises(DriverStyleError, match="at least one"):
        learn_driver([])
    with pytest.raises(DriverStyleError, match="risks"):
        learn_driver([paper_demo], risks=[0.7, 0.8])
    half = replace(paper_demo, t=paper_demo.t * 0.5)
    with pytest.raises(DriverStyleError, match="resample"):
        learn_driver([half])


@pytest.mark.slow
def test_learning_recovers_a_driver_that_reproduces_its_demonstration(paper_demo):
    fit = learn_driver([paper_demo], risks=[0.7], screen=4, restarts=1, max_iter=15)
    assert fit.status in ("converged", "max_iter")
    rmse_y, rmse_xy = reproduce(fit.style, paper_demo).errors(paper_demo)
    assert rmse_y < 0.05 and rmse_xy < 0.2
