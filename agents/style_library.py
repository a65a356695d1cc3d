"""Building style libraries from SMPC demonstrations, and evaluating identification.

Scenarios come from the ``LaneChangeRandom`` family; a scenario is *interactive* when the
SMPC at the probe risk (default: the library's lowest p) enters the λ-ellipse, i.e. the
trigger fires. The same K interactive scenarios serve every risk level, so the styles
differ only by p. More conservative SMPCs often never trigger in them (they keep their
distance); their reactive features are then inactive, which is itself part of the style.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from agents.rollout import generate_demonstration
from agents.smpc import SMPCConfig
from envs.demonstration import Demonstration, save_demonstration
from envs.scenario import ScenarioConfig, ScenarioRanges
from irl.features import FeatureConfig
from irl.learner import IRLConfig, MaxEntIRL
from irl.library import SCORERS, StyleLibrary, identify_all

__all__ = ["build_library", "draw_interactive_scenarios", "evaluate_library"]


def draw_interactive_scenarios(
    k: int,
    seed: int,
    probe_risk: float = 0.5,
    ranges: ScenarioRanges | None = None,
    max_draws: int = 500,
) -> list[ScenarioConfig]:
    """K scenarios of the random family in which the SMPC at ``probe_risk`` triggers.

    Args:
        k: how many.
        seed: seed of the draws (use disjoint seeds for training and evaluation).
        probe_risk: risk of the probing SMPC.
        ranges: the family (default ranges).
        max_draws: give up after this many draws.

    Returns:
        The scenarios.

    Raises:
        RuntimeError: fewer than k interactive scenarios in ``max_draws`` draws.
    """
    ranges = ranges or ScenarioRanges()
    rng = np.random.default_rng(seed)
    out: list[ScenarioConfig] = []
    for _ in range(max_draws):
        sc = ranges.sample(rng)
        _, summary = generate_demonstration(probe_risk, sc, SMPCConfig(risk=probe_risk))
        if summary["trigger_fired"] and not summary["collision"]:
            out.append(sc)
            if len(out) == k:
                return out
    raise RuntimeError(f"only {len(out)} interactive scenarios in {max_draws} draws")


def _learn_risk(
    risk: float, scenarios: list[dict], feature_set: str, out: str | None
) -> dict[str, Any]:
    """Worker: K demonstrations of one risk, one θ learned from them jointly."""
    t0 = time.perf_counter()
    demos: list[Demonstration] = []
    for i, raw in enumerate(scenarios):
        demo, _ = generate_demonstration(risk, ScenarioConfig(**raw), SMPCConfig(risk=risk))
        demos.append(demo)
        if out is not None:
            save_demonstration(demo, Path(out) / "demos" / f"p{risk:g}_s{i}.npz")
    t_demo = time.perf_counter() - t0
    learner = MaxEntIRL(demos, FeatureConfig(feature_set=feature_set), IRLConfig())
    result = learner.learn()
    # one style per demonstration too: identification takes the median over them
    members = [
        MaxEntIRL(d, FeatureConfig(feature_set=feature_set), IRLConfig()).learn().theta.tolist()
        for d in demos
    ]
    per_demo = [
        {
            "rmse_y_m": e["rmse_y_m"],
            "rmse_y_reaction_m": e["rmse_y_reaction_m"],
            "trigger_fired": p.basis.events.reactive_active,
        }
        for e, p in zip(result.errors, learner.problems, strict=True)
    ]
    return {
        "risk": risk,
        "theta": result.theta.tolist(),
        "members": members,
        "theta_normalised": result.theta_normalised.tolist(),
        "iterations": result.iterations,
        "converged": result.converged,
        "learning_error": result.learning_error,
        "per_demo": per_demo,
        "demo_s": t_demo,
        "learn_s": time.perf_counter() - t0 - t_demo,
    }


def build_library(
    risks: Sequence[float],
    scenarios: Sequence[ScenarioConfig],
    feature_set: str = "reactive",
    workers: int = 2,
    out: str | Path | None = None,
    progress: Callable[[dict], None] | None = None,
) -> StyleLibrary:
    """Learn one style per risk from demonstrations in the given scenarios (in parallel).

    Args:
        risks: risk levels p.
        scenarios: shared training scenarios.
        feature_set: 'reactive' or 'base'.
        workers: processes (1: in this process).
        out: folder to save the demonstrations under ``demos/``.
        progress: called with each finished risk's record.

    Returns:
        The library (``meta`` holds training scenarios, per-demo fit and timings).
    """
    risks = sorted(float(p) for p in risks)
    raw = [sc.to_dict() for sc in scenarios]
    args = [(p, raw, feature_set, None if out is None else str(out)) for p in risks]
    records: dict[float, dict] = {}
    if workers <= 1:
        for a in args:
            rec = _learn_risk(*a)
            records[rec["risk"]] = rec
            if progress:
                progress(rec)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(_learn_risk, *a) for a in args]
            for fut in as_completed(futures):
                rec = fut.result()
                records[rec["risk"]] = rec
                if progress:
                    progress(rec)
    return StyleLibrary(
        feature_set=feature_set,
        risks=tuple(risks),
        thetas=tuple(tuple(records[p]["theta"]) for p in risks),
        members=tuple(tuple(tuple(t) for t in records[p]["members"]) for p in risks),
        features=FeatureConfig(feature_set=feature_set),
        meta={
            "training_scenarios": raw,
            "per_risk": {
                str(p): {k: v for k, v in records[p].items() if k not in ("theta", "members")}
                for p in risks
            },
            "uncertainty": asdict(SMPCConfig().uncertainty),
        },
    )


def evaluate_library(
    library: StyleLibrary,
    scenarios: Sequence[ScenarioConfig],
    grid_risks: Sequence[float],
    between_risks: Sequence[float],
    progress: Callable[[int], Any] | None = None,
) -> dict[str, Any]:
    """Identification on held-out scenarios, for grid and between-grid risks.

    Every (risk, scenario) pair gives one SMPC demonstration that is identified with every
    scorer. ``transfer`` asks, for the grid risks, whether θ_p reproduces SMPC(p) best
    among the library styles (the rmse_y ranking's first place).

    Returns:
        Per-demo records and summary metrics per scorer.
    """
    records = []
    for p in [*grid_risks, *between_risks]:
        for i, sc in enumerate(scenarios):
            demo, summary = generate_demonstration(p, sc, SMPCConfig(risk=p))
            t0 = time.perf_counter()
            res = identify_all(demo, library)
            ident_s = time.perf_counter() - t0
            records.append(
                {
                    "risk": p,
                    "scenario": i,
                    "grid": p in grid_risks,
                    "trigger_fired": summary["trigger_fired"],
                    "identify_s": ident_s,
                    **{f"{s}_estimate": r["risk_estimate"] for s, r in res.items()},
                    **{f"{s}_interpolated": r["risk_interpolated"] for s, r in res.items()},
                    "scores": res["rmse_y"]["all_scores"],
                }
            )
            if progress:
                progress(1)
    summary: dict[str, Any] = {}
    for s in SCORERS:
        grid = [r for r in records if r["grid"]]
        between = [r for r in records if not r["grid"]]
        interactive = [r for r in grid if r["trigger_fired"]]

        def acc(rs: list[dict], s: str = s) -> float | None:
            return float(np.mean([r[f"{s}_estimate"] == r["risk"] for r in rs])) if rs else None

        def mae(rs: list[dict], key: str) -> float | None:
            return float(np.mean([abs(r[key] - r["risk"]) for r in rs])) if rs else None

        summary[s] = {
            "grid_accuracy": acc(grid),
            "grid_mae": mae(grid, f"{s}_estimate"),
            "grid_accuracy_interactive": acc(interactive),
            "n_grid": len(grid),
            "n_grid_interactive": len(interactive),
            "between_mae_nearest": mae(between, f"{s}_estimate"),
            "between_mae_interpolated": mae(between, f"{s}_interpolated"),
            "n_between": len(between),
        }
    summary["transfer_own_risk_best"] = summary["rmse_y"]["grid_accuracy"]
    summary["identify_s_median"] = float(np.median([r["identify_s"] for r in records]))
    return {"records": records, "summary": summary}
