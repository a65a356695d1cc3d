"""Headless rollout videos (mp4 through imageio-ffmpeg, or gif), recorded scenes' included."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.rollout import Policy, run_episode

__all__ = ["SCENE_POLICIES", "record_policy", "record_scene", "record_states", "write_video"]

SCENE_POLICIES = ("replay", "idm", "style")
"""How the agent of a recorded scene drives in :func:`record_scene`: its recorded inputs
(:func:`~drivestyle.envs.recorded_scene.replay_log`), the reactive vehicles' IDM
(:func:`~drivestyle.envs.recorded_scene.drive_idm`) or its own driver of ``others="style"``
(:func:`~drivestyle.envs.recorded_scene.drive_style`: with ``posterior=``, its identified
style)."""


def write_video(frames: list[np.ndarray], path: str | Path, fps: int = 5) -> Path:
    """Write RGB frames as ``.mp4`` (H.264) or ``.gif`` (by the path's suffix).

    Args:
        frames: (H, W, 3) uint8 frames.
        path: output file.
        fps: frames per second (5 = real time at T_s = 0.2 s).

    Returns:
        The path written.
    """
    import imageio.v2 as imageio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".gif":
        # a list of ArrayLike for imageio's annotation (list is invariant)
        imageio.mimsave(path, list(frames), duration=1000 / fps, loop=0)
    elif path.suffix.lower() == ".mp4":
        # not `with get_writer(...) as writer`: imageio's stub types __enter__ as the base
        # class, which lacks append_data (it returns the writer itself)
        writer = imageio.get_writer(
            path, fps=fps, codec="libx264", macro_block_size=1, ffmpeg_log_level="error"
        )
        with writer:
            for f in frames:
                writer.append_data(f)
    else:
        raise ValueError(f"video must end in .mp4 or .gif, got {path.name}")
    return path


def record_policy(
    env: LaneChangeEnv, policy: Policy, seed: int = 0, options: dict | None = None
) -> tuple[list[np.ndarray], list]:
    """Run a policy for one episode and collect the rendered frames (env in rgb_array mode).

    Args:
        env: the env, created with ``render_mode="rgb_array"``.
        policy: (env, raw observation) → [a, δ].
        seed: reset seed.
        options: reset options.

    Returns:
        (frames: reset frame + one per step, infos per step).
    """
    episode = run_episode(env, policy, seed, options, render=True)
    return episode.frames, episode.infos


def record_states(
    env: LaneChangeEnv, ev_states: np.ndarray, tv_states: np.ndarray
) -> list[np.ndarray]:
    """Replay given EV and TV states exactly (e.g. a spline reproduction) and render them.

    Args:
        env: the env in ``rgb_array`` mode (supplies scenario and drawing).
        ev_states: EV states [x, y, φ, v] per sample, shape (n, 4).
        tv_states: TV states per sample, shape (n, 4).

    Returns:
        One frame per sample.
    """
    env.reset(seed=0)
    frames = []
    for k, (ev, tv) in enumerate(zip(ev_states, tv_states, strict=True)):
        env.ev, env.tv, env.k = np.asarray(ev, float), np.asarray(tv, float), k
        frame = env.render()
        if frame is None:  # render_mode None or "human": nothing to record
            raise ValueError(
                f"record_states needs an env with render_mode='rgb_array', got {env.render_mode!r}"
            )
        frames.append(frame)
    return frames


def record_scene(
    episode: Demonstration | str | Path,
    policy: str = "replay",
    agent: int = 0,
    others: str = "log",
    **kwargs: Any,
) -> list[np.ndarray]:
    """Render a replay of a recorded scene (``drivestyle/Recorded-v0``) from its default start.

    Args:
        episode: a recorded demonstration or its ``.npz``.
        policy: one of :data:`SCENE_POLICIES`: how the agent drives.
        agent: the agent's vehicle (0 the EV).
        others: ``"log"``, ``"idm"`` or ``"style"`` (:class:`RecordedSceneEnv`).
        **kwargs: further arguments of :class:`RecordedSceneEnv` (``start``, ``idm``,
            ``posterior``, …).

    Returns:
        One frame per sample, the start's first.

    Raises:
        ValueError: an unknown policy; the env's errors for the other arguments.
    """
    from drivestyle.envs.recorded_scene import (
        RecordedSceneEnv,
        drive_idm,
        drive_style,
        replay_log,
    )

    policies: dict[str, Policy] = {"replay": replay_log, "idm": drive_idm, "style": drive_style}
    if policy not in policies:
        raise ValueError(f"policy must be one of {SCENE_POLICIES}, got {policy!r}")
    env = RecordedSceneEnv(episode, agent, others, render_mode="rgb_array", **kwargs)
    try:
        return record_policy(env, policies[policy])[0]
    finally:
        env.close()
