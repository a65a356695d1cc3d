"""Calibrating the physics predictor, and the file its parameters are shipped in.

:func:`calibrate_physics` fits :class:`~drivestyle.prediction.physics.PhysicsParams`
(:data:`CALIBRATED`, within :data:`BOUNDS`) by least squares of the displacement errors over
calibration cases (:class:`PhysicsCase`: a vehicle observed for t_obs and the truth after it;
the benchmark's are its train split's, ``drivestyle.studies.prediction``); the result
(:class:`PhysicsCalibration`) is written as a small JSON (:func:`save_params`) and read back,
checked, by :func:`load_params`. :data:`PHYSICS_FILE` is the shipped calibration.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any, Protocol, TypeVar

import numpy as np

from drivestyle.prediction.physics import PhysicsParams, physics_forecast

__all__ = [
    "BOUNDS",
    "CALIBRATED",
    "PHYSICS_ALL_FILE",
    "PHYSICS_FILE",
    "PhysicsCalibration",
    "PhysicsCase",
    "calibrate_physics",
    "load_params",
    "read_params_file",
    "save_params",
]

PHYSICS_FILE = Path(str(resources.files("drivestyle") / "data")) / "benchmark_physics.json"
"""The physics baseline's parameters calibrated on the benchmark's train split, shipped with
the package (``drivestyle.studies.prediction.calibrate_on_split``)."""
PHYSICS_ALL_FILE = PHYSICS_FILE.with_name("benchmark_physics_all.json")
"""The same calibrated on the train split of every vehicle's episodes (lane changes and
windows without one; ``evaluate-prediction --all-vehicles``)."""
CALIBRATED = ("v0_factor", "time_gap_s", "min_gap_m", "accel_mps2", "decel_mps2", "lc_duration_s")
"""The parameters :func:`calibrate_physics` fits (in this order)."""
BOUNDS = {
    "v0_factor": (0.8, 2.0),
    "time_gap_s": (0.3, 3.0),
    "min_gap_m": (0.5, 6.0),
    "accel_mps2": (0.2, 4.0),
    "decel_mps2": (0.3, 5.0),
    "lc_duration_s": (2.0, 12.0),
}
"""Their bounds in the calibration (the ranges reported for highway traffic, widened)."""


@dataclass(frozen=True)
class PhysicsCase:
    """One (vehicle, t_obs) of the calibration set: the observed part and the truth."""

    ev: np.ndarray
    """Observed states ξ_0 … ξ_k, shape (k + 1, 4)."""
    others: np.ndarray
    """Surrounding vehicles at sample k, shape (m, 4)."""
    actual: np.ndarray
    """True positions at j = 0 … H, shape (H + 1, 2)."""
    dt: float
    lane_width: float
    length: float


@dataclass(frozen=True)
class PhysicsCalibration:
    """The result of :func:`calibrate_physics`."""

    params: PhysicsParams
    initial: PhysicsParams
    n_cases: int
    rmse_m: float
    """Root mean square displacement over every predicted sample (each case weighted
    equally) at the fitted parameters [m]."""
    rmse_initial_m: float
    """The same at the initial parameters [m]."""
    message: str
    """The optimiser's message."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the file :func:`load_params` reads)."""
        return {
            "params": self.params.to_json(),
            "initial": self.initial.to_json(),
            "calibrated": list(CALIBRATED),
            "bounds": {k: list(v) for k, v in BOUNDS.items()},
            "n_cases": self.n_cases,
            "rmse_m": self.rmse_m,
            "rmse_initial_m": self.rmse_initial_m,
            "message": self.message,
        }


def _residuals(params: PhysicsParams, cases: Sequence[PhysicsCase]) -> np.ndarray:
    out = []
    for c in cases:
        xy = physics_forecast(c.ev, c.others, c.dt, len(c.actual) - 1, c.lane_width, c.length,
                              params)  # fmt: skip
        d = (xy[1:] - c.actual[1:]).ravel()
        out.append(d / np.sqrt(len(c.actual) - 1))
    return np.concatenate(out) if out else np.zeros(0)


def calibrate_physics(
    cases: Sequence[PhysicsCase], initial: PhysicsParams | None = None
) -> PhysicsCalibration:
    """Least squares of the displacement errors over every case (deterministic).

    Minimises Σ_cases (1/H) Σ_j ‖p̂_j − p_j‖² over :data:`CALIBRATED` within :data:`BOUNDS`
    (``scipy.optimize.least_squares``, trust-region reflective, finite differences) from
    ``initial`` and from the points a quarter and three quarters into the bounds, keeping
    the lowest: the mean squared displacement, each (vehicle, t_obs) counted once.

    Args:
        cases: the calibration cases (the train split's).
        initial: the start (default :class:`PhysicsParams`'s).

    Raises:
        ValueError: no case.
    """
    from scipy.optimize import least_squares

    if not cases:
        raise ValueError("need at least one case to calibrate the physics baseline")
    initial = initial or PhysicsParams()
    fixed = asdict(initial)
    lo = np.array([BOUNDS[k][0] for k in CALIBRATED])
    hi = np.array([BOUNDS[k][1] for k in CALIBRATED])
    x0 = np.clip([fixed[k] for k in CALIBRATED], lo, hi)

    def make(z: np.ndarray) -> PhysicsParams:
        return PhysicsParams(**(fixed | {k: float(v) for k, v in zip(CALIBRATED, z, strict=True)}))

    # the displacement errors are piecewise smooth (which vehicle leads changes where a
    # predicted path crosses a lane line), so trust-region descents can stop at a kink: the
    # start and two more, a quarter and three quarters into the bounds, and the lowest wins
    starts = [x0, lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo)]

    def descend(start: np.ndarray) -> Any:
        return least_squares(
            lambda z: _residuals(make(z), cases), start, bounds=(lo, hi), method="trf",
            diff_step=1e-3, x_scale=hi - lo, max_nfev=200,
        )  # fmt: skip

    runs = [descend(start) for start in starts]
    res = runs[int(np.argmin([float(r.cost) for r in runs]))]  # the first of equal costs
    n = len(cases)
    best = make(res.x)
    return PhysicsCalibration(
        params=best,
        initial=initial,
        n_cases=n,
        rmse_m=float(np.sqrt(np.sum(_residuals(best, cases) ** 2) / n)),
        rmse_initial_m=float(np.sqrt(np.sum(_residuals(make(x0), cases) ** 2) / n)),
        message=str(res.message),
    )


class _Calibration(Protocol):
    def to_json(self) -> dict[str, Any]: ...


def save_params(calibration: _Calibration, path: str | Path) -> None:
    """Write a calibration as JSON (its ``to_json``; sorted keys, a trailing newline)."""
    text = json.dumps(calibration.to_json(), indent=2, sort_keys=True)
    Path(path).write_text(text + "\n")


def load_params(path: str | Path) -> PhysicsParams:
    """The parameters of a file :func:`save_params` wrote (its ``params`` entry), checked.

    Every parameter of :class:`PhysicsParams` must be there, and no other; each a number,
    finite and > 0, a calibrated one within :data:`BOUNDS` (what calibration keeps to: a
    time gap of 30 s is no calibration's).

    Raises:
        FileNotFoundError: no such file.
        ValueError: a folder, not UTF-8 JSON, no ``params`` object, a parameter missing,
            unknown, not a number or out of its range; one line naming the file and the
            problem.
    """
    return read_params_file(
        path, PhysicsParams, BOUNDS, "physics",
        "drivestyle evaluate-prediction --calibrate-physics --physics FILE writes one",
    )  # fmt: skip


P = TypeVar("P")


def read_params_file(
    path: str | Path,
    cls: type[P],
    bounds: Mapping[str, tuple[float, float]],
    kind: str,
    writer: str,
    nonnegative: Sequence[str] = (),
) -> P:
    """A baseline's parameters file read and checked (its ``params`` entry): ``cls(**params)``.

    The one reader of the physics baselines' files (:func:`load_params`; the joint
    baseline's, :mod:`drivestyle.prediction.joint_physics_calibration`). Every field of the
    dataclass ``cls`` must be there, and no other; each a finite number > 0 (≥ 0 for
    ``nonnegative``), one of ``bounds`` within its range.

    Args:
        path: the file.
        cls: the parameters' frozen dataclass.
        bounds: name → (low, high) of the calibrated parameters.
        kind: the baseline's name in messages ("physics": "not a physics parameters file").
        writer: the command that writes one, for the message of a file that is not one.
        nonnegative: the parameters that may be 0.

    Raises:
        FileNotFoundError: no such file.
        ValueError: as :func:`load_params`; one line naming the file and the problem.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a {kind} parameters file")
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file (byte {exc.start} is not UTF-8)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(
            f"{path}: not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})"
        ) from None
    params = raw.get("params") if isinstance(raw, dict) else None
    if not isinstance(params, dict):
        raise ValueError(f'{path}: no "params" object: not a {kind} parameters file ({writer})')
    names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    unknown = [k for k in params if k not in names]
    missing = [k for k in names if k not in params]
    if unknown or missing:
        what = [f"unknown {', '.join(unknown)}"] if unknown else []
        what += [f"no {', '.join(missing)}"] if missing else []
        raise ValueError(f"{path}: params: {'; '.join(what)} (expected {', '.join(names)})")
    for name in names:
        value = params[name]
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        zero_ok = name in nonnegative
        if not (ok and math.isfinite(value) and (value >= 0 if zero_ok else value > 0)):
            floor = "≥ 0" if zero_ok else "> 0"
            raise ValueError(f"{path}: params.{name} {value!r} is not a finite number {floor}")
        lo, hi = bounds.get(name, (0.0, math.inf))
        slack = 1e-6 * (hi - lo if math.isfinite(hi) else 1.0)  # the optimiser's last digits
        if not lo - slack <= value <= hi + slack:
            raise ValueError(
                f"{path}: params.{name} {value:g} lies outside [{lo:g}, {hi:g}], the range "
                "calibration keeps to"
            )
    return cls(**params)
