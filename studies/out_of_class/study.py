r"""Drivers outside the style class: do identification and prediction still order them?

DESIGN §18 (the style class for real traffic).

Every driver the library was built from is a member of the style class (SMPC(p) with the
paper's horizon, weights and TV uncertainty); this study asks what the identified risk p
and the style's predictions are worth for drivers that are *not*, but whose caution is
known by construction:

- **highway-env drivers** (:data:`~drivestyle.agents.highway_drivers.HIGHWAY_CLASSES`):
  IDM for the speed and MOBIL for the lane changes, highway-env 1.12's
  :class:`~highway_env.vehicle.behavior.IDMVehicle` with other class constants, simulated
  together on a straight three-lane road and recorded at 10 Hz
  (:mod:`drivestyle.agents.highway_drivers`). Their caution order is known because every
  constant that sets how close a driver lets others come moves the same way from one
  class to the next (:class:`~drivestyle.agents.highway_drivers.DriverClass`): the IDM
  time gap and standstill gap (the gap it keeps), MOBIL's politeness and — the safety
  criterion — the braking it may impose on the new follower (MOBIL's minimum own gain, the
  motivation to change, is the same for all). The recording goes through the project's
  own extraction (:func:`~drivestyle.recorded.episodes.extract_episodes`, the path recorded
  traffic takes), so these lane changes are identified and predicted exactly as NGSIM's
  are.
- **SMPC drivers of another class** (:data:`SMPC_VARIANTS`): the expert with another
  horizon, another TV-uncertainty model or other cost weights, each at several risks; the
  known caution order is p within a variant.

The lane changes are drawn by :func:`highway_episodes` and :func:`smpc_episodes`. For each,
:func:`~.caution_order.identify_episode` reports the posterior mean p, its 90 % interval
and the verdict (DESIGN §15, "Verdict"); :func:`~.caution_order.order_checks` compares the
known caution rank with the identified p by Spearman's ρ, over the episodes and over the
groups' medians (the goal: ρ ≥ :data:`~.caution_order.SPEARMAN_GOAL`; both in
:mod:`.caution_order`). :func:`predict_episode` predicts each lane change after
t_obs ∈ :data:`T_OBS` with every method of :func:`drivestyle.prediction.methods.predict` except
the oracle (the recorded-episode path, :func:`~drivestyle.recorded.observed.observed_view`,
for the highway-env lane changes: nothing of the future enters); :func:`fde_goals`
compares the style methods' FDE with constant velocity's (the goal: ≥ :data:`FDE_GOAL`
lower). Given an amortized posterior, every lane change is also identified by it and the
caution order checked on the posterior means of p, T and s_0 (:mod:`.amortized`).

Everything is deterministic given the seeds and runs in one process.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstration
from drivestyle.agents.highway_drivers import (
    HIGHWAY_CLASSES,
    RECORD_HZ,
    SIM_HZ,
    DriverClass,
    TrafficConfig,
    draw_traffic,
    simulate_highway,
)
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.identification.library import DriverLibrary, LibraryError
from drivestyle.planning.description import SMPCConfig
from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY, TVUncertainty
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
from drivestyle.studies.out_of_class.amortized import (
    AmortizedOutOfClass,
    amortized_out_of_class,
)
from drivestyle.studies.out_of_class.caution_order import (
    EpisodeResult,
    GroupSummary,
    OrderCheck,
    group_summaries,
    identify_episode,
    order_checks,
)
from drivestyle.studies.prediction.observed_times import VehicleSpan, check_observed_times
from drivestyle.studies.prediction.records import (
    PREDICTION_ERRORS,
    PredictionRecord,
    SkippedPrediction,
    predict_vehicle,
)
from drivestyle.studies.prediction.summaries import MethodSummary, summarise_records

__all__ = [
    "FDE_GOAL",
    "HIGHWAY_EXTRACTION",
    "SMPC_VARIANTS",
    "STYLE_METHODS",
    "T_OBS",
    "FdeGoal",
    "OutOfClassEpisode",
    "OutOfClassStudy",
    "SMPCVariant",
    "StudyConfig",
    "fde_goals",
    "highway_episodes",
    "predict_episode",
    "run_study",
    "smpc_episodes",
    "vehicle_spans",
]

T_OBS = (1.0, 2.0, 3.0)
"""Observed times before each prediction [s]."""
FDE_GOAL = 0.3
"""The issue's goal: the style's FDE this fraction below constant velocity's."""
STYLE_METHODS = ("mode", "mixture")
"""The identified-style prediction methods the FDE goal is checked for."""
PREDICT_METHODS = ("cv", "ca", "physics", "population", "mode", "mixture")
"""Methods run (no oracle: the truth is not a member of the style class)."""
HIGHWAY_EXTRACTION = ExtractionConfig(dt=0.2, l_a=None)
"""How the highway-env lane changes are extracted: the recorded-traffic loaders' settings
(``recorded/real_data.py``)."""


# ------------------------------------------------------------------------- highway-env drivers
@dataclass(frozen=True)
class OutOfClassEpisode:
    """One lane change of a driver outside the style class, with its known caution."""

    family: str
    """``highway-env`` or ``smpc``."""
    group: str
    """The driver class (highway-env) or the SMPC variant."""
    caution: float
    """The known caution: the class's rank (highway-env) or p (SMPC)."""
    episode_id: str
    demo: Demonstration = field(repr=False, compare=False)
    """The lane change (highway-env: as extracted, origin ``"recorded"``; SMPC: as
    generated, origin ``"simulated"``)."""


def highway_episodes(
    config: TrafficConfig,
    seed: int,
    per_class: int,
    max_runs: int = 20,
    classes: Sequence[DriverClass] = HIGHWAY_CLASSES,
    progress: Callable[[int], Any] | None = None,
) -> tuple[list[OutOfClassEpisode], dict[str, Any]]:
    """Usable lane changes of every class, from traffic runs of seeds ``[seed, r]``.

    Runs until each class has ``per_class`` (the first ``per_class`` of a class are kept)
    or ``max_runs`` runs. Each run is :func:`~drivestyle.agents.highway_drivers.draw_traffic` +
    :func:`~drivestyle.agents.highway_drivers.simulate_highway`,
    then the project's extraction with :data:`HIGHWAY_EXTRACTION`.

    Returns:
        (the episodes, facts: runs, lane changes found, usable, unusable reasons counted).
    """
    if per_class < 1:
        raise ValueError(f"per_class must be >= 1, got {per_class}")
    kept: dict[str, list[OutOfClassEpisode]] = {c.name: [] for c in classes}
    rank = {c.name: c.caution for c in classes}
    found = usable = 0
    reasons: dict[str, int] = {}
    runs = 0
    for r in range(max_runs):
        if all(len(v) >= per_class for v in kept.values()):
            break
        runs += 1
        run_seed = int(np.random.default_rng([seed, r]).integers(0, 2**31 - 1))
        spawns = draw_traffic(config, run_seed, classes)
        rec, classes_of = simulate_highway(spawns, config, classes, name=f"run{r}")
        for e in extract_episodes(rec, HIGHWAY_EXTRACTION):
            found += 1
            if not e.usable or e.demo is None:
                for why in e.reasons:
                    key = (
                        why.split(":")[0]
                        if why.startswith(("implausible", "unusable"))
                        else ("too little track around the crossing")
                    )
                    reasons[key] = reasons.get(key, 0) + 1
                continue
            usable += 1
            cls = classes_of[e.vehicle_id]
            if len(kept[cls]) < per_class:
                kept[cls].append(OutOfClassEpisode("highway-env", cls, float(rank[cls]),
                                                   e.episode_id, e.demo))  # fmt: skip
        if progress is not None:
            progress(1)
    episodes = [e for c in classes for e in kept[c.name]]
    facts = {"runs": runs, "lane_changes": found, "usable": usable, "unusable_reasons": reasons,
             "kept_per_class": {k: len(v) for k, v in kept.items()}}  # fmt: skip
    return episodes, facts


# --------------------------------------------------------------------------- SMPC variants
@dataclass(frozen=True)
class SMPCVariant:
    """An SMPC expert outside the library's class: another horizon, uncertainty or weights."""

    name: str
    horizon: int = 10
    """N [steps] (the class: 10)."""
    uncertainty_scale: float = 1.0
    """Every σ of the TV prediction times this (the class: 1)."""
    Q: tuple[float, float, float, float] = SMPCConfig.Q
    """Stage and terminal state weights [x, y, φ, v] (the class: the paper's)."""
    R: tuple[float, float] = SMPCConfig.R
    """Input weights [a, δ]."""

    def config(self, risk: float) -> SMPCConfig:
        """The expert's configuration at risk p."""
        unc: TVUncertainty = PAPER_TV_UNCERTAINTY.scaled(self.uncertainty_scale)
        return SMPCConfig(risk=risk, horizon=self.horizon, Q=self.Q, Q_N=self.Q, R=self.R,
                          uncertainty=unc)  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"name": self.name, "horizon": self.horizon, "Q": list(self.Q),
                "uncertainty_scale": self.uncertainty_scale, "R": list(self.R)}  # fmt: skip


SMPC_VARIANTS = (
    SMPCVariant("horizon-15", horizon=15),
    SMPCVariant("uncertainty-x0.5", uncertainty_scale=0.5),
    SMPCVariant("weights", Q=(1e-6, 1.0, 20.0, 0.05), R=(0.5, 30.0)),
)
"""A longer horizon (3 s instead of 2 s), half the TV uncertainty the class assumes, and
other weights (5× the lane weight, 0.4× heading, 0.25× speed, 0.5× acceleration, 3×
steering)."""


def smpc_episodes(
    variants: Sequence[SMPCVariant],
    risks: Sequence[float],
    n_scenarios: int,
    seed: int,
    progress: Callable[[int], Any] | None = None,
) -> tuple[list[OutOfClassEpisode], list[SkippedPrediction]]:
    """Each variant at each risk in ``n_scenarios`` interactive scenarios of ``seed``.

    Scenarios: :func:`~drivestyle.agents.demo_generation.draw_interactive_scenarios`
    (those in which the class's SMPC(0.5) reacts to the TV). A demonstration that ends in
    a collision or cannot be generated is skipped with the reason.

    Returns:
        (the episodes, the skipped ones).
    """
    scenarios = draw_interactive_scenarios(n_scenarios, seed)
    out, skipped = [], []
    for v in variants:
        for p in risks:
            for i, sc in enumerate(scenarios):
                eid = f"{v.name}_p{p:g}_s{i}"
                try:
                    demo, summary = generate_demonstration(p, sc, v.config(p), seed=seed)
                except (RuntimeError, ValueError) as exc:
                    skipped.append(SkippedPrediction("smpc", eid, None, f"generation: {exc}"))
                else:
                    if summary.get("collision"):
                        skipped.append(SkippedPrediction("smpc", eid, None, "collision"))
                    else:
                        out.append(OutOfClassEpisode("smpc", v.name, float(p), eid, demo))
                if progress is not None:
                    progress(1)
    return out, skipped


# ---------------------------------------------------------------------------- prediction
def predict_episode(
    ep: OutOfClassEpisode,
    library: DriverLibrary,
    t_obs: Sequence[float] = T_OBS,
    physics: PhysicsParams | None = None,
) -> tuple[list[PredictionRecord], list[SkippedPrediction]]:
    """Predict one lane change after each t_obs by every method but the oracle.

    :func:`~drivestyle.studies.prediction.records.predict_vehicle`: a highway-env lane
    change is extracted as a recorded episode (``origin == "recorded"``) and is seen through
    ``observed_view`` (the one recorded view of its observed samples); an SMPC
    demonstration is predicted in its own scenario. The record's set is the family
    (:func:`run_study` sets its bootstrap unit to ``<group>:<episode>``: every episode is
    its own unit).
    """
    return predict_vehicle(ep.family, ep.episode_id, ep.demo, library, t_obs,
                           physics=physics, methods=PREDICT_METHODS)  # fmt: skip


@dataclass(frozen=True)
class FdeGoal:
    """A style method's FDE against constant velocity's over one family at one t_obs."""

    set: str
    t_obs: float
    method: str
    n: int
    fde_median_m: float
    fde_median_ci: tuple[float, float]
    cv_median_m: float
    cv_median_ci: tuple[float, float]
    reduction_median: float
    """1 − median FDE / median CV FDE."""
    reduction_mean: float | None
    """1 − mean FDE / mean CV FDE (the prediction study's definition)."""
    met: bool
    """Both reductions ≥ :data:`FDE_GOAL`."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def fde_goals(summaries: Sequence[MethodSummary]) -> list[FdeGoal]:
    """The FDE goal for each style method, set and t_obs (summaries with bootstrap stats)."""
    cv = {(s.set, s.t_obs): s for s in summaries if s.method == "cv"}
    out = []
    for s in summaries:
        base = cv.get((s.set, s.t_obs))
        if s.method not in STYLE_METHODS or base is None or "fde" not in s.stats:
            continue
        st, bt = s.stats["fde"], base.stats["fde"]
        red = 1.0 - st.median / bt.median if bt.median > 0 else float("nan")
        met = bool(red >= FDE_GOAL and (s.fde_reduction_vs_cv or 0.0) >= FDE_GOAL)
        out.append(FdeGoal(s.set, s.t_obs, s.method, s.n, st.median, (st.median_lo, st.median_hi),
                           bt.median, (bt.median_lo, bt.median_hi), float(red),
                           s.fde_reduction_vs_cv, met))  # fmt: skip
    return out


# ------------------------------------------------------------------------------- the study
@dataclass(frozen=True)
class StudyConfig:
    """What the study runs (:func:`run_study`)."""

    seed: int = 2701
    """Seed of the traffic runs and of the SMPC scenarios (disjoint from the library's 0)."""
    per_class: int = 10
    """highway-env lane changes kept per driver class."""
    max_runs: int = 20
    """Most traffic runs to find them."""
    traffic: TrafficConfig = field(default_factory=TrafficConfig)
    smpc_risks: tuple[float, ...] = (0.5, 0.65, 0.8, 0.95)
    smpc_scenarios: int = 2
    """Interactive scenarios per (variant, risk)."""
    variants: tuple[SMPCVariant, ...] = SMPC_VARIANTS
    t_obs: tuple[float, ...] = T_OBS
    predict: bool = True
    """Run the prediction part."""

    def __post_init__(self) -> None:
        if self.per_class < 0 or self.max_runs < 0 or self.smpc_scenarios < 0:
            raise ValueError("per_class, max_runs and smpc_scenarios must be >= 0")
        if self.smpc_scenarios and self.variants and len(set(self.smpc_risks)) < 2:
            raise ValueError("smpc_risks needs at least two distinct risks to order")
        for p in self.smpc_risks:
            if not 0.5 <= p < 1.0:
                raise ValueError(f"every SMPC risk must lie in [0.5, 1), got {p!r}")
        if self.predict and not self.t_obs:
            raise ValueError("t_obs must name at least one observed time")

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "seed": self.seed, "per_class": self.per_class, "max_runs": self.max_runs,
            "traffic": {k: getattr(self.traffic, k) for k in self.traffic.__dataclass_fields__},
            "classes": [c.to_json() for c in HIGHWAY_CLASSES],
            "smpc_risks": list(self.smpc_risks), "smpc_scenarios": self.smpc_scenarios,
            "variants": [v.to_json() for v in self.variants], "t_obs": list(self.t_obs),
            "predict": self.predict, "sim_hz": SIM_HZ, "record_hz": RECORD_HZ,
        }  # fmt: skip


def vehicle_spans(config: StudyConfig) -> list[VehicleSpan]:
    """How long the study's lane changes last and their T_s (what an observed time needs).

    highway-env lane changes are windows of :data:`HIGHWAY_EXTRACTION` (at most its
    ``before_s + after_s``); SMPC drivers are whole demonstrations of the random family's
    scenarios.
    """
    spans = []
    if config.per_class and config.max_runs:
        ext = HIGHWAY_EXTRACTION
        spans.append(VehicleSpan("highway-env lane changes", ext.dt, ext.before_s + ext.after_s,
                                 at_most=True))  # fmt: skip
    if config.smpc_scenarios and config.variants:
        base = ScenarioRanges().base
        spans.append(VehicleSpan("SMPC drivers", base.dt, base.horizon_s))
    return spans


@dataclass(frozen=True)
class OutOfClassStudy:
    """Everything the study measured."""

    config: StudyConfig
    results: tuple[EpisodeResult, ...]
    groups: tuple[GroupSummary, ...]
    orders: tuple[OrderCheck, ...]
    records: tuple[PredictionRecord, ...]
    summaries: tuple[MethodSummary, ...]
    goals: tuple[FdeGoal, ...]
    skipped: tuple[SkippedPrediction, ...]
    highway_facts: dict[str, Any]
    seconds: dict[str, float]
    amortized: AmortizedOutOfClass | None = None
    """The episodes on the amortized posterior and their order checks (None: not asked)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``out_of_class.json``; ``amortized`` only where it was run)."""
        extra = {} if self.amortized is None else {"amortized": self.amortized.to_json()}
        return {
            "config": self.config.to_json(),
            "highway": self.highway_facts,
            "episodes": [r.to_json() for r in self.results],
            "groups": [g.to_json() for g in self.groups],
            "order": [o.to_json() for o in self.orders],
            "prediction": {
                "summaries": [s.to_json() for s in self.summaries],
                "goals": [g.to_json() for g in self.goals],
                "records": [r.to_json() for r in self.records],
            },
            "skipped": [s.to_json() for s in self.skipped],
            "seconds": self.seconds,
        } | extra


def run_study(
    library: DriverLibrary,
    config: StudyConfig,
    physics: PhysicsParams | None = None,
    progress: Callable[[str, int], Any] | None = None,
    on_plan: Callable[[str, int], Any] | None = None,
    posterior: NeuralPosterior | None = None,
    estimator: str = "",
) -> OutOfClassStudy:
    """Simulate, extract, identify and predict (module docstring), in this process.

    Args:
        library: the driver library.
        config: the study's sizes and seeds.
        physics: the physics baseline's parameters (None: its defaults).
        progress: called with (stage, 1) after each unit of a stage.
        on_plan: called with (stage, units) before a stage starts.
        posterior: an amortized posterior: every lane change also identified by it and the
            caution orders checked on it (:mod:`.amortized`); None: not.
        estimator: where ``posterior`` was read from (for the output).

    Returns:
        The study.

    Raises:
        ValueError: the study's seed is the library's training seed; an observed time no
            lane change of the study serves
            (:func:`~drivestyle.studies.prediction.observed_times.check_observed_times`).
    """
    if library.meta.get("seed") == config.seed:
        raise ValueError(f"seed {config.seed} is the library's own training seed; use another")
    if config.predict:  # before any simulation: a time no lane change serves skips every one
        check_observed_times(config.t_obs, simulated=False, others=vehicle_spans(config))

    def stage(name: str, n: int) -> Callable[[int], Any] | None:
        if on_plan is not None:
            on_plan(name, n)
        return None if progress is None else lambda k: progress(name, k)

    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    episodes: list[OutOfClassEpisode] = []
    facts: dict[str, Any] = {}
    if config.per_class and config.max_runs:
        tick = stage("traffic runs", config.max_runs)
        episodes, facts = highway_episodes(config.traffic, config.seed, config.per_class,
                                           config.max_runs, progress=tick)  # fmt: skip
    seconds["highway_env"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    skipped: list[SkippedPrediction] = []
    if config.smpc_scenarios and config.variants:
        n = len(config.variants) * len(config.smpc_risks) * config.smpc_scenarios
        more, skipped = smpc_episodes(config.variants, config.smpc_risks, config.smpc_scenarios,
                                      config.seed, stage("SMPC demonstrations", n))  # fmt: skip
        episodes += more
    seconds["smpc_demos"] = time.perf_counter() - t0
    results: list[EpisodeResult] = []
    records: list[PredictionRecord] = []
    t_ident = t_pred = 0.0
    tick = stage("episodes", len(episodes))
    for ep in episodes:
        t0 = time.perf_counter()
        try:
            results.append(identify_episode(ep, library))
        except (LibraryError, *PREDICTION_ERRORS) as exc:
            skipped.append(
                SkippedPrediction(ep.family, ep.episode_id, None, f"identification: {exc}")
            )
        t_ident += time.perf_counter() - t0
        t0 = time.perf_counter()
        if config.predict:
            recs, skips = predict_episode(ep, library, config.t_obs, physics)
            records += [replace(r, unit=f"{ep.group}:{r.vehicle_id}") for r in recs]
            skipped += skips
        t_pred += time.perf_counter() - t0
        if tick is not None:
            tick(1)
    seconds["identification"] = t_ident
    seconds["prediction"] = t_pred
    summaries = summarise_records(records) if records else []
    orders = tuple(order_checks(results))
    amortized = None
    if posterior is not None:
        t0 = time.perf_counter()
        amortized = amortized_out_of_class(episodes, posterior, orders, estimator)
        seconds["amortized"] = time.perf_counter() - t0
    return OutOfClassStudy(
        config=config,
        results=tuple(results),
        groups=tuple(group_summaries(results)),
        orders=orders,
        records=tuple(records),
        summaries=tuple(summaries),
        goals=tuple(fde_goals(summaries)),
        skipped=tuple(skipped),
        highway_facts=facts,
        seconds=seconds,
        amortized=amortized,
    )
