"""drivestyle environments: the simulated world and its data.

The three-lane highway (scenarios, the bicycle dynamics and the inputs that carry one
state to the next, safety geometry, lanes, the Gymnasium envs and their reward models
(``reward_model``), episodes run by any policy (``rollout``), rendering and videos),
demonstrations (simulated or recorded, with the observed states) and their plausibility
(``plausibility``), the physical bounds of road vehicles (``units``)
and a tracker's noise model (``tracking``). Recorded traffic (tracks, readers, episodes,
the shipped samples) is the layer above, :mod:`drivestyle.recorded`.

Importing this package registers the Gymnasium ids (idempotently):

- ``drivestyle/LaneChange-v0``: the paper's scenario; keyword arguments override its
  parameters, e.g. ``gym.make("drivestyle/LaneChange-v0", ev_speed=27, tv_gap=-15)``.
- ``drivestyle/LaneChangeRandom-v0``: a scenario drawn per reset from
  :class:`drivestyle.envs.scenario.ScenarioRanges` with the env's seed.
- ``drivestyle/Traffic-v0``: the lane change among several vehicles
  (:data:`drivestyle.envs.traffic.DEFAULT_TRAFFIC`); ``others=[...]`` and scenario fields
  override it.
- ``drivestyle/TrafficRandom-v0``: traffic scenes drawn per reset from
  :class:`drivestyle.envs.traffic.TrafficRanges` with the env's seed.
- ``drivestyle/CutIn-v0``: the agent controls the vehicle in the target lane while an
  SMPC(p) lane changer of a risk drawn per reset cuts in ahead of it
  (:class:`drivestyle.envs.cut_in.CutInEnv`).
- ``drivestyle/Recorded-v0``: a recorded scene (``episode=``: a recorded demonstration or
  its ``.npz``) with the agent driving one of its vehicles and the others following their
  log or reacting (``others="log" | "idm" | "style"``;
  :class:`drivestyle.envs.recorded_scene.RecordedSceneEnv`).
"""

from __future__ import annotations

import gymnasium as gym

from drivestyle.envs.demonstration import Demonstration, load_demonstration, save_demonstration
from drivestyle.envs.dynamics import bicycle_ode, rk4_step
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.reward_model import task_reward
from drivestyle.envs.safety import ellipse_constraint, elliptical_index
from drivestyle.envs.scenario import PAPER, SCENARIOS, ScenarioConfig, ScenarioRanges, get_scenario

__all__ = [
    "ENV_IDS",
    "PAPER",
    "SCENARIOS",
    "Demonstration",
    "LaneChangeEnv",
    "ScenarioConfig",
    "ScenarioRanges",
    "bicycle_ode",
    "ellipse_constraint",
    "elliptical_index",
    "get_scenario",
    "load_demonstration",
    "register_envs",
    "rk4_step",
    "save_demonstration",
    "task_reward",
]

ENV_IDS = (
    "drivestyle/LaneChange-v0",
    "drivestyle/LaneChangeRandom-v0",
    "drivestyle/Traffic-v0",
    "drivestyle/TrafficRandom-v0",
    "drivestyle/CutIn-v0",
    "drivestyle/Recorded-v0",
)


def register_envs() -> None:
    """Register the drivestyle ids with Gymnasium (no-op if already registered)."""
    entry = "drivestyle.envs.lane_change:LaneChangeEnv"
    if ENV_IDS[0] not in gym.registry:
        gym.register(id=ENV_IDS[0], entry_point=entry, kwargs={"scenario": "paper"})
    if ENV_IDS[1] not in gym.registry:
        gym.register(
            id=ENV_IDS[1], entry_point=entry, kwargs={"scenario": "paper", "randomize": True}
        )
    traffic = "drivestyle.envs.traffic:TrafficEnv"
    if ENV_IDS[2] not in gym.registry:
        gym.register(id=ENV_IDS[2], entry_point=traffic)
    if ENV_IDS[3] not in gym.registry:
        gym.register(id=ENV_IDS[3], entry_point=traffic, kwargs={"randomize": True})
    if ENV_IDS[4] not in gym.registry:
        gym.register(id=ENV_IDS[4], entry_point="drivestyle.envs.cut_in:CutInEnv")
    if ENV_IDS[5] not in gym.registry:
        gym.register(id=ENV_IDS[5], entry_point="drivestyle.envs.recorded_scene:RecordedSceneEnv")


register_envs()
