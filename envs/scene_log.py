"""A recorded scene's log in the environment's vehicle order (DESIGN §24).

:class:`SceneLog` holds what ``drivestyle/Recorded-v0``
(:class:`~drivestyle.envs.recorded_scene.RecordedSceneEnv`) and the reactive drivers
(:mod:`drivestyle.envs.reactive`) read of a :class:`~drivestyle.envs.demonstration.Demonstration`:

- **Vehicle order.** Vehicle 0 is the EV, vehicle j ≥ 1 the j-th surrounding vehicle of
  ``demo.vehicles`` (1 the TV, then ``others``): ``states`` has shape (n, 1 + m, 4).
- **Presence.** A surrounding vehicle enters the scene at its first recorded sample (the
  ``observed`` mask; a demonstration without one is observed throughout) and stays from then
  on, beyond its last recorded sample at the extraction's constant velocity; before it, its
  states are the extraction's backward continuation, i.e. taken from its future, and it is
  not in the scene. The EV is present throughout. The phantom TV of an episode without an
  interacting vehicle (``meta["no_interaction"]``: a placeholder 1 km behind, no vehicle) is
  never present.
- **Desired speed** of a reactive vehicle from a start sample s (:func:`desired_speeds`):
  ``factor`` times the 90th percentile of its recorded speeds at samples ≤ s, or, for a
  vehicle that enters after s, its speed at its first recorded sample — never a later one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration, DemonstrationError
from drivestyle.envs.scenario import ScenarioConfig

__all__ = [
    "DT_TOLERANCE",
    "MIN_DESIRED_SPEED",
    "SceneLog",
    "desired_speeds",
    "scene_log",
]

DT_TOLERANCE = 1e-6
"""Relative disagreement allowed between a demonstration's sample spacing and its scenario's
T_s (recorded clocks carry round-off: 0.19999999999708962 s)."""
MIN_DESIRED_SPEED = 1e-3
"""The IDM needs v0 > 0: a vehicle that stood still before the start gets this [m/s]."""


@dataclass(frozen=True)
class SceneLog:
    """A demonstration's vehicles in the environment's order (module docstring)."""

    t: np.ndarray
    """Sample times, shape (n,) [s] (the recording's clock)."""
    states: np.ndarray
    """States [x, y, φ, v] of every vehicle, EV first, shape (n, N, 4), N = 1 + m."""
    present: np.ndarray
    """Whether each vehicle is in the scene at each sample, shape (n, N) bool."""
    observed: np.ndarray
    """Whether each state is a recorded sample, shape (n, N) bool (the EV: all True)."""
    ev_inputs: np.ndarray
    """The EV's recorded (recovered) inputs [a, δ], shape (n − 1, 2)."""
    scenario: ScenarioConfig
    """The episode's scenario (lanes, geometry, bounds, T_s)."""
    episode_id: str
    """``meta["episode_id"]``, or ``""``."""
    default_start: int
    """The sample a replay starts at by default: the end of the episode's observed part
    (``meta["observed_until_s"]``), else 0."""

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def n_vehicles(self) -> int:
        """N: the EV and the surrounding vehicles."""
        return int(self.states.shape[1])

    @property
    def dt(self) -> float:
        """T_s [s]."""
        return float(self.scenario.dt)

    def entry(self, j: int) -> int | None:
        """Vehicle j's first sample in the scene, None if it never is."""
        found = np.flatnonzero(self.present[:, j])
        return int(found[0]) if found.size else None

    def sample_at(self, t: float) -> int:
        """The sample whose time is nearest ``t`` [s] (the drivers' clock)."""
        return int(np.clip(round((t - float(self.t[0])) / self.dt), 0, self.n - 1))

    def scenario_from(self, start: int) -> ScenarioConfig:
        """The scenario of a replay from ``start`` to the log's end (its horizon).

        The start check is off: recorded vehicles may start inside each other's ellipses.
        """
        steps = self.n - 1 - start
        return dataclasses.replace(
            self.scenario, horizon_s=steps * self.scenario.dt, check_start=False
        )

    def check_start(self, start: Any, name: str = "start") -> int:
        """``start`` as a sample index that leaves at least two steps, or a one-line error.

        A scenario has at least two steps (:class:`ScenarioConfig`).

        Raises:
            ValueError: not an integer, or outside 0 … n − 3 (a ValueError for either:
                ``gym.make`` appends its keyword arguments, a whole demonstration, to a
                TypeError's message).
        """
        if not isinstance(start, (int, np.integer)) or isinstance(start, (bool, np.bool_)):
            raise ValueError(f"{name} must be a sample index (an integer), got {start!r}")
        if not 0 <= int(start) <= self.n - 3:
            raise ValueError(
                f"{name} must be a sample index 0 … {self.n - 3} (the episode has {self.n} "
                f"samples and a replay needs two steps), got {start}"
            )
        return int(start)


def _presence(demo: Demonstration) -> tuple[np.ndarray, np.ndarray]:
    """(present, observed) of the surrounding vehicles, shape (n, 1 + m) each."""
    n, m = demo.n, demo.vehicles.shape[1]
    observed = np.ones((n, m), bool) if demo.observed is None else demo.observed.T.copy()
    if demo.meta.get("no_interaction"):
        observed[:, 0] = False  # the phantom TV: a placeholder, no vehicle
    present = np.cumsum(observed, axis=0) > 0
    return present, observed


def scene_log(demo: Demonstration) -> SceneLog:
    """The scene of a demonstration (module docstring).

    Raises:
        DemonstrationError: no valid ``meta["scenario"]``, or samples not T_s apart.
    """
    sc = demo.scenario
    steps = np.diff(demo.t)
    if not np.allclose(steps, sc.dt, rtol=DT_TOLERANCE, atol=0.0):
        worst = float(steps[np.argmax(np.abs(steps - sc.dt))])
        raise DemonstrationError(
            f"its samples must be the scenario's T_s = {sc.dt} s apart to be replayed, "
            f"found a step of {worst:g} s"
        )
    present, observed = _presence(demo)
    n = demo.n
    states = np.concatenate([demo.ev[:, None, :], demo.vehicles], axis=1)
    ones = np.ones((n, 1), bool)
    until = demo.meta.get("observed_until_s")
    start = 0
    if isinstance(until, (int, float)) and math.isfinite(until) and until > 0:
        start = min(round(until / sc.dt), n - 3)
    log = SceneLog(
        t=demo.t.copy(),
        states=states,
        present=np.concatenate([ones, present], axis=1),
        observed=np.concatenate([ones, observed], axis=1),
        ev_inputs=demo.u.copy(),
        scenario=sc,
        episode_id=str(demo.meta.get("episode_id", "")),
        default_start=int(start),
    )
    for a in (log.t, log.states, log.present, log.observed, log.ev_inputs):
        a.setflags(write=False)
    return log


def desired_speeds(log: SceneLog, start: int, factor: float = 1.0) -> np.ndarray:
    """Each vehicle's IDM desired speed v0 for a replay from ``start`` (module docstring).

    Args:
        log: the scene.
        start: the replay's first sample.
        factor: ρ, v0 = ρ · (90th percentile of the recorded speeds at samples ≤ start).

    Returns:
        v0 per vehicle, shape (N,) [m/s], at least :data:`MIN_DESIRED_SPEED`; NaN for a
        vehicle never in the scene.
    """
    v0 = np.full(log.n_vehicles, np.nan)
    for j in range(log.n_vehicles):
        known = np.flatnonzero(log.observed[: start + 1, j])
        if known.size:
            speeds = log.states[known, j, 3]
        else:
            entry = np.flatnonzero(log.observed[:, j])
            if not entry.size:
                continue
            speeds = log.states[entry[:1], j, 3]
        v0[j] = max(factor * float(np.percentile(speeds, 90)), MIN_DESIRED_SPEED)
    return v0
