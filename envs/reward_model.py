"""The environment's reward: the task reward and the plug-in point of other rewards.

Every env of the family rewards a step by :func:`task_reward` unless it is given a
:class:`RewardModel` — any object with its ``reset``/``step``/``crash_penalty`` interface
(``reward=``), or a learned style's (``style=``), found through the entry-point group
:data:`REWARD_PLUGINS` (:func:`style_reward_model`) so that the env package never imports
the learning package.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Any, Protocol

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig

__all__ = [
    "COLLISION_PENALTY",
    "REWARD_PLUGINS",
    "RewardModel",
    "check_reward_model",
    "style_reward_model",
    "task_reward",
]

COLLISION_PENALTY = 10.0
"""Reward lost on a collision or on leaving the road (the episode then terminates)."""


REWARD_PLUGINS = "drivestyle.rewards"
"""Entry-point group of reward models that ``style=`` resolves (the ``style`` entry)."""


class RewardModel(Protocol):
    """A reward computed from the growing trajectory (e.g. a learned style's cost).

    The env calls ``reset`` at every reset and ``step`` after every step; on a crash it
    also subtracts ``crash_penalty``.
    """

    crash_penalty: float

    def reset(
        self,
        scenario: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        others: np.ndarray | None = None,
    ) -> None:
        """Start a trajectory at the episode's first sample."""

    def step(
        self,
        u: np.ndarray,
        ev: np.ndarray,
        tv: np.ndarray,
        dt: float,
        others: np.ndarray | None = None,
    ) -> tuple[float, np.ndarray]:
        """Add a sample; return (reward, per-feature increment).

        In traffic (:class:`drivestyle.envs.traffic.TrafficEnv`) ``reset`` and ``step`` also receive
        ``others``: the further vehicles' states, shape (m, 4); the single-TV env passes none.
        """


def style_reward_model(style: Any) -> RewardModel:
    """The reward model of a learned style, through the ``drivestyle.rewards`` plugin.

    The env package does not import the learning package (layering ``envs ← irl``); the
    learned reward registers itself as the entry point ``style`` of the group
    :data:`REWARD_PLUGINS` in the distribution's metadata (``pyproject.toml``), which is
    how ``gym.make(id, style=...)`` composes the two.

    Args:
        style: a ``style.json`` path (or its folder) or a loaded style.

    Raises:
        RuntimeError: no reward plugin is installed (install the project with pip).
    """
    found = entry_points(group=REWARD_PLUGINS, name="style")
    if not found:
        raise RuntimeError(
            "style= needs the learned-reward plugin 'style' of the entry-point group "
            f"{REWARD_PLUGINS!r}; install the project (pip install -e .) or pass reward="
        )
    return next(iter(found)).load()(style)


def check_reward_model(reward: Any) -> None:
    """Raise a TypeError naming ``reward=`` unless it has the :class:`RewardModel` API."""
    missing = [name for name in ("reset", "step") if not callable(getattr(reward, name, None))]
    if not hasattr(reward, "crash_penalty"):
        missing.append("crash_penalty")
    if missing:
        raise TypeError(
            f"reward must be a RewardModel (reset(), step(), crash_penalty); "
            f"{type(reward).__name__} lacks {missing}"
        )


def task_reward(ev: np.ndarray, sc: ScenarioConfig, crashed: bool) -> float:
    """Default task reward of one step, evaluated at the EV's new state.

    r = −[((y − y_ref)/w_lane)² + ((v − v_ref)/10 m/s)²] − 10·[collision or off-road].

    Args:
        ev: EV state after the step [x, y, φ, v].
        sc: the scenario (target lane centre, v_ref, lane width).
        crashed: the step ended in a collision or off the road.

    Returns:
        The reward [-].
    """
    lane_err = (ev[1] - sc.y_ref) / sc.lane_width
    speed_err = (ev[3] - sc.v_ref) / 10.0
    return float(-(lane_err**2 + speed_err**2) - COLLISION_PENALTY * crashed)
