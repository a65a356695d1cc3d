"""Identification on held-out demonstrations of known risk (DESIGN §8).

:func:`evaluate_identification` identifies held-out demonstrations with every scorer of
:mod:`drivestyle.irl.identification.posterior` and summarises accuracy on the library's grid, the
error between grid points, interval coverage, pooling of one vehicle's demonstrations and
timing. Results are typed (:mod:`.results`: :class:`~.results.Evaluation`, one
:class:`~.results.EvaluationRecord` per demonstration with a result per scorer); the
Markdown of ``evaluation.md`` is written from them by :mod:`.report`. Demonstrations of
continuous true risks (:func:`continuous_demonstrations`) test the posterior between the
grid points.

A :class:`~drivestyle.irl.identification.library.DriverLibrary` (DESIGN §15) is evaluated with its
one scorer, ``likelihood``: each demonstration's risk profile is computed once and reused by
its identification and by pooling. With ``ceiling=True`` every grid demonstration also gets
the *path ceiling* (:mod:`.path_ceiling`): the grid risk whose closed-loop path in the
demonstration's own scenario lies closest, and whether the demonstration is identifiable
at all. The references (the re-simulating ceiling, k-NN) are :mod:`.references`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import generate_demonstrations
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.tracking import observe
from drivestyle.envs.traffic import TrafficScene
from drivestyle.irl.driver.driver_style import DriverStyleError
from drivestyle.irl.driver.risk_profile import RiskProfile, refined_profile
from drivestyle.irl.identification.library import DriverLibrary, LibraryError, StyleLibrary
from drivestyle.irl.identification.paper_scorers import (
    DEFAULT_SCORER,
    SCORERS,
    demo_scores,
    posterior_from_scores,
    risk_interval,
    summarise,
)
from drivestyle.irl.identification.posterior import LIKELIHOOD, identify_driver
from drivestyle.irl.identification.result import DemoScores, Identification
from drivestyle.studies.identification.path_ceiling import IDENTIFIABLE_GAP_M, ceiling_records
from drivestyle.studies.identification.results import (
    Evaluation,
    EvaluationRecord,
    EvaluationSummary,
    PathCeilingSummary,
    PooledAccuracy,
    ScorerSummary,
)

__all__ = [
    "CONTINUOUS_RANGE",
    "continuous_demonstrations",
    "draw_continuous_risks",
    "evaluate_identification",
    "noise_curve_json",
    "observation",
    "pooled_accuracy",
]

CONTINUOUS_RANGE = (0.5, 0.95)
"""Continuous true risks are drawn from U[0.5, 0.95] (the library's grid span), as the
driver library's calibration draws them."""


# ---------------------------------------------------------------------------- continuous risks
def draw_continuous_risks(n_scenarios: int, per_scenario: int, seed: int) -> list[list[float]]:
    """Per scenario, ``per_scenario`` risks drawn from U(:data:`CONTINUOUS_RANGE`).

    Drawn from their own stream (``[seed, 2]``), so the scenarios drawn with ``seed`` stay
    the same whether or not continuous risks are added; rounded to 4 decimals.
    """
    rng = np.random.default_rng([seed, 2])
    lo, hi = CONTINUOUS_RANGE
    return [
        [float(np.round(rng.uniform(lo, hi), 4)) for _ in range(per_scenario)]
        for _ in range(n_scenarios)
    ]


def _continuous_task(
    risk: float, scenario: ScenarioConfig | TrafficScene, index: int
) -> Demonstration:
    demo = generate_demonstrations([risk], [scenario], workers=1)[risk][0]
    return replace(demo, meta={**demo.meta, "scenario_index": index, "continuous": True})


def continuous_demonstrations(
    scenarios: Sequence[ScenarioConfig | TrafficScene],
    risks: Sequence[Sequence[float]],
    workers: int = 2,
) -> list[Demonstration]:
    """SMPC demonstrations of continuous risks, ``risks[i]`` in ``scenarios[i]``.

    Returns:
        The demonstrations, scenario by scenario (``meta["continuous"]`` True,
        ``meta["scenario_index"]`` the scenario's index).
    """
    pairs = enumerate(zip(scenarios, risks, strict=True))
    tasks = [(p, sc, i) for i, (sc, ps) in pairs for p in ps]
    return parallel_map(_continuous_task, tasks, workers)


def observation(
    demo: Demonstration, library: StyleLibrary | DriverLibrary, noise: float, noise_seed: int
) -> Demonstration:
    """A held-out demonstration as the evaluation identifies it.

    With position noise σ > 0 the tracker's view of it
    (:func:`~drivestyle.envs.tracking.observe`, generator seeded with ``noise_seed``);
    without, the demonstration itself — unless the library was learned from tracked
    demonstrations, which then sees every test demonstration tracked. Deterministic given
    its arguments: every identification of one evaluation (the exact's, the amortized
    posterior's beside it) reads the same observation.
    """
    tracked = library.meta.get("observation") == "tracked"
    if noise == 0 and not tracked:
        return demo
    return observe(demo, noise, np.random.default_rng(noise_seed))


def _scores_task(
    demo: Demonstration, library: StyleLibrary, noise: float, noise_seed: int
) -> tuple[DemoScores | str, float]:
    """Worker: scores of the demonstration as observed with position noise, and wall time.

    The scores are :func:`demo_scores`'s, or the refusal's message.
    """
    t0 = time.perf_counter()
    observed = observation(demo, library, noise, noise_seed)
    try:
        out: DemoScores | str = demo_scores(observed, library)
    except LibraryError as exc:
        out = str(exc)
    return out, time.perf_counter() - t0


DriverOutcome = tuple[Demonstration, RiskProfile, Identification]
"""What :func:`_driver_task` returns for an identified demonstration."""


def _driver_task(
    demo: Demonstration, library: DriverLibrary, noise: float, noise_seed: int
) -> tuple[DriverOutcome | str, float]:
    """Worker: a driver library's identification of the demonstration as observed.

    The risk profile is computed once and handed to
    :func:`~drivestyle.irl.identification.posterior.identify_driver` (and kept for pooling).

    Returns:
        ((observed demonstration, profile, identification) or the refusal's message,
        wall time [s]).
    """
    t0 = time.perf_counter()
    observed = observation(demo, library, noise, noise_seed)
    out: DriverOutcome | str
    try:
        profile = refined_profile(library.style, observed)
        out = (observed, profile, identify_driver(observed, library, profiles=[profile]))
    except (LibraryError, DriverStyleError) as exc:
        out = str(exc)
    return out, time.perf_counter() - t0


def _record(
    demo: Demonstration,
    grid: set[float],
    risks: Sequence[float],
    scored: DemoScores | DriverOutcome | str,
    seconds: float,
) -> EvaluationRecord:
    p = float(demo.meta["risk"])
    index = demo.meta.get("scenario_index")
    continuous = bool(demo.meta.get("continuous", False))
    on_grid = p in grid and not continuous
    if isinstance(scored, str):
        return EvaluationRecord(p, index, on_grid, seconds, error=scored, continuous=continuous)
    if isinstance(scored, tuple):
        observed, profile, ident = scored
        return EvaluationRecord(
            p,
            index,
            on_grid,
            seconds,
            scores=ident.per_demo[0],
            by_scorer={LIKELIHOOD: ident},
            continuous=continuous,
            profile=profile,
            observed=observed,
        )
    return EvaluationRecord(
        p,
        index,
        on_grid,
        seconds,
        scores=scored,
        by_scorer={s: summarise(risks, [scored], s, [p]) for s in SCORERS},
        continuous=continuous,
    )


def _mean(values: Sequence[float | bool]) -> float | None:
    return float(np.mean(values)) if len(values) else None


def pooled_accuracy(
    records: Sequence[EvaluationRecord],
    risks: Sequence[float],
    n_pool: int = 3,
    scorer: str = DEFAULT_SCORER,
    library: DriverLibrary | None = None,
) -> PooledAccuracy:
    """Grid accuracy of single demonstrations against pools of ``n_pool`` of one vehicle.

    A "vehicle" is a grid risk; its demonstrations (in different scenarios, scenario order)
    are pooled in consecutive groups of ``n_pool`` by :func:`posterior_from_scores` (a
    driver library: by :func:`~drivestyle.irl.identification.posterior.identify_driver` from the
    records' risk profiles, ``library`` needed); the single and pooled accuracies are over
    the same demonstrations.
    """
    risks = list(risks)
    single, pooled, w1, wn = [], [], [], []
    for p in risks:
        rs = sorted(
            (r for r in records if r.risk == p and r.ok and r.grid),
            key=lambda r: (r.scenario is None, r.scenario or 0),
        )
        for k in range(0, len(rs) - n_pool + 1, n_pool):
            group = rs[k : k + n_pool]
            if scorer == LIKELIHOOD:
                if library is None:
                    raise ValueError("pooling likelihood identifications needs the library")
                joint = identify_driver(
                    [r.observed for r in group if r.observed is not None],
                    library,
                    profiles=[r.profile for r in group if r.profile is not None],
                )
                pooled.append(joint.risk_estimate == p)
                lo, hi = joint.risk_interval
            else:
                scored = [r.scores for r in group if r.scores is not None]
                post = posterior_from_scores(
                    [d.scores[scorer] for d in scored], [d.constraint_binds for d in scored]
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
    binding = [r for r in grid if r.scores is not None and r.scores.constraint_binds]
    interactive = [r for r in grid if r.scores is not None and r.scores.trigger_fired]
    between = [r for r in ok if not r.grid and not r.continuous]
    continuous = [r for r in ok if r.continuous]
    identifiable = [r for r in grid if r.identifiable]
    return ScorerSummary(
        grid_accuracy=_mean([r.correct(s) for r in grid]),
        grid_accuracy_informative=_mean([r.correct(s) for r in binding]),
        grid_mae_informative=_mean([abs(r.estimate(s) - r.risk) for r in binding]),
        grid_accuracy_interactive=_mean([r.correct(s) for r in interactive]),
        between_mae_nearest=_mean([abs(r.estimate(s) - r.risk) for r in between]),
        between_mae_interpolated=_mean(
            [abs(r.by_scorer[s].risk_interpolated - r.risk) for r in between]
        ),
        interval_coverage=_mean([r.by_scorer[s].covers(r.risk) for r in ok]),
        interval_width=_mean([float(np.ptp(r.by_scorer[s].risk_interval)) for r in ok]),
        grid_accuracy_identifiable=_mean([r.correct(s) for r in identifiable]),
        grid_coverage=_mean([r.by_scorer[s].covers(r.risk) for r in grid]),
        continuous_mae_interpolated=_mean(
            [abs(r.by_scorer[s].risk_interpolated - r.risk) for r in continuous]
        ),
        continuous_coverage=_mean([r.by_scorer[s].covers(r.risk) for r in continuous]),
        continuous_interval_width=_mean(
            [float(np.ptp(r.by_scorer[s].risk_interval)) for r in continuous]
        ),
    )


def _ceiling_summary(grid: Sequence[EvaluationRecord]) -> PathCeilingSummary:
    with_ceiling = [r for r in grid if r.ceiling is not None]
    identifiable = [r for r in with_ceiling if r.identifiable]

    def hit(r: EvaluationRecord) -> bool:
        return r.ceiling is not None and r.ceiling.estimate == r.risk

    return PathCeilingSummary(
        grid_accuracy=_mean([hit(r) for r in with_ceiling]),
        identifiable_accuracy=_mean([hit(r) for r in identifiable]),
        n_identifiable=len(identifiable),
        identifiable_gap_m=IDENTIFIABLE_GAP_M,
        tied_fraction=_mean([r.ceiling.tied for r in with_ceiling if r.ceiling is not None]),
    )


def evaluate_identification(
    library: StyleLibrary | DriverLibrary,
    demos: Sequence[Demonstration],
    grid_risks: Sequence[float],
    progress: Callable[[int], Any] | None = None,
    workers: int = 1,
    noise: float = 0.0,
    noise_seed: int = 0,
    ceiling: bool = False,
) -> Evaluation:
    """Identify held-out demonstrations of known risk with every scorer and summarise.

    Args:
        library: the style library (every scorer of :data:`SCORERS`) or a driver library
            (its one scorer, ``likelihood``; one risk profile per demonstration).
        demos: held-out demonstrations; ``meta["risk"]`` is the true risk and
            ``meta["scenario_index"]`` (optional) names the held-out scenario.
        grid_risks: the risks that count as grid points (others are between the grid).
        progress: called with 1 after each demonstration.
        workers: processes.
        noise: position noise σ [m] of the observation
            (:func:`drivestyle.envs.tracking.observe`; 0: the true states).
        noise_seed: seed of the noise (demonstration i uses ``noise_seed + i``).
        ceiling: add the path ceiling and the identifiable subset (module docstring); it
            needs the demonstrations of every grid risk in each scenario (``meta
            ["scenario_index"]``), continuous ones marked ``meta["continuous"]``.

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
    driver = isinstance(library, DriverLibrary)
    scored = parallel_map(
        _driver_task if driver else _scores_task,
        [(d, library, noise, noise_seed + i) for i, d in enumerate(demos)],
        workers,
        None if progress is None else lambda *_: progress(1),
    )
    records = tuple(
        _record(d, grid, library.risks, s, t) for d, (s, t) in zip(demos, scored, strict=True)
    )
    if ceiling:
        # the ceiling sees what the identifier sees (the observation), but whether a
        # demonstration is identifiable at all is a property of the true paths
        observed = [r.observed for r in records]
        ceilings = ceiling_records(demos, observed, grid)
        records = tuple(
            r if c is None else replace(r, ceiling=c)
            for r, c in zip(records, ceilings, strict=True)
        )
    ok = [r for r in records if r.ok]
    grid_recs = [r for r in ok if r.grid]
    scorers = (LIKELIHOOD,) if driver else SCORERS
    headline = LIKELIHOOD if driver else DEFAULT_SCORER
    risk_index = {p: i for i, p in enumerate(library.risks)}
    own = [
        r.scores.scores["rmse_y"][risk_index[r.risk]]
        for r in grid_recs
        if r.scores and "rmse_y" in r.scores.scores
    ]
    summary = EvaluationSummary(
        n=len(records),
        n_failed=len(records) - len(ok),
        n_grid=len(grid_recs),
        n_grid_informative=sum(bool(r.scores and r.scores.constraint_binds) for r in grid_recs),
        n_between=len(ok) - len(grid_recs),
        noise_sigma_m=noise,
        by_scorer={s: _scorer_summary(s, ok) for s in scorers},
        pooled=pooled_accuracy(
            records,
            sorted(grid),
            scorer=headline,
            library=library if isinstance(library, DriverLibrary) else None,
        ),
        transfer_own_risk_best=None if driver else _mean([r.correct("rmse_y") for r in grid_recs]),
        own_style_rmse_y_median_m=float(np.median(own)) if own else None,
        identify_s_median=float(np.median([r.identify_s for r in records])) if records else None,
        scorer=headline,
        n_continuous=sum(r.continuous for r in ok),
        ceiling=_ceiling_summary(grid_recs) if ceiling else None,
    )
    return Evaluation(records, summary)


def noise_curve_json(evaluations: Sequence[Evaluation]) -> list[dict[str, Any]]:
    """Per noise level σ, the headline scorer's summary (``evaluation.json``'s noise curve).

    The path ceiling's accuracies are added under ``ceiling`` where it was evaluated.
    """
    return [
        {
            "noise_sigma_m": e.summary.noise_sigma_m,
            **e.summary.by_scorer[e.scorer].to_json(),
            **({"ceiling": e.summary.ceiling.to_json()} if e.summary.ceiling else {}),
        }
        for e in evaluations
    ]
