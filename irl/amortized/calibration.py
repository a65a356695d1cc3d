"""Simulation-based calibration of a posterior estimator (DESIGN §22).

Draw θ_i from the prior, simulate x_i, draw S samples from the estimated posterior
q(θ | x_i). If q is the posterior of that prior, θ_i is one more draw from it, so its rank
among the S samples — the number of samples below it, 0 … S — is uniform on {0, …, S}
for every parameter (Talts et al. 2018, *Validating Bayesian inference algorithms with
simulation-based calibration*). A ∪-shaped rank histogram says the posterior is too
narrow, a ∩-shaped one too wide, a sloped one biased. The same draws give the coverage of
central intervals: the share of the θ_i inside the central ``level`` interval of their
samples, ``level`` for a calibrated estimator.

Pure functions on numpy arrays; :func:`calibrate` collects them in a :class:`Calibration`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

__all__ = [
    "Calibration",
    "calibrate",
    "central_coverage",
    "central_intervals",
    "rank_histogram",
    "rank_uniformity",
    "sbc_ranks",
]


def _checked(theta: np.ndarray, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    theta = np.asarray(theta, float)
    samples = np.asarray(samples, float)
    if theta.ndim != 2 or samples.ndim != 3 or samples.shape[::2] != theta.shape:
        raise ValueError(
            f"theta must be (N, D) and samples (N, S, D) with the same N and D, got "
            f"{theta.shape} and {samples.shape}"
        )
    if samples.shape[1] < 1:
        raise ValueError("need at least one posterior sample per simulation")
    return theta, samples


def sbc_ranks(theta: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """Rank of each true parameter among its posterior samples (Talts et al. 2018).

    Args:
        theta: true parameters of N held-out simulations, shape (N, D).
        samples: S posterior samples for each, shape (N, S, D).

    Returns:
        Shape (N, D) int: the number of samples strictly below the true value, 0 … S.
    """
    theta, samples = _checked(theta, samples)
    return np.sum(samples < theta[:, None, :], axis=1)


def rank_histogram(ranks: np.ndarray, n_samples: int, bins: int = 10) -> np.ndarray:
    """Counts of the ranks 0 … S in ``bins`` equal bins, per parameter: shape (bins, D).

    Rank r goes to bin floor(r · bins / (S + 1)): each bin covers the same number of rank
    values when ``bins`` divides S + 1.
    """
    ranks = np.asarray(ranks, int)
    if ranks.ndim != 2 or np.any(ranks < 0) or np.any(ranks > n_samples):
        raise ValueError(f"ranks must be (N, D) in 0 … {n_samples}")
    if not 1 <= bins <= n_samples + 1:
        raise ValueError(f"bins must lie in [1, {n_samples + 1}], got {bins}")
    which = (ranks * bins) // (n_samples + 1)
    return np.stack([np.bincount(which[:, d], minlength=bins) for d in range(ranks.shape[1])], 1)


def rank_uniformity(ranks: np.ndarray, n_samples: int, bins: int = 10) -> np.ndarray:
    """p-value of the χ² test that the binned ranks are uniform, per parameter: shape (D,).

    Each bin's expected count is proportional to the number of rank values it covers.
    """
    counts = rank_histogram(ranks, n_samples, bins)
    values = np.bincount((np.arange(n_samples + 1) * bins) // (n_samples + 1), minlength=bins)
    expected = (values / values.sum())[:, None] * counts.sum(axis=0, keepdims=True)
    return np.asarray(stats.chisquare(counts, expected, axis=0).pvalue, float)


def central_intervals(samples: np.ndarray, level: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """The central ``level`` interval of each simulation's samples, per parameter.

    Args:
        samples: shape (N, S, D).
        level: the intervals' level, in (0, 1).

    Returns:
        (lo, hi), each (N, D): the (1 − level)/2 and (1 + level)/2 quantiles of the S samples.
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    lo, hi = np.quantile(samples, [(1 - level) / 2, (1 + level) / 2], axis=1)
    return lo, hi


def central_coverage(theta: np.ndarray, samples: np.ndarray, level: float = 0.9) -> np.ndarray:
    """Share of true parameters inside their samples' central ``level`` interval: shape (D,).

    The interval of simulation i and parameter d runs from the (1 − level)/2 to the
    (1 + level)/2 quantile of its S samples (closed): :func:`central_intervals`.
    """
    theta, samples = _checked(theta, samples)
    lo, hi = central_intervals(samples, level)
    return np.mean((theta >= lo) & (theta <= hi), axis=0)


@dataclass(frozen=True)
class Calibration:
    """An estimator's calibration on held-out simulations (module docstring)."""

    names: tuple[str, ...]
    """Parameter names."""
    ranks: np.ndarray
    """SBC ranks, shape (N, D), each in 0 … ``n_samples``."""
    n_samples: int
    """Posterior samples per simulation S."""
    level: float
    """Level of the central intervals whose coverage is reported."""
    coverage: np.ndarray
    """Empirical coverage of the central ``level`` intervals, shape (D,)."""
    uniformity_p: np.ndarray
    """χ² p-values of uniform ranks (:func:`rank_uniformity`), shape (D,)."""
    bins: int
    """Rank-histogram bins of the χ² test."""

    def __post_init__(self) -> None:
        d = len(self.names)
        if self.ranks.ndim != 2 or self.ranks.shape[1] != d:
            raise ValueError(f"ranks must have shape (N, {d}), got {self.ranks.shape}")
        if self.coverage.shape != (d,) or self.uniformity_p.shape != (d,):
            raise ValueError(f"coverage and uniformity_p must have shape ({d},)")

    @property
    def histogram(self) -> np.ndarray:
        """Rank counts per bin and parameter, shape (bins, D)."""
        return rank_histogram(self.ranks, self.n_samples, self.bins)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready summary (per parameter: coverage, p-value, rank histogram)."""
        hist = self.histogram
        return {
            "n_simulations": int(self.ranks.shape[0]),
            "n_samples": self.n_samples,
            "level": self.level,
            "parameters": {
                name: {
                    "coverage": float(self.coverage[d]),
                    "uniformity_p": float(self.uniformity_p[d]),
                    "rank_histogram": hist[:, d].tolist(),
                }
                for d, name in enumerate(self.names)
            },
        }


def calibrate(
    theta: np.ndarray,
    samples: np.ndarray,
    names: tuple[str, ...],
    level: float = 0.9,
    bins: int = 10,
) -> Calibration:
    """SBC ranks, their uniformity and the coverage of central intervals.

    Args:
        theta: true parameters of N held-out simulations, shape (N, D).
        samples: S posterior samples for each, shape (N, S, D).
        names: the D parameter names.
        level: central interval level (0.9: the 90 % interval).
        bins: rank-histogram bins of the uniformity test.
    """
    theta, samples = _checked(theta, samples)
    ranks = sbc_ranks(theta, samples)
    s = samples.shape[1]
    return Calibration(
        names=tuple(names),
        ranks=ranks,
        n_samples=s,
        level=level,
        coverage=central_coverage(theta, samples, level),
        uniformity_p=rank_uniformity(ranks, s, bins),
        bins=bins,
    )
