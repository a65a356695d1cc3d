"""Resampling statistics: the one bootstrap every study's intervals come from.

A percentile bootstrap over *units* (the vehicles of a benchmark, the lane changes of a
comparison): a replicate draws the distinct units with replacement, as many as there are,
and takes every record of each drawn unit, so records of one unit never count as
independent evidence. Nothing here knows a vehicle: units are labels.

Two effect sizes the studies report with it: :func:`auroc`, how well a score tells two
groups apart (its interval :func:`auroc_interval`, the bootstrap within each group), and
:func:`icc_oneway`, the intra-class correlation of repeated measurements (its interval
from the F distribution).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "ICC",
    "auroc",
    "auroc_interval",
    "bootstrap_rows",
    "icc_oneway",
    "percentile_interval",
]


def bootstrap_rows(
    units: Sequence[Any], samples: int, rng: np.random.Generator
) -> list[np.ndarray]:
    """The records of each bootstrap replicate, resampling units.

    The distinct units, sorted, are drawn ``samples`` × (number of units) times with
    replacement by ``rng.integers`` in one call (so a caller's later draws from the same
    ``rng`` are reproducible); replicate b is the concatenation of the drawn units'
    record indices.

    Args:
        units: each record's unit, length r (any sortable labels).
        samples: replicates B.
        rng: the generator (its state advances by one draw of shape (B, units)).

    Returns:
        B arrays of record indices into ``units``.
    """
    labels = np.asarray(units)
    names = sorted(set(labels.tolist()))
    rows = [np.flatnonzero(labels == u) for u in names]
    draws = rng.integers(0, len(names), (samples, len(names)))
    if all(r.size == 1 for r in rows):  # one record per unit: the draws are the records
        order = np.array([r[0] for r in rows])
        return list(order[draws])
    return [np.concatenate([rows[i] for i in pick]) for pick in draws]


def percentile_interval(replicates: np.ndarray, level: float = 0.95) -> tuple[float, float]:
    """The central percentile interval of bootstrap replicates, e.g. 2.5–97.5 % for 0.95.

    Args:
        replicates: the statistic over the replicates, shape (B,).
        level: the interval's coverage.

    Returns:
        (lower, upper).
    """
    tail = 50.0 * (1.0 - level)
    lo, hi = np.percentile(np.asarray(replicates, float), [tail, 100.0 - tail])
    return float(lo), float(hi)


def _pairwise(positive: np.ndarray, negative: np.ndarray) -> np.ndarray:
    """C[i, j] = 1 where positive_i > negative_j, ½ where equal, else 0: shape (P, N)."""
    diff = positive[:, None] - negative[None, :]
    return (diff > 0) + 0.5 * (diff == 0)


def _scores(values: Sequence[float], what: str) -> np.ndarray:
    a = np.asarray(values, float)
    if a.ndim != 1 or a.size < 1 or not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be a non-empty list of finite numbers, got shape {a.shape}")
    return a


def auroc(positive: Sequence[float], negative: Sequence[float]) -> float:
    """The area under the ROC curve of a score: P(X > Y) + ½ P(X = Y).

    X a record of the positive group, Y one of the negative (the Mann–Whitney U over the
    product of the sizes): 1 when every positive scores above every negative, 0 when below,
    ½ when the score does not tell them apart.

    Raises:
        ValueError: a group empty or a value not finite.
    """
    pos, neg = _scores(positive, "positive"), _scores(negative, "negative")
    return float(_pairwise(pos, neg).mean())


def auroc_interval(
    positive: Sequence[float],
    negative: Sequence[float],
    samples: int,
    rng: np.random.Generator,
    level: float = 0.95,
) -> tuple[float, float]:
    """The percentile-bootstrap interval of :func:`auroc`, each group resampled on its own.

    Each record is its own unit (:func:`bootstrap_rows` draws the positive group's records,
    then the negative group's, from ``rng``): a replicate keeps both groups' sizes.

    Returns:
        (lower, upper).
    """
    pos, neg = _scores(positive, "positive"), _scores(negative, "negative")
    pairs = _pairwise(pos, neg)
    draws_p = np.array(bootstrap_rows(range(pos.size), samples, rng))  # (B, P)
    draws_n = np.array(bootstrap_rows(range(neg.size), samples, rng))  # (B, N)
    counts_p = np.stack([np.bincount(r, minlength=pos.size) for r in draws_p])
    counts_n = np.stack([np.bincount(r, minlength=neg.size) for r in draws_n])
    replicates = np.einsum("bi,ij,bj->b", counts_p, pairs, counts_n) / (pos.size * neg.size)
    return percentile_interval(replicates, level)


@dataclass(frozen=True)
class ICC:
    """A one-way intra-class correlation with its interval (:func:`icc_oneway`)."""

    icc: float
    """(MSB − MSW) / (MSB + (n₀ − 1) MSW); negative where the classes differ less than
    chance would make them."""
    lo: float
    """The interval's lower end."""
    hi: float
    """Its upper end."""
    classes: int
    """Classes k."""
    records: int
    """Records N."""


def icc_oneway(values: Sequence[float], classes: Sequence[Any], level: float = 0.95) -> ICC | None:
    """ICC(1): the share of the variance between classes, from a one-way ANOVA.

    The one-way random-effects intra-class correlation (Shrout & Fleiss 1979, ICC(1,1);
    McGraw & Wong 1996, case 1) of records grouped into classes of unequal sizes n_i
    (n₀ = (N − Σ n_i² / N) / (k − 1), Donner 1986), and its interval from the F
    distribution: F = MSB / MSW, F_L = F / F_{1−α/2}(k − 1, N − k),
    F_U = F · F_{1−α/2}(N − k, k − 1), the ends (F_x − 1) / (F_x + n₀ − 1).

    Args:
        values: one number per record.
        classes: each record's class (any labels).
        level: the interval's coverage.

    Returns:
        The :class:`ICC`; None where it is not defined: fewer than two classes, no class
        with two records, or no variance within the classes.
    """
    from scipy.stats import f

    x = _scores(values, "values")
    labels = np.asarray(classes)
    if labels.shape != x.shape:
        raise ValueError(f"{x.size} values but {labels.size} class labels")
    names = sorted(set(labels.tolist()))
    groups = [x[labels == c] for c in names]
    k, n = len(groups), x.size
    if k < 2 or n - k < 1:
        return None
    sizes = np.array([g.size for g in groups], float)
    means = np.array([g.mean() for g in groups])
    msb = float(np.sum(sizes * (means - x.mean()) ** 2) / (k - 1))
    msw = float(sum(np.sum((g - g.mean()) ** 2) for g in groups) / (n - k))
    if msw <= 0:
        return None
    n0 = (n - np.sum(sizes**2) / n) / (k - 1)
    ratio = msb / msw
    q = 1.0 - (1.0 - level) / 2
    f_lo = ratio / f.ppf(q, k - 1, n - k)
    f_hi = ratio * f.ppf(q, n - k, k - 1)
    icc = (msb - msw) / (msb + (n0 - 1) * msw)
    return ICC(float(icc), float((f_lo - 1) / (f_lo + n0 - 1)),
               float((f_hi - 1) / (f_hi + n0 - 1)), k, n)  # fmt: skip
