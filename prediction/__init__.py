"""drivestyle prediction: a vehicle's path after t_obs, from what an observer has seen of it.

A layer of its own between the learners (:mod:`drivestyle.irl`, whose styles and online
posterior the style predictors use) and the drivers (:mod:`drivestyle.agents`, whose
style-aware planner re-plans with the online predictors' path). DESIGN §17.

- :mod:`.protocol`: what every method of :data:`METHODS` is — a :class:`Predictor` takes an
  :class:`Observation` (the vehicle's and its neighbours' samples 0 … k, nothing later) and
  a horizon and returns a :class:`PredictedPath`; :class:`ForecastError`.
- The predictors, one per method of :data:`METHODS`:

  - ``cv`` :class:`ConstantVelocity`, ``ca`` :class:`ConstantAcceleration`
    (:mod:`.kinematic`);
  - ``physics`` :class:`PhysicsBaseline`: IDM behind the observed leader plus a quintic
    lane change (:mod:`.physics`), calibrated by :mod:`.physics_calibration`
    (:data:`PHYSICS_FILE`, the shipped calibration);
  - ``joint_physics`` :class:`JointPhysicsBaseline`: IDM and MOBIL for every observed
    vehicle, rolled out together (:mod:`.joint_physics`), calibrated by
    :mod:`.joint_physics_calibration` (:data:`JOINT_PHYSICS_FILE`);
  - the style predictors (:mod:`.style`): ``population`` (one style for every vehicle),
    ``mode`` (the online posterior's mode) and ``oracle`` (the vehicle's true style), each a
    :class:`StyleRollout`; ``mixture`` :class:`PosteriorMixture` (the rollouts averaged
    with the posterior's mass).

- :mod:`.online`: the online predictors of a vehicle cutting in, fed one step at a time (an
  :class:`OnlinePredictor`: reset per episode, then the path over the horizon at every
  step) — :class:`ConstantVelocityPredictor`, :class:`StylePredictor` (the style identified
  online) and :class:`OraclePredictor` (the true style); the style-aware ego
  (:class:`~drivestyle.agents.aware_planner.AwareSMPC`) plans around their path.
- :mod:`.methods`: :func:`predict` runs every method by name
  (:func:`~drivestyle.prediction.methods.method_predictors`) and scores it
  (:class:`Prediction` of :class:`MethodPrediction`); :func:`predict_demo` is the
  benchmark's prediction of one demonstration (a recorded episode through the no-leak view,
  :mod:`drivestyle.recorded.observed`).
- :mod:`.errors`: ADE and FDE and their lateral and longitudinal parts.
- :mod:`.regions`: split-conformal prediction regions of the final position and their
  coverage.

The study that evaluates them is :mod:`drivestyle.studies.prediction`.
"""

from drivestyle.prediction.errors import ERROR_METRICS, displacement_errors, error_parts
from drivestyle.prediction.joint_physics import (
    JointPhysicsBaseline,
    JointPhysicsParams,
    joint_physics_forecast,
)
from drivestyle.prediction.joint_physics_calibration import (
    JOINT_PHYSICS_FILE,
    calibrate_joint_physics,
    load_joint_params,
)
from drivestyle.prediction.kinematic import (
    ConstantAcceleration,
    ConstantVelocity,
    constant_acceleration,
    constant_velocity,
)
from drivestyle.prediction.methods import (
    METHODS,
    MethodPrediction,
    Prediction,
    predict,
    predict_demo,
)
from drivestyle.prediction.online import (
    ConstantVelocityPredictor,
    OnlinePredictor,
    OraclePredictor,
    StylePredictor,
)
from drivestyle.prediction.physics import PhysicsBaseline, PhysicsParams, physics_forecast
from drivestyle.prediction.physics_calibration import PHYSICS_FILE, calibrate_physics, load_params
from drivestyle.prediction.protocol import ForecastError, Observation, PredictedPath, Predictor
from drivestyle.prediction.regions import RegionCheck, region_coverage, region_rates
from drivestyle.prediction.style import (
    PosteriorMixture,
    StyleRollout,
    oracle_style,
    population_style,
    style_rollout,
)

__all__ = [
    "ERROR_METRICS",
    "JOINT_PHYSICS_FILE",
    "METHODS",
    "PHYSICS_FILE",
    "ConstantAcceleration",
    "ConstantVelocity",
    "ConstantVelocityPredictor",
    "ForecastError",
    "JointPhysicsBaseline",
    "JointPhysicsParams",
    "MethodPrediction",
    "Observation",
    "OnlinePredictor",
    "OraclePredictor",
    "PhysicsBaseline",
    "PhysicsParams",
    "PosteriorMixture",
    "PredictedPath",
    "Prediction",
    "Predictor",
    "RegionCheck",
    "StylePredictor",
    "StyleRollout",
    "calibrate_joint_physics",
    "calibrate_physics",
    "constant_acceleration",
    "constant_velocity",
    "displacement_errors",
    "error_parts",
    "joint_physics_forecast",
    "load_joint_params",
    "load_params",
    "oracle_style",
    "physics_forecast",
    "population_style",
    "predict",
    "predict_demo",
    "region_coverage",
    "region_rates",
    "style_rollout",
]
