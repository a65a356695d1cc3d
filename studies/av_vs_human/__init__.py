"""The automated car against human drivers in the CATS field test.

- :mod:`.study`: identified risk and observed caution per lane change, medians with
  bootstrap intervals per group, the AV's differences (``compare-av-human``);
- :mod:`.amortized`: the lane changes' amortized posteriors, the AV told apart from the
  humans by them (AUROC) and their consistency across runs (``--posterior``);
- :mod:`.report`: ``av_vs_human.md``;
- :mod:`.figures`: each quantity's lane changes per group.

The study's and the report's names are re-exported here.
"""

from drivestyle.studies.av_vs_human.report import amortized_markdown, av_human_markdown
from drivestyle.studies.av_vs_human.study import (
    AV_VEHICLE,
    BOOTSTRAP_SAMPLES,
    BOOTSTRAP_SEED,
    GROUPS,
    MIN_LANE_CHANGES,
    NEAR_M,
    NEEDED_COLUMNS,
    NOT_MINED,
    QUANTITIES,
    SAME_CAR_HUMAN,
    AVHumanComparison,
    Difference,
    EpisodeCaution,
    GroupStat,
    MinedRow,
    closest_distance,
    compare_av_human,
    episode_caution,
    group_of,
    read_mined,
    time_gaps,
    unmined,
)

__all__ = [
    "AV_VEHICLE",
    "BOOTSTRAP_SAMPLES",
    "BOOTSTRAP_SEED",
    "GROUPS",
    "MIN_LANE_CHANGES",
    "NEAR_M",
    "NEEDED_COLUMNS",
    "NOT_MINED",
    "QUANTITIES",
    "SAME_CAR_HUMAN",
    "AVHumanComparison",
    "Difference",
    "EpisodeCaution",
    "GroupStat",
    "MinedRow",
    "amortized_markdown",
    "av_human_markdown",
    "closest_distance",
    "compare_av_human",
    "episode_caution",
    "group_of",
    "read_mined",
    "time_gaps",
    "unmined",
]
