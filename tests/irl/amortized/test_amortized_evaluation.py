"""A posterior trained on stochastic drivers, judged on held-out ones, saved and verified."""

import numpy as np
import pytest

from drivestyle.irl.amortized.encoder import EncoderConfig
from drivestyle.irl.amortized.estimator import EstimatorConfig, EstimatorFileError, load_posterior
from drivestyle.irl.amortized.evaluation import evaluate_posterior
from drivestyle.irl.amortized.simulations import (
    PARAMETERS,
    parameter_box,
    series_width,
    simulate_set,
    with_prefixes,
)
from drivestyle.irl.amortized.training import TrainingConfig, train
from drivestyle.irl.driver.stochastic_prior import StochasticPrior

pytest.importorskip("zuko")


@pytest.fixture(scope="module")
def built():
    prior = StochasticPrior()
    low, high = parameter_box(prior)
    sims = simulate_set(prior, 4, seed=11)
    config = EstimatorConfig(PARAMETERS, tuple(low), tuple(high),
                             EncoderConfig(series_width(), hidden=4, embedding=4),
                             transforms=1, flow_hidden=(8, 8))  # fmt: skip
    rows = with_prefixes(sims.subset(range(2)), 4, 6, 0, low, high)
    posterior, _ = train(rows, config, TrainingConfig(epochs=1), progress=False)
    return posterior, sims.subset(range(2, 4)), np.clip(sims.theta[:2], low, high).mean(0)


def test_the_held_out_evaluation_reports_every_parameter(built):
    posterior, held, prior_mean = built
    low, high = parameter_box(StochasticPrior())
    out = evaluate_posterior(posterior, np.clip(held.theta, low, high), held.series,
                             prior_mean, samples=10)  # fmt: skip
    assert out["n_simulations"] == 2 and list(out["parameters"]) == list(PARAMETERS)
    for d, row in enumerate(out["parameters"].values()):
        assert row["mae_relative"] == pytest.approx(row["mae"] / (high[d] - low[d]))
        expected = np.abs(prior_mean[d] - np.clip(held.theta[:, d], low[d], high[d])).mean()
        assert row["prior_mean_mae"] == pytest.approx(expected)
        assert 0 <= row["coverage"] <= 1 and sum(row["rank_histogram"]) == 2
    assert 0 < out["identification_ms"]["median"] <= out["identification_ms"]["p95"]


def test_a_corrupted_posterior_file_is_refused(built, tmp_path):
    posterior, held, _ = built
    path = posterior.save(tmp_path / "posterior.npz")
    again = load_posterior(path)
    np.testing.assert_array_equal(
        again.sample(held.series[0], 5), posterior.sample(held.series[0], 5)
    )
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    (tmp_path / "bad.npz").write_bytes(bytes(raw))
    with pytest.raises(EstimatorFileError, match=r"bad\.npz"):
        load_posterior(tmp_path / "bad.npz")
