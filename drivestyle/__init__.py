"""drivestyle: identify the driving style of an automated vehicle from its trajectories.

One installable root with its layers, each importing only those before it:

- :mod:`drivestyle.common`: infrastructure (atomic files, the process pool, CLI helpers);
- :mod:`drivestyle.envs`: the simulated world and its data (Gymnasium envs,
  demonstrations, the physical bounds of road vehicles);
- :mod:`drivestyle.recorded`: recorded traffic (tracks, readers, lane-change episodes,
  the shipped samples);
- :mod:`drivestyle.planning`: the receding-horizon planner every driver and style solves;
- :mod:`drivestyle.irl`: learning styles from trajectories (splines, features, ME-IRL,
  style libraries, identification, the learned reward);
- :mod:`drivestyle.agents`: drivers (the SMPC expert, the style-aware ego, SB3 policies,
  highway-env's IDM + MOBIL drivers);
- :mod:`drivestyle.studies`: the evaluations that combine the layers before it, each study
  a sub-package with its report and figures;
- :mod:`drivestyle.scripts`: the command-line entry points (``drivestyle --help``).

Importing ``drivestyle`` registers the Gymnasium ids (``drivestyle/LaneChange-v0`` and
the others in :data:`drivestyle.envs.ENV_IDS`).
"""

from __future__ import annotations

from drivestyle.envs import ENV_IDS, register_envs

__all__ = ["ENV_IDS", "__version__", "register_envs"]

__version__ = "0.2.0"
