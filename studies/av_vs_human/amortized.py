"""The automated car against humans on the amortized posterior (``compare-av-human --posterior``).

Every CATS lane change of the comparison (:mod:`.study`) is identified by the amortized
posterior over the stochastic driver's parameters
(:func:`~drivestyle.irl.amortized.identify.identify_amortized_batch`: the whole episode,
through the recorded view identification reads; DESIGN §22). Two questions, beside the
study's medians:

* **Does a parameter tell the AV from the humans?** The AUROC of a score — each
  amortized parameter's posterior mean, and each of the study's own descriptors
  (:data:`~.study.QUANTITIES`: the mined risk, time gap, closest approach, speed, lateral
  speed, duration) for comparison — between the AV's lane changes and the humans'
  (all of them, the same car's human days, the other humans):
  :func:`~drivestyle.common.stats.auroc`, P(AV > human) + ½ P(tie), 0.5 when the score
  does not separate, far from it in either direction when it does; its 95 % interval by
  the study's bootstrap of lane changes, within each group
  (:func:`~drivestyle.common.stats.auroc_interval`). The estimator never saw CATS: every
  lane change is held out.
* **Are the AV's parameters consistent across its runs?** The one-way intra-class
  correlation (:func:`~drivestyle.common.stats.icc_oneway`) of each parameter's posterior
  mean over one vehicle's lane changes grouped by run (the recording's carriageway, e.g.
  ``AV-05-E``: a day and a direction; :func:`~drivestyle.recorded.real_data.recorded_vehicle`)
  — the share of its variance between runs: near 0, the runs agree (what they differ by is
  the lane changes' own spread); near 1, each run has its own value — for the AV and the
  same car's human; and over all vehicles (lane changes grouped by vehicle: the share of the
  variance that is the vehicle's — a trait, where it is high).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.common.stats import auroc, auroc_interval, icc_oneway
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import SAMPLES, AmortizedStyle, identify_amortized_batch
from drivestyle.recorded.real_data import recorded_vehicle
from drivestyle.studies.av_vs_human.study import (
    BOOTSTRAP_SAMPLES,
    BOOTSTRAP_SEED,
    GROUPS,
    QUANTITIES,
    SAME_CAR_HUMAN,
    AVHumanComparison,
    group_of,
)

__all__ = [
    "AGAINST",
    "ALL_VEHICLES",
    "HUMANS",
    "AmortizedComparison",
    "AmortizedLaneChange",
    "RunConsistency",
    "Separation",
    "amortized_comparison",
]

HUMANS = "humans"
"""Every human-driven lane change (the same car's and the other vehicles')."""
AGAINST = (HUMANS, *GROUPS[1:])
"""The groups the AV is told apart from, in report order."""
ALL_VEHICLES = "all vehicles"
"""The consistency row whose classes are the vehicles (not one vehicle's runs)."""
AMORTIZED = "amortized:"
"""Prefix of a quantity that is an amortized parameter's posterior mean."""


@dataclass(frozen=True)
class AmortizedLaneChange:
    """One lane change's amortized posterior."""

    episode_id: str
    vehicle: str
    group: str
    run: str
    """The recording's carriageway (a day and a direction), empty where unknown."""
    style: AmortizedStyle

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict: the ids and the style's summary."""
        return {"episode_id": self.episode_id, "vehicle": self.vehicle, "group": self.group,
                "run": self.run} | self.style.to_json()  # fmt: skip


@dataclass(frozen=True)
class Separation:
    """How well one quantity tells the AV's lane changes from another group's."""

    quantity: str
    """A :data:`~.study.QUANTITIES` key or ``amortized:<parameter>``."""
    against: str
    """One of :data:`AGAINST`."""
    n_av: int
    n_other: int
    auroc: float | None
    """P(AV > other) + ½ P(tie); None where a group has no value."""
    lo: float | None
    hi: float | None


@dataclass(frozen=True)
class RunConsistency:
    """The intra-class correlation of one parameter over one vehicle's runs (or the vehicles)."""

    group: str
    """``AV``, ``same car, human`` or :data:`ALL_VEHICLES`."""
    parameter: str
    classes: int
    """Runs (or vehicles)."""
    lane_changes: int
    icc: float | None
    """None: not defined (one run, no run with two lane changes, or no spread)."""
    lo: float | None
    hi: float | None


@dataclass(frozen=True)
class AmortizedComparison:
    """The comparison on the amortized posterior (module docstring)."""

    estimator: str
    """Where the estimator was read from."""
    estimator_sha256: str
    lane_changes: tuple[AmortizedLaneChange, ...]
    separations: tuple[Separation, ...]
    consistency: tuple[RunConsistency, ...]
    samples: int = BOOTSTRAP_SAMPLES
    seed: int = BOOTSTRAP_SEED

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``av_vs_human.json``'s ``amortized``)."""
        return {
            "estimator": self.estimator,
            "estimator_sha256": self.estimator_sha256,
            "draws": SAMPLES,
            "bootstrap": {
                "samples": self.samples,
                "seed": self.seed,
                "unit": "episode (lane change), within each group",
            },
            "auroc": [vars(s) for s in self.separations],
            "consistency": [vars(c) for c in self.consistency],
            "episodes": [e.to_json() for e in self.lane_changes],
        }


def _in_group(group: str, against: str) -> bool:
    return group != "AV" if against == HUMANS else group == against


def amortized_comparison(
    episodes: Sequence[tuple[str, str, Demonstration]],
    comparison: AVHumanComparison,
    posterior: NeuralPosterior,
    estimator: str = "",
    samples: int = BOOTSTRAP_SAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> AmortizedComparison:
    """Identify every lane change and compare (module docstring).

    Args:
        episodes: (episode id, vehicle id, demonstration), as the study was given them.
        comparison: the study's result on them (its descriptors' values per lane change).
        posterior: the estimator.
        estimator: where it was read from (for the output).
        samples: bootstrap replicates.
        seed: their seed (a generator of its own: the study's intervals do not move).

    Returns:
        The comparison.
    """
    styles = identify_amortized_batch(posterior, [d for _, _, d in episodes])
    changes = []
    for (eid, vid, demo), style in zip(episodes, styles, strict=True):
        who = recorded_vehicle(demo)
        changes.append(AmortizedLaneChange(eid, vid, group_of(vid),
                                           who.carriageway if who else "", style))  # fmt: skip
    names = posterior.config.names
    values: dict[str, dict[str, float | None]] = {e.episode_id: dict(e.values)
                                                  for e in comparison.episodes}  # fmt: skip
    for c in changes:
        row = values.setdefault(c.episode_id, {})
        for d, n in enumerate(names):
            row[AMORTIZED + n] = float(c.style.mean[d])
    group = {c.episode_id: c.group for c in changes}
    rng = np.random.default_rng(seed)
    separations = []
    for q in [*QUANTITIES, *(AMORTIZED + n for n in names)]:
        for against in AGAINST:
            av, other = [], []
            for eid, row in values.items():
                v = row.get(q)
                if v is None or eid not in group:
                    continue
                if group[eid] == "AV":
                    av.append(v)
                elif _in_group(group[eid], against):
                    other.append(v)
            if not av or not other:
                separations.append(Separation(q, against, len(av), len(other), None, None, None))
                continue
            lo, hi = auroc_interval(av, other, samples, rng)
            separations.append(Separation(q, against, len(av), len(other), auroc(av, other),
                                          lo, hi))  # fmt: skip
    consistency = []
    for name_of in ("AV", group_of(SAME_CAR_HUMAN), ALL_VEHICLES):
        rows = changes if name_of == ALL_VEHICLES else [c for c in changes if c.group == name_of]
        labels = [c.vehicle if name_of == ALL_VEHICLES else c.run for c in rows]
        for d, n in enumerate(names):
            icc = icc_oneway([c.style.mean[d] for c in rows], labels) if rows else None
            consistency.append(RunConsistency(
                name_of, n, len(set(labels)), len(rows), None if icc is None else icc.icc,
                None if icc is None else icc.lo, None if icc is None else icc.hi,
            ))  # fmt: skip
    return AmortizedComparison(estimator, posterior.weights_sha256(), tuple(changes),
                               tuple(separations), tuple(consistency), samples, seed)  # fmt: skip
