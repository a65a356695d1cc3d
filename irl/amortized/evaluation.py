"""A trained posterior judged on held-out simulations (DESIGN §22).

For held-out pairs (θ_i, x_i) drawn from the prior the estimator trained under, per
parameter: the posterior mean's mean absolute error (absolute, and relative to the box's
width), the same error of the prior's mean (the training set's mean θ: what an estimator
that reads nothing would say), the coverage of the central 90 % intervals and the χ²
p-value of uniform SBC ranks (:func:`~drivestyle.irl.amortized.calibration.calibrate`);
and the time to identify one episode — :meth:`~drivestyle.irl.amortized.estimator.
NeuralPosterior.sample` of ``samples`` draws for one series on one torch thread —
median and 95th percentile over the held-out episodes.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from drivestyle.irl.amortized.calibration import calibrate
from drivestyle.irl.amortized.estimator import NeuralPosterior

__all__ = ["evaluate_posterior", "identification_seconds"]


def identification_seconds(
    posterior: NeuralPosterior, series: Sequence[np.ndarray], samples: int
) -> np.ndarray:
    """Time of ``posterior.sample(x, samples)`` per series, on one torch thread [s]: (n,)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        posterior.sample(series[0], samples)  # warm-up: first calls allocate
        out = []
        for i, x in enumerate(series):
            t0 = time.perf_counter()
            posterior.sample(x, samples, seed=i)
            out.append(time.perf_counter() - t0)
    finally:
        torch.set_num_threads(threads)
    return np.array(out)


def evaluate_posterior(
    posterior: NeuralPosterior,
    theta: np.ndarray,
    series: Sequence[np.ndarray],
    prior_mean: np.ndarray,
    samples: int = 200,
    seed: int = 0,
    level: float = 0.9,
    batch: int = 50,
) -> dict[str, Any]:
    """The held-out evaluation (module docstring) as a JSON-ready dict.

    Args:
        posterior: the trained estimator.
        theta: true parameters of the held-out simulations, shape (M, D), in the box.
        series: their observed series.
        prior_mean: the prior's mean θ (the baseline's answer), shape (D,).
        samples: posterior samples per simulation S (SBC ranks 0 … S, intervals, means).
        seed: seeds the draws (batch j with ``seed + j``).
        level: the central intervals' level.
        batch: series sampled at once.

    Returns:
        ``parameters``: per name its ``mae``, ``mae_relative`` (to the box's width),
        ``prior_mean_mae``, ``prior_mean_mae_relative``, ``coverage``, ``uniformity_p``,
        ``rank_histogram``; ``identification_ms`` (median, p95, the draws); and the counts.
    """
    theta = np.asarray(theta, float)
    cfg = posterior.config
    if theta.ndim != 2 or theta.shape != (len(series), cfg.dim):
        raise ValueError(f"theta must have shape ({len(series)}, {cfg.dim}), got {theta.shape}")
    if samples < 2:
        raise ValueError(f"samples must be >= 2, got {samples}")
    draws = np.concatenate([
        posterior.sample_batch(list(series[s : s + batch]), samples, seed=seed + j)
        for j, s in enumerate(range(0, len(series), batch))
    ])  # fmt: skip
    width = np.array(cfg.high) - np.array(cfg.low)
    mean = draws.mean(axis=1)
    mae = np.abs(mean - theta).mean(axis=0)
    base = np.abs(np.asarray(prior_mean, float)[None] - theta).mean(axis=0)
    cal = calibrate(theta, draws, cfg.names, level=level).to_json()
    seconds = identification_seconds(posterior, series, samples)
    return {
        "n_simulations": len(series),
        "n_samples": samples,
        "level": level,
        "parameters": {
            name: {
                "mae": float(mae[d]),
                "mae_relative": float(mae[d] / width[d]),
                "prior_mean_mae": float(base[d]),
                "prior_mean_mae_relative": float(base[d] / width[d]),
                **cal["parameters"][name],
            }
            for d, name in enumerate(cfg.names)
        },
        "identification_ms": {
            "samples": samples,
            "median": float(1000 * np.median(seconds)),
            "p95": float(1000 * np.percentile(seconds, 95)),
            "threads": 1,
        },
    }
