"""Style identification: scorers, the posterior over a library's risks and its interval (DESIGN §8).

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
(:class:`Identification`).

The library (its type, file and learning) lives in :mod:`drivestyle.irl.identification.library`; the
held-out evaluation in :mod:`drivestyle.studies.identification.study`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.irl.driver.driver_style import RESIDUAL_FLOOR, RISK_RANGE, DriverStyleError
from drivestyle.irl.driver.risk_profile import RiskProfile, refined_profile
from drivestyle.irl.identification.library import DriverLibrary, LibraryError, StyleLibrary
from drivestyle.irl.metrics import trajectory_errors
from drivestyle.irl.paper.inner import InnerProblem, InnerSolveError
from drivestyle.irl.paper.learner import check_learnable
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "DEFAULT_SCORER",
    "ENTERS_REGION",
    "ENTERS_REGION_S_E",
    "INFORMATIVE",
    "MIN_MEMBERS",
    "NO_CONSTRAINT",
    "OUT_OF_CLASS",
    "PRIOR",
    "SCORERS",
    "VERDICT_LABELS",
    "VERDICT_PHRASES",
    "Calibration",
    "DemoScores",
    "Identification",
    "LibraryError",
    "StyleLibrary",
    "Verdict",
    "calibrate_temperature",
    "check_answerable",
    "constraint_binds",
    "demo_scores",
    "driver_posterior",
    "fit_verdict",
    "identify",
    "identify_all",
    "identify_driver",
    "kl_from_uniform",
    "posterior_from_scores",
    "recorded_verdict_label",
    "risk_interval",
    "risk_log_likelihood",
    "summarise",
    "verdict_label",
]

SCORERS = ("feature", "rmse_xy", "rmse_y", "suboptimality")
LIKELIHOOD = "likelihood"
"""The scorer of a :class:`~drivestyle.irl.identification.library.DriverLibrary`: the
demonstration's teacher-forced residuals under the one learned style as a function of p
(DESIGN §15)."""
DENSITY_STEP = 0.005
"""Spacing of the continuous posterior's grid over p ∈ [0.5, 0.99]."""
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
"""The paper model's stand-in for a binding constraint: a demonstration can say something
about p only when its TV comes within this elliptical index of the EV (s_e < 8, 120 m ahead
or behind in the same lane); farther, no library risk changes the SMPC's path (probes with
the TV 60–150 m behind: identical paths for p = 0.5 … 0.95)."""
INTERVAL_MASS = 0.9
"""Posterior mass of the reported risk interval."""
OUT_OF_CLASS_FACTOR = 55.0
"""k: a demonstration is *out of class* when its residual RMS at the best risk exceeds k noise
floors (:attr:`~drivestyle.irl.identification.library.DriverLibrary.noise_floor`, 0.1005 σ_u for
runs/library). Measured with runs/library: 10 simulated SMPC drivers of continuous risk
(random interactive scenarios, seed 4000) 2–50 floors exact and 10–52 through the 0.1 m
tracker — large because the 13-risk profile misses the true risk's sharp minimum (a 0.01
grid around it gives 0.3–11 floors exact, 9–51 tracked); recorded episodes (recovered
inputs) 12 NGSIM 50–75, 6 CATS AV 48–73; inputs with 3 σ_u of added noise 27–61. k = 55 is
the smallest round factor above every simulated in-class driver: on the coarse profile the
flag is a weak test (it fires for 8 of 12 NGSIM and 4 of 6 CATS AV episodes) and means "not
of the class" only when it fires."""
KL_INFORMATIVE = float(np.log(4 / 3))
"""Least KL(posterior ‖ prior) [nats] of an informative identification: log(4/3) ≈ 0.29,
the KL of a posterior uniform on three quarters of the prior's range (the data ruled out a
quarter). Demonstrations without a binding constraint give 0 exactly; 12 NGSIM episodes
0.01–0.25, 6 CATS AV 0.01–0.17; simulated SMPC drivers whose risk the profile resolves
0.4–4.5."""
ENTERS_REGION_S_E = 0.95
"""A recorded vehicle *enters the safety region* when another vehicle comes within this
elliptical index (s_e < 0.95): every risk p ≥ 0.5 of the class keeps s_e ≥ 1 in its plans
(the chance constraint's nominal ellipse; the tightening only grows with p), and the
library's own SMPC demonstrations come no closer than 1.0000001, so a vehicle inside is
less cautious than the least cautious style and its risk lies outside the library's range.
A tight made-up cut-in at s_e 0.25 was identified *more* cautious than a roomy one before
this flag; 11 of the 14 NGSIM lane changes and 12 of 88 CATS ones enter the 15 m region."""
WIDTH_INFORMATIVE = 0.75
"""Largest 90 % interval width, relative to the prior's (0.45), of an informative
identification: the same quarter ruled out (:data:`KL_INFORMATIVE`). NGSIM 0.84–0.99,
CATS AV 0.96–1.00; simulated SMPC drivers whose risk the profile resolves 0.0–0.66."""


@dataclass(frozen=True)
class DemoScores:
    """Every scorer's score of every library risk on one demonstration (lower is better)."""

    scores: Mapping[str, tuple[float, ...]]
    """Scorer → score per library risk (the median over the risk's nearest members)."""
    constraint_binds: bool
    """Whether p can matter in this demonstration: a chance constraint binds at some step
    (driver libraries, :func:`constraint_binds`), or the TV came within
    s_e < :data:`S_E_INFORMATIVE` (paper model). A fact of the demonstration, not a
    verdict (:attr:`Verdict.label`)."""
    min_s_e: float
    """Closest approach of the TV in ellipse units."""
    trigger_fired: bool
    """Whether the reaction trigger fired (the reactive features are active)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``scores`` as lists over the library's risks)."""
        return {
            "scores": {s: list(v) for s, v in self.scores.items()},
            "constraint_binds": self.constraint_binds,
            "min_s_e": self.min_s_e,
            "trigger_fired": self.trigger_fired,
        }


INFORMATIVE = "informative"
PRIOR = "prior"
NO_CONSTRAINT = "no_constraint"
OUT_OF_CLASS = "out_of_class"
ENTERS_REGION = "enters_region"
VERDICT_PHRASES: Mapping[str, str] = {
    INFORMATIVE: "informative: the data identify the risk",
    PRIOR: "the prior: nothing in the data moves the risk",
    NO_CONSTRAINT: "the prior: nothing in the data can move the risk",
    OUT_OF_CLASS: "out of class: the style does not describe this driver",
    ENTERS_REGION: "less cautious than the class: its risk lies below the library's range",
}
"""A verdict's label → its phrase, in the order of :func:`verdict_label`'s answers (the
only verdict vocabulary: reports count and print these)."""
VERDICT_LABELS: tuple[str, ...] = tuple(VERDICT_PHRASES)
"""The labels of :data:`VERDICT_PHRASES`, in report order."""


def verdict_label(
    constraint_binds: bool, moved: bool, out_of_class: bool, enters_region: bool
) -> str:
    """The one label of a verdict (:data:`VERDICT_LABELS`), from its flags.

    The first that applies: ``enters_region`` (another vehicle came inside the safety
    region every risk keeps clear of: less cautious than the class), ``out_of_class`` (the
    residuals are too large for any style of the class), ``no_constraint`` (no chance
    constraint binds, so the data cannot move the risk: the posterior is the prior),
    ``informative`` (the posterior moved: KL and interval width pass), else ``prior``
    (in the class, but the data barely moved the risk). A driver outside the class comes
    first because its posterior, moved or not, is not a risk of the class.

    Args:
        constraint_binds: a chance constraint binds at some step (paper model: a TV came
            within :data:`S_E_INFORMATIVE`).
        moved: KL > :data:`KL_INFORMATIVE` and width ratio < :data:`WIDTH_INFORMATIVE`.
        out_of_class: the residual RMS exceeds :data:`OUT_OF_CLASS_FACTOR` noise floors.
        enters_region: another vehicle came to s_e < :data:`ENTERS_REGION_S_E`.

    Returns:
        One of :data:`VERDICT_LABELS`.
    """
    if enters_region:
        return ENTERS_REGION
    if out_of_class:
        return OUT_OF_CLASS
    if not constraint_binds:
        return NO_CONSTRAINT
    return INFORMATIVE if moved else PRIOR


def recorded_verdict_label(
    informative: bool | None,
    out_of_class: bool | None,
    constraint_binds: bool | None,
    enters_region: bool | None,
) -> str:
    """:func:`verdict_label` of a verdict's recorded flags (a ``styles.csv`` row).

    A row records ``informative`` (the label was ``informative``), not whether the
    posterior moved; where the label depends on ``moved`` (binding, in class and not in the
    region) the two agree, so ``informative`` stands in for it. Flags a table of an earlier
    version lacks (None): ``out_of_class`` and ``enters_region`` false (a driver inside the
    region was flagged ``out_of_class`` then, so it reads as out of class), and
    ``constraint_binds`` true (a row without a binding constraint reads as ``prior``: its
    posterior is the prior either way).
    """
    return verdict_label(
        constraint_binds is not False, bool(informative), bool(out_of_class), bool(enters_region)
    )


@dataclass(frozen=True)
class Verdict:
    """What the data added to the prior, and whether the style describes the driver at all.

    Every identification carries one (:attr:`Identification.verdict`); its fields are the
    numbers, and everything said about them — the flags, the :attr:`label`, the
    :attr:`reason` — is derived from them here, so no two can disagree. For a driver
    library (DESIGN §15): the residual RMS the demonstrations leave at their best risk,
    √(min_p S(p) / n) [σ_u units], against the library's noise floor
    √(fit_residual² + s_floor²)
    (:attr:`~drivestyle.irl.identification.library.DriverLibrary.noise_floor`): out of class above
    :data:`OUT_OF_CLASS_FACTOR` floors. What the data added: the KL divergence of the posterior from
    the uniform prior, KL = Σ_i q_i log(q_i / u_i) [nats] (0 for the prior itself, log N for a point
    mass on one of N cells), and the 90 % interval's width relative to the prior's; the posterior
    *moved* when KL > :data:`KL_INFORMATIVE` and the width ratio < :data:`WIDTH_INFORMATIVE`. A
    paper-model library has no residual scale (``residual_rms`` and ``noise_floor`` None, never out
    of class); its KL and width are those of the posterior over the library's risks, and a TV
    within s_e < :data:`S_E_INFORMATIVE` stands for a binding constraint.
    """

    residual_rms: float | None
    """Residual RMS at the best risk [σ_u units] (None: no step yet, or a paper model)."""
    noise_floor: float | None
    """The residual RMS one driver of the class leaves [σ_u units] (None: paper model)."""
    kl_nats: float
    """KL(posterior ‖ prior) [nats]."""
    width_ratio: float
    """The 90 % interval's width over the prior's 90 % interval's width."""
    constraint_binds: bool
    """Whether a chance constraint binds at some step (at the largest risk): the only
    steps whose plan depends on p (paper model: whether a TV came within
    :data:`S_E_INFORMATIVE`)."""
    min_s_e: float | None = None
    """The closest approach of any other vehicle [ellipse units] (None: not known)."""

    @property
    def paper_model(self) -> bool:
        """Whether this is a paper-model library's verdict (no residual scale)."""
        return self.noise_floor is None

    @property
    def moved(self) -> bool:
        """Whether the posterior moved from the prior: a quarter of the range ruled out."""
        return self.kl_nats > KL_INFORMATIVE and self.width_ratio < WIDTH_INFORMATIVE

    @property
    def floors(self) -> float | None:
        """``residual_rms`` in noise floors (None where either is None)."""
        if self.residual_rms is None or not self.noise_floor:
            return None
        return self.residual_rms / self.noise_floor

    @property
    def residual_out_of_class(self) -> bool:
        """Whether ``residual_rms`` exceeds :data:`OUT_OF_CLASS_FACTOR` noise floors.

        Then the style does not describe this driver and its risk is that of the nearest
        style.
        """
        if self.residual_rms is None or self.noise_floor is None:
            return False
        return self.residual_rms > OUT_OF_CLASS_FACTOR * self.noise_floor

    @property
    def enters_region(self) -> bool:
        """Whether another vehicle came inside the safety region every risk keeps clear of.

        Closest s_e < :data:`ENTERS_REGION_S_E`, once there are residuals: less cautious
        than the class allows.
        """
        return (
            self.residual_rms is not None
            and self.min_s_e is not None
            and self.min_s_e < ENTERS_REGION_S_E
        )

    @property
    def out_of_class(self) -> bool:
        """Whether the style does not describe the driver.

        Its residuals (:attr:`residual_out_of_class`) or a vehicle inside the region
        (:attr:`enters_region`) say so.
        """
        return self.residual_out_of_class or self.enters_region

    @property
    def label(self) -> str:
        """The verdict in one word (:func:`verdict_label`, :data:`VERDICT_LABELS`)."""
        return verdict_label(
            self.constraint_binds, self.moved, self.residual_out_of_class, self.enters_region
        )

    @property
    def informative(self) -> bool:
        """Whether the identified risk says something: the :attr:`label` is ``informative``.

        A chance constraint binds, the posterior moved and the driver is of the class.
        """
        return self.label == INFORMATIVE

    @property
    def phrase(self) -> str:
        """The :attr:`label` in words (:data:`VERDICT_PHRASES`)."""
        return VERDICT_PHRASES[self.label]

    @property
    def reason(self) -> str:
        """Why, one line: the numbers behind each flag, each part chosen by that flag.

        No parentheses at the top level, so :attr:`headline` can put it in some.
        """
        parts = []
        if self.enters_region:
            parts.append(
                f"another vehicle came to s_e {self.min_s_e:.2f}, inside the safety region "
                "every risk keeps clear of, s_e ≥ 1"
            )
        if self.residual_out_of_class:
            parts.append(
                f"residual RMS {self.residual_rms:.2f} σ_u is {self.floors:.0f}× the class's "
                f"noise floor {self.noise_floor:.3f}, above {OUT_OF_CLASS_FACTOR:g}×"
            )
        closest = "" if self.min_s_e is None else f": closest s_e {self.min_s_e:.1f}"
        if self.paper_model:
            near = f"within s_e {S_E_INFORMATIVE:g}{closest}"
            parts.append(f"paper model, a TV came {near}" if self.constraint_binds
                         else f"paper model, no TV came {near}")  # fmt: skip
        elif self.residual_rms is None:
            parts.append("no step yet")
        elif not self.constraint_binds:
            parts.append("no chance constraint binds at any risk, the other vehicles never "
                         f"come near{closest}")  # fmt: skip
        if self.constraint_binds:
            # each comparison printed as it came out, so the text cannot contradict the flag
            kl = ">" if self.kl_nats > KL_INFORMATIVE else "≤"
            width = "<" if self.width_ratio < WIDTH_INFORMATIVE else "≥"
            parts.append(
                f"the data {'moved' if self.moved else 'barely moved'} the posterior: "
                f"KL {self.kl_nats:.3f} {kl} {KL_INFORMATIVE:.3f} nats, interval "
                f"{self.width_ratio:.1%} {width} {WIDTH_INFORMATIVE:.0%} of the prior's"
            )
        return "; ".join(parts)

    @property
    def headline(self) -> str:
        """The verdict first, the why after: ``<phrase> (<reason>)``."""
        return f"{self.phrase} ({self.reason})"

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (keys of ``identify.json``)."""
        return {
            "verdict": self.label,
            "informative": self.informative,
            "out_of_class": self.out_of_class,
            "residual_rms": self.residual_rms,
            "noise_floor": self.noise_floor,
            "residual_floors": self.floors,
            "kl_nats": self.kl_nats,
            "interval_width_ratio": self.width_ratio,
            "constraint_binds": self.constraint_binds,
            "enters_region": self.enters_region,
            "min_s_e": self.min_s_e,
            "reason": self.reason,
        }


def kl_from_uniform(mass: np.ndarray) -> float:
    """KL(q ‖ u) of a distribution ``mass`` on N cells from the uniform u = 1/N [nats].

    KL = Σ_i q_i log(q_i N) (terms with q_i = 0 are 0): 0 for q = u, log N for a point
    mass. Clipped at 0 against round-off.

    Args:
        mass: q, shape (N,), non-negative, summing to 1.
    """
    q = np.asarray(mass, float)
    q = q[q > 0]
    return max(float(np.sum(q * np.log(q * np.asarray(mass).size))), 0.0)


def constraint_binds(profile: RiskProfile) -> bool:
    """Whether a chance constraint binds at some step of ``profile`` at some risk.

    The solver flags a step active when a chance multiplier exceeds 1e-8
    (:attr:`~drivestyle.irl.driver.risk_profile.RiskProfile.n_active`); an interior-point
    multiplier is never exactly 0, so vehicles 120–150 m away are flagged too. A
    constraint that binds changes a plan, so S(p) is not constant: it binds when S
    varies over the risks by more than one residual entry at the floor,
    max S − min S > s_floor² (the flagged far-TV demonstrations vary by < 1e-5).
    """
    return profile.n_active > 0 and float(np.ptp(profile.ssr)) > RESIDUAL_FLOOR**2


def fit_verdict(
    ssr: np.ndarray,
    n_residuals: int,
    binds: bool,
    noise_floor: float,
    mass: np.ndarray,
    interval: tuple[float, float],
    prior_interval: tuple[float, float],
    min_s_e: float,
) -> Verdict:
    """The :class:`Verdict` of a driver library's identification.

    Args:
        ssr: the pooled residual sums S(p) on the posterior's grid (σ_u units squared).
        n_residuals: n, the residual count behind ``ssr``.
        binds: whether a chance constraint binds at some step (:func:`constraint_binds`).
        noise_floor: the library's noise floor [σ_u units].
        mass: the posterior on the grid (sums to 1; the prior is uniform on it).
        interval: the posterior's central 90 % interval (its quantiles, before any
            widening to the whole range).
        prior_interval: the prior's central 90 % interval on the same grid.
        min_s_e: the closest approach of any other vehicle [ellipse units].

    Returns:
        The verdict (:data:`OUT_OF_CLASS_FACTOR`, :data:`KL_INFORMATIVE`,
        :data:`WIDTH_INFORMATIVE`).
    """
    rms = float(np.sqrt(max(float(np.min(ssr)), 0.0) / n_residuals)) if n_residuals else None
    kl = kl_from_uniform(mass)
    width = (interval[1] - interval[0]) / (prior_interval[1] - prior_interval[0])
    return Verdict(rms, noise_floor, kl, float(width), binds, float(min_s_e))


def _paper_verdict(
    risks: np.ndarray,
    posterior: np.ndarray,
    interval: tuple[float, float],
    near: bool,
    min_s_e: float,
) -> Verdict:
    """The :class:`Verdict` of a paper-model identification (no residual scale).

    A TV within s_e < :data:`S_E_INFORMATIVE` stands for a binding constraint; KL and width
    are those of the posterior over the library's risks, whose prior is uniform on them.
    """
    kl = kl_from_uniform(posterior)
    width = (interval[1] - interval[0]) / float(np.ptp(risks))
    return Verdict(None, None, kl, float(width), near, float(min_s_e))


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
    density_risks: tuple[float, ...] = ()
    """Grid of the continuous posterior over p (driver libraries; empty otherwise)."""
    density: tuple[float, ...] = ()
    """Posterior mass at each of :attr:`density_risks` (sums to 1)."""
    verdict: Verdict | None = None
    """What the data added and whether the style fits (:class:`Verdict`; set by
    :func:`summarise` and :func:`driver_posterior`)."""

    @property
    def risk_mode(self) -> float:
        """The posterior's mode (its density's argmax; else :attr:`risk_estimate`).

        Driver libraries have a density on a fine grid; a paper-model library's mode is
        the library risk of the largest mass. A library's risks are a coarse grid: a
        posterior peaked halfway between two of them gives its mass to one of them, which
        can lie outside the 90 % interval; the density's argmax cannot.
        """
        if self.density:
            return float(self.density_risks[int(np.argmax(self.density))])
        return self.risk_estimate

    @property
    def informative(self) -> bool:
        """Whether the identified risk says something (:attr:`Verdict.informative`).

        False without a verdict.
        """
        return self.verdict is not None and self.verdict.informative

    @property
    def label(self) -> str | None:
        """The verdict's label (:attr:`Verdict.label`; None without a verdict)."""
        return None if self.verdict is None else self.verdict.label

    @property
    def out_of_class(self) -> bool:
        """Whether the style does not describe the driver (:attr:`Verdict.out_of_class`)."""
        return self.verdict is not None and self.verdict.out_of_class

    @property
    def reason(self) -> str:
        """Why the verdict is what it is, one line (:attr:`Verdict.reason`)."""
        return "" if self.verdict is None else self.verdict.reason

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
            "risk_mode": self.risk_mode,
            "risk_interpolated": self.risk_interpolated,
            "risk_interval": list(self.risk_interval),
            "interval_mass": self.interval_mass,
            "posterior": {str(p): q for p, q in zip(self.risks, self.posterior, strict=True)},
            "informative": self.informative,
            **(self.verdict.to_json() if self.verdict is not None else {}),
            "constraint_binds_per_demo": [d.constraint_binds for d in self.per_demo],
            "min_s_e_per_demo": [d.min_s_e for d in self.per_demo],
            "scores": all_scores[self.scorer],
            "all_scores": all_scores,
            "ranking": list(self.ranking),
            "n_demos": len(self.per_demo),
            "trigger_fired": self.trigger_fired,
            "trigger_fired_per_demo": [d.trigger_fired for d in self.per_demo],
            "true_risk": list(self.true_risks),
            **(
                {
                    "posterior_density": {
                        "risks": list(self.density_risks),
                        "mass": list(self.density),
                    }
                }
                if self.density
                else {}
            ),
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
    """exp(ℓ) normalised to sum 1 (:func:`_check_finite` first)."""
    _check_finite(log_lik, what)
    post = np.exp(log_lik - np.max(log_lik))
    return post / post.sum()


def _check_finite(log_lik: np.ndarray, what: str) -> None:
    """Refuse a log-likelihood that would make the posterior NaN (never output NaN).

    Raises:
        LibraryError: ℓ is NaN somewhere, or +inf or −inf everywhere (no risk is possible).
    """
    if np.isnan(log_lik).any() or not np.isfinite(np.max(log_lik)):
        raise LibraryError(
            f"the posterior over the risk is not finite ({what}): the log-likelihood is "
            f"{'NaN' if np.isnan(log_lik).any() else 'infinite'}; check the library's "
            "temperature and the demonstrations"
        )


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
        verdict=_paper_verdict(risks_a, posterior, interval, near, closest),
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
    library: StyleLibrary | DriverLibrary,
    scorer: str = DEFAULT_SCORER,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> Identification:
    """Identify one vehicle's risk from its demonstration(s), with an honest uncertainty.

    Args:
        demos: one demonstration or several of the same vehicle (their evidence pools).
        library: a driver library (the continuous risk of :func:`identify_driver`; the
            other arguments are unused) or a paper-model style library (at least
            :data:`MIN_MEMBERS` training scenarios).
        scorer: one of :data:`SCORERS` (lower is better).
        control_point_rule: control-point rule of the demonstrations.
        f_floor: floor of the relative feature error's denominators.
        nearest: per risk, the members of the nearest training scenarios to score (None:
            all).

    Returns:
        The :class:`Identification`: posterior mode, mean and 90 % interval, the
        posterior, the ranking, the scores and the :class:`Verdict`.

    Raises:
        ValueError: unknown scorer or no demonstrations.
        LibraryError: a demonstration is of another kind or degenerate (no TV, no lane
            change, no motion, a time grid other than its scenario's T_s), or the library
            has too few training scenarios.
    """
    demos = _as_list(demos)
    if isinstance(library, DriverLibrary):
        return identify_driver(demos, library)
    if scorer not in SCORERS:
        raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
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


# ---------------------------------------------------------------------------- driver libraries
def _min_s_e(demo: Demonstration) -> float:
    sc = demo.scenario
    vehicles = demo.vehicles
    s_e = elliptical_index(
        demo.ev[:, None, 0] - vehicles[..., 0], demo.ev[:, None, 1] - vehicles[..., 1],
        sc.l_a, sc.l_b,
    )  # fmt: skip
    return float(np.min(s_e))


def density_grid() -> np.ndarray:
    """The continuous posterior's grid over :data:`RISK_RANGE`, :data:`DENSITY_STEP` apart."""
    lo, hi = RISK_RANGE
    return np.round(np.arange(lo, hi + 1e-9, DENSITY_STEP), 4)


def risk_log_likelihood(
    profiles: Sequence[RiskProfile], temperature: float, grid: np.ndarray | None = None
) -> np.ndarray:
    """Log p(demonstrations | p) on ``grid`` (DESIGN §15), up to a constant.

    The residual sums of the demonstrations add (one vehicle, one p); between the solved
    risks they are interpolated linearly. With S(p) that sum, n its residual count and
    s² = min S / n + s_floor² the residual scale the best risk leaves (noise and model
    error; never below :data:`~drivestyle.irl.driver.driver_style.RESIDUAL_FLOOR`),
    ℓ(p) = −(S(p) − min S) / (2 τ² s²). Demonstrations without a step at which p matters
    contribute nothing.

    Args:
        profiles: the demonstrations' :class:`~drivestyle.irl.driver.risk_profile.RiskProfile`.
        temperature: τ > 0 (residuals of neighbouring steps are correlated: τ > 1 widens).
        grid: risks to evaluate at (default :func:`density_grid`).

    Returns:
        ℓ on the grid, max 0.
    """
    if not (np.isfinite(temperature) and temperature > 0):
        raise LibraryError(f"temperature must be a finite number > 0, got {temperature}")
    grid = density_grid() if grid is None else np.asarray(grid, float)
    used = [pr for pr in profiles if pr.n_active > 0]
    if not used:
        return np.zeros(grid.size)
    total = sum(np.interp(grid, pr.risks, pr.ssr) for pr in used)
    n = sum(pr.n_residuals for pr in used)
    s2 = float(np.min(total)) / n + RESIDUAL_FLOOR**2
    # τ² s² as one product of floats: τ**2 of a Python float raises OverflowError
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        ll = -(total - np.min(total)) / (2.0 * np.float64(temperature) ** 2 * s2)
    _check_finite(ll, f"temperature {temperature:g}, residual sums {float(np.min(total)):.3g}"
                      f" … {float(np.max(total)):.3g}")  # fmt: skip
    return ll - np.max(ll)


def _grid_mass(grid: np.ndarray, density: np.ndarray, risks: Sequence[float]) -> np.ndarray:
    """The continuous posterior's mass in each grid risk's cell (midpoints as borders)."""
    r = np.asarray(risks, float)
    edges = np.concatenate([[-np.inf], (r[1:] + r[:-1]) / 2, [np.inf]])
    cell = np.searchsorted(edges, grid, side="right") - 1
    return np.bincount(cell, weights=density, minlength=r.size)[: r.size]


def _quantile(grid: np.ndarray, density: np.ndarray, q: float) -> float:
    return float(grid[min(int(np.searchsorted(np.cumsum(density), q - 1e-12)), grid.size - 1)])


def _interval(grid: np.ndarray, density: np.ndarray) -> tuple[float, float]:
    """The central :data:`INTERVAL_MASS` interval of a mass on ``grid``, to its cells' edges.

    Each grid point's mass stands for its cell [g − h/2, g + h/2] (h = :data:`DENSITY_STEP`),
    so the quantiles' cells are included whole (clipped to the range): with the refined
    profile a posterior can be a few cells wide, and a true risk between two grid points
    then fell outside the points-only interval (validation, continuous risks: 59 % covered
    at the cells' centres, 86 % to their edges).
    """
    tail = (1 - INTERVAL_MASS) / 2
    half = DENSITY_STEP / 2
    lo = max(_quantile(grid, density, tail) - half, float(grid[0]))
    hi = min(_quantile(grid, density, 1 - tail) + half, float(grid[-1]))
    return lo, hi


def _posterior(
    profiles: Sequence[RiskProfile], temperature: float, grid: np.ndarray
) -> tuple[np.ndarray, tuple[float, float]]:
    """The posterior mass on ``grid`` (uniform prior) and its central 90 % interval."""
    density = np.exp(risk_log_likelihood(profiles, temperature, grid))
    density /= density.sum()  # finite: risk_log_likelihood refuses a non-finite posterior
    return density, _interval(grid, density)


def identify_driver(
    demos: Demonstration | Sequence[Demonstration],
    library: DriverLibrary,
    profiles: Sequence[RiskProfile] | None = None,
) -> Identification:
    """One vehicle's risk as a continuous parameter of the library's style (DESIGN §15).

    Each demonstration's teacher-forced residual sum is computed as a function of p
    (:func:`~drivestyle.irl.driver.risk_profile.risk_profile`), turned into a likelihood
    (:func:`risk_log_likelihood`) and, with a uniform prior on [0.5, 0.99], into a
    posterior over p on :func:`density_grid`. Reported: ``risk_interpolated`` its mean,
    ``risk_interval`` its central 90 % interval, ``posterior`` its mass in each library
    risk's cell and ``risk_estimate`` the library risk with most mass. No nearest-scenario
    lookup: the style is the driver's in every scenario.

    Args:
        demos: one demonstration or several of the same vehicle.
        library: the driver library.
        profiles: precomputed risk profiles of ``demos`` (evaluation reuses them).

    Returns:
        The :class:`Identification` (scorer ``"likelihood"``).

    Raises:
        LibraryError: a demonstration is of another kind, degenerate or off its
            scenario's time grid.
    """
    # a recorded episode beyond its scenario's heading bound is seen as the driver model
    # sees recorded traffic (its bounds, its recovered inputs): under the scenario's highway
    # bounds its own states are infeasible and every solve fights them (10–23 s per CATS
    # episode instead of 0.05–3 s)
    demos = [recorded_view(d) for d in _as_list(demos)]
    for d in demos:
        _check_kind(d)
    if profiles is None:
        try:
            profiles = [refined_profile(library.style, d) for d in demos]
        except DriverStyleError as exc:
            raise LibraryError(f"cannot identify this demonstration: {exc}") from None
    return driver_posterior(
        profiles, library, [_min_s_e(d) for d in demos], [_true_risk(d) for d in demos]
    )


def driver_posterior(
    profiles: Sequence[RiskProfile],
    library: DriverLibrary,
    min_s_e: Sequence[float],
    true_risks: Sequence[float | None],
) -> Identification:
    """The :class:`Identification` of demonstrations' risk profiles (:func:`identify_driver`).

    Shared by the offline identification and the online tracker
    (:class:`drivestyle.irl.identification.online.StyleTracker`), so both report the same posterior.

    Args:
        profiles: each demonstration's (or stream's) residual sums over the risks.
        library: the driver library (its risks, temperature).
        min_s_e: each demonstration's closest approach in ellipse units.
        true_risks: each demonstration's true risk, where known.

    Returns:
        The :class:`Identification` (scorer ``"likelihood"``).
    """
    grid = density_grid()
    density, (lo, hi) = _posterior(profiles, library.temperature, grid)
    uniform = np.full(grid.size, 1.0 / grid.size)
    prior_interval = _interval(grid, uniform)
    verdict = fit_verdict(
        sum((np.interp(grid, pr.risks, pr.ssr) for pr in profiles), np.zeros(grid.size)),
        sum(pr.n_residuals for pr in profiles),
        any(constraint_binds(pr) for pr in profiles),
        library.noise_floor,
        density,
        (lo, hi),
        prior_interval,
        min(min_s_e, default=float("inf")),
    )
    risks = np.asarray(library.risks, float)
    mass = _grid_mass(grid, density, library.risks)
    order = np.argsort(-mass, kind="stable")
    per_demo = [
        DemoScores(
            scores={LIKELIHOOD: tuple(np.interp(risks, pr.risks, pr.ssr).tolist())},
            constraint_binds=constraint_binds(pr),
            min_s_e=float(s_e),
            trigger_fired=pr.n_active > 0,
        )
        for pr, s_e in zip(profiles, min_s_e, strict=True)
    ]
    if not verdict.constraint_binds:
        lo, hi = RISK_RANGE  # nothing was learned about p: say so, not a prior's quantiles
    return Identification(
        scorer=LIKELIHOOD,
        risks=tuple(float(p) for p in risks),
        posterior=tuple(float(q) for q in mass),
        risk_estimate=float(risks[order[0]]),
        risk_interpolated=float(density @ grid),
        risk_interval=(lo, hi),
        ranking=tuple(float(risks[i]) for i in order),
        per_demo=tuple(per_demo),
        true_risks=tuple(true_risks),
        density_risks=tuple(float(p) for p in grid),
        density=tuple(float(q) for q in density),
        verdict=verdict,
    )


TEMPERATURES = (0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0)
"""Candidates of :func:`calibrate_temperature`."""


@dataclass(frozen=True)
class Calibration:
    """The temperature chosen for a driver library and the coverage behind the choice."""

    temperature: float
    """The smallest candidate τ whose 90 % intervals cover the truth for ≥ 90 % of the
    calibration demonstrations (the largest candidate if none does)."""
    coverage: Mapping[float, float]
    """τ → coverage on the calibration demonstrations."""
    n_demos: int
    """Informative calibration demonstrations."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "temperature": self.temperature,
            "coverage": {str(t): c for t, c in self.coverage.items()},
            "n_demos": self.n_demos,
        }


def calibrate_temperature(
    library: DriverLibrary,
    demos: Sequence[Demonstration],
    target: float = INTERVAL_MASS,
    candidates: Sequence[float] = TEMPERATURES,
) -> Calibration:
    """Choose τ so that the 90 % intervals cover the true risks of ``demos`` (DESIGN §15).

    Args:
        library: the driver library (its temperature is ignored).
        demos: calibration demonstrations with ``meta["risk"]`` (scenarios not used for
            learning; continuous risks make the intervals honest between grid risks).
        target: the coverage to reach.
        candidates: increasing temperatures to try.

    Returns:
        The :class:`Calibration`.

    Raises:
        ValueError: no demonstration with a true risk and an active chance constraint.
    """
    pairs = []
    for d in demos:
        truth = _true_risk(d)
        if truth is None:
            continue
        pr = refined_profile(library.style, d)
        if pr.n_active > 0:
            pairs.append((pr, truth))
    if not pairs:
        raise ValueError(
            "no calibration demonstration with a true risk and an active chance constraint"
        )
    grid = density_grid()
    coverage: dict[float, float] = {}
    for tau in candidates:
        hits = 0
        for pr, truth in pairs:
            _, (lo, hi) = _posterior([pr], tau, grid)
            hits += lo - 1e-9 <= truth <= hi + 1e-9  # the interval reaches its cells' edges
        coverage[float(tau)] = hits / len(pairs)
    chosen = next((t for t, c in coverage.items() if c >= target), float(candidates[-1]))
    return Calibration(chosen, coverage, len(pairs))
