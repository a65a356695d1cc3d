"""drivestyle IRL: learning driving styles from trajectories, and using them.

- :mod:`drivestyle.irl.paper`, the paper's model: quintic-spline trajectories (``spline``),
  the ten reaction-aware features (``features``), the inner problem (``inner``) and ME-IRL
  (``learner``), its styles (``style``) and the style as the env's reward
  (``style_reward``).
- :mod:`drivestyle.irl.driver`, the default style model, a receding-horizon driver on
  :mod:`drivestyle.planning`'s NLP: the model and its closed loop (``driver_style``), its
  planner (``style_planner``), teacher-forced learning (``driver_learning``, ``descent``,
  ``driver_fit``), the risk profile S(p) (``risk_profile``), its cost as the env's reward
  (``driver_cost``).
- :mod:`drivestyle.irl.identification`, identifying styles: libraries (``library``), the
  posterior over the risk (``posterior``; the paper model's ``paper_scorers``), what it
  returns (``result``) and its verdict (``verdict``), online tracking (``online``), many
  vehicles (``mining``, a row ``mined_row``, the run's folder ``mining_output``).
- Here: where the env's ``style=`` finds the learned reward (``reward``), error metrics
  (``metrics``).

Prediction with the styles is a layer of its own above this one, :mod:`drivestyle.prediction`.

The paper model's public names are re-exported here (``from drivestyle.irl import MaxEntIRL``).
"""

from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.features import (
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
from drivestyle.irl.paper.inner import InnerProblem, InnerSolution, InnerSolveError, newton_minimize
from drivestyle.irl.paper.learner import IRLConfig, LearningResult, MaxEntIRL, normalise_theta
from drivestyle.irl.paper.spline import (
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
