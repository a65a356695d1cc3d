"""Observation and action wrappers that make the lane-change env convenient for deep RL.

- :func:`rl_observation` / :class:`RLObservation`: a compact, translation-invariant
  observation ``[y, φ, v, x_TV − x_EV, y_TV, v_TV, t/T]`` (float32) instead of absolute
  positions (x grows without bound along the road, which a normaliser cannot fix) and
  with the episode's progress, which the time-limited learned cost depends on.
- :func:`physical_action` / :class:`NormalisedAction`: actions in [−1, 1]² (float32, as
  stable-baselines3 recommends for continuous actions) mapped linearly onto the
  scenario's [a_min, a_max] × [−δ_max, δ_max].

The same two functions serve training (through the wrappers) and a trained policy acting
on the raw env (``agents.sb3_baseline.SB3Policy``), so both see identical inputs.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import RecordConstructorArgs

__all__ = ["NormalisedAction", "RLObservation", "physical_action", "rl_observation"]


def rl_observation(observation: np.ndarray, k: int, n_steps: int) -> np.ndarray:
    """The RL observation of a raw drivestyle observation.

    Args:
        observation: raw observation [x, y, φ, v] of the EV then the TV, shape (8,).
        k: steps taken in the episode.
        n_steps: the episode's horizon in steps.

    Returns:
        ``[y, φ, v, x_TV − x_EV, y_TV, v_TV, k/n_steps]``, shape (7,), float32.
    """
    ev, tv = observation[:4], observation[4:8]
    progress = min(k / n_steps, 1.0)
    return np.array([ev[1], ev[2], ev[3], tv[0] - ev[0], tv[1], tv[3], progress], np.float32)


def physical_action(a: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Map a normalised action in [−1, 1]² (clipped) to [low, high] [m/s², rad]."""
    a = np.clip(np.asarray(a, float), -1.0, 1.0)
    return low + (a + 1.0) * 0.5 * (high - low)


class RLObservation(gym.ObservationWrapper, RecordConstructorArgs):
    """``[y, φ, v, x_TV − x_EV, y_TV, v_TV, t/T]`` (float32) from a drivestyle env.

    Raises:
        TypeError: ``env`` is not a drivestyle env (8-vector observation, a scenario).
    """

    def __init__(self, env: gym.Env) -> None:
        RecordConstructorArgs.__init__(self)
        gym.ObservationWrapper.__init__(self, env)
        base = env.unwrapped
        if env.observation_space.shape != (8,) or not hasattr(base, "scenario"):
            raise TypeError(
                "RLObservation needs a drivestyle env (observation [x, y, φ, v] of the EV "
                f"and the TV, shape (8,)); got {base!r} with {env.observation_space}"
            )
        inf = np.inf
        self.observation_space = spaces.Box(
            low=np.array([-inf, -inf, 0.0, -inf, -inf, 0.0, 0.0], dtype=np.float32),
            high=np.array([inf, inf, inf, inf, inf, inf, 1.0], dtype=np.float32),
            dtype=np.float32,
        )

    def observation(self, observation: np.ndarray) -> np.ndarray:
        """Map the raw 8-vector to the RL observation."""
        env = self.env.unwrapped
        return rl_observation(observation, env.k, env.scenario.n_steps)


class NormalisedAction(gym.ActionWrapper, RecordConstructorArgs):
    """Actions in [−1, 1]² (float32) for a drivestyle env with physical actions.

    Raises:
        TypeError: ``env``'s action space is not a bounded ``Box(2,)``.
        ValueError: (at ``step``) an action that is not 2 real numbers.
    """

    def __init__(self, env: gym.Env) -> None:
        RecordConstructorArgs.__init__(self)
        gym.ActionWrapper.__init__(self, env)
        space = env.action_space
        if not (
            isinstance(space, spaces.Box)
            and space.shape == (2,)
            and np.all(np.isfinite(space.low))
            and np.all(np.isfinite(space.high))
        ):
            raise TypeError(
                f"NormalisedAction needs a bounded Box(2,) action space [a, δ]; got {space}"
            )
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)

    def action(self, action: Any) -> np.ndarray:
        """[−1, 1]² → [a, δ] in the underlying env's bounds."""
        a = np.asarray(action)
        if a.dtype.kind not in "iuf" or a.size != 2:
            raise ValueError(f"action must be 2 real numbers in [-1, 1], got {action!r}")
        space = self.env.action_space
        action = a.reshape(2)
        return physical_action(action, space.low, space.high)
