"""What identification returns, and the checks every posterior makes before it answers.

:class:`Identification` is one vehicle's identified risk with its uncertainty (the keys of
``identify.json``), built from :class:`DemoScores`, each demonstration's scores and flags, by
either posterior: the driver library's continuous one
(:func:`drivestyle.irl.identification.posterior.driver_posterior`) or the paper model's
scorers (:func:`drivestyle.irl.identification.paper_scorers.summarise`). Both refuse a
demonstration of another kind (:func:`check_identifiable`) and never output a posterior that
is not finite (:func:`check_finite`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.identification.library import LibraryError
from drivestyle.irl.identification.verdict import Verdict
from drivestyle.irl.paper.learner import check_learnable

__all__ = [
    "INTERVAL_MASS",
    "DemoScores",
    "Identification",
    "check_finite",
    "check_identifiable",
]

INTERVAL_MASS = 0.9
"""Posterior mass of the reported risk interval."""


@dataclass(frozen=True)
class DemoScores:
    """Every scorer's score of every library risk on one demonstration (lower is better)."""

    scores: Mapping[str, tuple[float, ...]]
    """Scorer → score per library risk (the median over the risk's nearest members)."""
    constraint_binds: bool
    """Whether p can matter in this demonstration: a chance constraint binds at some step
    (driver libraries,
    :func:`~drivestyle.irl.identification.posterior.constraint_binds`), or the TV came within
    s_e < :data:`~drivestyle.irl.identification.verdict.S_E_INFORMATIVE` (paper model). A
    fact of the demonstration, not a verdict (:attr:`Verdict.label`)."""
    min_s_e: float
    """Closest approach of the TV in ellipse units."""
    trigger_fired: bool
    """Whether the reaction trigger fired (the reactive features are active)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``scores`` as lists over the library's risks)."""
        return {
            "scores": {s: list(v) for s, v in self.scores.items()},
            "constraint_binds": self.constraint_binds,
            "min_s_e": self.min_s_e,
            "trigger_fired": self.trigger_fired,
        }


@dataclass(frozen=True)
class Identification:
    """One vehicle's identified risk with its uncertainty (``identify.json``)."""

    scorer: str
    """The scorer the posterior is built from."""
    risks: tuple[float, ...]
    """The library's risks (the posterior's support)."""
    posterior: tuple[float, ...]
    """Posterior probability of each library risk (sums to 1)."""
    risk_estimate: float
    """Posterior mode."""
    risk_interpolated: float
    """Posterior mean (for risks between the library's)."""
    risk_interval: tuple[float, float]
    """Span [lo, hi] of the smallest set of risks holding :attr:`interval_mass`."""
    ranking: tuple[float, ...]
    """Library risks by decreasing posterior."""
    per_demo: tuple[DemoScores, ...]
    """Each demonstration's scores and flags (they pool into the posterior)."""
    true_risks: tuple[float | None, ...] = ()
    """Each demonstration's true risk where its metadata holds one (else None)."""
    interval_mass: float = INTERVAL_MASS
    """Posterior mass of :attr:`risk_interval`."""
    density_risks: tuple[float, ...] = ()
    """Grid of the continuous posterior over p (driver libraries; empty otherwise)."""
    density: tuple[float, ...] = ()
    """Posterior mass at each of :attr:`density_risks` (sums to 1)."""
    verdict: Verdict | None = None
    """What the data added and whether the style fits (:class:`Verdict`; set by
    :func:`~drivestyle.irl.identification.paper_scorers.summarise` and
    :func:`~drivestyle.irl.identification.posterior.driver_posterior`)."""

    @property
    def risk_mode(self) -> float:
        """The posterior's mode (its density's argmax; else :attr:`risk_estimate`).

        Driver libraries have a density on a fine grid; a paper-model library's mode is
        the library risk of the largest mass. A library's risks are a coarse grid: a
        posterior peaked halfway between two of them gives its mass to one of them, which
        can lie outside the 90 % interval; the density's argmax cannot.
        """
        if self.density:
            return float(self.density_risks[int(np.argmax(self.density))])
        return self.risk_estimate

    @property
    def informative(self) -> bool:
        """Whether the identified risk says something (:attr:`Verdict.informative`).

        False without a verdict.
        """
        return self.verdict is not None and self.verdict.informative

    @property
    def label(self) -> str | None:
        """The verdict's label (:attr:`Verdict.label`; None without a verdict)."""
        return None if self.verdict is None else self.verdict.label

    @property
    def out_of_class(self) -> bool:
        """Whether the style does not describe the driver (:attr:`Verdict.out_of_class`)."""
        return self.verdict is not None and self.verdict.out_of_class

    @property
    def reason(self) -> str:
        """Why the verdict is what it is, one line (:attr:`Verdict.reason`)."""
        return "" if self.verdict is None else self.verdict.reason

    @property
    def trigger_fired(self) -> bool:
        """Whether the trigger fired in any demonstration."""
        return any(d.trigger_fired for d in self.per_demo)

    @property
    def posterior_by_risk(self) -> dict[float, float]:
        """Risk → posterior probability."""
        return dict(zip(self.risks, self.posterior, strict=True))

    def mean_scores(self, scorer: str | None = None) -> dict[float, float]:
        """Risk → score of ``scorer`` (default: this one), averaged over the demonstrations."""
        s = scorer or self.scorer
        return {
            p: float(np.mean([d.scores[s][i] for d in self.per_demo]))
            for i, p in enumerate(self.risks)
        }

    def covers(self, risk: float) -> bool:
        """Whether ``risk`` lies in :attr:`risk_interval` (to round-off)."""
        lo, hi = self.risk_interval
        return lo - 1e-9 <= risk <= hi + 1e-9

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict with ``identify.json``'s keys (risks as strings)."""
        all_scores = {
            s: {str(p): v for p, v in self.mean_scores(s).items()} for s in self.per_demo[0].scores
        }
        return {
            "scorer": self.scorer,
            "risk_estimate": self.risk_estimate,
            "risk_mode": self.risk_mode,
            "risk_interpolated": self.risk_interpolated,
            "risk_interval": list(self.risk_interval),
            "interval_mass": self.interval_mass,
            "posterior": {str(p): q for p, q in zip(self.risks, self.posterior, strict=True)},
            "informative": self.informative,
            **(self.verdict.to_json() if self.verdict is not None else {}),
            "constraint_binds_per_demo": [d.constraint_binds for d in self.per_demo],
            "min_s_e_per_demo": [d.min_s_e for d in self.per_demo],
            "scores": all_scores[self.scorer],
            "all_scores": all_scores,
            "ranking": list(self.ranking),
            "n_demos": len(self.per_demo),
            "trigger_fired": self.trigger_fired,
            "trigger_fired_per_demo": [d.trigger_fired for d in self.per_demo],
            "true_risk": list(self.true_risks),
            **(
                {
                    "posterior_density": {
                        "risks": list(self.density_risks),
                        "mass": list(self.density),
                    }
                }
                if self.density
                else {}
            ),
        }


def check_identifiable(demo: Demonstration) -> None:
    """The demonstration must be a lane change next to a TV (what the library knows)."""
    try:
        check_learnable(demo)
    except ValueError as exc:
        raise LibraryError(f"cannot identify this demonstration: {exc}") from None
    tv_moves = np.ptp(demo.tv[:, 0]) > 0 or np.ptp(demo.tv[:, 1]) > 0
    if not tv_moves and np.all(demo.tv[:, 3] == 0):
        raise LibraryError(
            "the demonstration has no target vehicle (TV never moves); the "
            "library's styles are of lane changes next to a TV"
        )


def check_finite(log_lik: np.ndarray, what: str) -> None:
    """Refuse a log-likelihood that would make the posterior NaN (never output NaN).

    Raises:
        LibraryError: ℓ is NaN somewhere, or +inf or −inf everywhere (no risk is possible).
    """
    if np.isnan(log_lik).any() or not np.isfinite(np.max(log_lik)):
        raise LibraryError(
            f"the posterior over the risk is not finite ({what}): the log-likelihood is "
            f"{'NaN' if np.isnan(log_lik).any() else 'infinite'}; check the library's "
            "temperature and the demonstrations"
        )
