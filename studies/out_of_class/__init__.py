"""Drivers outside the style class: do identification and prediction still order them?

- :mod:`.study`: the lane changes of highway-env IDM + MOBIL drivers
  (:mod:`drivestyle.agents.highway_drivers`) and of SMPC drivers of another class, their
  prediction against constant velocity, the study (``evaluate-out-of-class``);
- :mod:`.caution_order`: each lane change identified, and the identified risk against the
  known caution order (Spearman's ρ);
- :mod:`.amortized`: the lane changes on the amortized posterior and its caution orders
  (``--posterior``);
- :mod:`.report`: ``out_of_class.md``.

The study's, the order check's and the report's names are re-exported here; the
highway-env simulator's are :mod:`drivestyle.agents.highway_drivers`'.
"""

from drivestyle.studies.out_of_class.caution_order import (
    SPEARMAN_GOAL,
    EpisodeResult,
    GroupSummary,
    OrderCheck,
    group_summaries,
    identify_episode,
    order_checks,
    spearman,
)
from drivestyle.studies.out_of_class.report import amortized_markdown, out_of_class_markdown
from drivestyle.studies.out_of_class.study import (
    FDE_GOAL,
    HIGHWAY_EXTRACTION,
    SMPC_VARIANTS,
    STYLE_METHODS,
    T_OBS,
    FdeGoal,
    OutOfClassEpisode,
    OutOfClassStudy,
    SMPCVariant,
    StudyConfig,
    fde_goals,
    highway_episodes,
    predict_episode,
    run_study,
    smpc_episodes,
    vehicle_spans,
)

__all__ = [
    "FDE_GOAL",
    "HIGHWAY_EXTRACTION",
    "SMPC_VARIANTS",
    "SPEARMAN_GOAL",
    "STYLE_METHODS",
    "T_OBS",
    "EpisodeResult",
    "FdeGoal",
    "GroupSummary",
    "OrderCheck",
    "OutOfClassEpisode",
    "OutOfClassStudy",
    "SMPCVariant",
    "StudyConfig",
    "amortized_markdown",
    "fde_goals",
    "group_summaries",
    "highway_episodes",
    "identify_episode",
    "order_checks",
    "out_of_class_markdown",
    "predict_episode",
    "run_study",
    "smpc_episodes",
    "spearman",
    "vehicle_spans",
]
