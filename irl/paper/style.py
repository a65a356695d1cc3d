"""A learned driving style on disk: ``style.json`` (docs/DESIGN.md §7) and its loader."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import read_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.paper.features import FEATURES, FeatureConfig
from drivestyle.irl.paper.learner import (
    IRLConfig,
    IterationRecord,
    LearningResult,
    LearningStatus,
    MaxEntIRL,
    normalise_theta,
)
from drivestyle.irl.paper.spline import spline_eval

__all__ = [
    "DemoFit",
    "FittedStyle",
    "ReproducedTrajectory",
    "Style",
    "StyleError",
    "fit_style",
    "load_style",
    "locate_demos",
]

DEMO_FROM_STYLE = "path_from_style"
"""``style.json`` → ``demos``: the demonstration's file relative to the folder of ``style.json``
(``path`` is as it was given, relative to the working directory of the learning run)."""


class StyleError(ValueError):
    """A style file is missing, malformed or inconsistent."""


@dataclass(frozen=True)
class ReproducedTrajectory:
    """r*_θ sampled at a demonstration's samples (``style.json`` → ``reproduced``)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    ax: np.ndarray
    ay: np.ndarray

    @classmethod
    def sample(cls, C: np.ndarray, t: np.ndarray) -> ReproducedTrajectory:
        """Sample the spline with control points C (S+1, 6) at the times t."""
        pos, vel, acc = (spline_eval(C, t, t, d) for d in (0, 1, 2))
        return cls(t, pos[:, 0], pos[:, 1], vel[:, 0], vel[:, 1], acc[:, 0], acc[:, 1])

    def to_json(self) -> dict[str, list[float]]:
        """``{t, x, y, vx, vy, ax, ay}`` as lists."""
        return {k: getattr(self, k).tolist() for k in ("t", "x", "y", "vx", "vy", "ax", "ay")}


@dataclass(frozen=True)
class DemoFit:
    """How the learned style reproduces one demonstration (``style.json`` → ``demos``)."""

    path: str | None
    t_trg_s: float | None
    t_turn_s: float | None
    trigger_fired: bool
    errors: dict[str, float | None]
    """:func:`drivestyle.irl.metrics.trajectory_errors` of the reproduction."""
    feature_values_demo: np.ndarray
    feature_values_reproduced: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """The entry of ``demos``: path, event times, errors and feature values."""
        return {
            "path": self.path,
            "t_trg_s": self.t_trg_s,
            "t_turn_s": self.t_turn_s,
            "trigger_fired": self.trigger_fired,
            **self.errors,
            "feature_values_demo": self.feature_values_demo.tolist(),
            "feature_values_reproduced": self.feature_values_reproduced.tolist(),
        }


@dataclass(frozen=True)
class FittedStyle:
    """A learned style with what ``style.json`` records about it (docs/DESIGN.md §7).

    Trajectory metrics are means over the demonstrations; ``demos`` holds them per
    demonstration, and ``reproduced`` is the first demonstration's reproduction sampled at
    its own samples (every T_s).
    """

    result: LearningResult
    method: str
    """The update rule ('lm' or 'paper')."""
    features: FeatureConfig
    control_point_rule: str
    demos: tuple[DemoFit, ...]
    reproduced: ReproducedTrajectory

    @classmethod
    def of(
        cls, result: LearningResult, learner: MaxEntIRL, demo_paths: Sequence[str] | None = None
    ) -> FittedStyle:
        """Describe a learning result.

        Args:
            result: the learning result.
            learner: the learner that produced it (features, control-point rule, problems).
            demo_paths: where the demonstrations came from.
        """
        demos = tuple(
            DemoFit(
                path=demo_paths[i] if demo_paths else None,
                t_trg_s=p.basis.events.t_trg,
                t_turn_s=p.basis.events.t_turn,
                trigger_fired=p.basis.events.reactive_active,
                errors=e,
                feature_values_demo=p.f_demo,
                feature_values_reproduced=sol.features,
            )
            for i, (p, sol, e) in enumerate(
                zip(learner.problems, result.solutions, result.errors, strict=True)
            )
        )
        p0 = learner.problems[0]
        return cls(
            result=result,
            method=learner.config.method,
            features=learner.features,
            control_point_rule=p0.control_point_rule,
            demos=demos,
            reproduced=ReproducedTrajectory.sample(result.solutions[0].control_points, p0.demo.t),
        )

    def _mean(self, key: str) -> float | None:
        """Mean of an error over the demonstrations; None if one of them has none."""
        values = [v for d in self.demos if (v := d.errors[key]) is not None]
        return float(np.mean(values)) if len(values) == len(self.demos) else None

    @property
    def status(self) -> LearningStatus:
        """How learning stopped (see :data:`drivestyle.irl.paper.learner.LearningStatus`)."""
        return self.result.status

    @property
    def rmse_y_m(self) -> float:
        """Lateral RMSE, mean over the demonstrations [m]."""
        return float(np.mean([d.errors["rmse_y_m"] for d in self.demos]))

    @property
    def rmse_xy_m(self) -> float:
        """Position RMSE, mean over the demonstrations [m]."""
        return float(np.mean([d.errors["rmse_xy_m"] for d in self.demos]))

    @property
    def rmse_y_reaction_m(self) -> float | None:
        """Lateral RMSE in the reaction window (None if a demonstration has none) [m]."""
        return self._mean("rmse_y_reaction_m")

    @property
    def t_trg_s(self) -> float | None:
        """The first demonstration's trigger time [s]."""
        return self.demos[0].t_trg_s

    @property
    def trigger_fired(self) -> bool:
        """Whether the trigger fired in the first demonstration (reactive features active)."""
        return self.demos[0].trigger_fired

    def to_json(self) -> dict[str, Any]:
        """The ``style.json`` payload (keys of docs/DESIGN.md §7, plus ``status``)."""
        fc = self.features
        learning = self.result.to_json()
        return {
            "features": learning.pop("features"),
            "feature_set": fc.feature_set,
            "theta": learning.pop("theta"),
            "theta_normalised": learning.pop("theta_normalised"),
            "iterations": learning.pop("iterations"),
            "converged": learning.pop("converged"),
            "status": learning.pop("status"),
            "method": self.method,
            "learning_error": learning.pop("learning_error"),
            "rmse_y_m": self.rmse_y_m,
            "rmse_xy_m": self.rmse_xy_m,
            "rmse_y_reaction_m": self.rmse_y_reaction_m,
            "wall_time_s": learning.pop("wall_time_s"),
            "inner_solve_ms_median": learning.pop("inner_solve_ms_median"),
            "t_trg_s": self.t_trg_s,
            "trigger_fired": self.trigger_fired,
            "t_rct_s": fc.t_rct,
            "omega": [fc.omega[FEATURES.index(n)] for n in self.result.names],
            "control_point_rule": self.control_point_rule,
            "feature_config": {k: getattr(fc, k) for k in fc.__dataclass_fields__},
            **learning,  # stop_reason, inner_failures, feature values, history
            "reproduced": self.reproduced.to_json(),
            "demos": [d.to_json() for d in self.demos],
        }


@dataclass(frozen=True)
class Style:
    """A loaded style: the weights and the feature constants they were learned with."""

    names: tuple[str, ...]
    theta: np.ndarray
    features: FeatureConfig
    control_point_rule: str
    raw: dict[str, Any]
    file: Path | None = None
    """The ``style.json`` it was read from."""

    @property
    def theta_normalised(self) -> np.ndarray:
        """θ normalised per feature group."""
        return normalise_theta(self.theta, self.names)

    def demo_path(self, source: str | Path = "the style") -> Path:
        """The file of the (first) demonstration the style was learned from.

        Found from the style's own folder where ``style.json`` records it so
        (:data:`DEMO_FROM_STYLE`, whatever the working directory), else as recorded.

        Args:
            source: how to name the style in the error (e.g. its path).

        Raises:
            StyleError: the style names no demonstration.
        """
        try:
            entry = self.raw["demos"][0]
            beside = entry.get(DEMO_FROM_STYLE)
            if beside is not None and self.file is not None:
                return self.file.parent / beside
            return Path(entry["path"])
        except (KeyError, IndexError, TypeError, AttributeError):
            raise StyleError(f"{source} names no demonstration: pass --demo") from None


def locate_demos(
    payload: dict[str, Any], style_dir: str | Path, demo_files: Sequence[str | Path]
) -> dict[str, Any]:
    """A ``style.json`` payload whose demonstrations are also found from its own folder.

    Args:
        payload: :meth:`FittedStyle.to_json`.
        style_dir: the folder ``style.json`` is written to.
        demo_files: the demonstrations' files, in order (both relative to one working
            directory, or absolute).

    Returns:
        The payload with :data:`DEMO_FROM_STYLE` in each ``demos`` entry.
    """
    demos = [
        {**entry, DEMO_FROM_STYLE: os.path.relpath(file, style_dir)}
        for entry, file in zip(payload["demos"], demo_files, strict=True)
    ]
    return {**payload, "demos": demos}


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
    return Style(names, theta, features, raw.get("control_point_rule", "kinematic"), raw, path)


def fit_style(
    demos: Demonstration | Sequence[Demonstration],
    features: FeatureConfig,
    config: IRLConfig | None = None,
    control_point_rule: str = "kinematic",
    demo_paths: Sequence[str] | None = None,
    progress: Callable[[IterationRecord], None] | None = None,
) -> FittedStyle:
    """Learn a style from demonstrations and describe it.

    Args:
        demos: one demonstration or a list (features averaged).
        features: feature configuration.
        config: outer-loop settings.
        control_point_rule: control-point rule of the demonstrations.
        demo_paths: recorded in ``style.json``.
        progress: per-iteration callback (see :meth:`MaxEntIRL.learn`).

    Returns:
        The fitted style: ``.result`` is the learning result, ``.to_json()`` the
        ``style.json`` payload.
    """
    learner = MaxEntIRL(demos, features, config, control_point_rule)
    return FittedStyle.of(learner.learn(progress=progress), learner, demo_paths)
