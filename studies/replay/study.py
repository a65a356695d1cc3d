"""Recorded scenes replayed reactively: collisions and speeds against the log (DESIGN §24).

Each episode is replayed once in ``drivestyle/Recorded-v0``
(:class:`~drivestyle.envs.recorded_scene.RecordedSceneEnv`) from its default start (the end
of its observed part) to the end of its log, every vehicle reactive: the surrounding
vehicles are ``others="idm"`` (the IDM along x, their log's lateral path), the EV is the
agent and drives the same IDM through the bicycle, steering towards its log's lateral path
(:func:`~drivestyle.envs.recorded_scene.drive_idm`) — so that no vehicle replays its log and
every reaction counts. The env ends the replay early if the EV collides or leaves the road.

Per episode the study reports:

- **Collisions**: every pair of vehicles in the scene whose rectangles (the scenario's
  length × width, the env's collision rule: :func:`~drivestyle.envs.safety.vehicles_overlap`)
  overlap at some sample, with the first time and the number of samples, in the replay and
  in the log itself from the start to its end (the recorded states, present by the same
  rule; a replay the EV's collision ended early is compared with the whole log); a *new*
  collision is a replayed pair the log never has.
- **Speeds**: each vehicle's replayed speed range against its recorded one (min/max over
  its recorded samples from the start to the log's end); within when the replayed range
  stays inside the recorded one widened by :data:`SPEED_TOLERANCE_MPS` on both sides.

``others="style"`` (``replay-recorded --others style --posterior FILE``) replays the same
scenes with every vehicle, the EV included, driving its own style identified from the
samples up to the start (:func:`~drivestyle.prediction.scene_drivers.style_drivers`: the
joint prediction's point driver, re-planning at every step against the current states of
the vehicles ahead and, changing lane, the target lane's, as the joint prediction's
rollout; ``attend`` chooses others; the EV through
:func:`~drivestyle.envs.recorded_scene.drive_style`); each episode also counts the plans and
the failed ones (the previous plan's next input or braking).

The IDM's parameters (:func:`idm_parameters`): ``calibrated`` (default) are the physics
baseline's, calibrated on the benchmark's train split (the shipped
``drivestyle/data/benchmark_physics.json``): recorded drivers' car following, short time gaps
and jam distances of congested NGSIM and the CATS track included; ``highway-env`` are the
traffic env's (s0 = 10 m, T = 1.5 s, a = 3 m/s²), which put a follower of a recorded
platoon far inside its desired gap from the first step, so that it brakes to a stop.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.recorded_scene import RecordedSceneEnv, drive_idm, drive_style
from drivestyle.envs.rollout import run_episode
from drivestyle.envs.safety import vehicles_overlap
from drivestyle.envs.scene_log import scene_log
from drivestyle.envs.traffic import IDM, IDMParams
from drivestyle.irl.amortized.identify import open_posterior
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.prediction.scene_drivers import ATTEND, StyleDriver, style_drivers
from drivestyle.recorded.benchmark import (
    SplitRow,
    check_sample_split,
    check_split_selects,
    load_recorded,
    read_split,
)
from drivestyle.recorded.episode_files import read_episodes
from drivestyle.recorded.real_data import DATASETS

if TYPE_CHECKING:
    from drivestyle.irl.amortized.estimator import NeuralPosterior

__all__ = [
    "IDM_CHOICES",
    "OTHERS_CHOICES",
    "SPEED_TOLERANCE_MPS",
    "Collision",
    "EpisodeReplay",
    "ReplayStudy",
    "VehicleSpeeds",
    "collisions",
    "folder_episodes",
    "idm_parameters",
    "replay_episode",
    "replay_recorded",
    "split_episodes",
]

SPEED_TOLERANCE_MPS = 0.5
"""[m/s] How far a replayed speed may leave the recorded range and still count as within it
(the speed noise of a recorded track after the extraction's splines is a few tenths)."""
IDM_CHOICES = ("calibrated", "highway-env")
"""The IDM parameters a replay can use (:func:`idm_parameters`)."""
OTHERS_CHOICES = ("idm", "style")
"""How the replayed vehicles drive (module docstring)."""


def idm_parameters(choice: str, physics: PhysicsParams) -> tuple[IDMParams, float]:
    """The IDM's parameters and ρ (v0 = ρ · v90) of a replay.

    Args:
        choice: ``calibrated`` (``physics``'s a_max, b, s0, T and ρ) or ``highway-env``
            (:data:`~drivestyle.envs.traffic.IDM`, ρ = 1).
        physics: the calibrated physics baseline.

    Raises:
        ValueError: an unknown choice.
    """
    if choice == "highway-env":
        return IDM, 1.0
    if choice != "calibrated":
        raise ValueError(f"unknown IDM parameters {choice!r}; choose one of {IDM_CHOICES}")
    idm = IDMParams(
        a_max=physics.accel_mps2,
        b=physics.decel_mps2,
        s0=physics.min_gap_m,
        time_gap=physics.time_gap_s,
    )
    return idm, physics.v0_factor


@dataclass(frozen=True)
class Collision:
    """Two vehicles whose rectangles overlap (vehicle 0 the EV, j ≥ 1 ``demo.vehicles``)."""

    a: int
    b: int
    first_s: float
    """The first overlapping sample's time since the replay's start [s]."""
    samples: int
    """How many samples they overlap."""


def collisions(
    states: np.ndarray, present: np.ndarray, length: float, width: float, dt: float
) -> tuple[Collision, ...]:
    """Every pair of present vehicles whose rectangles overlap at some sample.

    Args:
        states: [x, y, φ, v] per sample and vehicle, shape (T, N, 4).
        present: whether each vehicle is in the scene, shape (T, N).
        length: the rectangles' length [m].
        width: their width [m].
        dt: T_s [s].

    Returns:
        One :class:`Collision` per overlapping pair, ordered by (a, b).
    """
    T, N = present.shape
    found: dict[tuple[int, int], list[int]] = {}
    pairs = [(a, b) for a in range(N) for b in range(a + 1, N)]
    if not pairs:
        return ()
    ia, ib = np.array(pairs).T
    size = np.tile([length, width], (len(pairs), 1))
    for k in range(T):
        both = present[k, ia] & present[k, ib]
        if not both.any():
            continue
        hit = np.zeros(len(pairs), bool)
        hit[both] = vehicles_overlap(
            states[k, ia[both]], states[k, ib[both]], size[both], size[both]
        )
        for p in np.flatnonzero(hit):
            found.setdefault(pairs[p], []).append(k)
    return tuple(
        Collision(int(a), int(b), float(ks[0] * dt), len(ks))
        for (a, b), ks in sorted(found.items())
    )


@dataclass(frozen=True)
class VehicleSpeeds:
    """One vehicle's replayed speed range against its recorded one [m/s]."""

    vehicle: int
    recorded_min: float | None
    """None: no recorded sample in the window (a vehicle continued at constant velocity)."""
    recorded_max: float | None
    replayed_min: float
    replayed_max: float
    within: bool | None
    """The replayed range inside the recorded one ± :data:`SPEED_TOLERANCE_MPS`; None
    without a recorded range."""

    @property
    def excess(self) -> float | None:
        """How far the replayed range leaves the recorded one [m/s] (0 inside it)."""
        if self.recorded_min is None or self.recorded_max is None:
            return None
        return max(
            0.0, self.recorded_min - self.replayed_min, self.replayed_max - self.recorded_max
        )


@dataclass(frozen=True)
class EpisodeReplay:
    """One recorded episode replayed with every vehicle reactive (module docstring)."""

    dataset: str
    episode_id: str
    start: int
    """The replay's first sample."""
    steps: int
    """Steps replayed."""
    log_steps: int
    """Steps from the start to the log's end."""
    ended: str
    """``log end``, ``EV collision`` or ``EV off road``."""
    vehicles: int
    """Vehicles in the scene at some sample of the replay (the EV included)."""
    log_collisions: tuple[Collision, ...]
    replay_collisions: tuple[Collision, ...]
    speeds: tuple[VehicleSpeeds, ...]
    ev_lateral_m: float
    """The EV's largest lateral distance from its log [m] (its IDM steers along it within
    the steering bound)."""
    seconds: float
    plans: int | None = None
    """The style drivers' plans (None: IDM vehicles)."""
    failed_plans: int | None = None
    """Those that failed (the previous plan's next input or braking applied)."""

    @property
    def new_collisions(self) -> tuple[Collision, ...]:
        """Replayed collisions of pairs that never overlap in the log."""
        logged = {(c.a, c.b) for c in self.log_collisions}
        return tuple(c for c in self.replay_collisions if (c.a, c.b) not in logged)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            **asdict(self),
            "speeds": [asdict(s) | {"excess": s.excess} for s in self.speeds],
            "new_collisions": [asdict(c) for c in self.new_collisions],
        }


@functools.lru_cache(maxsize=2)
def _posterior(path: str) -> NeuralPosterior:
    """The amortized posterior of ``path``, loaded once per worker process."""
    return open_posterior(path)


def replay_episode(
    dataset: str,
    episode_id: str,
    demo: Demonstration,
    idm: IDMParams,
    v0_factor: float,
    tolerance: float = SPEED_TOLERANCE_MPS,
    posterior: str | None = None,
    attend: str = "ahead",
) -> EpisodeReplay:
    """Replay one episode with every vehicle reactive and compare it with its log.

    Args:
        dataset: its set (``ngsim``, ``cats`` or ``episodes``).
        episode_id: its id.
        demo: the recorded episode.
        idm: the IDM's parameters (IDM vehicles).
        v0_factor: ρ of the desired speeds (IDM vehicles).
        tolerance: :data:`SPEED_TOLERANCE_MPS`.
        posterior: the amortized posterior's file: every vehicle drives its identified
            style instead of the IDM (module docstring).
        attend: the vehicles each style driver plans around
            (:data:`~drivestyle.prediction.scene_drivers.ATTEND`).
    """
    t0 = time.perf_counter()
    drivers: dict[int, StyleDriver] = {}
    if posterior is None:
        env = RecordedSceneEnv(demo, agent=0, others="idm", idm=idm, v0_factor=v0_factor)
        episode = run_episode(env, drive_idm)
    else:
        start = scene_log(demo).default_start
        drivers = style_drivers(_posterior(posterior), demo, start, attend=attend)
        env = RecordedSceneEnv(demo, agent=0, others="style", start=start, drivers=drivers)
        episode = run_episode(env, drive_style)
    env.close()
    log, start = env.log, env.start
    replay = np.stack([episode.reset_info["states"], *(i["states"] for i in episode.infos)])
    shown = np.stack([episode.reset_info["present"], *(i["present"] for i in episode.infos)])
    window = slice(start, None)  # the log from the start to its end, whatever the replay's
    recorded, present = log.states[window], log.present[window]
    sc = log.scenario
    last = episode.infos[-1] if episode.infos else episode.reset_info
    ended = (
        "EV collision" if last["collision"] else "EV off road" if last["off_road"] else "log end"
    )
    speeds = []
    for j in np.flatnonzero(shown.any(axis=0)):
        rec = recorded[log.observed[window][:, j], j, 3]
        rep = replay[shown[:, j], j, 3]
        lo = hi = None
        within = None
        if rec.size:
            lo, hi = float(rec.min()), float(rec.max())
            within = bool(rep.min() >= lo - tolerance and rep.max() <= hi + tolerance)
        speeds.append(VehicleSpeeds(int(j), lo, hi, float(rep.min()), float(rep.max()), within))
    return EpisodeReplay(
        dataset=dataset,
        episode_id=episode_id,
        start=start,
        steps=episode.n_steps,
        log_steps=log.n - 1 - start,
        ended=ended,
        vehicles=int(shown.any(axis=0).sum()),
        log_collisions=collisions(recorded, present, sc.vehicle_length, sc.vehicle_width, sc.dt),
        replay_collisions=collisions(replay, shown, sc.vehicle_length, sc.vehicle_width, sc.dt),
        speeds=tuple(speeds),
        ev_lateral_m=float(np.abs(replay[:, 0, 1] - recorded[: len(replay), 0, 1]).max()),
        seconds=time.perf_counter() - t0,
        plans=sum(d.plans for d in drivers.values()) if posterior is not None else None,
        failed_plans=sum(d.failures for d in drivers.values()) if posterior is not None else None,
    )


@dataclass(frozen=True)
class ReplayStudy:
    """Every episode's replay and the parameters it ran with."""

    replays: tuple[EpisodeReplay, ...]
    source: str
    """``split <name> of <data dir>`` or ``episodes <folder>``."""
    idm_choice: str
    idm: IDMParams
    v0_factor: float
    tolerance: float
    seconds: float
    others: str = "idm"
    """``idm`` or ``style`` (:data:`OTHERS_CHOICES`)."""
    posterior: str | None = None
    """The amortized posterior's file of ``style``."""
    attend: str | None = None
    """The vehicles each style driver plans around (``style``)."""

    def summary(self) -> dict[str, Any]:
        """Counts over every episode: collisions (log, replay, new) and speeds within range."""
        speeds = [s for r in self.replays for s in r.speeds if s.within is not None]
        within = sum(bool(s.within) for s in speeds)
        return {
            "episodes": len(self.replays),
            "vehicles": sum(r.vehicles for r in self.replays),
            "ended_early": sum(r.ended != "log end" for r in self.replays),
            "log_collision_pairs": sum(len(r.log_collisions) for r in self.replays),
            "replay_collision_pairs": sum(len(r.replay_collisions) for r in self.replays),
            "new_collision_pairs": sum(len(r.new_collisions) for r in self.replays),
            "episodes_with_new_collisions": sum(bool(r.new_collisions) for r in self.replays),
            "vehicles_with_recorded_speeds": len(speeds),
            "speeds_within": within,
            "speeds_within_share": within / len(speeds) if speeds else None,
            "speed_excess_max_mps": max((s.excess or 0.0 for s in speeds), default=None),
            "ev_lateral_max_m": max((r.ev_lateral_m for r in self.replays), default=None),
            "plans": None if self.others != "style" else sum(r.plans or 0 for r in self.replays),
            "failed_plans": None
            if self.others != "style"
            else sum(r.failed_plans or 0 for r in self.replays),
        }

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``replay.json``)."""
        return {
            "source": self.source,
            "others": self.others,
            "posterior": self.posterior,
            "attend": self.attend,
            "idm_choice": self.idm_choice,
            "idm": asdict(self.idm),
            "v0_factor": self.v0_factor,
            "speed_tolerance_mps": self.tolerance,
            "summary": self.summary(),
            "episodes": [r.to_json() for r in self.replays],
            "seconds": self.seconds,
        }


Episodes = Sequence[tuple[str, str, Demonstration]]
"""(set, episode id, demonstration) per episode."""


def split_episodes(
    data_dir: str | Path, split: str, rows: Sequence[SplitRow] | None = None
) -> list[tuple[str, str, Demonstration]]:
    """The shipped samples' episodes of a benchmark split.

    Args:
        data_dir: the folder holding the datasets.
        split: a name of :data:`~drivestyle.recorded.benchmark.SPLITS`.
        rows: the split (default: the shipped
            :data:`~drivestyle.recorded.benchmark.SPLIT_FILE`'s).

    Raises:
        ValueError: an unknown split, a split the samples do not hold.
    """
    rows = read_split() if rows is None else rows
    check_split_selects(rows, split, tuple(DATASETS))
    check_sample_split(data_dir, rows)
    out = []
    for ds in DATASETS:
        ids = [r.episode_id for r in rows if r.dataset == ds and r.split == split]
        out += [(ds, eid, demo) for eid, demo in load_recorded(data_dir, ds, ids)]
    return out


def folder_episodes(folder: str | Path) -> list[tuple[str, str, Demonstration]]:
    """Every usable episode of a folder written by ``drivestyle extract-episodes``.

    Raises:
        FileNotFoundError: no such folder or no ``episodes.csv``.
        ValueError: a malformed folder, or one without a usable episode.
    """
    found = [("episodes", eid, demo) for eid, _, demo in read_episodes(folder)]
    if not found:
        raise ValueError(f"{folder}: no usable episode (episodes.csv lists none)")
    return found


def replay_recorded(
    episodes: Episodes,
    source: str,
    idm_choice: str,
    physics: PhysicsParams,
    workers: int = 1,
    tolerance: float = SPEED_TOLERANCE_MPS,
    progress: Callable[[], None] | None = None,
    posterior: str | Path | None = None,
    attend: str = "ahead",
) -> ReplayStudy:
    """Replay every episode with every vehicle reactive (module docstring).

    Args:
        episodes: (set, episode id, demonstration) per episode.
        source: where they come from (for the report).
        idm_choice: one of :data:`IDM_CHOICES`.
        physics: the calibrated physics baseline (``calibrated``).
        workers: worker processes.
        tolerance: :data:`SPEED_TOLERANCE_MPS`.
        progress: called as each episode finishes.
        posterior: the amortized posterior's file: every vehicle drives its identified
            style (``others="style"``); None: the IDM.
        attend: the vehicles each style driver plans around
            (:data:`~drivestyle.prediction.scene_drivers.ATTEND`).

    Raises:
        ValueError: no episode, an unknown ``idm_choice`` or ``attend``.
    """
    if not episodes:
        raise ValueError(f"{source}: no episode to replay")
    idm, v0_factor = idm_parameters(idm_choice, physics)
    if attend not in ATTEND:
        raise ValueError(f"attend must be one of {ATTEND}, got {attend!r}")
    post = None if posterior is None else str(Path(posterior).resolve())
    t0 = time.perf_counter()
    replays = parallel_map(
        replay_episode,
        [(ds, eid, demo, idm, v0_factor, tolerance, post, attend) for ds, eid, demo in episodes],
        workers,
        on_result=None if progress is None else lambda *_: progress(),
    )
    return ReplayStudy(
        tuple(replays), source, idm_choice, idm, v0_factor, tolerance, time.perf_counter() - t0,
        others="idm" if post is None else "style", posterior=post,
        attend=None if post is None else attend,
    )  # fmt: skip
