"""The prediction study's statistics: per set, kind, t_obs and method, and the goals.

:func:`summarise_records` summarises the records of each (set, t_obs, method)
(:class:`MethodSummary`): means and medians, the reduction against constant velocity and the
gap to the oracle, and every error of :data:`~drivestyle.prediction.errors.ERROR_METRICS`
with bootstrap 95 % intervals of its mean and median resampling vehicles
(:func:`bootstrap_stats`, seed :data:`BOOTSTRAP_SEED`; the resampling itself is
:mod:`drivestyle.common.stats`'s). These are the pooled numbers, every kind of episode
together (kind :data:`ALL_KINDS`). :func:`summarise_by_kind` makes the same summaries of the
recorded records of each episode kind (:data:`~drivestyle.recorded.kinds.EPISODE_KINDS`) and
of the stop-and-go windows whatever their kind (:data:`STOP_AND_GO`); the unit the bootstrap
resamples stays the vehicle (a vehicle's episodes of several kinds are one unit in the pooled
numbers). :func:`ratio_stats` gives, per kind and pooled, the median over records of each
method's FDE / CV's FDE (and of the lateral FDE for lane changes) with its bootstrap interval
over vehicles (:func:`median_ratios`, :class:`RatioStat`; the relative goals
:data:`RATIO_GOALS`). :func:`goal_checks` checks the goals (:data:`GOALS`) for the
identified-style methods (:class:`GoalCheck`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from drivestyle.common.stats import bootstrap_rows, percentile_interval
from drivestyle.prediction.errors import ERROR_METRICS
from drivestyle.prediction.methods import METHODS
from drivestyle.recorded.kinds import ALL_KINDS, EPISODE_KINDS, STOP_AND_GO
from drivestyle.studies.prediction.records import PredictionRecord

__all__ = [
    "ALL_KINDS",
    "BOOTSTRAP_SAMPLES",
    "BOOTSTRAP_SEED",
    "GOALS",
    "RATIO_GOALS",
    "RATIO_GOAL_KINDS",
    "RATIO_REFERENCE",
    "RECORDED",
    "SIMULATED",
    "STOP_AND_GO",
    "STYLE_METHODS",
    "ErrorStat",
    "GoalCheck",
    "MethodSummary",
    "RatioStat",
    "bootstrap_stats",
    "goal_checks",
    "kind_groups",
    "median_ratios",
    "ratio_stats",
    "report_set",
    "shown_kinds",
    "summarise_by_kind",
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

RATIO_REFERENCE = "cv"
"""The method every ratio is taken to (:func:`ratio_stats`)."""
RATIO_GOALS = {"fde": 0.70, "fde_lat": 0.60}
"""The relative goals as ratios to CV: FDE ≥ 30 % below CV's, pooled and for lane changes;
the lateral FDE of lane changes ≥ 40 % below."""
RATIO_GOAL_KINDS = {"fde": (ALL_KINDS, "lane_change"), "fde_lat": ("lane_change",)}
"""The kinds each relative goal is set for (the ratios of the others are reported without
one)."""

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
    kind: str = ALL_KINDS
    """The episodes summarised: :data:`ALL_KINDS` (pooled), a name of
    :data:`~drivestyle.recorded.kinds.EPISODE_KINDS` or :data:`STOP_AND_GO`."""

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
    pool = len({r.set for r in records if r.set != SIMULATED}) > 1
    return _summaries(_by_set(records, pool), samples)


def _by_set(records: Sequence[PredictionRecord], pool: bool) -> dict[str, list[PredictionRecord]]:
    """The records of each set (in order of appearance).

    And, if ``pool``, of :data:`RECORDED`: every recorded record (NGSIM and CATS together).
    """
    by_set: dict[str, list[PredictionRecord]] = {}
    for r in records:
        by_set.setdefault(r.set, []).append(r)
    recorded = [r for r in records if r.set != SIMULATED]
    if pool and recorded:
        by_set[RECORDED] = recorded
    return by_set


def _summaries(by_set: dict[str, list[PredictionRecord]], samples: int) -> list[MethodSummary]:
    """Per set of ``by_set``, t_obs and method (with records) the summary and its intervals."""
    out = []
    for set_name, recs in by_set.items():
        for t in sorted({r.t_obs for r in recs}):
            at_t = [r for r in recs if r.t_obs == t]
            have = {m: [r for r in at_t if m in r.fde_m] for m in METHODS}
            out += _with_stats(
                [_summary(set_name, t, m, have[m]) for m in METHODS if have[m]], have, samples
            )
    return out


def kind_groups(records: Sequence[PredictionRecord]) -> dict[str, list[PredictionRecord]]:
    """The records of each kind present, then of the stop-and-go windows.

    The kinds in :data:`~drivestyle.recorded.kinds.EPISODE_KINDS`' order; the stop-and-go
    windows (:data:`STOP_AND_GO`, whatever their kind) only if any.
    """
    groups = {k: [r for r in records if r.kind == k] for k in EPISODE_KINDS}
    groups = {k: recs for k, recs in groups.items() if recs}
    stop_and_go = [r for r in records if r.stop_and_go]
    return groups | ({STOP_AND_GO: stop_and_go} if stop_and_go else {})


def summarise_by_kind(
    records: Sequence[PredictionRecord], samples: int = BOOTSTRAP_SAMPLES
) -> list[MethodSummary]:
    """Per (set, kind, t_obs, method) the summaries of the recorded records of each kind.

    As :func:`summarise_records` over each group of :func:`kind_groups` (the kinds present,
    and the stop-and-go windows), each summary's :attr:`MethodSummary.kind` the group's name;
    a group's records of every recorded set are pooled in :data:`RECORDED` whenever the run
    has more than one recorded set (so each kind has its pooled row even where only one set
    holds it). Simulated vehicles are not grouped: the SMPC's demonstrations are lane changes
    by construction, and their pooled summaries are :func:`summarise_records`'. The
    bootstrap resamples the vehicles of the group.
    """
    recorded = [r for r in records if r.set != SIMULATED]
    pool = len({r.set for r in recorded}) > 1
    return [
        replace(s, kind=kind)
        for kind, recs in kind_groups(recorded).items()
        for s in _summaries(_by_set(recs, pool), samples)
    ]


def report_set(sets: Sequence[str]) -> str | None:
    """The set a run's by-kind tables and figure show.

    :data:`RECORDED` (every recorded episode) where the run pooled several recorded sets,
    else its one recorded set (None: no recorded set).
    """
    recorded = [s for s in dict.fromkeys(sets) if s != SIMULATED]
    if RECORDED in recorded:
        return RECORDED
    return recorded[0] if recorded else None


def _with_stats(
    summaries: Sequence[MethodSummary],
    records: dict[str, list[PredictionRecord]],
    samples: int,
) -> list[MethodSummary]:
    """The summaries with their :func:`bootstrap_stats` over the records of their method.

    Methods summarised over the same records share one call (the replicates of a method's
    records are the same whichever call draws them: the same units and seed), so the
    units are drawn once per (set, t_obs) rather than once per method.
    """
    by_records: dict[tuple[int, ...], list[MethodSummary]] = {}
    for s in summaries:
        by_records.setdefault(tuple(id(r) for r in records[s.method]), []).append(s)
    done = {}
    for same in by_records.values():
        recs = records[same[0].method]
        values = np.array([[r.error(m, s.method) for s in same for m in ERROR_METRICS]
                           for r in recs])  # fmt: skip
        units = [r.unit or r.vehicle_id for r in recs]
        stats = bootstrap_stats(values, units, samples, BOOTSTRAP_SEED)
        k = len(ERROR_METRICS)
        for i, s in enumerate(same):
            done[s.method] = replace(
                s, stats=dict(zip(ERROR_METRICS, stats[i * k : (i + 1) * k], strict=True)),
                n_units=len(set(units)),
            )  # fmt: skip
    return [done[s.method] for s in summaries]


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


def shown_kinds(kind_summaries: Sequence[MethodSummary]) -> list[str]:
    """The kinds a report's by-kind tables and figure show, in order.

    Each kind present in ``kind_summaries`` (:func:`summarise_by_kind`'s), preceded by every
    kind pooled (:data:`ALL_KINDS`) where there are several (with one, the pooled numbers
    are that kind's), then the stop-and-go windows where any.
    """
    kinds = [k for k in EPISODE_KINDS if any(s.kind == k for s in kind_summaries)]
    groups = [ALL_KINDS, *kinds] if len(kinds) > 1 else kinds
    return groups + ([STOP_AND_GO] if any(s.kind == STOP_AND_GO for s in kind_summaries) else [])


@dataclass(frozen=True)
class RatioStat:
    """One method's error relative to CV's over one set, kind and t_obs (:func:`ratio_stats`).

    The median over the records of error_method / error_cv, each record's own ratio, with a
    percentile bootstrap 95 % interval resampling vehicles (:func:`median_ratios`). Below 1:
    the method beats CV on the typical record.
    """

    set: str
    kind: str
    """:data:`ALL_KINDS`, a name of :data:`~drivestyle.recorded.kinds.EPISODE_KINDS` or
    :data:`STOP_AND_GO`."""
    t_obs: float
    method: str
    metric: str
    """``fde`` or ``fde_lat`` (a name of :data:`~drivestyle.prediction.errors.ERROR_METRICS`)."""
    n: int
    """Records with a ratio."""
    n_units: int
    """Their distinct vehicles (what the bootstrap resamples)."""
    median: float
    lo: float
    hi: float
    goal: float | None
    """The relative goal's ratio (:data:`RATIO_GOALS`) where it is set for this kind
    (:data:`RATIO_GOAL_KINDS`), else None."""

    @property
    def below_goal(self) -> bool | None:
        """Whether the whole interval lies below the goal (None: no goal)."""
        return None if self.goal is None else self.hi < self.goal

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "t_obs"}
        return out | {"t_obs_s": self.t_obs, "reference": RATIO_REFERENCE,
                      "below_goal": self.below_goal}  # fmt: skip


def median_ratios(
    values: np.ndarray | Sequence[Sequence[float]],
    reference: np.ndarray | Sequence[Sequence[float]],
    units: Sequence[str],
    samples: int = BOOTSTRAP_SAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> list[tuple[float, float, float, int, int]]:
    """Per column, the median of values / reference over records, with its bootstrap 95 % interval.

    Each record's ratio r_ic = values_ic / reference_ic; per column the median over the
    records, and the 2.5–97.5 % percentiles of the median over bootstrap replicates that
    resample the units (:func:`drivestyle.common.stats.bootstrap_rows`: a drawn vehicle brings
    all its records; the same replicates serve every column, paired), as every median of the
    study. A record whose reference is not > 0 (nothing to reduce) or whose value is not
    finite has no ratio in that column and is left out of it (a replicate that draws none of
    a column's records, of its interval).

    Args:
        values: the methods' errors, shape (records, columns) [m].
        reference: the reference method's errors, the same shape (or (records,)) [m].
        units: each record's unit (vehicle), length records.
        samples: replicates B.
        seed: the replicates' seed.

    Returns:
        Per column (median, lo, hi, records with a ratio, their units); NaNs and zeros where
        no record has one.
    """
    v = np.asarray(values, dtype=float).reshape(len(units), -1)
    ref = np.broadcast_to(np.asarray(reference, dtype=float).reshape(len(units), -1), v.shape)
    keep = np.isfinite(v) & np.isfinite(ref) & (ref > 0)
    ratio = np.divide(v, ref, out=np.full(v.shape, np.nan), where=keep)
    reps = np.full((samples, v.shape[1]), np.nan)
    if keep.any():
        median = np.median if keep.all() else np.nanmedian
        with warnings.catch_warnings():  # a replicate with none of a column's records: NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            for b, rows in enumerate(bootstrap_rows(units, samples, np.random.default_rng(seed))):
                reps[b] = median(ratio[rows], axis=0)
    labels = np.asarray(units)
    out = []
    for c in range(v.shape[1]):
        k = keep[:, c]
        if not k.any():
            out.append((float("nan"), float("nan"), float("nan"), 0, 0))
            continue
        lo, hi = percentile_interval(reps[np.isfinite(reps[:, c]), c])
        units_c = len(set(labels[k].tolist()))
        out.append((float(np.median(ratio[k, c])), lo, hi, int(k.sum()), units_c))
    return out


def ratio_stats(
    records: Sequence[PredictionRecord], samples: int = BOOTSTRAP_SAMPLES
) -> list[RatioStat]:
    """Per recorded set, kind, t_obs and method, its FDE relative to CV's (:class:`RatioStat`).

    The kinds: :data:`ALL_KINDS` (every recorded record) and each group of
    :func:`kind_groups`; the sets as :func:`summarise_by_kind`'s. The FDE ratio for every
    group, the lateral FDE's for lane changes (the issue's goal for them); every method
    but CV over the records that have it and CV. Simulated vehicles are left out (their
    summaries compare with the oracle).
    """
    recorded = [r for r in records if r.set != SIMULATED]
    pool = len({r.set for r in recorded}) > 1
    out = []
    for kind, group in ({ALL_KINDS: recorded} | kind_groups(recorded)).items():
        metrics = ("fde", "fde_lat") if kind == "lane_change" else ("fde",)
        for set_name, recs in _by_set(group, pool).items():
            for t in sorted({r.t_obs for r in recs}):
                at_t = [r for r in recs if r.t_obs == t and RATIO_REFERENCE in r.fde_m]
                out += _ratios(set_name, kind, t, metrics, at_t, samples)
    return out


def _ratios(
    set_name: str, kind: str, t: float, metrics: Sequence[str],
    records: Sequence[PredictionRecord], samples: int,
) -> list[RatioStat]:  # fmt: skip
    """:func:`median_ratios` of every (metric, method but the reference) the records have."""
    methods = [m for m in METHODS if m != RATIO_REFERENCE and any(m in r.fde_m for r in records)]
    cols = [(metric, m) for metric in metrics for m in methods]
    if not cols:
        return []
    stats = median_ratios(
        [[r.error(metric, m) for metric, m in cols] for r in records],
        [[r.error(metric, RATIO_REFERENCE) for metric, _ in cols] for r in records],
        [r.unit or r.vehicle_id for r in records],
        samples,
    )
    return [
        RatioStat(set_name, kind, t, m, metric, n, n_units, med, lo, hi,
                  RATIO_GOALS[metric] if kind in RATIO_GOAL_KINDS[metric] else None)
        for (metric, m), (med, lo, hi, n, n_units) in zip(cols, stats, strict=True)
    ]  # fmt: skip
