"""The recorded-traffic study: styles learned from recorded lane changes (NGSIM, CATS).

- :mod:`.study`: the paper model: personal, general (leave-one-out) and constant-velocity
  reproductions of each episode; on CATS the AV against human drivers (``real-traffic``);
- :mod:`.driver_study`: the receding-horizon driver model on the same episodes, personal
  and per vehicle leave-one-out (``real-traffic --model driver``);
- :mod:`.report`: ``real_traffic.md``;
- :mod:`.figures`: one episode's reproductions; driver model against paper model.

The studies' and the report's names are re-exported here.
"""

from drivestyle.recorded.real_data import RECORDED_DELTA_MAX, RECORDED_PHI_MAX
from drivestyle.studies.real_traffic.driver_study import (
    DRIVER_REPRODUCTIONS,
    DriverSettings,
    DriverSplit,
    DriverTrafficStudy,
    driver_demo,
    driver_splits,
    episode_vehicle,
    own_line_shift,
    run_driver_study,
)
from drivestyle.studies.real_traffic.report import driver_traffic_markdown, real_traffic_markdown
from drivestyle.studies.real_traffic.study import (
    REPRODUCTIONS,
    RealTrafficStudy,
    av_vs_hv,
    classify_loo,
    constant_velocity,
    episode_feature_config,
    lane_change_stats,
    learn_general,
    learn_personal,
    reproduce_with,
    run_study,
)

__all__ = [
    "DRIVER_REPRODUCTIONS",
    "RECORDED_DELTA_MAX",
    "RECORDED_PHI_MAX",
    "REPRODUCTIONS",
    "DriverSettings",
    "DriverSplit",
    "DriverTrafficStudy",
    "RealTrafficStudy",
    "av_vs_hv",
    "classify_loo",
    "constant_velocity",
    "driver_demo",
    "driver_splits",
    "driver_traffic_markdown",
    "episode_feature_config",
    "episode_vehicle",
    "lane_change_stats",
    "learn_general",
    "learn_personal",
    "own_line_shift",
    "real_traffic_markdown",
    "reproduce_with",
    "run_driver_study",
    "run_study",
]
