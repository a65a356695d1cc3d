"""Prediction after t_obs (prediction/): baselines in closed form, errors, the style methods."""

import numpy as np
import pytest

from drivestyle.irl.driver.driver_style import DriverStyle, expert_style
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.planning.description import SMPCConfig
from drivestyle.prediction.errors import displacement_errors
from drivestyle.prediction.kinematic import (
    constant_acceleration,
    constant_velocity,
    others_at_constant_velocity,
)
from drivestyle.prediction.methods import AMORTIZED_METHODS, METHODS, method_predictors, predict
from drivestyle.prediction.protocol import ForecastError, Observation

LIBRARY = DriverLibrary(
    DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
)


def test_constant_velocity_holds_the_velocity_vector():
    state = np.array([10.0, 2.0, 0.3, 20.0])
    xy = constant_velocity(state, 0.2, 5)
    j = np.arange(6) * 0.2
    expected = np.stack([10.0 + j * 20.0 * np.cos(0.3), 2.0 + j * 20.0 * np.sin(0.3)], axis=1)
    np.testing.assert_allclose(xy, expected, atol=1e-12)


def test_constant_acceleration_is_the_parabola_of_the_last_velocity_change():
    # v: 10 → 12 m/s along x over one step of 0.5 s, heading 0: a = 4 m/s²
    states = np.array([[0.0, 1.0, 0.0, 10.0], [5.0, 1.0, 0.0, 12.0]])
    xy = constant_acceleration(states, 0.5, 4)
    tau = np.arange(5) * 0.5
    np.testing.assert_allclose(xy[:, 0], 5.0 + 12.0 * tau + 0.5 * 4.0 * tau**2, atol=1e-12)
    np.testing.assert_allclose(xy[:, 1], 1.0, atol=1e-12)
    # a turning vehicle at constant speed: the velocity vector's change, not the speed's
    turn = np.array([[0.0, 0.0, 0.0, 10.0], [2.0, 0.0, np.pi / 2, 10.0]])
    xy = constant_acceleration(turn, 1.0, 1)
    np.testing.assert_allclose(xy[1], [2.0 + 0.0 - 5.0, 0.0 + 10.0 + 5.0], atol=1e-12)
    # one sample: no acceleration, the constant-velocity path
    one = states[-1:]
    cv = constant_velocity(one[0], 0.5, 3)
    np.testing.assert_allclose(constant_acceleration(one, 0.5, 3), cv)


def test_others_at_constant_velocity():
    others = np.array([[0.0, 3.5, 0.0, 10.0], [5.0, 0.0, np.pi / 2, 2.0]])
    out = others_at_constant_velocity(others, 0.5, 2)
    assert out.shape == (3, 2, 4)
    np.testing.assert_allclose(out[2, 0], [10.0, 3.5, 0.0, 10.0], atol=1e-12)
    np.testing.assert_allclose(out[2, 1], [5.0, 2.0, np.pi / 2, 2.0], atol=1e-12)


def test_displacement_errors_by_hand():
    actual = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    predicted = np.array([[9.0, 9.0], [1.0, 3.0], [2.0, 0.0], [7.0, 3.0]])  # row 0 not scored
    ade, fde = displacement_errors(predicted, actual)
    assert fde == pytest.approx(5.0)
    assert ade == pytest.approx((3.0 + 0.0 + 5.0) / 3)


@pytest.fixture(scope="module")
def prediction(paper_demo):
    return predict(paper_demo, LIBRARY, 2.0, oracle=expert_style(SMPCConfig(risk=0.7)))


def test_predict_runs_every_method_on_the_rest(prediction, paper_demo):
    # the amortized styles need a posterior (below)
    assert list(prediction.methods) == [m for m in METHODS if m not in AMORTIZED_METHODS]
    k = round(2.0 / paper_demo.scenario.dt)
    steps = paper_demo.n - 1 - k
    assert prediction.actual.shape == (steps + 1, 2)
    np.testing.assert_allclose(prediction.actual, paper_demo.ev[k:, :2])
    np.testing.assert_allclose(prediction.observed, paper_demo.ev[: k + 1, :2])
    for m in prediction.methods.values():
        assert m.xy.shape == (steps + 1, 2)
        np.testing.assert_allclose(m.xy[0], paper_demo.ev[k, :2], atol=1e-9)
        assert (m.ade_m, m.fde_m) == pytest.approx(displacement_errors(m.xy, prediction.actual))
    js = prediction.to_json()
    assert set(js["methods"]["mode"]) == {
        "radius_m",
        "ade_m",
        "ade_lat_m",
        "ade_lon_m",
        "fde_m",
        "fde_lat_m",
        "fde_lon_m",
        "risk",
        "path",
    }
    assert js["true_risk"] == 0.7


def test_the_oracle_is_exact_and_the_mode_far_better_than_cv(prediction):
    # the paper's TV drives at constant velocity, so SMPC(0.7)'s style from the observed
    # state re-plans exactly what the SMPC did
    fde = {name: m.fde_m for name, m in prediction.methods.items()}
    assert fde["oracle"] < 0.05
    assert fde["mode"] < 0.3 * fde["cv"]


@pytest.mark.parametrize(
    "t_obs, match",
    [(0.0, "must be > 0"), (0.3, "whole number"), (1e3, "nothing to predict")],
)
def test_observation_windows_the_demo_cannot_serve(paper_demo, t_obs, match):
    with pytest.raises(ForecastError, match=match):
        predict(paper_demo, LIBRARY, t_obs, methods=("cv",))


def test_an_unknown_method_is_refused(paper_demo):
    with pytest.raises(ForecastError, match="unknown prediction method"):
        predict(paper_demo, LIBRARY, 1.0, methods=("cv", "kalman"))


def test_without_a_library_the_methods_without_a_style_run_and_the_styled_are_refused(
    paper_demo, prediction
):
    alone = predict(paper_demo, None, 2.0, methods=("cv", "ca", "physics", "joint_physics"))
    assert set(alone.methods) == {"cv", "ca", "physics", "joint_physics"}
    for name in alone.methods:  # the same paths as with a library: no style enters them
        assert np.array_equal(alone.methods[name].xy, prediction.methods[name].xy)
    with pytest.raises(ForecastError, match=r"\['mode'\] need a driver library"):
        predict(paper_demo, None, 1.0, methods=("cv", "mode"))


def test_the_lateral_final_error_is_the_y_part_of_the_fde(prediction):
    for m in prediction.methods.values():
        assert m.fde_lat_m == pytest.approx(abs(m.xy[-1, 1] - prediction.actual[-1, 1]))
        assert m.fde_lat_m <= m.fde_m + 1e-12
        assert m.to_json()["fde_lat_m"] == m.fde_lat_m


def test_every_method_is_a_predictor_of_the_observation_alone(prediction, paper_demo):
    # the table predict() runs: each predictor's path from samples 0 … k only is the method's
    k = round(2.0 / paper_demo.scenario.dt)
    seen = Observation(paper_demo.ev[: k + 1], paper_demo.vehicles[: k + 1], paper_demo.scenario)
    table = method_predictors(LIBRARY, physics=None)
    assert list(table) == ["cv", "ca", "physics", "joint_physics", "population"]  # no posterior
    for name, predictor in table.items():
        path = predictor.predict(seen, paper_demo.n - 1 - k)
        assert np.array_equal(path.xy, prediction.methods[name].xy), name
        assert path.risk == prediction.methods[name].risk, name


def test_an_observation_of_the_wrong_shape_is_refused(paper_demo):
    with pytest.raises(ForecastError, match=r"shape \(k \+ 1, 4\)"):
        Observation(paper_demo.ev[:, :2], paper_demo.vehicles, paper_demo.scenario)
    with pytest.raises(ForecastError, match="surrounding vehicles"):
        Observation(paper_demo.ev[:3], paper_demo.vehicles[:2], paper_demo.scenario)


def test_the_amortized_styles_run_with_a_posterior_and_say_their_region(tiny_posterior, paper_demo):
    posterior, _ = tiny_posterior
    pred = predict(paper_demo, None, 4.0, methods=("cv", *AMORTIZED_METHODS), amortized=posterior)
    assert list(pred.methods) == ["cv", *AMORTIZED_METHODS]
    for name in AMORTIZED_METHODS:
        m = pred.methods[name]
        assert m.xy.shape == pred.actual.shape and np.isfinite(m.fde_m)
        assert m.radius_m is not None and m.radius_m >= 0
        assert m.xy[0] == pytest.approx(pred.observed[-1])
    assert pred.methods["cv"].radius_m is None
