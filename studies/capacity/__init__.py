"""The capacity study: how well a style model class's *best* parameters reproduce a driver.

- :mod:`.study`: each reproduction class fitted to one SMPC(p) driver's demonstrations,
  scored in-sample and held out, beside the models' learners (``capacity-study``);
- :mod:`.nelder_mead`: the derivative-free search the fits use (an evaluation budget,
  restarts);
- :mod:`.report`: ``capacity.md``.

The study's, the search's and the report's names are re-exported here.
"""

from drivestyle.studies.capacity.nelder_mead import NelderMeadResult, nelder_mead
from drivestyle.studies.capacity.report import capacity_markdown
from drivestyle.studies.capacity.study import (
    CLASSES,
    LABELS,
    TEST_SEED,
    TRAIN_SEED,
    X_WEIGHT,
    CapacityError,
    CapacityStudy,
    ClassResult,
    RiskCapacity,
    capacity_of_risk,
    capacity_study,
    reproduction_score,
)

__all__ = [
    "CLASSES",
    "LABELS",
    "TEST_SEED",
    "TRAIN_SEED",
    "X_WEIGHT",
    "CapacityError",
    "CapacityStudy",
    "ClassResult",
    "NelderMeadResult",
    "RiskCapacity",
    "capacity_markdown",
    "capacity_of_risk",
    "capacity_study",
    "nelder_mead",
    "reproduction_score",
]
