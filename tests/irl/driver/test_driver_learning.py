"""Teacher-forced learning of a driver style (irl/driver/driver_learning.py, DESIGN §15): the
risk reaches the bound p = 0.5, the profile over p leaves the saw-tooth's local minima,
the Cauchy descent leaves least squares' local minima, and the fit says when no single
driver explains the demonstrations (``poor_fit``) — not when only the learner's residual
is high and the closed loop reproduces them."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.driver.driver_fit import REPRODUCTION_TOLERANCE
from drivestyle.irl.driver.driver_learning import cauchy_residuals, learn_driver
from drivestyle.irl.driver.driver_style import INPUT_SCALE, DriverStyle, DriverStyleError

SMPC_WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)
"""The expert's weights: SMPC(p) drivers are the style (SMPC_WEIGHTS, p)."""


@pytest.fixture(scope="module")
def smpc_demos():
    """SMPC(p) demonstrations, p ∈ {0.5, 0.55, 0.9}, in 3 interactive scenarios (seed 0)."""
    from drivestyle.agents.demo_generation import (
        draw_interactive_scenarios,
        generate_demonstrations,
    )

    scenarios = draw_interactive_scenarios(3, seed=0, probe_risk=0.5)
    return generate_demonstrations([0.5, 0.55, 0.9], scenarios, workers=1)


def test_cauchy_residuals_are_the_square_root_of_the_steps_cauchy_loss():
    r = np.array([[0.0, 0.0], [1e-4, -2e-4], [3.0, 4.0], [-300.0, 400.0]])
    c = 0.3
    out = cauchy_residuals(r, c)
    steps = np.sum(r**2, axis=1)
    assert np.allclose(np.sum(out**2, axis=1), c**2 * np.log1p(steps / c**2))
    assert np.all(out[0] == 0.0)  # no division by a zero norm
    assert np.allclose(out[1], r[1], rtol=1e-6)  # a small residual is kept
    # same direction; a 100× larger outlier weighs only ≈ 1.6× more (logarithmic growth)
    assert np.allclose(out[2] / np.linalg.norm(out[2]), r[2] / 5.0)
    assert np.linalg.norm(out[3]) / np.linalg.norm(out[2]) == pytest.approx(1.62, abs=0.01)


# ---------------------------------------------------------------------------- local minima
@pytest.fixture(scope="module")
def p09_demo():
    """SMPC(0.9) in the 3rd interactive scenario of seed 2: least squares' local minimum."""
    from drivestyle.agents import generate_demonstration
    from drivestyle.agents.demo_generation import draw_interactive_scenarios
    from drivestyle.agents.smpc import SMPCConfig

    scenario = draw_interactive_scenarios(3, seed=2)[2]
    return generate_demonstration(0.9, scenario, SMPCConfig(risk=0.9))[0]


@pytest.mark.slow  # one learning from a local minimum's start (≈ 4 s)
def test_the_cauchy_descent_leaves_least_squares_local_minimum(p09_demo):
    # least squares alone (before the Cauchy descent) stopped at w_δ 57 against the
    # driver's 10, 4.4 noise floors: poor_fit (the default search: w_δ 81630, 5.6 floors)
    fit = learn_driver([p09_demo], screen=4, restarts=1)
    assert fit.status == "converged" and not fit.poor_demos and not fit.notes
    assert np.allclose(fit.style.normalised(), SMPC_WEIGHTS, rtol=1e-3)
    assert fit.style.risk == pytest.approx(0.9, abs=1e-3)
    assert fit.residual_rms < 1e-3 * fit.residual_floor
    assert fit.per_demo[0].reproduced and fit.per_demo[0].closed_loop.rmse_xy_m < 1e-3


# ---------------------------------------------------------------------------- low risks
@pytest.mark.parametrize("risk", [0.5, 0.55])
@pytest.mark.parametrize(
    "n_demos",
    [1, pytest.param(2, marks=pytest.mark.slow), pytest.param(3, marks=pytest.mark.slow)],
)  # ≈ 3 s per demonstration: 14 teacher-forced passes each
def test_a_low_risk_driver_is_learned_from_a_start_on_another_tooth(smpc_demos, risk, n_demos):
    # the driver's own weights at p = 0.7: LM in p alone stopped on a tooth of the
    # saw-tooth objective; the profile over p finds the driver's risk
    demos = smpc_demos[risk][:n_demos]
    start = DriverStyle(SMPC_WEIGHTS, risk=0.7)
    fit = learn_driver(demos, initial=start, screen=1, restarts=1, max_iter=5)
    assert fit.style.risk == risk
    assert np.allclose(fit.style.normalised(), SMPC_WEIGHTS)
    assert fit.status == "converged" and fit.residual_rms < 1e-6
    assert [d.best_risk for d in fit.per_demo] == [risk] * n_demos
    assert not fit.poor_demos


@pytest.mark.slow  # the default search: 24 starts, 2 LM runs (≈ 20–90 s each)
@pytest.mark.parametrize("risk", [0.5, 0.55])
@pytest.mark.parametrize("n_demos", [1, 2, 3])
def test_a_low_risk_driver_is_learned_with_the_default_search(smpc_demos, risk, n_demos):
    # before the profile over p, two p = 0.5 demonstrations were learned as p = 0.695
    # ("converged", cost 6698, residual rms 10.6 σ_u)
    fit = learn_driver(smpc_demos[risk][:n_demos])
    assert fit.style.risk == pytest.approx(risk, abs=0.01)
    assert fit.status == "converged" and not fit.poor_demos
    assert fit.residual_rms < fit.poor_fit_threshold


# ---------------------------------------------------------------------------- honest status


def test_a_fit_whose_closed_loop_reproduces_the_demonstration_is_not_poor(paper_demo):
    # one recorded input off by 5 σ_u, the path as driven: 6.5 floors of teacher-forced
    # residual, but the style drives the recorded path (before the closed-loop check:
    # poor_fit)
    u = paper_demo.u.copy()
    u[8, 0] += 5 * INPUT_SCALE[0]
    demo = replace(paper_demo, u=u)
    start = DriverStyle(SMPC_WEIGHTS, risk=0.7)
    fit = learn_driver([demo], initial=start, fit_weights=False)
    (d,) = fit.per_demo
    assert d.residual_rms > fit.poor_fit_threshold and d.reproduced and not d.poor
    assert fit.status == fit.optimiser_status == "converged"
    assert fit.style.risk == pytest.approx(0.7, abs=1e-3)
    assert len(fit.notes) == 1 and fit.notes[0].startswith("per_demo[0]: teacher-forced")
    assert fit.to_json()["notes"] == list(fit.notes)


@pytest.mark.slow  # a learning of two drivers' demonstrations (≈ 3 s)
def test_a_fit_whose_closed_loop_misses_the_demonstration_stays_poor(paper_demo):
    # p = 0.5 and p = 0.95 drivers with the expert's weights given, one shared risk learned:
    # one of them is neither fitted nor reproduced
    from drivestyle.agents import generate_demonstration

    demos = [generate_demonstration(p)[0] for p in (0.5, 0.95)]
    start = DriverStyle(SMPC_WEIGHTS, risk=0.7)
    fit = learn_driver(demos, initial=start, fit_weights=False)
    assert fit.status == "poor_fit" and fit.poor_demos and not fit.notes
    for i in fit.poor_demos:
        d = fit.per_demo[i]
        assert d.residual_rms > fit.poor_fit_threshold and not d.reproduced
        assert d.closed_loop.rmse_xy_m > 10 * REPRODUCTION_TOLERANCE


def test_learning_refuses_a_non_positive_floor(paper_demo):
    with pytest.raises(DriverStyleError, match="floor"):
        learn_driver([paper_demo], residual_floor=0.0)


@pytest.mark.slow  # three demonstrations, the default search (≈ 2 min)
def test_two_drivers_learned_together_are_a_poor_fit_naming_the_odd_one(smpc_demos):
    demos = [*smpc_demos[0.5][:2], smpc_demos[0.9][2]]
    fit = learn_driver(demos)
    assert fit.status == "poor_fit" and fit.optimiser_status in ("converged", "max_iter")
    assert fit.poor_demos == (2,)
    assert fit.per_demo[2].best_risk >= 0.85
    assert fit.per_demo[2].residual_rms > fit.poor_fit_threshold


def test_with_the_cost_given_only_the_drivers_risk_is_learned(paper_demo):
    # an SMPC(0.77) driver with the expert's weights given: the risk off the profile grid
    from drivestyle.agents import generate_demonstration

    demo = generate_demonstration(0.77)[0]
    start = DriverStyle(SMPC_WEIGHTS, risk=0.7)
    fit = learn_driver([demo], initial=start, fit_weights=False)
    assert fit.style.weights == start.weights
    assert fit.style.risk == pytest.approx(0.77, abs=0.005) and fit.cost < 1e-10
    with pytest.raises(DriverStyleError, match="give initial"):
        learn_driver([paper_demo], fit_weights=False)
    with pytest.raises(DriverStyleError, match="nothing to learn"):
        learn_driver([paper_demo], risks=[0.7], initial=start, fit_weights=False)
