"""The verdict of an identification: what the data added, and whether the style fits (DESIGN §15).

Every identification carries one :class:`Verdict` (its numbers: residual RMS and noise
floor, KL from the prior, interval width, whether a constraint binds, the closest approach);
every word said about it — the flags, the one label of :data:`VERDICT_LABELS`
(:func:`verdict_label`, the one rule every report uses), the phrase, the reason — is derived
from those numbers here, so no two can disagree. :func:`fit_verdict` builds the verdict of a
driver library's posterior, :func:`paper_verdict` that of a paper-model library's;
:func:`recorded_verdict_label` reads the label back from a ``styles.csv`` row's flags.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "ENTERS_REGION",
    "ENTERS_REGION_S_E",
    "INFORMATIVE",
    "KL_INFORMATIVE",
    "NO_CONSTRAINT",
    "OUT_OF_CLASS",
    "OUT_OF_CLASS_FACTOR",
    "PRIOR",
    "S_E_INFORMATIVE",
    "VERDICT_LABELS",
    "VERDICT_PHRASES",
    "WIDTH_INFORMATIVE",
    "Verdict",
    "fit_verdict",
    "kl_from_uniform",
    "paper_verdict",
    "recorded_verdict_label",
    "verdict_label",
]

S_E_INFORMATIVE = 8.0
"""The paper model's stand-in for a binding constraint: a demonstration can say something
about p only when its TV comes within this elliptical index of the EV (s_e < 8, 120 m ahead
or behind in the same lane); farther, no library risk changes the SMPC's path (probes with
the TV 60–150 m behind: identical paths for p = 0.5 … 0.95)."""
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

    Every identification carries one
    (:attr:`~drivestyle.irl.identification.result.Identification.verdict`); its fields are the
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


def paper_verdict(
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
