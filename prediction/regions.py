"""Prediction regions of the final position and how often they cover it (split conformal).

A method's region (DESIGN §17) is a disc around its predicted final position with radius
rate × the prediction's horizon; the rate is the split-conformal quantile of FDE per second of
horizon over *another* split's records (:func:`region_rates`), so no record a region judges
informed it; :func:`region_coverage` counts how often the regions cover the true final
position (:class:`RegionCheck`). Not the style's *safety* region (the ellipse the planner keeps
others out of, :meth:`~drivestyle.irl.driver.driver_style.DriverStyle.region`).

Per episode kind (:mod:`drivestyle.recorded.kinds`): :func:`kind_region_rates` calibrates
each kind's rate on that kind's calibration records alone — exchangeable with the kind's
records it judges, where the pooled rate mixes kinds whose errors differ — and falls back to
the pooled rate where the kind has fewer than :data:`KIND_MIN_CALIBRATION` records
(:class:`KindRate`, saying so); :func:`kind_region_coverage` judges each record by its kind's
region and reports the coverage per kind, over every kind and over the stop-and-go windows
(:class:`KindRegionCheck`).

A record is a prediction study's record: an object with ``to_json()`` or its
``prediction_eval.json`` row (``set``, ``t_obs_s``, ``horizon_s``, ``fde_m``: method → FDE;
``kind`` and ``stop_and_go``, absent in a run written before the kinds were: a lane change,
not stop-and-go).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from drivestyle.recorded.kinds import ALL_KINDS, EPISODE_KINDS, STOP_AND_GO, kind_in, stop_and_go_in

__all__ = [
    "KIND_MIN_CALIBRATION",
    "REGION_LEVEL",
    "KindRate",
    "KindRegionCheck",
    "RegionCheck",
    "kind_region_coverage",
    "kind_region_rates",
    "record_rows",
    "region_coverage",
    "region_rates",
]

REGION_LEVEL = 0.9
"""The prediction region's nominal coverage."""


class _Record(Protocol):
    """A record that writes its ``prediction_eval.json`` row."""

    def to_json(self) -> dict[str, Any]: ...


@dataclass(frozen=True)
class RegionCheck:
    """A method's 90 % prediction region of the final position, and how often it covered.

    The region is a disc around the method's predicted final position with radius
    ``rate_m_per_s`` × the prediction's horizon: the split-conformal quantile of FDE per
    second of horizon over another split's records (:func:`region_rates`), so no record it
    judges informed it.
    """

    set: str
    t_obs: float
    method: str
    rate_m_per_s: float
    n_calibration: int
    n: int
    coverage: float | None
    """Fraction of this split's records whose final position lies in the region."""
    median_radius_m: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return dict(vars(self))


def record_rows(records: Sequence[_Record | Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The records as ``prediction_eval.json`` rows (an object's ``to_json()``, a row as is)."""
    return [r if isinstance(r, Mapping) else r.to_json() for r in records]


def region_rates(
    records: Sequence[_Record | Mapping[str, Any]], level: float = REGION_LEVEL
) -> dict[tuple[str, float], tuple[float, int]]:
    """Split-conformal radius rates from calibration records.

    Per (method, t_obs): the ⌈(n + 1)·level⌉-th smallest of FDE / horizon over the n
    records (pooled over sets), so that a new exchangeable record's final position falls
    within rate × horizon with probability ≥ ``level``.

    Args:
        records: the calibration split's records (objects or ``prediction_eval.json`` rows).
        level: the nominal coverage, in (0, 1).

    Returns:
        (method, t_obs) → (rate [m/s], n); a (method, t_obs) with too few records for the
        level (⌈(n + 1)·level⌉ > n) is left out.

    Raises:
        ValueError: ``level`` outside (0, 1).
    """
    if not 0 < level < 1:
        raise ValueError(f"the region's level must lie in (0, 1), got {level}")
    out = {}
    for key, vals in _scores(record_rows(records)).items():
        k = math.ceil((len(vals) + 1) * level)
        if k <= len(vals):
            out[key] = (float(np.sort(vals)[k - 1]), len(vals))
    return out


def _scores(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, float], list[float]]:
    """(method, t_obs) → the conformity scores FDE / horizon [m/s] of the rows that have one."""
    scores: dict[tuple[str, float], list[float]] = {}
    for r in rows:
        for method, fde in r["fde_m"].items():
            if fde is not None and math.isfinite(fde) and r["horizon_s"] > 0:
                scores.setdefault((method, float(r["t_obs_s"])), []).append(fde / r["horizon_s"])
    return scores


def region_coverage(
    records: Sequence[_Record | Mapping[str, Any]],
    rates: Mapping[tuple[str, float], tuple[float, int]],
) -> list[RegionCheck]:
    """How often each method's region (:func:`region_rates`) covers the final position.

    Per recorded set and pooled (``recorded``), t_obs and method with a rate.
    """
    judged = record_rows(records)
    sets = sorted({r["set"] for r in judged})
    out = []
    for set_name in [*sets, "recorded"] if len(sets) > 1 else sets:
        sel = [r for r in judged if set_name in (r["set"], "recorded")]
        for (method, t_obs), (rate, n_cal) in sorted(rates.items()):
            here = [r for r in sel if float(r["t_obs_s"]) == t_obs and method in r["fde_m"]]
            inside = [r["fde_m"][method] <= rate * r["horizon_s"] for r in here]
            radii = [rate * r["horizon_s"] for r in here]
            out.append(RegionCheck(
                set_name, t_obs, method, rate, n_cal, len(here),
                float(np.mean(inside)) if here else None,
                float(np.median(radii)) if here else None,
            ))  # fmt: skip
    return out


KIND_MIN_CALIBRATION = 20
"""Calibration records of a kind (at one t_obs, for one method) below which its region takes
the pooled rate. Split conformal covers ≥ 90 % on average over calibration sets whatever
their size n ≥ 9, but the coverage a given calibration set yields is Beta(k, n + 1 − k)
distributed (k = ⌈(n + 1)·0.9⌉): its standard deviation is 9 points at n = 9, 6.5 at n = 19
and 4 at n = 49. Below 20 records a kind's own region would cover anywhere from ~75 % to
100 %: the pooled rate, calibrated on more records but on other kinds too, is the better
guess there."""


@dataclass(frozen=True)
class KindRate:
    """The region's rate for one kind, t_obs and method (:func:`kind_region_rates`)."""

    kind: str
    """A name of :data:`~drivestyle.recorded.kinds.EPISODE_KINDS`."""
    t_obs: float
    method: str
    rate_m_per_s: float
    n_calibration: int
    """The calibration records the rate comes from (the kind's, or every kind's if
    :attr:`pooled`)."""
    n_kind: int
    """The calibration records of this kind."""
    pooled: bool
    """True: the kind had fewer than the minimum (:data:`KIND_MIN_CALIBRATION`), the rate is
    the pooled one."""


def kind_region_rates(
    records: Sequence[_Record | Mapping[str, Any]],
    level: float = REGION_LEVEL,
    min_records: int = KIND_MIN_CALIBRATION,
) -> dict[tuple[str, str, float], KindRate]:
    """Each kind's split-conformal rates, the pooled rate where the kind has too few records.

    Per kind of :data:`~drivestyle.recorded.kinds.EPISODE_KINDS` and each (method, t_obs)
    the pooled calibration (:func:`region_rates` over every record) has: :func:`region_rates`
    over the kind's records alone if it has at least ``min_records`` of them (and enough for
    the level), else the pooled rate (:attr:`KindRate.pooled`). A record without a kind (a
    run written before the kinds were) is a lane change.

    Args:
        records: the calibration split's records (objects or ``prediction_eval.json`` rows).
        level: the nominal coverage, in (0, 1).
        min_records: the fewest calibration records of a kind its own rate is taken from.

    Returns:
        (kind, method, t_obs) → :class:`KindRate`, for every kind.

    Raises:
        ValueError: ``level`` outside (0, 1); a record of an unknown kind.
    """
    rows = record_rows(records)
    pooled = region_rates(rows, level)
    out = {}
    for kind in EPISODE_KINDS:
        own = [r for r in rows if kind_in(r) == kind]
        own_rates, own_scores = region_rates(own, level), _scores(own)
        for (method, t_obs), (rate, n) in pooled.items():
            n_kind = len(own_scores.get((method, t_obs), []))
            if n_kind >= min_records and (method, t_obs) in own_rates:
                out[kind, method, t_obs] = KindRate(
                    kind, t_obs, method, own_rates[method, t_obs][0], n_kind, n_kind, False
                )
            else:
                out[kind, method, t_obs] = KindRate(kind, t_obs, method, rate, n, n_kind, True)
    return out


@dataclass(frozen=True)
class KindRegionCheck:
    """How often the regions of each kind covered, over one kind or a group of kinds.

    Each record is judged by its own kind's region (:func:`kind_region_rates`).
    """

    set: str
    kind: str
    """A name of :data:`~drivestyle.recorded.kinds.EPISODE_KINDS`, or a group of kinds:
    :data:`~drivestyle.recorded.kinds.ALL_KINDS` (every record) or
    :data:`~drivestyle.recorded.kinds.STOP_AND_GO` (the stop-and-go windows)."""
    t_obs: float
    method: str
    calibrated_on: str
    """``kind`` (the kind's own calibration records), ``pooled`` (too few of them: every
    kind's) or, for a group, ``each kind's`` (each record its kind's rate)."""
    rate_m_per_s: float | None
    """The rate (None for a group: one per kind)."""
    n_calibration: int | None
    """The records the rate comes from (None for a group)."""
    n_kind_calibration: int | None
    """The kind's own calibration records (None for a group)."""
    n: int
    coverage: float | None
    """Fraction of this split's records whose final position lies in their region."""
    median_radius_m: float | None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return dict(vars(self))


def kind_region_coverage(
    records: Sequence[_Record | Mapping[str, Any]],
    rates: Mapping[tuple[str, str, float], KindRate],
) -> list[KindRegionCheck]:
    """How often each record's kind's region covers its final position.

    Per set (each recorded set, and ``recorded`` pooling them where there are several), per
    group — each kind present, every kind (``all``) and the stop-and-go windows (if any) —
    and per (method, t_obs) with a rate.
    """
    judged = record_rows(records)
    sets = sorted({r["set"] for r in judged})
    kinds = [k for k in EPISODE_KINDS if any(kind_in(r) == k for r in judged)]
    groups: list[str] = [*kinds, ALL_KINDS]
    groups += [STOP_AND_GO] if any(stop_and_go_in(r) for r in judged) else []
    keys = sorted({(method, t_obs) for _, method, t_obs in rates})
    out = []
    for set_name in [*sets, "recorded"] if len(sets) > 1 else sets:
        in_set = [r for r in judged if set_name in (r["set"], "recorded")]
        for group in groups:
            sel = [r for r in in_set if _in_group(r, group)]
            for method, t_obs in keys:
                here = [r for r in sel if float(r["t_obs_s"]) == t_obs and method in r["fde_m"]]
                radii = [rates[kind_in(r), method, t_obs].rate_m_per_s * r["horizon_s"]
                         for r in here]  # fmt: skip
                inside = [r["fde_m"][method] <= rad for r, rad in zip(here, radii, strict=True)]
                own = rates.get((group, method, t_obs))
                out.append(KindRegionCheck(
                    set_name, group, t_obs, method,
                    "each kind's" if own is None else ("pooled" if own.pooled else "kind"),
                    None if own is None else own.rate_m_per_s,
                    None if own is None else own.n_calibration,
                    None if own is None else own.n_kind,
                    len(here),
                    float(np.mean(inside)) if here else None,
                    float(np.median(radii)) if here else None,
                ))  # fmt: skip
    return out


def _in_group(row: Mapping[str, Any], group: str) -> bool:
    """Whether a record belongs to a kind or a group of kinds."""
    if group == ALL_KINDS:
        return True
    if group == STOP_AND_GO:
        return stop_and_go_in(row)
    return kind_in(row) == group
