"""drivestyle IRL: quintic-spline trajectories, reaction-aware features and ME-IRL."""

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
