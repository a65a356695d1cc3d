"""The physics predictors calibrated on the benchmark's train split.

:func:`calibrate_on_split` takes the train split's recorded episodes (the shipped samples', or
a folder's of extracted episodes: :func:`train_episodes`, whatever episodes the split's train
part holds), sees each after every t_obs through the no-leak view (:func:`physics_cases`)
and fits the physics baseline on them
(:func:`~drivestyle.prediction.physics_calibration.calibrate_physics`); the shipped result is
:data:`~drivestyle.prediction.physics_calibration.PHYSICS_FILE`.
:func:`calibrate_joint_on_split` does the same for the joint physics baseline
(:func:`joint_physics_cases`: every observed vehicle's samples 0 … k;
:func:`~drivestyle.prediction.joint_physics_calibration.calibrate_joint_physics`), shipped as
:data:`~drivestyle.prediction.joint_physics_calibration.JOINT_PHYSICS_FILE`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from drivestyle.envs.demonstration import Demonstration
from drivestyle.prediction.joint_physics_calibration import (
    JointPhysicsCalibration,
    JointPhysicsCase,
    calibrate_joint_physics,
)
from drivestyle.prediction.physics_calibration import (
    PhysicsCalibration,
    PhysicsCase,
    calibrate_physics,
)
from drivestyle.recorded.benchmark import (
    DEFAULT_DATA_DIR,
    SplitRow,
    check_sample_split,
    check_split_selects,
    episodes_split,
    load_episodes_folder,
    load_recorded,
    read_split,
)
from drivestyle.recorded.observed import observed_view
from drivestyle.recorded.real_data import DATASETS
from drivestyle.studies.prediction.study import T_OBS

__all__ = [
    "calibrate_joint_on_split",
    "calibrate_on_split",
    "joint_physics_cases",
    "physics_cases",
    "train_episodes",
]


def physics_cases(
    recorded: Sequence[tuple[str, Demonstration]], t_obs: Sequence[float] = T_OBS
) -> list[PhysicsCase]:
    """The physics calibration's cases: each episode at each t_obs, as :func:`observed_view`.

    Episodes too short for a t_obs are left out.
    """
    cases = []
    for _, demo in recorded:
        dt = float(demo.t[1] - demo.t[0])
        for t in t_obs:
            k = round(t / dt)
            if k >= demo.n - 1:
                continue
            seen, sc = observed_view(demo, t)
            cases.append(PhysicsCase(seen.ev[: k + 1], seen.vehicles[k], seen.ev[k:, :2], dt,
                                     sc.lane_width, sc.vehicle_length))  # fmt: skip
    return cases


def joint_physics_cases(
    recorded: Sequence[tuple[str, Demonstration]], t_obs: Sequence[float] = T_OBS
) -> list[JointPhysicsCase]:
    """The joint physics calibration's cases: each episode at each t_obs, as :func:`observed_view`.

    Every vehicle's observed samples 0 … k (the view's: unobserved vehicles as phantoms) and
    the predicted vehicle's truth after k. Episodes too short for a t_obs are left out.
    """
    cases = []
    for _, demo in recorded:
        dt = float(demo.t[1] - demo.t[0])
        for t in t_obs:
            k = round(t / dt)
            if k >= demo.n - 1:
                continue
            seen, sc = observed_view(demo, t)
            cases.append(JointPhysicsCase(seen.ev[: k + 1], seen.vehicles[: k + 1],
                                          seen.ev[k:, :2], dt, sc.lane_width,
                                          sc.vehicle_length, sc.n_lanes))  # fmt: skip
    return cases


def train_episodes(
    data_dir: str | Path = DEFAULT_DATA_DIR,
    rows: Sequence[SplitRow] | None = None,
    episodes_dir: str | Path | None = None,
) -> list[tuple[str, Demonstration]]:
    """The train split's recorded episodes (episode id, episode as extracted).

    Args:
        data_dir: the folder holding the datasets.
        rows: the split (default: :func:`~drivestyle.recorded.benchmark.read_split` of
            :data:`~drivestyle.recorded.benchmark.SPLIT_FILE`; with
            ``episodes_dir``: the folder's own, :func:`episodes_split`).
        episodes_dir: a folder of extracted episodes to take instead of the shipped samples.
    """
    if episodes_dir is not None:
        rows = episodes_split(episodes_dir) if rows is None else rows
        return [(e, d) for _, e, d, _ in load_episodes_folder(episodes_dir, rows, "train")]
    rows = read_split() if rows is None else rows
    check_split_selects(rows, "train", tuple(DATASETS))
    check_sample_split(data_dir, rows)
    recorded = []
    for ds in DATASETS:
        ids = [r.episode_id for r in rows if r.dataset == ds and r.split == "train"]
        recorded += load_recorded(data_dir, ds, ids)
    return recorded


def calibrate_on_split(
    data_dir: str | Path = DEFAULT_DATA_DIR,
    rows: Sequence[SplitRow] | None = None,
    t_obs: Sequence[float] = T_OBS,
    episodes_dir: str | Path | None = None,
) -> PhysicsCalibration:
    """The physics baseline calibrated on the train split's episodes at every t_obs.

    Args:
        data_dir: the folder holding the datasets.
        rows: the split (:func:`train_episodes`).
        t_obs: observed times [s].
        episodes_dir: a folder of extracted episodes to calibrate on instead of the shipped
            samples.
    """
    recorded = train_episodes(data_dir, rows, episodes_dir)
    return calibrate_physics(physics_cases(recorded, t_obs))


def calibrate_joint_on_split(
    data_dir: str | Path = DEFAULT_DATA_DIR,
    rows: Sequence[SplitRow] | None = None,
    t_obs: Sequence[float] = T_OBS,
    episodes_dir: str | Path | None = None,
) -> JointPhysicsCalibration:
    """The joint physics baseline calibrated on the train split's episodes at every t_obs.

    Args: as :func:`calibrate_on_split`.
    """
    recorded = train_episodes(data_dir, rows, episodes_dir)
    return calibrate_joint_physics(joint_physics_cases(recorded, t_obs))
