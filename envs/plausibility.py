"""A demonstration's physics checked against the model every learner assumes (DESIGN §7).

:func:`check_plausible` refuses, and :func:`plausibility_problems` lists, what cannot be a
car on a road in the stated frame and units: not one lane change to +y, backward driving,
positions that disagree with the speeds, lateral speed beyond what the heading allows,
steps beyond a vehicle's reach of speed and acceleration (:func:`step_problems`, which
the online tracker also calls sample by sample), lanes that do not fit the data, a vehicle
overlapping the EV. Its thresholds (the constants below, each saying why it has its
value) are deliberately generous: the SMPC's demonstrations sit far inside them and every
recorded NGSIM and CATS episode passes; what they refuse cannot be a car on a road in the
stated frame and units. The names are also importable from
:mod:`drivestyle.envs.demonstration`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from drivestyle.envs.safety import rectangles_overlap, vehicle_corners
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.envs.units import speed_unit_hint

if TYPE_CHECKING:
    from drivestyle.envs.demonstration import Demonstration

__all__ = [
    "ACCEL_MAX_MPS2",
    "BACKWARD_RATE_MPS",
    "BACKWARD_SPEED_MPS",
    "HEADING_FACTOR",
    "LANE_TOLERANCE",
    "LANE_WIDTH_RANGE_M",
    "LATERAL_NOISE_MPS",
    "OVERLAP_SHRINK",
    "SPEED_CHECK_MIN_M",
    "SPEED_RATIO_MAX",
    "SPEED_TOLERANCE_MPS",
    "STANDING_DRIFT_M",
    "STANDING_SPEED_MPS",
    "check_plausible",
    "plausibility_problems",
    "step_problems",
]

LANE_WIDTH_RANGE_M = (2.0, 7.0)
"""Lane widths a road can have [m]. Real lanes are 2.5–4 m (NGSIM 3.4–3.7, CATS 3.95), the
paper's are 5.25 m; 12 ft = 3.66 m lanes read in feet give 12.1 — the usual unit slip."""
BACKWARD_SPEED_MPS = 0.1
"""A speed v below −this is driving backwards [m/s] (a little noise around standstill passes)."""
BACKWARD_RATE_MPS = 0.5
"""x falling faster than this between two samples is driving backwards [m/s]: generous
for position noise of a (nearly) standing car, far from any real reversing manoeuvre."""
SPEED_RATIO_MAX = 2.5
"""The distance x advances and the distance the speeds v add up to may differ by at most
this factor (either way). SMPC and recorded data agree within 1 % (ẋ = v cos(φ + β) with
small angles); feet against m/s is 3.28, time in the wrong unit 10."""
SPEED_CHECK_MIN_M = 5.0
"""The position/speed comparison is made when either distance reaches this [m] (a standing
EV has nothing to compare)."""
HEADING_FACTOR = 6.0
"""Lateral speed allowed per step: |ẏ| ≤ HEADING_FACTOR · v · tan(φ_max) + LATERAL_NOISE_MPS.
The model bounds the heading by φ_max (0.05 rad in the paper, ``ScenarioConfig.phi_max``,
the SMPC's |φ| ≤ φ_max) and the slip angle adds at most half of δ_max, so the SMPC's
demonstrations stay below 1.5 × v tan(φ_max). Recorded drivers turn harder than the model:
up to 0.22 rad (4.2 × v tan(0.05); NGSIM I-80 and CATS episodes at 4–6 m/s), so the bound
is 6 × (≈ 0.3 rad, 17°), 1.4 × the hardest recorded lane change."""
LATERAL_NOISE_MPS = 0.25
"""Allowance for lateral position noise at any speed [m/s] (see :data:`HEADING_FACTOR`)."""
STANDING_SPEED_MPS = 0.5
"""Below this speed the EV counts as standing [m/s]: it cannot move sideways."""
STANDING_DRIFT_M = 0.3
"""Lateral displacement allowed in total over the samples where the EV stands [m]."""
SPEED_TOLERANCE_MPS = 1.0
"""How far a speed may exceed the scenario's v_max (by default and for every extracted
episode :data:`~drivestyle.envs.units.ROAD_SPEED_MAX_MPS`, 70 m/s, the fastest a road
vehicle drives) [m/s]: the speed a step's positions imply carries position noise (0.1 m per
sample at T_s = 0.2 s). SMPC demonstrations stay at or below v_max, recorded ones below
22 m/s."""
ACCEL_MAX_MPS2 = 25.0
"""Largest acceleration (magnitude of the change of the velocity the positions imply
between consecutive steps, any direction) a vehicle may show [m/s²]. Tyres on a road give
at most ≈ 1.2 g (12 m/s²) and the model bounds a to [−9, 6]; the hardest seen are the
SMPC's 9 m/s² braking (traffic scenes), 7.7 after the RTS tracker with 1 m of noise, 4.2
for a recorded NGSIM or CATS EV and 12.2 for a noisy recorded neighbour. 25 (≈ 2.5 g)
leaves twice that for noise; a position jump of 1 m in one 0.2 s step already implies
±25 m/s², the tester's 50 m jump 1250."""
OVERLAP_SHRINK = 0.9
"""Two vehicles overlap when their rectangles shrunk to this fraction of the scenario's
length and width intersect (recorded positions and sizes are approximate)."""
LANE_TOLERANCE = 0.25
"""How far (a fraction of the lane width) the EV may be outside its start lane at t = 0,
or beyond its target lane's far edge or its start lane's near edge at any time. Recorded
EVs start 0.22–1.10 lane widths from the start lane's near edge and reach at most 1.92."""


def _fmt(value: float) -> str:
    """A number for a message: 3 significant digits, no float noise (2.4000000000000004)."""
    return f"{value:.3g}"


def _lane_of(y: float, w: float) -> int:
    return math.floor(y / w)


def plausibility_problems(demo: Demonstration) -> list[str]:
    """What makes a demonstration physically impossible or inconsistent with its metadata.

    The checks, in order (module docstring; each threshold is a module constant that says
    why it has its value):

    1. the scenario's lane width is a road's (:data:`LANE_WIDTH_RANGE_M`; feet give 12 m);
    2. the scenario is one lane change to +y (``target_lane = ev_lane + 1``), the only
       manoeuvre the features, the SMPC and the library model;
    3. the EV drives forward: no speed below −:data:`BACKWARD_SPEED_MPS`, no x falling
       faster than :data:`BACKWARD_RATE_MPS`;
    4. positions and speeds agree: the distance x advances and ∫v dt differ by at most
       :data:`SPEED_RATIO_MAX` (positions in feet, speeds in km/h, times rescaled);
    5. no lateral motion while standing (:data:`STANDING_SPEED_MPS`,
       :data:`STANDING_DRIFT_M`) and no lateral speed beyond what the heading allows
       (:data:`HEADING_FACTOR`, :data:`LATERAL_NOISE_MPS`);
    6. no vehicle (TV or traffic) overlaps the EV at any time (:data:`OVERLAP_SHRINK`),
       and every step of every vehicle is within a vehicle's reach (:func:`step_problems`):
       no speed, stated or implied by two consecutive positions, beyond the scenario's
       v_max (+ :data:`SPEED_TOLERANCE_MPS`), no implied acceleration beyond
       :data:`ACCEL_MAX_MPS2`;
    7. the lanes fit the data: the EV starts in ``ev_lane`` (:data:`LANE_TOLERANCE`), the
       TV — which keeps its lane — drives in ``tv_lane`` (its median y, no tolerance);
    8. the data shows one lane change to +y: the EV does not end up more than half a lane
       towards −y (a rightward change), nor go past the target lane's far edge (a
       two-lane change) or its start lane's near edge, by more than
       :data:`LANE_TOLERANCE` lanes.

    Only the first failing check of 3–6 (its speeds and accelerations; an overlap always)
    and of 7–8 is reported (a later one would repeat it).

    Args:
        demo: the demonstration (with ``meta["scenario"]``).

    Returns:
        One-line messages, each naming what is wrong and what to fix; empty when plausible.

    Raises:
        DemonstrationError: no (valid) scenario in the metadata.
    """
    sc = demo.scenario
    problems: list[str] = []
    w = sc.lane_width
    lo, hi = LANE_WIDTH_RANGE_M
    if not lo <= w <= hi:
        hint = (
            "positions in feet? (NGSIM's unit: its 12 ft lanes read as 12.1); convert "
            "positions to metres and speeds to m/s"
            if w > hi
            else "positions in another unit?"
        )
        problems.append(
            f"lanes {_fmt(w)} m wide (scenario lane_width): a road's lanes are "
            f"{lo:g}–{hi:g} m wide; {hint}"
        )
        return problems  # every later check would repeat the unit error
    if sc.target_lane != sc.ev_lane + 1:
        kind = (
            "towards −y (rightward)"
            if sc.target_lane < sc.ev_lane
            else f"across {sc.target_lane - sc.ev_lane} lanes"
        )
        problems.append(
            f"the scenario's lane change goes from lane {sc.ev_lane} to lane "
            f"{sc.target_lane}, {kind}; the model is one lane change to +y (target_lane = "
            "ev_lane + 1): mirror y (and the lanes) of a rightward change, split a multi-lane one"
        )
    t, x, y, v = demo.t, demo.ev[:, 0], demo.ev[:, 1], demo.ev[:, 3]
    dt = np.diff(t)
    x_rate, y_rate = np.diff(x) / dt, np.diff(y) / dt
    speed = np.maximum(np.abs(v[:-1]), np.abs(v[1:]))  # the larger end: generous
    states = _states(demo.ev, demo.vehicles)
    overlap = _overlap(demo.t, states, sc, 0)
    problems.extend([overlap] if overlap else [])
    problems.extend(
        _motion_problems(t, x, v, x_rate)
        or _lateral_problems(t, y_rate, speed, sc)
        or _kinematic_problems(demo.t, states, sc, 0)
    )
    problems.extend(_lane_problems(demo))
    return problems


def _motion_problems(t: np.ndarray, x: np.ndarray, v: np.ndarray, x_rate: np.ndarray) -> list[str]:
    """Backward driving and positions that disagree with the speeds (checks 3–4)."""
    if v.min() < -BACKWARD_SPEED_MPS:
        k = int(np.argmin(v))
        return [
            f"the EV drives backwards: speed v = {_fmt(v[k])} m/s at t = {_fmt(t[k])} s; the "
            "model's EV drives forward along +x (v ≥ 0): mirror x if the data runs along −x"
        ]
    if x_rate.min() < -BACKWARD_RATE_MPS:
        k = int(np.argmin(x_rate))
        return [
            f"the EV drives backwards: x falls from {_fmt(x[k])} to {_fmt(x[k + 1])} m between "
            f"t = {_fmt(t[k])} and {_fmt(t[k + 1])} s; the model's EV drives forward along +x: "
            "mirror x if the data runs along −x"
        ]
    advance = float(x[-1] - x[0])
    travelled = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)))
    if max(advance, travelled) >= SPEED_CHECK_MIN_M:
        ratio = advance / travelled if travelled > 0 else math.inf
        if not 1 / SPEED_RATIO_MAX <= ratio <= SPEED_RATIO_MAX:
            return [
                f"positions and speeds disagree: the EV's x advances {_fmt(advance)} m in "
                f"{_fmt(float(t[-1] - t[0]))} s while its speeds v add up to {_fmt(travelled)} m "
                f"({_fmt(ratio)}×); use SI units throughout (m, m/s, s: positions in feet are "
                "3.28×) and speeds along the path"
            ]
    return []


def _lateral_problems(
    t: np.ndarray, y_rate: np.ndarray, speed: np.ndarray, sc: ScenarioConfig
) -> list[str]:
    """Lateral motion without speed and beyond the heading bound (check 5)."""
    standing = speed < STANDING_SPEED_MPS
    drift = float(np.sum(np.abs(y_rate[standing]) * np.diff(t)[standing]))
    allowed = HEADING_FACTOR * speed * math.tan(sc.phi_max) + LATERAL_NOISE_MPS
    over = np.abs(y_rate) > allowed
    if drift > STANDING_DRIFT_M or (over & standing).any():
        k = int(np.argmax(np.abs(y_rate) * standing))
        return [
            f"lateral motion without speed: the EV moves sideways {_fmt(drift)} m while its "
            f"speed is below {STANDING_SPEED_MPS:g} m/s (at t = {_fmt(t[k])} s: "
            f"|ẏ| = {_fmt(abs(y_rate[k]))} m/s, v = {_fmt(speed[k])} m/s); a car cannot "
            "move sideways standing: check y and v"
        ]
    if over.any():
        k = int(np.argmax(np.abs(y_rate) - allowed))
        heading = math.atan2(abs(y_rate[k]), speed[k])
        return [
            f"lateral speed beyond what the heading allows: |ẏ| = {_fmt(abs(y_rate[k]))} m/s at "
            f"v = {_fmt(speed[k])} m/s (t = {_fmt(t[k])} s) needs a heading of "
            f"{_fmt(heading)} rad; the model bounds it by phi_max = {_fmt(sc.phi_max)} rad and "
            f"refuses beyond {HEADING_FACTOR:g}× v·tan(phi_max) + {LATERAL_NOISE_MPS:g} m/s "
            "(y in another unit than x, or times too short?)"
        ]
    return []


def _who(j: int) -> str:
    """The name of vehicle j of ``[EV, TV, traffic …]`` in a message."""
    return ("the EV", "the TV")[j] if j < 2 else f"traffic vehicle {j - 2}"


def step_problems(
    t: np.ndarray,
    ev: np.ndarray,
    vehicles: np.ndarray,
    scenario: ScenarioConfig,
    first: int = 0,
) -> list[str]:
    """What no vehicle can do in one step: a speed, jump, acceleration or overlap (check 6).

    Per sample and vehicle (the EV, then ``vehicles``): the stated speed v and the speed
    two consecutive positions imply must not exceed ``scenario.v_max`` +
    :data:`SPEED_TOLERANCE_MPS`; the change of the implied velocity between consecutive
    steps must not exceed :data:`ACCEL_MAX_MPS2`; no vehicle may overlap the EV
    (rectangles shrunk by :data:`OVERLAP_SHRINK`). Shared by :func:`plausibility_problems`
    and the online tracker (:class:`drivestyle.irl.identification.online.StyleTracker`), which
    checks each new sample with the two before it.

    Args:
        t: sample times, shape (n,) [s], strictly increasing.
        ev: EV states [x, y, φ, v], shape (n, 4).
        vehicles: the other vehicles' states, TV first, shape (n, m, 4).
        scenario: the scenario (v_max, vehicle size).
        first: the index of sample 0 in the messages (a window of a longer stream).

    Returns:
        At most one message per kind (overlap, speed, acceleration), each naming the
        vehicle, the sample's index and time, and the value.
    """
    t = np.asarray(t, float)
    states = _states(ev, vehicles)
    overlap = _overlap(t, states, scenario, first)
    return [*([overlap] if overlap else []), *_kinematic_problems(t, states, scenario, first)]


def _states(ev: np.ndarray, vehicles: np.ndarray) -> np.ndarray:
    """The EV and the other vehicles as one array, EV first: shape (n, 1 + m, 4)."""
    return np.concatenate([np.asarray(ev, float)[:, None, :], np.asarray(vehicles, float)], 1)


def _kinematic_problems(
    t: np.ndarray, states: np.ndarray, scenario: ScenarioConfig, first: int
) -> list[str]:
    """Speeds and accelerations beyond a vehicle's reach (:func:`step_problems`)."""
    problems: list[str] = []
    v_limit = scenario.v_max + SPEED_TOLERANCE_MPS
    limit_text = (
        f"the model's speed bound v_max = {_fmt(scenario.v_max)} m/s (scenario) is the most a "
        "vehicle drives"
    )
    v = np.abs(states[:, :, 3])
    if v.max() > v_limit:
        k, j = (int(i) for i in np.unravel_index(int(np.argmax(v)), v.shape))
        problems.append(
            f"{_who(j)}'s speed v = {_fmt(v[k, j])} m/s at t = {_fmt(t[k])} s (sample "
            f"{first + k}): {limit_text}; {speed_unit_hint(float(v[k, j]), 'speeds')}"
        )
    if t.size >= 2:
        dt = np.diff(t)
        vel = np.diff(states[:, :, :2], axis=0) / dt[:, None, None]  # (n−1, m+1, 2)
        implied = np.hypot(vel[..., 0], vel[..., 1])
        if not problems and implied.max() > v_limit:
            k, j = (int(i) for i in np.unravel_index(int(np.argmax(implied)), implied.shape))
            jump = implied[k, j] * dt[k]
            # a fleet beyond the bound is refused by the readers (recorded.track_checks): one
            # step beyond it is a jump, one vehicle at that speed throughout a unit slip
            steady = bool(np.median(implied[:, j]) > v_limit)
            cause = (
                speed_unit_hint(float(implied[k, j]), "positions")
                if steady
                else "a position jump in the data?"
            )
            problems.append(
                f"{_who(j)} moves {_fmt(jump)} m between t = {_fmt(t[k])} and "
                f"{_fmt(t[k + 1])} s (samples {first + k} and {first + k + 1}): "
                f"{_fmt(implied[k, j])} m/s, but {limit_text}; {cause}"
            )
        if t.size >= 3:
            # between the midpoints of consecutive steps (uneven steps allowed)
            span = (t[2:] - t[:-2]) / 2
            dvel = np.diff(vel, axis=0)
            accel = np.hypot(dvel[..., 0], dvel[..., 1]) / span[:, None]  # (n−2, m+1)
            if accel.max() > ACCEL_MAX_MPS2:
                k, j = (int(i) for i in np.unravel_index(int(np.argmax(accel)), accel.shape))
                problems.append(
                    f"{_who(j)}'s positions imply an acceleration of {_fmt(accel[k, j])} m/s² "
                    f"at t = {_fmt(t[k + 1])} s (sample {first + k + 1}): no vehicle "
                    f"accelerates or brakes beyond {ACCEL_MAX_MPS2:g} m/s² (≈ 2.5 g); a "
                    "position jump or a wrong time stamp?"
                )
    return problems


def _overlap(t: np.ndarray, states: np.ndarray, sc: ScenarioConfig, first: int) -> str | None:
    """The first sample at which a vehicle overlaps the EV (``states[:, 0]``), said."""
    length, width = OVERLAP_SHRINK * sc.vehicle_length, OVERLAP_SHRINK * sc.vehicle_width
    d = states[:, 1:, :2] - states[:, :1, :2]
    # farther apart than the rectangles' diagonal they cannot touch: test only the rest
    near = np.argwhere(np.hypot(d[..., 0], d[..., 1]) <= math.hypot(length, width))
    for k, i in near:
        ev = vehicle_corners(states[k, 0], length, width)
        if rectangles_overlap(ev, vehicle_corners(states[k, i + 1], length, width)):
            return (
                f"{_who(i + 1)} overlaps the EV at t = {_fmt(t[k])} s (sample {first + k}; "
                f"Δx = {_fmt(d[k, i, 0])} m, Δy = {_fmt(d[k, i, 1])} m; vehicles "
                f"{_fmt(sc.vehicle_length)} × {_fmt(sc.vehicle_width)} m): two cars cannot "
                "share a place; check the positions"
            )
    return None


def _lane_problems(demo: Demonstration) -> list[str]:
    """Lanes that do not fit the data, rightward and two-lane changes (checks 7–8).

    The hints name what set the scenario's lanes: ``meta["lanes_from"]`` where the
    extraction set them from a road's lane lines (the user wrote lines, not metadata),
    else the demonstration's metadata.
    """
    sc = demo.scenario
    w, tol = sc.lane_width, LANE_TOLERANCE * sc.lane_width
    lanes_from = demo.meta.get("lanes_from")
    if lanes_from:
        set_by = f"lane_width, ev_lane and tv_lane come from {lanes_from}"
        ev_hint = f"{set_by}: are they the road's, road edges included, in metres?"
        tv_hint = (
            f"{set_by} and the TV's lane at the window's start: the TV changes lane or "
            "drives on a line in the window, or the lines are not the road's"
        )
        narrow = f"or {lanes_from} are too narrow"
    else:
        ev_hint = "wrong lane_width or ev_lane in the metadata, or y in another frame or unit?"
        tv_hint = "wrong lane_width or tv_lane in the metadata, or y in another frame or unit?"
        narrow = "or the lane_width in the metadata is too small"
    y = demo.ev[:, 1]
    fit = f"the lateral positions do not fit lanes {_fmt(w)} m wide (scenario lane_width)"
    start_lo, start_hi = sc.ev_lane * w, (sc.ev_lane + 1) * w
    if not start_lo - tol <= y[0] <= start_hi + tol:
        return [
            f"{fit}: the EV starts at y = {_fmt(y[0])} m, in lane {_lane_of(y[0], w)}, not in "
            f"its lane {sc.ev_lane} [{_fmt(start_lo)}, {_fmt(start_hi)}) m; {ev_hint}"
        ]
    tv_y = float(np.median(demo.tv[:, 1]))
    tv_lo, tv_hi = sc.tv_lane * w, (sc.tv_lane + 1) * w
    if not tv_lo <= tv_y <= tv_hi:
        return [
            f"{fit}: the TV, which keeps lane {sc.tv_lane} [{_fmt(tv_lo)}, {_fmt(tv_hi)}) m, "
            f"drives at y ≈ {_fmt(tv_y)} m (median), in lane {_lane_of(tv_y, w)}; {tv_hint}"
        ]
    if y[-1] - y[0] < -0.5 * w:
        return [
            f"the EV changes lane towards −y (rightward: y goes from {_fmt(y[0])} to "
            f"{_fmt(y[-1])} m); the model is one lane change to +y: mirror y (y → −y, "
            "and the lanes) before learning"
        ]
    far = (sc.target_lane + 1) * w
    if y.max() > far + tol:
        k = int(np.argmax(y))
        return [
            f"the EV reaches y = {_fmt(y[k])} m at t = {_fmt(demo.t[k])} s, lane "
            f"{_lane_of(y[k], w)}, past its target lane {sc.target_lane} "
            f"[{_fmt(far - w)}, {_fmt(far)}) m: a two-lane change? the model is one lane "
            f"change to +y ({narrow})"
        ]
    if y.min() < start_lo - tol:
        k = int(np.argmin(y))
        return [
            f"the EV reaches y = {_fmt(y[k])} m at t = {_fmt(demo.t[k])} s, below its lane "
            f"{sc.ev_lane} [{_fmt(start_lo)}, {_fmt(start_hi)}) m, away from the target lane; "
            "the model is one lane change to +y"
        ]
    return []


def check_plausible(demo: Demonstration) -> None:
    """Refuse a physically impossible or inconsistent demonstration.

    Args:
        demo: the demonstration (with ``meta["scenario"]``).

    Raises:
        DemonstrationError: the first problem of :func:`plausibility_problems` (the
            message counts any further ones).
    """
    from drivestyle.envs.demonstration import DemonstrationError  # it imports this module

    problems = plausibility_problems(demo)
    if problems:
        more = f" (and {len(problems) - 1} more problem(s))" if len(problems) > 1 else ""
        raise DemonstrationError(f"implausible demonstration: {problems[0]}{more}")
