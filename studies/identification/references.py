"""The identification study's references: the ceiling that knows the expert, and k-NN.

The ceiling (:func:`ceiling_identify`) is an identifier that knows the expert (a reference,
not IRL): for a demonstration in a known scenario, simulate SMPC(p) for every grid risk in
that same scenario and pick the risk whose trajectory is closest (RMS position distance).
The expert is deterministic, so this is as good as identification can get when the expert
and its scenario are known; it cannot be applied to a vehicle whose controller is unknown,
which is what the IRL route is for (docs/RESULTS.md §6).

The other reference, :func:`knn_baseline`, is supervised and without IRL: the k nearest
training demonstrations by feature values and scenario. :func:`identification_references`
runs both on the identification study's grid demonstrations (``evaluate-identification
--references``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.identification.library import StyleLibrary
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.inner import InnerProblem

__all__ = [
    "CeilingResult",
    "CeilingSummary",
    "KnnSummary",
    "References",
    "ceiling_identify",
    "identification_references",
    "knn_baseline",
]


@dataclass(frozen=True)
class CeilingResult:
    """The ceiling's answer for one demonstration."""

    risk_estimate: float
    """The grid risk whose SMPC trajectory is closest."""
    distances: Mapping[float, float]
    """Risk → RMS position distance of its SMPC trajectory to the demonstration [m]."""
    tied: tuple[float, ...]
    """Risks within 1 cm of the best (the expert drives them identically here)."""


@dataclass(frozen=True)
class CeilingSummary:
    """The ceiling on the grid demonstrations."""

    grid_accuracy: float
    tied_fraction: float
    """Share of demonstrations the expert drives identically at another risk."""
    grid_accuracy_untied: float | None
    """Accuracy on the others (None: every demonstration is tied)."""


@dataclass(frozen=True)
class KnnSummary:
    """The k-NN reference of one feature set on the grid demonstrations."""

    grid_accuracy: float
    grid_mae: float
    n_train: int
    """Training demonstrations (the library's own)."""


@dataclass(frozen=True)
class References:
    """The two references of the identification evaluation."""

    ceiling: CeilingSummary
    knn: Mapping[str, KnnSummary]
    """Feature-set name → k-NN on that library's training demonstrations."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict: ``ceiling`` and ``knn_<feature set>``."""
        return {
            "ceiling": asdict(self.ceiling),
            **{f"knn_{name}": asdict(k) for name, k in self.knn.items()},
        }


def ceiling_identify(demo: Demonstration, risks: Sequence[float]) -> CeilingResult:
    """The grid risk whose SMPC trajectory in the demonstration's scenario is closest.

    Args:
        demo: the demonstration (its ``meta["scenario"]`` is simulated).
        risks: candidate risks.
    """
    dist = {}
    for p in risks:
        sim, _ = generate_demonstration(float(p), demo.scenario, SMPCConfig(risk=float(p)))
        n = min(sim.n, demo.n)
        diff = sim.ev[:n, :2] - demo.ev[:n, :2]
        dist[float(p)] = float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
    best = min(dist, key=lambda p: dist[p])
    return CeilingResult(
        risk_estimate=best,
        distances=dist,
        tied=tuple(p for p, d in dist.items() if d <= dist[best] + 0.01),
    )


def knn_baseline(
    train: Sequence[Demonstration],
    test: Sequence[Demonstration],
    features: FeatureConfig | None = None,
    k: int = 3,
) -> list[float]:
    """A supervised reference without IRL: k-nearest neighbours on features and scenario.

    Each demonstration is described by its scaled feature values Ω f(r_D) and its scenario
    (EV speed, TV speed, TV gap), each column standardised on the training set; a test
    demonstration gets the median true risk of its k nearest training demonstrations.

    Args:
        train: demonstrations with ``meta["risk"]`` (e.g. the library's own).
        test: demonstrations to classify.
        features: feature configuration (default: the reactive set).
        k: neighbours.

    Returns:
        The estimated risk of each test demonstration.
    """
    fc = features or FeatureConfig()

    def describe(d: Demonstration) -> np.ndarray:
        sc = d.scenario
        return np.concatenate([InnerProblem(d, fc).f_demo, [sc.ev_speed, sc.tv_speed, sc.tv_gap]])

    X = np.array([describe(d) for d in train])
    y = np.array([float(d.meta["risk"]) for d in train])
    mu, sd = X.mean(0), X.std(0) + 1e-9
    Xs = (X - mu) / sd
    out = []
    for d in test:
        dist = np.linalg.norm(Xs - (describe(d) - mu) / sd, axis=1)
        out.append(float(np.median(y[np.argsort(dist)[:k]])))
    return out


def identification_references(
    libraries: Mapping[str, StyleLibrary],
    library_dirs: Mapping[str, Path],
    demos: Sequence[Demonstration],
    grid: Sequence[float],
) -> References:
    """The ceiling and a k-NN baseline without IRL on the grid demonstrations.

    Args:
        libraries: feature-set name → library (its training demonstrations are read from
            ``library_dirs[name] / "demos"`` for the k-NN baseline; a library without them
            gets no k-NN).
        library_dirs: feature-set name → library folder.
        demos: held-out demonstrations with ``meta["risk"]``.
        grid: the grid risks (only their demonstrations are used).
    """
    grid_demos = [d for d in demos if float(d.meta["risk"]) in set(grid)]
    ceiling = [ceiling_identify(d, grid) for d in grid_demos]
    truth = [float(d.meta["risk"]) for d in grid_demos]
    hits = [c.risk_estimate == p for c, p in zip(ceiling, truth, strict=True)]
    untied = [h for h, c in zip(hits, ceiling, strict=True) if len(c.tied) == 1]
    knn = {}
    for name, lib in libraries.items():
        train_files = sorted((Path(library_dirs[name]) / "demos").glob("*.npz"))
        if not train_files:
            continue
        train = [load_demonstration(f) for f in train_files]
        est = knn_baseline(train, grid_demos, lib.features)
        knn[name] = KnnSummary(
            grid_accuracy=float(np.mean([e == p for e, p in zip(est, truth, strict=True)])),
            grid_mae=float(np.mean([abs(e - p) for e, p in zip(est, truth, strict=True)])),
            n_train=len(train),
        )
    return References(
        ceiling=CeilingSummary(
            grid_accuracy=float(np.mean(hits)),
            tied_fraction=float(np.mean([len(c.tied) > 1 for c in ceiling])),
            grid_accuracy_untied=float(np.mean(untied)) if untied else None,
        ),
        knn=knn,
    )
