"""Learning and comparing styles on recorded lane changes (beyond the paper).

For each recorded episode four reproductions are compared with the recording:

- ``personal_reactive`` / ``personal_base``: a style learned from that episode alone;
- ``general``: a reactive style learned jointly from all *other* used episodes of the same
  dataset (leave-one-out), reproduced in this episode's scenario;
- ``constant_velocity``: the EV's velocity at the window's start, extrapolated.

Errors are taken at the recording's samples: rmse_y, rmse_xy and the final displacement
error (fde). Feature constants adapt to each episode: the scenario's lane width, v_ref and
ellipse come from the observed part (:mod:`drivestyle.recorded.real_data`, DESIGN §10);
l_initial and l_des are the EV's own mean lateral positions over the window's first and
last second (drivers keep their own line, not the painted lane centre, and a constant
offset would otherwise be charged as lane deviation), and v_des = v_lane is its mean speed
over the last second (the speed it settles at, rather than the scenario's v_ref).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.driver_learning import RESTARTS, SCREEN_CANDIDATES, learn_driver
from drivestyle.irl.driver.driver_style import reproduce
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL, normalise_theta
from drivestyle.recorded.real_data import (
    RECORDED_DELTA_MAX,
    RECORDED_PHI_MAX,
    RecordedEpisode,
    recorded_view,
)
from drivestyle.studies.figures import plot_episode

__all__ = [
    "DRIVER_REPRODUCTIONS",
    "RECORDED_DELTA_MAX",
    "RECORDED_PHI_MAX",
    "REPRODUCTIONS",
    "DriverSettings",
    "DriverSplit",
    "DriverTrafficStudy",
    "RealTrafficStudy",
    "av_vs_hv",
    "classify_loo",
    "constant_velocity",
    "driver_demo",
    "driver_splits",
    "episode_feature_config",
    "learn_general",
    "learn_personal",
    "own_line_shift",
    "reproduce_with",
    "run_driver_study",
    "run_study",
]

REPRODUCTIONS = ("personal_reactive", "personal_base", "general", "constant_velocity")
"""The reproductions compared with each recorded lane change (module docstring)."""


@dataclass(frozen=True)
class RealTrafficStudy:
    """Every reproduction on every used recorded episode (``real_traffic.json``, DESIGN §7).

    Attributes:
        dataset: 'ngsim' or 'cats'.
        n_episodes: episodes loaded (used and unused).
        n_used: episodes studied.
        medians: reproduction (:data:`REPRODUCTIONS`, in order) → median ``rmse_y_m``,
            ``rmse_xy_m`` and ``fde_m`` over the used episodes (None: no episode).
        episodes: per loaded episode: ``episode_id``, ``used``, ``reasons``, ``flags``
            and, if used, ``methods`` (reproduction → errors) and ``stats``.
        av_vs_hv: CATS only: the computer- against the human-driven lane changes.
    """

    dataset: str
    n_episodes: int
    n_used: int
    medians: dict[str, dict[str, float | None]]
    episodes: list[dict[str, Any]]
    av_vs_hv: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        """``real_traffic.json``'s study keys (the script adds the neighbour counts)."""
        out: dict[str, Any] = {
            "dataset": self.dataset,
            "n_episodes": self.n_episodes,
            "n_used": self.n_used,
            "median_rmse_y_m": {m: v["rmse_y_m"] for m, v in self.medians.items()},
            "medians": self.medians,
            "episodes": self.episodes,
        }
        if self.av_vs_hv is not None:
            out["av_vs_hv"] = self.av_vs_hv
        return out


def episode_feature_config(
    demo: Demonstration, feature_set: str = "reactive", settle_s: float = 1.0
) -> FeatureConfig:
    """Feature constants for one recorded episode (module docstring's rule).

    Args:
        demo: the recorded episode.
        feature_set: 'reactive' or 'base'.
        settle_s: length of the start and end stretches that define the EV's lines [s].

    Returns:
        The feature configuration.
    """
    k = max(1, round(settle_s / float(demo.t[1] - demo.t[0])))
    v_end = float(demo.ev[-k:, 3].mean())
    return FeatureConfig(
        feature_set=feature_set,
        l_initial=float(demo.ev[:k, 1].mean()),
        l_des=float(demo.ev[-k:, 1].mean()),
        v_des=v_end,
        v_lane=v_end,
    )


def own_line_shift(demo: Demonstration, settle_s: float = 1.0) -> Demonstration:
    """Every vehicle shifted laterally so that the model's y_ref lies on the EV's final line.

    The learning study's l_des rule (:func:`episode_feature_config`): drivers keep their own
    line, and the ±4 s windows often end before the lane change settles, so the target
    lane's centre is moved onto the EV's mean y over the last ``settle_s``. It reads the
    episode's end: a learning and reproduction rule, never a prediction's. Errors are
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


def constant_velocity(demo: Demonstration) -> np.ndarray:
    """Positions extrapolated at the EV's initial velocity, shape (n, 2)."""
    x0, y0, phi, v = demo.ev[0]
    t = demo.t - demo.t[0]
    return np.column_stack([x0 + v * math.cos(phi) * t, y0 + v * math.sin(phi) * t])


def learn_personal(demo: Demonstration, feature_set: str) -> dict[str, Any]:
    """Learn and reproduce one episode's own style."""
    learner = MaxEntIRL(demo, episode_feature_config(demo, feature_set), IRLConfig())
    res = learner.learn()
    C = res.solutions[0].control_points
    return {
        "theta": res.theta.tolist(),
        "theta_normalised": res.theta_normalised.tolist(),
        "names": list(res.names),
        "iterations": res.iterations,
        "converged": res.converged,
        "control_points": C,
        "trigger_fired": learner.problems[0].basis.events.reactive_active,
        **trajectory_errors(C[:, [0, 3]], demo),
    }


def reproduce_with(
    theta: np.ndarray, demo: Demonstration, feature_set: str = "reactive"
) -> np.ndarray:
    """r*_θ in one episode's scenario (its own event times and constants), control points."""
    problem = InnerProblem(demo, episode_feature_config(demo, feature_set))
    return problem.solve(np.asarray(theta)).control_points


def learn_general(demos: Sequence[Demonstration], feature_set: str = "reactive") -> np.ndarray:
    """θ learned jointly from several recorded episodes, each with its own constants."""
    configs = [episode_feature_config(d, feature_set) for d in demos]
    return MaxEntIRL(list(demos), configs, IRLConfig()).learn().theta


def classify_loo(thetas: np.ndarray, labels: Sequence[str], names: Sequence[str]) -> dict[str, Any]:
    """Leave-one-out nearest-centroid classification of normalised style vectors.

    Args:
        thetas: learned θ, shape (n, m).
        labels: class of each (e.g. 'AV', 'HV').
        names: feature names (for the per-group normalisation).

    Returns:
        Accuracy, predictions, and a one-sided exact binomial p-value against guessing the
        majority class (how surprising the accuracy would be by chance).
    """
    X = np.array([np.log(normalise_theta(t, names) + 1e-6) for t in thetas])
    labels = list(labels)
    preds = []
    for i in range(len(labels)):
        keep = [j for j in range(len(labels)) if j != i]
        cents = {
            c: X[[j for j in keep if labels[j] == c]].mean(axis=0)
            for c in sorted(set(labels[j] for j in keep))
        }
        preds.append(min(cents, key=lambda c: float(np.sum((X[i] - cents[c]) ** 2))))
    correct = sum(p == y for p, y in zip(preds, labels, strict=True))
    n = len(labels)
    base = max(labels.count(c) for c in set(labels)) / n
    p_value = sum(math.comb(n, k) * base**k * (1 - base) ** (n - k) for k in range(correct, n + 1))
    return {
        "accuracy": correct / n,
        "n": n,
        "predictions": preds,
        "labels": labels,
        "majority_rate": base,
        "p_value_vs_majority": float(p_value),
    }


def _episode_task(i: int, demos: list[Demonstration], figure_dir: str | None) -> dict:
    """All four methods on episode i (the general style leaves episode i out)."""
    demo = demos[i]
    res = {}
    paths = {}
    for fs in ("reactive", "base"):
        r = learn_personal(demo, fs)
        res[f"personal_{fs}"] = {
            k: r[k] for k in ("rmse_y_m", "rmse_xy_m", "fde_m", "iterations", "converged")
        }
        res[f"personal_{fs}"]["theta_normalised"] = r["theta_normalised"]
        res[f"personal_{fs}"]["trigger_fired"] = r["trigger_fired"]
        paths[f"personal {fs}"] = r["control_points"][:, [0, 3]]
    others = [d for j, d in enumerate(demos) if j != i]
    if others:
        theta = learn_general(others)
        C = reproduce_with(theta, demo)
        res["general"] = trajectory_errors(C[:, [0, 3]], demo)
        paths["general (leave-one-out)"] = C[:, [0, 3]]
    cv = constant_velocity(demo)
    res["constant_velocity"] = trajectory_errors(cv, demo)
    paths["constant velocity"] = cv
    if figure_dir is not None:
        plot_episode(
            demo,
            paths,
            Path(figure_dir) / f"{demo.meta['episode_id']}.png",
            demo.meta["episode_id"],
        )
    return res


def lane_change_stats(demo: Demonstration | None) -> dict[str, float]:
    """Peak lateral acceleration and 10–90 % lane-change duration of a recording.

    Raises:
        ValueError: no demonstration (an episode that did not load).
    """
    if demo is None:
        raise ValueError("no demonstration to describe")
    y = demo.ev[:, 1]
    vy = np.gradient(y, demo.t)
    ay = np.gradient(vy, demo.t)
    y0, y1 = y[:5].mean(), y[-5:].mean()
    frac = (y - y0) / (y1 - y0)
    t10 = demo.t[np.argmax(frac >= 0.1)]
    t90 = demo.t[np.argmax(frac >= 0.9)]
    return {
        "peak_lateral_accel_mps2": float(np.abs(ay).max()),
        "peak_lateral_speed_mps": float(np.abs(vy).max()),
        "duration_10_90_s": float(t90 - t10),
    }


def av_vs_hv(records: list[dict]) -> dict:
    """Compare the computer-driven and human-driven CATS lane changes."""
    rows = [r for r in records if "methods" in r]
    labels = [r["flags"]["set"] for r in rows]
    out: dict = {"n": {c: labels.count(c) for c in sorted(set(labels))}}
    for c in sorted(set(labels)):
        sel = [r for r in rows if r["flags"]["set"] == c]
        out[c] = {
            "rmse_y_personal_reactive_median_m": float(
                np.median([r["methods"]["personal_reactive"]["rmse_y_m"] for r in sel])
            ),
            **{k: float(np.median([r["stats"][k] for r in sel])) for k in sel[0]["stats"]},
            "theta_base_normalised_mean": np.mean(
                [r["methods"]["personal_base"]["theta_normalised"] for r in sel], axis=0
            ).tolist(),
        }
    names = ("ax", "ay", "v", "l", "il", "el")
    out["classifier_base_features"] = classify_loo(
        np.array([r["methods"]["personal_base"]["theta_normalised"] for r in rows]), labels, names
    )
    return out


def run_study(
    episodes: Sequence[RecordedEpisode],
    dataset: str,
    workers: int = 2,
    figure_dir: str | Path | None = None,
    limit: int | None = None,
    progress: Callable[[int], Any] | None = None,
) -> RealTrafficStudy:
    """The recorded-traffic study: every method on every used episode, with medians.

    Args:
        episodes: the loaded episodes (used and unused).
        dataset: 'ngsim' or 'cats' (CATS adds the AV-vs-human comparison).
        workers: processes (1: in this process).
        figure_dir: write one figure per episode here (None: no figures).
        limit: only the first N used episodes (None: all).
        progress: called with 1 after each episode.

    Returns:
        The study (its ``to_json()`` is ``real_traffic.json``'s study part).

    Raises:
        ValueError: fewer than 2 usable episodes (the general style leaves one out).
    """
    used = [e for e in episodes if e.used]
    if limit is not None:
        used = used[:limit]
    if len(used) < 2:
        raise ValueError(f"{len(used)} usable {dataset} episode(s); the study needs at least 2")
    demos = [e.demo for e in used]
    fig = None if figure_dir is None else str(figure_dir)
    results = parallel_map(
        _episode_task,
        [(i, demos, fig) for i in range(len(demos))],
        workers,
        None if progress is None else lambda *_: progress(1),
    )
    records: list[dict[str, Any]] = []
    for e in episodes:
        rec = {
            "episode_id": e.episode_id,
            "used": e in used,
            "reasons": list(e.reasons),
            "flags": e.flags,
        }
        if e in used:
            i = used.index(e)
            rec["methods"] = results[i]
            rec["stats"] = lane_change_stats(e.demo)
        records.append(rec)
    medians = {}
    for m in REPRODUCTIONS:
        vals = [r["methods"][m] for r in records if "methods" in r and m in r["methods"]]
        medians[m] = {
            k: float(np.median([v[k] for v in vals])) if vals else None
            for k in ("rmse_y_m", "rmse_xy_m", "fde_m")
        }
    return RealTrafficStudy(
        dataset=dataset,
        n_episodes=len(episodes),
        n_used=len(used),
        medians=medians,
        episodes=records,
        av_vs_hv=av_vs_hv(records) if dataset == "cats" else None,
    )


# ------------------------------------------------------------ the receding-horizon driver model
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
