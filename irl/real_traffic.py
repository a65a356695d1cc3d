"""Learning and comparing styles on recorded lane changes (beyond the paper).

For each recorded episode four reproductions are compared with the recording:

- ``personal_reactive`` / ``personal_base``: a style learned from that episode alone;
- ``general``: a reactive style learned jointly from all *other* used episodes of the same
  dataset (leave-one-out), reproduced in this episode's scenario;
- ``constant_velocity``: the EV's velocity at the window's start, extrapolated.

Errors are taken at the recording's samples: rmse_y, rmse_xy and the final displacement
error (fde). Feature constants adapt to each episode: the scenario's lane width, v_ref
and ellipse come from :func:`envs.real_data.scenario_from_episode`; l_initial and l_des are
the EV's own mean lateral positions over the window's first and last second (drivers keep
their own line, not the painted lane centre, and a constant offset would otherwise be
charged as lane deviation), and v_des = v_lane is its mean speed over the last second (the
speed it settles at, rather than the scenario's v_ref).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from envs.demonstration import Demonstration
from irl.features import FeatureConfig
from irl.inner import InnerProblem
from irl.learner import IRLConfig, MaxEntIRL, normalise_theta

__all__ = [
    "METHODS",
    "classify_loo",
    "constant_velocity",
    "episode_feature_config",
    "trajectory_errors",
]

METHODS = ("personal_reactive", "personal_base", "general", "constant_velocity")


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


def trajectory_errors(xy: np.ndarray, demo: Demonstration) -> dict[str, float]:
    """rmse_y, rmse_xy and final displacement error of positions at the samples [m]."""
    dx, dy = xy[:, 0] - demo.ev[:, 0], xy[:, 1] - demo.ev[:, 1]
    return {
        "rmse_y_m": float(np.sqrt(np.mean(dy**2))),
        "rmse_xy_m": float(np.sqrt(np.mean(dx**2 + dy**2))),
        "fde_m": float(math.hypot(dx[-1], dy[-1])),
    }


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
