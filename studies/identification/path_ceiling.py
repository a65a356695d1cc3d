"""The path ceiling: which grid risk's closed-loop path lies closest to a demonstration.

The SMPC(q) path of each grid risk q in a demonstration's own scenario is the held-out
demonstration of q in that scenario (the expert is deterministic, so this is what
:func:`~drivestyle.studies.identification.references.ceiling_identify` re-simulates); the
ceiling's estimate is the closest such path to the demonstration as observed
(:func:`ceiling_records`), and a grid demonstration is *identifiable* when the closed-loop
paths of the true risk's neighbouring grid risks both lie at least
:data:`IDENTIFIABLE_GAP_M` (RMS position distance over the demonstration) from
SMPC(true)'s (:func:`neighbour_gap`). The identification study
(:func:`~drivestyle.studies.identification.study.evaluate_identification` with
``ceiling=True``) reports its accuracy beside the identifier's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration

__all__ = [
    "IDENTIFIABLE_GAP_M",
    "CeilingRecord",
    "ceiling_records",
    "is_identifiable",
    "neighbour_gap",
    "path_distance",
]

IDENTIFIABLE_GAP_M = 0.05
"""A grid demonstration is identifiable when the closed-loop SMPC paths of its true risk's
neighbouring grid risks lie at least this far (RMS position distance) from SMPC(true)'s
(the capacity study's ceiling tells the neighbours apart by ≥ 5 cm, RESULTS §10). RMS, not
max, because it is the ceiling's own distance: two paths that part for one step only are
not told apart."""


def path_distance(a: np.ndarray, b: np.ndarray) -> float:
    """RMS position distance of two paths (n, ≥ 2) over their common length [m].

    The distance :func:`drivestyle.studies.identification.references.ceiling_identify` ranks by.
    """
    n = min(len(a), len(b))
    diff = np.asarray(a)[:n, :2] - np.asarray(b)[:n, :2]
    return float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))


def neighbour_gap(
    paths: Mapping[float, np.ndarray], risk: float, grid: Sequence[float]
) -> float | None:
    """Least distance between SMPC(risk)'s path and its neighbouring grid risks' paths.

    Args:
        paths: grid risk → the SMPC's closed-loop path in one scenario, (n, ≥ 2).
        risk: the true risk (a grid risk).
        grid: the grid risks, increasing.

    Returns:
        min over the (one or two) neighbours q of :func:`path_distance` (SMPC(q),
        SMPC(risk)) [m]; None when ``risk`` is off the grid or a needed path is missing.
    """
    grid = [float(p) for p in grid]
    if risk not in grid or risk not in paths:
        return None
    i = grid.index(risk)
    neighbours = [grid[j] for j in (i - 1, i + 1) if 0 <= j < len(grid)]
    if not neighbours or any(q not in paths for q in neighbours):
        return None
    return min(path_distance(paths[q], paths[risk]) for q in neighbours)


def is_identifiable(gap: float | None, threshold: float = IDENTIFIABLE_GAP_M) -> bool:
    """Whether a neighbour gap (:func:`neighbour_gap`) makes the demonstration identifiable."""
    return gap is not None and gap >= threshold


@dataclass(frozen=True)
class CeilingRecord:
    """The path ceiling's answer for one grid demonstration (module docstring)."""

    distances: Mapping[float, float]
    """Grid risk q → distance of SMPC(q)'s path in the scenario to the observed demo [m]."""
    estimate: float
    """The grid risk with the closest path (the first of equal distances)."""
    neighbour_gap_m: float | None
    """:func:`neighbour_gap` of the true risk (from the true paths, not the observation)."""

    @property
    def identifiable(self) -> bool:
        """Whether the neighbouring risks' paths lie ≥ :data:`IDENTIFIABLE_GAP_M` away."""
        return is_identifiable(self.neighbour_gap_m)

    @property
    def tied(self) -> bool:
        """Whether another grid risk's path lies within 1 cm of the closest."""
        d = np.asarray(list(self.distances.values()))
        return int(np.sum(d <= d.min() + 0.01)) > 1


def ceiling_records(
    demos: Sequence[Demonstration], observed: Sequence[Demonstration | None], grid: set[float]
) -> list[CeilingRecord | None]:
    """The path ceiling of every grid demonstration with a scenario index (else None)."""
    order = sorted(grid)
    paths: dict[Any, dict[float, np.ndarray]] = {}
    for d in demos:
        p, index = float(d.meta["risk"]), d.meta.get("scenario_index")
        if p in grid and index is not None and not d.meta.get("continuous"):
            paths.setdefault(index, {})[p] = d.ev[:, :2]
    out: list[CeilingRecord | None] = []
    for d, seen in zip(demos, observed, strict=True):
        p, index = float(d.meta["risk"]), d.meta.get("scenario_index")
        here = paths.get(index, {})
        if p not in grid or d.meta.get("continuous") or index is None or p not in here:
            out.append(None)
            continue
        xy = (d if seen is None else seen).ev[:, :2]
        dist = {q: path_distance(here[q], xy) for q in order if q in here}
        best = min(dist, key=lambda q: dist[q])
        out.append(CeilingRecord(dist, best, neighbour_gap(here, p, order)))
    return out
