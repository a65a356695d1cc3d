"""The amortized posterior beside the exact one: typed records and summaries.

:func:`~drivestyle.studies.identification.amortized.evaluate_beside_exact` returns a
:class:`BesideExact`: per noise level an :class:`AmortizedRecord` per demonstration (the
amortized posterior's answer, the exact's beside it as an :class:`ExactAnswer`) and an
:class:`AmortizedSummary` (both posteriors' :class:`EstimatorScores` on the same
demonstrations, their :class:`Agreement`, the other parameters'
:class:`ParameterSummary`), and each noise level's :class:`NoiseCost`. Each ``to_json()``
writes ``evaluation.json``'s ``amortized`` section.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from drivestyle.irl.amortized.simulations import PARAMETERS
from drivestyle.irl.identification.result import INTERVAL_MASS
from drivestyle.studies.prediction.summaries import ErrorStat

__all__ = [
    "Agreement",
    "AmortizedRecord",
    "AmortizedSummary",
    "BesideExact",
    "EstimatorScores",
    "ExactAnswer",
    "NoiseCost",
    "ParameterSummary",
]


@dataclass(frozen=True)
class ExactAnswer:
    """The exact posterior's answer for one demonstration."""

    mean: float
    """Its mean of p (``risk_interpolated``)."""
    interval: tuple[float, float]
    """Its 90 % interval of p."""
    estimate: float
    """Its grid risk (``risk_estimate``)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"mean": self.mean, "interval": list(self.interval), "estimate": self.estimate}


@dataclass(frozen=True)
class AmortizedRecord:
    """One held-out demonstration read by the amortized posterior, the exact's answer beside."""

    risk: float
    """True risk p."""
    scenario: int | None
    """Index of the held-out scenario (the bootstrap's unit)."""
    grid: bool
    """Whether p is a library grid risk (not a midpoint, not continuous)."""
    continuous: bool
    """Whether p was drawn from the continuous range."""
    identifiable: bool
    """Whether the path ceiling tells p's grid neighbours apart (grid only)."""
    mean: tuple[float, ...]
    """Posterior mean of every parameter, in
    :data:`~drivestyle.irl.amortized.simulations.PARAMETERS`' order (risk first)."""
    lo: tuple[float, ...]
    """Lower end of each parameter's central 90 % interval."""
    hi: tuple[float, ...]
    """Upper end."""
    estimate: float
    """The library risk whose cell holds most of the draws (the exact's rule)."""
    identify_s: float
    """Time of the series and the draws, one torch thread [s]."""
    expert: tuple[float | None, ...]
    """The SMPC expert's parameters in this demonstration's scenario (risk p); None where
    it has none (τ)."""
    exact: ExactAnswer | None
    """The exact posterior's answer (None: it refused the demonstration)."""
    exact_identify_s: float
    """The exact's time for this demonstration (its record's, refusals too) [s]."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (per-parameter values by name)."""
        out = asdict(self)
        for key in ("mean", "lo", "hi", "expert"):
            out[key] = dict(zip(PARAMETERS, getattr(self, key), strict=True))
        out["exact"] = None if self.exact is None else self.exact.to_json()
        return out


@dataclass(frozen=True)
class EstimatorScores:
    """One posterior's identification of p on a set of demonstrations."""

    n: int
    """Demonstrations."""
    risk_error: ErrorStat | None
    """|posterior mean − p|: mean and median with bootstrap 95 % intervals (scenarios)."""
    coverage: float | None
    """Share of p inside the 90 % interval."""
    interval_width: float | None
    """Mean width of the 90 % interval."""
    grid_accuracy: float | None
    """Share of grid demonstrations whose grid risk is p."""
    identifiable_accuracy: float | None
    """The same on the identifiable grid demonstrations."""
    continuous_mae: float | None
    """Mean |posterior mean − p| on the continuous risks."""
    identify_ms_median: float | None
    """Median time per episode [ms]."""
    identify_ms_p95: float | None
    """95th percentile [ms]."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        out = asdict(self)
        out["risk_error"] = None if self.risk_error is None else self.risk_error.to_json()
        return out


@dataclass(frozen=True)
class Agreement:
    """How near the amortized posterior's mean of p is to the exact's, demonstration by one."""

    n: int
    mae: float | None
    """Mean |amortized mean − exact mean|."""
    median: float | None
    """Median of the same."""
    max: float | None
    """Largest."""
    correlation: float | None
    """Pearson correlation of the two means (None: fewer than 2 or one constant)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class ParameterSummary:
    """One parameter's amortized posterior means on SMPC drivers, against the expert's value."""

    name: str
    low: float
    """The estimator's box."""
    high: float
    mean: float
    """Mean over demonstrations of the posterior mean."""
    median: float
    """Their median."""
    box_position: float
    """(mean − low) / (high − low): where in the prior's box it sits (0: low end)."""
    expert_mean: float | None
    """Mean over demonstrations of the expert's value (None: it has none,
    :data:`~drivestyle.studies.identification.amortized.NO_TRUTH`)."""
    mae: float | None
    """Mean |posterior mean − expert's value|."""
    mae_relative: float | None
    """The same over the box's width."""
    centre_mae_relative: float | None
    """Mean |box centre − expert's value| over the box's width: what a posterior that learnt
    nothing of the parameter would err by, roughly (the prior's mean for a uniform prior)."""
    coverage: float | None
    """Share of the expert's values inside the 90 % interval."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class AmortizedSummary:
    """Both posteriors at one noise level, on the demonstrations both identified."""

    noise_sigma_m: float
    n: int
    """Demonstrations read by the amortized posterior."""
    n_exact_refused: int
    """Of them, refused by the exact (left out of every comparison)."""
    n_identifiable: int
    """Identifiable grid demonstrations among the compared."""
    amortized: EstimatorScores
    exact: EstimatorScores
    agreement: Agreement
    parameters: tuple[ParameterSummary, ...]
    """Every parameter but p."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "noise_sigma_m": self.noise_sigma_m,
            "n": self.n,
            "n_exact_refused": self.n_exact_refused,
            "n_identifiable": self.n_identifiable,
            "amortized": self.amortized.to_json(),
            "exact": self.exact.to_json(),
            "agreement": self.agreement.to_json(),
            "parameters": {p.name: p.to_json() for p in self.parameters},
        }


@dataclass(frozen=True)
class NoiseCost:
    """What a noise level costs each posterior against the first level."""

    noise_sigma_m: float
    baseline_sigma_m: float
    exact_identifiable_points: float | None
    """100 × (identifiable accuracy here − at the baseline): negative is a loss."""
    amortized_identifiable_points: float | None
    exact_grid_points: float | None
    """The same for the whole grid."""
    amortized_grid_points: float | None
    exact_mae_change: float | None
    """Mean risk error here − at the baseline: positive is a loss."""
    amortized_mae_change: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return asdict(self)


@dataclass(frozen=True)
class BesideExact:
    """The amortized posterior beside the exact one at every noise level."""

    posterior: str
    """The estimator file."""
    samples: int
    """Draws per demonstration."""
    low: tuple[float, ...]
    """The estimator's box."""
    high: tuple[float, ...]
    records: tuple[tuple[AmortizedRecord, ...], ...]
    """Per noise level, one record per demonstration."""
    summaries: tuple[AmortizedSummary, ...]
    """Per noise level."""
    noise_cost: tuple[NoiseCost, ...]
    """Per noise level after the first."""

    def to_json(self) -> dict[str, Any]:
        """``evaluation.json``'s ``amortized`` section (the records: the first noise level's)."""
        return {
            "posterior": self.posterior,
            "samples": self.samples,
            "level": INTERVAL_MASS,
            "parameters": list(PARAMETERS),
            "box": {"low": list(self.low), "high": list(self.high)},
            "by_noise": [s.to_json() for s in self.summaries],
            "noise_cost": [c.to_json() for c in self.noise_cost],
            "records": [r.to_json() for r in self.records[0]] if self.records else [],
        }
