"""The one episode loop: any policy (SMPC, replayed spline, SB3, scripted) in a drivestyle env.

A policy is a callable ``(env, observation) -> [a, δ]`` in physical units; the loop resets
the env, steps it until it terminates or is truncated, and keeps the observations, the
inputs actually applied (after clipping), the step infos and, on request, rendered frames.
Demonstrations, comparisons and videos all come from :func:`run_episode`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from drivestyle.envs.demonstration import Demonstration

__all__ = ["Episode", "Policy", "run_episode"]

Policy = Callable[[gym.Env, np.ndarray], np.ndarray]
"""(env, raw observation [x, y, φ, v of EV then TV]) → [a, δ] [m/s², rad]."""


@dataclass
class Episode:
    """What one episode produced."""

    observations: np.ndarray
    """Raw observations, reset first, shape (k+1, 8)."""
    inputs: np.ndarray
    """Inputs applied (after clipping), shape (k, 2)."""
    infos: list[dict[str, Any]]
    """The env's info of every step (the reset's info is ``reset_info``)."""
    reset_info: dict[str, Any]
    """The reset's info (``scenario`` among it)."""
    rewards: np.ndarray
    """Rewards of every step, shape (k,)."""
    frames: list[np.ndarray] = field(default_factory=list)
    """Rendered frames (reset frame first) when rendering was requested."""
    terminated: bool = False
    """The episode ended in a collision or off the road."""

    @property
    def n_steps(self) -> int:
        """Number of steps taken."""
        return int(self.inputs.shape[0])

    def to_demonstration(self, meta: dict[str, Any] | None = None) -> Demonstration:
        """The episode as a demonstration (sample times from the scenario's T_s).

        Args:
            meta: metadata; ``scenario`` is added from the reset info when absent.

        Raises:
            ValueError: fewer than 2 steps (a demonstration needs 3 samples).
        """
        if self.n_steps < 2:
            raise ValueError(
                f"the episode ended after {self.n_steps} step(s); a demonstration needs >= 2"
            )
        sc = self.reset_info["scenario"]
        meta = {"scenario": sc.to_dict(), **(meta or {})}
        obs = self.observations
        others = None
        if "vehicles" in self.reset_info:  # traffic: every vehicle in the scene's order
            vehicles = np.stack([self.reset_info["vehicles"], *(i["vehicles"] for i in self.infos)])
            tv, others = vehicles[:, 0], vehicles[:, 1:]
            meta.setdefault("scene", self.reset_info["scene"].to_dict())
        else:
            tv = obs[:, 4:8]
        return Demonstration(
            t=np.arange(obs.shape[0]) * sc.dt,
            ev=obs[:, :4],
            tv=tv,
            u=self.inputs,
            meta=meta,
            others=others,
        )


def run_episode(
    env: gym.Env,
    policy: Policy,
    seed: int | None = None,
    options: dict[str, Any] | None = None,
    render: bool = False,
    max_steps: int | None = None,
    on_reset: Callable[[dict[str, Any]], None] | None = None,
    progress: str | None = None,
) -> Episode:
    """Run ``policy`` in ``env`` for one episode.

    Args:
        env: a drivestyle env (possibly wrapped; ``render_mode="rgb_array"`` to render).
        policy: (env, raw observation) → [a, δ].
        seed: reset seed.
        options: reset options (e.g. ``{"scenario": cfg}``).
        render: collect ``env.render()`` after the reset and after every step.
        max_steps: step cap (default: the scenario's horizon).
        on_reset: called with the reset's info before the first action (e.g. to reset a
            stateful policy to the episode's scenario).
        progress: show a progress bar with this description.

    Returns:
        The episode.
    """
    obs, reset_info = env.reset(seed=seed, options=options)
    if on_reset is not None:
        on_reset(reset_info)
    n = reset_info["scenario"].n_steps if max_steps is None else max_steps
    observations, inputs, infos, rewards = [np.array(obs, float)], [], [], []
    frames = [_rgb_frame(env)] if render else []
    terminated = False
    for _ in tqdm(range(n), desc=progress, disable=progress is None, leave=False):
        u = np.asarray(policy(env, obs), float)
        obs, reward, terminated, truncated, info = env.step(u)
        observations.append(np.array(obs, float))
        inputs.append(np.asarray(info.get("action", u), float))
        infos.append(info)
        rewards.append(float(reward))
        if render:
            frames.append(_rgb_frame(env))
        if terminated or truncated:
            break
    return Episode(
        observations=np.array(observations),
        inputs=np.array(inputs, float).reshape(-1, 2),
        infos=infos,
        reset_info=reset_info,
        rewards=np.array(rewards),
        frames=frames,
        terminated=bool(terminated),
    )


def _rgb_frame(env: gym.Env) -> np.ndarray:
    """``env.render()`` as an RGB array (gymnasium types it as any frame, a list or None)."""
    frame = env.render()
    if not isinstance(frame, np.ndarray):
        raise ValueError(
            f"rendering a rollout needs render_mode='rgb_array', got {env.render_mode!r} "
            f"(render() returned {type(frame).__name__})"
        )
    return frame
