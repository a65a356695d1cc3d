"""Predicting a vehicle's trajectory from its observed past, with or without its style (DESIGN §17).

Not to be confused with :mod:`drivestyle.planning.tv_gaussian`, the SMPC's own model of the
vehicles around it (constant velocity plus a growing covariance, inside the NLP). Here an
*observer* has seen a vehicle's first samples ξ_0 … ξ_k and predicts ξ_{k+1} … ξ_{k+H}:

- ``cv``: constant velocity, the last velocity vector (v cos φ, v sin φ) held;
- ``ca``: constant acceleration, the last velocity change per step held as well;
- ``physics``: IDM car following behind the observed leader plus a fitted quintic lane
  change (:mod:`drivestyle.irl.physics`), with calibrated parameters;
- ``style`` rollouts (:func:`style_rollout`): the receding-horizon style model
  (:mod:`drivestyle.irl.driver.driver_style`) driven in closed loop from ξ_k, the surrounding
  vehicles predicted at constant velocity from their last observed states (the observer
  does not know their future either). With the risk from the online posterior
  (:class:`~drivestyle.irl.identification.online.StyleTracker`): ``mode`` — the posterior density's
  argmax; ``mixture`` — the rollouts at the library's risks averaged with the posterior's
  mass (the mean prediction under the posterior; risks with mass below
  :data:`MIXTURE_MIN_MASS` are dropped and the rest renormalised); ``population`` — one
  style for every vehicle, the library's cost at its middle risk (no identification);
  ``oracle`` — the vehicle's true model (for an SMPC(p):
  :func:`~drivestyle.irl.driver.driver_style.expert_style`).

:func:`predict` runs every method on one demonstration after ``t_obs`` seconds and scores
each with the average and final displacement errors (ADE, FDE) over the rest of it, and
their lateral (|Δy|) and longitudinal (|Δx|) parts in the road frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.units import off_grid
from drivestyle.irl.driver.driver_style import DriverStyle, StylePlanner, closed_loop, planner_for
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.irl.identification.posterior import Identification
from drivestyle.irl.physics import PhysicsParams, physics_forecast
from drivestyle.planning.description import PrimalDual

__all__ = [
    "METHODS",
    "ForecastError",
    "MethodPrediction",
    "Prediction",
    "constant_acceleration",
    "constant_velocity",
    "displacement_errors",
    "error_parts",
    "others_at_constant_velocity",
    "predict",
    "rollout_from",
    "style_rollout",
]

METHODS = ("cv", "ca", "physics", "population", "mode", "mixture", "oracle")
"""Every prediction method, in report order (``oracle`` only where the truth is known)."""
MIXTURE_MIN_MASS = 1e-3
"""Library risks with less posterior mass are left out of the mixture."""


class ForecastError(ValueError):
    """A prediction request the data cannot answer (observation window, shapes)."""


# ---------------------------------------------------------------------------- baselines
def constant_velocity(state: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """Positions under constant velocity: p_j = p_k + j T_s (v cos φ, v sin φ).

    Args:
        state: the last observed state [x, y, φ, v], shape (4,).
        dt: T_s [s].
        steps: H, samples to predict.

    Returns:
        Positions at j = 0 … H, shape (H + 1, 2) (row 0: the last observed position).
    """
    x, y, phi, v = (float(s) for s in state)
    j = np.arange(steps + 1)[:, None] * dt
    return np.array([x, y]) + j * v * np.array([np.cos(phi), np.sin(phi)])


def constant_acceleration(states: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """Positions under constant acceleration: p_j = p_k + j T_s v_k + ½ (j T_s)² a_k.

    The velocity vector is (v cos φ, v sin φ); a_k is its change over the last step
    divided by T_s (zero with one sample).

    Args:
        states: the observed states, shape (k + 1, 4), the last one current.
        dt: T_s [s].
        steps: H.

    Returns:
        Shape (H + 1, 2).
    """
    vel = states[:, 3:4] * np.stack([np.cos(states[:, 2]), np.sin(states[:, 2])], axis=1)
    acc = (vel[-1] - vel[-2]) / dt if len(states) > 1 else np.zeros(2)
    tau = np.arange(steps + 1)[:, None] * dt
    return states[-1, :2] + tau * vel[-1] + 0.5 * tau**2 * acc


def others_at_constant_velocity(others: np.ndarray, dt: float, steps: int) -> np.ndarray:
    """The surrounding vehicles' states over the next ``steps`` at constant velocity.

    Args:
        others: their last observed states, shape (m, 4).
        dt: T_s [s].
        steps: H.

    Returns:
        Shape (H + 1, m, 4) (heading and speed held).
    """
    tau = np.arange(steps + 1)[:, None] * dt
    out = np.repeat(others[None, :, :], steps + 1, axis=0).astype(float)
    out[..., 0] += tau * others[:, 3] * np.cos(others[:, 2])
    out[..., 1] += tau * others[:, 3] * np.sin(others[:, 2])
    return out


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


def displacement_errors(predicted: np.ndarray, actual: np.ndarray) -> tuple[float, float]:
    """(ADE, FDE): mean and final Euclidean distance over the predicted samples [m].

    Args:
        predicted: positions at j = 0 … H, shape (H + 1, 2) (row 0, the present, is
            not scored).
        actual: the true positions, same shape.

    Returns:
        (average displacement error, final displacement error).
    """
    d = np.hypot(*(predicted[1:, :2] - actual[1:, :2]).T)
    return float(d.mean()), float(d[-1])


def error_parts(predicted: np.ndarray, actual: np.ndarray) -> dict[str, float]:
    """ADE and FDE and their lateral and longitudinal parts [m].

    In the road frame: ADE = mean_j ‖p̂_j − p_j‖, ADE_lat = mean_j |ŷ_j − y_j|,
    ADE_lon = mean_j |x̂_j − x_j| over j = 1 … H; FDE, FDE_lat, FDE_lon the same at j = H.

    Args:
        predicted: positions at j = 0 … H, shape (H + 1, 2) (row 0 not scored).
        actual: the true positions, same shape.

    Returns:
        ``ade``, ``ade_lat``, ``ade_lon``, ``fde``, ``fde_lat``, ``fde_lon``.
    """
    ade, fde = displacement_errors(predicted, actual)
    d = np.abs(predicted[1:, :2] - actual[1:, :2])
    return {
        "ade": ade,
        "ade_lat": float(d[:, 1].mean()),
        "ade_lon": float(d[:, 0].mean()),
        "fde": fde,
        "fde_lat": float(d[-1, 1]),
        "fde_lon": float(d[-1, 0]),
    }


# ---------------------------------------------------------------------------- one demonstration
@dataclass(frozen=True)
class MethodPrediction:
    """One method's predicted path and its errors."""

    method: str
    """A name of :data:`METHODS`."""
    xy: np.ndarray
    """Predicted positions from t_obs to the end, shape (H + 1, 2) [m]."""
    ade_m: float
    """Average displacement error over the predicted samples [m]."""
    fde_m: float
    """Displacement error at the last sample [m]."""
    fde_lat_m: float = float("nan")
    """Its lateral part |Δy| at the last sample [m] (where the lane change ends; the rest is
    the longitudinal error, i.e. the speed prediction)."""
    risk: float | None = None
    """The risk the style methods used (the mixture: its posterior mean)."""
    ade_lat_m: float = float("nan")
    """The average error's lateral part, mean |Δy| [m]."""
    ade_lon_m: float = float("nan")
    """The average error's longitudinal part, mean |Δx| [m]."""
    fde_lon_m: float = float("nan")
    """The final error's longitudinal part |Δx| [m]."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction.json``'s per-method entry)."""
        return {
            "ade_m": self.ade_m,
            "ade_lat_m": self.ade_lat_m,
            "ade_lon_m": self.ade_lon_m,
            "fde_m": self.fde_m,
            "fde_lat_m": self.fde_lat_m,
            "fde_lon_m": self.fde_lon_m,
            "risk": self.risk,
            "path": self.xy.round(4).tolist(),
        }


@dataclass(frozen=True)
class Prediction:
    """Every method's prediction of one vehicle after ``t_obs`` seconds (:func:`predict`)."""

    t_obs: float
    """Observed time [s] (samples 0 … k_obs)."""
    t: np.ndarray
    """Times of the predicted samples, t_obs … end, shape (H + 1,) [s]."""
    actual: np.ndarray
    """The true positions at those times, shape (H + 1, 2) [m]."""
    observed: np.ndarray
    """The observed positions, shape (k_obs + 1, 2) [m]."""
    methods: dict[str, MethodPrediction]
    """Method name → prediction (in :data:`METHODS` order)."""
    identification: Identification | None
    """The online posterior at t_obs (None: no identified-style method was run)."""
    true_risk: float | None
    """The vehicle's true risk, where known."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction.json``)."""
        ident = self.identification
        return {
            "t_obs_s": self.t_obs,
            "horizon_s": float(self.t[-1] - self.t[0]),
            "true_risk": self.true_risk,
            "identified": None
            if ident is None
            else {
                "risk_mean": ident.risk_interpolated,
                "risk_interval": list(ident.risk_interval),
                "informative": ident.informative,
                "verdict": ident.label,
            },
            "t": self.t.round(6).tolist(),
            "actual": self.actual.round(4).tolist(),
            "observed": self.observed.round(4).tolist(),
            "methods": {name: m.to_json() for name, m in self.methods.items()},
        }


def _observed_samples(demo: Demonstration, t_obs: float) -> int:
    """k_obs: the index of the last observed sample.

    Raises:
        ForecastError: t_obs is not positive, leaves nothing to predict, or is off the
            demonstration's sampling grid.
    """
    dt = float(demo.t[1] - demo.t[0])
    k = round(t_obs / dt)
    if not (np.isfinite(t_obs) and t_obs > 0):
        raise ForecastError(f"the observed time must be > 0 s, got {t_obs:g}")
    miss = off_grid(t_obs, dt)
    if miss:
        raise ForecastError(f"the observed time {t_obs:g} s {miss}")
    if k >= demo.n - 1:
        span = float(demo.t[-1] - demo.t[0])
        raise ForecastError(
            f"observing {t_obs} s of a {span:.1f} s demonstration leaves nothing to predict"
        )
    return k


def predict(
    demo: Demonstration,
    library: DriverLibrary,
    t_obs: float,
    oracle: DriverStyle | None = None,
    scenario: ScenarioConfig | None = None,
    methods: Sequence[str] = METHODS,
    physics: PhysicsParams | None = None,
) -> Prediction:
    """Observe a demonstration for ``t_obs`` seconds and predict the rest by every method.

    The online tracker sees samples 0 … k_obs (inputs recovered from the states: an
    observer does not see them); each method then predicts samples k_obs … n−1.

    Args:
        demo: the vehicle's demonstration (its EV is the predicted vehicle).
        library: the driver library (the style's cost and risk grid).
        t_obs: observed time [s], a whole number of T_s, less than the demonstration.
        oracle: the vehicle's true style (None: no ``oracle`` method).
        scenario: the scenario the style methods plan in (default: the demonstration's;
            recorded traffic passes one whose v_ref comes from the observed part only).
        methods: the methods to run (a subset of :data:`METHODS`).
        physics: the physics baseline's parameters (default: :class:`PhysicsParams`'s; the
            benchmark passes the calibrated ones).

    Returns:
        The :class:`Prediction`.

    Raises:
        ForecastError: an unknown method, or an observation window the demonstration
            cannot serve.
    """
    unknown = sorted(set(methods) - set(METHODS))
    if unknown:
        raise ForecastError(f"unknown prediction method(s) {unknown}; known: {list(METHODS)}")
    k = _observed_samples(demo, t_obs)
    sc = scenario or demo.scenario
    steps = demo.n - 1 - k
    vehicles = demo.vehicles
    tracker = StyleTracker(library, sc)
    ident = None
    if {"mode", "mixture"} & set(methods):  # the online posterior (inputs recovered)
        for j in range(k + 1):
            ident = tracker.update(demo.ev[j], vehicles[j])
    actual = demo.ev[k:, :2]
    xi, others = demo.ev[k], vehicles[k]

    def rollout(style: DriverStyle) -> np.ndarray:
        history = (demo.ev[:k], vehicles[:k])
        return style_rollout(style, xi, others, sc, steps, history=history)[:, :2]

    paths: dict[str, tuple[np.ndarray, float | None]] = {}
    if "cv" in methods:
        paths["cv"] = (constant_velocity(xi, sc.dt, steps), None)
    if "ca" in methods:
        paths["ca"] = (constant_acceleration(demo.ev[: k + 1], sc.dt, steps), None)
    if "physics" in methods:
        xy = physics_forecast(demo.ev[: k + 1], others, sc.dt, steps, sc.lane_width,
                              sc.vehicle_length, physics or PhysicsParams())  # fmt: skip
        paths["physics"] = (xy, None)
    if "population" in methods:
        p_pop = float(np.median(library.risks))
        paths["population"] = (rollout(replace(library.style, risk=p_pop)), p_pop)
    if "mode" in methods:
        style = tracker.style("mode")
        paths["mode"] = (rollout(style), style.risk)
    if "mixture" in methods and ident is not None:
        mass = np.asarray(ident.posterior)
        keep = mass >= MIXTURE_MIN_MASS
        w = mass[keep] / mass[keep].sum()
        risks = np.asarray(ident.risks)[keep]
        rolled = [rollout(replace(library.style, risk=float(p))) for p in risks]
        xy = np.tensordot(w, np.array(rolled), axes=1)
        paths["mixture"] = (xy, float(w @ risks))
    if "oracle" in methods and oracle is not None:
        paths["oracle"] = (rollout(oracle), oracle.risk)
    out = {}
    for name in METHODS:
        if name in paths:
            xy, risk = paths[name]
            e = error_parts(xy, actual)
            out[name] = MethodPrediction(name, xy, e["ade"], e["fde"], e["fde_lat"], risk,
                                         e["ade_lat"], e["ade_lon"], e["fde_lon"])  # fmt: skip
    true = demo.meta.get("risk")
    return Prediction(
        t_obs=float(t_obs),
        t=demo.t[k:].copy(),
        actual=actual.copy(),
        observed=demo.ev[: k + 1, :2].copy(),
        methods=out,
        identification=ident,
        true_risk=None if true is None else float(true),
    )
