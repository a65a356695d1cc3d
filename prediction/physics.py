"""The physics predictor: IDM car following plus a fitted quintic lane change.

What a highway researcher compares a learned predictor with (DESIGN §17). From the observed
part only — the vehicle's states ξ_0 … ξ_k and the surrounding vehicles' states at sample k —
it predicts the vehicle's positions ξ_{k+1} … ξ_{k+H} in the road frame (x along the road,
y lateral, lanes ``lane_width`` wide with lane i covering [i·w, (i+1)·w)):

- **Longitudinal: the Intelligent Driver Model** (Treiber, Hennecke, Helbing 2000) behind
  the leader. The surrounding vehicles are predicted at constant velocity from their last
  observed states; the leader at step j is the nearest vehicle ahead in the lane of the
  vehicle's own predicted lateral position (:func:`drivestyle.envs.lanes.leaders`: the
  leader changes when the predicted lane change crosses into the target lane):

      a = a_max [1 − (v / v0)^4 − (s* / s)²],   s* = s0 + max(0, v T + v Δv / (2 √(a_max b))),

  with s the bumper gap (front-to-front distance minus the vehicle length) [m], Δv = v − v_l
  the approach rate [m/s], v the longitudinal speed v cos φ. The desired speed is the
  vehicle's own: v0 = ρ · v_90 with v_90 the 90th percentile of its *observed* longitudinal
  speeds and ρ calibrated (one v0 in m/s for congested NGSIM and a free CATS test track would
  be an average of two regimes). Integration: v_{j+1} = max(0, v_j + a_j T_s),
  x_{j+1} = x_j + ½ (v_j + v_{j+1}) T_s.
- **Lateral: a quintic (minimum-jerk) lane change of duration D.** Its observed lateral
  velocity v_y (over the last :data:`LATERAL_WINDOW_S`) decides: below
  :attr:`PhysicsParams.trigger_mps` in magnitude the vehicle keeps its lateral position;
  otherwise it is changing lane towards the *target line*: the centre of the next lane in the
  direction of v_y (or of its current lane if it crossed into it in that direction during
  the observation) — never the recorded final lane. Its progress
  u_k ∈ [0, 1] through a change from the origin line (target − w) is read from its offset,
  f = s(u_k), with s(u) = 10u³ − 15u⁴ + 6u⁵; the rest of the change continues from y_k:

      y(t_k + τ) = y_k + (y_T − y_k) [s(min(1, u_k + τ/D)) − s(u_k)] / (1 − s(u_k)).

The parameters (:class:`PhysicsParams`: ρ, T, s0, a_max, b, D) are calibrated by least
squares of the displacement errors on the benchmark's train split
(:mod:`drivestyle.prediction.physics_calibration`, which also reads and writes their JSON).
MOBIL-style timing (when a change starts) is not modelled: a change that has not started by
t_obs is predicted as lane keeping. :class:`PhysicsBaseline` is the model as a
:class:`~drivestyle.prediction.protocol.Predictor` (``physics``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields

import numpy as np

from drivestyle.envs.lanes import LATERAL_WINDOW_S, lane_change_target, leaders
from drivestyle.envs.traffic import IDMParams
from drivestyle.envs.traffic import idm_acceleration as _idm
from drivestyle.prediction.protocol import Observation, PredictedPath

__all__ = [
    "PhysicsBaseline",
    "PhysicsParams",
    "idm_acceleration",
    "lane_change_state",
    "lateral_forecast",
    "longitudinal_forecast",
    "physics_forecast",
    "quintic_progress",
]


@dataclass(frozen=True)
class PhysicsParams:
    """The physics baseline's parameters (module docstring)."""

    v0_factor: float = 1.1
    """ρ: the IDM desired speed v0 = ρ · (90th percentile of the observed speeds) [-]."""
    time_gap_s: float = 1.2
    """T: desired time gap [s]."""
    min_gap_m: float = 2.0
    """s0: jam distance [m]."""
    accel_mps2: float = 1.0
    """a_max: maximum acceleration [m/s²]."""
    decel_mps2: float = 1.5
    """b: comfortable deceleration [m/s²]."""
    lc_duration_s: float = 5.0
    """D: duration of a whole lane change (origin line to target line) [s]."""
    trigger_mps: float = 0.1
    """|v_y| above which a lane change is under way [m/s] (fixed a priori, not calibrated)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"{f.name} must be a finite number > 0, got {value!r}")

    def to_json(self) -> dict[str, float]:
        """JSON-ready dict."""
        return {k: float(v) for k, v in asdict(self).items()}


# ---------------------------------------------------------------------------- the model
def idm_acceleration(
    v: float, gap: float | None, dv: float, v0: float, params: PhysicsParams
) -> float:
    """IDM acceleration [m/s²] with the baseline's parameters (module docstring).

    The one IDM of the project (:func:`drivestyle.envs.traffic.idm_acceleration`, its
    braking bounded as there) with T, s0, a_max, b from ``params``.

    Args:
        v: own longitudinal speed [m/s].
        gap: bumper gap to the leader [m] (None: no leader, the free-road term only).
        dv: approach rate v − v_leader [m/s].
        v0: desired speed [m/s].
        params: T, s0, a_max, b.
    """
    idm = IDMParams(
        a_max=params.accel_mps2,
        b=params.decel_mps2,
        s0=params.min_gap_m,
        time_gap=params.time_gap_s,
    )
    return _idm(v, max(v0, 1e-3), gap, v - dv, idm)


def quintic_progress(u: np.ndarray | float) -> np.ndarray:
    """s(u) = 10u³ − 15u⁴ + 6u⁵ on u clipped to [0, 1] (minimum-jerk transition)."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    return np.asarray(u**3 * (10.0 + u * (-15.0 + 6.0 * u)))


def _inverse_progress(f: float) -> float:
    """The progress u with s(u) = f, f clipped to [0, 1] (s is increasing: bisection to 1e-9)."""
    f = float(np.clip(f, 0.0, 1.0))
    lo, hi = 0.0, 1.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if quintic_progress(mid) < f else (lo, mid)
    return 0.5 * (lo + hi)


def lane_change_state(y: np.ndarray, dt: float, lane_width: float) -> tuple[float, float, float]:
    """The observed lateral motion as the lane-change model reads it (module docstring).

    Args:
        y: the observed lateral positions y_0 … y_k [m], shape (k + 1,).
        dt: T_s [s].
        lane_width: w [m].

    Returns:
        (v_y, y_T, u_k): the observed lateral velocity over the last
        :data:`~drivestyle.envs.lanes.LATERAL_WINDOW_S` [m/s] (0 with one sample), the target
        line (the centre of the lane :func:`~drivestyle.envs.lanes.lane_change_target` names)
        [m] and the progress u_k ∈ [0, 1] through a change from the origin line y_T ∓ w, read
        from the offset y_k by s(u_k) = (y_k − origin) / (y_T − origin) [-]. Whether a change
        is under way (|v_y| ≥ the trigger) is the caller's.
    """
    y = np.asarray(y, dtype=float)
    m = min(len(y) - 1, max(1, round(LATERAL_WINDOW_S / dt)))
    vy = (y[-1] - y[-1 - m]) / (m * dt) if m >= 1 else 0.0
    yk = float(y[-1])
    lane, d = lane_change_target(y, dt, lane_width)  # the target line's rule (envs.lanes)
    target = (lane + 0.5) * lane_width
    origin = target - d * lane_width
    u_k = _inverse_progress((yk - origin) / (target - origin))
    return float(vy), float(target), u_k


def lateral_forecast(
    y: np.ndarray, dt: float, steps: int, lane_width: float, params: PhysicsParams
) -> np.ndarray:
    """Lateral positions over the prediction (module docstring's lane-change model).

    Args:
        y: the observed lateral positions y_0 … y_k [m], shape (k + 1,).
        dt: T_s [s].
        steps: H.
        lane_width: w [m].
        params: D and the trigger.

    Returns:
        y at j = 0 … H, shape (H + 1,) (row 0: y_k).
    """
    y = np.asarray(y, dtype=float)
    vy, target, u_k = lane_change_state(y, dt, lane_width)
    yk = float(y[-1])
    if abs(vy) < params.trigger_mps:
        return np.full(steps + 1, yk)
    s_k = float(quintic_progress(u_k))
    tau = np.arange(steps + 1) * dt
    share = (quintic_progress(u_k + tau / params.lc_duration_s) - s_k) / max(1.0 - s_k, 1e-9)
    return yk + (target - yk) * share


def longitudinal_forecast(
    ev: np.ndarray,
    others: np.ndarray,
    y_path: np.ndarray,
    dt: float,
    lane_width: float,
    length: float,
    params: PhysicsParams,
) -> np.ndarray:
    """Longitudinal positions under IDM behind the leader of the predicted lane.

    Args:
        ev: the observed states [x, y, φ, v] ξ_0 … ξ_k, shape (k + 1, 4).
        others: the surrounding vehicles' states at sample k, shape (m, 4) (predicted at
            constant velocity from here).
        y_path: the vehicle's predicted lateral positions, shape (H + 1,).
        dt: T_s [s].
        lane_width: w [m] (lane i covers [i·w, (i + 1)·w)).
        length: the leader's length, subtracted from the front-to-front distance [m].
        params: the IDM parameters.

    Returns:
        x at j = 0 … H, shape (H + 1,) (row 0: x_k).
    """
    steps = len(y_path) - 1
    v_obs = ev[:, 3] * np.cos(ev[:, 2])
    v0 = params.v0_factor * max(float(np.percentile(v_obs, 90)), 1.0)
    others = np.asarray(others, dtype=float).reshape(-1, 4)
    ox0, oy0 = others[:, 0], others[:, 1]
    ovx, ovy = others[:, 3] * np.cos(others[:, 2]), others[:, 3] * np.sin(others[:, 2])
    x = np.empty(steps + 1)
    x[0], v = float(ev[-1, 0]), float(v_obs[-1])
    for j in range(steps):
        t = j * dt
        ox, oy = ox0 + ovx * t, oy0 + ovy * t
        i = int(leaders(x[j : j + 1], y_path[j : j + 1], ox, oy, lane_width)[0])
        if i >= 0:
            acc = idm_acceleration(v, float(ox[i] - x[j] - length), v - float(ovx[i]), v0, params)
        else:
            acc = idm_acceleration(v, None, 0.0, v0, params)
        v_next = max(0.0, v + acc * dt)
        x[j + 1] = x[j] + 0.5 * (v + v_next) * dt
        v = v_next
    return x


def physics_forecast(
    ev: np.ndarray,
    others: np.ndarray,
    dt: float,
    steps: int,
    lane_width: float,
    length: float,
    params: PhysicsParams,
) -> np.ndarray:
    """The physics baseline's positions: the lateral model, then IDM along it.

    Args:
        ev: the observed states ξ_0 … ξ_k, shape (k + 1, 4).
        others: the surrounding vehicles' states at sample k, shape (m, 4) (m may be 0).
        dt: T_s [s].
        steps: H.
        lane_width: w [m].
        length: vehicle length [m].
        params: the model's parameters.

    Returns:
        Positions at j = 0 … H, shape (H + 1, 2) (row 0: the last observed position).
    """
    ev = np.asarray(ev, dtype=float)
    y = lateral_forecast(ev[:, 1], dt, steps, lane_width, params)
    x = longitudinal_forecast(ev, others, y, dt, lane_width, length, params)
    return np.column_stack([x, y])


@dataclass(frozen=True)
class PhysicsBaseline:
    """``physics``: :func:`physics_forecast` of the observed vehicle with ``params``."""

    params: PhysicsParams = field(default_factory=PhysicsParams)
    """The model's parameters (the benchmark passes the calibrated ones)."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The physics baseline's path (:class:`~drivestyle.prediction.protocol.Predictor`)."""
        sc = seen.scenario
        xy = physics_forecast(seen.ev, seen.others, seen.dt, steps, sc.lane_width,
                              sc.vehicle_length, self.params)  # fmt: skip
        return PredictedPath(xy)
