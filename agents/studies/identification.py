"""Identification on held-out demonstrations of known risk, and a k-NN reference (DESIGN §8).

:func:`evaluate_identification` identifies held-out demonstrations with every scorer of
:mod:`drivestyle.irl.identification` and summarises accuracy on the library's grid, the error
between grid points, interval coverage, pooling of one vehicle's demonstrations and
timing; :func:`knn_baseline` is a supervised reference without IRL. Results are typed
(:class:`Evaluation`, one :class:`EvaluationRecord` per demonstration with a result per
scorer); the Markdown of ``evaluation.md`` is written from them by small functions.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.tracking import observe
from drivestyle.irl.features import FeatureConfig
from drivestyle.irl.identification import (
    DEFAULT_SCORER,
    SCORERS,
    DemoScores,
    Identification,
    demo_scores,
    posterior_from_scores,
    risk_interval,
    summarise,
)
from drivestyle.irl.inner import InnerProblem
from drivestyle.irl.library import LibraryError, StyleLibrary

__all__ = [
    "Evaluation",
    "EvaluationRecord",
    "EvaluationSummary",
    "PooledAccuracy",
    "ScorerSummary",
    "evaluate_identification",
    "knn_baseline",
    "noise_curve_json",
    "pooled_accuracy",
]


@dataclass(frozen=True)
class EvaluationRecord:
    """One held-out demonstration: its truth and every scorer's identification."""

    risk: float
    """True risk (``meta["risk"]``)."""
    scenario: int | None
    """Index of the held-out scenario (``meta["scenario_index"]``)."""
    grid: bool
    """Whether the true risk is one of the library's grid risks."""
    identify_s: float
    """Wall time of scoring the demonstration [s]."""
    error: str | None = None
    """Why the demonstration was refused (then there are no scores)."""
    scores: DemoScores | None = None
    """Every scorer's scores and the demonstration's flags."""
    by_scorer: Mapping[str, Identification] = field(default_factory=dict)
    """Scorer → identification from this demonstration alone."""

    @property
    def ok(self) -> bool:
        """Whether the demonstration was identified."""
        return self.error is None and self.scores is not None

    def estimate(self, scorer: str) -> float:
        """The posterior mode of ``scorer``."""
        return self.by_scorer[scorer].risk_estimate

    def correct(self, scorer: str) -> bool:
        """Whether ``scorer`` found the true risk."""
        return self.estimate(scorer) == self.risk

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``evaluation.json``'s record keys: ``<scorer>_estimate``, …)."""
        rec: dict[str, Any] = {
            "risk": self.risk,
            "scenario": self.scenario,
            "grid": self.grid,
            "identify_s": self.identify_s,
        }
        if not self.ok or self.scores is None:
            return rec | {"error": self.error}
        rec |= self.scores.to_json()
        for s, res in self.by_scorer.items():
            rec |= {
                f"{s}_estimate": res.risk_estimate,
                f"{s}_interpolated": res.risk_interpolated,
                f"{s}_interval": list(res.risk_interval),
                f"{s}_covered": res.covers(self.risk),
            }
        rec["posterior"] = self.by_scorer[DEFAULT_SCORER].to_json()["posterior"]
        return rec


@dataclass(frozen=True)
class ScorerSummary:
    """One scorer's accuracy, errors and intervals over the held-out demonstrations."""

    grid_accuracy: float | None
    grid_accuracy_informative: float | None
    grid_mae_informative: float | None
    grid_accuracy_interactive: float | None
    """Accuracy among grid demonstrations whose trigger fired."""
    between_mae_nearest: float | None
    """MAE of the posterior mode on risks between grid points."""
    between_mae_interpolated: float | None
    """MAE of the posterior mean on risks between grid points."""
    interval_coverage: float | None
    interval_width: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class PooledAccuracy:
    """Grid accuracy of single demonstrations against pools of one vehicle's."""

    n_pool: int
    n_pools: int
    single_accuracy: float | None
    pooled_accuracy: float | None
    single_interval_width: float | None
    pooled_interval_width: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class EvaluationSummary:
    """Counts, per-scorer summaries, pooling, transfer and timing of an evaluation."""

    n: int
    n_failed: int
    n_grid: int
    n_grid_informative: int
    n_between: int
    noise_sigma_m: float
    by_scorer: Mapping[str, ScorerSummary]
    pooled: PooledAccuracy
    transfer_own_risk_best: float | None
    """Share of grid demonstrations whose own risk's styles reproduce them best (rmse_y)."""
    own_style_rmse_y_median_m: float | None
    identify_s_median: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (scorer summaries under their scorer's name)."""
        return {
            "n": self.n,
            "n_failed": self.n_failed,
            "n_grid": self.n_grid,
            "n_grid_informative": self.n_grid_informative,
            "n_between": self.n_between,
            "noise_sigma_m": self.noise_sigma_m,
            **{s: m.to_json() for s, m in self.by_scorer.items()},
            "pooled": self.pooled.to_json(),
            "transfer_own_risk_best": self.transfer_own_risk_best,
            "own_style_rmse_y_median_m": self.own_style_rmse_y_median_m,
            "identify_s_median": self.identify_s_median,
        }


@dataclass(frozen=True)
class Evaluation:
    """An evaluation: one record per demonstration and their summary."""

    records: tuple[EvaluationRecord, ...]
    summary: EvaluationSummary

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"records": [r.to_json() for r in self.records], "summary": self.summary.to_json()}


def _scores_task(
    demo: Demonstration, library: StyleLibrary, noise: float, noise_seed: int
) -> tuple[DemoScores | str, float]:
    """Worker: scores of the demonstration as observed with position noise, and wall time.

    The scores are :func:`demo_scores`'s, or the refusal's message.
    """
    t0 = time.perf_counter()
    # a library learned from tracked demonstrations sees every test demonstration tracked
    tracked = library.meta.get("observation") == "tracked"
    observed = (
        demo
        if noise == 0 and not tracked
        else observe(demo, noise, np.random.default_rng(noise_seed))
    )
    try:
        out: DemoScores | str = demo_scores(observed, library)
    except LibraryError as exc:
        out = str(exc)
    return out, time.perf_counter() - t0


def _record(
    demo: Demonstration,
    grid: set[float],
    risks: Sequence[float],
    scored: DemoScores | str,
    seconds: float,
) -> EvaluationRecord:
    p = float(demo.meta["risk"])
    index = demo.meta.get("scenario_index")
    if isinstance(scored, str):
        return EvaluationRecord(p, index, p in grid, seconds, error=scored)
    return EvaluationRecord(
        p,
        index,
        p in grid,
        seconds,
        scores=scored,
        by_scorer={s: summarise(risks, [scored], s, [p]) for s in SCORERS},
    )


def _mean(values: Sequence[float | bool]) -> float | None:
    return float(np.mean(values)) if len(values) else None


def pooled_accuracy(
    records: Sequence[EvaluationRecord],
    risks: Sequence[float],
    n_pool: int = 3,
    scorer: str = DEFAULT_SCORER,
) -> PooledAccuracy:
    """Grid accuracy of single demonstrations against pools of ``n_pool`` of one vehicle.

    A "vehicle" is a grid risk; its demonstrations (in different scenarios, scenario order)
    are pooled in consecutive groups of ``n_pool`` by :func:`posterior_from_scores`; the
    single and pooled accuracies are over the same demonstrations.
    """
    risks = list(risks)
    single, pooled, w1, wn = [], [], [], []
    for p in risks:
        rs = sorted(
            (r for r in records if r.risk == p and r.ok),
            key=lambda r: (r.scenario is None, r.scenario or 0),
        )
        for k in range(0, len(rs) - n_pool + 1, n_pool):
            group = rs[k : k + n_pool]
            scored = [r.scores for r in group if r.scores is not None]
            post = posterior_from_scores(
                [d.scores[scorer] for d in scored], [d.informative for d in scored]
            )
            pooled.append(risks[int(np.argmax(post))] == p)
            lo, hi = risk_interval(risks, post)
            wn.append(hi - lo)
            single += [r.correct(scorer) for r in group]
            w1 += [np.ptp(r.by_scorer[scorer].risk_interval) for r in group]
    return PooledAccuracy(
        n_pool=n_pool,
        n_pools=len(pooled),
        single_accuracy=_mean(single),
        pooled_accuracy=_mean(pooled),
        single_interval_width=_mean(w1),
        pooled_interval_width=_mean(wn),
    )


def _scorer_summary(s: str, ok: Sequence[EvaluationRecord]) -> ScorerSummary:
    grid = [r for r in ok if r.grid]
    informative = [r for r in grid if r.scores is not None and r.scores.informative]
    interactive = [r for r in grid if r.scores is not None and r.scores.trigger_fired]
    between = [r for r in ok if not r.grid]
    return ScorerSummary(
        grid_accuracy=_mean([r.correct(s) for r in grid]),
        grid_accuracy_informative=_mean([r.correct(s) for r in informative]),
        grid_mae_informative=_mean([abs(r.estimate(s) - r.risk) for r in informative]),
        grid_accuracy_interactive=_mean([r.correct(s) for r in interactive]),
        between_mae_nearest=_mean([abs(r.estimate(s) - r.risk) for r in between]),
        between_mae_interpolated=_mean(
            [abs(r.by_scorer[s].risk_interpolated - r.risk) for r in between]
        ),
        interval_coverage=_mean([r.by_scorer[s].covers(r.risk) for r in ok]),
        interval_width=_mean([float(np.ptp(r.by_scorer[s].risk_interval)) for r in ok]),
    )


def evaluate_identification(
    library: StyleLibrary,
    demos: Sequence[Demonstration],
    grid_risks: Sequence[float],
    progress: Callable[[int], Any] | None = None,
    workers: int = 1,
    noise: float = 0.0,
    noise_seed: int = 0,
) -> Evaluation:
    """Identify held-out demonstrations of known risk with every scorer and summarise.

    Args:
        library: the style library.
        demos: held-out demonstrations; ``meta["risk"]`` is the true risk and
            ``meta["scenario_index"]`` (optional) names the held-out scenario.
        grid_risks: the risks that count as grid points (others are between the grid).
        progress: called with 1 after each demonstration.
        workers: processes.
        noise: position noise σ [m] of the observation
            (:func:`drivestyle.envs.tracking.observe`; 0: the true states).
        noise_seed: seed of the noise (demonstration i uses ``noise_seed + i``).

    Returns:
        One record per demonstration and the summary: per scorer the grid accuracy (all and
        informative), grid MAE, between-grid MAE of the posterior mean, interval coverage
        and width; pooled vs single accuracy; transfer; identification time.

    Raises:
        ValueError: a demonstration has no true risk in its metadata.
    """
    if any("risk" not in d.meta for d in demos):
        raise ValueError("every evaluation demonstration needs meta['risk'] (its true risk)")
    grid = {float(p) for p in grid_risks}
    scored = parallel_map(
        _scores_task,
        [(d, library, noise, noise_seed + i) for i, d in enumerate(demos)],
        workers,
        None if progress is None else lambda *_: progress(1),
    )
    records = tuple(
        _record(d, grid, library.risks, s, t) for d, (s, t) in zip(demos, scored, strict=True)
    )
    ok = [r for r in records if r.ok]
    grid_recs = [r for r in ok if r.grid]
    risk_index = {p: i for i, p in enumerate(library.risks)}
    own = [r.scores.scores["rmse_y"][risk_index[r.risk]] for r in grid_recs if r.scores]
    summary = EvaluationSummary(
        n=len(records),
        n_failed=len(records) - len(ok),
        n_grid=len(grid_recs),
        n_grid_informative=sum(bool(r.scores and r.scores.informative) for r in grid_recs),
        n_between=len(ok) - len(grid_recs),
        noise_sigma_m=noise,
        by_scorer={s: _scorer_summary(s, ok) for s in SCORERS},
        pooled=pooled_accuracy(records, sorted(grid)),
        transfer_own_risk_best=_mean([r.correct("rmse_y") for r in grid_recs]),
        own_style_rmse_y_median_m=float(np.median(own)) if own else None,
        identify_s_median=float(np.median([r.identify_s for r in records])) if records else None,
    )
    return Evaluation(records, summary)


def knn_baseline(
    train: Sequence[Demonstration],
    test: Sequence[Demonstration],
    features: FeatureConfig | None = None,
    k: int = 3,
) -> list[float]:
    """A supervised reference without IRL: k-nearest neighbours on features and scenario.

    Each demonstration is described by its scaled feature values Ω f(r_D) and its scenario
    (EV speed, TV speed, TV gap), each column standardised on the training set; a test
    demonstration gets the median true risk of its k nearest training demonstrations.

    Args:
        train: demonstrations with ``meta["risk"]`` (e.g. the library's own).
        test: demonstrations to classify.
        features: feature configuration (default: the reactive set).
        k: neighbours.

    Returns:
        The estimated risk of each test demonstration.
    """
    fc = features or FeatureConfig()

    def describe(d: Demonstration) -> np.ndarray:
        sc = d.scenario
        return np.concatenate([InnerProblem(d, fc).f_demo, [sc.ev_speed, sc.tv_speed, sc.tv_gap]])

    X = np.array([describe(d) for d in train])
    y = np.array([float(d.meta["risk"]) for d in train])
    mu, sd = X.mean(0), X.std(0) + 1e-9
    Xs = (X - mu) / sd
    out = []
    for d in test:
        dist = np.linalg.norm(Xs - (describe(d) - mu) / sd, axis=1)
        out.append(float(np.median(y[np.argsort(dist)[:k]])))
    return out


def noise_curve_json(evaluations: Sequence[Evaluation]) -> list[dict[str, Any]]:
    """Per noise level σ, the default scorer's summary (``evaluation.json``'s noise curve)."""
    return [
        {
            "noise_sigma_m": e.summary.noise_sigma_m,
            **e.summary.by_scorer[DEFAULT_SCORER].to_json(),
        }
        for e in evaluations
    ]
