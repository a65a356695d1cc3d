"""The observed times a prediction run can use: the one rule of every command that predicts.

:func:`check_observed_times` refuses, before any vehicle is simulated, an observed time no
vehicle of the run can be observed for: not finite or not > 0, not a whole number of the
vehicles' T_s, or not shorter than the longest of them (:class:`VehicleSpan`, per kind of
vehicle: this study's simulated ones, :func:`recorded_spans` of recorded episodes, another
study's).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioRanges
from drivestyle.envs.traffic import TrafficRanges
from drivestyle.envs.units import off_grid

__all__ = [
    "VehicleSpan",
    "check_observed_times",
    "recorded_spans",
]


@dataclass(frozen=True)
class VehicleSpan:
    """How long the vehicles of one kind last, and their T_s: what an observed time needs."""

    kind: str
    """What they are, plural ("simulated ones", "highway-env lane changes"), for messages."""
    dt: float
    """Their T_s [s]: an observed time is a whole number of it."""
    length_s: float
    """The longest one's length [s]: an observed time is shorter."""
    at_most: bool = False
    """Whether their lengths vary (the message says "at most")."""

    def __str__(self) -> str:
        return f"{self.kind} {'at most ' if self.at_most else ''}{self.length_s:g} s"


def _simulated_spans() -> list[VehicleSpan]:
    """The simulated vehicles' demonstrations (both families)."""
    bases = (ScenarioRanges().base, TrafficRanges().single.base)
    return [VehicleSpan("simulated ones", b.dt, b.horizon_s) for b in bases]


def recorded_spans(recorded: Sequence[Demonstration]) -> list[VehicleSpan]:
    """The recorded episodes' spans: one per T_s among them (none without episodes)."""
    by_dt: dict[float, float] = {}
    for d in recorded:
        dt = round(float(d.t[1] - d.t[0]), 9)
        by_dt[dt] = max(by_dt.get(dt, 0.0), float(d.t[-1] - d.t[0]))
    return [VehicleSpan("recorded ones", dt, n, at_most=True) for dt, n in by_dt.items()]


def check_observed_times(
    t_obs: Sequence[float],
    recorded: Sequence[Demonstration] = (),
    simulated: bool = True,
    others: Sequence[VehicleSpan] = (),
) -> tuple[float, ...]:
    """The observed times as a study uses them, refusing times no vehicle can be observed.

    The one rule of every command that predicts after observed times (evaluate-prediction,
    evaluate-out-of-class), checked before any vehicle is simulated.

    Args:
        t_obs: observed times [s] (repeats are dropped: a time counted twice would count
            every vehicle twice in its summary; the caller says so).
        recorded: the run's recorded episodes (raw demonstrations).
        simulated: whether the run has this study's simulated vehicles.
        others: the spans of the run's other vehicles (another study's).

    Returns:
        The distinct times, in the given order.

    Raises:
        ValueError: no time, a time not finite or not > 0, not a whole number of the
            vehicles' T_s (the message names the nearest that are), or not shorter than
            the longest vehicle of the run (nothing would be left to predict for any).
    """
    times: list[float] = []
    for t in (float(v) for v in t_obs):
        if t not in times:
            times.append(t)
    if not times:
        raise ValueError("need at least one observed time")
    bad = [t for t in times if not (np.isfinite(t) and t > 0)]
    if bad:
        raise ValueError(f"observed times must be finite and > 0 s, got {bad}")
    spans = [*(_simulated_spans() if simulated else []), *recorded_spans(recorded), *others]
    if not spans:
        return tuple(times)
    longest = max(s.length_s for s in spans)
    beyond = [t for t in times if t >= longest - 1e-9]
    if beyond:
        lasting: dict[tuple[str, bool], VehicleSpan] = {}  # the longest of each kind
        for span in spans:
            key = (span.kind, span.at_most)
            if key not in lasting or span.length_s > lasting[key].length_s:
                lasting[key] = span
        raise ValueError(
            f"observed time(s) {', '.join(f'{t:g}' for t in beyond)} s: no vehicle of this run "
            "lasts that long, nothing would be left to predict (the "
            f"{' and '.join(map(str, lasting.values()))}); observe less than {longest:g} s"
        )
    for dt in sorted({round(s.dt, 9) for s in spans}):
        for t in times:
            miss = off_grid(t, dt, "the vehicles' T_s")
            if miss:
                raise ValueError(f"observed time {t:g} s {miss}")
    return tuple(times)
