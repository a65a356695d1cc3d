"""Learning and comparing the paper model's styles on recorded lane changes (beyond the paper).

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

On CATS the computer-driven and human-driven lane changes are compared (:func:`av_vs_hv`).
The receding-horizon driver model's study of the same episodes is
:mod:`drivestyle.studies.real_traffic.driver_study`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL, normalise_theta
from drivestyle.recorded.real_data import RecordedEpisode
from drivestyle.studies.real_traffic.figures import plot_episode

__all__ = [
    "REPRODUCTIONS",
    "RealTrafficStudy",
    "av_vs_hv",
    "classify_loo",
    "constant_velocity",
    "episode_feature_config",
    "lane_change_stats",
    "learn_general",
    "learn_personal",
    "reproduce_with",
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
