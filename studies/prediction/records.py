"""The prediction study's records: every method's errors on one vehicle after t_obs.

:func:`predict_vehicle` predicts one vehicle at every observed time with
:func:`~drivestyle.prediction.methods.predict_demo` (the benchmark's prediction: a recorded
episode through the no-leak view) and keeps one :class:`PredictionRecord` per t_obs, or a
:class:`SkippedPrediction` with the reason where the data cannot be predicted
(:data:`PREDICTION_ERRORS`). A record carries its episode's kind and stop-and-go flag
(:mod:`drivestyle.recorded.kinds`), by which the summaries group it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver.driver_style import DriverStyle, DriverStyleError
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.online import TrackerError
from drivestyle.prediction.joint_physics import JointPhysicsParams
from drivestyle.prediction.methods import METHODS, Prediction, predict_demo
from drivestyle.prediction.physics import PhysicsParams
from drivestyle.prediction.protocol import ForecastError
from drivestyle.recorded.kinds import DEFAULT_KIND, check_kind, episode_kind, is_stop_and_go

if TYPE_CHECKING:
    from drivestyle.irl.amortized.estimator import NeuralPosterior

__all__ = [
    "PREDICTION_ERRORS",
    "PredictionRecord",
    "SkippedPrediction",
    "predict_vehicle",
]


@dataclass(frozen=True)
class PredictionRecord:
    """Every method's errors on one vehicle after t_obs seconds."""

    set: str
    """``simulated``, ``ngsim`` or ``cats``."""
    vehicle_id: str
    t_obs: float
    """Observed time [s]."""
    horizon_s: float
    """Predicted time [s] (the rest of the demonstration)."""
    true_risk: float | None
    risk_mode: float | None
    """The risk the ``mode`` method used."""
    risk_mean: float
    """The online posterior's mean at t_obs."""
    ade_m: dict[str, float]
    """Method → average displacement error [m]."""
    fde_m: dict[str, float]
    """Method → final displacement error [m]."""
    fde_lat_m: dict[str, float] = field(default_factory=dict)
    """Method → the final error's lateral part |Δy| [m]."""
    fde_lon_m: dict[str, float] = field(default_factory=dict)
    """Method → the final error's longitudinal part |Δx| [m]."""
    ade_lat_m: dict[str, float] = field(default_factory=dict)
    """Method → the average error's lateral part, mean |Δy| [m]."""
    ade_lon_m: dict[str, float] = field(default_factory=dict)
    """Method → the average error's longitudinal part, mean |Δx| [m]."""
    unit: str = ""
    """The vehicle the bootstrap resamples (recorded: the split's vehicle id; simulated:
    the vehicle id); empty: :attr:`vehicle_id`."""
    kind: str = DEFAULT_KIND
    """The episode's kind, a name of :data:`~drivestyle.recorded.kinds.EPISODE_KINDS` (a
    simulated SMPC vehicle changes lane)."""
    stop_and_go: bool = False
    """Whether the episode's window is stop-and-go traffic (a flag across kinds)."""
    prediction: Prediction | None = field(default=None, repr=False, compare=False)
    """The whole prediction (paths; kept in memory for the figures, not in the JSON)."""

    def __post_init__(self) -> None:
        check_kind(self.kind)  # a name of EPISODE_KINDS, or ValueError naming them

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``prediction_eval.json``'s record)."""
        return {
            "set": self.set,
            "vehicle_id": self.vehicle_id,
            "t_obs_s": self.t_obs,
            "horizon_s": self.horizon_s,
            "true_risk": self.true_risk,
            "risk_mode": self.risk_mode,
            "risk_mean": self.risk_mean,
            "ade_m": dict(self.ade_m),
            "fde_m": dict(self.fde_m),
            "fde_lat_m": dict(self.fde_lat_m),
            "fde_lon_m": dict(self.fde_lon_m),
            "ade_lat_m": dict(self.ade_lat_m),
            "ade_lon_m": dict(self.ade_lon_m),
            "unit": self.unit or self.vehicle_id,
            "kind": self.kind,
            "stop_and_go": self.stop_and_go,
        }

    def error(self, metric: str, method: str) -> float:
        """One error of one method [m] (NaN: not recorded).

        Args:
            metric: a name of :data:`~drivestyle.prediction.errors.ERROR_METRICS`.
            method: a name of :data:`~drivestyle.prediction.methods.METHODS`.
        """
        table = {
            "ade": self.ade_m,
            "ade_lat": self.ade_lat_m,
            "ade_lon": self.ade_lon_m,
            "fde": self.fde_m,
            "fde_lat": self.fde_lat_m,
            "fde_lon": self.fde_lon_m,
        }
        return float(table[metric].get(method, np.nan))


@dataclass(frozen=True)
class SkippedPrediction:
    """A (vehicle, t_obs) that could not be predicted, and why."""

    set: str
    vehicle_id: str
    t_obs: float | None
    """None: the whole vehicle (e.g. its demonstration could not be generated)."""
    reason: str

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"set": self.set, "vehicle_id": self.vehicle_id, "t_obs_s": self.t_obs,
                "reason": self.reason}  # fmt: skip


def _record(
    set_name: str, vehicle_id: str, demo: Demonstration, pred: Prediction, unit: str
) -> PredictionRecord:
    mode = pred.methods.get("mode")
    return PredictionRecord(
        set=set_name,
        vehicle_id=vehicle_id,
        t_obs=pred.t_obs,
        horizon_s=float(pred.t[-1] - pred.t[0]),
        true_risk=pred.true_risk,
        risk_mode=None if mode is None else mode.risk,
        risk_mean=float("nan")
        if pred.identification is None
        else float(pred.identification.risk_interpolated),
        ade_m={m: p.ade_m for m, p in pred.methods.items()},
        fde_m={m: p.fde_m for m, p in pred.methods.items()},
        fde_lat_m={m: p.fde_lat_m for m, p in pred.methods.items()},
        fde_lon_m={m: p.fde_lon_m for m, p in pred.methods.items()},
        ade_lat_m={m: p.ade_lat_m for m, p in pred.methods.items()},
        ade_lon_m={m: p.ade_lon_m for m, p in pred.methods.items()},
        unit=unit or vehicle_id,
        kind=episode_kind(demo),
        stop_and_go=is_stop_and_go(demo),
        prediction=pred,
    )


PREDICTION_ERRORS = (ForecastError, TrackerError, DriverStyleError, RuntimeError, ValueError)
"""Failures that skip a (vehicle, t_obs) with their message instead of ending the study."""


def predict_vehicle(
    set_name: str,
    vehicle_id: str,
    demo: Demonstration,
    library: DriverLibrary,
    t_obs: Sequence[float],
    oracle: DriverStyle | None = None,
    physics: PhysicsParams | None = None,
    methods: Sequence[str] = METHODS,
    unit: str = "",
    joint_physics: JointPhysicsParams | None = None,
    amortized: NeuralPosterior | None = None,
) -> tuple[list[PredictionRecord], list[SkippedPrediction]]:
    """Predict one vehicle at every observed time.

    Each by :func:`~drivestyle.prediction.methods.predict_demo`, the benchmark's prediction.

    Args:
        set_name: the set the vehicle belongs to.
        vehicle_id: its name.
        demo: its demonstration (a recorded episode as extracted).
        library: the driver library.
        t_obs: observed times [s].
        oracle: its true style (None: no oracle).
        physics: the physics baseline's parameters (None: the defaults).
        methods: the methods to run.
        unit: the vehicle the bootstrap resamples (default: ``vehicle_id``).
        joint_physics: the joint physics baseline's parameters (None: the defaults).
        amortized: the amortized posterior (None: no ``style_alone`` nor ``style_joint``).

    Returns:
        (records, skipped).
    """
    records, skipped = [], []
    for t in t_obs:
        try:
            pred = predict_demo(demo, library, t, oracle, physics, methods,
                                joint_physics=joint_physics, amortized=amortized)  # fmt: skip
        except PREDICTION_ERRORS as exc:
            skipped.append(SkippedPrediction(set_name, vehicle_id, float(t), str(exc)))
            continue
        records.append(_record(set_name, vehicle_id, demo, pred, unit))
    return records, skipped
