r"""Drivers outside the style class: do identification and prediction still order them?

DESIGN §18 (the style class for real traffic).

Every driver the library was built from is a member of the style class (SMPC(p) with the
paper's horizon, weights and TV uncertainty); this study asks what the identified risk p
and the style's predictions are worth for drivers that are *not*, but whose caution is
known by construction:

- **highway-env drivers** (:data:`HIGHWAY_CLASSES`): IDM for the speed and MOBIL for the
  lane changes, highway-env 1.12's :class:`~highway_env.vehicle.behavior.IDMVehicle` with
  other class constants, simulated together on a straight three-lane road
  (:func:`simulate_highway`) and recorded at :data:`RECORD_HZ` Hz. Their caution order is
  known because every constant that sets how close a driver lets others come moves the
  same way from one class to the next (:class:`DriverClass`): the IDM time gap and
  standstill gap (the gap it keeps), MOBIL's politeness and — the safety criterion — the
  braking it may impose on the new follower (MOBIL's minimum own gain, the motivation to
  change, is the same for all). The recording goes through the project's own extraction
  (:func:`~drivestyle.recorded.episodes.extract_episodes`, the path recorded traffic takes), so
  these lane changes are identified and predicted exactly as NGSIM's are.
- **SMPC drivers of another class** (:data:`SMPC_VARIANTS`): the expert with another
  horizon, another TV-uncertainty model or other cost weights, each at several risks; the
  known caution order is p within a variant.

For each lane change :func:`identify_episode` reports the posterior mean p, its 90 %
interval and the verdict (DESIGN §15, "Verdict"); :func:`order_checks`
compares the known caution rank with the identified p by Spearman's ρ, over the episodes
and over the groups' medians (the issue's goal: ρ ≥ :data:`SPEARMAN_GOAL`).
:func:`predict_episode` predicts each lane change after t_obs ∈ :data:`T_OBS` with every
method of :func:`drivestyle.prediction.methods.predict` except the oracle (the recorded-episode
path, :func:`~drivestyle.recorded.observed.observed_view`, for the highway-env
lane changes: nothing of the future enters); :func:`prediction_summaries` compares the
style methods' FDE with constant velocity's (the goal: ≥ :data:`FDE_GOAL` lower).

Everything is deterministic given the seeds and runs in one process.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstration
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.irl.identification.library import DriverLibrary, LibraryError
from drivestyle.irl.identification.posterior import (
    Identification,
    identify_driver,
    recorded_verdict_label,
)
from drivestyle.planning.description import SMPCConfig
from drivestyle.planning.tv_gaussian import PAPER_TV_UNCERTAINTY, TVUncertainty
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
from drivestyle.recorded.tracks import Carriageway, Recording, Track
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
    "HIGHWAY_CLASSES",
    "HIGHWAY_EXTRACTION",
    "LANE_WIDTH",
    "RECORD_HZ",
    "SIM_HZ",
    "SMPC_VARIANTS",
    "SPEARMAN_GOAL",
    "STYLE_METHODS",
    "T_OBS",
    "DriverClass",
    "EpisodeResult",
    "FdeGoal",
    "GroupSummary",
    "OrderCheck",
    "OutOfClassEpisode",
    "OutOfClassStudy",
    "SMPCVariant",
    "Spawn",
    "StudyConfig",
    "TrafficConfig",
    "draw_traffic",
    "fde_goals",
    "group_summaries",
    "highway_episodes",
    "highway_recording",
    "identify_episode",
    "order_checks",
    "predict_episode",
    "project_frame",
    "run_study",
    "simulate_highway",
    "smpc_episodes",
    "spearman",
    "vehicle_spans",
]

SIM_HZ = 15
"""highway-env's usual simulation frequency (its envs' ``simulation_frequency``) [Hz]."""
RECORD_HZ = 10
"""Recording rate of the simulated traffic (a drone dataset's; highD is 25, NGSIM 10) [Hz]."""
LANE_WIDTH = 4.0
"""highway-env's lane width (``StraightLane.DEFAULT_WIDTH``) [m]."""
T_OBS = (1.0, 2.0, 3.0)
"""Observed times before each prediction [s]."""
SPEARMAN_GOAL = 0.9
"""The issue's goal: Spearman's ρ between the known caution order and the identified p."""
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
class DriverClass:
    """An IDM + MOBIL driver: highway-env's ``IDMVehicle`` with these class constants.

    Along :data:`HIGHWAY_CLASSES` (``caution`` 0 = least cautious) every margin moves the
    same way: a larger IDM time gap and standstill gap (the gap it keeps to a leader, and
    the gap it assumes a new follower wants), a larger politeness (it weighs the braking it
    causes others) and a smaller braking it may impose on the new follower (MOBIL's safety
    criterion: it accepts only roomier gaps). The minimum gain is not a margin and is
    equal in :data:`HIGHWAY_CLASSES`.
    """

    name: str
    caution: int
    """The known rank, 0 = least cautious."""
    time_wanted: float
    """IDM time gap T [s] (``TIME_WANTED``; highway-env's default 1.5)."""
    distance_wanted: float
    """IDM standstill gap s_0 [m] (``DISTANCE_WANTED``; default 10, centre to centre − 5 m)."""
    politeness: float
    """MOBIL politeness (``POLITENESS``; default 0)."""
    min_acc_gain: float
    """MOBIL minimum acceleration gain [m/s²] (``LANE_CHANGE_MIN_ACC_GAIN``; default 0.2)."""
    max_braking_imposed: float
    """MOBIL's safety limit on the new follower's deceleration [m/s²]
    (``LANE_CHANGE_MAX_BRAKING_IMPOSED``; default 2)."""
    share: float = 1.0
    """Relative frequency in the spawned traffic (:func:`draw_traffic`)."""

    def vehicle_type(self) -> type:
        """The ``IDMVehicle`` subclass with these constants (named after the class)."""
        from highway_env.vehicle.behavior import IDMVehicle

        return type(
            f"{self.name.capitalize()}IDMVehicle",
            (IDMVehicle,),
            {
                "TIME_WANTED": self.time_wanted,
                "DISTANCE_WANTED": self.distance_wanted,
                "POLITENESS": self.politeness,
                "LANE_CHANGE_MIN_ACC_GAIN": self.min_acc_gain,
                "LANE_CHANGE_MAX_BRAKING_IMPOSED": self.max_braking_imposed,
            },
        )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


HIGHWAY_CLASSES = (
    DriverClass("reckless", 0, 0.6, 4.0, 0.0, 0.1, 6.0, 1.0),
    DriverClass("assertive", 1, 1.0, 7.0, 0.1, 0.1, 4.0, 1.0),
    DriverClass("moderate", 2, 1.5, 10.0, 0.3, 0.1, 2.5, 2.0),
    DriverClass("cautious", 3, 2.0, 12.0, 0.5, 0.1, 1.5, 3.0),
)
"""Four classes in increasing caution. ``moderate`` is close to highway-env's own
``IDMVehicle`` (T = 1.5 s, s_0 = 10 m; its politeness 0 and braking limit 2 m/s² moved to
0.3 and 2.5 to keep the order strict). The minimum gain is the same for all: it is the
motivation to change, not a safety margin, and equal it keeps the classes' lane-change
rates comparable. The cautious classes change lanes less often, so they are spawned more
often (``share``)."""


@dataclass(frozen=True)
class Spawn:
    """One vehicle placed on the road at t = 0 (highway-env's frame: lane 0 leftmost)."""

    driver: str
    """A :class:`DriverClass` name."""
    lane: int
    """highway-env lane index (0 = the leftmost lane, y grows to the right)."""
    x: float
    """Longitudinal position [m]."""
    speed: float
    """Initial speed [m/s]."""
    target_speed: float
    """IDM desired speed [m/s]."""


@dataclass(frozen=True)
class TrafficConfig:
    """The simulated road and its traffic (:func:`draw_traffic`, :func:`simulate_highway`)."""

    lanes: int = 3
    vehicles_per_lane: int = 5
    spacing_m: float = 60.0
    """Mean distance between consecutive vehicles of a lane at t = 0 (± 30 %) [m]."""
    speed_range: tuple[float, float] = (20.0, 28.0)
    """Initial speeds, uniform [m/s]."""
    target_speed_range: tuple[float, float] = (18.0, 36.0)
    """IDM desired speeds, uniform: their spread is what makes MOBIL change lanes [m/s]."""
    speed_limit: float = 40.0
    """The lanes' speed limit (caps the desired speed) [m/s]."""
    duration_s: float = 60.0
    """Simulated time [s]."""

    def __post_init__(self) -> None:
        if not (isinstance(self.lanes, int) and self.lanes >= 2):
            raise ValueError(f"lanes must be an integer >= 2, got {self.lanes!r}")
        if not (isinstance(self.vehicles_per_lane, int) and self.vehicles_per_lane >= 1):
            raise ValueError(
                f"vehicles_per_lane must be an integer >= 1, got {self.vehicles_per_lane!r}"
            )
        if not self.spacing_m >= 10.0:
            raise ValueError(
                f"spacing_m must be >= 10 m (vehicles 5 m long), got {self.spacing_m!r}"
            )
        for name in ("speed_range", "target_speed_range"):
            lo, hi = getattr(self, name)
            if not (0 < lo <= hi <= self.speed_limit):
                raise ValueError(f"{name} must satisfy 0 < lo <= hi <= speed_limit, got {(lo, hi)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be > 0 s, got {self.duration_s!r}")


def draw_traffic(
    config: TrafficConfig, seed: int, classes: Sequence[DriverClass] = HIGHWAY_CLASSES
) -> list[Spawn]:
    """Vehicles for one run: each lane a queue, every vehicle's class drawn by its ``share``.

    Returns:
        ``lanes × vehicles_per_lane`` spawns (lane by lane, front last), deterministic in
        ``seed``.
    """
    if not classes or min(c.share for c in classes) <= 0:
        raise ValueError("draw_traffic needs at least one class, every share > 0")
    rng = np.random.default_rng(seed)
    n = config.lanes * config.vehicles_per_lane
    share = np.array([c.share for c in classes], float)
    names = [classes[i].name for i in rng.choice(len(classes), n, p=share / share.sum())]
    out: list[Spawn] = []
    for lane in range(config.lanes):
        x = 0.0
        for _ in range(config.vehicles_per_lane):
            x += config.spacing_m * float(rng.uniform(0.7, 1.3))
            out.append(Spawn(names[len(out)], lane, x, float(rng.uniform(*config.speed_range)),
                             float(rng.uniform(*config.target_speed_range))))  # fmt: skip
    return out


def project_frame(
    y: np.ndarray, heading: np.ndarray, lanes: int, lane_width: float = LANE_WIDTH
) -> tuple[np.ndarray, np.ndarray, tuple[float, ...]]:
    """highway-env's lateral axis to the project's road frame (``recorded/tracks.py``).

    highway-env's y grows to the right of travel with lane i's centre at y = i·w (lane 0
    leftmost); the project's grows to the left with lane 0 the rightmost. So
    y' = (lanes − ½)·w − y and φ' = −φ, and the lane lines are at 0, w, …, lanes·w:
    highway-env's lane i becomes the project's lane ``lanes − 1 − i``.

    Args:
        y: highway-env lateral positions, any shape [m].
        heading: highway-env headings, same shape [rad].
        lanes: number of lanes.
        lane_width: w [m].

    Returns:
        (y', φ', markings).
    """
    y_new = (lanes - 0.5) * lane_width - np.asarray(y, float)
    markings = tuple(float(k * lane_width) for k in range(lanes + 1))
    return y_new, -np.asarray(heading, float), markings


def highway_recording(
    samples: dict[str, np.ndarray], lanes: int, name: str = "highway-env"
) -> Recording:
    """Recorded highway-env states as a :class:`~drivestyle.recorded.tracks.Recording`.

    Args:
        samples: vehicle id → rows [t, x, y, v, φ] in highway-env's frame, shape (n, 5)
            [s, m, m, m/s, rad].
        lanes: number of lanes (all 4 m wide, :data:`LANE_WIDTH`).
        name: the carriageway's and the source's name.

    Returns:
        One carriageway in the project's frame (:func:`project_frame`).
    """
    tracks = []
    markings: tuple[float, ...] = ()
    for vid, rows in samples.items():
        y, phi, markings = project_frame(rows[:, 2], rows[:, 4], lanes)
        tracks.append(Track(vid, rows[:, 0], rows[:, 1], y, np.arange(rows.shape[0]),
                            v=rows[:, 3], heading=phi, source=name))  # fmt: skip
    if not markings:
        markings = project_frame(np.zeros(1), np.zeros(1), lanes)[2]
    return Recording(name, (Carriageway(name, markings, tuple(tracks)),),
                     {"format": "highway-env", "rate_hz": RECORD_HZ})  # fmt: skip


def simulate_highway(
    spawns: Sequence[Spawn],
    config: TrafficConfig,
    classes: Sequence[DriverClass] = HIGHWAY_CLASSES,
    name: str = "highway-env",
) -> tuple[Recording, dict[str, str]]:
    """Simulate highway-env traffic and record it at :data:`RECORD_HZ` Hz.

    A straight road of ``config.lanes`` lanes (``RoadNetwork.straight_road_network``), the
    spawned ``IDMVehicle`` subclasses (:meth:`DriverClass.vehicle_type`), stepped with
    ``road.act(); road.step(1 / SIM_HZ)`` — highway-env's own models decide every
    acceleration and lane change (collisions handled by highway-env). Each vehicle's
    [x, y, v, φ] at the 10 Hz times is interpolated linearly between the two 15 Hz
    states around it (every 0.2 s the two grids coincide exactly).

    Args:
        spawns: the vehicles (:func:`draw_traffic`).
        config: the road and the duration.
        classes: the driver classes the spawns name.
        name: the recording's name (episode ids start with it).

    Returns:
        (the recording in the project's frame, vehicle id → driver class name).

    Raises:
        ValueError: a spawn names an unknown class or a lane the road does not have.
    """
    from highway_env.road.road import Road, RoadNetwork

    types = {c.name: c.vehicle_type() for c in classes}
    for s in spawns:
        if s.driver not in types:
            raise ValueError(
                f"spawn names the unknown driver class {s.driver!r}; known: {sorted(types)}"
            )
        if not 0 <= s.lane < config.lanes:
            raise ValueError(f"spawn lane {s.lane} is not a lane of the {config.lanes}-lane road")
    length = max([s.x for s in spawns], default=0.0) + 2.0 * config.speed_limit * config.duration_s
    net = RoadNetwork.straight_road_network(lanes=config.lanes, length=length,
                                            speed_limit=config.speed_limit)  # fmt: skip
    road = Road(network=net, np_random=np.random.RandomState(0), record_history=False)
    vehicles = []
    for s in spawns:
        lane = net.get_lane(("0", "1", s.lane))
        v = types[s.driver](road, lane.position(s.x, 0.0), lane.heading_at(s.x), speed=s.speed,
                            target_speed=s.target_speed)  # fmt: skip
        road.vehicles.append(v)
        vehicles.append(v)
    steps = round(config.duration_s * SIM_HZ)
    states = np.empty((steps + 1, len(vehicles), 4))
    for k in range(steps + 1):
        for j, v in enumerate(vehicles):
            states[k, j] = (v.position[0], v.position[1], v.speed, v.heading)
        if k < steps:
            road.act()
            road.step(1.0 / SIM_HZ)
    t_sim = np.arange(steps + 1) / SIM_HZ
    t_rec = np.round(np.arange(math.floor(config.duration_s * RECORD_HZ + 1e-9) + 1) / RECORD_HZ, 9)
    samples = {}
    for j in range(len(vehicles)):
        cols = [np.interp(t_rec, t_sim, states[:, j, c]) for c in range(4)]
        samples[str(j)] = np.column_stack([t_rec, *cols])
    classes_of = {str(j): s.driver for j, s in enumerate(spawns)}
    return highway_recording(samples, config.lanes, name), classes_of


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
    or ``max_runs`` runs. Each run is :func:`draw_traffic` + :func:`simulate_highway`,
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


# --------------------------------------------------------------------------- identification
@dataclass(frozen=True)
class EpisodeResult:
    """The identification of one out-of-class lane change."""

    family: str
    group: str
    caution: float
    episode_id: str
    risk_mean: float
    """Posterior mean p."""
    risk_interval: tuple[float, float]
    """Central 90 % interval."""
    informative: bool
    out_of_class: bool
    enters_region: bool
    residual_floors: float | None
    """Residual RMS at the best risk in the library's noise floors."""
    min_s_e: float | None
    """Closest approach of another vehicle [ellipse units]."""
    constraint_binds: bool

    @property
    def verdict(self) -> str:
        """The identification's label.

        One of :data:`~drivestyle.irl.identification.posterior.VERDICT_LABELS`, derived from the
        flags by the identification's own rule.
        """
        return recorded_verdict_label(
            self.informative, self.out_of_class, self.constraint_binds, self.enters_region
        )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__} | {"verdict": self.verdict}


def identify_episode(ep: OutOfClassEpisode, library: DriverLibrary) -> EpisodeResult:
    """Identify one lane change's p with the library (whole episode, offline)."""
    ident: Identification = identify_driver(ep.demo, library)
    v = ident.verdict
    assert v is not None
    lo, hi = ident.risk_interval
    return EpisodeResult(
        family=ep.family,
        group=ep.group,
        caution=ep.caution,
        episode_id=ep.episode_id,
        risk_mean=float(ident.risk_interpolated),
        risk_interval=(float(lo), float(hi)),
        informative=v.informative,
        out_of_class=v.out_of_class,
        enters_region=v.enters_region,
        residual_floors=v.floors,
        min_s_e=v.min_s_e,
        constraint_binds=v.constraint_binds,
    )


def spearman(
    known: Sequence[float], identified: Sequence[float]
) -> tuple[float | None, float | None]:
    """Spearman's ρ (ties ranked by their mean rank) and its two-sided p-value.

    Returns:
        (ρ, p-value); (None, None) with fewer than 3 pairs or a constant side.
    """
    from scipy.stats import spearmanr

    a, b = np.asarray(known, float), np.asarray(identified, float)
    if a.size != b.size:
        raise ValueError(f"spearman needs equal lengths, got {a.size} and {b.size}")
    if a.size < 3 or np.ptp(a) == 0 or np.ptp(b) == 0:
        return None, None
    res = spearmanr(a, b)
    return float(res.statistic), float(res.pvalue)


@dataclass(frozen=True)
class GroupSummary:
    """A driver class's (or SMPC variant's at one p) identified risks."""

    family: str
    group: str
    caution: float
    n: int
    risk_median: float | None
    risk_q25: float | None
    risk_q75: float | None
    verdicts: dict[str, int]
    """Verdict → count (:attr:`EpisodeResult.verdict`)."""
    n_binds: int = 0
    """Episodes in which a chance constraint binds (the only ones whose p the data can
    move; the others' posterior is the prior, mean 0.745)."""
    min_s_e_median: float | None = None
    """Median closest approach of another vehicle [ellipse units]: an observed caution that
    needs no model (the reference the identified p is read against)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def group_summaries(results: Sequence[EpisodeResult]) -> list[GroupSummary]:
    """Per (family, group, caution): the identified p's quartiles and the verdicts."""
    keys = sorted({(r.family, r.group, r.caution) for r in results},
                  key=lambda k: (k[0], k[1] if k[0] == "smpc" else "", k[2]))  # fmt: skip
    out = []
    for fam, grp, c in keys:
        rs = [r for r in results if (r.family, r.group, r.caution) == (fam, grp, c)]
        p = np.array([r.risk_mean for r in rs])
        counts: dict[str, int] = {}
        for r in rs:
            counts[r.verdict] = counts.get(r.verdict, 0) + 1
        q25, med, q75 = (float(x) for x in np.quantile(p, [0.25, 0.5, 0.75]))
        s_e = [r.min_s_e for r in rs if r.min_s_e is not None]
        out.append(GroupSummary(fam, grp, c, len(rs), med, q25, q75, counts,
                                sum(r.constraint_binds for r in rs),
                                float(np.median(s_e)) if s_e else None))  # fmt: skip
    return out


@dataclass(frozen=True)
class OrderCheck:
    """Spearman's ρ between known caution and identified p over one family (or variant)."""

    scope: str
    """``highway-env``, ``smpc:<variant>`` or ``smpc`` (every variant pooled)."""
    subset: str
    """``all`` episodes, ``in_region`` (without the ``enters_region`` ones) or ``binds``
    (in region, and a chance constraint binds: the episodes the data can inform)."""
    n: int
    rho_episodes: float | None
    """ρ over the episodes."""
    p_value: float | None
    rho_medians: float | None
    """ρ over the groups' (caution levels') median identified p."""
    met: bool
    """ρ over the episodes ≥ :data:`SPEARMAN_GOAL`."""
    rho_min_s_e: float | None = None
    """Reference: ρ between the known caution and the closest approach min s_e over the
    episodes (an observed caution, no model)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _order(scope: str, subset: str, rs: Sequence[EpisodeResult]) -> OrderCheck:
    rho, pv = spearman([r.caution for r in rs], [r.risk_mean for r in rs])
    levels = sorted({r.caution for r in rs})
    med = [float(np.median([r.risk_mean for r in rs if r.caution == c])) for c in levels]
    rho_m, _ = spearman(levels, med)
    have = [r for r in rs if r.min_s_e is not None]
    rho_s, _ = spearman([r.caution for r in have], [float(r.min_s_e or 0.0) for r in have])
    return OrderCheck(scope, subset, len(rs), rho, pv, rho_m,
                      rho is not None and rho >= SPEARMAN_GOAL, rho_s)  # fmt: skip


def order_checks(results: Sequence[EpisodeResult]) -> list[OrderCheck]:
    """ρ per family, per SMPC variant and SMPC pooled, over each subset of episodes."""
    scopes: list[tuple[str, list[EpisodeResult]]] = []
    hw = [r for r in results if r.family == "highway-env"]
    if hw:
        scopes.append(("highway-env", hw))
    smpc = [r for r in results if r.family == "smpc"]
    for g in dict.fromkeys(r.group for r in smpc):
        scopes.append((f"smpc:{g}", [r for r in smpc if r.group == g]))
    if smpc:
        scopes.append(("smpc", smpc))
    out = []
    for scope, rs in scopes:
        out.append(_order(scope, "all", rs))
        inside = [r for r in rs if not r.enters_region]
        out.append(_order(scope, "in_region", inside))
        out.append(_order(scope, "binds", [r for r in inside if r.constraint_binds]))
    return out


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

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``out_of_class.json``)."""
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
        }


def run_study(
    library: DriverLibrary,
    config: StudyConfig,
    physics: PhysicsParams | None = None,
    progress: Callable[[str, int], Any] | None = None,
    on_plan: Callable[[str, int], Any] | None = None,
) -> OutOfClassStudy:
    """Simulate, extract, identify and predict (module docstring), in this process.

    Args:
        library: the driver library.
        config: the study's sizes and seeds.
        physics: the physics baseline's parameters (None: its defaults).
        progress: called with (stage, 1) after each unit of a stage.
        on_plan: called with (stage, units) before a stage starts.

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
    return OutOfClassStudy(
        config=config,
        results=tuple(results),
        groups=tuple(group_summaries(results)),
        orders=tuple(order_checks(results)),
        records=tuple(records),
        summaries=tuple(summaries),
        goals=tuple(fde_goals(summaries)),
        skipped=tuple(skipped),
        highway_facts=facts,
        seconds=seconds,
    )
