"""The joint physics predictor: IDM and MOBIL for every observed vehicle, rolled out together.

The physics baseline (:mod:`drivestyle.prediction.physics`) predicts one vehicle with the
others at constant velocity, so the braking of the car ahead never reaches it. Here every
vehicle of the observation — the predicted vehicle (row 0) and each surrounding one — is
rolled out together from its state at sample k, step by step, in the road frame (lanes
``w`` wide, lane i covering [i·w, (i + 1)·w)). From the observed samples 0 … k only:

- **Longitudinal: IDM behind the leader as rolled out** (Treiber, Hennecke, Helbing 2000).
  At step j each vehicle's leader is the nearest vehicle ahead in its lane among the
  others' *rollout* states at j (:func:`neighbours`: the rule of
  :func:`drivestyle.envs.lanes.leaders`), so a leader that brakes slows its follower:

      a = a_max [1 − (v / v0)^4 − (s* / s)²],   s* = s0 + max(0, v T + v Δv / (2 √(a_max b))),

  s the bumper gap (x_leader − x − vehicle length) [m], Δv = v − v_leader [m/s], v the
  longitudinal speed v cos φ (the one IDM: :func:`drivestyle.envs.traffic.idm_accelerations`).
  Each vehicle's desired speed is its own: v0 = ρ · v_90, v_90 the 90th percentile of *its*
  observed longitudinal speeds (at least 1 m/s), as the physics baseline's for the vehicle.
  Every vehicle's acceleration at j is computed from the states at j, then all move:
  v_{j+1} = max(0, v_j + a_j T_s), x_{j+1} = x_j + ½ (v_j + v_{j+1}) T_s.
- **Lateral: the quintic lane change of the physics baseline, started by MOBIL.** A vehicle
  whose observed lateral velocity is at least :attr:`JointPhysicsParams.trigger_mps`
  continues its change to the target line exactly as the physics baseline predicts it
  (:func:`~drivestyle.prediction.physics.lane_change_state`: progress u_k, duration D);
  the others keep their lateral position until MOBIL (Kesting, Treiber, Helbing 2007,
  "General lane-changing model MOBIL for car-following models", TRR 1999) starts a change.
  At every step each vehicle not changing lane weighs the lanes beside it (:func:`mobil`):

      incentive   ã_c − a_c + p [(ã_n − a_n) + (ã_o − a_o)] > Δa_th,
      safety      ã_n ≥ −b_safe,

  a_c, ã_c its own IDM acceleration now and after the change (behind the new leader),
  a_n, ã_n those of the new follower (behind the new leader, then behind it), a_o, ã_o
  those of the old follower (behind it, then behind its old leader), p the politeness,
  Δa_th the threshold and b_safe the safe braking; a missing follower contributes 0, and no
  vehicle may change into a lane where another overlaps it (|Δx| < vehicle length). Of the
  two sides, the larger incentive that passes wins (a tie: the left). The change is the
  quintic from the current lateral position y_j to the new lane's centre over D:
  y(t_j + τ) = y_j + (y_T − y_j) s(τ / D), s(u) = 10u³ − 15u⁴ + 6u⁵. A vehicle becomes a
  candidate again when its change ends. Within a step the vehicles decide one after
  another, the largest incentive first, each change counted before the next decision
  (:func:`mobil_starts`). The lanes a vehicle may use are the scenario's
  (``n_lanes``, lanes 0 … n_lanes − 1 of the frame) and any lane a vehicle was observed in.

One vehicle alone is the physics baseline's free-road prediction (no leader, no incentive;
tested). Batches: :class:`JointScene` holds B scenes of up to n vehicles (padded, with a
``present`` mask) so that a calibration rolls every case out at once (:func:`joint_rollout`);
one scene is B = 1 (:func:`observed_scene`). The parameters (:class:`JointPhysicsParams`)
are calibrated on the benchmark's train split by
:mod:`drivestyle.prediction.joint_physics_calibration`. :class:`JointPhysicsBaseline` is the
model as a :class:`~drivestyle.prediction.protocol.Predictor` (``joint_physics``: the
predicted vehicle's path).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from drivestyle.envs.lanes import lane_index
from drivestyle.envs.traffic import IDMParams, idm_accelerations
from drivestyle.prediction.physics import PhysicsParams, lane_change_state, quintic_progress
from drivestyle.prediction.protocol import Observation, PredictedPath

__all__ = [
    "JointPhysicsBaseline",
    "JointPhysicsParams",
    "JointScene",
    "following_acceleration",
    "joint_physics_forecast",
    "joint_rollout",
    "lane_members",
    "mobil",
    "mobil_starts",
    "neighbours",
    "observed_scene",
    "stack_scenes",
]


@dataclass(frozen=True)
class JointPhysicsParams:
    """The joint physics baseline's parameters (module docstring)."""

    v0_factor: float = 1.1
    """ρ: each vehicle's IDM desired speed v0 = ρ · (90th percentile of its observed
    speeds) [-]."""
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
    politeness: float = 0.25
    """p: MOBIL's politeness, the weight of the followers' gains [-] (≥ 0)."""
    threshold_mps2: float = 0.2
    """Δa_th: MOBIL's switching threshold [m/s²] (≥ 0)."""
    safe_decel_mps2: float = 4.0
    """b_safe: the hardest braking a change may impose on the new follower [m/s²] (Kesting et
    al.'s value, fixed a priori)."""
    trigger_mps: float = 0.1
    """|v_y| above which an observed lane change is under way [m/s] (the physics baseline's,
    fixed a priori)."""

    NONNEGATIVE = ("politeness", "threshold_mps2")
    """The parameters that may be 0 (the others must be > 0)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            zero_ok = f.name in self.NONNEGATIVE
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not (ok and np.isfinite(value) and (value >= 0 if zero_ok else value > 0)):
                raise ValueError(
                    f"{f.name} must be a finite number {'>=' if zero_ok else '>'} 0, got {value!r}"
                )

    def to_json(self) -> dict[str, float]:
        """JSON-ready dict."""
        return {k: float(v) for k, v in asdict(self).items()}

    @property
    def idm(self) -> IDMParams:
        """The IDM's parameters (T, s0, a_max, b; the project IDM's exponent and bound)."""
        return IDMParams(a_max=self.accel_mps2, b=self.decel_mps2, s0=self.min_gap_m,
                         time_gap=self.time_gap_s)  # fmt: skip

    def physics(self) -> PhysicsParams:
        """The single-vehicle physics baseline with the same IDM, D and trigger."""
        return PhysicsParams(**{f.name: getattr(self, f.name) for f in fields(PhysicsParams)})


# ---------------------------------------------------------------------------- the scene
@dataclass(frozen=True)
class JointScene:
    """B scenes of up to n vehicles at their present sample k (row 0: the predicted vehicle).

    Every array field is (B, n) unless said; a scene with fewer vehicles is padded with
    absent ones (``present`` False: nobody's leader or follower, never moved).
    """

    x: np.ndarray
    """Longitudinal positions x_k [m]."""
    y: np.ndarray
    """Lateral positions y_k [m]."""
    v: np.ndarray
    """Longitudinal speeds v_k cos φ_k [m/s]."""
    v90: np.ndarray
    """The 90th percentile of each vehicle's observed longitudinal speeds, at least 1 [m/s]."""
    vy: np.ndarray
    """Observed lateral velocities (:func:`~drivestyle.prediction.physics.lane_change_state`)
    [m/s]."""
    target: np.ndarray
    """The target lines of the observed lateral motions [m]."""
    progress: np.ndarray
    """The progress u_k ∈ [0, 1] through the observed changes [-]."""
    present: np.ndarray
    """Which vehicles exist (bool)."""
    dt: np.ndarray
    """T_s per scene, shape (B,) [s]."""
    lane_width: np.ndarray
    """w per scene, shape (B,) [m]."""
    length: np.ndarray
    """Vehicle length per scene, shape (B,) [m]."""
    lanes: np.ndarray
    """The lowest and highest lane any vehicle may use per scene, shape (B, 2) (int)."""

    def __post_init__(self) -> None:
        shape = np.shape(self.x)
        if len(shape) != 2 or shape[1] < 1:
            raise ValueError(f"a joint scene's states must be (B, n) with n >= 1, got {shape}")
        for name in ("y", "v", "v90", "vy", "target", "progress", "present"):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(
                    f"{name} must have shape {shape}, got {np.shape(getattr(self, name))}"
                )
        for name in ("dt", "lane_width", "length"):
            if np.shape(getattr(self, name)) != shape[:1]:
                raise ValueError(f"{name} must have shape {shape[:1]}")
        if np.shape(self.lanes) != (shape[0], 2):
            raise ValueError(f"lanes must have shape ({shape[0]}, 2), got {np.shape(self.lanes)}")


def observed_scene(
    ev: np.ndarray,
    vehicles: np.ndarray,
    dt: float,
    lane_width: float,
    length: float,
    n_lanes: int,
) -> JointScene:
    """One observed scene (B = 1) from the observed states of every vehicle.

    Args:
        ev: the predicted vehicle's observed states ξ_0 … ξ_k [x, y, φ, v], shape (k + 1, 4)
            [m, m, rad, m/s].
        vehicles: the surrounding vehicles' observed states at the same samples, shape
            (k + 1, m, 4) (m may be 0).
        dt: T_s [s].
        lane_width: w [m].
        length: vehicle length [m].
        n_lanes: the scenario's lanes (0 … n_lanes − 1 are usable, and any lane a vehicle
            was observed in).

    Returns:
        The scene, vehicles in order (the predicted one first), shape (1, 1 + m).
    """
    ev = np.asarray(ev, dtype=float)
    vehicles = np.asarray(vehicles, dtype=float).reshape(len(ev), -1, 4)
    every = np.concatenate([ev[:, None, :], vehicles], axis=1)  # (k + 1, n, 4)
    n = every.shape[1]
    v_obs = every[:, :, 3] * np.cos(every[:, :, 2])
    states = [lane_change_state(every[:, i, 1], dt, lane_width) for i in range(n)]
    seen = lane_index(every[:, :, 1], lane_width)
    lanes = [min(0, int(seen.min())), max(n_lanes - 1, int(seen.max()))]
    return JointScene(
        x=every[-1, :, 0][None, :].copy(),
        y=every[-1, :, 1][None, :].copy(),
        v=v_obs[-1][None, :].copy(),
        v90=np.array([[max(float(np.percentile(v_obs[:, i], 90)), 1.0) for i in range(n)]]),
        vy=np.array([[s[0] for s in states]]),
        target=np.array([[s[1] for s in states]]),
        progress=np.array([[s[2] for s in states]]),
        present=np.ones((1, n), bool),
        dt=np.array([float(dt)]),
        lane_width=np.array([float(lane_width)]),
        length=np.array([float(length)]),
        lanes=np.array([lanes]),
    )


def stack_scenes(scenes: Sequence[JointScene]) -> JointScene:
    """Scenes as one batch, each padded to the most vehicles with absent ones.

    Raises:
        ValueError: no scene.
    """
    if not scenes:
        raise ValueError("no scene to stack")
    n = max(s.x.shape[1] for s in scenes)

    def pad(name: str, fill: float | bool) -> np.ndarray:
        parts = []
        for s in scenes:
            a = getattr(s, name)
            parts.append(np.pad(a, ((0, 0), (0, n - a.shape[1])), constant_values=fill))
        return np.concatenate(parts)

    return JointScene(
        x=pad("x", 0.0), y=pad("y", 0.0), v=pad("v", 0.0), v90=pad("v90", 1.0),
        vy=pad("vy", 0.0), target=pad("target", 0.0), progress=pad("progress", 0.0),
        present=pad("present", False),
        dt=np.concatenate([s.dt for s in scenes]),
        lane_width=np.concatenate([s.lane_width for s in scenes]),
        length=np.concatenate([s.length for s in scenes]),
        lanes=np.concatenate([s.lanes for s in scenes]),
    )  # fmt: skip


# ---------------------------------------------------------------------------- the model
def lane_members(lane: np.ndarray, examined: np.ndarray) -> np.ndarray:
    """Which vehicles are in the lane examined for each vehicle.

    Args:
        lane: each vehicle's lane, shape (B, n) (its lane ℓ_j, or for MOBIL the lane it is
            headed for: see :func:`mobil`).
        examined: the lane examined for each vehicle, shape (B, n).

    Returns:
        m[b, i, j]: vehicle j is in the lane examined for vehicle i, shape (B, n, n) bool.
    """
    return np.asarray(lane[:, None, :] == examined[:, :, None])


def neighbours(
    x: np.ndarray, members: np.ndarray, present: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each vehicle's leader and follower among the vehicles of a lane.

    The leader is the nearest vehicle ahead (x_j > x_i) of the lane, the follower the
    nearest behind (x_j < x_i); in a vehicle's own lane the leader is the one of
    :func:`drivestyle.envs.lanes.leaders`.

    Args:
        x: longitudinal positions, shape (B, n) [m].
        members: who is in the lane examined for each vehicle (:func:`lane_members`), shape
            (B, n, n) bool.
        present: which vehicles exist, shape (B, n) bool.

    Returns:
        (leader, follower, longitudinal distances): the leader's and follower's columns,
        −1 where none, shape (B, n) each; and x_j − x_i for every vehicle j of the lane
        (NaN for the others and j = i), shape (B, n, n) [m].
    """
    n = x.shape[1]
    dx = x[:, None, :] - x[:, :, None]  # [b, i, j] = x_j − x_i
    there = members & present[:, None, :] & ~np.eye(n, dtype=bool)[None]
    ahead, behind = there & (dx > 0), there & (dx < 0)
    lead = np.where(ahead.any(axis=2), np.argmin(np.where(ahead, dx, np.inf), axis=2), -1)
    follow = np.where(behind.any(axis=2), np.argmax(np.where(behind, dx, -np.inf), axis=2), -1)
    return lead, follow, np.where(there, dx, np.nan)


def following_acceleration(
    who: np.ndarray,
    ahead: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    v0: np.ndarray,
    length: np.ndarray,
    idm: IDMParams,
) -> np.ndarray:
    """The IDM acceleration of vehicle ``who`` behind vehicle ``ahead``, per entry.

    Args:
        who: the following vehicle's column, −1: none (its acceleration is then 0: a
            missing follower gains nothing in MOBIL's sum), shape (B, K) (any K pairs).
        ahead: the leading vehicle's column, −1: none (the free-road term), shape (B, K).
        x: longitudinal positions, shape (B, n) [m].
        v: longitudinal speeds, shape (B, n) [m/s].
        v0: desired speeds, shape (B, n) [m/s].
        length: vehicle length per scene (the bumper gap is x_ahead − x_who − length),
            shape (B,) [m].
        idm: the IDM's parameters.

    Returns:
        Accelerations [m/s²], shape (B, K).
    """
    rows = np.arange(x.shape[0])[:, None]
    w, a = np.maximum(who, 0), np.maximum(ahead, 0)
    xw, vw, v0w, xa, va = x[rows, w], v[rows, w], v0[rows, w], x[rows, a], v[rows, a]
    gap = np.where(ahead >= 0, xa - xw - length[:, None], np.nan)
    return np.where(who >= 0, idm_accelerations(vw, v0w, gap, va, idm), 0.0)


def mobil(
    x: np.ndarray,
    v: np.ndarray,
    lane: np.ndarray,
    entering: np.ndarray,
    v0: np.ndarray,
    present: np.ndarray,
    free: np.ndarray,
    length: np.ndarray,
    lanes: np.ndarray,
    params: JointPhysicsParams,
) -> tuple[np.ndarray, np.ndarray]:
    """MOBIL's wish for every vehicle (module docstring): the side it would change to.

    Each side's incentive ã_c − a_c + p [(ã_n − a_n) + (ã_o − a_o)] is computed from the
    present states; a side qualifies where it is a usable lane, no vehicle of it overlaps
    (|x_j − x_i| < vehicle length), the new follower keeps ã_n ≥ −b_safe and the incentive
    exceeds Δa_th; of two that qualify the larger incentive wins (a tie: the left). A
    vehicle that has started a change counts, as a leader or follower, in the lane it is
    headed for only
    (``entering``: it is leaving the other, and a slow leader would otherwise yield to a
    follower that is already going), and in both lanes as an obstacle (the overlap).

    Args:
        x: longitudinal positions, shape (B, n) [m].
        v: longitudinal speeds, shape (B, n) [m/s].
        lane: lane indices, shape (B, n).
        entering: the lane each vehicle is changing into (its own where none), shape (B, n).
        v0: desired speeds, shape (B, n) [m/s].
        present: which vehicles exist, shape (B, n) bool.
        free: which vehicles may start a change (present, not changing), shape (B, n) bool.
        length: vehicle length per scene, shape (B,) [m].
        lanes: the lowest and highest usable lane per scene, shape (B, 2).
        params: the IDM's parameters, p, Δa_th, b_safe.

    Returns:
        (side, incentive): −1 (to lane ℓ − 1), +1 (to ℓ + 1) or 0 (stay), and the winning
        side's incentive [m/s²] (−inf where it stays), shape (B, n) each.
    """
    n = x.shape[1]
    own = np.broadcast_to(np.arange(n), x.shape)
    lead, follow, _ = neighbours(x, lane_members(entering, lane), present)
    sides = (1, -1)  # a tie goes to the left, the passing side
    new, overlap = [], []
    for d in sides:
        headed = lane_members(entering, lane + d)
        new.append(neighbours(x, headed, present)[:2])
        _, _, dx = neighbours(x, headed | lane_members(lane, lane + d), present)
        overlap.append(np.any(np.abs(dx) < length[:, None, None], axis=2))  # NaN: not there
    # every IDM acceleration MOBIL weighs, in one call: (follower, leader) pairs side by side
    pairs = [(own, lead), (follow, own), (follow, lead)]
    for new_lead, new_follow in new:
        pairs += [(own, new_lead), (new_follow, new_lead), (new_follow, own)]
    acc = following_acceleration(np.concatenate([p[0] for p in pairs], axis=1),
                                 np.concatenate([p[1] for p in pairs], axis=1),
                                 x, v, v0, length, params.idm)  # fmt: skip
    a_c, a_o, a_o_after = (acc[:, i * n : (i + 1) * n] for i in range(3))
    best = np.full(x.shape, -np.inf)
    side = np.zeros(x.shape, int)
    for i, d in enumerate(sides):
        a_c_after, a_n, a_n_after = (acc[:, (3 + 3 * i + j) * n : (4 + 3 * i + j) * n]
                                     for j in range(3))  # fmt: skip
        gain = a_c_after - a_c + params.politeness * (a_n_after - a_n + a_o_after - a_o)
        usable = (lane + d >= lanes[:, :1]) & (lane + d <= lanes[:, 1:])
        ok = free & usable & ~overlap[i] & (a_n_after >= -params.safe_decel_mps2)
        ok &= (gain > params.threshold_mps2) & (gain > best)
        best = np.where(ok, gain, best)
        side = np.where(ok, d, side)
    return side, best


def mobil_starts(
    x: np.ndarray,
    v: np.ndarray,
    lane: np.ndarray,
    entering: np.ndarray,
    v0: np.ndarray,
    present: np.ndarray,
    free: np.ndarray,
    length: np.ndarray,
    lanes: np.ndarray,
    params: JointPhysicsParams,
) -> np.ndarray:
    """The changes MOBIL starts at one step, decided one vehicle after another.

    Decisions made at once from the same states would send two vehicles into one gap, or
    both of a pair out of each other's way (a slow leader's politeness moving it aside
    while its follower overtakes). So, per scene, the vehicle with the largest qualifying
    incentive (:func:`mobil`) starts first and then counts in the lane it is headed for
    (``entering``); the others decide again, until none wishes to change.

    Args: as :func:`mobil`.

    Returns:
        The side each vehicle starts to (−1, +1; 0: none), shape (B, n).
    """
    starts = np.zeros(x.shape, int)
    free, entering = free.copy(), entering.copy()
    rows = np.arange(x.shape[0])
    while True:
        side, gain = mobil(x, v, lane, entering, v0, present, free, length, lanes, params)
        if not side.any():
            return starts
        first = np.argmax(gain, axis=1)  # per scene, the largest incentive (−inf: none)
        chosen = side[rows, first]
        moved = rows[chosen != 0]
        starts[moved, first[chosen != 0]] = chosen[chosen != 0]
        free[moved, first[chosen != 0]] = False
        entering[moved, first[chosen != 0]] += chosen[chosen != 0]


def joint_rollout(scene: JointScene, steps: int, params: JointPhysicsParams) -> np.ndarray:
    """Every vehicle of every scene rolled out together (module docstring).

    At each step j, from the states at j: MOBIL starts the changes it decides
    (:func:`mobil_starts`, among the vehicles not changing lane), every vehicle's IDM
    acceleration behind its leader in its lane (the lane of y_j), then all move.

    Args:
        scene: B scenes of n vehicles at sample k.
        steps: H, samples to predict.
        params: the model's parameters.

    Returns:
        Positions [x, y] at j = 0 … H, shape (B, H + 1, n, 2) [m] (row 0: sample k; absent
        vehicles stay where they are padded).
    """
    present = np.asarray(scene.present, bool)
    w, dt, length = scene.lane_width, scene.dt, scene.length
    D = params.lc_duration_s
    idm = params.idm
    # the lateral plan: y(τ) = y_a + (y_T − y_a) [s(u_a + (τ − τ_a)/D) − s(u_a)] / (1 − s(u_a))
    changing = present & (np.abs(scene.vy) >= params.trigger_mps)
    y_from = np.asarray(scene.y, dtype=float).copy()
    y_to = np.where(changing, scene.target, y_from)
    u_from = np.where(changing, scene.progress, 0.0)
    t_from = np.zeros_like(y_from)

    def lateral(tau: np.ndarray) -> np.ndarray:
        s_from = quintic_progress(u_from)
        share = (quintic_progress(u_from + (tau[:, None] - t_from) / D) - s_from) / np.maximum(
            1.0 - s_from, 1e-9
        )
        return np.asarray(y_from + (y_to - y_from) * share)

    v0 = params.v0_factor * scene.v90
    x, v = np.asarray(scene.x, dtype=float).copy(), np.asarray(scene.v, dtype=float).copy()
    own = np.broadcast_to(np.arange(x.shape[1]), x.shape)
    out = np.empty((x.shape[0], steps + 1, x.shape[1], 2))
    out[:, 0, :, 0], out[:, 0, :, 1] = x, lateral(np.zeros_like(dt))
    for j in range(steps):
        tau = j * dt
        y = lateral(tau)
        lane = lane_index(y, w[:, None])
        under_way = (y_to != y_from) & (tau[:, None] < t_from + (1.0 - u_from) * D)
        entering = np.where(under_way, lane_index(y_to, w[:, None]), lane)
        side = mobil_starts(x, v, lane, entering, v0, present, present & ~under_way, length,
                            scene.lanes, params)  # fmt: skip
        if side.any():
            start = side != 0
            y_from, u_from = np.where(start, y, y_from), np.where(start, 0.0, u_from)
            y_to = np.where(start, (lane + side + 0.5) * w[:, None], y_to)
            t_from = np.where(start, tau[:, None], t_from)
        lead, _, _ = neighbours(x, lane_members(lane, lane), present)  # envs.lanes.leaders
        acc = following_acceleration(own, lead, x, v, v0, length, idm)
        v_next = np.maximum(0.0, v + acc * dt[:, None])
        x = np.where(present, x + 0.5 * (v + v_next) * dt[:, None], x)
        v = np.where(present, v_next, v)
        out[:, j + 1, :, 0], out[:, j + 1, :, 1] = x, lateral((j + 1) * dt)
    return out


def joint_physics_forecast(
    ev: np.ndarray,
    vehicles: np.ndarray,
    dt: float,
    steps: int,
    lane_width: float,
    length: float,
    n_lanes: int,
    params: JointPhysicsParams,
) -> np.ndarray:
    """Every observed vehicle's predicted positions (module docstring).

    Args:
        ev: the predicted vehicle's observed states ξ_0 … ξ_k, shape (k + 1, 4).
        vehicles: the surrounding vehicles' observed states, shape (k + 1, m, 4).
        dt: T_s [s].
        steps: H.
        lane_width: w [m].
        length: vehicle length [m].
        n_lanes: the scenario's lanes.
        params: the model's parameters.

    Returns:
        Positions at j = 0 … H, shape (H + 1, 1 + m, 2) [m] (column 0: the predicted
        vehicle; row 0: the last observed positions).
    """
    scene = observed_scene(ev, vehicles, dt, lane_width, length, n_lanes)
    return joint_rollout(scene, steps, params)[0]


@dataclass(frozen=True)
class JointPhysicsBaseline:
    """``joint_physics``: the observed vehicle's path in :func:`joint_physics_forecast`."""

    params: JointPhysicsParams = field(default_factory=JointPhysicsParams)
    """The model's parameters (the benchmark passes the calibrated ones)."""

    def predict(self, seen: Observation, steps: int) -> PredictedPath:
        """The vehicle's path in the joint rollout (the ``Predictor`` protocol)."""
        sc = seen.scenario
        xy = joint_physics_forecast(seen.ev, seen.vehicles, seen.dt, steps, sc.lane_width,
                                    sc.vehicle_length, sc.n_lanes, self.params)  # fmt: skip
        return PredictedPath(xy[:, 0])
