"""Dense traffic: the lane change among several surrounding vehicles (beyond the paper).

A :class:`TrafficScene` is the single-TV :class:`ScenarioConfig` (EV, TV, road, bounds) plus
a tuple of further vehicles (:class:`VehicleSpec`: lane, initial gap to the EV, speed,
behaviour). Other vehicles either keep their velocity (``"constant"``, as the paper's TV)
or follow highway-env's Intelligent Driver Model with lane keeping (``"idm"``, its
``IDMVehicle`` parameters: comfortable acceleration 3 m/s², braking 5 m/s², jam distance
10 m, time gap 1.5 s, exponent 4; desired speed = the vehicle's initial speed; the leader
is the nearest vehicle ahead whose centre is in the same lane, the EV included).

:class:`TrafficEnv` (``drivestyle/Traffic-v0``: :data:`DEFAULT_TRAFFIC`;
``drivestyle/TrafficRandom-v0``: scenes drawn per reset by :class:`TrafficRanges`) checks
collisions against every vehicle. Observation layout (``Box(4 + 5K,)``, float64, road
frame, SI units), K = :data:`OBS_SLOTS`:

    [x, y, φ, v]_EV ++ K × [present, x, y, φ, v]

the K slots holding the other vehicles (the TV included) nearest to the EV by centre
distance, nearest first; absent slots are zeros. ``info["vehicles"]`` holds every other
vehicle's state in the scene's fixed order (TV first), shape (m, 4).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from gymnasium import spaces

from drivestyle.envs.lane_change import LaneChangeEnv, checked_options
from drivestyle.envs.lanes import leaders
from drivestyle.envs.safety import elliptical_index, rectangles_overlap, vehicle_corners
from drivestyle.envs.scenario import PAPER, ScenarioConfig, ScenarioRanges

__all__ = [
    "BEHAVIOURS",
    "DEFAULT_TRAFFIC",
    "IDM",
    "OBS_SLOTS",
    "TrafficEnv",
    "TrafficRanges",
    "TrafficScene",
    "VehicleSpec",
    "idm_acceleration",
    "idm_accelerations",
    "parse_traffic_observation",
]

BEHAVIOURS = ("constant", "idm")
OBS_SLOTS = 6
"""K: other vehicles in the observation."""


@dataclass(frozen=True)
class IDMParams:
    """Intelligent Driver Model parameters (highway-env's ``IDMVehicle`` defaults)."""

    a_max: float = 3.0
    """Comfortable acceleration [m/s²]."""
    b: float = 5.0
    """Comfortable deceleration [m/s²]."""
    s0: float = 10.0
    """Jam distance, front to rear plus margin [m]."""
    time_gap: float = 1.5
    """Desired time headway [s]."""
    delta: float = 4.0
    """Velocity exponent."""
    max_decel: float = 10.0
    """The hardest braking the IDM commands [m/s²]: its (s*/s)² term grows without bound as
    the gap closes, a car brakes at about 1 g at most."""


IDM = IDMParams()


def idm_acceleration(
    v: float, v0: float, gap: float | None, v_leader: float, p: IDMParams = IDM
) -> float:
    """IDM acceleration a = a_max [1 − (v/v0)^δ − (s*/s)²], s* = s0 + max(0, vT + vΔv/(2√(a b))).

    The project's one IDM (Treiber, Hennecke, Helbing 2000): the traffic env's vehicles and
    the physics baseline of prediction (:mod:`drivestyle.prediction.physics`) both call it.

    Args:
        v: own speed [m/s].
        v0: desired speed [m/s] (> 0).
        gap: bumper-to-bumper distance to the leader [m]; None: no leader.
        v_leader: the leader's speed [m/s].
        p: parameters.

    Returns:
        Acceleration [m/s²], bounded below by −``p.max_decel`` (an emergency brake).
    """
    free = 1.0 - (max(v, 0.0) / v0) ** p.delta
    if gap is None:
        return p.a_max * free
    s_star = p.s0 + max(v * p.time_gap + v * (v - v_leader) / (2 * math.sqrt(p.a_max * p.b)), 0)
    acc = p.a_max * (free - (s_star / max(gap, 0.1)) ** 2)
    return max(acc, -p.max_decel)


def idm_accelerations(
    v: np.ndarray, v0: np.ndarray, gap: np.ndarray, v_leader: np.ndarray, p: IDMParams = IDM
) -> np.ndarray:
    """:func:`idm_acceleration` elementwise on arrays (the same model, the same bound).

    For rollouts of many vehicles at once (the joint physics baseline of prediction,
    :mod:`drivestyle.prediction.joint_physics`); equal to the scalar function (tested).

    Args:
        v: own speeds [m/s], any shape.
        v0: desired speeds [m/s] (> 0), broadcast with ``v``.
        gap: bumper-to-bumper distances to the leaders [m]; NaN: no leader.
        v_leader: the leaders' speeds [m/s] (read only where there is a leader).
        p: parameters.

    Returns:
        Accelerations [m/s²], the broadcast shape, bounded below by −``p.max_decel``.
    """
    v, gap = np.asarray(v, dtype=float), np.asarray(gap, dtype=float)
    free = 1.0 - (np.maximum(v, 0.0) / np.asarray(v0, dtype=float)) ** p.delta
    approach = v * p.time_gap + v * (v - np.asarray(v_leader, dtype=float)) / (
        2 * math.sqrt(p.a_max * p.b)
    )
    s_star = p.s0 + np.maximum(approach, 0)
    s = np.maximum(np.where(np.isnan(gap), 1.0, gap), 0.1)  # NaN: no leader, the free term below
    led = np.maximum(p.a_max * (free - (s_star / s) ** 2), -p.max_decel)
    return np.where(np.isnan(gap), p.a_max * free, led)


@dataclass(frozen=True)
class VehicleSpec:
    """One surrounding vehicle at the episode start."""

    lane: int
    """Lane index (0 = right-most)."""
    gap: float
    """Initial x of its centre minus the EV's [m]."""
    speed: float
    """Initial (and, for IDM, desired) speed [m/s]."""
    behaviour: str = "constant"
    """'constant' (keeps its velocity) or 'idm'."""

    def __post_init__(self) -> None:
        if not (isinstance(self.lane, (int, np.integer)) and self.lane >= 0):
            raise ValueError(f"VehicleSpec.lane must be an integer >= 0, got {self.lane!r}")
        for name in ("gap", "speed"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float, np.floating)) and math.isfinite(value)):
                raise ValueError(f"VehicleSpec.{name} must be a finite number, got {value!r}")
        if self.speed <= 0:
            raise ValueError(f"VehicleSpec.speed must be > 0, got {self.speed}")
        if self.behaviour not in BEHAVIOURS:
            raise ValueError(
                f"VehicleSpec.behaviour must be one of {BEHAVIOURS}, got {self.behaviour!r}"
            )


def _default_others() -> tuple[VehicleSpec, ...]:
    return (
        VehicleSpec(lane=0, gap=60.0, speed=24.0, behaviour="idm"),  # leader, EV's lane
        VehicleSpec(lane=1, gap=60.0, speed=30.0, behaviour="idm"),  # leader, target lane
        VehicleSpec(lane=2, gap=0.0, speed=27.0, behaviour="idm"),  # third lane
    )


@dataclass(frozen=True)
class TrafficScene:
    """A single-TV scenario plus further vehicles (module docstring)."""

    base: ScenarioConfig = PAPER
    """EV, TV, road and bounds (the TV is the target-lane vehicle the paper's features use)."""
    others: tuple[VehicleSpec, ...] = field(default_factory=_default_others)
    """The further vehicles."""
    tv_behaviour: str = "constant"
    """Behaviour of the TV ('constant' as in the paper, or 'idm')."""

    def __post_init__(self) -> None:
        if not isinstance(self.base, ScenarioConfig):
            raise TypeError(f"TrafficScene.base must be a ScenarioConfig, got {self.base!r}")
        others = tuple(self.others)
        if not all(isinstance(o, VehicleSpec) for o in others):
            raise TypeError("TrafficScene.others must be VehicleSpec instances")
        object.__setattr__(self, "others", others)
        if self.tv_behaviour not in BEHAVIOURS:
            raise ValueError(f"tv_behaviour must be one of {BEHAVIOURS}, got {self.tv_behaviour!r}")
        sc = self.base
        for i, o in enumerate(others):
            if o.lane >= sc.n_lanes:
                raise ValueError(f"vehicle {i}: lane {o.lane} does not exist ({sc.n_lanes} lanes)")
        states = self.initial_states()
        ev = sc.ev_initial_state
        for i, s in enumerate(states[1:], start=1):
            s_e = float(elliptical_index(ev[0] - s[0], ev[1] - s[1], sc.l_a, sc.l_b))
            if s_e <= 1.0:
                raise ValueError(
                    f"vehicle {i} starts inside the EV's safety ellipse (s_e = {s_e:.2f} <= 1): "
                    "no SMPC plan is feasible; move it"
                )
        corners = [vehicle_corners(s, sc.vehicle_length, sc.vehicle_width) for s in states]
        for i in range(len(states)):
            for j in range(i + 1, len(states)):
                if rectangles_overlap(corners[i], corners[j]):
                    raise ValueError(f"vehicles {i} and {j} overlap at the start")

    @property
    def behaviours(self) -> tuple[str, ...]:
        """Behaviour of every other vehicle, TV first."""
        return (self.tv_behaviour, *(o.behaviour for o in self.others))

    def initial_states(self) -> np.ndarray:
        """States [x, y, φ, v] of every other vehicle at t = 0, TV first, shape (m, 4)."""
        sc = self.base
        rows: list[np.ndarray | list[float]] = [sc.tv_initial_state]
        rows += [[sc.ev_x + o.gap, sc.lane_centres[o.lane], 0.0, o.speed] for o in self.others]
        return np.array(rows, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (``base`` as the scenario's fields)."""
        return {
            "base": self.base.to_dict(),
            "others": [dataclasses.asdict(o) for o in self.others],
            "tv_behaviour": self.tv_behaviour,
        }

    @classmethod
    def from_dict(cls, raw: dict[str, Any]) -> TrafficScene:
        """Inverse of :meth:`to_dict`."""
        return cls(
            ScenarioConfig(**raw["base"]),
            tuple(VehicleSpec(**o) for o in raw["others"]),
            raw.get("tv_behaviour", "constant"),
        )


DEFAULT_TRAFFIC = TrafficScene()
"""The fixed default scene of ``drivestyle/Traffic-v0``: the paper's EV and TV, a leader in
the EV's lane (60 m ahead, 24 m/s), a leader in the target lane (60 m ahead, 30 m/s) and a
vehicle in the third lane beside the EV (27 m/s), all three IDM. SMPC(0.7) changes lane
behind the TV at t_trg = 3.0 s as in the paper; SMPC(0.95) stays behind the slow leader."""


@dataclass(frozen=True)
class TrafficRanges:
    """Random traffic scenes: the single-TV family plus the three further vehicles drawn."""

    single: ScenarioRanges = field(default_factory=ScenarioRanges)
    """EV and TV (the random family of ``LaneChangeRandom-v0``)."""
    leader_gap: tuple[float, float] = (35.0, 70.0)
    """Gap of the EV-lane leader [m]."""
    leader_speed: tuple[float, float] = (20.0, 27.0)
    """Speed of the EV-lane leader [m/s]."""
    target_leader_gap: tuple[float, float] = (30.0, 70.0)
    """Gap of the target-lane leader [m]."""
    target_leader_speed: tuple[float, float] = (25.0, 32.0)
    """Speed of the target-lane leader [m/s]."""
    third_gap: tuple[float, float] = (-30.0, 30.0)
    """Gap of the third-lane vehicle [m]."""
    third_speed: tuple[float, float] = (24.0, 32.0)
    """Speed of the third-lane vehicle [m/s]."""
    behaviour: str = "idm"
    """Behaviour of the further vehicles."""

    def sample(self, rng: np.random.Generator, max_tries: int = 100) -> TrafficScene:
        """Draw one feasible scene.

        Raises:
            RuntimeError: no feasible draw within ``max_tries``.
        """
        for _ in range(max_tries):
            base = self.single.sample(rng)
            others = (
                VehicleSpec(
                    base.ev_lane,
                    float(rng.uniform(*self.leader_gap)),
                    float(rng.uniform(*self.leader_speed)),
                    self.behaviour,
                ),
                VehicleSpec(
                    base.target_lane,
                    float(rng.uniform(*self.target_leader_gap)),
                    float(rng.uniform(*self.target_leader_speed)),
                    self.behaviour,
                ),
                VehicleSpec(
                    3 - base.ev_lane - base.target_lane,
                    float(rng.uniform(*self.third_gap)),
                    float(rng.uniform(*self.third_speed)),
                    self.behaviour,
                ),
            )
            try:
                return TrafficScene(base, others)
            except ValueError:
                continue
        raise RuntimeError(f"no feasible traffic scene in {max_tries} draws; widen the ranges")


def parse_traffic_observation(obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split a :class:`TrafficEnv` observation into the EV state and the present vehicles.

    Returns:
        EV state (4,) and the present vehicles' states (m, 4), nearest first.

    Raises:
        ValueError: the observation does not have the documented layout.
    """
    obs = np.asarray(obs, dtype=float)
    if obs.ndim != 1 or obs.size < 4 or (obs.size - 4) % 5:
        raise ValueError(f"a traffic observation has 4 + 5K entries, got shape {obs.shape}")
    slots = obs[4:].reshape(-1, 5)
    return obs[:4].copy(), slots[slots[:, 0] > 0.5, 1:].copy()


class TrafficEnv(LaneChangeEnv):
    """The lane change among several vehicles (module docstring).

    Args:
        scene: a :class:`TrafficScene` (default :data:`DEFAULT_TRAFFIC`).
        randomize: ``True`` or a :class:`TrafficRanges`: draw a scene per reset.
        render_mode: as :class:`LaneChangeEnv`.
        show_ellipse: draw the TV's safety ellipse.
        style: a learned style as the reward (as :class:`LaneChangeEnv`).
        reward: any reward model (as :class:`LaneChangeEnv`).
        others: the further vehicles instead of the scene's (a list of VehicleSpec or of
            dicts with their fields).
        **overrides: fields of the base scenario (e.g. ``ev_speed=27``).
    """

    # gymnasium types Env.metadata as an instance variable: __init__ sets the env's render_fps
    metadata: dict[str, Any] = {  # noqa: RUF012 (never mutated; __init__ assigns a copy)
        "render_modes": ["human", "rgb_array"],
        "render_fps": 5,
    }

    def __init__(
        self,
        scene: TrafficScene | None = None,
        randomize: bool | TrafficRanges = False,
        render_mode: str | None = None,
        show_ellipse: bool = True,
        style: Any = None,
        reward: Any = None,
        others: Any = None,
        **overrides: Any,
    ) -> None:
        scene = DEFAULT_TRAFFIC if scene is None else scene
        if not isinstance(scene, TrafficScene):
            raise TypeError(f"scene must be a TrafficScene, got {type(scene).__name__}")
        if others is not None:
            specs = tuple(o if isinstance(o, VehicleSpec) else VehicleSpec(**o) for o in others)
            scene = dataclasses.replace(scene, others=specs)
        if overrides:
            scene = dataclasses.replace(scene, base=scene.base.with_overrides(**overrides))
        if randomize is True:
            randomize = TrafficRanges()
        elif randomize is not False and not isinstance(randomize, TrafficRanges):
            raise TypeError(f"randomize must be a bool or TrafficRanges, got {randomize!r}")
        # the vehicles first: the base class sets the TV, which is vehicles[0] here
        self.vehicles = scene.initial_states()
        self._desired_speeds = self.vehicles[:, 3].copy()  # IDM: the initial speeds
        super().__init__(scene.base, False, render_mode, show_ellipse, style=style, reward=reward)
        self.base_scene = scene
        self.scene = scene
        self.traffic_ranges: TrafficRanges | None = randomize or None
        n = 4 + 5 * OBS_SLOTS
        low = np.full(n, -np.inf)
        high = np.full(n, np.inf)
        low[3], high[3] = 0.0, scene.base.v_max
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)

    # ------------------------------------------------------------------ helpers
    @property
    def tv(self) -> np.ndarray:
        """The TV's state (the first of :attr:`vehicles`)."""
        return self.vehicles[0]

    @tv.setter
    def tv(self, state: np.ndarray) -> None:
        self.vehicles[0] = state

    # Python floats in the step, as in the base class (its comment); the results equal the
    # array formulas (tests/envs/test_traffic.py).
    def _obs(self) -> np.ndarray:
        ev = self.ev.tolist()
        rows = self.vehicles.tolist()
        obs = ev + [0.0] * (5 * OBS_SLOTS)
        # numpy's hypot (the math module's may round differently), then a stable sort
        dist = np.hypot(self.vehicles[:, 0] - ev[0], self.vehicles[:, 1] - ev[1]).tolist()
        for slot, j in enumerate(sorted(range(len(rows)), key=dist.__getitem__)[:OBS_SLOTS]):
            obs[4 + 5 * slot : 9 + 5 * slot] = [1.0, *rows[j]]
        return np.array(obs)

    def _info(self, **extra: Any) -> dict[str, Any]:
        info = super()._info(**extra)
        c = self._constants()
        x, y = self.ev.tolist()[:2]
        s_e_min = math.inf
        for r in self.vehicles.tolist():
            # elliptical_index; numpy squares arrays as z * z
            zx, zy = (x - r[0]) / c.l_a, (y - r[1]) / c.l_b
            s_e_min = min(s_e_min, zx * zx + zy * zy)
        info["s_e_min"] = s_e_min
        info["vehicles"] = self.vehicles.copy()
        return info

    def _collision(self) -> bool:
        """Whether the EV collides with any other vehicle, the TV included."""
        return self._overlaps_any(self.vehicles.tolist())

    def _advance_others(self) -> None:
        """Move every other vehicle one step (constant velocity or IDM)."""
        sc = self.scenario
        dt, length = sc.dt, sc.vehicle_length
        w = sc.lane_width
        old = self.vehicles.tolist()
        # every vehicle's leader among the others and the EV (the one rule, envs.lanes)
        everyone = np.vstack([self.vehicles, self.ev[None, :]])
        n = len(old)
        ox = np.where(np.eye(n, n + 1, dtype=bool), -np.inf, everyone[:, 0][None, :])
        oy = np.broadcast_to(everyone[:, 1], (n, n + 1))
        lead = leaders(everyone[:n, 0], everyone[:n, 1], ox, oy, w).tolist()
        rows = everyone.tolist()
        desired = self._desired_speeds.tolist()
        new = []
        for j, behaviour in enumerate(self.scene.behaviours):
            x, y, phi, v = old[j]
            if behaviour == "idm":
                leader = None if lead[j] < 0 else rows[lead[j]]
                gap = None if leader is None else leader[0] - x - length
                a = idm_acceleration(v, desired[j], gap, 0.0 if leader is None else leader[3])
                v_new = max(v + a * dt, 0.0)
                x += 0.5 * (v + v_new) * dt
                new.append([x, y, 0.0, v_new])
            else:
                new.append([x + v * math.cos(phi) * dt, y + v * math.sin(phi) * dt, phi, v])
        self.vehicles = np.array(new)

    # ------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode; ``options={"scene": TrafficScene}`` fixes this episode's scene.

        Raises:
            TypeError: ``options`` is not a dict, or ``scene`` not a TrafficScene.
            ValueError: an unknown option.
        """
        options = checked_options(options, ("scene",))
        super(LaneChangeEnv, self).reset(seed=seed)  # seeds np_random only
        if "scene" in options:
            if not isinstance(options["scene"], TrafficScene):
                raise TypeError("reset options['scene'] must be a TrafficScene")
            self.scene = options["scene"]
        elif self.traffic_ranges is not None:
            self.scene = self.traffic_ranges.sample(self.np_random)
        else:
            self.scene = self.base_scene
        self.scenario = self.scene.base
        self.ev = self.scenario.ev_initial_state
        self.vehicles = self.scene.initial_states()
        self._desired_speeds = self.vehicles[:, 3].copy()
        self.k = 0
        self._done = False
        if self._reward_model is not None:
            self._reward_model.reset(self.scenario, self.ev, self.tv, others=self.vehicles[1:])
        if self.render_mode == "human":
            self.render()
        info = self._info(scenario=self.scenario, scene=self.scene, action_clipped=False)
        return self._obs(), info

    def _reward_context(self) -> dict[str, Any]:
        return {"others": self.vehicles[1:].copy()}

    def render(self) -> np.ndarray | None:
        """Draw the scene, every vehicle included."""
        if self.render_mode is None:
            return super().render()
        if self._renderer is None:
            from drivestyle.envs.rendering import HighwayRenderer

            self._renderer = HighwayRenderer(self.render_mode)
        info = self._info()
        caption = (
            f"t = {info['t']:4.1f} s   v = {self.ev[3]:5.2f} m/s   min s_e = {info['s_e_min']:5.2f}"
        )
        return self._renderer.draw(
            self.scenario, self.ev, self.tv, caption, self.show_ellipse, others=self.vehicles[1:]
        )
