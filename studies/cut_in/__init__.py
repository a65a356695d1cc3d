"""The cut-in study: an SMPC ego that predicts a lane changer by CV, its style, or the truth.

- :mod:`.study`: each cut-in scene driven once per predictor; collisions, distance,
  braking, jerk, progress, planning time (``evaluate-planning``, DESIGN §17);
- :mod:`.report`: ``planning.md``;
- :mod:`.figures`: per scene, the ego's braking and distance by predictor.

The study's and the report's names are re-exported here.
"""

from drivestyle.studies.cut_in.report import planning_markdown
from drivestyle.studies.cut_in.study import (
    CUT_IN_RANGES,
    HARD_BRAKING,
    ORACLE_TOLERANCE,
    MethodSummary,
    PlanningStudy,
    SceneRun,
    cut_in_study,
    planning_goals,
    predictor_for,
    run_scene,
    summarise_runs,
)

__all__ = [
    "CUT_IN_RANGES",
    "HARD_BRAKING",
    "ORACLE_TOLERANCE",
    "MethodSummary",
    "PlanningStudy",
    "SceneRun",
    "cut_in_study",
    "planning_goals",
    "planning_markdown",
    "predictor_for",
    "run_scene",
    "summarise_runs",
]
