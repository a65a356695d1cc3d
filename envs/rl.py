"""Wrappers that make the lane-change env convenient for deep RL (stable-baselines3).

- :class:`RLObservation`: a compact, translation-invariant observation
  ``[y, φ, v, x_TV − x_EV, y_TV, v_TV, t/T]`` instead of absolute positions (x grows
  without bound along the road, which a normaliser cannot fix) and with the episode's
  progress, which the time-limited learned cost depends on.
- :func:`make_rl_env`: env → learned reward → RL observation → actions rescaled to
  [−1, 1] (SB3's recommendation for continuous actions).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.wrappers import RescaleAction

from envs.lane_change import LaneChangeEnv
from envs.scenario import ScenarioConfig
from envs.style_reward import LearnedStyleReward

__all__ = ["RLObservation", "make_rl_env"]


class RLObservation(gym.ObservationWrapper):
    """``[y, φ, v, x_TV − x_EV, y_TV, v_TV, t/T]`` (float32) from a drivestyle env."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        inf = np.inf
        self.observation_space = spaces.Box(
            low=np.array([-inf, -inf, 0.0, -inf, -inf, 0.0, 0.0], dtype=np.float32),
            high=np.array([inf, inf, inf, inf, inf, inf, 1.0], dtype=np.float32),
            dtype=np.float32,
        )

    def observation(self, observation: np.ndarray) -> np.ndarray:
        """Map the raw 8-vector to the RL observation."""
        env = self.env.unwrapped
        ev, tv = observation[:4], observation[4:]
        progress = min(env.k / env.scenario.n_steps, 1.0)
        return np.array(
            [ev[1], ev[2], ev[3], tv[0] - ev[0], tv[1], tv[3], progress], dtype=np.float32
        )


def make_rl_env(
    style: Any,
    scenario: str | ScenarioConfig = "paper",
    randomize: bool = False,
    monitor_file: str | Path | None = None,
    render_mode: str | None = None,
    crash_penalty: float | None = None,
    **overrides: Any,
) -> gym.Env:
    """The RL training env: learned reward, RL observation, actions in [−1, 1].

    Args:
        style: ``style.json`` path or loaded :class:`irl.style.Style`.
        scenario: scenario name or config.
        randomize: draw scenarios per reset (``LaneChangeRandom``).
        monitor_file: write SB3 ``Monitor`` episode statistics to this CSV (the Monitor
            wrapper is always added when stable-baselines3 is installed).
        render_mode: passed to the env.
        crash_penalty: see :class:`envs.style_reward.StyleReward`.
        **overrides: scenario overrides.

    Returns:
        The wrapped env.
    """
    env: gym.Env = LaneChangeEnv(
        scenario=scenario, randomize=randomize, render_mode=render_mode, **overrides
    )
    env = LearnedStyleReward(env, style, crash_penalty)
    try:
        from stable_baselines3.common.monitor import Monitor
    except ImportError:  # the rl extra is optional for everything but training
        Monitor = None
    if Monitor is not None:
        env = Monitor(
            env,
            None if monitor_file is None else str(monitor_file),
            info_keywords=("collision", "off_road"),
        )
    env = RLObservation(env)
    return RescaleAction(env, -1.0, 1.0)
