"""The prediction study's statistics: per set, t_obs and method, and the goals.

:func:`summarise_records` summarises the records of each (set, t_obs, method)
(:class:`MethodSummary`): means and medians, the reduction against constant velocity and the
gap to the oracle, and every error of :data:`~drivestyle.prediction.errors.ERROR_METRICS`
with bootstrap 95 % intervals of its mean and median resampling vehicles
(:func:`bootstrap_stats`, seed :data:`BOOTSTRAP_SEED`; the resampling itself is
:mod:`drivestyle.common.stats`'s). :func:`goal_checks` checks the goals (:data:`GOALS`) for
the identified-style methods (:class:`GoalCheck`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from drivestyle.common.stats import bootstrap_rows, percentile_interval
from drivestyle.prediction.errors import ERROR_METRICS
from drivestyle.prediction.methods import METHODS
from drivestyle.studies.prediction.records import PredictionRecord

__all__ = [
    "BOOTSTRAP_SAMPLES",
    "BOOTSTRAP_SEED",
    "GOALS",
    "RECORDED",
    "SIMULATED",
    "STYLE_METHODS",
    "ErrorStat",
    "GoalCheck",
    "MethodSummary",
    "bootstrap_stats",
    "goal_checks",
    "summarise_records",
]

STYLE_METHODS = ("mode", "mixture")
"""The identified-style methods the goals are checked for."""

GOALS = {
    "simulated_vs_cv": 0.30,
    "recorded_vs_cv": 0.15,
    "simulated_vs_oracle": 1.25,
}
"""The issue's goals: FDE ≥ 30 % below CV on simulated vehicles, ≥ 15 % below on recorded
ones (each dataset and both pooled), and FDE ≤ 1.25 × the oracle's on simulated ones."""
SIMULATED = "simulated"
"""The set of the simulated held-out vehicles."""
RECORDED = "recorded"
"""The pooled set of every recorded episode (NGSIM and CATS)."""

BOOTSTRAP_SEED = 26
"""The seed of the bootstrap intervals."""
BOOTSTRAP_SAMPLES = 2000
"""Bootstrap replicates per interval."""


@dataclass(frozen=True)
class MethodSummary:
    """One method's errors over one set at one t_obs."""

    set: str
    t_obs: float
    method: str
    n: int
    ade_mean_m: float
    ade_median_m: float
    fde_mean_m: float
    fde_median_m: float
    fde_lat_mean_m: float
    """Mean lateral part of the FDE [m]."""
    fde_reduction_vs_cv: float | None
    """1 − mean FDE / mean FDE of constant velocity over the same records."""
    fde_ratio_to_oracle: float | None
    """Mean FDE / mean FDE of the oracle over the same records (simulated only). The oracle
    is often exact (FDE ≈ 0: SMPC(p) is its own style), which makes this ratio explode;
    :attr:`fde_gap_to_oracle_m` and :attr:`oracle_gain_share` read better then."""
    fde_gap_to_oracle_m: float | None = None
    """Mean FDE − the oracle's mean FDE [m]."""
    oracle_gain_share: float | None = None
    """(FDE_cv − FDE) / (FDE_cv − FDE_oracle): the share of the oracle's gain over constant
    velocity this method achieves (1: as good as the oracle)."""
    stats: dict[str, ErrorStat] = field(default_factory=dict)
    """Error of :data:`ERROR_METRICS` → its mean and median with bootstrap 95 % intervals."""
    n_units: int = 0
    """Distinct vehicles the records come from (what the bootstrap resamples)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "stats"}
        return out | {
            "t_obs_s": self.t_obs,
            "stats": {k: v.to_json() for k, v in self.stats.items()},
        }


@dataclass(frozen=True)
class ErrorStat:
    """One error's mean and median over a set of records, with bootstrap 95 % intervals [m]."""

    mean: float
    mean_lo: float
    mean_hi: float
    median: float
    median_lo: float
    median_hi: float

    def to_json(self) -> dict[str, float]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def bootstrap_stats(
    values: np.ndarray,
    units: Sequence[str],
    samples: int = BOOTSTRAP_SAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> list[ErrorStat]:
    """Mean and median of each column with percentile bootstrap 95 % intervals over units.

    :func:`drivestyle.common.stats.bootstrap_rows`: a replicate draws the distinct units
    (vehicles) with replacement and takes every record of each drawn unit; the interval is
    the 2.5–97.5 % percentile of the replicates' statistic. The same replicates serve every
    column (paired comparisons).

    Args:
        values: errors, shape (records, columns) [m]; a column with NaN gets NaN statistics.
        units: each record's unit, length records.
        samples: replicates B.
        seed: the replicates' seed.

    Returns:
        One :class:`ErrorStat` per column.
    """
    values = np.asarray(values, dtype=float).reshape(len(units), -1)
    means = np.empty((samples, values.shape[1]))
    medians = np.empty_like(means)
    for b, rows in enumerate(bootstrap_rows(units, samples, np.random.default_rng(seed))):
        sub = values[rows]
        means[b] = sub.mean(axis=0)
        medians[b] = np.median(sub, axis=0)
    out = []
    for c in range(values.shape[1]):
        mlo, mhi = percentile_interval(means[:, c])
        dlo, dhi = percentile_interval(medians[:, c])
        col = values[:, c]
        out.append(ErrorStat(float(col.mean()), float(mlo), float(mhi),
                             float(np.median(col)), float(dlo), float(dhi)))  # fmt: skip
    return out


@dataclass(frozen=True)
class GoalCheck:
    """One of the issue's goals (:data:`GOALS`) for one set, t_obs and style method."""

    goal: str
    """A key of :data:`GOALS`."""
    set: str
    t_obs: float
    method: str
    threshold: float
    value: float | None
    """The reduction vs CV (``*_vs_cv``) or the ratio to the oracle (``*_vs_oracle``)."""
    met: bool

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"goal": self.goal, "set": self.set, "t_obs_s": self.t_obs,
                "method": self.method, "threshold": self.threshold, "value": self.value,
                "met": self.met}  # fmt: skip


def _summary(
    set_name: str, t: float, method: str, recs: Sequence[PredictionRecord]
) -> MethodSummary:
    ade = np.array([r.ade_m[method] for r in recs])
    fde = np.array([r.fde_m[method] for r in recs])
    with_cv = [r for r in recs if "cv" in r.fde_m]
    with_oracle = [r for r in recs if "oracle" in r.fde_m]
    cv = float(np.mean([r.fde_m["cv"] for r in with_cv])) if len(with_cv) == len(recs) else None
    oracle = (
        float(np.mean([r.fde_m["oracle"] for r in with_oracle]))
        if with_oracle and len(with_oracle) == len(recs)
        else None
    )
    mean = float(fde.mean())
    return MethodSummary(
        set=set_name,
        t_obs=t,
        method=method,
        n=len(recs),
        ade_mean_m=float(ade.mean()),
        ade_median_m=float(np.median(ade)),
        fde_mean_m=mean,
        fde_median_m=float(np.median(fde)),
        fde_lat_mean_m=float(np.mean([r.fde_lat_m.get(method, np.nan) for r in recs])),
        fde_reduction_vs_cv=None if not cv else float(1.0 - mean / cv),
        fde_ratio_to_oracle=None if not oracle else float(mean / oracle),
        fde_gap_to_oracle_m=None if oracle is None else float(mean - oracle),
        oracle_gain_share=(
            None
            if oracle is None or not cv or cv - oracle <= 0
            else float((cv - mean) / (cv - oracle))
        ),
    )


def summarise_records(
    records: Sequence[PredictionRecord], samples: int = BOOTSTRAP_SAMPLES
) -> list[MethodSummary]:
    """Per (set, t_obs, method) the errors over the records that have the method.

    Sets: every record's own, and :data:`RECORDED` pooling the recorded sets (NGSIM and
    CATS) when more than one is present. Each summary's :attr:`MethodSummary.stats` are
    :func:`bootstrap_stats` over the records' units (``samples`` replicates).
    """
    by_set: dict[str, list[PredictionRecord]] = {}
    for r in records:
        by_set.setdefault(r.set, []).append(r)
    recorded = [r for r in records if r.set != SIMULATED]
    if len({r.set for r in recorded}) > 1:
        by_set[RECORDED] = recorded
    out = []
    for set_name, recs in by_set.items():
        for t in sorted({r.t_obs for r in recs}):
            at_t = [r for r in recs if r.t_obs == t]
            for method in METHODS:
                have = [r for r in at_t if method in r.fde_m]
                if have:
                    out.append(_with_stats(_summary(set_name, t, method, have), have, samples))
    return out


def _with_stats(
    summary: MethodSummary, recs: Sequence[PredictionRecord], samples: int
) -> MethodSummary:
    values = np.array([[r.error(m, summary.method) for m in ERROR_METRICS] for r in recs])
    units = [r.unit or r.vehicle_id for r in recs]
    stats = bootstrap_stats(values, units, samples, BOOTSTRAP_SEED)
    return replace(summary, stats=dict(zip(ERROR_METRICS, stats, strict=True)),
                   n_units=len(set(units)))  # fmt: skip


def goal_checks(summaries: Sequence[MethodSummary]) -> list[GoalCheck]:
    """Every goal of :data:`GOALS` for each style method, set and t_obs that applies."""
    out = []
    for s in summaries:
        if s.method not in STYLE_METHODS:
            continue
        if s.set == "simulated":
            checks = [("simulated_vs_cv", s.fde_reduction_vs_cv, True),
                      ("simulated_vs_oracle", s.fde_ratio_to_oracle, False)]  # fmt: skip
        else:
            checks = [("recorded_vs_cv", s.fde_reduction_vs_cv, True)]
        for goal, value, at_least in checks:
            thr = GOALS[goal]
            met = value is not None and (value >= thr if at_least else value <= thr)
            out.append(GoalCheck(goal, s.set, s.t_obs, s.method, thr, value, met))
    return out
