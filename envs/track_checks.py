"""Every reader's tracks checked by their physics: the rules' one home.

Each reader of :mod:`drivestyle.envs.readers` (the generic table, raw NGSIM, levelX,
INTERACTION, the shipped samples) ends with :func:`check_recording`; no reader keeps a
copy of a rule. A rule has two outcomes:

- **the file** is refused (:class:`~drivestyle.envs.tracks.TrackError`, one line naming
  the file, the column and the value with the likely unit) where most of its vehicles
  break the rule: that is a unit or a convention of the file, not a vehicle;
- **a vehicle** that breaks it alone is kept with the reason in
  :attr:`~drivestyle.envs.tracks.Track.problems`: its lane changes are listed unusable in
  ``episodes.csv`` with it, and a warning on stderr names the vehicles.

The rules (their bounds are :mod:`drivestyle.envs.units`' and this module's constants):

- **sampling**: a vehicle's median time step is at most
  :data:`~drivestyle.envs.units.SAMPLE_PERIOD_MAX_S` (a step of 100 is a time in
  milliseconds: its cars drive at 0.025 m/s);
- **speed**: a vehicle's median speed — the recorded one and the one its positions imply —
  is at most :data:`~drivestyle.envs.units.ROAD_SPEED_MAX_MPS`;
- **heading**: a recorded heading agrees with the course of the positions (their direction
  over :data:`COURSE_BASE_M` of path) within :data:`HEADING_COURSE_TOL_RAD` at all but
  :data:`HEADING_DISAGREE_SHARE` of the samples (degrees read as radians do not).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence

import numpy as np

from drivestyle.envs.tracks import Carriageway, Recording, Track, TrackError
from drivestyle.envs.units import (
    ROAD_SPEED_MAX_MPS,
    SAMPLE_PERIOD_MAX_S,
    degrees_hint,
    speed_unit_hint,
    time_unit_hint,
)

__all__ = [
    "COURSE_BASE_M",
    "HEADING_COURSE_TOL_RAD",
    "HEADING_DISAGREE_SHARE",
    "WARN_VEHICLES",
    "check_recording",
    "course_disagreement",
    "implied_speeds",
    "track_problems_warning",
]

WARN_VEHICLES = 5
"""Vehicles the warning names (the rest are counted)."""
COURSE_BASE_M = 2.0
"""The course of the positions is their direction over this much path [m]: 0.1 m of
position noise at each end turns it by ≈ 0.07 rad, and a lane-changing car's heading
changes by less than 0.02 rad over it."""
HEADING_COURSE_TOL_RAD = 0.35
"""How far (20°) a recorded heading may differ from the course [rad]: a car's slip angle
at road speeds is below 0.05 rad, recorded lane changes turn by at most 0.22 rad, and the
course's noise adds ≈ 0.07 (:data:`COURSE_BASE_M`). A heading in degrees read as radians
is off by 0.35 rad from a course of 0.35° (0.006 rad) on: anything but dead straight."""
HEADING_DISAGREE_SHARE = 0.1
"""The share of a track's compared samples whose heading may differ from the course by
more than :data:`HEADING_COURSE_TOL_RAD` (a noisy fix, a sample at a standstill)."""


def implied_speeds(t: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The speed two consecutive positions imply, per step.

    Args:
        t: sample times, shape (n,) [s], increasing.
        x: positions along the road, shape (n,) [m].
        y: lateral positions, shape (n,) [m].

    Returns:
        Shape (n − 1,) [m/s].
    """
    return np.hypot(np.diff(x), np.diff(y)) / np.diff(t)


def course_disagreement(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, heading: np.ndarray, base_m: float = COURSE_BASE_M
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far a recorded heading is from the course of the positions.

    The course at sample i is the direction from position i to the first position at least
    ``base_m`` of path further; it is compared with the heading at the time midway between
    the two samples (the heading unwrapped and interpolated).

    Args:
        t: sample times, shape (n,) [s], increasing.
        x: positions along the road, shape (n,) [m].
        y: lateral positions, shape (n,) [m].
        heading: recorded headings against +x, shape (n,) [rad].
        base_m: the path over which the course is taken [m].

    Returns:
        (|heading − course| wrapped to [0, π] [rad], the heading compared [rad], the
        course [rad]), each of shape (m,) for the m samples with ``base_m`` of path ahead.
    """
    path = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    ahead = np.searchsorted(path, path + base_m)
    i = np.flatnonzero(ahead < path.size)
    j = ahead[i]
    course = np.arctan2(y[j] - y[i], x[j] - x[i])
    compared = np.interp((t[i] + t[j]) / 2, t, np.unwrap(heading))
    return np.abs(np.angle(np.exp(1j * (compared - course)))), compared, course


def _where(road: Carriageway, track: Track) -> str:
    return f"vehicle {track.vehicle_id} ({road.name})"


def _majority(flags: Sequence[bool]) -> bool:
    """More than half of the vehicles: a property of the file, not of a vehicle."""
    return 2 * sum(flags) > len(flags)


def _sampling_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[str, ...]]:
    """Tracks sampled too rarely to show a lane change (the sampling rule), per track.

    Raises:
        TrackError: most vehicles are (a time unit of the file).
    """
    bound = SAMPLE_PERIOD_MAX_S
    steps = np.array([float(np.median(np.diff(tr.t))) for _, tr in tracks])
    rare = steps > bound
    if _majority(rare.tolist()):
        step = float(np.median(steps))
        speed = float(np.median([np.median(implied_speeds(tr.t, tr.x, tr.y)) for _, tr in tracks]))
        raise TrackError(
            f"{recording.source}: {int(rare.sum())} of {len(tracks)} vehicles have a median time "
            f"step of {step:g} (read as seconds: more than {bound:g} s, too rare to show a lane "
            f"change) and drive at a median {speed:.3g} m/s: {time_unit_hint(step)}"
        )
    return [
        (
            f"has a median time step of {steps[k]:g} s, more than {bound:g} s: too rare to show "
            "a lane change (3–6 s)",
        )
        if rare[k]
        else ()
        for k in range(len(tracks))
    ]


def _speed_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[str, ...]]:
    """Median speeds beyond a road vehicle's (the speed rule), per track.

    Raises:
        TrackError: most vehicles are beyond it (a unit of the file).
    """
    bound = ROAD_SPEED_MAX_MPS
    limit = f"beyond {bound:g} m/s ({bound * 3.6:.0f} km/h), the fastest a road vehicle drives"
    implied = np.array([float(np.median(implied_speeds(tr.t, tr.x, tr.y))) for _, tr in tracks])
    recorded = np.array(
        [float(np.median(np.abs(tr.v))) if tr.v is not None else 0.0 for _, tr in tracks]
    )
    kinds = (("speeds", "the speed column", recorded), ("positions", "their positions", implied))
    for of, column, speeds in kinds:
        fast = speeds > bound
        if _majority(fast.tolist()):
            k = int(np.argmax(speeds))
            median = float(np.median(speeds))
            raise TrackError(
                f"{recording.source}: {int(fast.sum())} of {len(tracks)} vehicles drive at a "
                f"median {median:.3g} m/s by {column} (the fastest, {_where(*tracks[k])}, at "
                f"{speeds[k]:.3g} m/s), {limit}: {speed_unit_hint(median, of)}"
            )
    out: list[tuple[str, ...]] = []
    for k in range(len(tracks)):
        found = [
            f"drives at a median {speeds[k]:.3g} m/s by {column.replace('their', 'its')}, "
            f"{limit}: {speed_unit_hint(float(speeds[k]), of)}"
            for of, column, speeds in kinds
            if speeds[k] > bound
        ]
        out.append(tuple(found[:1]))  # the speed column's first: the positions' would repeat it
    return out


def _heading_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[str, ...]]:
    """Recorded headings that disagree with the course of the positions, per track.

    Raises:
        TrackError: most vehicles with a heading disagree (the file's unit or convention).
    """
    tol, share = HEADING_COURSE_TOL_RAD, HEADING_DISAGREE_SHARE
    said: list[str | None] = []
    for _, tr in tracks:
        if tr.heading is None:
            said.append(None)
            continue
        off, heading, course = course_disagreement(tr.t, tr.x, tr.y, tr.heading)
        if not off.size or np.mean(off > tol) <= share:
            said.append("")
            continue
        k = int(np.argmax(off))
        # the usual slips: the opposite direction's heading, degrees read as radians
        backwards = np.abs(np.angle(np.exp(1j * (heading - course - np.pi))))
        in_degrees = np.abs(np.angle(np.exp(1j * (np.radians(heading) - course))))
        if np.mean(backwards > tol) <= share:
            hint = "it points against its motion: the heading of the other driving direction?"
        elif np.mean(in_degrees > tol) <= share:
            hint = degrees_hint(float(heading[k]))
        else:
            hint = "a heading is against +x, counter-clockwise, in radians"
        said.append(
            f"has a recorded heading of {heading[k]:.3g} rad where its positions' course is "
            f"{course[k]:.3g} rad ({np.mean(off > tol):.0%} of its samples differ by more than "
            f"{tol:g} rad): {hint}"
        )
    checked = [p for p in said if p is not None]
    if checked and _majority([bool(p) for p in checked]):
        k = next(k for k, p in enumerate(said) if p)
        raise TrackError(
            f"{recording.source}: column heading: {sum(map(bool, checked))} of {len(checked)} "
            f"vehicles' headings disagree with the course of their positions; "
            f"{_where(*tracks[k])} {said[k]}"
        )
    return [(p,) if p else () for p in said]


def track_problems_warning(recording: Recording) -> str | None:
    """A one-line warning naming the vehicles kept with problems, or None.

    Args:
        recording: a checked recording (:func:`check_recording`).

    Returns:
        ``warning: …`` naming up to :data:`WARN_VEHICLES` vehicles with their first
        problem, or None when every track is plausible.
    """
    found = [(road, tr) for road in recording.carriageways for tr in road.tracks if tr.problems]
    if not found:
        return None
    named = "; ".join(f"{_where(road, tr)} {tr.problems[0]}" for road, tr in found[:WARN_VEHICLES])
    rest = len(found) - WARN_VEHICLES
    more = f"; and {rest} more vehicle(s)" if rest > 0 else ""
    return (
        f"warning: {recording.source}: {len(found)} vehicle(s) kept but unusable (their lane "
        f"changes are listed unusable in episodes.csv): {named}{more}"
    )


def check_recording(recording: Recording, warn: bool = True) -> Recording:
    """A reader's recording checked by the rules (module docstring).

    Args:
        recording: as a reader built it (tracks without problems).
        warn: print :func:`track_problems_warning` on stderr.

    Returns:
        The recording with each track's :attr:`~drivestyle.envs.tracks.Track.problems` set
        (``meta["track_problems"]``: carriageway, vehicle and problems of each such track).

    Raises:
        TrackError: a rule that most of the file's vehicles break (a unit or convention of
            the file); one line naming the file, the value and the likely unit.
    """
    tracks = [(road, tr) for road in recording.carriageways for tr in road.tracks]
    if not tracks:
        return recording
    # the sampling first: a time in the wrong unit makes every speed wrong too
    rules = [
        _sampling_problems(recording, tracks),
        _speed_problems(recording, tracks),
        _heading_problems(recording, tracks),
    ]
    found = {id(tr): sum((rule[k] for rule in rules), ()) for k, (_, tr) in enumerate(tracks)}
    roads = tuple(
        dataclasses.replace(
            road,
            tracks=tuple(
                dataclasses.replace(tr, problems=tr.problems + found[id(tr)])
                if found[id(tr)]
                else tr
                for tr in road.tracks
            ),
        )
        for road in recording.carriageways
    )
    meta = dict(recording.meta)
    meta["track_problems"] = [
        {"carriageway": road.name, "vehicle_id": tr.vehicle_id, "problems": list(tr.problems)}
        for road in roads
        for tr in road.tracks
        if tr.problems
    ]
    checked = Recording(recording.source, roads, meta)
    warning = track_problems_warning(checked) if warn else None
    if warning:
        print(warning, file=sys.stderr, flush=True)
    return checked
