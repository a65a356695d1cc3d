"""Style identification: scorers, the posterior over a library's risks and its interval (DESIGN §8).

*Identification* scores, per risk of a :class:`~drivestyle.irl.library.StyleLibrary`, the
members learned in the training scenarios nearest to an unseen demonstration's, by
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
(:class:`Identification`).

The library (its type, file and learning) lives in :mod:`drivestyle.irl.library`; the
held-out evaluation in :mod:`drivestyle.agents.studies.identification`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.irl.inner import InnerProblem, InnerSolveError
from drivestyle.irl.learner import check_learnable
from drivestyle.irl.library import LibraryError, StyleLibrary
from drivestyle.irl.metrics import trajectory_errors

__all__ = [
    "DEFAULT_SCORER",
    "MIN_MEMBERS",
    "SCORERS",
    "DemoScores",
    "Identification",
    "LibraryError",
    "StyleLibrary",
    "check_answerable",
    "demo_scores",
    "identify",
    "identify_all",
    "posterior_from_scores",
    "risk_interval",
    "summarise",
]

SCORERS = ("feature", "rmse_xy", "rmse_y", "suboptimality")
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
S_E_INFORMATIVE = 8.0
"""A demonstration is informative when the TV comes within this elliptical index of the
EV (s_e < 8, 120 m ahead or behind in the same lane): farther, no library risk changes the
SMPC's path (probes with the TV 60–150 m behind: identical paths for p = 0.5 … 0.95)."""
INTERVAL_MASS = 0.9
"""Posterior mass of the reported risk interval."""


@dataclass(frozen=True)
class DemoScores:
    """Every scorer's score of every library risk on one demonstration (lower is better)."""

    scores: Mapping[str, tuple[float, ...]]
    """Scorer → score per library risk (the median over the risk's nearest members)."""
    informative: bool
    """Whether the TV came near enough (s_e < :data:`S_E_INFORMATIVE`) for p to matter."""
    min_s_e: float
    """Closest approach of the TV in ellipse units."""
    trigger_fired: bool
    """Whether the reaction trigger fired (the reactive features are active)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``scores`` as lists over the library's risks)."""
        return {
            "scores": {s: list(v) for s, v in self.scores.items()},
            "informative": self.informative,
            "min_s_e": self.min_s_e,
            "trigger_fired": self.trigger_fired,
        }


@dataclass(frozen=True)
class Identification:
    """One vehicle's identified risk with its uncertainty (``identify.json``)."""

    scorer: str
    """The scorer the posterior is built from."""
    risks: tuple[float, ...]
    """The library's risks (the posterior's support)."""
    posterior: tuple[float, ...]
    """Posterior probability of each library risk (sums to 1)."""
    risk_estimate: float
    """Posterior mode."""
    risk_interpolated: float
    """Posterior mean (for risks between the library's)."""
    risk_interval: tuple[float, float]
    """Span [lo, hi] of the smallest set of risks holding :attr:`interval_mass`."""
    ranking: tuple[float, ...]
    """Library risks by decreasing posterior."""
    per_demo: tuple[DemoScores, ...]
    """Each demonstration's scores and flags (they pool into the posterior)."""
    true_risks: tuple[float | None, ...] = ()
    """Each demonstration's true risk where its metadata holds one (else None)."""
    interval_mass: float = INTERVAL_MASS
    """Posterior mass of :attr:`risk_interval`."""

    @property
    def informative(self) -> bool:
        """Whether any demonstration's TV came near enough for p to matter.

        False: the posterior is the uniform prior and the interval the whole grid.
        """
        return any(d.informative for d in self.per_demo)

    @property
    def trigger_fired(self) -> bool:
        """Whether the trigger fired in any demonstration."""
        return any(d.trigger_fired for d in self.per_demo)

    @property
    def posterior_by_risk(self) -> dict[float, float]:
        """Risk → posterior probability."""
        return dict(zip(self.risks, self.posterior, strict=True))

    def mean_scores(self, scorer: str | None = None) -> dict[float, float]:
        """Risk → score of ``scorer`` (default: this one), averaged over the demonstrations."""
        s = scorer or self.scorer
        return {
            p: float(np.mean([d.scores[s][i] for d in self.per_demo]))
            for i, p in enumerate(self.risks)
        }

    def covers(self, risk: float) -> bool:
        """Whether ``risk`` lies in :attr:`risk_interval` (to round-off)."""
        lo, hi = self.risk_interval
        return lo - 1e-9 <= risk <= hi + 1e-9

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict with ``identify.json``'s keys (risks as strings)."""
        all_scores = {
            s: {str(p): v for p, v in self.mean_scores(s).items()} for s in self.per_demo[0].scores
        }
        return {
            "scorer": self.scorer,
            "risk_estimate": self.risk_estimate,
            "risk_interpolated": self.risk_interpolated,
            "risk_interval": list(self.risk_interval),
            "interval_mass": self.interval_mass,
            "posterior": {str(p): q for p, q in zip(self.risks, self.posterior, strict=True)},
            "informative": self.informative,
            "informative_per_demo": [d.informative for d in self.per_demo],
            "min_s_e_per_demo": [d.min_s_e for d in self.per_demo],
            "scores": all_scores[self.scorer],
            "all_scores": all_scores,
            "ranking": list(self.ranking),
            "n_demos": len(self.per_demo),
            "trigger_fired": self.trigger_fired,
            "trigger_fired_per_demo": [d.trigger_fired for d in self.per_demo],
            "true_risk": list(self.true_risks),
        }


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
    _check_kind(demo)
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
        informative=min_s_e < S_E_INFORMATIVE,
        min_s_e=min_s_e,
        trigger_fired=bool(events.reactive_active),
    )


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
    for row, info in zip(scores, informative, strict=True):
        s = np.asarray(row, float)
        if not info or not np.any(np.isfinite(s)):
            continue
        best = max(float(np.min(s[np.isfinite(s)])), 1e-9)
        log_lik -= np.where(np.isfinite(s), (s / best - 1.0) / temperature, np.inf)
    log_lik -= np.max(log_lik)
    post = np.exp(log_lik)
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
        [d.scores[scorer] for d in per_demo], [d.informative for d in per_demo]
    )
    order = np.argsort(-posterior, kind="stable")
    return Identification(
        scorer=scorer,
        risks=tuple(float(p) for p in risks_a),
        posterior=tuple(float(q) for q in posterior),
        risk_estimate=float(risks_a[order[0]]),
        risk_interpolated=float(posterior @ risks_a),
        risk_interval=risk_interval(risks_a, posterior),
        ranking=tuple(float(risks_a[i]) for i in order),
        per_demo=tuple(per_demo),
        true_risks=tuple(true_risks),
    )


def _as_list(demos: Demonstration | Sequence[Demonstration]) -> list[Demonstration]:
    out = [demos] if isinstance(demos, Demonstration) else list(demos)
    if not out:
        raise ValueError("need at least one demonstration")
    return out


def _true_risk(demo: Demonstration) -> float | None:
    p = demo.meta.get("risk")
    return None if p is None else float(p)


def identify(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary,
    scorer: str = DEFAULT_SCORER,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> Identification:
    """Identify one vehicle's risk from its demonstration(s), with an honest uncertainty.

    Args:
        demos: one demonstration or several of the same vehicle (their evidence pools).
        library: the style library (at least :data:`MIN_MEMBERS` training scenarios).
        scorer: one of :data:`SCORERS` (lower is better).
        control_point_rule: control-point rule of the demonstrations.
        f_floor: floor of the relative feature error's denominators.
        nearest: per risk, the members of the nearest training scenarios to score (None:
            all).

    Returns:
        The :class:`Identification`: posterior mode, mean and 90 % interval, the
        posterior, the ranking, the scores, whether the demonstrations were informative.

    Raises:
        ValueError: unknown scorer or no demonstrations.
        LibraryError: a demonstration is of another kind or degenerate (no TV, no lane
            change, no motion, a time grid other than its scenario's T_s), or the library
            has too few training scenarios.
    """
    if scorer not in SCORERS:
        raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
    demos = _as_list(demos)
    per_demo = [demo_scores(d, library, control_point_rule, f_floor, nearest) for d in demos]
    return summarise(library.risks, per_demo, scorer, [_true_risk(d) for d in demos])


def identify_all(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary,
    control_point_rule: str = "kinematic",
    nearest: int | None = NEAREST_MEMBERS,
) -> dict[str, Identification]:
    """:func:`identify` with every scorer (scorer → result) from one set of inner solves."""
    demos = _as_list(demos)
    per_demo = [demo_scores(d, library, control_point_rule, nearest=nearest) for d in demos]
    true = [_true_risk(d) for d in demos]
    return {s: summarise(library.risks, per_demo, s, true) for s in SCORERS}
