"""The prediction study: style-aware prediction against constant velocity (DESIGN §17).

Held-out simulated vehicles and the recorded benchmark's NGSIM/CATS episodes predicted after
1–3 s by every method of :mod:`drivestyle.prediction`, and the online posterior over time:

- :mod:`.study`: the orchestration, :func:`evaluate_prediction` → :class:`PredictionStudy`
  (its seeds and observed times);
- :mod:`.vehicles`: the simulated held-out vehicles (:func:`draw_simulated`);
- :mod:`.records`: one :class:`PredictionRecord` per (vehicle, t_obs)
  (:func:`predict_vehicle`), or a :class:`SkippedPrediction`;
- :mod:`.tracking`: online identification over each simulated demonstration
  (:func:`track_vehicle`, :class:`TrackingSummary`);
- :mod:`.summaries`: the statistics per (set, t_obs, method) with bootstrap intervals over
  vehicles (:func:`summarise_records`), per kind of episode (:func:`summarise_by_kind`),
  each method's FDE relative to CV's (:func:`ratio_stats`) and the goals
  (:func:`goal_checks`);
- :mod:`.runs`: another split's run read back to calibrate the prediction regions
  (:func:`read_prediction_run`, :func:`calibration_records`);
- :mod:`.observed_times`: the observed times a run can use (:func:`check_observed_times`);
- :mod:`.physics_split`: the physics baselines calibrated on the train split
  (:func:`calibrate_on_split`, :func:`calibrate_joint_on_split`);
- :mod:`.report` and :mod:`.figures`: its ``report.md`` and figures.

The recorded benchmark's split and the no-leak view it predicts recorded episodes in are
recorded data (:mod:`drivestyle.recorded.benchmark`, :mod:`drivestyle.recorded.observed`);
the predictors, their errors and regions are :mod:`drivestyle.prediction`'s. The study's
public names are re-exported here.
"""

from drivestyle.studies.prediction.observed_times import (
    VehicleSpan,
    check_observed_times,
    recorded_spans,
)
from drivestyle.studies.prediction.physics_split import (
    calibrate_joint_on_split,
    calibrate_on_split,
    joint_physics_cases,
    physics_cases,
)
from drivestyle.studies.prediction.records import (
    PREDICTION_ERRORS,
    PredictionRecord,
    SkippedPrediction,
    predict_vehicle,
)
from drivestyle.studies.prediction.runs import (
    PredictionRun,
    calibration_records,
    read_prediction_run,
)
from drivestyle.studies.prediction.study import (
    T_OBS,
    TEST_SEED,
    VALIDATION_SEED,
    PredictionStudy,
    evaluate_prediction,
    example_record,
)
from drivestyle.studies.prediction.summaries import (
    BOOTSTRAP_SAMPLES,
    BOOTSTRAP_SEED,
    GOALS,
    RATIO_GOALS,
    RECORDED,
    SIMULATED,
    STYLE_METHODS,
    ErrorStat,
    GoalCheck,
    MethodSummary,
    RatioStat,
    bootstrap_stats,
    goal_checks,
    median_ratios,
    ratio_stats,
    summarise_by_kind,
    summarise_records,
)
from drivestyle.studies.prediction.tracking import (
    NARROW_WIDTH,
    TrackingRecord,
    TrackingSummary,
    spanning_tracks,
    summarise_tracking,
    track_vehicle,
)
from drivestyle.studies.prediction.vehicles import RISK_RANGE, SimulatedVehicle, draw_simulated

__all__ = [
    "BOOTSTRAP_SAMPLES",
    "BOOTSTRAP_SEED",
    "GOALS",
    "NARROW_WIDTH",
    "PREDICTION_ERRORS",
    "RATIO_GOALS",
    "RECORDED",
    "RISK_RANGE",
    "SIMULATED",
    "STYLE_METHODS",
    "TEST_SEED",
    "T_OBS",
    "VALIDATION_SEED",
    "ErrorStat",
    "GoalCheck",
    "MethodSummary",
    "PredictionRecord",
    "PredictionRun",
    "PredictionStudy",
    "RatioStat",
    "SimulatedVehicle",
    "SkippedPrediction",
    "TrackingRecord",
    "TrackingSummary",
    "VehicleSpan",
    "bootstrap_stats",
    "calibrate_joint_on_split",
    "calibrate_on_split",
    "calibration_records",
    "check_observed_times",
    "draw_simulated",
    "evaluate_prediction",
    "example_record",
    "goal_checks",
    "joint_physics_cases",
    "median_ratios",
    "physics_cases",
    "predict_vehicle",
    "ratio_stats",
    "read_prediction_run",
    "recorded_spans",
    "spanning_tracks",
    "summarise_by_kind",
    "summarise_records",
    "summarise_tracking",
    "track_vehicle",
]
