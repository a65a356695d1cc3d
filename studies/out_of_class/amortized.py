"""The out-of-class study's order check on the amortized posterior (``--posterior``).

Every lane change of the study (highway-env's IDM + MOBIL classes, the SMPC variants) is
identified by the amortized posterior over the stochastic driver's parameters
(:func:`~drivestyle.irl.amortized.identify.identify_amortized_batch`: the whole episode,
through the recorded view the exact identification reads; DESIGN §22), and the known
caution is compared with the posterior mean of the parameters that should follow it —
the risk p, the time gap T and the standstill gap s_0 (:data:`ORDERED`: a more cautious
driver has each larger) — by Spearman's ρ over the episodes and over the caution levels'
medians, per scope of :func:`~.caution_order.order_scopes`, beside the exact
identification's ρ of p over the same scope (:class:`~.caution_order.OrderCheck`, all
episodes). Every episode counts: the amortized posterior has no verdict that sets one
aside.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import SAMPLES, AmortizedStyle, identify_amortized_batch
from drivestyle.studies.out_of_class.caution_order import (
    SPEARMAN_GOAL,
    OrderCheck,
    order_scopes,
    spearman,
)

if TYPE_CHECKING:
    from drivestyle.studies.out_of_class.study import OutOfClassEpisode

__all__ = [
    "ORDERED",
    "AmortizedEpisode",
    "AmortizedOrder",
    "AmortizedOutOfClass",
    "amortized_orders",
    "amortized_out_of_class",
]

ORDERED = ("risk", "time_gap", "min_gap")
"""The parameters a more cautious driver has larger: p, T, s_0 (those the estimator infers)."""


@dataclass(frozen=True)
class AmortizedEpisode:
    """One lane change's amortized posterior, with its known caution."""

    family: str
    group: str
    caution: float
    episode_id: str
    style: AmortizedStyle

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict: the ids and caution, and the style's summary."""
        return {"family": self.family, "group": self.group, "caution": self.caution,
                "episode_id": self.episode_id} | self.style.to_json()  # fmt: skip


@dataclass(frozen=True)
class AmortizedOrder:
    """Spearman's ρ between the known caution and one parameter's posterior mean."""

    scope: str
    """As :attr:`~.caution_order.OrderCheck.scope`."""
    parameter: str
    n: int
    rho_episodes: float | None
    p_value: float | None
    rho_medians: float | None
    """ρ over the caution levels' median posterior means."""
    met: bool
    """ρ over the episodes ≥ :data:`~.caution_order.SPEARMAN_GOAL`."""
    rho_exact: float | None = None
    """The exact identification's ρ of p over the scope's episodes (its ``all`` subset)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class AmortizedOutOfClass:
    """The study's episodes on the amortized posterior and their order checks."""

    estimator: str
    estimator_sha256: str
    episodes: tuple[AmortizedEpisode, ...]
    orders: tuple[AmortizedOrder, ...]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``out_of_class.json``'s ``amortized``)."""
        return {
            "estimator": self.estimator,
            "estimator_sha256": self.estimator_sha256,
            "draws": SAMPLES,
            "order": [o.to_json() for o in self.orders],
            "episodes": [e.to_json() for e in self.episodes],
        }


def amortized_orders(
    episodes: Sequence[AmortizedEpisode], exact: Sequence[OrderCheck] = ()
) -> list[AmortizedOrder]:
    """ρ of each :data:`ORDERED` parameter the estimator infers, per scope (module docstring)."""
    if not episodes:
        return []
    names = episodes[0].style.names
    rho_exact = {o.scope: o.rho_episodes for o in exact if o.subset == "all"}
    out = []
    for scope, eps in order_scopes(episodes):
        for name in (n for n in ORDERED if n in names):
            d = names.index(name)
            caution = [e.caution for e in eps]
            rho, pv = spearman(caution, [float(e.style.mean[d]) for e in eps])
            levels = sorted(set(caution))
            med = [float(np.median([e.style.mean[d] for e in eps if e.caution == c]))
                   for c in levels]  # fmt: skip
            rho_m, _ = spearman(levels, med)
            out.append(AmortizedOrder(scope, name, len(eps), rho, pv, rho_m,
                                      rho is not None and rho >= SPEARMAN_GOAL,
                                      rho_exact.get(scope)))  # fmt: skip
    return out


def amortized_out_of_class(
    episodes: Sequence[OutOfClassEpisode],
    posterior: NeuralPosterior,
    exact: Sequence[OrderCheck] = (),
    estimator: str = "",
) -> AmortizedOutOfClass:
    """Identify every lane change with the amortized posterior and check the orders.

    Args:
        episodes: the study's lane changes.
        posterior: the estimator.
        exact: the exact identification's order checks (their ρ is reported beside).
        estimator: where the estimator was read from (for the output).
    """
    styles = identify_amortized_batch(posterior, [e.demo for e in episodes])
    found = tuple(AmortizedEpisode(e.family, e.group, e.caution, e.episode_id, s)
                  for e, s in zip(episodes, styles, strict=True))  # fmt: skip
    return AmortizedOutOfClass(estimator, posterior.weights_sha256(), found,
                               tuple(amortized_orders(found, exact)))  # fmt: skip
