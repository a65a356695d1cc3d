"""A learned driving style on disk: ``style.json`` (docs/DESIGN.md §7) and its loader."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.irl.features import FEATURES, FeatureConfig
from drivestyle.irl.learner import LearningResult, MaxEntIRL
from drivestyle.irl.spline import spline_eval

from drivestyle.common.io import read_json

__all__ = ["Style", "StyleError", "fit_style", "load_style", "style_payload"]


class StyleError(ValueError):
    """A style file is missing, malformed or inconsistent."""


def _reproduced(C: np.ndarray, t: np.ndarray) -> dict[str, list[float]]:
    pos, vel, acc = (spline_eval(C, t, t, d) for d in (0, 1, 2))
    return {
        "t": t.tolist(),
        "x": pos[:, 0].tolist(),
        "y": pos[:, 1].tolist(),
        "vx": vel[:, 0].tolist(),
        "vy": vel[:, 1].tolist(),
        "ax": acc[:, 0].tolist(),
        "ay": acc[:, 1].tolist(),
    }


def style_payload(
    result: LearningResult, learner: MaxEntIRL, demo_paths: list[str] | None = None
) -> dict[str, Any]:
    """Everything ``learn_style.py`` writes to ``style.json``.

    Trajectory metrics are means over the demonstrations; ``demos`` lists them per
    demonstration, and ``reproduced`` is the first demonstration's reproduction sampled at
    its own samples (every T_s).

    Args:
        result: the learning result.
        learner: the learner that produced it (features, control-point rule, problems).
        demo_paths: where the demonstrations came from.

    Returns:
        JSON-ready dict.
    """
    fc = learner.features
    p0 = learner.problems[0]
    errs = result.errors

    def mean(key):
        return (
            float(np.mean([e[key] for e in errs]))
            if all(e[key] is not None for e in errs)
            else None
        )

    per_demo = []
    for i, (p, sol, e) in enumerate(zip(learner.problems, result.solutions, errs, strict=True)):
        events = p.basis.events
        per_demo.append(
            {
                "path": demo_paths[i] if demo_paths else None,
                "t_trg_s": events.t_trg,
                "t_turn_s": events.t_turn,
                "trigger_fired": events.reactive_active,
                **e,
                "feature_values_demo": p.f_demo.tolist(),
                "feature_values_reproduced": sol.features.tolist(),
            }
        )
    return {
        "features": list(result.names),
        "feature_set": fc.feature_set,
        "theta": result.theta.tolist(),
        "theta_normalised": result.theta_normalised.tolist(),
        "iterations": result.iterations,
        "converged": result.converged,
        "method": learner.config.method,
        "learning_error": result.learning_error,
        "rmse_y_m": mean("rmse_y_m"),
        "rmse_xy_m": mean("rmse_xy_m"),
        "rmse_y_reaction_m": mean("rmse_y_reaction_m"),
        "wall_time_s": result.wall_time_s,
        "inner_solve_ms_median": float(np.median(result.inner_solve_ms)),
        "t_trg_s": p0.basis.events.t_trg,
        "trigger_fired": p0.basis.events.reactive_active,
        "t_rct_s": fc.t_rct,
        "omega": [fc.omega[FEATURES.index(n)] for n in result.names],
        "control_point_rule": learner.problems[0].control_point_rule,
        "feature_config": {k: getattr(fc, k) for k in fc.__dataclass_fields__},
        "feature_values_demo": result.feature_values_demo.tolist(),
        "feature_values_reproduced": result.feature_values_reproduced.tolist(),
        "history": [
            {
                "iteration": h["iteration"],
                "theta": h["theta"],
                "epsilon": h["epsilon"],
                "rmse_y_m": h["rmse_y_m"],
            }
            for h in result.history
        ],
        "reproduced": _reproduced(result.solutions[0].control_points, p0.demo.t),
        "demos": per_demo,
    }


@dataclass(frozen=True)
class Style:
    """A loaded style: the weights and the feature constants they were learned with."""

    names: tuple[str, ...]
    theta: np.ndarray
    features: FeatureConfig
    control_point_rule: str
    raw: dict[str, Any]

    @property
    def theta_normalised(self) -> np.ndarray:
        """θ normalised per feature group."""
        from drivestyle.irl.learner import normalise_theta

        return normalise_theta(self.theta, self.names)

    def demo_path(self, source: str | Path = "the style") -> Path:
        """The file of the (first) demonstration the style was learned from.

        Args:
            source: how to name the style in the error (e.g. its path).

        Raises:
            StyleError: the style names no demonstration.
        """
        try:
            return Path(self.raw["demos"][0]["path"])
        except (KeyError, IndexError, TypeError):
            raise StyleError(f"{source} names no demonstration: pass --demo") from None


def load_style(path: str | Path) -> Style:
    """Read and validate a ``style.json``.

    Args:
        path: the file, or a folder containing ``style.json``.

    Returns:
        The style.

    Raises:
        FileNotFoundError: no such file.
        StyleError: malformed JSON, missing keys, or θ inconsistent with the features.
    """
    path, raw = read_json(path, "style.json", StyleError, "style file")
    for key in ("features", "theta", "feature_config"):
        if key not in raw:
            raise StyleError(f"{path}: missing key {key!r}")
    names = tuple(raw["features"])
    theta = np.asarray(raw["theta"], dtype=float)
    if theta.shape != (len(names),) or not all(math.isfinite(v) and v > 0 for v in theta):
        raise StyleError(f"{path}: theta must be {len(names)} positive numbers, got {raw['theta']}")
    try:
        features = FeatureConfig.from_dict(raw["feature_config"])
    except (TypeError, ValueError) as exc:
        raise StyleError(f"{path}: invalid feature_config ({exc})") from None
    if features.names != names:
        raise StyleError(
            f"{path}: features {names} do not match feature_set {features.feature_set!r}"
        )
    return Style(names, theta, features, raw.get("control_point_rule", "kinematic"), raw)


def fit_style(
    demos,
    features: FeatureConfig,
    config=None,
    control_point_rule: str = "kinematic",
    demo_paths: list[str] | None = None,
    progress=None,
) -> tuple[LearningResult, MaxEntIRL, dict[str, Any]]:
    """Learn a style from demonstrations and describe it (the ``style.json`` payload).

    Args:
        demos: one demonstration or a list (features averaged).
        features: feature configuration.
        config: :class:`drivestyle.irl.learner.IRLConfig`.
        control_point_rule: control-point rule of the demonstrations.
        demo_paths: recorded in the payload.
        progress: per-iteration callback (see :meth:`MaxEntIRL.learn`).

    Returns:
        (result, learner, payload).
    """
    learner = MaxEntIRL(demos, features, config, control_point_rule)
    result = learner.learn(progress=progress)
    return result, learner, style_payload(result, learner, demo_paths)
