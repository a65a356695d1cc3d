"""drivestyle IRL: learning driving styles from trajectories, and using them.

- The paper's model: quintic-spline trajectories (``spline``), the ten reaction-aware
  features (``features``), the inner problem (``inner``) and ME-IRL (``learner``), its
  styles (``style``).
- The default style model, a receding-horizon driver on :mod:`drivestyle.planning`'s NLP:
  the model and its closed loop (``driver_style``), teacher-forced learning
  (``driver_learning``), the risk profile S(p) (``risk_profile``).
- Identification: libraries (``library``), the posterior over the risk
  (``identification``), online tracking (``online``), prediction (``forecast``), many
  vehicles (``mining``, ``mining_output``); the learned style as the env's reward
  (``reward``); error metrics (``metrics``).
"""

from drivestyle.irl.features import (
    FEATURE_SETS,
    FEATURES,
    EventTimes,
    FeatureBasis,
    FeatureConfig,
    event_times,
    feature_basis,
    feature_values,
    gauss_legendre_nodes,
)
from drivestyle.irl.inner import InnerProblem, InnerSolution, InnerSolveError, newton_minimize
from drivestyle.irl.learner import IRLConfig, LearningResult, MaxEntIRL, normalise_theta
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.spline import (
    QuinticTrajectory,
    basis_matrix,
    demo_control_points,
    evaluate_quintic,
    quintic_coefficients,
    spline_eval,
)

__all__ = [
    "FEATURES",
    "FEATURE_SETS",
    "EventTimes",
    "FeatureBasis",
    "FeatureConfig",
    "IRLConfig",
    "InnerProblem",
    "InnerSolution",
    "InnerSolveError",
    "LearningResult",
    "MaxEntIRL",
    "QuinticTrajectory",
    "basis_matrix",
    "demo_control_points",
    "evaluate_quintic",
    "event_times",
    "feature_basis",
    "feature_values",
    "gauss_legendre_nodes",
    "newton_minimize",
    "normalise_theta",
    "quintic_coefficients",
    "spline_eval",
    "trajectory_errors",
]
