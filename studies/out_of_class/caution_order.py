"""The out-of-class study's order check: does the identified risk follow the known caution?

Each lane change is identified offline with the library (:func:`identify_episode`: the
posterior mean p, its 90 % interval and the verdict, DESIGN §15); the groups' quartiles
and verdicts are summarised (:func:`group_summaries`); and :func:`order_checks` compares the
known caution rank with the identified p by Spearman's ρ (:func:`spearman`), over the
episodes and over the groups' medians, for every episode, those inside the region and
those in which a chance constraint binds (the goal: ρ ≥ :data:`SPEARMAN_GOAL`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.posterior import identify_driver
from drivestyle.irl.identification.result import Identification
from drivestyle.irl.identification.verdict import recorded_verdict_label

if TYPE_CHECKING:
    from drivestyle.studies.out_of_class.study import OutOfClassEpisode

__all__ = [
    "SPEARMAN_GOAL",
    "EpisodeResult",
    "GroupSummary",
    "OrderCheck",
    "group_summaries",
    "identify_episode",
    "order_checks",
    "order_scopes",
    "spearman",
]

SPEARMAN_GOAL = 0.9
"""The issue's goal: Spearman's ρ between the known caution order and the identified p."""


@dataclass(frozen=True)
class EpisodeResult:
    """The identification of one out-of-class lane change."""

    family: str
    group: str
    caution: float
    episode_id: str
    risk_mean: float
    """Posterior mean p."""
    risk_interval: tuple[float, float]
    """Central 90 % interval."""
    informative: bool
    out_of_class: bool
    enters_region: bool
    residual_floors: float | None
    """Residual RMS at the best risk in the library's noise floors."""
    min_s_e: float | None
    """Closest approach of another vehicle [ellipse units]."""
    constraint_binds: bool

    @property
    def verdict(self) -> str:
        """The identification's label.

        One of :data:`~drivestyle.irl.identification.posterior.VERDICT_LABELS`, derived from the
        flags by the identification's own rule.
        """
        return recorded_verdict_label(
            self.informative, self.out_of_class, self.constraint_binds, self.enters_region
        )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__} | {"verdict": self.verdict}


def identify_episode(ep: OutOfClassEpisode, library: DriverLibrary) -> EpisodeResult:
    """Identify one lane change's p with the library (whole episode, offline)."""
    ident: Identification = identify_driver(ep.demo, library)
    v = ident.verdict
    assert v is not None
    lo, hi = ident.risk_interval
    return EpisodeResult(
        family=ep.family,
        group=ep.group,
        caution=ep.caution,
        episode_id=ep.episode_id,
        risk_mean=float(ident.risk_interpolated),
        risk_interval=(float(lo), float(hi)),
        informative=v.informative,
        out_of_class=v.out_of_class,
        enters_region=v.enters_region,
        residual_floors=v.floors,
        min_s_e=v.min_s_e,
        constraint_binds=v.constraint_binds,
    )


def spearman(
    known: Sequence[float], identified: Sequence[float]
) -> tuple[float | None, float | None]:
    """Spearman's ρ (ties ranked by their mean rank) and its two-sided p-value.

    Returns:
        (ρ, p-value); (None, None) with fewer than 3 pairs or a constant side.
    """
    from scipy.stats import spearmanr

    a, b = np.asarray(known, float), np.asarray(identified, float)
    if a.size != b.size:
        raise ValueError(f"spearman needs equal lengths, got {a.size} and {b.size}")
    if a.size < 3 or np.ptp(a) == 0 or np.ptp(b) == 0:
        return None, None
    res = spearmanr(a, b)
    return float(res.statistic), float(res.pvalue)


@dataclass(frozen=True)
class GroupSummary:
    """A driver class's (or SMPC variant's at one p) identified risks."""

    family: str
    group: str
    caution: float
    n: int
    risk_median: float | None
    risk_q25: float | None
    risk_q75: float | None
    verdicts: dict[str, int]
    """Verdict → count (:attr:`EpisodeResult.verdict`)."""
    n_binds: int = 0
    """Episodes in which a chance constraint binds (the only ones whose p the data can
    move; the others' posterior is the prior, mean 0.745)."""
    min_s_e_median: float | None = None
    """Median closest approach of another vehicle [ellipse units]: an observed caution that
    needs no model (the reference the identified p is read against)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def group_summaries(results: Sequence[EpisodeResult]) -> list[GroupSummary]:
    """Per (family, group, caution): the identified p's quartiles and the verdicts."""
    keys = sorted({(r.family, r.group, r.caution) for r in results},
                  key=lambda k: (k[0], k[1] if k[0] == "smpc" else "", k[2]))  # fmt: skip
    out = []
    for fam, grp, c in keys:
        rs = [r for r in results if (r.family, r.group, r.caution) == (fam, grp, c)]
        p = np.array([r.risk_mean for r in rs])
        counts: dict[str, int] = {}
        for r in rs:
            counts[r.verdict] = counts.get(r.verdict, 0) + 1
        q25, med, q75 = (float(x) for x in np.quantile(p, [0.25, 0.5, 0.75]))
        s_e = [r.min_s_e for r in rs if r.min_s_e is not None]
        out.append(GroupSummary(fam, grp, c, len(rs), med, q25, q75, counts,
                                sum(r.constraint_binds for r in rs),
                                float(np.median(s_e)) if s_e else None))  # fmt: skip
    return out


@dataclass(frozen=True)
class OrderCheck:
    """Spearman's ρ between known caution and identified p over one family (or variant)."""

    scope: str
    """``highway-env``, ``smpc:<variant>`` or ``smpc`` (every variant pooled)."""
    subset: str
    """``all`` episodes, ``in_region`` (without the ``enters_region`` ones) or ``binds``
    (in region, and a chance constraint binds: the episodes the data can inform)."""
    n: int
    rho_episodes: float | None
    """ρ over the episodes."""
    p_value: float | None
    rho_medians: float | None
    """ρ over the groups' (caution levels') median identified p."""
    met: bool
    """ρ over the episodes ≥ :data:`SPEARMAN_GOAL`."""
    rho_min_s_e: float | None = None
    """Reference: ρ between the known caution and the closest approach min s_e over the
    episodes (an observed caution, no model)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _order(scope: str, subset: str, rs: Sequence[EpisodeResult]) -> OrderCheck:
    rho, pv = spearman([r.caution for r in rs], [r.risk_mean for r in rs])
    levels = sorted({r.caution for r in rs})
    med = [float(np.median([r.risk_mean for r in rs if r.caution == c])) for c in levels]
    rho_m, _ = spearman(levels, med)
    have = [r for r in rs if r.min_s_e is not None]
    rho_s, _ = spearman([r.caution for r in have], [float(r.min_s_e or 0.0) for r in have])
    return OrderCheck(scope, subset, len(rs), rho, pv, rho_m,
                      rho is not None and rho >= SPEARMAN_GOAL, rho_s)  # fmt: skip


class _Grouped(Protocol):
    @property
    def family(self) -> str: ...

    @property
    def group(self) -> str: ...


_G = TypeVar("_G", bound=_Grouped)


def order_scopes(items: Sequence[_G]) -> list[tuple[str, list[_G]]]:
    """The scopes an order is checked over: highway-env, each SMPC variant, SMPC pooled.

    Args:
        items: episodes' results (anything with a ``family`` and a ``group``).

    Returns:
        (scope, its items) for each scope that has items, in that order.
    """
    scopes: list[tuple[str, list[_G]]] = []
    hw = [r for r in items if r.family == "highway-env"]
    if hw:
        scopes.append(("highway-env", hw))
    smpc = [r for r in items if r.family == "smpc"]
    for g in dict.fromkeys(r.group for r in smpc):
        scopes.append((f"smpc:{g}", [r for r in smpc if r.group == g]))
    if smpc:
        scopes.append(("smpc", smpc))
    return scopes


def order_checks(results: Sequence[EpisodeResult]) -> list[OrderCheck]:
    """ρ per family, per SMPC variant and SMPC pooled, over each subset of episodes."""
    out = []
    for scope, rs in order_scopes(results):
        out.append(_order(scope, "all", rs))
        inside = [r for r in rs if not r.enters_region]
        out.append(_order(scope, "in_region", inside))
        out.append(_order(scope, "binds", [r for r in inside if r.constraint_binds]))
    return out
