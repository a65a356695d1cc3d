"""Style libraries, style identification and its evaluation (beyond the paper; DESIGN §8).

A *library* holds, per SMPC risk level p, one θ learned jointly from K demonstrations of
that risk in shared scenarios of the random family and one θ per demonstration
(*members*). *Identification* scores, per risk, the members learned in the training
scenarios nearest to an unseen demonstration's, by reproducing r*_θ in the
demonstration's own scenario (its knots, event times and TV) and comparing it with the
demonstration:

- ``feature`` (default, :data:`DEFAULT_SCORER`; best on validation, docs/RESULTS.md §6):
  relative feature error ‖(f(r*_θ) − f_D)/max(|f_D|, f_floor)‖₂ — the ME-IRL matching
  criterion;
- ``rmse_xy``: RMS position distance of r*_θ to the demonstration [m];
- ``rmse_y``: lateral RMSE of r*_θ against the demonstration [m] — the trajectory-level
  criterion (DESIGN §6: ε is not the headline);
- ``suboptimality``: how far from optimal the demonstration is under θ, per feature group
  g (x, y) and relative, Σ_g θ_gᵀ(f_D − f(r*_θ))_g / θ_gᵀf(r*_θ)_g — the exponent of an
  approximate max-ent likelihood p(r_D | θ) ∝ exp(−θᵀf(r_D)) with the partition function
  replaced by its Laplace peak exp(−θᵀf(r*_θ)), normalised per group to remove θ's gauge.

All are invariant to the per-group scale of θ (r*_θ is), so styles learned from
different demonstrations are comparable. The scores become a posterior over the library's
risks (:func:`posterior_from_scores`, DESIGN §8): its mode is ``risk_estimate``, its mean
``risk_interpolated`` and the span of its 90 % set ``risk_interval``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.tracking import observe
from drivestyle.irl.features import FeatureConfig
from drivestyle.irl.inner import InnerProblem, InnerSolveError
from drivestyle.irl.learner import IRLConfig, MaxEntIRL, check_learnable
from drivestyle.irl.metrics import trajectory_errors

from drivestyle.common.io import fmt, read_json
from drivestyle.common.parallel import parallel_map

__all__ = [
    "DEFAULT_SCORER",
    "SCORERS",
    "LibraryError",
    "StyleLibrary",
    "demo_scores",
    "evaluate_identification",
    "evaluation_markdown",
    "identify",
    "identify_all",
    "knn_baseline",
    "learn_library",
    "load_library",
    "pooled_accuracy",
    "posterior_from_scores",
    "risk_interval",
]

SCORERS = ("feature", "rmse_xy", "rmse_y", "suboptimality")
DEFAULT_SCORER = "feature"
"""The scorer the library API and the command line use unless told otherwise (validation
seed 500, docs/RESULTS.md §6: best grid accuracy with scenario-nearest members)."""
NEAREST_MEMBERS: int | None = 5
"""Per risk, score the members learned in the k training scenarios nearest to the
demonstration's (a scenario-conditioned style; None: all members). Validation seed 500
with a 6 × 30 library: grid accuracy 72 % with 5 nearest, 68 % with 10, 63 % with all."""
SCENARIO_SCALE = {"ev_speed": 3.0, "tv_speed": 3.5, "tv_gap": 10.0}
"""Units of the scenario distance: half the random family's range of each quantity."""
TEMPERATURE = 0.5
"""τ of the likelihood ℓ_p = −(s_p / min_q s_q − 1)/τ (relative score gap), the smallest
τ whose 90 % intervals cover the truth for ≈ 90 % of validation demonstrations (89 %)."""
S_E_INFORMATIVE = 8.0
"""A demonstration is informative when the TV comes within this elliptical index of the
EV (s_e < 8, 120 m ahead or behind in the same lane): farther, no library risk changes the
SMPC's path (probes with the TV 60–150 m behind: identical paths for p = 0.5 … 0.95)."""
INTERVAL_MASS = 0.9
"""Posterior mass of the reported risk interval."""


class LibraryError(ValueError):
    """A style library is empty, corrupt or inconsistent."""


@dataclass(frozen=True)
class StyleLibrary:
    """Learned styles by risk level."""

    feature_set: str
    """'base' or 'reactive'."""
    risks: tuple[float, ...]
    """Risk levels p, increasing."""
    thetas: tuple[tuple[float, ...], ...]
    """θ per risk (active features, FEATURES order)."""
    features: FeatureConfig = field(default_factory=FeatureConfig)
    """Feature configuration the styles were learned with."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Training scenarios, per-demo fit, timings."""
    members: tuple[tuple[tuple[float, ...], ...], ...] = ()
    """Per-demonstration styles of each risk (one θ per training scenario, in the order of
    ``meta["training_scenarios"]``); identification scores a risk's members nearest to the
    demonstration's scenario and takes the median. A library file without them is rejected
    by :func:`load_library` (identification would silently change)."""

    def __post_init__(self) -> None:
        if not self.risks:
            raise LibraryError("the library is empty (no risk levels)")
        if len(self.risks) != len(self.thetas):
            raise LibraryError(f"{len(self.risks)} risks but {len(self.thetas)} weight vectors")
        if list(self.risks) != sorted(self.risks) or len(set(self.risks)) != len(self.risks):
            raise LibraryError(f"risks must be strictly increasing, got {self.risks}")
        m = len(self.features.names)
        if self.members and len(self.members) != len(self.risks):
            raise LibraryError(f"{len(self.risks)} risks but {len(self.members)} member sets")
        for i, (p, th) in enumerate(zip(self.risks, self.thetas, strict=True)):
            for t in (th, *(self.members[i] if self.members else ())):
                if len(t) != m or not all(math.isfinite(v) and v > 0 for v in t):
                    raise LibraryError(f"theta for p={p} must be {m} positive numbers, got {t}")

    def styles(
        self, i: int, nearest: int | None = None, scenario: ScenarioConfig | None = None
    ) -> tuple[tuple[float, ...], ...]:
        """The weight vectors that represent risk i in a scenario.

        The members learned in the ``nearest`` training scenarios closest to ``scenario``
        (distance in :data:`SCENARIO_SCALE` units over EV speed, TV speed and TV gap); all
        members if ``nearest`` is None, and the first ``nearest`` if the library does not
        record its training scenarios; the joint θ if it has no members.
        """
        if not self.members:
            return (self.thetas[i],)
        members = self.members[i]
        train = self.meta.get("training_scenarios") or []
        if nearest is None or nearest >= len(members):
            return members
        if scenario is None or len(train) != len(members):
            return members[:nearest]
        keys = list(SCENARIO_SCALE)
        scale = np.array([SCENARIO_SCALE[k] for k in keys])
        here = np.array([getattr(scenario, k) for k in keys])
        there = np.array([[float(sc[k]) for k in keys] for sc in train])
        order = np.argsort(np.linalg.norm((there - here) / scale, axis=1), kind="stable")
        return tuple(members[j] for j in order[:nearest])

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``library.json``)."""
        fc = self.features
        return {
            "feature_set": self.feature_set,
            "features": list(fc.names),
            "risks": list(self.risks),
            "theta": {str(p): list(t) for p, t in zip(self.risks, self.thetas, strict=True)},
            "members": {
                str(p): [list(t) for t in self.members[i]] for i, p in enumerate(self.risks)
            }
            if self.members
            else {},
            "feature_config": {k: getattr(fc, k) for k in fc.__dataclass_fields__},
            **self.meta,
        }


def load_library(path: str | Path) -> StyleLibrary:
    """Read ``library.json`` (or a folder holding it).

    Raises:
        FileNotFoundError: no such file.
        LibraryError: malformed, empty or inconsistent library.
    """
    path, raw = read_json(path, "library.json", LibraryError, "style library")
    try:
        features = FeatureConfig.from_dict(raw["feature_config"])
        risks = tuple(float(p) for p in raw["risks"])
        thetas = tuple(tuple(float(v) for v in raw["theta"][str(p)]) for p in raw["risks"])
        raw_members = raw.get("members") or {}
        if not raw_members:
            raise LibraryError(
                f"{path}: the library has no per-demonstration 'members'; identification "
                "needs them (rebuild it with build_style_library.py)"
            )
        members = tuple(
            tuple(tuple(float(v) for v in t) for t in raw_members[str(p)]) for p in raw["risks"]
        )
        if any(not m for m in members):
            raise LibraryError(f"{path}: a risk level has an empty member list")
    except (KeyError, TypeError, ValueError) as exc:
        raise LibraryError(f"{path}: corrupt library ({type(exc).__name__}: {exc})") from None
    meta = {
        k: v
        for k, v in raw.items()
        if k not in ("feature_set", "features", "risks", "theta", "feature_config", "members")
    }
    return StyleLibrary(
        raw.get("feature_set", features.feature_set), risks, thetas, features, meta, members
    )


def _check_kind(demo: Demonstration) -> None:
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


def demo_scores(
    demo: Demonstration,
    library: StyleLibrary,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> dict[str, Any]:
    """Every scorer's score of every library risk on one demonstration (lower is better).

    A risk's score is the median over its ``nearest`` members' reproductions r*_θ in the
    demonstration's own scenario (module docstring; :meth:`StyleLibrary.styles`).

    Returns:
        ``scores`` (scorer → list over the library's risks), ``informative``, ``min_s_e``
        (closest approach of the TV in ellipse units) and ``trigger_fired``.

    Raises:
        LibraryError: the demonstration is of another kind or degenerate.
    """
    _check_kind(demo)
    problem = InnerProblem(demo, library.features, control_point_rule)
    events = problem.basis.events
    scale = np.maximum(np.abs(problem.f_demo), f_floor)
    scores = {s: [] for s in SCORERS}
    for i in range(len(library.risks)):
        member_scores = {s: [] for s in SCORERS}
        for theta in library.styles(i, nearest, demo.scenario):
            problem.reset()
            try:
                sol = problem.solve(np.asarray(theta))
            except InnerSolveError:
                for s in SCORERS:
                    member_scores[s].append(np.inf)
                continue
            err = trajectory_errors(
                sol.control_points[:, [0, 3]], demo, events.t_trg, events.t_rct_end
            )
            member_scores["rmse_y"].append(err["rmse_y_m"])
            member_scores["rmse_xy"].append(err["rmse_xy_m"])
            gap = 0.0
            for names in problem.groups.values():
                idx = [problem.names.index(n) for n in names]
                if idx:
                    th = np.asarray(theta)[idx]
                    ref = max(float(th @ sol.features[idx]), 1e-12)
                    gap += float(th @ (problem.f_demo[idx] - sol.features[idx])) / ref
            member_scores["suboptimality"].append(gap)
            member_scores["feature"].append(
                float(np.linalg.norm((sol.features - problem.f_demo) / scale))
            )
        for s in SCORERS:  # median over a risk's members (one member: its value)
            scores[s].append(float(np.median(member_scores[s])))
    sc = demo.scenario
    s_e = elliptical_index(
        demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], sc.l_a, sc.l_b
    )
    min_s_e = float(np.min(s_e))
    return {
        "scores": scores,
        "informative": min_s_e < S_E_INFORMATIVE,
        "min_s_e": min_s_e,
        "trigger_fired": bool(events.reactive_active),
    }


def posterior_from_scores(
    scores: Sequence[Sequence[float]],
    informative: Sequence[bool],
    temperature: float = TEMPERATURE,
) -> np.ndarray:
    """Posterior over the library's risks from one or several demonstrations' scores.

    Each informative demonstration contributes the log-likelihood
    ℓ_p = −(s_p / min_q s_q − 1)/τ (its relative score gap, free of the scorer's unit and of
    how hard the scenario is to reproduce); uninformative ones contribute nothing; the
    prior is uniform over the library's risks. Demonstrations of one vehicle pool by adding
    their log-likelihoods, so the posterior sharpens as they are added.

    Args:
        scores: per demonstration, the scores of the library's risks (lower is better).
        informative: per demonstration, whether it says anything about p.
        temperature: τ > 0.

    Returns:
        Posterior probabilities, shape (n_risks,), summing to 1.
    """
    if not temperature > 0:
        raise ValueError(f"temperature must be > 0, got {temperature}")
    n = len(scores[0]) if len(scores) else 0
    if n == 0:
        raise ValueError("need the scores of at least one demonstration")
    log_lik = np.zeros(n)
    for s, info in zip(scores, informative, strict=True):
        s = np.asarray(s, float)
        if not info or not np.any(np.isfinite(s)):
            continue
        best = max(float(np.min(s[np.isfinite(s)])), 1e-9)
        log_lik -= np.where(np.isfinite(s), (s / best - 1.0) / temperature, np.inf)
    log_lik -= np.max(log_lik)
    post = np.exp(log_lik)
    return post / post.sum()


def risk_interval(
    risks: Sequence[float], posterior: np.ndarray, mass: float = INTERVAL_MASS
) -> tuple[float, float]:
    """The smallest set of risks holding ``mass`` of the posterior, as the [lo, hi] it spans."""
    risks = np.asarray(risks, float)
    order = np.argsort(-posterior, kind="stable")
    k = int(np.searchsorted(np.cumsum(posterior[order]), mass - 1e-12)) + 1
    chosen = risks[order[: min(k, risks.size)]]
    return float(chosen.min()), float(chosen.max())


def _summarise(
    risks: Sequence[float], per_demo: list[dict[str, Any]], scorer: str
) -> dict[str, Any]:
    """Posterior, estimate, interval and ranking of one scorer from per-demonstration scores."""
    risks = np.asarray(risks, float)
    informative = [d["informative"] for d in per_demo]
    posterior = posterior_from_scores([d["scores"][scorer] for d in per_demo], informative)
    order = np.argsort(-posterior, kind="stable")
    lo, hi = risk_interval(risks, posterior)
    mean_scores = {
        s: {
            str(p): float(np.mean([d["scores"][s][i] for d in per_demo]))
            for i, p in enumerate(risks)
        }
        for s in SCORERS
    }
    return {
        "scorer": scorer,
        "risk_estimate": float(risks[order[0]]),
        "risk_interpolated": float(posterior @ risks),
        "risk_interval": [lo, hi],
        "interval_mass": INTERVAL_MASS,
        "posterior": {str(p): float(q) for p, q in zip(risks, posterior, strict=True)},
        "informative": any(informative),
        "informative_per_demo": informative,
        "min_s_e_per_demo": [d["min_s_e"] for d in per_demo],
        "scores": mean_scores[scorer],
        "all_scores": mean_scores,
        "ranking": [float(risks[i]) for i in order],
        "n_demos": len(per_demo),
        "trigger_fired": any(d["trigger_fired"] for d in per_demo),
        "trigger_fired_per_demo": [d["trigger_fired"] for d in per_demo],
    }


def identify(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary,
    scorer: str = DEFAULT_SCORER,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> dict[str, Any]:
    """Identify one vehicle's risk from its demonstration(s), with an honest uncertainty.

    Args:
        demos: one demonstration or several of the same vehicle (their evidence pools).
        library: the style library.
        scorer: one of :data:`SCORERS` (lower is better).
        control_point_rule: control-point rule of the demonstrations.
        f_floor: floor of the relative feature error's denominators.
        nearest: per risk, the members of the nearest training scenarios to score (None:
            all).

    Returns:
        ``risk_estimate`` (posterior mode), ``risk_interpolated`` (posterior mean),
        ``risk_interval`` (the smallest set of risks with 90 % of the posterior, as
        [lo, hi]), ``posterior`` (risk → probability), ``informative`` (False: no
        demonstration's TV came near enough for p to matter; the posterior is then the
        uniform prior), ``scores`` (risk → mean score; every scorer under ``all_scores``),
        ``ranking`` (by posterior), ``scorer``, ``trigger_fired``.

    Raises:
        LibraryError: a demonstration is of another kind or degenerate (no TV, no lane
            change, no motion, a time grid other than its scenario's T_s).
    """
    if scorer not in SCORERS:
        raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
    demos = [demos] if isinstance(demos, Demonstration) else list(demos)
    if not demos:
        raise ValueError("need at least one demonstration")
    per_demo = [demo_scores(d, library, control_point_rule, f_floor, nearest) for d in demos]
    return _summarise(library.risks, per_demo, scorer)


def identify_all(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary,
    control_point_rule: str = "kinematic",
    nearest: int | None = NEAREST_MEMBERS,
) -> dict[str, dict[str, Any]]:
    """:func:`identify` with every scorer from one set of inner solves."""
    demos = [demos] if isinstance(demos, Demonstration) else list(demos)
    per_demo = [demo_scores(d, library, control_point_rule, nearest=nearest) for d in demos]
    return {s: _summarise(library.risks, per_demo, s) for s in SCORERS}


def _learn_risk(risk: float, demos: list[Demonstration], feature_set: str) -> dict[str, Any]:
    """Worker: one θ learned jointly from a risk's demonstrations and one per demonstration."""
    t0 = time.perf_counter()
    features = FeatureConfig(feature_set=feature_set)
    learner = MaxEntIRL(demos, features, IRLConfig())
    result = learner.learn()
    members = [MaxEntIRL(d, features, IRLConfig()).learn().theta.tolist() for d in demos]
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
        "learn_s": time.perf_counter() - t0,
    }


def learn_library(
    demos_by_risk: dict[float, Sequence[Demonstration]],
    feature_set: str = "reactive",
    workers: int = 2,
    progress: Callable[[dict[str, Any]], None] | None = None,
    meta: dict[str, Any] | None = None,
) -> StyleLibrary:
    """Learn a style library from demonstrations grouped by risk (in parallel processes).

    Args:
        demos_by_risk: risk p → its demonstrations (the same scenarios for every risk, so
            that the styles differ only by p).
        feature_set: 'reactive' or 'base'.
        workers: processes (1: in this process).
        progress: called with each finished risk's record.
        meta: stored in the library (training scenarios, seeds, …).

    Returns:
        The library; ``meta["per_risk"]`` holds each risk's fit and timing.

    Raises:
        ValueError: no risks, or a risk without demonstrations.
    """
    risks = sorted(float(p) for p in demos_by_risk)
    if not risks:
        raise ValueError("need demonstrations of at least one risk level")
    if any(not demos_by_risk[p] for p in risks):
        raise ValueError("every risk level needs at least one demonstration")
    args = [(p, list(demos_by_risk[p]), feature_set) for p in risks]
    done = parallel_map(
        _learn_risk, args, workers, None if progress is None else lambda _, rec: progress(rec)
    )
    records = {rec["risk"]: rec for rec in done}
    return StyleLibrary(
        feature_set=feature_set,
        risks=tuple(risks),
        thetas=tuple(tuple(records[p]["theta"]) for p in risks),
        members=tuple(tuple(tuple(t) for t in records[p]["members"]) for p in risks),
        features=FeatureConfig(feature_set=feature_set),
        meta={
            **(meta or {}),
            "per_risk": {
                str(p): {k: v for k, v in records[p].items() if k not in ("theta", "members")}
                for p in risks
            },
        },
    )


def _scores_task(
    demo: Demonstration, library: StyleLibrary, noise: float, noise_seed: int
) -> dict[str, Any]:
    """Worker: :func:`demo_scores` of the demonstration as observed with position noise."""
    t0 = time.perf_counter()
    # a library learned from tracked demonstrations sees every test demonstration tracked
    tracked = library.meta.get("observation") == "tracked"
    observed = (
        demo
        if noise == 0 and not tracked
        else observe(demo, noise, np.random.default_rng(noise_seed))
    )
    try:
        out = demo_scores(observed, library)
    except LibraryError as exc:
        return {"error": str(exc), "identify_s": time.perf_counter() - t0}
    return out | {"identify_s": time.perf_counter() - t0}


def _record(
    demo: Demonstration, grid: set[float], risks: Sequence[float], scored: dict[str, Any]
) -> dict[str, Any]:
    p = float(demo.meta["risk"])
    rec: dict[str, Any] = {
        "risk": p,
        "scenario": demo.meta.get("scenario_index"),
        "grid": p in grid,
        "identify_s": scored["identify_s"],
    }
    if "error" in scored:
        return rec | {"error": scored["error"]}
    rec |= {k: scored[k] for k in ("informative", "min_s_e", "trigger_fired", "scores")}
    for scorer in SCORERS:
        res = _summarise(risks, [scored], scorer)
        lo, hi = res["risk_interval"]
        rec |= {
            f"{scorer}_estimate": res["risk_estimate"],
            f"{scorer}_interpolated": res["risk_interpolated"],
            f"{scorer}_interval": [lo, hi],
            f"{scorer}_covered": lo - 1e-9 <= p <= hi + 1e-9,
        }
        if scorer == DEFAULT_SCORER:
            rec["posterior"] = res["posterior"]
    return rec


def pooled_accuracy(
    records: list[dict[str, Any]],
    risks: Sequence[float],
    n_pool: int = 3,
    scorer: str = DEFAULT_SCORER,
) -> dict[str, Any]:
    """Grid accuracy of single demonstrations against pools of ``n_pool`` of one vehicle.

    A "vehicle" is a grid risk; its demonstrations (in different scenarios, scenario order)
    are pooled in consecutive groups of ``n_pool`` by :func:`posterior_from_scores`.

    Returns:
        ``single_accuracy`` and ``pooled_accuracy`` over the same demonstrations,
        ``single_interval_width`` and ``pooled_interval_width`` (mean), ``n_pools``.
    """
    risks = list(risks)
    single, pooled, w1, wn = [], [], [], []
    for p in risks:
        rs = sorted(
            (r for r in records if r["risk"] == p and "error" not in r),
            key=lambda r: (r["scenario"] is None, r["scenario"]),
        )
        for k in range(0, len(rs) - n_pool + 1, n_pool):
            group = rs[k : k + n_pool]
            post = posterior_from_scores(
                [r["scores"][scorer] for r in group], [r["informative"] for r in group]
            )
            pooled.append(risks[int(np.argmax(post))] == p)
            lo, hi = risk_interval(risks, post)
            wn.append(hi - lo)
            single += [r[f"{scorer}_estimate"] == p for r in group]
            w1 += [r[f"{scorer}_interval"][1] - r[f"{scorer}_interval"][0] for r in group]
    return {
        "n_pool": n_pool,
        "n_pools": len(pooled),
        "single_accuracy": float(np.mean(single)) if single else None,
        "pooled_accuracy": float(np.mean(pooled)) if pooled else None,
        "single_interval_width": float(np.mean(w1)) if w1 else None,
        "pooled_interval_width": float(np.mean(wn)) if wn else None,
    }


def evaluate_identification(
    library: StyleLibrary,
    demos: Sequence[Demonstration],
    grid_risks: Sequence[float],
    progress: Callable[[int], Any] | None = None,
    workers: int = 1,
    noise: float = 0.0,
    noise_seed: int = 0,
) -> dict[str, Any]:
    """Identify held-out demonstrations of known risk with every scorer and summarise.

    Args:
        library: the style library.
        demos: held-out demonstrations; ``meta["risk"]`` is the true risk and
            ``meta["scenario_index"]`` (optional) names the held-out scenario.
        grid_risks: the risks that count as grid points (others are between the grid).
        progress: called with 1 after each demonstration.
        workers: processes.
        noise: position noise σ [m] of the observation (:func:`drivestyle.envs.tracking.observe`;
            0: the true states).
        noise_seed: seed of the noise (demonstration i uses ``noise_seed + i``).

    Returns:
        ``records`` (one per demonstration) and ``summary``: per scorer the grid accuracy
        (all and informative), grid MAE, between-grid MAE of the posterior mean, interval
        coverage and width; pooled vs single accuracy; transfer; identification time.

    Raises:
        ValueError: a demonstration has no true risk in its metadata.
    """
    if any("risk" not in d.meta for d in demos):
        raise ValueError("every evaluation demonstration needs meta['risk'] (its true risk)")
    grid = {float(p) for p in grid_risks}
    scored = parallel_map(
        _scores_task,
        [(d, library, noise, noise_seed + i) for i, d in enumerate(demos)],
        workers,
        None if progress is None else lambda *_: progress(1),
    )
    records = [_record(d, grid, library.risks, s) for d, s in zip(demos, scored, strict=True)]
    ok = [r for r in records if "error" not in r]
    grid_recs = [r for r in ok if r["grid"]]
    informative = [r for r in grid_recs if r["informative"]]
    between = [r for r in ok if not r["grid"]]

    def mean(values: list) -> float | None:
        return float(np.mean(values)) if values else None

    summary: dict[str, Any] = {
        "n": len(records),
        "n_failed": len(records) - len(ok),
        "n_grid": len(grid_recs),
        "n_grid_informative": len(informative),
        "n_between": len(between),
        "noise_sigma_m": noise,
    }
    for s in SCORERS:
        summary[s] = {
            "grid_accuracy": mean([r[f"{s}_estimate"] == r["risk"] for r in grid_recs]),
            "grid_accuracy_informative": mean(
                [r[f"{s}_estimate"] == r["risk"] for r in informative]
            ),
            "grid_mae_informative": mean(
                [abs(r[f"{s}_estimate"] - r["risk"]) for r in informative]
            ),
            "grid_accuracy_interactive": mean(
                [r[f"{s}_estimate"] == r["risk"] for r in grid_recs if r["trigger_fired"]]
            ),
            "between_mae_nearest": mean([abs(r[f"{s}_estimate"] - r["risk"]) for r in between]),
            "between_mae_interpolated": mean(
                [abs(r[f"{s}_interpolated"] - r["risk"]) for r in between]
            ),
            "interval_coverage": mean([r[f"{s}_covered"] for r in ok]),
            "interval_width": mean([r[f"{s}_interval"][1] - r[f"{s}_interval"][0] for r in ok]),
        }
    summary["pooled"] = pooled_accuracy(records, sorted(grid))
    summary["transfer_own_risk_best"] = mean([r["rmse_y_estimate"] == r["risk"] for r in grid_recs])
    own = [r["scores"]["rmse_y"][list(library.risks).index(r["risk"])] for r in grid_recs]
    summary["own_style_rmse_y_median_m"] = float(np.median(own)) if own else None
    summary["identify_s_median"] = (
        float(np.median([r["identify_s"] for r in records])) if records else None
    )
    return {"records": records, "summary": summary}


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


def evaluation_markdown(results: dict[str, dict[str, Any]], extra: list[str] | None = None) -> str:
    """``evaluation.md``: per feature set and scorer, accuracy, MAE, intervals, pooling, timing.

    Args:
        results: feature-set name → :func:`evaluate_identification` output.
        extra: further Markdown lines (references, noise curve).
    """
    lines = [
        "# Style identification on held-out scenarios",
        "",
        f"Default scorer: {DEFAULT_SCORER}; interval: {INTERVAL_MASS:.0%} posterior mass.",
        "",
        "Demonstrations refused (not identifiable, e.g. no lane change): "
        + ", ".join(
            f"{n} {r['summary']['n_failed']} of {r['summary']['n']}" for n, r in results.items()
        ),
        "",
        "| features | scorer | grid acc. (informative) | grid acc. (all) | grid MAE "
        "(informative) | between MAE (posterior mean) | interval coverage | interval width |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        sm = r["summary"]
        for s in SCORERS:
            m = sm[s]
            lines.append(
                f"| {name} | {s} | {fmt(m['grid_accuracy_informative'], 2)} "
                f"({sm['n_grid_informative']}) | {fmt(m['grid_accuracy'], 2)} ({sm['n_grid']}) | "
                f"{fmt(m['grid_mae_informative'])} | {fmt(m['between_mae_interpolated'])} | "
                f"{fmt(m['interval_coverage'], 2)} | {fmt(m['interval_width'], 2)} |"
            )
    lines += [
        "",
        "| features | pooled 3 demos: accuracy single → pooled | interval width single → "
        "pooled | transfer | identify s (median) |",
        "|---|---|---|---|---|",
    ]
    for name, r in results.items():
        sm = r["summary"]
        pl = sm["pooled"]
        lines.append(
            f"| {name} | {fmt(pl['single_accuracy'], 2)} → {fmt(pl['pooled_accuracy'], 2)} "
            f"({pl['n_pools']} pools) | {fmt(pl['single_interval_width'], 2)} → "
            f"{fmt(pl['pooled_interval_width'], 2)} | {fmt(sm['transfer_own_risk_best'], 2)} "
            f"(own style's median rmse_y {fmt(sm['own_style_rmse_y_median_m'], 2)} m) | "
            f"{fmt(sm['identify_s_median'], 2)} |"
        )
    return "\n".join([*lines, "", *(extra or []), ""])
