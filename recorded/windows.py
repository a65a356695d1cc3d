"""Every vehicle's windows without a lane change, as demonstrations of their kind (DESIGN §23).

``extract-episodes --all-vehicles`` writes, beside the lane changes
(:mod:`drivestyle.recorded.episodes`), every vehicle's windows of the same length
(``before_s + after_s``) in which it keeps its lane, so that a benchmark scores every
vehicle of a recording, not only the few that change lane. The rules:

- **Windows.** A track is cut into consecutive windows of ``before_s + after_s`` from its
  first sample; a window is kept when it lies inside the track, holds no change of lane of
  the vehicle (no crossing of a line), no gap longer than ``max_gap_s``, and does not
  overlap a lane-change window of the same vehicle ([t_c − ``before_s``, t_c + ``after_s``],
  usable or not): no motion is scored twice.
- **Frame.** As a lane change's, with the vehicle's own lane as the origin lane and the
  lane to its left as the "target" (+y), or the lane to its right, mirrored, when it drives
  in the leftmost lane: lane 0 = [0, w) is its lane. The interacting vehicles are a lane
  change's (:func:`~drivestyle.recorded.episodes.interacting_vehicles`).
- **Kind** (:func:`window_kind`, a label for the tables — no predictor reads it): from the
  own-lane leader at the window's start (the nearest vehicle ahead in the vehicle's lane
  within ``interaction_range_m``) over the *whole* window:

  - ``approaching``: it closes in on a slower leader — the mean closing speed is at least
    :data:`APPROACH_CLOSING_MPS` and the gap shrinks by at least :data:`APPROACH_GAP_DROP_M`;
  - ``car_following``: else a leader within :data:`FOLLOWING_HEADWAY_S` of time headway
    (bumper gap / own speed) on average;
  - ``lane_keeping``: else (no leader, or one far ahead).

- **Stop-and-go** (:func:`stop_and_go`, a flag across kinds): the leader (without one, the
  vehicle itself) slows below :data:`STOP_AND_GO_SPEED_MPS` and its speed swings by at
  least :data:`STOP_AND_GO_SWING_MPS` in the window: the traffic in which the braking of the
  car ahead should reach the car behind.
"""

from __future__ import annotations

import math

import numpy as np

from drivestyle.recorded.episodes import (
    Episode,
    _built_episode,
    _episode_fields,
    interacting_vehicles,
)
from drivestyle.recorded.extraction_config import ExtractionConfig
from drivestyle.recorded.kinds import EPISODE_KINDS, WINDOW_ID_SUFFIX
from drivestyle.recorded.lane_changes import _lanes
from drivestyle.recorded.resampling import _states_on
from drivestyle.recorded.tracks import Carriageway, Track

__all__ = [
    "APPROACH_CLOSING_MPS",
    "APPROACH_GAP_DROP_M",
    "FOLLOWING_HEADWAY_S",
    "STOP_AND_GO_SPEED_MPS",
    "STOP_AND_GO_SWING_MPS",
    "stop_and_go",
    "vehicle_windows",
    "window_kind",
]

APPROACH_CLOSING_MPS = 1.0
"""Least mean closing speed v − v_leader of an approach [m/s]: below it the gap holds within
a few metres over a window of 8 s, which is following."""
APPROACH_GAP_DROP_M = 5.0
"""Least shrinking of the gap over the window of an approach [m] (a vehicle length)."""
FOLLOWING_HEADWAY_S = 3.0
"""Largest mean time headway of car following [s]: beyond it drivers are found to choose
their speed freely (the usual 3–4 s free-flow threshold of car-following studies)."""
STOP_AND_GO_SPEED_MPS = 8.0
"""The leader's slowest speed in a stop-and-go window is below this [m/s] (≈ 30 km/h)."""
STOP_AND_GO_SWING_MPS = 3.0
"""Least range of the leader's speed in a stop-and-go window [m/s]: a wave, not a queue
moving at one slow speed."""


def window_kind(ev: np.ndarray, leader: np.ndarray | None, length: float) -> str:
    """The kind of a window without a lane change (module docstring).

    Args:
        ev: the vehicle's states over the window [x, y, φ, v], shape (n, 4) [m, m, rad, m/s].
        leader: its own-lane leader's states on the same samples, shape (n, 4), or None.
        length: the vehicle length the bumper gap subtracts [m].

    Returns:
        ``"approaching"``, ``"car_following"`` or ``"lane_keeping"``.
    """
    if leader is None:
        return "lane_keeping"
    gap = leader[:, 0] - ev[:, 0] - length
    closing = float(np.mean(ev[:, 3] - leader[:, 3]))
    if closing >= APPROACH_CLOSING_MPS and gap[0] - gap[-1] >= APPROACH_GAP_DROP_M:
        return "approaching"
    headway = float(np.mean(np.maximum(gap, 0.0) / np.maximum(ev[:, 3], 0.5)))
    return "car_following" if headway <= FOLLOWING_HEADWAY_S else "lane_keeping"


def stop_and_go(ev: np.ndarray, leader: np.ndarray | None) -> bool:
    """Whether a window is stop-and-go traffic (module docstring).

    Args:
        ev: the vehicle's states, shape (n, 4).
        leader: its own-lane leader's states, shape (n, 4), or None (then the vehicle's own
            speeds decide).

    Returns:
        True when the speed falls below :data:`STOP_AND_GO_SPEED_MPS` and swings by at least
        :data:`STOP_AND_GO_SWING_MPS`.
    """
    v = (ev if leader is None else leader)[:, 3]
    return bool(v.min() < STOP_AND_GO_SPEED_MPS and np.ptp(v) >= STOP_AND_GO_SWING_MPS)


def _free_of(spans: list[tuple[float, float]], start: float, stop: float) -> bool:
    return all(stop <= lo or start >= hi for lo, hi in spans)


def vehicle_windows(
    track: Track,
    road: Carriageway,
    lane_change_times: list[float],
    config: ExtractionConfig,
) -> list[Episode]:
    """Every window of a track without a lane change, as an :class:`Episode` of its kind.

    Args:
        track: one vehicle.
        road: its carriageway.
        lane_change_times: its lane changes' crossing times t_c [s] (their windows are
            left out).
        config: the extraction's numbers (window length, T_s, gaps, observed part).

    Returns:
        The windows in time order; usable ones hold a demonstration whose ``meta`` says its
        ``kind`` and ``stop_and_go``; unusable ones carry their reasons (an implausible
        demonstration, an interacting vehicle's gap).
    """
    span = config.before_s + config.after_s
    count = math.floor((track.t[-1] - track.t[0]) / span + 1e-9)
    lanes = _lanes(track, road)
    n_lanes = len(road.markings) - 1
    taken = [(t_c - config.before_s, t_c + config.after_s) for t_c in lane_change_times]
    steps = np.diff(track.t)
    episodes = []
    for i in range(count):
        start = float(track.t[0] + i * span)
        stop = start + span
        inside = (track.t >= start - 1e-9) & (track.t <= stop + 1e-9)
        held = lanes[inside]
        if held.size < 2 or np.any(held != held[0]) or not _free_of(taken, start, stop):
            continue
        between = inside[:-1] & inside[1:]
        if np.any(steps[between] > config.max_gap_s):
            continue
        a = int(held[0])
        if n_lanes < 2 or not 0 <= a < n_lanes:
            continue
        b = a + 1 if a + 1 < n_lanes else a - 1  # the lane the frame puts at +y
        mid = start + config.before_s
        eid = f"{road.name}_{track.vehicle_id}_{round(mid * 1000)}{WINDOW_ID_SUFFIX}"
        common = _episode_fields(track, road, eid, a, b, mid, start, stop)
        line = road.markings[max(a, b)]
        grid = np.round(start + np.arange(round(span / config.dt) + 1) * config.dt, 9)
        ev = _states_on(track, grid)[0]
        leaders = [
            other
            for role, other in interacting_vehicles(
                track, road, start, a, b, config.interaction_range_m
            )
            if role == "own_leader"
        ]
        leader = _states_on(leaders[0], grid)[0] if leaders else None
        kind = window_kind(ev, leader, track.length)
        assert kind in EPISODE_KINDS
        flagged = tuple(
            f"vehicle {track.vehicle_id} {p.text}" for p in track.problems if p.meets(start, stop)
        )
        extra = {"kind": kind, "stop_and_go": stop_and_go(ev, leader)}
        episodes.append(
            _built_episode(
                common | {"kind": kind}, track, road, start, stop, line, config, flagged, extra
            )
        )
    return episodes
