"""Reactive drivers of a recorded scene: their protocol and the IDM along the log (DESIGN §24).

A :data:`Driver` is what drives a vehicle of ``drivestyle/Recorded-v0`` that does not follow
its log (``others="style"``, and the agent's policy
:func:`~drivestyle.envs.recorded_scene.drive_idm`):
a callable ``(j, t, states) → [a, δ]`` of the vehicle index j (0 the EV, j ≥ 1 the j-th
vehicle of ``demo.vehicles``), the time t [s] on the recording's clock and every vehicle's
state at t, shape (N, 4), NaN rows for vehicles not (yet) in the scene. Its input is applied
over one T_s through the kinematic bicycle (:mod:`drivestyle.envs.dynamics`), clipped to the
scenario's bounds, as the agent's is.

:class:`LogLateralIDM` is the reactive vehicle the environment builds itself
(``others="idm"``), self-contained in this layer:

- **Longitudinal: the IDM** (:func:`drivestyle.envs.traffic.idm_acceleration`, the project's
  one IDM) behind the nearest vehicle ahead in its current lane among those in the scene, the
  agent included (:func:`drivestyle.envs.lanes.leaders`); the bumper gap is the centres'
  distance minus the vehicle length, the approach rate the difference of the speeds; v0 per
  vehicle from its speeds up to the start (:func:`drivestyle.envs.scene_log.desired_speeds`);
  the acceleration within the scenario's bounds.
- **Lateral: its log over time.** :meth:`LogLateralIDM.step` moves a vehicle as the traffic
  env's IDM vehicles move (v' = max(v + a T_s, 0), x' = x + ½ (v + v') T_s) and gives it the
  lateral position and heading of its log at the next sample: its lane changes and drift
  happen when they happened. (Through the bicycle, recorded lateral moves at low speed need
  more than the steering bound δ_max allows: a vehicle at 3–5 m/s swerving 2 m in 4 s.)
  As a :data:`Driver` (the agent's policy, which the bicycle moves) it steers towards its
  log's next lateral position and heading instead (:func:`steer_towards`), within δ_max.

A :class:`DriverFactory` builds a scene's drivers from its start: ``Recorded-v0``'s
``posterior=`` finds the identified styles' one through the ``drivestyle.scene_drivers``
entry points (:func:`load_driver_factory`; ``style``:
:func:`drivestyle.prediction.scene_drivers.scene_styles`), so that ``envs`` imports nothing
above it, as ``CutIn-v0`` finds its lane changer.

The IDM's parameters are the caller's (:class:`~drivestyle.envs.traffic.IDMParams`;
highway-env's by default); a higher layer supplies calibrated ones
(``drivestyle replay-recorded``: the physics baseline's, calibrated on the benchmark's train
split).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from drivestyle.envs.dynamics import INPUT_FIT_SCALE, rk4_step_scalar
from drivestyle.envs.lanes import leaders
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.scene_log import SceneLog
from drivestyle.envs.traffic import IDM, IDMParams, idm_acceleration

if TYPE_CHECKING:
    from drivestyle.envs.demonstration import Demonstration

__all__ = [
    "SCENE_DRIVER_PLUGINS",
    "Driver",
    "DriverFactory",
    "LogLateralIDM",
    "load_driver_factory",
    "steer_towards",
]

Driver = Callable[[int, float, np.ndarray], Any]
"""(vehicle index j, time t [s], every vehicle's state at t (N, 4), NaN where absent) → [a, δ]."""

SCENE_DRIVER_PLUGINS = "drivestyle.scene_drivers"
"""Entry-point group of driver factories (module docstring); ``style``: the identified styles."""


class DriverFactory(Protocol):
    """A scene's drivers for a replay from a start sample (fresh ones: a driver has state)."""

    def __call__(self, demo: Demonstration, start: int) -> Mapping[int, Driver]:
        """{vehicle: driver} of ``demo`` replayed from sample ``start``."""


def load_driver_factory(name: str, source: Any) -> DriverFactory:
    """The driver factory of the ``drivestyle.scene_drivers`` plug-in ``name`` for ``source``.

    Args:
        name: the entry point's name (``style``: the identified styles).
        source: what the plug-in builds its drivers from (``style``: an amortized posterior
            or its file).

    Raises:
        RuntimeError: no such plug-in is installed (install the project with pip).
    """
    found = entry_points(group=SCENE_DRIVER_PLUGINS, name=name)
    if not found:
        raise RuntimeError(
            f"Recorded-v0 needs the scene-driver plug-in {name!r} of the entry-point group "
            f"{SCENE_DRIVER_PLUGINS!r}; install the project (pip install -e .) or pass drivers="
        )
    factory: DriverFactory = next(iter(found)).load()(source)
    return factory


_STEER_ITERATIONS = 8
_STEER_STEP = 1e-7
"""[rad] The finite difference of the steering's derivative."""


def steer_towards(
    state: np.ndarray, a: float, y_next: float, phi_next: float, sc: ScenarioConfig
) -> float:
    """The steering δ ∈ [−δ_max, δ_max] that brings (y, φ) closest to (y_next, φ_next).

    One RK4 step of the bicycle under [a, δ] (:func:`rk4_step_scalar`); the mismatch of the
    lateral position and the heading is weighted by :data:`INPUT_FIT_SCALE` (0.05 m,
    0.01 rad), as :func:`~drivestyle.envs.dynamics.inverse_step` weighs a whole state; a
    bounded Gauss–Newton on δ alone, from δ = 0.

    Args:
        state: [x, y, φ, v] at t_k [m, m, rad, m/s].
        a: the acceleration applied over the step [m/s²].
        y_next: the lateral position to reach at t_{k+1} [m].
        phi_next: the heading to reach at t_{k+1} [rad].
        sc: the scenario (T_s, l_f, l_r, δ_max).

    Returns:
        δ [rad].
    """
    x, y, phi, v = (float(s) for s in state)
    sy, sphi = float(INPUT_FIT_SCALE[1]), float(INPUT_FIT_SCALE[2])
    bound = float(sc.delta_max)

    def residual(delta: float) -> tuple[float, float]:
        _, y1, phi1, _ = rk4_step_scalar(x, y, phi, v, a, delta, sc.dt, sc.l_f, sc.l_r)
        return (y1 - y_next) / sy, (phi1 - phi_next) / sphi

    delta = 0.0
    for _ in range(_STEER_ITERATIONS):
        r = residual(delta)
        r_h = residual(delta + _STEER_STEP)
        j = ((r_h[0] - r[0]) / _STEER_STEP, (r_h[1] - r[1]) / _STEER_STEP)
        jj = j[0] * j[0] + j[1] * j[1]
        if jj == 0.0:  # standing still: the steering moves nothing
            return 0.0
        new = min(max(delta - (j[0] * r[0] + j[1] * r[1]) / jj, -bound), bound)
        if abs(new - delta) < 1e-10:
            return new
        delta = new
    return delta


@dataclass(frozen=True)
class LogLateralIDM:
    """The IDM along the log's lateral path, for every vehicle of a scene (module docstring).

    :meth:`step` moves a vehicle of ``others="idm"``; called as a :data:`Driver`,
    ``driver(j, t, states) → [a, δ]``, it gives the bicycle's input.
    """

    log: SceneLog
    """The scene (its lanes, geometry and each vehicle's recorded lateral path)."""
    v0: np.ndarray
    """Desired speed per vehicle, shape (N,) [m/s]."""
    idm: IDMParams = IDM
    """The IDM's parameters (highway-env's by default)."""

    def acceleration(self, j: int, states: np.ndarray) -> float:
        """Vehicle j's IDM acceleration behind its leader, within the scenario's bounds [m/s²].

        Below its desired speed, at most what reaches v0 in one T_s: an explicit step
        overshoots a small v0 (a vehicle that stood still before the start, v0 ≈ 0, would
        alternate between standing and 0.6 m/s).

        Args:
            j: the vehicle.
            states: every vehicle's state, shape (N, 4), NaN rows for absent vehicles.
        """
        sc = self.log.scenario
        x, y, _, v = (float(s) for s in states[j])
        others = np.isfinite(states[:, 0])
        others[j] = False
        rows = states[others]
        here = np.array([x]), np.array([y])
        lead = int(leaders(*here, rows[None, :, 0], rows[None, :, 1], sc.lane_width)[0])
        if lead < 0:
            gap, v_leader = None, 0.0
        else:
            gap, v_leader = float(rows[lead, 0]) - x - sc.vehicle_length, float(rows[lead, 3])
        v0 = float(self.v0[j])
        a = idm_acceleration(v, v0, gap, v_leader, self.idm)
        if v < v0:  # a step of T_s never carries the speed past v0 (nor oscillates about a v0 ≈ 0)
            a = min(a, (v0 - v) / sc.dt)
        return min(max(a, sc.a_min), sc.a_max)

    def step(self, j: int, k: int, states: np.ndarray) -> np.ndarray:
        """Vehicle j's state at sample k + 1: the IDM along x, its log's lateral path.

        Args:
            j: the vehicle.
            k: the current sample.
            states: every vehicle's state at sample k, shape (N, 4), NaN rows for absent
                vehicles.

        Returns:
            [x, y, φ, v] at sample k + 1 (module docstring).
        """
        x, _, _, v = (float(s) for s in states[j])
        a = self.acceleration(j, states)
        dt = self.log.dt
        v_new = max(v + a * dt, 0.0)
        _, y, phi, _ = self.log.states[min(k + 1, self.log.n - 1), j].tolist()
        return np.array([x + 0.5 * (v + v_new) * dt, y, phi, v_new])

    def __call__(self, j: int, t: float, states: np.ndarray) -> np.ndarray:
        """[a, δ] of vehicle j at time t, for the bicycle (module docstring)."""
        log = self.log
        states = np.asarray(states, float)
        a = self.acceleration(j, states)
        target = log.states[min(log.sample_at(t) + 1, log.n - 1), j]
        delta = steer_towards(states[j], a, float(target[1]), float(target[2]), log.scenario)
        return np.array([a, delta])
