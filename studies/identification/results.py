"""The identification study's typed results: one record per demonstration, their summary.

:func:`~drivestyle.studies.identification.study.evaluate_identification` returns an
:class:`Evaluation`: an :class:`EvaluationRecord` per held-out demonstration (its truth,
every scorer's identification, the path ceiling's answer) and an
:class:`EvaluationSummary` (per scorer accuracy, errors and intervals; pooling; the path
ceiling's accuracy; timing). Each ``to_json()`` keeps ``evaluation.json``'s keys.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.risk_profile import RiskProfile
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER
from drivestyle.irl.identification.result import DemoScores, Identification
from drivestyle.studies.identification.path_ceiling import CeilingRecord

__all__ = [
    "Evaluation",
    "EvaluationRecord",
    "EvaluationSummary",
    "PathCeilingSummary",
    "PooledAccuracy",
    "ScorerSummary",
]


@dataclass(frozen=True)
class EvaluationRecord:
    """One held-out demonstration: its truth and every scorer's identification."""

    risk: float
    """True risk (``meta["risk"]``)."""
    scenario: int | None
    """Index of the held-out scenario (``meta["scenario_index"]``)."""
    grid: bool
    """Whether the true risk is one of the library's grid risks."""
    identify_s: float
    """Wall time of scoring the demonstration [s]."""
    error: str | None = None
    """Why the demonstration was refused (then there are no scores)."""
    scores: DemoScores | None = None
    """Every scorer's scores and the demonstration's flags."""
    by_scorer: Mapping[str, Identification] = field(default_factory=dict)
    """Scorer → identification from this demonstration alone."""
    continuous: bool = False
    """Whether the true risk was drawn from
    :data:`~drivestyle.studies.identification.study.CONTINUOUS_RANGE` (not a midpoint)."""
    ceiling: CeilingRecord | None = None
    """The path ceiling (grid demonstrations of an evaluation with ``ceiling=True``)."""
    profile: RiskProfile | None = field(default=None, repr=False)
    """The risk profile (driver libraries; pooling reuses it)."""
    observed: Demonstration | None = field(default=None, repr=False, compare=False)
    """The demonstration as identified (noise, tracker), driver libraries only."""

    @property
    def ok(self) -> bool:
        """Whether the demonstration was identified."""
        return self.error is None and self.scores is not None

    def estimate(self, scorer: str) -> float:
        """The posterior mode of ``scorer``."""
        return self.by_scorer[scorer].risk_estimate

    def correct(self, scorer: str) -> bool:
        """Whether ``scorer`` found the true risk."""
        return self.estimate(scorer) == self.risk

    @property
    def identifiable(self) -> bool:
        """Whether the path ceiling tells the true risk's neighbours apart (grid only)."""
        return self.ceiling is not None and self.ceiling.identifiable

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``evaluation.json``'s record keys: ``<scorer>_estimate``, …).

        Keys that only some evaluations have are written where they apply: ``continuous``
        (True) for continuous risks, ``ceiling_estimate``, ``ceiling_correct``,
        ``neighbour_gap_m`` and ``identifiable`` with the path ceiling, ``risk_profile``
        for driver libraries.
        """
        rec: dict[str, Any] = {
            "risk": self.risk,
            "scenario": self.scenario,
            "grid": self.grid,
            "identify_s": self.identify_s,
        }
        if not self.ok or self.scores is None:
            return rec | {"error": self.error}
        rec |= self.scores.to_json()
        for s, res in self.by_scorer.items():
            rec |= {
                f"{s}_estimate": res.risk_estimate,
                f"{s}_interpolated": res.risk_interpolated,
                f"{s}_interval": list(res.risk_interval),
                f"{s}_covered": res.covers(self.risk),
            }
        main = DEFAULT_SCORER if DEFAULT_SCORER in self.by_scorer else next(iter(self.by_scorer))
        rec["posterior"] = self.by_scorer[main].to_json()["posterior"]
        if self.continuous:
            rec["continuous"] = True
        if self.ceiling is not None:
            rec |= {
                "ceiling_estimate": self.ceiling.estimate,
                "ceiling_correct": self.ceiling.estimate == self.risk,
                "neighbour_gap_m": self.ceiling.neighbour_gap_m,
                "identifiable": self.ceiling.identifiable,
            }
        if self.profile is not None:
            rec["risk_profile"] = {
                "risks": list(self.profile.risks),
                "ssr": list(self.profile.ssr),
                "n_residuals": self.profile.n_residuals,
                "n_active": self.profile.n_active,
            }
        return rec


@dataclass(frozen=True)
class ScorerSummary:
    """One scorer's accuracy, errors and intervals over the held-out demonstrations."""

    grid_accuracy: float | None
    grid_accuracy_informative: float | None
    """Accuracy among grid demonstrations in which p can matter
    (:attr:`~drivestyle.irl.identification.posterior.DemoScores.constraint_binds`; the name is the
    results' key, older than the verdict's labels)."""
    grid_mae_informative: float | None
    """MAE of the posterior mode on the same demonstrations."""
    grid_accuracy_interactive: float | None
    """Accuracy among grid demonstrations whose trigger fired."""
    between_mae_nearest: float | None
    """MAE of the posterior mode on risks between grid points."""
    between_mae_interpolated: float | None
    """MAE of the posterior mean on risks between grid points."""
    interval_coverage: float | None
    interval_width: float | None
    grid_accuracy_identifiable: float | None = None
    """Accuracy on the grid demonstrations the path ceiling calls identifiable."""
    grid_coverage: float | None = None
    """Interval coverage on the grid demonstrations."""
    continuous_mae_interpolated: float | None = None
    """MAE of the posterior mean on continuous true risks."""
    continuous_coverage: float | None = None
    """Interval coverage on continuous true risks."""
    continuous_interval_width: float | None = None
    """Mean interval width on continuous true risks."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class PathCeilingSummary:
    """The path ceiling's accuracy on the same grid demonstrations (:mod:`.path_ceiling`)."""

    grid_accuracy: float | None
    """On every grid demonstration (ties go to the lower risk)."""
    identifiable_accuracy: float | None
    """On the identifiable ones."""
    n_identifiable: int
    """Grid demonstrations whose neighbouring risks' paths lie ≥ 5 cm away."""
    identifiable_gap_m: float
    """The threshold
    (:data:`~drivestyle.studies.identification.path_ceiling.IDENTIFIABLE_GAP_M`)."""
    tied_fraction: float | None
    """Share of grid demonstrations with another risk's path within 1 cm of the closest."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class PooledAccuracy:
    """Grid accuracy of single demonstrations against pools of one vehicle's."""

    n_pool: int
    n_pools: int
    single_accuracy: float | None
    pooled_accuracy: float | None
    single_interval_width: float | None
    pooled_interval_width: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class EvaluationSummary:
    """Counts, per-scorer summaries, pooling, transfer and timing of an evaluation."""

    n: int
    n_failed: int
    n_grid: int
    n_grid_informative: int
    """Grid demonstrations in which p can matter (``grid_accuracy_informative``'s)."""
    n_between: int
    noise_sigma_m: float
    by_scorer: Mapping[str, ScorerSummary]
    pooled: PooledAccuracy
    transfer_own_risk_best: float | None
    """Share of grid demonstrations whose own risk's styles reproduce them best (rmse_y)."""
    own_style_rmse_y_median_m: float | None
    identify_s_median: float | None
    scorer: str = DEFAULT_SCORER
    """The headline scorer (``likelihood`` for a driver library)."""
    n_continuous: int = 0
    """Demonstrations with continuous true risks (part of ``n_between``)."""
    ceiling: PathCeilingSummary | None = None
    """The path ceiling (``ceiling=True``)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (scorer summaries under their scorer's name)."""
        return {
            "n": self.n,
            "n_failed": self.n_failed,
            "n_grid": self.n_grid,
            "n_grid_informative": self.n_grid_informative,
            "n_between": self.n_between,
            "noise_sigma_m": self.noise_sigma_m,
            **{s: m.to_json() for s, m in self.by_scorer.items()},
            "pooled": self.pooled.to_json(),
            "transfer_own_risk_best": self.transfer_own_risk_best,
            "own_style_rmse_y_median_m": self.own_style_rmse_y_median_m,
            "identify_s_median": self.identify_s_median,
            "scorer": self.scorer,
            "n_continuous": self.n_continuous,
            **({"ceiling": self.ceiling.to_json()} if self.ceiling is not None else {}),
        }


@dataclass(frozen=True)
class Evaluation:
    """An evaluation: one record per demonstration and their summary."""

    records: tuple[EvaluationRecord, ...]
    summary: EvaluationSummary

    @property
    def scorer(self) -> str:
        """The headline scorer."""
        return self.summary.scorer

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"records": [r.to_json() for r in self.records], "summary": self.summary.to_json()}
