"""Observation and action wrappers that make the lane-change env convenient for deep RL.

- :func:`rl_observation` / :class:`RLObservation`: a compact observation made of
  relative quantities, so that one policy can serve the whole scenario family:
  ``[y − y_target, y − y_initial, φ, v − v_ref, x_TV − x_EV, y_TV − y, v_TV − v, t_left/T]``
  (float32; lane offsets against the target and the initial lane centre, the TV relative
  to the EV, the share of the episode left — the time-limited learned cost depends on it)
  instead of absolute positions (x grows without bound along the road).
- :func:`physical_action` / :class:`NormalisedAction`: actions in [−1, 1]² (float32, as
  stable-baselines3 recommends for continuous actions) mapped linearly onto the
  scenario's [a_min, a_max] × [−δ_max, δ_max]; with ``heading_bound`` the steering is
  further limited so that the next heading stays within the SMPC's bound |φ| ≤ φ_max
  (:func:`heading_steering_limits`): a policy cannot exploit the reward by swinging.

The same two functions serve training (through the wrappers) and a trained policy acting
on the raw env (``drivestyle.agents.sb3_baseline.SB3Policy``), so both see identical inputs.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import RecordConstructorArgs

__all__ = [
    "RL_OBSERVATION_SIZE",
    "NormalisedAction",
    "RLObservation",
    "heading_steering_limits",
    "physical_action",
    "rl_observation",
    "rl_observation_size",
]


RL_OBSERVATION_SIZE = 8
"""Size of the single-TV RL observation; traffic: 4 + 4K + 1 (:func:`rl_observation_size`)."""


def rl_observation_size(raw_size: int) -> int:
    """RL observation size for a raw observation of ``raw_size`` entries (8 or 4 + 5K)."""
    if raw_size == 8:
        return RL_OBSERVATION_SIZE
    if raw_size < 9 or (raw_size - 4) % 5:
        raise ValueError(f"not a drivestyle observation size: {raw_size}")
    return 4 + 4 * ((raw_size - 4) // 5) + 1


def rl_observation(observation: np.ndarray, k: int, scenario: Any) -> np.ndarray:
    """The RL observation of a raw drivestyle observation (module docstring).

    Single TV (raw shape (8,)): ``[y − y_target, y − y_initial, φ, v − v_ref,
    x_TV − x_EV, y_TV − y, v_TV − v, t_left/T]``. Traffic (raw ``EV ++ K × [present, x, y, φ,
    v]``): the same four EV entries, then per slot ``[present, x − x_EV, y − y, v − v]``
    (zeros when absent), then t_left/T.

    Args:
        observation: raw observation.
        k: steps taken in the episode.
        scenario: the episode's :class:`drivestyle.envs.scenario.ScenarioConfig`.

    Returns:
        Float32 vector of :func:`rl_observation_size` entries.
    """
    # Python floats: a training loop calls this every step, and building small arrays costs
    # more than the arithmetic (the same operations as the array form; tests/envs/test_rl.py)
    values = np.asarray(observation, float).reshape(-1).tolist()
    x, y, phi, v = values[:4]
    n_steps, y_ref, y_initial, v_ref = _scenario_constants(scenario)
    left = max(1.0 - k / n_steps, 0.0)
    out = [y - y_ref, y - y_initial, phi, v - v_ref]
    if len(values) == 8:
        out += [values[4] - x, values[5] - y, values[7] - v, left]
        return np.array(out, np.float32)
    for i in range(4, len(values), 5):
        present, ox, oy, _, ov = values[i : i + 5]
        out += [present, ox - x, oy - y, ov - v] if not present < 0.5 else [0.0] * 4
    out.append(left)
    return np.array(out, np.float32)


_CONSTANTS: dict[int, tuple[Any, tuple[float, float, float, float]]] = {}


def _scenario_constants(sc: Any) -> tuple[float, float, float, float]:
    """The scenario's (n_steps, y_target, y_initial, v_ref), cached: its properties build arrays."""
    hit = _CONSTANTS.get(id(sc))
    if hit is not None and hit[0] is sc:
        return hit[1]
    values = (sc.n_steps, float(sc.y_ref), float(sc.lane_centres[sc.ev_lane]), float(sc.v_ref))
    if len(_CONSTANTS) > 1024:  # a random family draws a scenario per episode
        _CONSTANTS.clear()
    _CONSTANTS[id(sc)] = (sc, values)
    return values


def heading_steering_limits(ev: np.ndarray, scenario: Any) -> tuple[float, float]:
    """Steering range that keeps the next heading within [−φ_max, φ_max] [rad].

    From φ_{k+1} ≈ φ_k + T_s (v/l_r) sin β, β = atan(l_r/(l_f + l_r) tan δ) (first order in
    T_s), intersected with [−δ_max, δ_max]; if the heading is already outside the bound,
    the range still turns it back.

    Args:
        ev: EV state [x, y, φ, v].
        scenario: geometry, T_s, φ_max and δ_max.
    """
    sc = scenario
    phi, v = float(ev[2]), max(float(ev[3]), 1e-3)
    scale = sc.l_r / (v * sc.dt)
    # both bounds' sin β, clipped, through one array: numpy's arcsin, tan and arctan (the
    # math module's can round differently)
    sin_beta = [
        min(max(s, -0.99), 0.99) for s in ((-sc.phi_max - phi) * scale, (sc.phi_max - phi) * scale)
    ]
    steer_lo, steer_hi = (
        np.arctan(np.tan(np.arcsin(sin_beta)) * (sc.l_f + sc.l_r) / sc.l_r)
    ).tolist()
    lo = max(-sc.delta_max, steer_lo)
    hi = min(sc.delta_max, steer_hi)
    if lo > hi:  # numerically outside the bound: steer back as hard as allowed
        lo = hi = -sc.delta_max if phi > 0 else sc.delta_max
    return lo, hi


def physical_action(
    a: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    ev: np.ndarray | None = None,
    scenario: Any = None,
) -> np.ndarray:
    """Map a normalised action in [−1, 1]² (clipped) to [low, high] [m/s², rad].

    With ``ev`` and ``scenario`` the steering is then clipped to
    :func:`heading_steering_limits` (the SMPC's heading bound).
    """
    # np.clip and the affine map on floats, element by element
    values = np.asarray(a, float).reshape(-1).tolist()
    low_l, high_l = (
        np.asarray(low, float).reshape(-1).tolist(),
        np.asarray(high, float).reshape(-1).tolist(),
    )
    u = [
        lo + (min(max(x, -1.0), 1.0) + 1.0) * 0.5 * (hi - lo)
        for x, lo, hi in zip(values, low_l, high_l, strict=True)
    ]
    if ev is not None and scenario is not None:
        lo, hi = heading_steering_limits(ev, scenario)
        u[1] = min(max(u[1], lo), hi)
    return np.array(u)


class RLObservation(gym.ObservationWrapper, RecordConstructorArgs):
    """The relative RL observation (:func:`rl_observation`, float32) from a drivestyle env.

    Raises:
        TypeError: ``env`` is not a drivestyle env (8-vector observation, a scenario).
    """

    def __init__(self, env: gym.Env) -> None:
        RecordConstructorArgs.__init__(self)
        gym.ObservationWrapper.__init__(self, env)
        base = env.unwrapped
        shape = env.observation_space.shape
        try:
            size = rl_observation_size(shape[0]) if shape and len(shape) == 1 else None
        except ValueError:
            size = None
        if size is None or not hasattr(base, "scenario"):
            raise TypeError(
                "RLObservation needs a drivestyle env (observation [x, y, φ, v] of the EV and "
                "the TV, shape (8,), or the traffic layout 4 + 5K); got "
                f"{base!r} with {env.observation_space}"
            )
        inf = np.inf
        low = np.full(size, -inf, dtype=np.float32)
        high = np.full(size, inf, dtype=np.float32)
        low[-1], high[-1] = 0.0, 1.0
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float32)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        """Map the raw 8-vector to the RL observation."""
        env = self.env.unwrapped
        if not (hasattr(env, "k") and hasattr(env, "scenario")):  # a gym.Env has neither
            raise TypeError(f"RLObservation needs a drivestyle env (k, scenario), got {env!r}")
        return rl_observation(observation, env.k, env.scenario)


class NormalisedAction(gym.ActionWrapper, RecordConstructorArgs):
    """Actions in [−1, 1]² (float32) for a drivestyle env with physical actions.

    Raises:
        TypeError: ``env``'s action space is not a bounded ``Box(2,)``.
        ValueError: (at ``step``) an action that is not 2 real numbers.
    """

    def __init__(self, env: gym.Env, heading_bound: bool = True) -> None:
        RecordConstructorArgs.__init__(self, heading_bound=heading_bound)
        gym.ActionWrapper.__init__(self, env)
        self.heading_bound = bool(heading_bound)
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
        if not isinstance(space, spaces.Box):  # checked in __init__; gym types it as any Space
            raise TypeError(f"NormalisedAction needs a Box action space [a, δ]; got {space}")
        base = self.env.unwrapped
        if self.heading_bound and hasattr(base, "ev") and hasattr(base, "scenario"):
            return physical_action(a.reshape(2), space.low, space.high, base.ev, base.scenario)
        return physical_action(a.reshape(2), space.low, space.high)
