"""Every prediction method by name: predicting a vehicle after t_obs, and scoring each.

DESIGN §17. :func:`predict` observes a demonstration for ``t_obs`` seconds (an
:class:`~drivestyle.prediction.protocol.Observation` of samples 0 … k_obs) and runs every
method of :data:`METHODS` through its :class:`~drivestyle.prediction.protocol.Predictor`
(:func:`method_predictors`: ``cv`` and ``ca`` :mod:`~drivestyle.prediction.kinematic`,
``physics`` :mod:`~drivestyle.prediction.physics`, ``joint_physics``
:mod:`~drivestyle.prediction.joint_physics`, ``population``, ``mode``, ``mixture`` and
``oracle`` :mod:`~drivestyle.prediction.style`), scoring each path against the rest of the
demonstration (:func:`~drivestyle.prediction.errors.error_parts`); the result is a
:class:`Prediction` of one :class:`MethodPrediction` per method. :func:`predict_demo` is the
prediction the benchmark and ``drivestyle predict-trajectory`` make: a recorded episode seen
through :func:`~drivestyle.recorded.observed.observed_view` first.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.units import off_grid
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import StyleTracker
from drivestyle.irl.identification.result import Identification
from drivestyle.prediction.errors import error_parts
from drivestyle.prediction.joint import JointStyle
from drivestyle.prediction.joint_physics import JointPhysicsBaseline, JointPhysicsParams
from drivestyle.prediction.kinematic import ConstantAcceleration, ConstantVelocity
from drivestyle.prediction.physics import PhysicsBaseline, PhysicsParams
from drivestyle.prediction.protocol import ForecastError, Observation, Predictor
from drivestyle.prediction.style import (
    PosteriorMixture,
    StyleRollout,
    online_posterior,
    population_style,
)
from drivestyle.recorded.observed import observer_view

if TYPE_CHECKING:
    from drivestyle.irl.amortized.estimator import NeuralPosterior

__all__ = [
    "AMORTIZED_METHODS",
    "LIBRARY_METHODS",
    "METHODS",
    "MethodPrediction",
    "Prediction",
    "method_predictors",
    "predict",
    "predict_demo",
]

METHODS = (
    "cv", "ca", "physics", "joint_physics", "population", "mode", "mixture", "style_alone",
    "style_joint", "oracle",
)  # fmt: skip
"""Every prediction method, in report order (``oracle`` only where the truth is known)."""
AMORTIZED_METHODS = ("style_alone", "style_joint")
"""The methods that need the amortized posterior (:mod:`~drivestyle.prediction.joint`): the
stochastic style of every vehicle identified from its own past, rolled out alone (the others
at constant velocity) or together."""
POSTERIOR_METHODS = ("mode", "mixture")
"""The methods that need the online posterior
(:func:`~drivestyle.prediction.style.online_posterior`)."""
LIBRARY_METHODS = ("population", *POSTERIOR_METHODS)
"""The methods that need a driver library (its style and risk grid)."""


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
    radius_m: float | None = None
    """A sampling method's own 90 % region of the final position: the radius around its
    final position holding 90 % of its samples [m] (None: a point prediction)."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction.json``'s per-method entry)."""
        return {
            "radius_m": self.radius_m,
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


def method_predictors(
    library: DriverLibrary | None,
    oracle: DriverStyle | None = None,
    physics: PhysicsParams | None = None,
    posterior: StyleTracker | None = None,
    joint_physics: JointPhysicsParams | None = None,
    amortized: NeuralPosterior | None = None,
) -> dict[str, Predictor]:
    """Method name → its predictor, for the methods these inputs serve (in :data:`METHODS` order).

    Args:
        library: the driver library (the population style; the mixture's style; None: no
            ``population``).
        oracle: the vehicle's true style (None: no ``oracle``).
        physics: the physics baseline's parameters (default: :class:`PhysicsParams`'s).
        posterior: the online posterior after the observed samples
            (:func:`~drivestyle.prediction.style.online_posterior`; None: no ``mode`` nor
            ``mixture``).
        joint_physics: the joint physics baseline's parameters (default:
            :class:`JointPhysicsParams`'s).
        amortized: the amortized posterior (None: no ``style_alone`` nor ``style_joint``).
    """
    table: dict[str, Predictor] = {
        "cv": ConstantVelocity(),
        "ca": ConstantAcceleration(),
        "physics": PhysicsBaseline(physics or PhysicsParams()),
        "joint_physics": JointPhysicsBaseline(joint_physics or JointPhysicsParams()),
    }
    if library is not None:
        table["population"] = StyleRollout(population_style(library))
    if posterior is not None and library is not None:
        table["mode"] = StyleRollout(posterior.style("mode"))
        if posterior.estimate is not None:
            table["mixture"] = PosteriorMixture(library.style, posterior.estimate)
    if amortized is not None:
        table["style_alone"] = JointStyle(amortized, react=False)
        table["style_joint"] = JointStyle(amortized, react=True)
    if oracle is not None:
        table["oracle"] = StyleRollout(oracle)
    return table


def predict(
    demo: Demonstration,
    library: DriverLibrary | None,
    t_obs: float,
    oracle: DriverStyle | None = None,
    scenario: ScenarioConfig | None = None,
    methods: Sequence[str] = METHODS,
    physics: PhysicsParams | None = None,
    joint_physics: JointPhysicsParams | None = None,
    amortized: NeuralPosterior | None = None,
) -> Prediction:
    """Observe a demonstration for ``t_obs`` seconds and predict the rest by every method.

    The predictors see samples 0 … k_obs only (an
    :class:`~drivestyle.prediction.protocol.Observation`; the online tracker without the
    inputs: an observer does not see them); each predicts samples k_obs … n−1.

    Args:
        demo: the vehicle's demonstration (its EV is the predicted vehicle).
        library: the driver library (the style's cost and risk grid; None: the methods
            without a style only — cv, ca, physics, and the oracle's own).
        t_obs: observed time [s], a whole number of T_s, less than the demonstration.
        oracle: the vehicle's true style (None: no ``oracle`` method).
        scenario: the scenario the methods predict in (default: the demonstration's;
            recorded traffic passes one whose v_ref comes from the observed part only).
        methods: the methods to run (a subset of :data:`METHODS`).
        physics: the physics baseline's parameters (default: :class:`PhysicsParams`'s; the
            benchmark passes the calibrated ones).
        joint_physics: the joint physics baseline's parameters (default:
            :class:`JointPhysicsParams`'s; the benchmark passes the calibrated ones).
        amortized: the amortized posterior (None: no ``style_alone`` nor ``style_joint``).

    Returns:
        The :class:`Prediction`.

    Raises:
        ForecastError: an unknown method, or an observation window the demonstration
            cannot serve.
    """
    unknown = sorted(set(methods) - set(METHODS))
    if unknown:
        raise ForecastError(f"unknown prediction method(s) {unknown}; known: {list(METHODS)}")
    styled = [m for m in methods if m in LIBRARY_METHODS]
    if library is None and styled:
        raise ForecastError(f"prediction method(s) {styled} need a driver library; none given")
    k = _observed_samples(demo, t_obs)
    seen = Observation(demo.ev[: k + 1], demo.vehicles[: k + 1], scenario or demo.scenario)
    steps = demo.n - 1 - k
    posterior = (
        online_posterior(library, seen)
        if library is not None and set(POSTERIOR_METHODS) & set(methods)
        else None
    )
    predictors = method_predictors(library, oracle, physics, posterior, joint_physics, amortized)
    actual = demo.ev[k:, :2]
    out = {}
    for name in METHODS:
        if name in methods and name in predictors:
            path = predictors[name].predict(seen, steps)
            e = error_parts(path.xy, actual)
            out[name] = MethodPrediction(name, path.xy, e["ade"], e["fde"], e["fde_lat"],
                                         path.risk, e["ade_lat"], e["ade_lon"],
                                         e["fde_lon"], path.radius)  # fmt: skip
    true = demo.meta.get("risk")
    return Prediction(
        t_obs=float(t_obs),
        t=demo.t[k:].copy(),
        actual=actual.copy(),
        observed=demo.ev[: k + 1, :2].copy(),
        methods=out,
        identification=None if posterior is None else posterior.estimate,
        true_risk=None if true is None else float(true),
    )


def predict_demo(
    demo: Demonstration,
    library: DriverLibrary | None,
    t_obs: float,
    oracle: DriverStyle | None = None,
    physics: PhysicsParams | None = None,
    methods: Sequence[str] = METHODS,
    view: tuple[Demonstration, ScenarioConfig | None] | None = None,
    joint_physics: JointPhysicsParams | None = None,
    amortized: NeuralPosterior | None = None,
) -> Prediction:
    """One vehicle predicted after ``t_obs`` by every method, as the benchmark predicts it.

    A recorded episode is seen through :func:`~drivestyle.recorded.observed.observed_view`
    (the recorded view of the observed samples, the no-leak frame and scenario); a simulated
    demonstration in its own scenario. ``drivestyle predict-trajectory`` and the prediction
    study (``drivestyle.studies.prediction``) both call this.

    Args:
        demo: the demonstration (a recorded episode as extracted, or a simulated one).
        library: the driver library (None: the methods without a style only, :func:`predict`).
        t_obs: observed time [s].
        oracle: its true style (None: no oracle).
        physics: the physics baseline's parameters (None: the defaults).
        methods: the methods to run.
        view: ``observer_view(demo, t_obs)`` where the caller has it already (a command
            that also draws the view), so that the episode is seen once; None: made here.
        joint_physics: the joint physics baseline's parameters (None: the defaults).
        amortized: the amortized posterior (None: no ``style_alone`` nor ``style_joint``).

    Returns:
        The :class:`Prediction` (paths in the frame of the view: a recorded episode's is
        shifted laterally by ``observed_shift_m`` of
        :func:`~drivestyle.recorded.observed.observed_view`).

    Raises:
        ForecastError: an observation window the demonstration cannot serve.
    """
    seen, sc = observer_view(demo, t_obs) if view is None else view
    return predict(seen, library, t_obs, oracle=oracle, scenario=sc, methods=methods,
                   physics=physics, joint_physics=joint_physics,
                   amortized=amortized)  # fmt: skip
