"""drivestyle recorded data: tracks of real traffic and the episodes drawn from them.

The layer directly above :mod:`drivestyle.envs` (the simulated world): it reads what others
recorded and turns it into that world's demonstrations. The one road frame of recorded tracks
(``tracks``), the readers' checks of every format (``track_checks``), readers of published
formats (``readers``, one module per format), lane-change episodes from them (``episodes``,
with ``extraction_config``, ``lane_changes``, ``resampling``, ``episode_scenario`` and
``episode_files``; their kinds, ``kinds``), which states of an episode were observed and the
no-leak view of it after t_obs (``observed``) and the shipped NGSIM/CATS samples' loaders and
the one view of a recorded episode (``real_data``), the recorded benchmark's split by vehicle
(``benchmark``). The physical bounds every reader checks are :mod:`drivestyle.envs.units` (the
scenario and a demonstration's plausibility share them); a tracker's simulated noise is
:mod:`drivestyle.envs.tracking`.
"""
