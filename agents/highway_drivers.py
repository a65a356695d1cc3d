"""Other drivers simulated by highway-env and recorded as tracks: IDM + MOBIL driver classes.

highway-env's :class:`~highway_env.vehicle.behavior.IDMVehicle` (highway-env 1.12) drives
with IDM for the speed and MOBIL for the lane changes; a :class:`DriverClass` is that
vehicle with other class constants. :func:`simulate_highway` puts the spawned vehicles
(:func:`draw_traffic`) on a straight road of several lanes and lets highway-env's own
models decide every acceleration and lane change, stepped at :data:`SIM_HZ` Hz; the
states are recorded at :data:`RECORD_HZ` Hz as a
:class:`~drivestyle.recorded.tracks.Recording` in the project's road frame
(:func:`project_frame`, :func:`highway_recording`), so they go through the same extraction
as recorded traffic (:func:`~drivestyle.recorded.episodes.extract_episodes`).

:data:`HIGHWAY_CLASSES` are four classes whose caution is known by construction: every
constant that sets how close a driver lets others come moves the same way from one class
to the next (:class:`DriverClass`). The out-of-class study
(:mod:`drivestyle.studies.out_of_class`) identifies them against that order.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.recorded.tracks import Carriageway, Recording, Track

__all__ = [
    "HIGHWAY_CLASSES",
    "LANE_WIDTH",
    "RECORD_HZ",
    "SIM_HZ",
    "DriverClass",
    "Spawn",
    "TrafficConfig",
    "draw_traffic",
    "highway_recording",
    "project_frame",
    "simulate_highway",
]

SIM_HZ = 15
"""highway-env's usual simulation frequency (its envs' ``simulation_frequency``) [Hz]."""
RECORD_HZ = 10
"""Recording rate of the simulated traffic (a drone dataset's; highD is 25, NGSIM 10) [Hz]."""
LANE_WIDTH = 4.0
"""highway-env's lane width (``StraightLane.DEFAULT_WIDTH``) [m]."""


@dataclass(frozen=True)
class DriverClass:
    """An IDM + MOBIL driver: highway-env's ``IDMVehicle`` with these class constants.

    Along :data:`HIGHWAY_CLASSES` (``caution`` 0 = least cautious) every margin moves the
    same way: a larger IDM time gap and standstill gap (the gap it keeps to a leader, and
    the gap it assumes a new follower wants), a larger politeness (it weighs the braking it
    causes others) and a smaller braking it may impose on the new follower (MOBIL's safety
    criterion: it accepts only roomier gaps). The minimum gain is not a margin and is
    equal in :data:`HIGHWAY_CLASSES`.
    """

    name: str
    caution: int
    """The known rank, 0 = least cautious."""
    time_wanted: float
    """IDM time gap T [s] (``TIME_WANTED``; highway-env's default 1.5)."""
    distance_wanted: float
    """IDM standstill gap s_0 [m] (``DISTANCE_WANTED``; default 10, centre to centre − 5 m)."""
    politeness: float
    """MOBIL politeness (``POLITENESS``; default 0)."""
    min_acc_gain: float
    """MOBIL minimum acceleration gain [m/s²] (``LANE_CHANGE_MIN_ACC_GAIN``; default 0.2)."""
    max_braking_imposed: float
    """MOBIL's safety limit on the new follower's deceleration [m/s²]
    (``LANE_CHANGE_MAX_BRAKING_IMPOSED``; default 2)."""
    share: float = 1.0
    """Relative frequency in the spawned traffic (:func:`draw_traffic`)."""

    def vehicle_type(self) -> type:
        """The ``IDMVehicle`` subclass with these constants (named after the class)."""
        from highway_env.vehicle.behavior import IDMVehicle

        return type(
            f"{self.name.capitalize()}IDMVehicle",
            (IDMVehicle,),
            {
                "TIME_WANTED": self.time_wanted,
                "DISTANCE_WANTED": self.distance_wanted,
                "POLITENESS": self.politeness,
                "LANE_CHANGE_MIN_ACC_GAIN": self.min_acc_gain,
                "LANE_CHANGE_MAX_BRAKING_IMPOSED": self.max_braking_imposed,
            },
        )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


HIGHWAY_CLASSES = (
    DriverClass("reckless", 0, 0.6, 4.0, 0.0, 0.1, 6.0, 1.0),
    DriverClass("assertive", 1, 1.0, 7.0, 0.1, 0.1, 4.0, 1.0),
    DriverClass("moderate", 2, 1.5, 10.0, 0.3, 0.1, 2.5, 2.0),
    DriverClass("cautious", 3, 2.0, 12.0, 0.5, 0.1, 1.5, 3.0),
)
"""Four classes in increasing caution. ``moderate`` is close to highway-env's own
``IDMVehicle`` (T = 1.5 s, s_0 = 10 m; its politeness 0 and braking limit 2 m/s² moved to
0.3 and 2.5 to keep the order strict). The minimum gain is the same for all: it is the
motivation to change, not a safety margin, and equal it keeps the classes' lane-change
rates comparable. The cautious classes change lanes less often, so they are spawned more
often (``share``)."""


@dataclass(frozen=True)
class Spawn:
    """One vehicle placed on the road at t = 0 (highway-env's frame: lane 0 leftmost)."""

    driver: str
    """A :class:`DriverClass` name."""
    lane: int
    """highway-env lane index (0 = the leftmost lane, y grows to the right)."""
    x: float
    """Longitudinal position [m]."""
    speed: float
    """Initial speed [m/s]."""
    target_speed: float
    """IDM desired speed [m/s]."""


@dataclass(frozen=True)
class TrafficConfig:
    """The simulated road and its traffic (:func:`draw_traffic`, :func:`simulate_highway`)."""

    lanes: int = 3
    vehicles_per_lane: int = 5
    spacing_m: float = 60.0
    """Mean distance between consecutive vehicles of a lane at t = 0 (± 30 %) [m]."""
    speed_range: tuple[float, float] = (20.0, 28.0)
    """Initial speeds, uniform [m/s]."""
    target_speed_range: tuple[float, float] = (18.0, 36.0)
    """IDM desired speeds, uniform: their spread is what makes MOBIL change lanes [m/s]."""
    speed_limit: float = 40.0
    """The lanes' speed limit (caps the desired speed) [m/s]."""
    duration_s: float = 60.0
    """Simulated time [s]."""

    def __post_init__(self) -> None:
        if not (isinstance(self.lanes, int) and self.lanes >= 2):
            raise ValueError(f"lanes must be an integer >= 2, got {self.lanes!r}")
        if not (isinstance(self.vehicles_per_lane, int) and self.vehicles_per_lane >= 1):
            raise ValueError(
                f"vehicles_per_lane must be an integer >= 1, got {self.vehicles_per_lane!r}"
            )
        if not self.spacing_m >= 10.0:
            raise ValueError(
                f"spacing_m must be >= 10 m (vehicles 5 m long), got {self.spacing_m!r}"
            )
        for name in ("speed_range", "target_speed_range"):
            lo, hi = getattr(self, name)
            if not (0 < lo <= hi <= self.speed_limit):
                raise ValueError(f"{name} must satisfy 0 < lo <= hi <= speed_limit, got {(lo, hi)}")
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be > 0 s, got {self.duration_s!r}")


def draw_traffic(
    config: TrafficConfig, seed: int, classes: Sequence[DriverClass] = HIGHWAY_CLASSES
) -> list[Spawn]:
    """Vehicles for one run: each lane a queue, every vehicle's class drawn by its ``share``.

    Returns:
        ``lanes × vehicles_per_lane`` spawns (lane by lane, front last), deterministic in
        ``seed``.
    """
    if not classes or min(c.share for c in classes) <= 0:
        raise ValueError("draw_traffic needs at least one class, every share > 0")
    rng = np.random.default_rng(seed)
    n = config.lanes * config.vehicles_per_lane
    share = np.array([c.share for c in classes], float)
    names = [classes[i].name for i in rng.choice(len(classes), n, p=share / share.sum())]
    out: list[Spawn] = []
    for lane in range(config.lanes):
        x = 0.0
        for _ in range(config.vehicles_per_lane):
            x += config.spacing_m * float(rng.uniform(0.7, 1.3))
            out.append(Spawn(names[len(out)], lane, x, float(rng.uniform(*config.speed_range)),
                             float(rng.uniform(*config.target_speed_range))))  # fmt: skip
    return out


def project_frame(
    y: np.ndarray, heading: np.ndarray, lanes: int, lane_width: float = LANE_WIDTH
) -> tuple[np.ndarray, np.ndarray, tuple[float, ...]]:
    """highway-env's lateral axis to the project's road frame (``recorded/tracks.py``).

    highway-env's y grows to the right of travel with lane i's centre at y = i·w (lane 0
    leftmost); the project's grows to the left with lane 0 the rightmost. So
    y' = (lanes − ½)·w − y and φ' = −φ, and the lane lines are at 0, w, …, lanes·w:
    highway-env's lane i becomes the project's lane ``lanes − 1 − i``.

    Args:
        y: highway-env lateral positions, any shape [m].
        heading: highway-env headings, same shape [rad].
        lanes: number of lanes.
        lane_width: w [m].

    Returns:
        (y', φ', markings).
    """
    y_new = (lanes - 0.5) * lane_width - np.asarray(y, float)
    markings = tuple(float(k * lane_width) for k in range(lanes + 1))
    return y_new, -np.asarray(heading, float), markings


def highway_recording(
    samples: dict[str, np.ndarray], lanes: int, name: str = "highway-env"
) -> Recording:
    """Recorded highway-env states as a :class:`~drivestyle.recorded.tracks.Recording`.

    Args:
        samples: vehicle id → rows [t, x, y, v, φ] in highway-env's frame, shape (n, 5)
            [s, m, m, m/s, rad].
        lanes: number of lanes (all 4 m wide, :data:`LANE_WIDTH`).
        name: the carriageway's and the source's name.

    Returns:
        One carriageway in the project's frame (:func:`project_frame`).
    """
    tracks = []
    markings: tuple[float, ...] = ()
    for vid, rows in samples.items():
        y, phi, markings = project_frame(rows[:, 2], rows[:, 4], lanes)
        tracks.append(Track(vid, rows[:, 0], rows[:, 1], y, np.arange(rows.shape[0]),
                            v=rows[:, 3], heading=phi, source=name))  # fmt: skip
    if not markings:
        markings = project_frame(np.zeros(1), np.zeros(1), lanes)[2]
    return Recording(name, (Carriageway(name, markings, tuple(tracks)),),
                     {"format": "highway-env", "rate_hz": RECORD_HZ})  # fmt: skip


def simulate_highway(
    spawns: Sequence[Spawn],
    config: TrafficConfig,
    classes: Sequence[DriverClass] = HIGHWAY_CLASSES,
    name: str = "highway-env",
) -> tuple[Recording, dict[str, str]]:
    """Simulate highway-env traffic and record it at :data:`RECORD_HZ` Hz.

    A straight road of ``config.lanes`` lanes (``RoadNetwork.straight_road_network``), the
    spawned ``IDMVehicle`` subclasses (:meth:`DriverClass.vehicle_type`), stepped with
    ``road.act(); road.step(1 / SIM_HZ)`` — highway-env's own models decide every
    acceleration and lane change (collisions handled by highway-env). Each vehicle's
    [x, y, v, φ] at the 10 Hz times is interpolated linearly between the two 15 Hz
    states around it (every 0.2 s the two grids coincide exactly).

    Args:
        spawns: the vehicles (:func:`draw_traffic`).
        config: the road and the duration.
        classes: the driver classes the spawns name.
        name: the recording's name (episode ids start with it).

    Returns:
        (the recording in the project's frame, vehicle id → driver class name).

    Raises:
        ValueError: a spawn names an unknown class or a lane the road does not have.
    """
    from highway_env.road.road import Road, RoadNetwork

    types = {c.name: c.vehicle_type() for c in classes}
    for s in spawns:
        if s.driver not in types:
            raise ValueError(
                f"spawn names the unknown driver class {s.driver!r}; known: {sorted(types)}"
            )
        if not 0 <= s.lane < config.lanes:
            raise ValueError(f"spawn lane {s.lane} is not a lane of the {config.lanes}-lane road")
    length = max([s.x for s in spawns], default=0.0) + 2.0 * config.speed_limit * config.duration_s
    net = RoadNetwork.straight_road_network(lanes=config.lanes, length=length,
                                            speed_limit=config.speed_limit)  # fmt: skip
    road = Road(network=net, np_random=np.random.RandomState(0), record_history=False)
    vehicles = []
    for s in spawns:
        lane = net.get_lane(("0", "1", s.lane))
        v = types[s.driver](road, lane.position(s.x, 0.0), lane.heading_at(s.x), speed=s.speed,
                            target_speed=s.target_speed)  # fmt: skip
        road.vehicles.append(v)
        vehicles.append(v)
    steps = round(config.duration_s * SIM_HZ)
    states = np.empty((steps + 1, len(vehicles), 4))
    for k in range(steps + 1):
        for j, v in enumerate(vehicles):
            states[k, j] = (v.position[0], v.position[1], v.speed, v.heading)
        if k < steps:
            road.act()
            road.step(1.0 / SIM_HZ)
    t_sim = np.arange(steps + 1) / SIM_HZ
    t_rec = np.round(np.arange(math.floor(config.duration_s * RECORD_HZ + 1e-9) + 1) / RECORD_HZ, 9)
    samples = {}
    for j in range(len(vehicles)):
        cols = [np.interp(t_rec, t_sim, states[:, j, c]) for c in range(4)]
        samples[str(j)] = np.column_stack([t_rec, *cols])
    classes_of = {str(j): s.driver for j, s in enumerate(spawns)}
    return highway_recording(samples, config.lanes, name), classes_of
