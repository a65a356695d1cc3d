"""Scenario parameters of the three-lane lane-change problem (paper §IV-A, docs/DESIGN.md §1).

A :class:`ScenarioConfig` holds every physical constant of one episode: road, vehicle
geometry, limits, initial states, the EV's goal, the sampling time and the safety
ellipse. It is frozen; vary it with :func:`dataclasses.replace` or
:meth:`ScenarioConfig.with_overrides`. :class:`ScenarioRanges` describes the random family
used by ``drivestyle/LaneChangeRandom-v0``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.units import ROAD_SPEED_MAX_MPS

__all__ = [
    "PAPER",
    "SCENARIOS",
    "ScenarioConfig",
    "ScenarioRanges",
    "get_scenario",
]


def _require(cond: bool, message: str) -> None:
    if not cond:
        raise ValueError(message)


def _finite(name: str, value: float) -> None:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise TypeError(f"{name} must be a number, got {type(value).__name__}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")


@dataclass(frozen=True)
class ScenarioConfig:
    """One lane-change scenario: the EV changes lane next to a constant-speed TV.

    The EV starts in ``ev_lane`` and heads for ``target_lane``; the TV keeps ``tv_lane``.
    Defaults are the paper's scenario (§IV-A, DESIGN §1). Lane 0 is the right-most lane
    (smallest y); x points along the road.
    """

    lane_width: float = 5.25
    """w_lane: lane width [m]."""
    n_lanes: int = 3
    """Number of lanes."""
    vehicle_length: float = 5.0
    """l_veh: vehicle length (both vehicles) [m]."""
    vehicle_width: float = 2.0
    """w_veh: vehicle width (both vehicles) [m]."""
    l_f: float = 2.0
    """Distance from the centre of mass to the front axle [m]."""
    l_r: float = 2.0
    """Distance from the centre of mass to the rear axle [m]."""
    phi_max: float = 0.05
    """Heading bound |φ| ≤ phi_max [rad]."""
    v_max: float = ROAD_SPEED_MAX_MPS
    """Speed bound 0 ≤ v ≤ v_max [m/s] (:data:`~drivestyle.envs.units.ROAD_SPEED_MAX_MPS`)."""
    a_min: float = -9.0
    """Lower acceleration bound [m/s²]."""
    a_max: float = 6.0
    """Upper acceleration bound [m/s²]."""
    delta_max: float = 0.05
    """Steering bound |δ| ≤ delta_max [rad]."""
    ev_lane: int = 0
    """EV's initial lane index."""
    target_lane: int = 1
    """EV's goal lane index."""
    ev_x: float = 80.0
    """EV's initial longitudinal position [m]."""
    ev_speed: float = 25.0
    """EV's initial speed [m/s]."""
    tv_lane: int = 1
    """TV's lane index (it keeps it)."""
    tv_gap: float = -20.0
    """Initial gap x_TV − x_EV [m] (negative: the TV starts behind the EV)."""
    tv_speed: float = 28.0
    """TV's constant speed [m/s]."""
    v_ref: float = 30.0
    """EV's reference (desired) speed [m/s]."""
    dt: float = 0.2
    """T_s: sampling time of the env and the SMPC [s]."""
    horizon_s: float = 6.0
    """Episode length [s]; the paper's 31 samples are t = 0 … 6.0 s."""
    l_a: float = 15.0
    """Semi-major axis of the safety ellipse around the TV [m]."""
    l_b: float = 3.0
    """Semi-minor axis of the safety ellipse around the TV [m]."""
    trigger_lambda: float = 1.82
    """λ: threshold of the elliptical index that triggers the reactive features (§III-B)."""
    check_start: bool = True
    """Reject starts inside the safety ellipse (recorded traffic disables the check)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.type == "bool":
                if not isinstance(value, bool):
                    raise TypeError(f"{f.name} must be a bool, got {value!r}")
            elif f.type in ("int",):
                if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
                    raise TypeError(f"{f.name} must be an integer, got {value!r}")
            else:
                _finite(f.name, value)
        positive = (
            "lane_width vehicle_length vehicle_width l_f l_r phi_max v_max a_max "
            "delta_max dt horizon_s l_a l_b trigger_lambda"
        )
        for name in positive.split():
            _require(getattr(self, name) > 0, f"{name} must be > 0, got {getattr(self, name)}")
        _require(self.a_min < 0, f"a_min must be < 0, got {self.a_min}")
        _require(self.n_lanes >= 2, f"n_lanes must be >= 2, got {self.n_lanes}")
        for name in ("ev_lane", "target_lane", "tv_lane"):
            lane = getattr(self, name)
            _require(
                0 <= lane < self.n_lanes,
                f"{name}={lane} is not a lane of a {self.n_lanes}-lane road "
                f"(0 … {self.n_lanes - 1})",
            )
        _require(
            self.ev_lane != self.target_lane,
            f"ev_lane and target_lane are both {self.ev_lane}: there is no lane change",
        )
        _require(self.vehicle_width < self.lane_width, "vehicle_width must be < lane_width")
        _require(
            0 <= self.ev_speed <= self.v_max,
            f"ev_speed={self.ev_speed} outside [0, v_max={self.v_max}] m/s",
        )
        _require(self.tv_speed >= 0, f"tv_speed must be >= 0, got {self.tv_speed}")
        _require(0 < self.v_ref <= self.v_max, f"v_ref={self.v_ref} outside (0, v_max]")
        _require(
            self.n_steps >= 2,
            f"horizon_s={self.horizon_s} gives {self.n_steps} steps of dt={self.dt}: need >= 2",
        )
        _require(
            abs(self.n_steps * self.dt - self.horizon_s) < 1e-6 * max(1.0, self.horizon_s),
            f"horizon_s={self.horizon_s} is not a whole number of steps of dt={self.dt}",
        )
        s_e0 = self.initial_elliptical_index
        _require(
            s_e0 > 1.0 or not self.check_start,
            "infeasible start: the EV starts inside the TV's safety ellipse "
            f"(s_e = {s_e0:.3f} <= 1; tv_gap={self.tv_gap} m, ev_lane={self.ev_lane}, "
            f"tv_lane={self.tv_lane}, l_a={self.l_a} m, l_b={self.l_b} m)",
        )

    # ------------------------------------------------------------------ derived
    @property
    def n_steps(self) -> int:
        """Number of control steps in the episode (samples − 1)."""
        return round(self.horizon_s / self.dt)

    @property
    def road_width(self) -> float:
        """Paved width n_lanes · w_lane [m]."""
        return self.n_lanes * self.lane_width

    @property
    def lane_centres(self) -> np.ndarray:
        """Lateral positions of the lane centres, shape (n_lanes,) [m]."""
        return (np.arange(self.n_lanes) + 0.5) * self.lane_width

    @property
    def y_ref(self) -> float:
        """Centre of the target lane [m]."""
        return float(self.lane_centres[self.target_lane])

    @property
    def y_bounds(self) -> tuple[float, float]:
        """Admissible EV centre y: road edges minus half a vehicle width (DESIGN §1 erratum) [m]."""
        half = self.vehicle_width / 2
        return (half, self.road_width - half)

    @property
    def ev_initial_state(self) -> np.ndarray:
        """ξ0 of the EV, [x, y, φ, v], shape (4,) [m, m, rad, m/s]."""
        return np.array([self.ev_x, self.lane_centres[self.ev_lane], 0.0, self.ev_speed])

    @property
    def tv_initial_state(self) -> np.ndarray:
        """Initial TV state [x, y, φ, v], shape (4,) [m, m, rad, m/s]."""
        return np.array(
            [self.ev_x + self.tv_gap, self.lane_centres[self.tv_lane], 0.0, self.tv_speed]
        )

    @property
    def initial_elliptical_index(self) -> float:
        """s_e at t = 0 (eq. 9)."""
        ev, tv = self.ev_initial_state, self.tv_initial_state
        return float(elliptical_index(ev[0] - tv[0], ev[1] - tv[1], self.l_a, self.l_b))

    def with_overrides(self, **overrides: float) -> ScenarioConfig:
        """A copy with some fields replaced; unknown names raise a clear error.

        Args:
            **overrides: field name → value.

        Returns:
            The new, validated scenario.
        """
        names = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise TypeError(
                f"unknown scenario parameter(s) {unknown}; valid names: {sorted(names)}"
            )
        # replace() types each keyword as its field (int lanes, bool check_start), which
        # **float cannot promise statically; __post_init__ validates the values
        changes: dict[str, Any] = dict(overrides)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        """Plain dict of the fields (for JSON)."""
        return dataclasses.asdict(self)


PAPER = ScenarioConfig()
"""The paper's scenario (§IV-A)."""

SCENARIOS: dict[str, ScenarioConfig] = {"paper": PAPER}
"""Named scenarios accepted by ``scenario=`` arguments."""


def get_scenario(name: str | ScenarioConfig) -> ScenarioConfig:
    """Look up a named scenario (a config passes through).

    Args:
        name: a key of :data:`SCENARIOS` or a :class:`ScenarioConfig`.

    Returns:
        The scenario.

    Raises:
        KeyError: unknown name (the message lists the known ones).
    """
    if isinstance(name, ScenarioConfig):
        return name
    try:
        return SCENARIOS[name]
    except (KeyError, TypeError):
        raise KeyError(f"unknown scenario {name!r}; known scenarios: {sorted(SCENARIOS)}") from None


@dataclass(frozen=True)
class ScenarioRanges:
    """Sampling ranges of the random scenario family (``drivestyle/LaneChangeRandom-v0``).

    Each continuous parameter is drawn uniformly from its (low, high) interval, the TV
    lane uniformly from ``tv_lanes``; every other field comes from ``base``. Draws whose
    start lies inside the safety ellipse are rejected and redrawn. The defaults keep the
    paper's geometry (TV in the target lane, behind or beside the EV and faster), so most
    draws are interactive.
    """

    ev_speed: tuple[float, float] = (22.0, 28.0)
    """EV initial speed [m/s]."""
    tv_speed: tuple[float, float] = (25.0, 32.0)
    """TV speed [m/s]."""
    tv_gap: tuple[float, float] = (-30.0, -10.0)
    """Initial gap x_TV − x_EV [m]."""
    tv_lanes: tuple[int, ...] = (1,)
    """Lanes the TV may drive in."""
    base: ScenarioConfig = field(default_factory=ScenarioConfig)
    """Scenario supplying every other parameter."""

    def __post_init__(self) -> None:
        for name in ("ev_speed", "tv_speed", "tv_gap"):
            low, high = getattr(self, name)
            _finite(f"{name}[0]", low)
            _finite(f"{name}[1]", high)
            _require(low <= high, f"{name} range must have low <= high, got ({low}, {high})")
        _require(len(self.tv_lanes) > 0, "tv_lanes must not be empty")
        for lane in self.tv_lanes:
            _require(
                0 <= lane < self.base.n_lanes,
                f"tv_lanes contains {lane}, not a lane of the base road",
            )

    def sample(self, rng: np.random.Generator, max_tries: int = 100) -> ScenarioConfig:
        """Draw one scenario.

        Args:
            rng: random generator (the env's ``np_random``).
            max_tries: redraws allowed for starts inside the safety ellipse.

        Returns:
            A feasible scenario.

        Raises:
            RuntimeError: no feasible draw within ``max_tries``.
        """
        for _ in range(max_tries):
            # drawn in this order (ev_speed, tv_speed, tv_gap, tv_lane): the seed's stream
            ev_speed = float(rng.uniform(*self.ev_speed))
            tv_speed = float(rng.uniform(*self.tv_speed))
            tv_gap = float(rng.uniform(*self.tv_gap))
            tv_lane = int(self.tv_lanes[rng.integers(len(self.tv_lanes))])
            try:
                return dataclasses.replace(
                    self.base, ev_speed=ev_speed, tv_speed=tv_speed, tv_gap=tv_gap, tv_lane=tv_lane
                )
            except ValueError:
                continue
        raise RuntimeError(
            f"no feasible scenario in {max_tries} draws from {self}; widen the ranges"
        )
