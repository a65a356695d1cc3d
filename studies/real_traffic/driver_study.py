"""The receding-horizon driver model on recorded lane changes (beyond the paper model).

Every used episode gets its personal driver style (weights, risk p and desired speed
learned by :func:`~drivestyle.irl.driver.driver_learning.learn_driver`), reproduced in
closed loop against the recorded vehicles; a vehicle with several episodes is also learned
from all but one and reproduces the held-out one, beside the general style of the other
vehicles' episodes (:func:`run_driver_study`). Each episode is the one recorded view,
shifted to the EV's own final line (:func:`driver_demo`). The paper model's study of the
same episodes is :mod:`drivestyle.studies.real_traffic.study`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.driver_learning import RESTARTS, SCREEN_CANDIDATES, learn_driver
from drivestyle.irl.driver.driver_style import reproduce
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.recorded.real_data import (
    RECORDED_DELTA_MAX,
    RECORDED_PHI_MAX,
    RecordedEpisode,
    recorded_view,
)

__all__ = [
    "DRIVER_REPRODUCTIONS",
    "DriverSettings",
    "DriverSplit",
    "DriverTrafficStudy",
    "driver_demo",
    "driver_splits",
    "episode_vehicle",
    "own_line_shift",
    "run_driver_study",
]


def own_line_shift(demo: Demonstration, settle_s: float = 1.0) -> Demonstration:
    """Every vehicle shifted laterally so that the model's y_ref lies on the EV's final line.

    The learning study's l_des rule
    (:func:`~drivestyle.studies.real_traffic.study.episode_feature_config`): drivers keep
    their own line, and the ±4 s windows often end before the lane change settles, so the
    target lane's centre is moved onto the EV's mean y over the last ``settle_s``. It reads
    the episode's end: a learning and reproduction rule, never a prediction's. Errors are
    shift-invariant.

    Args:
        demo: a recorded episode.
        settle_s: the final stretch that defines the EV's line [s].

    Returns:
        The shifted demonstration (``meta["lateral_shift_m"]``: the shift [m]).
    """
    k = max(1, round(settle_s / float(demo.t[1] - demo.t[0])))
    shift = np.array([0.0, demo.scenario.y_ref - float(demo.ev[-k:, 1].mean()), 0.0, 0.0])
    others = demo.other_vehicles + shift
    return replace(
        demo,
        ev=demo.ev + shift,
        tv=demo.tv + shift,
        others=others if others.shape[1] else None,
        meta={**demo.meta, "lateral_shift_m": float(shift[1])},
    )


def driver_demo(demo: Demonstration, own_line: bool = True) -> Demonstration:
    """A recorded episode as the driver-model study learns from it.

    The one recorded view (:func:`~drivestyle.recorded.real_data.recorded_view`), shifted to
    the EV's own final line with ``own_line`` (:func:`own_line_shift`).

    Returns:
        The demonstration (``meta["lateral_shift_m"]``: the shift, 0 without one).
    """
    view = recorded_view(demo)
    return (
        own_line_shift(view)
        if own_line
        else replace(view, meta={**view.meta, "lateral_shift_m": 0.0})
    )


DRIVER_REPRODUCTIONS = ("personal", "own_loo", "general_loo")
"""Driver-model reproductions: the episode's own style; a vehicle's style from its other
episodes (leave-one-out); the style of the other vehicles' episodes (leave-one-out)."""


@dataclass(frozen=True)
class DriverSettings:
    """How the driver model is learned on recorded traffic (:func:`learn_driver`'s search)."""

    screen: int = SCREEN_CANDIDATES
    """Starting points scored before the Levenberg–Marquardt runs."""
    restarts: int = RESTARTS
    """Levenberg–Marquardt runs from the best-scored starting points."""
    own_line: bool = True
    """Shift each episode to the EV's own final line (:func:`own_line_shift`)."""
    max_iter: int = 30
    """Levenberg–Marquardt iteration cap per run (:func:`learn_driver`'s default: 30)."""
    fit_region: bool = False
    """Also learn the speed-scaled safety region (time gap, standstill axis; DESIGN §18)."""

    def __post_init__(self) -> None:
        for name in ("screen", "restarts", "max_iter"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ValueError(f"{name} must be an integer ≥ 1, got {value!r}")
        if self.restarts > self.screen:
            raise ValueError(
                f"restarts ({self.restarts}) cannot exceed the screened starts ({self.screen})"
            )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "screen": self.screen,
            "restarts": self.restarts,
            "own_line": self.own_line,
            "max_iter": self.max_iter,
            "fit_region": self.fit_region,
        }


@dataclass(frozen=True)
class DriverSplit:
    """One leave-one-out split of a vehicle's episodes (indices into the used episodes)."""

    vehicle: str
    held_out: int
    """The reproduced episode."""
    own: tuple[int, ...]
    """The vehicle's other episodes (its style's training set)."""
    general: tuple[int, ...]
    """The other vehicles' episodes (the general style's training set)."""


def driver_splits(vehicles: Sequence[str], min_episodes: int = 3) -> list[DriverSplit]:
    """Leave-one-out splits for every vehicle with at least ``min_episodes`` episodes.

    Args:
        vehicles: the vehicle (driver) of each used episode.
        min_episodes: a vehicle needs this many (its style is learned from one fewer).

    Returns:
        One split per episode of each such vehicle, in episode order; ``general`` holds
        every episode of the other vehicles (none of the held-out vehicle's).

    Raises:
        ValueError: ``min_episodes`` < 2.
    """
    if min_episodes < 2:
        raise ValueError(
            f"min_episodes must be ≥ 2 (one learns, one is held out), got {min_episodes}"
        )
    vehicles = list(vehicles)
    out = []
    for i, v in enumerate(vehicles):
        own = tuple(j for j, w in enumerate(vehicles) if w == v and j != i)
        if len(own) + 1 < min_episodes:
            continue
        general = tuple(j for j, w in enumerate(vehicles) if w != v)
        out.append(DriverSplit(v, i, own, general))
    return out


def _reproduction_errors(style: Any, demo: Demonstration) -> dict[str, Any]:
    rep = reproduce(style, demo)
    return {
        **trajectory_errors(rep.states[:, :2], demo),
        "min_d": rep.min_d,
        "failures": rep.failures,
    }


def _driver_fit_task(
    train: tuple[int, ...],
    test: tuple[int, ...],
    demos: list[Demonstration],
    settings: DriverSettings,
) -> dict[str, Any]:
    """Learn one style on ``train`` (risk and desired speed free), reproduce it on ``test``."""
    fit = learn_driver(
        [demos[j] for j in train],
        fit_speed=True,
        screen=settings.screen,
        restarts=settings.restarts,
        max_iter=settings.max_iter,
        fit_region=settings.fit_region,
    )
    fit_json = {k: v for k, v in fit.to_json().items() if k != "history"}
    return {"fit": fit_json, "test": {j: _reproduction_errors(fit.style, demos[j]) for j in test}}


@dataclass(frozen=True)
class DriverTrafficStudy:
    """The receding-horizon driver model on recorded episodes (``real_traffic.json``: ``driver``).

    Attributes:
        dataset: 'ngsim' or 'cats'.
        settings: the learning search.
        medians: reproduction (:data:`DRIVER_REPRODUCTIONS`) → median ``rmse_y_m``,
            ``rmse_xy_m``, ``fde_m`` over the episodes that have it (None: none).
        episodes: per used episode: ``episode_id``, ``vehicle``, ``lateral_shift_m`` and
            reproduction → errors (``personal`` also its learned ``style``).
        vehicles: per vehicle with leave-one-out splits: its episodes, the splits' errors
            and medians of ``own_loo`` against ``general_loo``.
        seconds: learning time summed over the fits (CPU seconds of the workers).
    """

    dataset: str
    settings: DriverSettings
    medians: dict[str, dict[str, float | None]]
    episodes: list[dict[str, Any]]
    vehicles: dict[str, Any]
    seconds: float

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "model": "receding-horizon driver style (irl/driver/driver_style.py)",
            "dataset": self.dataset,
            "settings": self.settings.to_json(),
            "limits": {"phi_max_rad": RECORDED_PHI_MAX, "delta_max_rad": RECORDED_DELTA_MAX},
            "median_rmse_y_m": {m: v["rmse_y_m"] for m, v in self.medians.items()},
            "medians": self.medians,
            "episodes": self.episodes,
            "vehicles": self.vehicles,
            "fit_seconds": self.seconds,
        }


def episode_vehicle(episode: RecordedEpisode) -> str:
    """The driver of an episode.

    CATS's ego car (vehicle 3) is driven by the computer in the AV set and by a human in the
    HV set: two drivers. Every NGSIM episode is its own driver.
    """
    if episode.dataset == "cats":
        return f"CATS {episode.flags.get('set')} (vehicle 3)"
    return episode.episode_id


def _medians(rows: Sequence[dict[str, Any]]) -> dict[str, float | None]:
    return {
        k: float(np.median([r[k] for r in rows])) if rows else None
        for k in ("rmse_y_m", "rmse_xy_m", "fde_m")
    }


def run_driver_study(
    episodes: Sequence[RecordedEpisode],
    dataset: str,
    workers: int = 2,
    limit: int | None = None,
    progress: Callable[[int], Any] | None = None,
    settings: DriverSettings | None = None,
    min_episodes: int = 3,
    on_plan: Callable[[int], Any] | None = None,
) -> DriverTrafficStudy:
    """Personal driver styles of every used episode, and per vehicle a leave-one-out test.

    Each fit learns weights, risk and desired speed (``fit_speed=True``) and is reproduced in
    closed loop against the recorded vehicles. A vehicle with ``min_episodes`` or more
    episodes is also learned from all but one of them and reproduces the held-out one,
    beside the general style learned from the other vehicles' episodes.

    Args:
        episodes: the loaded episodes (used and unused).
        dataset: 'ngsim' or 'cats'.
        workers: processes (1: in this process).
        limit: only the first N used episodes (None: all).
        progress: called with 1 after each fit.
        settings: the learning search (default :class:`DriverSettings`).
        min_episodes: episodes a vehicle needs for its leave-one-out test.
        on_plan: called with the number of fits before they start (a progress bar's total).

    Returns:
        The study.

    Raises:
        ValueError: no usable episode.
    """
    settings = settings or DriverSettings()
    used = [e for e in episodes if e.used]
    if limit is not None:
        used = used[:limit]
    if not used:
        raise ValueError(f"no usable {dataset} episode")
    demos = [driver_demo(e.demo, settings.own_line) for e in used if e.demo is not None]
    vehicles = [episode_vehicle(e) for e in used]
    splits = driver_splits(vehicles, min_episodes)
    # one fit per distinct training set, reproduced on every episode that needs it
    fits: dict[tuple[int, ...], set[int]] = {(i,): {i} for i in range(len(used))}
    for s in splits:
        fits.setdefault(s.own, set()).add(s.held_out)
        if s.general:
            fits.setdefault(s.general, set()).add(s.held_out)
    order = sorted(fits, key=len, reverse=True)  # the longest fits first: balanced workers
    tasks = [(train, tuple(sorted(fits[train])), demos, settings) for train in order]
    if on_plan is not None:
        on_plan(len(tasks))
    results = parallel_map(
        _driver_fit_task, tasks, workers, None if progress is None else lambda *_: progress(1)
    )
    by_train = dict(zip(order, results, strict=True))
    rows = []
    for i, e in enumerate(used):
        personal = by_train[(i,)]
        rows.append(
            {
                "episode_id": e.episode_id,
                "vehicle": vehicles[i],
                "lateral_shift_m": demos[i].meta["lateral_shift_m"],
                "personal": {**personal["test"][i], "fit": personal["fit"]},
            }
        )
    per_vehicle: dict[str, Any] = {}
    for s in splits:
        own = by_train[s.own]["test"][s.held_out]
        row = rows[s.held_out]
        row["own_loo"] = {**own, "n_train": len(s.own)}
        entry = per_vehicle.setdefault(
            s.vehicle, {"episodes": [], "own_styles": [], "general_style": None, "splits": []}
        )
        entry["episodes"].append(used[s.held_out].episode_id)
        entry["own_styles"].append(by_train[s.own]["fit"]["style"])
        split = {"held_out": used[s.held_out].episode_id, "own_loo": own}
        if s.general:
            general = by_train[s.general]["test"][s.held_out]
            row["general_loo"] = {**general, "n_train": len(s.general)}
            entry["general_style"] = by_train[s.general]["fit"]["style"]
            split["general_loo"] = general
        entry["splits"].append(split)
    for entry in per_vehicle.values():
        for m in ("own_loo", "general_loo"):
            vals = [sp[m] for sp in entry["splits"] if m in sp]
            entry[f"median_{m}"] = _medians(vals)
        pairs = [sp for sp in entry["splits"] if "general_loo" in sp]
        entry["own_better_rmse_y"] = sum(
            sp["own_loo"]["rmse_y_m"] < sp["general_loo"]["rmse_y_m"] for sp in pairs
        )
        entry["own_better_rmse_xy"] = sum(
            sp["own_loo"]["rmse_xy_m"] < sp["general_loo"]["rmse_xy_m"] for sp in pairs
        )
        entry["n_splits"] = len(entry["splits"])
    medians = {m: _medians([r[m] for r in rows if m in r]) for m in DRIVER_REPRODUCTIONS}
    return DriverTrafficStudy(
        dataset=dataset,
        settings=settings,
        medians=medians,
        episodes=rows,
        vehicles=per_vehicle,
        seconds=float(sum(r["fit"]["seconds"] for r in results)),
    )
