"""Identification on held-out demonstrations of known risk, and a k-NN reference (DESIGN §8).

:func:`evaluate_identification` identifies held-out demonstrations with every scorer of
:mod:`drivestyle.irl.identification.posterior` and summarises accuracy on the library's grid, the
error between grid points, interval coverage, pooling of one vehicle's demonstrations and
timing; :func:`knn_baseline` is a supervised reference without IRL. Results are typed
(:class:`Evaluation`, one :class:`EvaluationRecord` per demonstration with a result per
scorer); the Markdown of ``evaluation.md`` is written from them by small functions.

A :class:`~drivestyle.irl.identification.library.DriverLibrary` (DESIGN §15) is evaluated with its
one scorer, ``likelihood``: each demonstration's risk profile is computed once and reused by
its identification and by pooling. With ``ceiling=True`` every grid demonstration also gets
the *path ceiling* (:class:`CeilingRecord`): the SMPC(q) path of each grid risk q in the
demonstration's own scenario is the held-out demonstration of q in that scenario (the
expert is deterministic, so this is what :mod:`~drivestyle.studies.ceiling`
re-simulates), the ceiling's estimate is the closest such path to the demonstration as
observed, and the demonstration is *identifiable* when the closed-loop paths of the true
risk's neighbouring grid risks both lie at least :data:`IDENTIFIABLE_GAP_M` (RMS position
distance over the demonstration) from SMPC(true)'s (:func:`neighbour_gap`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
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
from drivestyle.irl.identification.posterior import (
    DEFAULT_SCORER,
    LIKELIHOOD,
    SCORERS,
    DemoScores,
    Identification,
    demo_scores,
    identify_driver,
    posterior_from_scores,
    risk_interval,
    summarise,
)
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem

__all__ = [
    "CONTINUOUS_RANGE",
    "IDENTIFIABLE_GAP_M",
    "CeilingRecord",
    "Evaluation",
    "EvaluationRecord",
    "EvaluationSummary",
    "PathCeilingSummary",
    "PooledAccuracy",
    "ScorerSummary",
    "continuous_demonstrations",
    "draw_continuous_risks",
    "evaluate_identification",
    "is_identifiable",
    "knn_baseline",
    "neighbour_gap",
    "noise_curve_json",
    "path_distance",
    "pooled_accuracy",
]

IDENTIFIABLE_GAP_M = 0.05
"""A grid demonstration is identifiable when the closed-loop SMPC paths of its true risk's
neighbouring grid risks lie at least this far (RMS position distance) from SMPC(true)'s
(the capacity study's ceiling tells the neighbours apart by ≥ 5 cm, RESULTS §10). RMS, not
max, because it is the ceiling's own distance: two paths that part for one step only are
not told apart."""
CONTINUOUS_RANGE = (0.5, 0.95)
"""Continuous true risks are drawn from U[0.5, 0.95] (the library's grid span), as the
driver library's calibration draws them."""


# ---------------------------------------------------------------------------- the path ceiling
def path_distance(a: np.ndarray, b: np.ndarray) -> float:
    """RMS position distance of two paths (n, ≥ 2) over their common length [m].

    The distance :func:`drivestyle.studies.ceiling.ceiling_identify` ranks by.
    """
    n = min(len(a), len(b))
    diff = np.asarray(a)[:n, :2] - np.asarray(b)[:n, :2]
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def neighbour_gap(
    paths: Mapping[float, np.ndarray], risk: float, grid: Sequence[float]
) -> float | None:
    """Least distance between SMPC(risk)'s path and its neighbouring grid risks' paths.

    Args:
        paths: grid risk → the SMPC's closed-loop path in one scenario, (n, ≥ 2).
        risk: the true risk (a grid risk).
        grid: the grid risks, increasing.

    Returns:
        min over the (one or two) neighbours q of :func:`path_distance` (SMPC(q),
        SMPC(risk)) [m]; None when ``risk`` is off the grid or a needed path is missing.
    """
    grid = [float(p) for p in grid]
    if risk not in grid or risk not in paths:
        return None
    i = grid.index(risk)
    neighbours = [grid[j] for j in (i - 1, i + 1) if 0 <= j < len(grid)]
    if not neighbours or any(q not in paths for q in neighbours):
        return None
    return min(path_distance(paths[q], paths[risk]) for q in neighbours)


def is_identifiable(gap: float | None, threshold: float = IDENTIFIABLE_GAP_M) -> bool:
    """Whether a neighbour gap (:func:`neighbour_gap`) makes the demonstration identifiable."""
    return gap is not None and gap >= threshold


@dataclass(frozen=True)
class CeilingRecord:
    """The path ceiling's answer for one grid demonstration (module docstring)."""

    distances: Mapping[float, float]
    """Grid risk q → distance of SMPC(q)'s path in the scenario to the observed demo [m]."""
    estimate: float
    """The grid risk with the closest path (the first of equal distances)."""
    neighbour_gap_m: float | None
    """:func:`neighbour_gap` of the true risk (from the true paths, not the observation)."""

    @property
    def identifiable(self) -> bool:
        """Whether the neighbouring risks' paths lie ≥ :data:`IDENTIFIABLE_GAP_M` away."""
        return is_identifiable(self.neighbour_gap_m)

    @property
    def tied(self) -> bool:
        """Whether another grid risk's path lies within 1 cm of the closest."""
        d = np.asarray(list(self.distances.values()))
        return int(np.sum(d <= d.min() + 0.01)) > 1


def _ceiling_records(
    demos: Sequence[Demonstration], observed: Sequence[Demonstration | None], grid: set[float]
) -> list[CeilingRecord | None]:
    """The path ceiling of every grid demonstration with a scenario index (else None)."""
    order = sorted(grid)
    paths: dict[Any, dict[float, np.ndarray]] = {}
    for d in demos:
        p, index = float(d.meta["risk"]), d.meta.get("scenario_index")
        if p in grid and index is not None and not d.meta.get("continuous"):
            paths.setdefault(index, {})[p] = d.ev[:, :2]
    out: list[CeilingRecord | None] = []
    for d, seen in zip(demos, observed, strict=True):
        p, index = float(d.meta["risk"]), d.meta.get("scenario_index")
        here = paths.get(index, {})
        if p not in grid or d.meta.get("continuous") or index is None or p not in here:
            out.append(None)
            continue
        xy = (d if seen is None else seen).ev[:, :2]
        dist = {q: path_distance(here[q], xy) for q in order if q in here}
        best = min(dist, key=lambda q: dist[q])
        out.append(CeilingRecord(dist, best, neighbour_gap(here, p, order)))
    return out


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
    continuous: bool = False
    """Whether the true risk was drawn from :data:`CONTINUOUS_RANGE` (not a midpoint)."""
    ceiling: CeilingRecord | None = None
    """The path ceiling (grid demonstrations of an evaluation with ``ceiling=True``)."""
    profile: RiskProfile | None = field(default=None, repr=False)
    """The risk profile (driver libraries; pooling reuses it)."""
    observed: Demonstration | None = field(default=None, repr=False, compare=False)
    """The demonstration as identified (noise, tracker), driver libraries only."""

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

    @property
    def identifiable(self) -> bool:
        """Whether the path ceiling tells the true risk's neighbours apart (grid only)."""
        return self.ceiling is not None and self.ceiling.identifiable

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``evaluation.json``'s record keys: ``<scorer>_estimate``, …).

        Keys that only some evaluations have are written where they apply: ``continuous``
        (True) for continuous risks, ``ceiling_estimate``, ``ceiling_correct``,
        ``neighbour_gap_m`` and ``identifiable`` with the path ceiling, ``risk_profile``
        for driver libraries.
        """
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
        main = DEFAULT_SCORER if DEFAULT_SCORER in self.by_scorer else next(iter(self.by_scorer))
        rec["posterior"] = self.by_scorer[main].to_json()["posterior"]
        if self.continuous:
            rec["continuous"] = True
        if self.ceiling is not None:
            rec |= {
                "ceiling_estimate": self.ceiling.estimate,
                "ceiling_correct": self.ceiling.estimate == self.risk,
                "neighbour_gap_m": self.ceiling.neighbour_gap_m,
                "identifiable": self.ceiling.identifiable,
            }
        if self.profile is not None:
            rec["risk_profile"] = {
                "risks": list(self.profile.risks),
                "ssr": list(self.profile.ssr),
                "n_residuals": self.profile.n_residuals,
                "n_active": self.profile.n_active,
            }
        return rec


@dataclass(frozen=True)
class ScorerSummary:
    """One scorer's accuracy, errors and intervals over the held-out demonstrations."""

    grid_accuracy: float | None
    grid_accuracy_informative: float | None
    """Accuracy among grid demonstrations in which p can matter
    (:attr:`~drivestyle.irl.identification.posterior.DemoScores.constraint_binds`; the name is the
    results' key, older than the verdict's labels)."""
    grid_mae_informative: float | None
    """MAE of the posterior mode on the same demonstrations."""
    grid_accuracy_interactive: float | None
    """Accuracy among grid demonstrations whose trigger fired."""
    between_mae_nearest: float | None
    """MAE of the posterior mode on risks between grid points."""
    between_mae_interpolated: float | None
    """MAE of the posterior mean on risks between grid points."""
    interval_coverage: float | None
    interval_width: float | None
    grid_accuracy_identifiable: float | None = None
    """Accuracy on the grid demonstrations the path ceiling calls identifiable."""
    grid_coverage: float | None = None
    """Interval coverage on the grid demonstrations."""
    continuous_mae_interpolated: float | None = None
    """MAE of the posterior mean on continuous true risks."""
    continuous_coverage: float | None = None
    """Interval coverage on continuous true risks."""
    continuous_interval_width: float | None = None
    """Mean interval width on continuous true risks."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class PathCeilingSummary:
    """The path ceiling's accuracy on the same grid demonstrations (module docstring)."""

    grid_accuracy: float | None
    """On every grid demonstration (ties go to the lower risk)."""
    identifiable_accuracy: float | None
    """On the identifiable ones."""
    n_identifiable: int
    """Grid demonstrations whose neighbouring risks' paths lie ≥ 5 cm away."""
    identifiable_gap_m: float
    """The threshold (:data:`IDENTIFIABLE_GAP_M`)."""
    tied_fraction: float | None
    """Share of grid demonstrations with another risk's path within 1 cm of the closest."""

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
    """Grid demonstrations in which p can matter (``grid_accuracy_informative``'s)."""
    n_between: int
    noise_sigma_m: float
    by_scorer: Mapping[str, ScorerSummary]
    pooled: PooledAccuracy
    transfer_own_risk_best: float | None
    """Share of grid demonstrations whose own risk's styles reproduce them best (rmse_y)."""
    own_style_rmse_y_median_m: float | None
    identify_s_median: float | None
    scorer: str = DEFAULT_SCORER
    """The headline scorer (``likelihood`` for a driver library)."""
    n_continuous: int = 0
    """Demonstrations with continuous true risks (part of ``n_between``)."""
    ceiling: PathCeilingSummary | None = None
    """The path ceiling (``ceiling=True``)."""

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
            "scorer": self.scorer,
            "n_continuous": self.n_continuous,
            **({"ceiling": self.ceiling.to_json()} if self.ceiling is not None else {}),
        }


@dataclass(frozen=True)
class Evaluation:
    """An evaluation: one record per demonstration and their summary."""

    records: tuple[EvaluationRecord, ...]
    summary: EvaluationSummary

    @property
    def scorer(self) -> str:
        """The headline scorer."""
        return self.summary.scorer

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
    tracked = library.meta.get("observation") == "tracked"
    observed = (
        demo
        if noise == 0 and not tracked
        else observe(demo, noise, np.random.default_rng(noise_seed))
    )
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
        ceilings = _ceiling_records(demos, observed, grid)
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
