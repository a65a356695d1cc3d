"""The amortized posterior's training set: stochastic drivers simulated from their prior."""

import dataclasses
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.amortized.simulations import (
    PARAMETERS,
    SimulationsFileError,
    expert_parameters,
    load_simulated,
    parameter_box,
    parameters_of,
    save_simulated,
    series_width,
    simulate_set,
    style_of,
    with_prefixes,
)
from drivestyle.irl.driver.stochastic_prior import StochasticPrior

PRIOR = StochasticPrior()


@pytest.fixture(scope="module")
def sims():
    return simulate_set(PRIOR, 3, seed=5)


def test_the_training_set_has_one_row_of_every_parameter_and_one_series_per_episode(sims):
    low, high = parameter_box(PRIOR)
    assert sims.theta.shape == (3, len(PARAMETERS)) == (3, 9)
    assert np.all(sims.theta >= low - 1e-12) and np.all(sims.theta <= high + 1e-12)
    assert [x.shape for x in sims.series] == [(41, series_width())] * 3  # 8 s at 0.2 s
    assert series_width() == 6 + 4 * 3  # EV, then per vehicle [Δx, Δy, Δv] and its mask
    assert all(np.all(np.isfinite(x)) for x in sims.series)
    assert sims.seconds.shape == sims.failures.shape == (3,) and sims.wall_s > 0
    # θ is the drawn driver's, the desired speed as its ratio to the EV's start speed
    draws = PRIOR.draw(3, 5)
    np.testing.assert_array_equal(sims.theta, np.stack([parameters_of(d) for d in draws]))
    d = draws[0]
    assert sims.theta[0, 1] == pytest.approx(d.style.v_ref / d.scene.base.ev_speed)


def test_the_training_set_is_deterministic_given_the_seed(sims):
    again = simulate_set(PRIOR, 2, seed=5)  # the first two of the same draws
    np.testing.assert_array_equal(again.theta, sims.theta[:2])
    for a, b in zip(again.series, sims.series[:2], strict=True):
        np.testing.assert_array_equal(a, b)
    other = simulate_set(PRIOR, 1, seed=6)
    assert not np.array_equal(other.theta[0], sims.theta[0])


def test_prefixes_are_the_episodes_observed_for_less_time(sims):
    low, high = parameter_box(PRIOR)
    rows = with_prefixes(sims, 2, 6, 0, low, high)
    assert rows.n == 3 + 3 * 2
    for i in range(3):
        np.testing.assert_array_equal(rows.x[i], sims.series[i])  # whole episodes first
        for j in (3 + 2 * i, 4 + 2 * i):
            t = rows.x[j].shape[0]
            assert 6 <= t < 41
            np.testing.assert_array_equal(rows.x[j], sims.series[i][:t])
            np.testing.assert_array_equal(rows.theta[j], rows.theta[i])
    np.testing.assert_array_equal(rows.groups, [0, 1, 2, 0, 0, 1, 1, 2, 2])  # validated whole
    again = with_prefixes(sims, 2, 6, 0, low, high)
    assert [x.shape for x in again.x] == [x.shape for x in rows.x]
    assert with_prefixes(sims, 0, 6, 0, low, high).n == 3


def test_a_parameter_the_prior_does_not_vary_is_refused():
    with pytest.raises(ValueError, match="risk"):
        parameter_box(StochasticPrior(risk=(0.7, 0.7)))


def test_a_kept_set_reads_back_as_simulated_and_only_for_what_made_it(sims, tmp_path):
    path = save_simulated(sims, PRIOR, 5, tmp_path / "simulations.npz")
    back = load_simulated(path, PRIOR, 5, 2)
    np.testing.assert_array_equal(back.theta, sims.theta[:2])
    for a, b in zip(back.series, sims.series[:2], strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(back.failures, sims.failures[:2])
    assert load_simulated(path, PRIOR, 5).n == 3
    with pytest.raises(SimulationsFileError, match="another seed"):
        load_simulated(path, PRIOR, 6, 2)
    with pytest.raises(SimulationsFileError, match="another prior"):
        load_simulated(path, dataclasses.replace(PRIOR, risk=(0.6, 0.99)), 5, 2)
    with pytest.raises(SimulationsFileError, match="holds 3 episodes, this build needs 4"):
        load_simulated(path, PRIOR, 5, 4)
    with pytest.raises(SimulationsFileError, match="no such"):
        load_simulated(tmp_path / "none.npz", PRIOR, 5, 1)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(SimulationsFileError, match="not a readable"):
        load_simulated(tmp_path / "bad.npz", PRIOR, 5, 1)


def test_an_estimator_of_other_features_or_parameters_is_refused(sims, tmp_path):
    pytest.importorskip("zuko")
    from drivestyle.irl.amortized.encoder import EncoderConfig
    from drivestyle.irl.amortized.estimator import (
        EstimatorConfig,
        EstimatorFileError,
        load_posterior,
    )
    from drivestyle.irl.amortized.simulations import EPISODE_FEATURES, check_episode_estimator
    from drivestyle.irl.amortized.training import Simulations, TrainingConfig, train

    low, high = parameter_box(PRIOR)
    rows = Simulations(np.clip(np.tile(sims.theta, (4, 1)), low, high), sims.series * 4)
    quick = TrainingConfig(epochs=1, batch_size=4, seed=0)

    def build(**kw):
        enc = EncoderConfig(series_width(), hidden=4, embedding=4)
        config = EstimatorConfig(PARAMETERS, tuple(low), tuple(high), enc, transforms=1,
                                 flow_hidden=(8,), **kw)  # fmt: skip
        trained = train(rows, config, quick, progress=False)[0]
        return load_posterior(trained.save(tmp_path / "p.npz"))

    assert check_episode_estimator(build(features=EPISODE_FEATURES), "p.npz").config.dim == 9
    with pytest.raises(EstimatorFileError, match=r"p\.npz: an estimator of features 'unstated'"):
        check_episode_estimator(build(), "p.npz")
    with pytest.raises(EstimatorFileError, match="build it again"):
        check_episode_estimator(build(features="episode-v1"), "p.npz")


def test_the_smpc_expert_is_the_driver_without_deviation_onset_or_speed_scaled_region():
    from drivestyle.envs.scenario import ScenarioConfig

    sc = ScenarioConfig(ev_speed=24.0, v_ref=30.0, l_a=12.0)
    theta = dict(zip(PARAMETERS, expert_parameters(sc, 0.85), strict=True))
    assert theta["risk"] == 0.85 and theta["speed_ratio"] == pytest.approx(30.0 / 24.0)
    assert theta["time_gap"] == 0.0 and theta["min_gap"] == 12.0  # the scenario's region
    assert theta["lateral"] == 1.0 and theta["onset"] == 0.0
    assert theta["sigma_a"] == theta["sigma_delta"] == 0.0


def test_style_of_inverts_parameters_of():
    for params in PRIOR.draw(20, 3):
        style = style_of(parameters_of(params), params.scene.base.ev_speed)
        assert style.v_ref == pytest.approx(params.style.v_ref, rel=1e-12)
        assert replace(style, v_ref=params.style.v_ref) == params.style
    with pytest.raises(ValueError, match="9 finite numbers"):
        style_of(np.zeros(3), 20.0)
