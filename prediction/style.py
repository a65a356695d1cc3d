"""The style predictors: a driver style driven in closed loop from the observed state.

DESIGN §17. A style rollout (:func:`style_rollout`) drives the receding-horizon style model
(:mod:`drivestyle.irl.driver.driver_style`) in closed loop from ξ_k, the surrounding vehicles
predicted at constant velocity from their last observed states (the observer does not know
their future either). The style is what tells the predictors apart:

- ``population`` (:func:`population_style`): one style for every vehicle, the library's cost
  at its middle risk (no identification);
- ``mode``: the library's style at the online posterior's mode — the posterior density's
  argmax (:func:`online_posterior`, a
  :class:`~drivestyle.irl.identification.online.StyleTracker` fed the observed samples,
  inputs unseen);
- ``mixture`` (:class:`PosteriorMixture`): the rollouts at the library's risks averaged with
  the posterior's mass (the mean prediction under the posterior; risks with mass below
  :data:`MIXTURE_MIN_MASS` are dropped and the rest renormalised);
- ``oracle``: the vehicle's true model (for an SMPC(p) demonstration, :func:`oracle_style`:
  :func:`~drivestyle.irl.driver.driver_style.expert_style` of its SMPC).

Each but the mixture is a :class:`StyleRollout` of its style. :func:`rollout_from` is the same
rollout from a given warm start (the online style predictors of :mod:`.online` re-plan with it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_style import DriverStyle, closed_loop, expert_style
from drivestyle.irl.driver.style_planner import StylePlanner, planner_for
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.irl.identification.result import Identification
from drivestyle.planning.description import PrimalDual, SMPCConfig
from drivestyle.prediction.kinematic import others_at_constant_velocity
from drivestyle.prediction.protocol import Observation, PredictedPath

__all__ = [
    "MIXTURE_MIN_MASS",
    "PosteriorMixture",
    "StyleRollout",
    "online_posterior",
    "oracle_style",
    "population_style",
    "rollout_from",
    "style_rollout",
]

MIXTURE_MIN_MASS = 1e-3
"""Library risks with less posterior mass are left out of the mixture."""


# ---------------------------------------------------------------------------- the rollout
def style_rollout(
    style: DriverStyle,
    xi: np.ndarray,
    others: np.ndarray,
    scenario: ScenarioConfig,
    steps: int,
    n_vehicles: int | None = None,
    history: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """The style driven in closed loop from ξ_k for ``steps`` samples (module docstring).

    Args:
        style: weights, risk, desired speed.
        xi: the vehicle's current state, shape (4,).
        others: the surrounding vehicles' current states, shape (m, 4) (predicted at
            constant velocity).
        scenario: the vehicle's scenario (target lane, v_ref, bounds, geometry).
        steps: H.
        n_vehicles: the NLP's vehicle slots (default: 1 for a lone TV, else 4, as learning).
        history: the observed states ξ_0 … ξ_{k−1}, shape (k, 4), and the vehicles' states
            then, shape (k, m, 4): the style re-plans along them, each plan warm-started from
            the previous one as a driver does, and the last warm-starts the first solve
            from ξ_k (the NLP is not convex: a cold start there may find another plan).

    Returns:
        The predicted states, shape (H + 1, 4) (row 0: ξ_k).
    """
    previous = None
    if history is not None:
        planner = _planner(style, others, scenario, n_vehicles)
        for state, around in zip(*history, strict=True):
            res = planner.plan(state, around, style, scenario, previous)
            previous = res.point if res.ok else None
    return rollout_from(style, xi, others, scenario, steps, previous, n_vehicles)[0]


def _planner(
    style: DriverStyle, others: np.ndarray, scenario: ScenarioConfig, n_vehicles: int | None
) -> StylePlanner:
    m = others.shape[0]
    return planner_for(scenario, style.horizon, n_vehicles or (1 if m == 1 else 4))


def rollout_from(
    style: DriverStyle,
    xi: np.ndarray,
    others: np.ndarray,
    scenario: ScenarioConfig,
    steps: int,
    previous: PrimalDual | None = None,
    n_vehicles: int | None = None,
) -> tuple[np.ndarray, PrimalDual | None]:
    """:func:`style_rollout` from a given warm start, also returning the first plan.

    Args:
        style: weights, risk, desired speed.
        xi: the vehicle's current state, shape (4,).
        others: the surrounding vehicles' current states, shape (m, 4) (predicted at
            constant velocity).
        scenario: the vehicle's scenario.
        steps: H.
        previous: the plan of the step before ξ_k, the first solve's warm start (None:
            cold).
        n_vehicles: the NLP's vehicle slots (default as :func:`style_rollout`).

    Returns:
        (the predicted states, shape (H + 1, 4); the plan from ξ_k — the warm start of a
        rollout one step later, or None where that solve failed).
    """
    planner = _planner(style, others, scenario, n_vehicles)
    future = others_at_constant_velocity(others, scenario.dt, steps)
    xs, plans, _, _ = closed_loop(style, np.asarray(xi, float), future, scenario, planner, previous)
    return xs, plans[0]


def _observed_rollout(style: DriverStyle, seen: Observation, steps: int) -> np.ndarray:
    """:func:`style_rollout` from the observation, re-planning along its past; positions."""
    history = (seen.ev[:-1], seen.vehicles[:-1])
    xy = style_rollout(style, seen.state, seen.others, seen.scenario, steps, history=history)
    return xy[:, :2]


# ---------------------------------------------------------------------------- the styles
def population_style(library: DriverLibrary) -> DriverStyle:
    """One style for every vehicle: the library's cost at the median of its risks."""
    return replace(library.style, risk=float(np.median(library.risks)))


def online_posterior(library: DriverLibrary, seen: Observation) -> StyleTracker:
    """The online posterior over the vehicle's risk after its observed samples.

    A fresh :class:`~drivestyle.irl.identification.online.StyleTracker` in the observation's
    scenario fed samples 0 … k (inputs recovered from the states: an observer does not see
    them); its ``estimate`` is the posterior, its ``style("mode")`` the ``mode`` style.
    """
    tracker = StyleTracker(library, seen.scenario)
    for xi, around in zip(seen.ev, seen.vehicles, strict=True):
        tracker.update(xi, around)
    return tracker


def oracle_style(meta: dict[str, Any]) -> DriverStyle | None:
    """The true style of an SMPC demonstration (``"risk"`` and ``"smpc"`` in its meta).

    :func:`~drivestyle.irl.driver.driver_style.expert_style` of the SMPC at the demonstration's
    risk, with its recorded weights and horizon where the meta holds them.

    Returns:
        The style, or None for a demonstration of unknown risk (recorded traffic).
    """
    if "risk" not in meta or "smpc" not in meta:
        return None
    smpc = meta["smpc"] if isinstance(meta["smpc"], dict) else {}
    known = {k: smpc[k] for k in ("Q", "Q_N", "R") if k in smpc}
    fields: dict[str, Any] = {k: tuple(float(x) for x in v) for k, v in known.items()}
    if "horizon" in smpc:
        fields["horizon"] = int(smpc["horizon"])
    cfg = SMPCConfig(risk=float(meta["risk"]), **fields)
    return expert_style(cfg)


# ---------------------------------------------------------------------------- the predictors
@dataclass(frozen=True)
class StyleRollout:
    """One style's closed-loop path from the observed state: ``population``, ``mode``, ``oracle``.

    The style re-plans along the observed samples first (:func:`style_rollout`).
    """

    style: DriverStyle
    """The style driven; its risk is the path's."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The style's path (:class:`~drivestyle.prediction.protocol.Predictor`)."""
        return PredictedPath(_observed_rollout(self.style, seen, steps), self.style.risk)


@dataclass(frozen=True)
class PosteriorMixture:
    """``mixture``: the library style's rollouts at the posterior's risks, mass-weighted.

    Risks of mass below :data:`MIXTURE_MIN_MASS` are left out, the rest renormalised to w;
    the path is Σ w_i · path(p_i), its risk the weighted mean Σ w_i p_i.
    """

    style: DriverStyle
    """The library's style (its risk is replaced by each of the posterior's)."""
    identification: Identification
    """The online posterior (:func:`online_posterior`'s ``estimate``)."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The mixture's path (:class:`~drivestyle.prediction.protocol.Predictor`)."""
        mass = np.asarray(self.identification.posterior)
        keep = mass >= MIXTURE_MIN_MASS
        w = mass[keep] / mass[keep].sum()
        risks = np.asarray(self.identification.risks)[keep]
        rolled = [_observed_rollout(replace(self.style, risk=float(p)), seen, steps) for p in risks]
        xy = np.tensordot(w, np.array(rolled), axes=1)
        return PredictedPath(xy, float(w @ risks))
