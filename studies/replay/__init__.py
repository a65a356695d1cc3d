"""Recorded scenes replayed with every vehicle reactive: collisions and speeds against the log.

- :mod:`.study`: each episode replayed once in ``drivestyle/Recorded-v0`` (IDM vehicles along
  their log's lateral path, the EV too; or every vehicle driving its identified style);
  collisions in the replay and in the log, speed ranges (``replay-recorded``, DESIGN §24);
- :mod:`.report`: ``replay.md``.

The study's and the report's names are re-exported here.
"""

from drivestyle.studies.replay.report import replay_markdown
from drivestyle.studies.replay.study import (
    IDM_CHOICES,
    OTHERS_CHOICES,
    SPEED_TOLERANCE_MPS,
    Collision,
    EpisodeReplay,
    ReplayStudy,
    VehicleSpeeds,
    collisions,
    folder_episodes,
    idm_parameters,
    replay_episode,
    replay_recorded,
    split_episodes,
)

__all__ = [
    "IDM_CHOICES",
    "OTHERS_CHOICES",
    "SPEED_TOLERANCE_MPS",
    "Collision",
    "EpisodeReplay",
    "ReplayStudy",
    "VehicleSpeeds",
    "collisions",
    "folder_episodes",
    "idm_parameters",
    "replay_episode",
    "replay_markdown",
    "replay_recorded",
    "split_episodes",
]
