"""The identification ceiling: an identifier that knows the expert (a reference, not IRL).

For a demonstration in a known scenario, simulate SMPC(p) for every grid risk in that same
scenario and pick the risk whose trajectory is closest (RMS position distance). The
expert is deterministic, so this is as good as identification can get when the expert
and its scenario are known; it cannot be applied to a vehicle whose controller is unknown,
which is what the IRL route is for (docs/RESULTS.md §6).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.identification import DEFAULT_SCORER, StyleLibrary, knn_baseline

from drivestyle.common.io import fmt

__all__ = ["ceiling_identify", "identification_references", "references_markdown"]


def ceiling_identify(demo: Demonstration, risks: Sequence[float]) -> dict[str, Any]:
    """The grid risk whose SMPC trajectory in the demonstration's scenario is closest.

    Args:
        demo: the demonstration (its ``meta["scenario"]`` is simulated).
        risks: candidate risks.

    Returns:
        ``risk_estimate``, ``distances`` (risk → RMS position distance [m]) and
        ``tied`` (risks within 1 cm of the best: the expert drives them identically here).
    """
    dist = {}
    for p in risks:
        sim, _ = generate_demonstration(float(p), demo.scenario, SMPCConfig(risk=float(p)))
        n = min(sim.n, demo.n)
        diff = sim.ev[:n, :2] - demo.ev[:n, :2]
        dist[float(p)] = float(np.sqrt(np.mean(np.sum(diff**2, axis=1))))
    best = min(dist, key=dist.get)
    return {
        "risk_estimate": best,
        "distances": dist,
        "tied": [p for p, d in dist.items() if d <= dist[best] + 0.01],
    }


def identification_references(
    libraries: dict[str, StyleLibrary],
    library_dirs: dict[str, Path],
    demos: Sequence[Demonstration],
    grid: Sequence[float],
) -> dict[str, Any]:
    """The ceiling and a k-NN baseline without IRL on the grid demonstrations.

    Args:
        libraries: feature-set name → library (its training demonstrations are read from
            ``library_dirs[name] / "demos"`` for the k-NN baseline).
        library_dirs: feature-set name → library folder.
        demos: held-out demonstrations with ``meta["risk"]``.
        grid: the grid risks (only their demonstrations are used).

    Returns:
        ``ceiling`` (grid accuracy, share of demonstrations the expert drives identically
        at a neighbouring risk, accuracy on the others) and ``knn_<name>`` per library.
    """
    grid_demos = [d for d in demos if float(d.meta["risk"]) in set(grid)]
    ceiling = [ceiling_identify(d, grid) for d in grid_demos]
    truth = [float(d.meta["risk"]) for d in grid_demos]
    out = {
        "ceiling": {
            "grid_accuracy": float(
                np.mean([c["risk_estimate"] == p for c, p in zip(ceiling, truth, strict=True)])
            ),
            "tied_fraction": float(np.mean([len(c["tied"]) > 1 for c in ceiling])),
            "grid_accuracy_untied": float(
                np.mean(
                    [
                        c["risk_estimate"] == p
                        for c, p in zip(ceiling, truth, strict=True)
                        if len(c["tied"]) == 1
                    ]
                )
            ),
        }
    }
    for name, lib in libraries.items():
        train_files = sorted((Path(library_dirs[name]) / "demos").glob("*.npz"))
        if not train_files:
            continue
        train = [load_demonstration(f) for f in train_files]
        est = knn_baseline(train, grid_demos, lib.features)
        out[f"knn_{name}"] = {
            "grid_accuracy": float(np.mean([e == p for e, p in zip(est, truth, strict=True)])),
            "grid_mae": float(np.mean([abs(e - p) for e, p in zip(est, truth, strict=True)])),
            "n_train": len(train),
        }
    return out


def references_markdown(refs: dict[str, Any], results: dict[str, Any]) -> list[str]:
    """Markdown lines comparing IRL identification with the two references."""
    lines = [
        "## References on the same grid demonstrations",
        "",
        "| method | grid accuracy |",
        "|---|---|",
    ]
    for name, r in results.items():
        lines.append(
            f"| IRL library ({name}, {DEFAULT_SCORER}) | "
            f"{fmt(r['summary'][DEFAULT_SCORER]['grid_accuracy'], 2)} |"
        )
    for key, r in refs.items():
        if key.startswith("knn"):
            lines.append(
                f"| k-NN on features + scenario ({key[4:]}), no IRL | "
                f"{fmt(r['grid_accuracy'], 2)} |"
            )
    c = refs["ceiling"]
    lines.append(
        f"| ceiling: simulate SMPC(p) in the demo's scenario | {fmt(c['grid_accuracy'], 2)} "
        f"({fmt(c['tied_fraction'], 2)} of demos tied with a neighbour; untied "
        f"{fmt(c['grid_accuracy_untied'], 2)}) |"
    )
    return [*lines, ""]
