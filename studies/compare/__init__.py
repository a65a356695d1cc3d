"""Driving a learned style, compared: the SMPC it came from, the spline, an RL policy.

- :mod:`.study`: the paper scenario and held-out scenarios (``compare-baseline``), also the
  default style model's closed-loop reproduction;
- :mod:`.deviation`: a TV that deviates from its prediction, closed-loop drivers against
  open-loop plans (``deviating-tv``);
- :mod:`.report`: ``compare.md``;
- :mod:`.figures`: the compared paths and the held-out errors.

The studies' and the report's names are re-exported here.
"""

from drivestyle.studies.compare.deviation import (
    DeviationStudy,
    DriverMeasures,
    deviating_tv_study,
    plan_states,
    write_videos,
)
from drivestyle.studies.compare.report import comparison_markdown
from drivestyle.studies.compare.study import (
    LABELS,
    Comparison,
    HeldoutComparison,
    HeldoutSummary,
    compare_methods,
    heldout_comparison,
    policy_frames,
    rollout_policy,
    state_metrics,
    trajectory_metrics,
)

__all__ = [
    "LABELS",
    "Comparison",
    "DeviationStudy",
    "DriverMeasures",
    "HeldoutComparison",
    "HeldoutSummary",
    "compare_methods",
    "comparison_markdown",
    "deviating_tv_study",
    "heldout_comparison",
    "plan_states",
    "policy_frames",
    "rollout_policy",
    "state_metrics",
    "trajectory_metrics",
    "write_videos",
]
