"""Calibrating the joint physics predictor, and the file its parameters are shipped in.

:func:`calibrate_joint_physics` fits
:class:`~drivestyle.prediction.joint_physics.JointPhysicsParams` on calibration cases
(:class:`JointPhysicsCase`: every vehicle observed for t_obs and the predicted vehicle's
truth after it; the benchmark's are its train split's,
``drivestyle.studies.prediction.physics_split``) by the physics baseline's criterion
(:func:`~drivestyle.prediction.physics_calibration.calibrate_physics`): the mean squared
displacement of the predicted vehicle, each (vehicle, t_obs) counted once. The IDM's
parameters, ρ and D (:data:`CALIBRATED`) by least squares; MOBIL's politeness and threshold
on a grid (:data:`MOBIL_GRID`: they decide *whether* a vehicle changes lane, so the
displacement is piecewise constant in them and finite differences see no slope). Every
case is rolled out at once (:func:`~drivestyle.prediction.joint_physics.stack_scenes`), so
a residual costs one batched rollout. The result (:class:`JointPhysicsCalibration`) is
written as a small JSON (:func:`save_joint_params`) and read back, checked, by
:func:`load_joint_params`. :data:`JOINT_PHYSICS_FILE` is the shipped calibration.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.prediction.joint_physics import (
    JointPhysicsParams,
    JointScene,
    joint_rollout,
    observed_scene,
    stack_scenes,
)
from drivestyle.prediction.physics_calibration import BOUNDS as PHYSICS_BOUNDS
from drivestyle.prediction.physics_calibration import read_params_file, save_params

__all__ = [
    "BOUNDS",
    "CALIBRATED",
    "JOINT_PHYSICS_ALL_FILE",
    "JOINT_PHYSICS_FILE",
    "MOBIL_GRID",
    "JointPhysicsCalibration",
    "JointPhysicsCase",
    "calibrate_joint_physics",
    "joint_residuals",
    "load_joint_params",
    "save_joint_params",
]

JOINT_PHYSICS_FILE = (
    Path(str(resources.files("drivestyle") / "data")) / "benchmark_joint_physics.json"
)
"""The joint physics baseline's parameters calibrated on the benchmark's train split, shipped
with the package (``drivestyle evaluate-prediction --calibrate-joint-physics``)."""
JOINT_PHYSICS_ALL_FILE = JOINT_PHYSICS_FILE.with_name("benchmark_joint_physics_all.json")
"""The same calibrated on the train split of every vehicle's episodes (lane changes and
windows without one; ``evaluate-prediction --all-vehicles``)."""
CALIBRATED = ("v0_factor", "time_gap_s", "min_gap_m", "accel_mps2", "decel_mps2", "lc_duration_s")
"""The parameters least squares fits (in this order): the physics baseline's."""
MOBIL_GRID = {
    "politeness": (0.0, 0.1, 0.25, 0.5, 1.0),
    "threshold_mps2": (0.05, 0.1, 0.2, 0.4, 0.8, 1.6),
}
"""MOBIL's politeness p [-] and threshold Δa_th [m/s²] tried (Kesting et al. report p ≈ 0 …
0.5 and Δa_th ≈ 0.1 m/s² for highway traffic; the grid brackets both)."""
BOUNDS = {**PHYSICS_BOUNDS, "politeness": (0.0, 1.0), "threshold_mps2": (0.0, 2.0)}
"""The calibrated parameters' bounds (the physics baseline's, and MOBIL's around its grid)."""
ROUNDS = 3
"""At most this many rounds of (MOBIL grid, least squares)."""


@dataclass(frozen=True)
class JointPhysicsCase:
    """One (vehicle, t_obs) of the calibration set: every vehicle's observed part, the truth."""

    ev: np.ndarray
    """The predicted vehicle's observed states ξ_0 … ξ_k, shape (k + 1, 4)."""
    vehicles: np.ndarray
    """The surrounding vehicles' observed states, shape (k + 1, m, 4)."""
    actual: np.ndarray
    """The predicted vehicle's true positions at j = 0 … H, shape (H + 1, 2)."""
    dt: float
    lane_width: float
    length: float
    n_lanes: int

    def scene(self) -> JointScene:
        """The observed scene (:func:`~drivestyle.prediction.joint_physics.observed_scene`)."""
        return observed_scene(self.ev, self.vehicles, self.dt, self.lane_width, self.length,
                              self.n_lanes)  # fmt: skip


@dataclass(frozen=True)
class JointPhysicsCalibration:
    """The result of :func:`calibrate_joint_physics`."""

    params: JointPhysicsParams
    initial: JointPhysicsParams
    n_cases: int
    rmse_m: float
    """Root mean square displacement over every predicted sample (each case weighted
    equally) at the fitted parameters [m]."""
    rmse_initial_m: float
    """The same at the initial parameters [m]."""
    rounds: int
    """Rounds of (MOBIL grid, least squares) run (:data:`ROUNDS` at most)."""
    message: str
    """The last least squares' message."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the file :func:`load_joint_params` reads)."""
        return {
            "params": self.params.to_json(),
            "initial": self.initial.to_json(),
            "calibrated": list(CALIBRATED),
            "grid": {k: list(v) for k, v in MOBIL_GRID.items()},
            "bounds": {k: list(v) for k, v in BOUNDS.items()},
            "n_cases": self.n_cases,
            "rmse_m": self.rmse_m,
            "rmse_initial_m": self.rmse_initial_m,
            "rounds": self.rounds,
            "message": self.message,
        }


@dataclass(frozen=True)
class _Batch:
    """Every case as one batch: the stacked scene and the truths, padded to the longest."""

    scene: JointScene
    actual: np.ndarray
    """(B, H_max, 2): the true positions at j = 1 … H_b, zeros after."""
    weight: np.ndarray
    """(B, H_max): 1/√H_b at j = 1 … H_b, 0 after."""


def _batch(cases: Sequence[JointPhysicsCase]) -> _Batch:
    steps = max(len(c.actual) - 1 for c in cases)
    actual = np.zeros((len(cases), steps, 2))
    weight = np.zeros((len(cases), steps))
    for b, c in enumerate(cases):
        h = len(c.actual) - 1
        actual[b, :h] = c.actual[1:]
        weight[b, :h] = 1.0 / np.sqrt(h)
    return _Batch(stack_scenes([c.scene() for c in cases]), actual, weight)


def joint_residuals(params: JointPhysicsParams, cases: Sequence[JointPhysicsCase]) -> np.ndarray:
    """The weighted displacement errors p̂_j − p_j / √H of the predicted vehicle, every case.

    Args:
        params: the model's parameters.
        cases: the calibration cases.

    Returns:
        The residuals of every case in order, shape (Σ_cases 2 H,): Σ of their squares /
        cases is the mean squared displacement :func:`calibrate_joint_physics` minimises.
    """
    batch = _batch(cases)
    return _residuals(params, batch)[batch.weight.ravel().repeat(2) > 0]


def _residuals(params: JointPhysicsParams, batch: _Batch) -> np.ndarray:
    xy = joint_rollout(batch.scene, batch.actual.shape[1], params)[:, 1:, 0]  # (B, H_max, 2)
    return np.asarray(((xy - batch.actual) * batch.weight[..., None]).ravel())


def calibrate_joint_physics(
    cases: Sequence[JointPhysicsCase], initial: JointPhysicsParams | None = None
) -> JointPhysicsCalibration:
    """Least squares of the displacement errors over every case, MOBIL's on a grid.

    Minimises Σ_cases (1/H) Σ_j ‖p̂_j − p_j‖² (deterministic) in rounds: MOBIL's
    politeness and threshold are chosen on :data:`MOBIL_GRID` at the current values (first:
    ``initial``'s), then :data:`CALIBRATED` are fitted within :data:`BOUNDS` at that choice
    (``scipy.optimize.least_squares``, trust-region reflective, finite differences; in the
    first round from the current values and from the points a quarter and three quarters
    into the bounds, as the physics baseline's calibration, later from the current values),
    until the grid's choice repeats (at most :data:`ROUNDS` rounds). The lowest cost seen
    wins.

    Args:
        cases: the calibration cases (the train split's).
        initial: the start (default :class:`JointPhysicsParams`'s).

    Raises:
        ValueError: no case.
    """
    from scipy.optimize import least_squares

    if not cases:
        raise ValueError("need at least one case to calibrate the joint physics baseline")
    initial = initial or JointPhysicsParams()
    batch = _batch(cases)
    lo = np.array([BOUNDS[k][0] for k in CALIBRATED])
    hi = np.array([BOUNDS[k][1] for k in CALIBRATED])

    def make(base: JointPhysicsParams, z: np.ndarray) -> JointPhysicsParams:
        return replace(base, **{k: float(v) for k, v in zip(CALIBRATED, z, strict=True)})

    def cost(params: JointPhysicsParams) -> float:
        return float(np.sum(_residuals(params, batch) ** 2))

    def descend(base: JointPhysicsParams, start: np.ndarray) -> Any:
        return least_squares(
            lambda z: _residuals(make(base, z), batch), start, bounds=(lo, hi), method="trf",
            diff_step=1e-3, x_scale=hi - lo, max_nfev=200,
        )  # fmt: skip

    fixed = asdict(initial)
    x0 = np.clip([fixed[k] for k in CALIBRATED], lo, hi)
    start = make(initial, x0)
    current, best, best_cost, message = start, start, cost(start), "no least squares run"
    rounds = 0
    while rounds < ROUNDS:
        grid = [replace(current, politeness=p, threshold_mps2=a)
                for p, a in itertools.product(*MOBIL_GRID.values())]  # fmt: skip
        costs = [cost(g) for g in grid]
        chosen = grid[int(np.argmin(costs))]  # the first of equal costs
        if rounds and chosen == current:  # the choice repeats: least squares ended there
            break
        rounds += 1
        z = np.array([getattr(chosen, k) for k in CALIBRATED])
        starts = [z, lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo)] if rounds == 1 else [z]
        runs = [descend(chosen, s) for s in starts]
        res = runs[int(np.argmin([float(r.cost) for r in runs]))]  # the first of equal costs
        fitted = make(chosen, res.x)
        fitted_cost = cost(fitted)
        current = fitted if fitted_cost <= min(costs) else chosen
        for candidate, c in ((chosen, min(costs)), (fitted, fitted_cost)):
            if c < best_cost:
                best, best_cost, message = candidate, c, str(res.message)
    n = len(cases)
    return JointPhysicsCalibration(
        params=best,
        initial=initial,
        n_cases=n,
        rmse_m=float(np.sqrt(best_cost / n)),
        rmse_initial_m=float(np.sqrt(cost(start) / n)),
        rounds=rounds,
        message=message,
    )


def save_joint_params(calibration: JointPhysicsCalibration, path: str | Path) -> None:
    """Write the calibration as JSON (sorted keys, a trailing newline)."""
    save_params(calibration, path)


def load_joint_params(path: str | Path) -> JointPhysicsParams:
    """The parameters of a file :func:`save_joint_params` wrote (its ``params`` entry), checked.

    As the physics baseline's file
    (:func:`~drivestyle.prediction.physics_calibration.read_params_file`): every parameter of
    :class:`~drivestyle.prediction.joint_physics.JointPhysicsParams` and no other, each a
    finite number > 0 (the politeness and threshold ≥ 0), a calibrated one within
    :data:`BOUNDS`.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a folder, not UTF-8 JSON, no ``params`` object, a parameter missing,
            unknown, not a number or out of its range; one line naming the file and the
            problem.
    """
    return read_params_file(
        path, JointPhysicsParams, BOUNDS, "joint physics",
        "drivestyle evaluate-prediction --calibrate-joint-physics --joint-physics FILE writes one",
        nonnegative=JointPhysicsParams.NONNEGATIVE,
    )  # fmt: skip
