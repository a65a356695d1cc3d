"""Resampling statistics: the one bootstrap every study's intervals come from.

A percentile bootstrap over *units* (the vehicles of a benchmark, the lane changes of a
comparison): a replicate draws the distinct units with replacement, as many as there are,
and takes every record of each drawn unit, so records of one unit never count as
independent evidence. Nothing here knows a vehicle: units are labels.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["bootstrap_rows", "percentile_interval"]


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
