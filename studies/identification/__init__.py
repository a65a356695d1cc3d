"""The identification study: how well the posterior over the risk finds a known risk.

- :mod:`.study`: held-out demonstrations of known risk (grid, between the grid, continuous)
  identified with every scorer, with noise and pooling (``evaluate-identification``);
- :mod:`.results`: its typed results (records and summaries);
- :mod:`.path_ceiling`: the closest grid risk's path, and which demonstrations are
  identifiable at all;
- :mod:`.references`: the re-simulating ceiling and the k-NN reference (``--references``);
- :mod:`.population`: simulated populations with known risks, the ground truth for mining
  at scale (``simulate-population``);
- :mod:`.report`: ``evaluation.md``;
- :mod:`.figures`: the confusion matrix, the noise curve, one identification's posterior
  and reproduction (``identify-style --plot``).

The names of the study, its results, references, population and report are re-exported
here.
"""

from drivestyle.studies.identification.path_ceiling import (
    IDENTIFIABLE_GAP_M,
    CeilingRecord,
    ceiling_records,
    is_identifiable,
    neighbour_gap,
    path_distance,
)
from drivestyle.studies.identification.population import (
    Population,
    draw_vehicle,
    simulate_population,
)
from drivestyle.studies.identification.references import (
    CeilingResult,
    CeilingSummary,
    KnnSummary,
    References,
    ceiling_identify,
    identification_references,
    knn_baseline,
)
from drivestyle.studies.identification.report import (
    driver_evaluation_markdown,
    evaluation_markdown,
    noise_markdown,
    references_markdown,
)
from drivestyle.studies.identification.results import (
    Evaluation,
    EvaluationRecord,
    EvaluationSummary,
    PathCeilingSummary,
    PooledAccuracy,
    ScorerSummary,
)
from drivestyle.studies.identification.study import (
    CONTINUOUS_RANGE,
    continuous_demonstrations,
    draw_continuous_risks,
    evaluate_identification,
    noise_curve_json,
    pooled_accuracy,
)

__all__ = [
    "CONTINUOUS_RANGE",
    "IDENTIFIABLE_GAP_M",
    "CeilingRecord",
    "CeilingResult",
    "CeilingSummary",
    "Evaluation",
    "EvaluationRecord",
    "EvaluationSummary",
    "KnnSummary",
    "PathCeilingSummary",
    "PooledAccuracy",
    "Population",
    "References",
    "ScorerSummary",
    "ceiling_identify",
    "ceiling_records",
    "continuous_demonstrations",
    "draw_continuous_risks",
    "draw_vehicle",
    "driver_evaluation_markdown",
    "evaluate_identification",
    "evaluation_markdown",
    "identification_references",
    "is_identifiable",
    "knn_baseline",
    "neighbour_gap",
    "noise_curve_json",
    "noise_markdown",
    "path_distance",
    "pooled_accuracy",
    "references_markdown",
    "simulate_population",
]
