"""Online identification over time: the risk posterior of each simulated vehicle.

:func:`track_vehicle` feeds each simulated demonstration whole to the
:class:`~drivestyle.irl.identification.online.StyleTracker` without its inputs (an observer
does not see them): per vehicle the posterior mean and 90 % interval over time and the first
time the interval is narrower than :data:`NARROW_WIDTH` (:class:`TrackingRecord`);
:func:`summarise_tracking` says how fast it narrows over the vehicles
(:class:`TrackingSummary`); :func:`spanning_tracks` picks the vehicles a figure shows.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.studies.prediction.vehicles import RISK_RANGE

__all__ = [
    "NARROW_WIDTH",
    "TrackingRecord",
    "TrackingSummary",
    "spanning_tracks",
    "summarise_tracking",
    "track_vehicle",
]

NARROW_WIDTH = 0.2
"""Online identification is *narrow* once its 90 % interval is narrower than this."""


@dataclass(frozen=True)
class TrackingRecord:
    """The online posterior of one simulated vehicle over its whole demonstration."""

    vehicle_id: str
    true_risk: float
    t: tuple[float, ...]
    """Sample times [s]."""
    mean: tuple[float, ...]
    """Posterior mean after each sample."""
    lo: tuple[float, ...]
    """Lower end of the 90 % interval after each sample."""
    hi: tuple[float, ...]
    """Upper end."""
    t_narrow: float | None
    """First time the interval is narrower than :data:`NARROW_WIDTH` [s] (None: never)."""
    t_narrow_stays: float | None = None
    """First time from which the interval stays narrower to the end [s] (None: the last
    interval is not narrow)."""
    update_ms: tuple[float, ...] = field(default=(), repr=False)
    """Wall time of each update [ms]."""

    @property
    def covered_at_end(self) -> bool:
        """Whether the final interval holds the true risk."""
        return self.lo[-1] <= self.true_risk <= self.hi[-1]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction_eval.json``'s tracking record)."""
        return {
            "vehicle_id": self.vehicle_id,
            "true_risk": self.true_risk,
            "t_narrow_s": self.t_narrow,
            "t_narrow_stays_s": self.t_narrow_stays,
            "final_mean": self.mean[-1],
            "final_interval": [self.lo[-1], self.hi[-1]],
            "covered_at_end": self.covered_at_end,
            "update_ms_median": float(np.median(self.update_ms)) if self.update_ms else None,
            "t": [round(x, 6) for x in self.t],
            "mean": [round(x, 5) for x in self.mean],
            "lo": list(self.lo),
            "hi": list(self.hi),
        }


def track_vehicle(
    vehicle_id: str, demo: Demonstration, library: DriverLibrary, true_risk: float
) -> TrackingRecord:
    """Feed a demonstration to a fresh tracker, inputs unseen (as ``track_demo(…, False)``).

    The loop is :func:`~drivestyle.irl.identification.online.track_demo`'s, timed per update.
    """
    tracker = StyleTracker(library, demo.scenario)
    vehicles = demo.vehicles
    mean, lo, hi, ms = [], [], [], []
    t_narrow = None
    for k in range(demo.n):
        t0 = time.perf_counter()
        ident = tracker.update(demo.ev[k], vehicles[k])
        ms.append(1e3 * (time.perf_counter() - t0))
        a, b = ident.risk_interval
        mean.append(float(ident.risk_interpolated))
        lo.append(float(a))
        hi.append(float(b))
        if t_narrow is None and b - a < NARROW_WIDTH:
            t_narrow = float(demo.t[k] - demo.t[0])
    narrow = np.asarray(hi) - np.asarray(lo) < NARROW_WIDTH
    wide = np.flatnonzero(~narrow)
    first_stays = 0 if wide.size == 0 else int(wide[-1]) + 1
    return TrackingRecord(
        vehicle_id=vehicle_id,
        true_risk=float(true_risk),
        t=tuple(float(x - demo.t[0]) for x in demo.t),
        mean=tuple(mean),
        lo=tuple(lo),
        hi=tuple(hi),
        t_narrow=t_narrow,
        t_narrow_stays=float(demo.t[first_stays] - demo.t[0]) if first_stays < demo.n else None,
        update_ms=tuple(ms),
    )


@dataclass(frozen=True)
class TrackingSummary:
    """How fast the online interval narrows over the simulated vehicles."""

    n: int
    n_narrow: int
    """Vehicles whose interval ever gets narrower than :data:`NARROW_WIDTH`."""
    fraction_narrow: float | None
    t_narrow_median_s: float | None
    """Median time to narrow, over the vehicles that get there."""
    t_narrow_q10_s: float | None
    t_narrow_q25_s: float | None
    t_narrow_q75_s: float | None
    t_narrow_q90_s: float | None
    n_narrow_stays: int
    """Vehicles whose interval is narrow from some time to the end."""
    t_narrow_stays_median_s: float | None
    """Median time from which the interval stays narrow, over those vehicles."""
    final_coverage: float | None
    """Share of vehicles whose final 90 % interval holds the true risk."""
    final_mae: float | None
    """Mean |posterior mean − true risk| after the last sample."""
    update_ms_median: float | None
    """Median wall time of one update over every vehicle's updates [ms] (parallel workers
    on a shared machine: an upper bound)."""
    update_ms_p95: float | None
    narrow_width: float = NARROW_WIDTH

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _q(values: Sequence[float], q: float) -> float | None:
    return float(np.quantile(values, q)) if len(values) else None


def summarise_tracking(tracks: Sequence[TrackingRecord]) -> TrackingSummary:
    """The :class:`TrackingSummary` of the tracking records."""
    times = [r.t_narrow for r in tracks if r.t_narrow is not None]
    stays = [r.t_narrow_stays for r in tracks if r.t_narrow_stays is not None]
    ms = [x for r in tracks for x in r.update_ms]
    return TrackingSummary(
        n=len(tracks),
        n_narrow=len(times),
        fraction_narrow=len(times) / len(tracks) if tracks else None,
        t_narrow_median_s=_q(times, 0.5),
        t_narrow_q10_s=_q(times, 0.1),
        t_narrow_q25_s=_q(times, 0.25),
        t_narrow_q75_s=_q(times, 0.75),
        t_narrow_q90_s=_q(times, 0.9),
        n_narrow_stays=len(stays),
        t_narrow_stays_median_s=_q(stays, 0.5),
        final_coverage=float(np.mean([r.covered_at_end for r in tracks])) if tracks else None,
        final_mae=float(np.mean([abs(r.mean[-1] - r.true_risk) for r in tracks]))
        if tracks
        else None,
        update_ms_median=_q(ms, 0.5),
        update_ms_p95=_q(ms, 0.95),
    )


def spanning_tracks(tracks: Sequence[TrackingRecord], k: int = 4) -> list[TrackingRecord]:
    """Up to ``k`` vehicles spanning the risk range: nearest to k evenly spaced risks.

    The targets are evenly spaced over :data:`RISK_RANGE`; each picks the vehicle of the
    nearest true risk not picked yet. Returned in increasing risk.
    """
    left = list(tracks)
    out: list[TrackingRecord] = []
    for target in np.linspace(*RISK_RANGE, k):
        if not left:
            break
        best = min(left, key=lambda r: abs(r.true_risk - target))
        left.remove(best)
        out.append(best)
    return sorted(out, key=lambda r: r.true_risk)
