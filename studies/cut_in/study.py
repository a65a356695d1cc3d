"""The cut-in study: an SMPC ego that predicts the lane changer by CV, its style, or the truth.

Each scene of ``drivestyle/CutIn-v0`` (:mod:`drivestyle.envs.cut_in`; the lane changer is
SMPC(p), p drawn per scene) is driven three times from the same seed, the ego planned by
:class:`~drivestyle.agents.aware_planner.AwareSMPC` with each predictor of
:data:`~drivestyle.agents.aware_planner.PREDICTORS`: ``cv`` (today's SMPC), ``style`` (the
style identified online) and ``oracle`` (the cutter's true model). Per run: collision,
least ellipse margin d = s_e − 1, time inside the safety ellipse (s_e < 1), the ego's
hardest braking and largest jerk, the time it brakes harder than :data:`HARD_BRAKING`,
its progress, and the planning time per step (DESIGN §17).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.agents.aware_planner import PREDICTORS, AwareSMPC
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.cut_in import CutInEnv
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges
from drivestyle.irl.driver.driver_style import expert_style
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.planning.description import SMPCConfig
from drivestyle.prediction.online import (
    ConstantVelocityPredictor,
    OnlinePredictor,
    OraclePredictor,
    StylePredictor,
)

__all__ = [
    "CUT_IN_RANGES",
    "HARD_BRAKING",
    "ORACLE_TOLERANCE",
    "MethodSummary",
    "PlanningStudy",
    "SceneRun",
    "cut_in_study",
    "planning_goals",
    "predictor_for",
    "run_scene",
    "summarise_runs",
]

HARD_BRAKING = 3.0
"""Deceleration counted as hard braking [m/s²] (comfort limit of ACC systems, ISO 15622)."""

CUT_IN_RANGES = ScenarioRanges(
    ev_speed=(20.0, 26.0),
    tv_speed=(26.0, 32.0),
    tv_gap=(-45.0, -20.0),
    tv_lanes=(1,),
    base=ScenarioConfig(horizon_s=8.0),
)
"""The study's scenes (cutter's frame): the cutter in lane 0 at 20–26 m/s, the ego in lane 1
20–45 m behind at 26–32 m/s and closing in. Closer starts (the env's default family) leave
no choice but full braking at t = 0, whatever the prediction."""


@dataclass(frozen=True)
class SceneRun:
    """One scene driven by the ego with one predictor."""

    seed: int
    method: str
    cutter_risk: float
    collision: bool
    min_d: float
    """Least nominal ellipse margin s_e − 1 between ego and cutter."""
    min_distance_m: float
    """Least centre distance between ego and cutter [m]."""
    time_in_ellipse_s: float
    """Time with s_e < 1 [s]."""
    hardest_braking: float
    """max(−a) of the ego [m/s²] (0 if it never brakes)."""
    max_jerk: float
    """max |Δa| / T_s of the ego [m/s³]."""
    hard_braking_s: float
    """Time the ego decelerates harder than :data:`HARD_BRAKING` [s]."""
    progress_m: float
    """Distance the ego travelled [m]."""
    cut_in: bool
    """The cutter ended in the ego's lane ahead of it."""
    plan_ms: float
    """Median wall time of the ego's step (prediction and solve) [ms]."""
    accel: tuple[float, ...] = field(default=(), repr=False)
    """The ego's acceleration per step [m/s²]."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "accel"} | {
            "accel": list(self.accel)
        }


def predictor_for(method: str, library: DriverLibrary) -> OnlinePredictor:
    """The ego's predictor named ``method`` (:data:`PREDICTORS`).

    Raises:
        ValueError: an unknown name.
    """
    if method == "cv":
        return ConstantVelocityPredictor()
    if method == "style":
        return StylePredictor(library)
    if method == "oracle":
        return OraclePredictor(expert_style(SMPCConfig()))
    raise ValueError(f"unknown predictor {method!r}; known: {list(PREDICTORS)}")


def run_scene(
    env: CutInEnv,
    ego: AwareSMPC,
    seed: int,
    method: str,
    frame: Callable[[np.ndarray], None] | None = None,
) -> SceneRun:
    """Drive one scene (``env.reset(seed)``) with the ego and score it.

    Args:
        env: the cut-in env.
        ego: the ego planner (its predictor named ``method``).
        seed: the scene's seed (scenario and cutter risk).
        method: the predictor's name (recorded).
        frame: called with each rendered frame (videos; needs an rgb_array env).

    Returns:
        The :class:`SceneRun`.
    """
    obs, info = env.reset(seed=seed)
    sc: ScenarioConfig = info["scenario"]
    risk = float(info["cutter_risk"])
    ego.start(sc, risk)
    x0 = float(obs[0])
    acc, s_e, ms = [], [], []
    dist = [float(np.hypot(*(obs[4:6] - obs[0:2])))]
    collision = False

    def capture() -> None:
        image = env.render() if frame is not None else None
        if frame is not None and image is not None:
            frame(image)

    capture()
    while True:
        t0 = time.perf_counter()
        action = ego.act(obs)
        ms.append((time.perf_counter() - t0) * 1e3)
        obs, _, terminated, truncated, info = env.step(action)
        acc.append(float(info["action"][0]))
        s_e.append(float(info["s_e"]))
        dist.append(float(np.hypot(*(obs[4:6] - obs[0:2]))))
        collision |= bool(info["collision"])
        capture()
        if terminated or truncated:
            break
    a = np.array(acc)
    dt = sc.dt
    ego_lane = sc.tv_lane
    cutter = info["cutter"]
    lane = int(np.clip(cutter[1] // sc.lane_width, 0, sc.n_lanes - 1))
    return SceneRun(
        seed=seed,
        method=method,
        cutter_risk=risk,
        collision=collision,
        min_d=float(np.min(s_e) - 1.0),
        min_distance_m=float(min(dist)),
        time_in_ellipse_s=float(np.sum(np.array(s_e) < 1.0) * dt),
        hardest_braking=float(max(0.0, -a.min())),
        max_jerk=float(np.max(np.abs(np.diff(a))) / dt) if a.size > 1 else 0.0,
        hard_braking_s=float(np.sum(a < -HARD_BRAKING) * dt),
        progress_m=float(obs[0] - x0),
        cut_in=bool(lane == ego_lane and cutter[0] > obs[0]),
        plan_ms=float(np.median(ms)),
        accel=tuple(a.round(4).tolist()),
    )


# ------------------------------------------------------------------ workers
_WORKER: dict[str, Any] = {}


def _init_worker(library_json: dict[str, Any], ranges: ScenarioRanges | None) -> None:
    library = DriverLibrary.from_json(library_json)
    env = CutInEnv(randomize=ranges or CUT_IN_RANGES)
    _WORKER.update(env=env, egos={m: AwareSMPC(predictor_for(m, library)) for m in PREDICTORS})


def _scene_task(seed: int) -> list[SceneRun]:
    env, egos = _WORKER["env"], _WORKER["egos"]
    return [run_scene(env, egos[m], seed, m) for m in PREDICTORS]


# ------------------------------------------------------------------ summary
@dataclass(frozen=True)
class MethodSummary:
    """One predictor over every scene."""

    method: str
    n: int
    collisions: int
    min_d_mean: float
    min_d_min: float
    min_distance_m_mean: float
    min_distance_m_min: float
    time_in_ellipse_s_mean: float
    hardest_braking_mean: float
    hardest_braking_p90: float
    hard_braking_s_mean: float
    scenes_with_hard_braking: int
    max_jerk_mean: float
    progress_m_mean: float
    plan_ms_median: float

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def summarise_runs(runs: Sequence[SceneRun], method: str) -> MethodSummary:
    """The :class:`MethodSummary` of one predictor's runs."""
    rs = [r for r in runs if r.method == method]
    if not rs:
        raise ValueError(f"no runs of {method!r}")

    def col(name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in rs], dtype=float)

    brake = col("hardest_braking")
    return MethodSummary(
        method=method,
        n=len(rs),
        collisions=int(col("collision").sum()),
        min_d_mean=float(col("min_d").mean()),
        min_d_min=float(col("min_d").min()),
        min_distance_m_mean=float(col("min_distance_m").mean()),
        min_distance_m_min=float(col("min_distance_m").min()),
        time_in_ellipse_s_mean=float(col("time_in_ellipse_s").mean()),
        hardest_braking_mean=float(brake.mean()),
        hardest_braking_p90=float(np.percentile(brake, 90)),
        hard_braking_s_mean=float(col("hard_braking_s").mean()),
        scenes_with_hard_braking=int(np.sum(brake > HARD_BRAKING)),
        max_jerk_mean=float(col("max_jerk").mean()),
        progress_m_mean=float(col("progress_m").mean()),
        plan_ms_median=float(np.median(col("plan_ms"))),
    )


@dataclass(frozen=True)
class PlanningStudy:
    """The cut-in comparison (:func:`cut_in_study`)."""

    seeds: tuple[int, ...]
    runs: tuple[SceneRun, ...]
    summaries: tuple[MethodSummary, ...]
    goals: dict[str, bool]
    """The issue's goals for the style-aware ego (:func:`planning_goals`)."""

    def summary(self, method: str) -> MethodSummary:
        """One predictor's summary."""
        return next(s for s in self.summaries if s.method == method)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``planning.json``)."""
        return {
            "seeds": list(self.seeds),
            "n_scenes": len(self.seeds),
            "hard_braking_threshold": HARD_BRAKING,
            "summaries": {s.method: s.to_json() for s in self.summaries},
            "goals": dict(self.goals),
            "runs": [r.to_json() for r in self.runs],
        }


ORACLE_TOLERANCE = 0.25
""""Close to the oracle": the style-aware ego's mean hardest braking within this fraction of
the oracle's (the prediction study's tolerance)."""


def planning_goals(summaries: Sequence[MethodSummary]) -> dict[str, bool]:
    """The issue's goals evaluated on the summaries (:attr:`PlanningStudy.goals`).

    The style-aware ego: no collision; mean hardest braking at least 30 % below the CV
    ego's; mean least centre distance and mean least ellipse margin not below the CV ego's;
    mean hardest braking within :data:`ORACLE_TOLERANCE` of the oracle ego's.
    """
    by = {s.method: s for s in summaries}
    cv, style, oracle = by["cv"], by["style"], by["oracle"]
    close = abs(style.hardest_braking_mean - oracle.hardest_braking_mean) <= (
        ORACLE_TOLERANCE * max(oracle.hardest_braking_mean, 1e-9)
    )
    return {
        "no_collision": style.collisions == 0,
        "braking_30pct_below_cv": style.hardest_braking_mean <= 0.7 * cv.hardest_braking_mean,
        "min_distance_not_below_cv": style.min_distance_m_mean >= cv.min_distance_m_mean,
        "min_margin_not_below_cv": style.min_d_mean >= cv.min_d_mean,
        "braking_close_to_oracle": bool(close),
    }


def cut_in_study(
    library: DriverLibrary,
    n_scenes: int,
    seed: int,
    workers: int = 1,
    ranges: ScenarioRanges | None = None,
    on_result: Callable[[int, Any], None] | None = None,
) -> PlanningStudy:
    """Drive ``n_scenes`` scenes with each predictor (module docstring).

    Args:
        library: the driver library the style predictor identifies with.
        n_scenes: scenes (each with its own scenario and cutter risk).
        seed: the first scene's seed (scenes use seed, seed + 1, …).
        workers: processes.
        ranges: the scene family (default :data:`CUT_IN_RANGES`).
        on_result: progress callback (scene index, its runs).

    Returns:
        The :class:`PlanningStudy`.

    Raises:
        ValueError: n_scenes < 1.
    """
    if n_scenes < 1:
        raise ValueError(f"need at least one scene, got {n_scenes}")
    seeds = tuple(range(seed, seed + n_scenes))
    per_scene = parallel_map(
        _scene_task, [(s,) for s in seeds], workers, on_result=on_result,
        initializer=_init_worker, initargs=(library.to_json(), ranges),
    )  # fmt: skip
    runs = tuple(r for scene in per_scene for r in scene)
    summaries = tuple(summarise_runs(runs, m) for m in PREDICTORS)
    return PlanningStudy(seeds, runs, summaries, planning_goals(summaries))
