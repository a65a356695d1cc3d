"""The paper model's identification: scorers and the posterior over a library's risks (DESIGN §8).

*Identification* scores, per risk of a :class:`~drivestyle.irl.identification.library.StyleLibrary`,
the members learned in the training scenarios nearest to an unseen demonstration's, by
reproducing r*_θ in the demonstration's own scenario (its knots, event times and TV) and
comparing it with the demonstration:

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
``risk_interpolated`` and the span of its 90 % set ``risk_interval``
(:class:`~drivestyle.irl.identification.result.Identification`).

The library (its type, file and learning) lives in
:mod:`drivestyle.irl.identification.library`; the driver library's continuous posterior and
the entry point :func:`~drivestyle.irl.identification.posterior.identify` in
:mod:`drivestyle.irl.identification.posterior`; the held-out evaluation in
:mod:`drivestyle.studies.identification.study`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.irl.identification.library import LibraryError, StyleLibrary
from drivestyle.irl.identification.result import (
    INTERVAL_MASS,
    DemoScores,
    Identification,
    check_finite,
    check_identifiable,
)
from drivestyle.irl.identification.verdict import S_E_INFORMATIVE, paper_verdict
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.inner import InnerProblem, InnerSolveError

__all__ = [
    "DEFAULT_SCORER",
    "MIN_MEMBERS",
    "NEAREST_MEMBERS",
    "SCORERS",
    "TEMPERATURE",
    "check_answerable",
    "demo_scores",
    "posterior_from_scores",
    "risk_interval",
    "summarise",
]

SCORERS = ("feature", "rmse_xy", "rmse_y", "suboptimality")
"""The paper model's scorers (module docstring; lower is better)."""
DEFAULT_SCORER = "feature"
"""The scorer the library API and the command line use unless told otherwise (validation
seed 500, docs/RESULTS.md §6: best grid accuracy with scenario-nearest members)."""
NEAREST_MEMBERS: int | None = 5
"""Per risk, score the members learned in the k training scenarios nearest to the
demonstration's (a scenario-conditioned style; None: all members). Validation seed 500
with a 6 × 30 library: grid accuracy 72 % with 5 nearest, 68 % with 10, 63 % with all."""
MIN_MEMBERS = 5
"""Fewest members per risk (training scenarios K) identification answers from. The
temperature was calibrated on scores that are medians of 5 members; a median of fewer,
farther members is noisier than τ allows for, and a 3-scenario library answered the paper
demonstration of p = 0.7 with posterior 0.996 on p = 0.5 (interval [0.5, 0.5])."""
TEMPERATURE = 0.5
"""τ of the likelihood ℓ_p = −(s_p / min_q s_q − 1)/τ (relative score gap), the smallest
τ whose 90 % intervals cover the truth for ≈ 90 % of validation demonstrations (89 %)."""


def check_answerable(library: StyleLibrary, nearest: int | None = NEAREST_MEMBERS) -> None:
    """Refuse a library with too few training scenarios to answer honestly.

    A risk's score is the median of its ``nearest`` members (:data:`MIN_MEMBERS` at least);
    with fewer training scenarios it would be the median of fewer, farther styles and the
    posterior over-confident (:data:`MIN_MEMBERS`).

    Raises:
        LibraryError: K < max(:data:`MIN_MEMBERS`, ``nearest``).
    """
    needed = max(MIN_MEMBERS, nearest or 0)
    if library.n_scenarios < needed:
        raise LibraryError(
            f"the library has {library.n_scenarios} training scenario"
            f"{'s' if library.n_scenarios != 1 else ''} per risk; identification scores the "
            f"{needed} nearest, so it needs at least {needed} (rebuild it with "
            f"build_style_library.py --scenarios {needed} or more)"
        )


def demo_scores(
    demo: Demonstration,
    library: StyleLibrary,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> DemoScores:
    """Every scorer's score of every library risk on one demonstration (lower is better).

    A risk's score is the median over its ``nearest`` members' reproductions r*_θ in the
    demonstration's own scenario (module docstring; :meth:`StyleLibrary.styles`).

    Raises:
        LibraryError: the demonstration is of another kind or degenerate, or the library has
            too few training scenarios (:func:`check_answerable`).
    """
    check_identifiable(demo)
    check_answerable(library, nearest)
    problem = InnerProblem(demo, library.features, control_point_rule)
    events = problem.basis.events
    scale = np.maximum(np.abs(problem.f_demo), f_floor)
    scores: dict[str, list[float]] = {s: [] for s in SCORERS}
    for i in range(len(library.risks)):
        member_scores: dict[str, list[float]] = {s: [] for s in SCORERS}
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
            rmse_y, rmse_xy = err["rmse_y_m"], err["rmse_xy_m"]
            assert rmse_y is not None and rmse_xy is not None  # None: reaction window only
            member_scores["rmse_y"].append(rmse_y)
            member_scores["rmse_xy"].append(rmse_xy)
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
    return DemoScores(
        scores={s: tuple(v) for s, v in scores.items()},
        constraint_binds=min_s_e < S_E_INFORMATIVE,
        min_s_e=min_s_e,
        trigger_fired=bool(events.reactive_active),
    )


def posterior_from_scores(
    scores: Sequence[Sequence[float]],
    binds: Sequence[bool],
    temperature: float = TEMPERATURE,
) -> np.ndarray:
    """Posterior over the library's risks from one or several demonstrations' scores.

    Each demonstration in which p can matter (``binds``) contributes the log-likelihood
    ℓ_p = −(s_p / min_q s_q − 1)/τ (its relative score gap, free of the scorer's unit and of
    how hard the scenario is to reproduce); the others contribute nothing; the
    prior is uniform over the library's risks. Demonstrations of one vehicle pool by adding
    their log-likelihoods, so the posterior sharpens as they are added.

    Args:
        scores: per demonstration, the scores of the library's risks (lower is better).
        binds: per demonstration, whether p can matter in it (:attr:`DemoScores.constraint_binds`).
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
    for row, info in zip(scores, binds, strict=True):
        s = np.asarray(row, float)
        if not info or not np.any(np.isfinite(s)):
            continue
        best = max(float(np.min(s[np.isfinite(s)])), 1e-9)
        log_lik -= np.where(np.isfinite(s), (s / best - 1.0) / temperature, np.inf)
    return _normalised(log_lik, f"temperature {temperature:g}")


def _normalised(log_lik: np.ndarray, what: str) -> np.ndarray:
    """exp(ℓ) normalised to sum 1 (:func:`check_finite` first)."""
    check_finite(log_lik, what)
    post = np.exp(log_lik - np.max(log_lik))
    return post / post.sum()


def risk_interval(
    risks: Sequence[float] | np.ndarray, posterior: np.ndarray, mass: float = INTERVAL_MASS
) -> tuple[float, float]:
    """The smallest set of risks holding ``mass`` of the posterior, as the [lo, hi] it spans."""
    risks_a = np.asarray(risks, float)
    order = np.argsort(-posterior, kind="stable")
    k = int(np.searchsorted(np.cumsum(posterior[order]), mass - 1e-12)) + 1
    chosen = risks_a[order[: min(k, risks_a.size)]]
    return float(chosen.min()), float(chosen.max())


def summarise(
    risks: Sequence[float],
    per_demo: Sequence[DemoScores],
    scorer: str = DEFAULT_SCORER,
    true_risks: Sequence[float | None] = (),
) -> Identification:
    """Posterior, estimate, interval and ranking of one scorer from per-demonstration scores.

    Raises:
        ValueError: unknown scorer or no demonstrations.
    """
    if scorer not in SCORERS:
        raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
    if not per_demo:
        raise ValueError("need the scores of at least one demonstration")
    risks_a = np.asarray(risks, float)
    posterior = posterior_from_scores(
        [d.scores[scorer] for d in per_demo], [d.constraint_binds for d in per_demo]
    )
    order = np.argsort(-posterior, kind="stable")
    interval = risk_interval(risks_a, posterior)
    near = any(d.constraint_binds for d in per_demo)
    closest = min(d.min_s_e for d in per_demo)
    return Identification(
        scorer=scorer,
        risks=tuple(float(p) for p in risks_a),
        posterior=tuple(float(q) for q in posterior),
        risk_estimate=float(risks_a[order[0]]),
        risk_interpolated=float(posterior @ risks_a),
        risk_interval=interval,
        ranking=tuple(float(risks_a[i]) for i in order),
        per_demo=tuple(per_demo),
        true_risks=tuple(true_risks),
        verdict=paper_verdict(risks_a, posterior, interval, near, closest),
    )
