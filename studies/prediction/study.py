"""Style-aware prediction against constant velocity, on simulated and recorded vehicles.

DESIGN §17 (using a style: online identification, prediction and planning).

:func:`evaluate_prediction` observes each held-out vehicle for t_obs ∈ :data:`T_OBS` seconds
and predicts the rest of its demonstration with every method of
:func:`drivestyle.prediction.methods.predict` (constant velocity and acceleration, the physics
baselines — the vehicle alone, and every vehicle jointly —, the population style, the online
posterior's mode and mixture, and — where the truth is known — the oracle), scoring each by
its average and final displacement errors (ADE, FDE).

The vehicles:

- **simulated** (known risk, :mod:`.vehicles`): SMPC(p) in the random family and in random
  traffic; the oracle is the SMPC as a style. :data:`VALIDATION_SEED` is the seed anything
  was chosen on (the study's settings, the tests); :data:`TEST_SEED` is the held-out seed
  whose run is reported, once. Each is also tracked online over its whole demonstration
  (:mod:`.tracking`).
- **recorded**: the NGSIM and CATS episodes of one split of the recorded benchmark
  (:mod:`drivestyle.recorded.benchmark`, RESULTS §13), or a folder of extracted episodes,
  each seen through :func:`~drivestyle.recorded.observed.observed_view` after t_obs — the one
  recorded view of the observed samples in the no-leak frame: every method gets only what an
  observer knows then. No oracle. Episodes too short for a t_obs, or whose prediction fails,
  are skipped and counted with the reason
  (:class:`~drivestyle.studies.prediction.records.SkippedPrediction`).

The physics baselines' parameters are calibrated on the train split
(:mod:`.physics_split`) and read from
:data:`~drivestyle.prediction.physics_calibration.PHYSICS_FILE` and
:data:`~drivestyle.prediction.joint_physics_calibration.JOINT_PHYSICS_FILE`. Summaries carry
bootstrap 95 % intervals of the mean and median of every error, resampling vehicles
(:mod:`.summaries`); another split's run calibrates 90 % prediction regions
(:mod:`drivestyle.prediction.regions`, :mod:`.runs`) whose coverage is reported.

Every recorded episode has a kind (lane change, lane keeping, car following, approaching a
slower leader; :mod:`drivestyle.recorded.kinds`) and may be a stop-and-go window: the pooled
summaries are every kind together; the recorded ones are also summarised per kind and over
the stop-and-go windows, each method's FDE is taken relative to CV's per kind and pooled
(medians of the ratio with intervals over vehicles), and the regions are calibrated per kind
too (the pooled rate where a kind has too few calibration records) with their coverage per
kind and pooled.

Results are typed: one record per (vehicle, t_obs), a summary per (set, t_obs, method) and
per (set, kind, t_obs, method), a ratio to CV per (set, kind, t_obs, method), a goal check per
goal, one tracking record per simulated vehicle and their summary, all in one
:class:`PredictionStudy`.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.prediction.joint_physics import JointPhysicsParams
from drivestyle.prediction.methods import METHODS
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.prediction.regions import (
    KIND_MIN_CALIBRATION,
    KindRegionCheck,
    RegionCheck,
    kind_region_coverage,
    kind_region_rates,
    record_rows,
    region_coverage,
    region_rates,
)
from drivestyle.prediction.style import oracle_style
from drivestyle.recorded.benchmark import (
    DEFAULT_DATA_DIR,
    SPLIT_SEED,
    SPLITS,
    SplitRow,
    check_sample_split,
    check_split_selects,
    episodes_split,
    load_episodes_folder,
    load_recorded,
    read_split,
)
from drivestyle.recorded.kinds import ALL_KINDS, EPISODE_KINDS
from drivestyle.recorded.real_data import DATASETS
from drivestyle.studies.prediction.observed_times import check_observed_times
from drivestyle.studies.prediction.records import (
    PREDICTION_ERRORS,
    PredictionRecord,
    SkippedPrediction,
    predict_vehicle,
)
from drivestyle.studies.prediction.summaries import (
    BOOTSTRAP_SAMPLES,
    BOOTSTRAP_SEED,
    GOALS,
    RATIO_GOALS,
    GoalCheck,
    MethodSummary,
    RatioStat,
    goal_checks,
    ratio_stats,
    summarise_by_kind,
    summarise_records,
)
from drivestyle.studies.prediction.tracking import (
    TrackingRecord,
    TrackingSummary,
    summarise_tracking,
    track_vehicle,
)
from drivestyle.studies.prediction.vehicles import SimulatedVehicle, draw_simulated

__all__ = [
    "TEST_SEED",
    "T_OBS",
    "VALIDATION_SEED",
    "PredictionStudy",
    "evaluate_prediction",
    "example_record",
]

T_OBS = (1.0, 2.0, 3.0)
"""Observed times [s] (the issue's)."""
VALIDATION_SEED = 19_000
"""The seed of the runs anything was chosen on (settings, tests)."""
TEST_SEED = 19_001
"""The held-out seed of the reported run (``evaluate_prediction.py``'s default)."""


@dataclass(frozen=True)
class PredictionStudy:
    """The whole comparison (:func:`evaluate_prediction`)."""

    seed: int
    t_obs: tuple[float, ...]
    vehicles: tuple[SimulatedVehicle, ...]
    records: tuple[PredictionRecord, ...]
    skipped: tuple[SkippedPrediction, ...]
    summaries: tuple[MethodSummary, ...]
    goals: tuple[GoalCheck, ...]
    tracks: tuple[TrackingRecord, ...]
    tracking: TrackingSummary
    recorded_sets: tuple[str, ...]
    """The recorded datasets evaluated (empty with ``recorded=False``)."""
    n_geometries: dict[str, int]
    """Recorded set → distinct solver geometries (l_f, l_r, l_a, l_b, vehicle slots)."""
    seconds: dict[str, float]
    """Wall time per stage [s]."""
    demos: dict[str, Demonstration] = field(default_factory=dict, repr=False, compare=False)
    """Vehicle id → the demonstration predicted (in memory, for figures)."""
    split: str | None = None
    """The benchmark split of the recorded episodes (None: the used episodes)."""
    physics: PhysicsParams | None = None
    """The physics baseline's parameters (None: the defaults)."""
    regions: tuple[RegionCheck, ...] = ()
    """The 90 % prediction regions' coverage (empty: no calibration split given)."""
    kind_summaries: tuple[MethodSummary, ...] = ()
    """The recorded records' summaries per kind and over the stop-and-go windows
    (:func:`~drivestyle.studies.prediction.summaries.summarise_by_kind`; :attr:`summaries`
    are the pooled ones)."""
    ratios: tuple[RatioStat, ...] = ()
    """Each method's FDE relative to CV's, per recorded set, kind (and pooled) and t_obs."""
    kind_regions: tuple[KindRegionCheck, ...] = ()
    """The 90 % regions calibrated per kind and their coverage per kind and pooled (empty: no
    calibration split given)."""
    joint_physics: JointPhysicsParams | None = None
    """The joint physics baseline's parameters (None: the defaults)."""

    def physics_json(self) -> dict[str, float]:
        """The physics baseline's parameters as used."""
        return (self.physics or PhysicsParams()).to_json()

    def joint_physics_json(self) -> dict[str, float]:
        """The joint physics baseline's parameters as used."""
        return (self.joint_physics or JointPhysicsParams()).to_json()

    def summary(
        self, set_name: str, t_obs: float, method: str, kind: str = ALL_KINDS
    ) -> MethodSummary | None:
        """The summary of one (set, t_obs, method) over one kind (default: pooled), if any."""
        for s in self.summaries if kind == ALL_KINDS else self.kind_summaries:
            if (s.set, s.t_obs, s.method, s.kind) == (set_name, t_obs, method, kind):
                return s
        return None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction_eval.json``)."""
        skipped_by_reason: dict[str, int] = {}
        for s in self.skipped:
            key = f"{s.set}: {s.reason}"
            skipped_by_reason[key] = skipped_by_reason.get(key, 0) + 1
        return {
            "seed": self.seed,
            "validation_seed": VALIDATION_SEED,
            "test_seed": TEST_SEED,
            "t_obs_s": list(self.t_obs),
            "methods": list(METHODS),
            "goals": dict(GOALS),
            "simulated_vehicles": [
                {
                    "vehicle_id": v.vehicle_id,
                    "risk": v.risk,
                    "traffic_seed": v.traffic_seed,
                    "scenario": None if v.scenario is None else v.scenario.to_dict(),
                }
                for v in self.vehicles
            ],
            "recorded_sets": list(self.recorded_sets),
            "split": self.split,
            "split_seed": SPLIT_SEED,
            "bootstrap": {
                "seed": BOOTSTRAP_SEED,
                "samples": BOOTSTRAP_SAMPLES,
                "resampled": "vehicles",
                "interval": 0.95,
            },
            "physics_params": self.physics_json(),
            "joint_physics_params": self.joint_physics_json(),
            "n_geometries": dict(self.n_geometries),
            "summaries": [s.to_json() for s in self.summaries],
            "goal_checks": [g.to_json() for g in self.goals],
            "tracking_summary": self.tracking.to_json(),
            "n_records": len(self.records),
            "n_skipped": len(self.skipped),
            "skipped_by_reason": skipped_by_reason,
            "skipped": [s.to_json() for s in self.skipped],
            "records": [r.to_json() for r in self.records],
            "tracking": [t.to_json() for t in self.tracks],
            "regions": [g.to_json() for g in self.regions],
            "episode_kinds": list(EPISODE_KINDS),
            "summaries_by_kind": [s.to_json() for s in self.kind_summaries],
            "ratio_goals": dict(RATIO_GOALS),
            "fde_ratios": [r.to_json() for r in self.ratios],
            "kind_min_calibration": KIND_MIN_CALIBRATION,
            "regions_by_kind": [g.to_json() for g in self.kind_regions],
            "seconds": dict(self.seconds),
        }


def _simulated_task(
    vehicle: SimulatedVehicle, library: DriverLibrary, t_obs: tuple[float, ...]
) -> tuple[Demonstration | None, list[PredictionRecord], list[SkippedPrediction],
           TrackingRecord | None]:  # fmt: skip
    """Worker: generate one simulated vehicle, predict it at every t_obs and track it."""
    try:
        demo = vehicle.demonstration()
    except (RuntimeError, ValueError) as exc:
        skip = SkippedPrediction("simulated", vehicle.vehicle_id, None, f"generation: {exc}")
        return None, [], [skip], None
    records, skipped = predict_vehicle(
        "simulated", vehicle.vehicle_id, demo, library, t_obs, oracle_style(demo.meta)
    )
    try:
        track = track_vehicle(vehicle.vehicle_id, demo, library, vehicle.risk)
    except PREDICTION_ERRORS as exc:
        skipped.append(SkippedPrediction("simulated", vehicle.vehicle_id, None, f"tracking: {exc}"))
        track = None
    return demo, records, skipped, track


@functools.lru_cache(maxsize=2)
def _amortized(path: str) -> NeuralPosterior:
    """The amortized posterior of ``path``, loaded once per worker process."""
    return open_posterior(path)


def _recorded_task(
    set_name: str, episode_id: str, raw: Demonstration, unit: str, library: DriverLibrary,
    t_obs: tuple[float, ...], physics: PhysicsParams | None,
    joint_physics: JointPhysicsParams | None = None, posterior: str | None = None,
) -> tuple[list[PredictionRecord], list[SkippedPrediction]]:  # fmt: skip
    """Worker: predict one recorded episode at every t_obs."""
    amortized = None if posterior is None else _amortized(posterior)
    return predict_vehicle(set_name, episode_id, raw, library, t_obs, physics=physics, unit=unit,
                           joint_physics=joint_physics, amortized=amortized)  # fmt: skip


def _geometry(demo: Demonstration) -> tuple:
    sc = demo.scenario
    slots = 1 if demo.other_vehicles.shape[1] == 0 else 4
    return (round(sc.l_f, 6), round(sc.l_r, 6), round(sc.l_a, 6), round(sc.l_b, 6), slots)


def evaluate_prediction(
    library: DriverLibrary,
    n_vehicles: int,
    seed: int,
    data_dir: str | Path | None = DEFAULT_DATA_DIR,
    t_obs: Sequence[float] = T_OBS,
    workers: int = 2,
    progress: Callable[[str, int], Any] | None = None,
    on_plan: Callable[[str, int], Any] | None = None,
    split: str | None = None,
    split_rows: Sequence[SplitRow] | None = None,
    physics: PhysicsParams | None = None,
    calibration: Sequence[PredictionRecord | Mapping[str, Any]] | None = None,
    episodes_dir: str | Path | None = None,
    joint_physics: JointPhysicsParams | None = None,
    posterior: str | Path | None = None,
) -> PredictionStudy:
    """Run the comparison (module docstring).

    Args:
        library: the driver library.
        n_vehicles: simulated held-out vehicles (half random family, half traffic).
        seed: the held-out seed (:data:`TEST_SEED` for the report, :data:`VALIDATION_SEED`
            while choosing anything).
        data_dir: the folder holding ``ngsim/`` and ``cats-av-lanechange/`` (None: no
            recorded episodes).
        t_obs: observed times [s].
        workers: processes (CasADi is not thread-safe).
        progress: called with (stage, 1) after each vehicle of a stage.
        on_plan: called with (stage, number of vehicles) before a stage starts.
        split: the benchmark split whose recorded episodes are predicted (None: the
            learning studies' used episodes, each its own vehicle).
        split_rows: the split (default: :data:`~drivestyle.recorded.benchmark.SPLIT_FILE`'s).
        physics: the physics baseline's parameters (None: the defaults).
        calibration: another split's recorded records (e.g. a validation run's
            ``prediction_eval.json`` rows): the 90 % prediction regions' radii
            (:func:`region_rates`), whose coverage on this run's recorded records is
            reported (None: no regions).
        episodes_dir: a folder of extracted episodes (``drivestyle extract-episodes``) to
            benchmark instead of the shipped samples (``data_dir`` is then not read):
            ``split`` selects its episodes from ``split_rows`` (None: the folder's own
            split, :func:`episodes_split`); ``split="all"`` takes every episode
            (:func:`load_episodes_folder`).
        joint_physics: the joint physics baseline's parameters (None: the defaults).
        posterior: the amortized posterior's file (``build-posterior``): its recorded
            episodes are also predicted by ``style_alone`` and ``style_joint``
            (:mod:`drivestyle.prediction.joint`; None: not).

    Returns:
        The study.

    Raises:
        ValueError: a bad argument (observed times: :func:`check_observed_times`, checked
            before any vehicle is simulated), the library's own training seed, or missing
            data.
    """
    if library.meta.get("seed") == seed:
        raise ValueError(
            f"seed {seed} is the library's own training seed; use a disjoint held-out seed"
        )
    seconds: dict[str, float] = {}

    def stage(name: str, n: int) -> Callable[..., None] | None:
        if on_plan is not None:
            on_plan(name, n)
        return None if progress is None else lambda *_: progress(name, 1)

    known = (*SPLITS, "all") if episodes_dir is not None else SPLITS
    if split is not None and split not in known:
        raise ValueError(f"unknown split {split!r}; known: {list(known)}")
    recorded: list[tuple[str, str, Demonstration, str]] = []
    recorded_sets: tuple[str, ...] = ()
    if episodes_dir is not None:
        rows_here = split_rows
        if rows_here is None and split != "all":
            rows_here = episodes_split(episodes_dir)
        recorded = load_episodes_folder(episodes_dir, rows_here, split or "all")
        recorded_sets = tuple(dict.fromkeys(r[0] for r in recorded))
    elif data_dir is not None:
        rows = (split_rows if split_rows is not None else read_split()) if split else []
        if split:
            check_split_selects(rows, split, tuple(DATASETS))
            check_sample_split(data_dir, rows)
        unit_of = {r.episode_id: r.vehicle_id for r in rows}
        for ds in DATASETS:
            ids = None if split is None else [r.episode_id for r in rows
                                               if r.dataset == ds and r.split == split]  # fmt: skip
            recorded += [(ds, eid, d, unit_of.get(eid, eid))
                         for eid, d in load_recorded(data_dir, ds, ids)]  # fmt: skip
        recorded_sets = tuple(DATASETS)
    t_obs = check_observed_times(t_obs, [r[2] for r in recorded], simulated=n_vehicles > 0)
    t0 = time.perf_counter()
    vehicles = draw_simulated(n_vehicles, seed) if n_vehicles > 0 else []
    seconds["draw_scenarios"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim = parallel_map(
        _simulated_task,
        [(v, library, t_obs) for v in vehicles],
        workers,
        stage("simulated", len(vehicles)),
    )
    seconds["simulated"] = time.perf_counter() - t0
    records: list[PredictionRecord] = []
    skipped: list[SkippedPrediction] = []
    tracks: list[TrackingRecord] = []
    demos: dict[str, Demonstration] = {}
    for v, (demo, recs, skips, track) in zip(vehicles, sim, strict=True):
        records += recs
        skipped += skips
        if track is not None:
            tracks.append(track)
        if demo is not None:
            demos[v.vehicle_id] = demo
    n_geometries: dict[str, int] = {}
    if recorded:
        t0 = time.perf_counter()
        # one geometry's episodes in one worker: its solver is built (or loaded) once there
        order = sorted(range(len(recorded)), key=lambda i: _geometry(recorded[i][2]))
        post = None if posterior is None else str(posterior)
        out = parallel_map(
            _recorded_task,
            [(*recorded[i], library, t_obs, physics, joint_physics, post) for i in order],
            workers,
            stage("recorded", len(recorded)),
        )
        seconds["recorded"] = time.perf_counter() - t0
        for recs, skips in out:
            records += recs
            skipped += skips
        for ds in recorded_sets:
            n_geometries[ds] = len({_geometry(r[2]) for r in recorded if r[0] == ds})
        demos |= {r[1]: r[2] for r in recorded}
    summaries = summarise_records(records)
    recorded_records = [r for r in records if r.set != "simulated"]
    calibration_rows = (
        None
        if calibration is None
        else [r for r in record_rows(calibration) if r["set"] != "simulated"]
    )
    return PredictionStudy(
        seed=seed,
        t_obs=t_obs,
        vehicles=tuple(vehicles),
        records=tuple(records),
        skipped=tuple(skipped),
        summaries=tuple(summaries),
        goals=tuple(goal_checks(summaries)),
        tracks=tuple(tracks),
        tracking=summarise_tracking(tracks),
        recorded_sets=recorded_sets,
        n_geometries=n_geometries,
        seconds=seconds,
        demos=demos,
        split=split,
        physics=physics,
        joint_physics=joint_physics,
        regions=()
        if calibration_rows is None
        else tuple(region_coverage(recorded_records, region_rates(calibration_rows))),
        kind_summaries=tuple(summarise_by_kind(records)),
        ratios=tuple(ratio_stats(records)),
        kind_regions=()
        if calibration_rows is None
        else tuple(kind_region_coverage(recorded_records, kind_region_rates(calibration_rows))),
    )


def example_record(
    study: PredictionStudy, set_name: str = "simulated", t_obs: float = 2.0
) -> PredictionRecord | None:
    """A representative prediction for the figure: the median mode-vs-CV FDE gain.

    Among the records of ``set_name`` at ``t_obs`` (else its first t_obs) with a prediction
    kept, the one whose FDE_cv − FDE_mode is the median (not the best case).
    """
    recs = [r for r in study.records if r.set == set_name and r.prediction is not None]
    times = sorted({r.t_obs for r in recs})
    if not times:
        return None
    at = [r for r in recs if r.t_obs == (t_obs if t_obs in times else times[0])]
    at = [r for r in at if "mode" in r.fde_m and "cv" in r.fde_m]
    if not at:
        return None
    at.sort(key=lambda r: r.fde_m["cv"] - r.fde_m["mode"])
    return at[(len(at) - 1) // 2]
