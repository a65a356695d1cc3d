"""The amortized posterior beside the exact one, on the same SMPC demonstrations (DESIGN §22).

``evaluate-identification --posterior FILE``: every held-out demonstration the driver
library's exact (teacher-forced) posterior identifies — grid and midpoint risks, continuous
risks, at every noise level — is also read by the amortized posterior
(:class:`~drivestyle.irl.amortized.estimator.NeuralPosterior`, the file
``build-posterior`` writes). It reads only the demonstration as observed: the same
observation the exact reads (:func:`~drivestyle.studies.identification.study.observation`:
the tracker's view under noise), through
:func:`~drivestyle.irl.amortized.simulations.episode_series`.

Per demonstration (:func:`amortized_records`): ``samples`` draws on one torch thread
(seeded as the noise is: ``noise_seed`` + its index), their means of every parameter, the
central 90 % interval of each
(:func:`~drivestyle.irl.amortized.calibration.central_intervals`), and the grid risk it
identifies by the exact's own rule
(:func:`~drivestyle.irl.identification.posterior.grid_estimate`: the library risk whose cell
holds most posterior mass; here the draws' mass); beside it the exact's posterior mean,
interval and estimate, and whether the path ceiling calls the demonstration identifiable.

Per noise level (:func:`summarise_beside_exact`), on the demonstrations both identified
(the exact refuses some: no lane change): each posterior's risk error |posterior mean − p|
(mean and median with 95 % bootstrap intervals, resampling held-out scenarios:
:func:`~drivestyle.studies.prediction.summaries.bootstrap_stats`), the coverage of the true
p by its 90 % interval, its accuracy on the grid and on the identifiable grid
demonstrations, its continuous-risk MAE and its time per episode (the exact's: its
record's scoring time, the observation included; the amortized's: the series and the
draws); their agreement (the posterior means' absolute differences and correlation); and
the amortized posterior's means of the other parameters, which on an SMPC driver have the
expert's values (:func:`~drivestyle.irl.amortized.simulations.expert_parameters`: T = 0,
s_0 = l_a, λ_y = 1, t_on = 0, σ = 0; τ none) — how near they sit. :func:`noise_costs`:
what each noise level costs against the first, in points of accuracy and in MAE.

The types are :mod:`.amortized_results`'. Torch is imported inside
:func:`amortized_records` only.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.calibration import central_intervals
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.simulations import (
    PARAMETERS,
    check_episode_estimator,
    episode_series,
    expert_parameters,
)
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.posterior import grid_estimate
from drivestyle.irl.identification.result import INTERVAL_MASS
from drivestyle.studies.identification.amortized_results import (
    Agreement,
    AmortizedRecord,
    AmortizedSummary,
    BesideExact,
    EstimatorScores,
    ExactAnswer,
    NoiseCost,
    ParameterSummary,
)
from drivestyle.studies.identification.results import Evaluation
from drivestyle.studies.identification.study import observation
from drivestyle.studies.prediction.summaries import ErrorStat, bootstrap_stats

__all__ = [
    "NO_TRUTH",
    "SAMPLES",
    "amortized_records",
    "evaluate_beside_exact",
    "noise_costs",
    "summarise_beside_exact",
]

SAMPLES = 200
"""Posterior draws per demonstration (as ``build-posterior``'s calibration draws)."""
NO_TRUTH = ("tau",)
"""Parameters an SMPC driver has no value of: a deviation of scale zero has no correlation
time."""


def amortized_records(
    posterior: NeuralPosterior,
    demos: Sequence[Demonstration],
    library: DriverLibrary,
    evaluation: Evaluation,
    noise_seed: int,
    samples: int = SAMPLES,
    progress: Callable[[int], Any] | None = None,
) -> tuple[AmortizedRecord, ...]:
    """The amortized posterior on each demonstration, the exact's evaluation beside.

    Args:
        posterior: the estimator (of episodes:
            :func:`~drivestyle.irl.amortized.simulations.check_episode_estimator`).
        demos: the held-out demonstrations, in the order ``evaluation`` identified them.
        library: the exact's driver library (which observation it reads).
        evaluation: the exact's evaluation of ``demos`` at one noise level (with the path
            ceiling, for the identifiable flag).
        noise_seed: the evaluation's noise seed (demonstration i observed with
            ``noise_seed`` + i, and its draws seeded so).
        samples: draws per demonstration.
        progress: called with 1 after each demonstration.

    Returns:
        One :class:`AmortizedRecord` per demonstration.
    """
    import torch

    if len(demos) != len(evaluation.records):
        raise ValueError(f"{len(demos)} demonstrations, {len(evaluation.records)} records")
    noise = evaluation.summary.noise_sigma_m
    scorer = evaluation.scorer
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    out = []
    try:
        if demos:  # warm-up: the first call allocates
            posterior.sample(episode_series(demos[0]), samples)
        for i, (demo, rec) in enumerate(zip(demos, evaluation.records, strict=True)):
            seen = observation(demo, library, noise, noise_seed + i)
            t0 = time.perf_counter()
            draws = posterior.sample(episode_series(seen), samples, seed=noise_seed + i)
            seconds = time.perf_counter() - t0
            lo, hi = central_intervals(draws[None], INTERVAL_MASS)
            mass = np.full(samples, 1.0 / samples)
            ident = rec.by_scorer.get(scorer) if rec.ok else None
            exact = None
            if ident is not None:
                exact = ExactAnswer(ident.risk_interpolated, ident.risk_interval,
                                    ident.risk_estimate)  # fmt: skip
            out.append(
                AmortizedRecord(
                    risk=rec.risk,
                    scenario=rec.scenario,
                    grid=rec.grid,
                    continuous=rec.continuous,
                    identifiable=rec.identifiable,
                    mean=tuple(float(v) for v in draws.mean(axis=0)),
                    lo=tuple(float(v) for v in lo[0]),
                    hi=tuple(float(v) for v in hi[0]),
                    estimate=grid_estimate(draws[:, 0], mass, library.risks),
                    identify_s=seconds,
                    expert=_expert(demo, rec.risk),
                    exact=exact,
                    exact_identify_s=rec.identify_s,
                )
            )
            if progress is not None:
                progress(1)
    finally:
        torch.set_num_threads(threads)
    return tuple(out)


def _expert(demo: Demonstration, risk: float) -> tuple[float | None, ...]:
    """The SMPC expert's parameters in the demonstration's scenario; None where it has none."""
    theta = expert_parameters(demo.scenario, risk)
    return tuple(
        None if n in NO_TRUTH else float(v) for n, v in zip(PARAMETERS, theta, strict=True)
    )


def _mean(values: Sequence[float | bool]) -> float | None:
    return float(np.mean(values)) if len(values) else None


def _covers(interval: tuple[float, float], value: float) -> bool:
    return interval[0] - 1e-9 <= value <= interval[1] + 1e-9


def _scores(
    records: Sequence[AmortizedRecord],
    means: Sequence[float],
    intervals: Sequence[tuple[float, float]],
    estimates: Sequence[float],
    seconds: Sequence[float],
    error: ErrorStat | None,
) -> EstimatorScores:
    err = [abs(m - r.risk) for r, m in zip(records, means, strict=True)]
    grid = [i for i, r in enumerate(records) if r.grid]
    ms = 1000 * np.asarray(seconds, float)
    return EstimatorScores(
        n=len(records),
        risk_error=error,
        coverage=_mean([_covers(iv, r.risk) for r, iv in zip(records, intervals, strict=True)]),
        interval_width=_mean([iv[1] - iv[0] for iv in intervals]),
        grid_accuracy=_mean([estimates[i] == records[i].risk for i in grid]),
        identifiable_accuracy=_mean(
            [estimates[i] == records[i].risk for i in grid if records[i].identifiable]
        ),
        continuous_mae=_mean([e for e, r in zip(err, records, strict=True) if r.continuous]),
        identify_ms_median=float(np.median(ms)) if ms.size else None,
        identify_ms_p95=float(np.percentile(ms, 95)) if ms.size else None,
    )


def _agreement(a: np.ndarray, b: np.ndarray) -> Agreement:
    d = np.abs(a - b)
    corr = None
    if a.size >= 2 and np.ptp(a) > 0 and np.ptp(b) > 0:
        corr = float(np.corrcoef(a, b)[0, 1])
    return Agreement(
        n=int(a.size),
        mae=float(d.mean()) if d.size else None,
        median=float(np.median(d)) if d.size else None,
        max=float(d.max()) if d.size else None,
        correlation=corr,
    )


def _parameters(
    records: Sequence[AmortizedRecord], low: Sequence[float], high: Sequence[float]
) -> tuple[ParameterSummary, ...]:
    out = []
    if not records:
        return ()
    mean = np.array([r.mean for r in records])
    lo = np.array([r.lo for r in records])
    hi = np.array([r.hi for r in records])
    for d, name in enumerate(PARAMETERS):
        if name == "risk":
            continue
        width = high[d] - low[d]
        m = mean[:, d]
        values = [r.expert[d] for r in records]
        known = [float(v) for v in values if v is not None]
        truth: dict[str, float | None] = dict.fromkeys(
            ("expert_mean", "mae", "mae_relative", "centre_mae_relative", "coverage")
        )
        if len(known) == len(values):  # the expert has a value of it
            expert = np.array(known)
            e = np.abs(m - expert)
            truth = {
                "expert_mean": float(expert.mean()),
                "mae": float(e.mean()),
                "mae_relative": float(e.mean() / width),
                "centre_mae_relative": float(
                    np.abs((low[d] + high[d]) / 2 - expert).mean() / width
                ),
                "coverage": float(np.mean((lo[:, d] <= expert) & (expert <= hi[:, d]))),
            }
        out.append(
            ParameterSummary(
                name=name,
                low=float(low[d]),
                high=float(high[d]),
                mean=float(m.mean()),
                median=float(np.median(m)),
                box_position=float((m.mean() - low[d]) / width),
                **truth,
            )
        )
    return tuple(out)


def summarise_beside_exact(
    records: Sequence[AmortizedRecord],
    noise_sigma_m: float,
    low: Sequence[float],
    high: Sequence[float],
    bootstrap_samples: int = 2000,
    bootstrap_seed: int = 26,
) -> AmortizedSummary:
    """Both posteriors on the demonstrations both identified (module docstring).

    Args:
        records: one noise level's records (:func:`amortized_records`).
        noise_sigma_m: that level [m].
        low: the estimator's box (:data:`PARAMETERS`' order).
        high: its upper bounds.
        bootstrap_samples: replicates of the risk errors' intervals.
        bootstrap_seed: their seed.

    Returns:
        The :class:`AmortizedSummary`; the two posteriors' risk-error intervals come from
        the same replicates (a paired comparison).
    """
    pairs = [(r, r.exact) for r in records if r.exact is not None]
    both = [r for r, _ in pairs]
    exact = [e for _, e in pairs]
    errors: list[ErrorStat | None] = [None, None]
    if pairs:
        units = [f"s{r.scenario}" if r.scenario is not None else f"d{i}"
                 for i, r in enumerate(both)]  # fmt: skip
        values = np.array([[abs(r.mean[0] - r.risk), abs(e.mean - r.risk)] for r, e in pairs])
        errors = list(bootstrap_stats(values, units, bootstrap_samples, bootstrap_seed))
    return AmortizedSummary(
        noise_sigma_m=float(noise_sigma_m),
        n=len(records),
        n_exact_refused=len(records) - len(both),
        n_identifiable=sum(r.grid and r.identifiable for r in both),
        amortized=_scores(
            both,
            [r.mean[0] for r in both],
            [(r.lo[0], r.hi[0]) for r in both],
            [r.estimate for r in both],
            [r.identify_s for r in both],
            errors[0],
        ),
        exact=_scores(
            both,
            [e.mean for e in exact],
            [e.interval for e in exact],
            [e.estimate for e in exact],
            [r.exact_identify_s for r in both],
            errors[1],
        ),
        agreement=_agreement(
            np.array([r.mean[0] for r in both]), np.array([e.mean for e in exact])
        ),
        parameters=_parameters(both, low, high),
    )


def _change(a: float | None, b: float | None, scale: float = 1.0) -> float | None:
    return None if a is None or b is None else scale * (a - b)


def noise_costs(summaries: Sequence[AmortizedSummary]) -> tuple[NoiseCost, ...]:
    """What each noise level after the first costs against the first (:class:`NoiseCost`)."""
    if not summaries:
        return ()
    base = summaries[0]

    def mae(s: EstimatorScores) -> float | None:
        return None if s.risk_error is None else s.risk_error.mean

    return tuple(
        NoiseCost(
            noise_sigma_m=s.noise_sigma_m,
            baseline_sigma_m=base.noise_sigma_m,
            exact_identifiable_points=_change(
                s.exact.identifiable_accuracy, base.exact.identifiable_accuracy, 100.0
            ),
            amortized_identifiable_points=_change(
                s.amortized.identifiable_accuracy, base.amortized.identifiable_accuracy, 100.0
            ),
            exact_grid_points=_change(s.exact.grid_accuracy, base.exact.grid_accuracy, 100.0),
            amortized_grid_points=_change(
                s.amortized.grid_accuracy, base.amortized.grid_accuracy, 100.0
            ),
            exact_mae_change=_change(mae(s.exact), mae(base.exact)),
            amortized_mae_change=_change(mae(s.amortized), mae(base.amortized)),
        )
        for s in summaries[1:]
    )


def evaluate_beside_exact(
    posterior: NeuralPosterior,
    path: str | Path,
    demos: Sequence[Demonstration],
    library: DriverLibrary,
    evaluations: Sequence[Evaluation],
    noise_seed: int,
    samples: int = SAMPLES,
    progress: Callable[[int], Any] | None = None,
) -> BesideExact:
    """The amortized posterior beside the exact's evaluations, one per noise level.

    Args:
        posterior: the estimator, loaded from ``path``.
        path: its file (reported).
        demos: the held-out demonstrations.
        library: the exact's driver library.
        evaluations: the exact's evaluations of ``demos``, one per noise level (the first:
            the noise costs' baseline).
        noise_seed: the evaluations' noise seed.
        samples: draws per demonstration.
        progress: called with 1 after each demonstration at each level.

    Returns:
        The :class:`BesideExact`.
    """
    check_episode_estimator(posterior, path)
    low, high = posterior.config.low, posterior.config.high
    records = tuple(
        amortized_records(posterior, demos, library, e, noise_seed, samples, progress)
        for e in evaluations
    )
    summaries = tuple(
        summarise_beside_exact(r, e.summary.noise_sigma_m, low, high)
        for r, e in zip(records, evaluations, strict=True)
    )
    return BesideExact(
        posterior=str(path),
        samples=samples,
        low=tuple(low),
        high=tuple(high),
        records=records,
        summaries=summaries,
        noise_cost=noise_costs(summaries),
    )
