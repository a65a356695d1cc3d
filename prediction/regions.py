"""Prediction regions of the final position and how often they cover it (split conformal).

A method's region (DESIGN §17) is a disc around its predicted final position with radius
rate × the prediction's horizon; the rate is the split-conformal quantile of FDE per second of
horizon over *another* split's records (:func:`region_rates`), so no record a region judges
informed it; :func:`region_coverage` counts how often the regions cover the true final
position (:class:`RegionCheck`). Not the style's *safety* region (the ellipse the planner keeps
others out of, :meth:`~drivestyle.irl.driver.driver_style.DriverStyle.region`).

A record is a prediction study's record: an object with ``to_json()`` or its
``prediction_eval.json`` row (``set``, ``t_obs_s``, ``horizon_s``, ``fde_m``: method → FDE).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

__all__ = ["REGION_LEVEL", "RegionCheck", "record_rows", "region_coverage", "region_rates"]

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
    scores: dict[tuple[str, float], list[float]] = {}
    for r in record_rows(records):
        for method, fde in r["fde_m"].items():
            if fde is not None and math.isfinite(fde) and r["horizon_s"] > 0:
                scores.setdefault((method, float(r["t_obs_s"])), []).append(fde / r["horizon_s"])
    out = {}
    for key, vals in scores.items():
        k = math.ceil((len(vals) + 1) * level)
        if k <= len(vals):
            out[key] = (float(np.sort(vals)[k - 1]), len(vals))
    return out


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
