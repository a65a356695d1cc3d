"""Every reader's tracks checked by their physics: the rules' one home.

Each reader of :mod:`drivestyle.recorded.readers` (the generic table, raw NGSIM, levelX,
INTERACTION, the shipped samples) ends with :func:`check_recording`; no reader keeps a
copy of a rule. A rule has two outcomes:

- **the file** is refused (:class:`~drivestyle.recorded.tracks.TrackError`, one line naming
  the file, the column and the value with the likely unit) where most of its vehicles
  break the rule: that is a unit or a convention of the file, not a vehicle;
- **a vehicle** that breaks it alone is kept with the reason in
  :attr:`~drivestyle.recorded.tracks.Track.problems` (with the times it concerns): a lane
  change whose window meets it — the lane changer's or an interacting vehicle's — is
  listed unusable in ``episodes.csv`` with it, and a warning on stderr names the vehicles.

The rules (their bounds are :mod:`drivestyle.envs.units`' and this module's constants):

- **sampling**: a vehicle's median time step is at most
  :data:`~drivestyle.envs.units.SAMPLE_PERIOD_MAX_S` (a step of 100 is a time in
  milliseconds: its cars drive at 0.025 m/s);
- **speed**: a vehicle's median speed — the recorded one and the one its positions imply —
  is at most :data:`~drivestyle.envs.units.ROAD_SPEED_MAX_MPS`;
- **heading**: a recorded heading agrees with the course of the positions (their direction
  over :data:`COURSE_BASE_M` along the road) within :data:`HEADING_COURSE_TOL_RAD` at all but
  :data:`HEADING_DISAGREE_SHARE` of the samples (degrees read as radians do not);
- **lateral unit**: vehicles keep to their lanes: where the vehicles' median y lies a
  median :data:`LANE_OFF_CENTRE` lane widths or more from a lane's centre (off the road
  counts as a line) while × 0.3048 it lies within :data:`LANE_ON_CENTRE`, the positions are
  in feet and the file is refused (slow traffic in feet passes the speed rule: 14 m/s is
  46 ft/s). A rule of the file only: one vehicle between lanes is a lane change;
- **samples**: a vehicle of a single sample shows no motion and no lane change: a reader
  skips it and lists it in ``meta[SINGLE_SAMPLE]``, and a note on stderr counts them (most
  of a file's vehicles so: refused, the ids are not per vehicle);
- **overlap**: no two vehicles of a carriageway overlap at any time (their rectangles,
  shrunk to :data:`~drivestyle.envs.plausibility.OVERLAP_SHRINK` as the demonstration's
  check shrinks them, on a common time grid; :func:`overlaps`): both are kept unusable,
  each naming the other. A pair is never a unit of the file, so this rule marks only.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Sequence

import numpy as np

from drivestyle.envs.plausibility import OVERLAP_SHRINK
from drivestyle.envs.safety import vehicles_overlap
from drivestyle.envs.units import (
    FOOT,
    ROAD_SPEED_MAX_MPS,
    SAMPLE_PERIOD_MAX_S,
    degrees_hint,
    speed_unit_hint,
    time_unit_hint,
)
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError, TrackProblem

__all__ = [
    "COURSE_BASE_M",
    "HEADING_COURSE_TOL_RAD",
    "HEADING_DISAGREE_SHARE",
    "LANE_OFF_CENTRE",
    "LANE_ON_CENTRE",
    "LATERAL_MIN_VEHICLES",
    "SINGLE_SAMPLE",
    "WARN_VEHICLES",
    "check_recording",
    "course",
    "course_disagreement",
    "implied_speeds",
    "overlaps",
    "single_sample_note",
    "track_problems_warning",
]

WARN_VEHICLES = 5
"""Vehicles the warning names (the rest are counted)."""
COURSE_BASE_M = 2.0
"""The course of the positions is their direction over this much advance along x [m]: 0.1 m of
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


def _ahead(x: np.ndarray, base_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(i, j): each sample i and the first later sample j at least ``base_m`` further along x.

    Along x, not along the path: every vehicle of a carriageway drives to +x (the road
    frame), and a standing vehicle's jitter grows its path without taking it anywhere.
    """
    reached = np.maximum.accumulate(x)  # nondecreasing: the farthest x so far
    ahead = np.searchsorted(reached, x + base_m)
    i = np.flatnonzero(ahead < x.size)
    return i, ahead[i]


def course_disagreement(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, heading: np.ndarray, base_m: float = COURSE_BASE_M
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far a recorded heading is from the course of the positions.

    The course at sample i is the direction from position i to the first position at least
    ``base_m`` further along x (not a standing vehicle's jitter); it is compared with the
    heading at the time midway between the two samples (the heading unwrapped and
    interpolated).

    Args:
        t: sample times, shape (n,) [s], increasing.
        x: positions along the road, shape (n,) [m].
        y: lateral positions, shape (n,) [m].
        heading: recorded headings against +x, shape (n,) [rad].
        base_m: the path over which the course is taken [m].

    Returns:
        (|heading − course| wrapped to [0, π] [rad], the heading compared [rad], the
        course [rad]), each of shape (m,) for the m samples with a course.
    """
    i, j = _ahead(x, base_m)
    moving = np.arctan2(y[j] - y[i], x[j] - x[i])
    compared = np.interp((t[i] + t[j]) / 2, t, np.unwrap(heading))
    return np.abs(np.angle(np.exp(1j * (compared - moving)))), compared, moving


def course(x: np.ndarray, y: np.ndarray, base_m: float = COURSE_BASE_M) -> np.ndarray:
    """The direction of motion at each sample: towards the position ``base_m`` further along x.

    Over a base, not one step: a standing vehicle's position noise would turn a one-step
    direction anywhere. A sample without such a position ahead (the track's end) takes the
    nearest earlier course; a vehicle that never moves ``base_m`` points along +x.

    Args:
        x: positions along the road, shape (n,) [m].
        y: lateral positions, shape (n,) [m].
        base_m: the path over which the direction is taken [m].

    Returns:
        The course against +x, shape (n,) [rad].
    """
    i, j = _ahead(x, base_m)
    if not i.size:
        return np.zeros(x.size)
    known = np.full(x.size, -1)
    known[i] = i
    earlier = np.maximum.accumulate(known)  # the nearest sample with a course at or before
    source = np.where(earlier >= 0, earlier, i[0])
    out = np.zeros(x.size)
    out[i] = np.arctan2(y[j] - y[i], x[j] - x[i])
    return out[source]


def overlaps(
    key: np.ndarray,
    states: np.ndarray,
    length: np.ndarray,
    width: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of vehicle rectangles that overlap at the same time key.

    Sorted by (key, x), a rectangle can reach only those after it within the sum of the
    largest circumscribed radii along x at the same key: the candidates are found offset by
    offset (i, i + 1), (i, i + 2), … until none is left, never comparing all pairs; a
    candidate whose circumscribed circles meet is tested exactly, rectangle against
    rectangle (:func:`~drivestyle.envs.safety.vehicles_overlap`: the separating-axis test
    the demonstration's overlap check makes).

    Args:
        key: the time (grid index) of each rectangle, shape (r,).
        states: [x, y, φ] of each centre, shape (r, 3) [m, m, rad].
        length: each rectangle's length, shape (r,) [m].
        width: each rectangle's width, shape (r,) [m].

    Returns:
        (i, j): row indices into the inputs of each overlapping pair, shape (p,) each.
    """
    order = np.lexsort((states[:, 0], key))
    k, xs, ys = key[order], states[order, 0], states[order, 1]
    radius = np.hypot(length, width)[order] / 2
    reach = 2 * float(radius.max()) if radius.size else 0.0
    found_i: list[np.ndarray] = []
    found_j: list[np.ndarray] = []
    for m in range(1, k.size):
        a, b = np.arange(k.size - m), np.arange(m, k.size)
        near = (k[a] == k[b]) & (xs[b] - xs[a] < reach)
        if not near.any():
            break
        a, b = a[near], b[near]
        meet = np.hypot(xs[b] - xs[a], ys[b] - ys[a]) < radius[a] + radius[b]
        i, j = order[a[meet]], order[b[meet]]
        size = np.column_stack([length, width])
        hit = vehicles_overlap(states[i], states[j], size[i], size[j])
        found_i.append(i[hit])
        found_j.append(j[hit])
    if not found_i:
        return np.zeros(0, int), np.zeros(0, int)
    return np.concatenate(found_i), np.concatenate(found_j)


LANE_OFF_CENTRE = 0.25
"""The median distance of the vehicles' median y from a lane's centre [lane widths] from
which they keep to no lane (half a lane is a line; uniformly spread positions give 0.25;
the shipped samples' vehicles lie 0.05 (NGSIM) and 0.09 (CATS) from a centre)."""
LANE_ON_CENTRE = 0.1
"""The median distance [lane widths] within which the positions × 0.3048 keep to the lanes
(the shipped samples' read so lie 0.23 and 0.25 away: no lane)."""
LATERAL_MIN_VEHICLES = 5
"""The fewest vehicles that tell the unit of the positions by their lanes (two vehicles,
one of them changing lane, are no evidence)."""

SINGLE_SAMPLE = "single_sample_tracks_dropped"
"""The key of a recording's ``meta`` where its reader lists the vehicles it skipped for
having a single sample (each as the messages name it: the id, and its recording or road)."""


def _skipped(recording: Recording) -> list[str]:
    """The vehicles its reader skipped for a single sample (``meta[SINGLE_SAMPLE]``)."""
    value = recording.meta.get(SINGLE_SAMPLE)
    return [str(v) for v in value] if isinstance(value, list | tuple) else []


def _single_samples(recording: Recording, kept: int) -> list[str]:
    """The vehicles the reader skipped for a single sample.

    Raises:
        TrackError: most of the file's vehicles have one (an id per row, not per vehicle).
    """
    skipped = _skipped(recording)
    if skipped and _majority([True] * len(skipped) + [False] * kept):
        named = ", ".join(skipped[:WARN_VEHICLES]) + (", …" if len(skipped) > WARN_VEHICLES else "")
        raise TrackError(
            f"{recording.source}: {len(skipped)} of {len(skipped) + kept} vehicles have a single "
            f"sample (vehicle {named}): a track needs 2 or more to show motion; is the vehicle "
            "id the same on every row of one vehicle (not a row number)?"
        )
    return skipped


def single_sample_note(recording: Recording) -> str | None:
    """A one-line note counting the vehicles skipped for a single sample, or None.

    Args:
        recording: a reader's recording (``meta[SINGLE_SAMPLE]``).

    Returns:
        ``note: …`` naming up to :data:`WARN_VEHICLES` of them.
    """
    skipped = _skipped(recording)
    if not skipped:
        return None
    named = ", ".join(skipped[:WARN_VEHICLES])
    rest = len(skipped) - WARN_VEHICLES
    more = f" and {rest} more" if rest > 0 else ""
    return (
        f"note: {recording.source}: {len(skipped)} vehicle(s) of a single sample skipped (one "
        f"position shows no motion and no lane change): vehicle {named}{more}"
    )


def _where(road: Carriageway, track: Track) -> str:
    return f"vehicle {track.vehicle_id} ({road.name})"


def _majority(flags: Sequence[bool]) -> bool:
    """More than half of the vehicles: a property of the file, not of a vehicle."""
    return 2 * sum(flags) > len(flags)


def _sampling_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[TrackProblem, ...]]:
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
            TrackProblem(
                f"has a median time step of {steps[k]:g} s, more than {bound:g} s: too rare to "
                "show a lane change (3–6 s)"
            ),
        )
        if rare[k]
        else ()
        for k in range(len(tracks))
    ]


def _speed_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[TrackProblem, ...]]:
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
    out: list[tuple[TrackProblem, ...]] = []
    for k in range(len(tracks)):
        found = [
            f"drives at a median {speeds[k]:.3g} m/s by {column.replace('their', 'its')}, "
            f"{limit}: {speed_unit_hint(float(speeds[k]), of)}"
            for of, column, speeds in kinds
            if speeds[k] > bound
        ]
        # the speed column's first: the positions' would repeat it
        out.append(tuple(TrackProblem(text) for text in found[:1]))
    return out


def _off_centre(tracks: list[tuple[Carriageway, Track]], scale: float) -> float:
    """The median distance of the vehicles' median y (× ``scale``) from their lane's centre.

    In lane widths: 0 at a centre, 0.5 on a line; a median y off the road counts 0.5.
    """
    off = []
    for road, tr in tracks:
        lines = np.asarray(road.markings)
        y = float(np.median(tr.y)) * scale
        k = int(np.searchsorted(lines, y)) - 1
        if 0 <= k < lines.size - 1:
            off.append(abs((y - lines[k]) / (lines[k + 1] - lines[k]) - 0.5))
        else:
            off.append(0.5)
    return float(np.median(off))


def _lateral_unit(recording: Recording, tracks: list[tuple[Carriageway, Track]]) -> None:
    """Refuse positions in feet that the lanes reveal (the lateral unit rule).

    Raises:
        TrackError: the vehicles keep to no lane as read, but to the lanes × 0.3048.
    """
    if len(tracks) < LATERAL_MIN_VEHICLES:
        return
    read, feet = _off_centre(tracks, 1.0), _off_centre(tracks, FOOT)
    if read >= LANE_OFF_CENTRE and feet <= LANE_ON_CENTRE:
        raise TrackError(
            f"{recording.source}: the vehicles keep to no lane: their median y lies a median "
            f"{read:.2f} lane widths from a lane's centre (0.5: on a line or off the road), "
            f"but × {FOOT:g} {feet:.2f}: positions in feet (× {FOOT:g})?"
        )


def _wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles in (−π, π] [rad] (π stays π: a heading against +x is said as 3.14, not −3.14)."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def _heading_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[TrackProblem, ...]]:
    """Recorded headings that disagree with the course of the positions, per track.

    Said in the source's frame (:attr:`~drivestyle.recorded.tracks.Carriageway.heading_offset`):
    the heading the file holds and the course of its positions as the file has them.

    Raises:
        TrackError: most vehicles with a heading disagree (the file's unit or convention).
    """
    tol, share = HEADING_COURSE_TOL_RAD, HEADING_DISAGREE_SHARE
    said: list[str | None] = []
    for road, tr in tracks:
        if tr.heading is None:
            said.append(None)
            continue
        off, heading, moving = course_disagreement(tr.t, tr.x, tr.y, tr.heading)
        if not off.size or np.mean(off > tol) <= share:
            said.append("")
            continue
        k = int(np.argmax(off))
        # the usual slips: the opposite direction's heading, degrees read as radians
        backwards = np.abs(np.angle(np.exp(1j * (heading - moving - np.pi))))
        in_degrees = np.abs(np.angle(np.exp(1j * (np.radians(heading) - moving))))
        # said in the source's frame, the values its file holds (a table's −x traffic was
        # turned by π), in (−π, π] as read
        if road.heading_offset:
            heading = _wrapped(heading + road.heading_offset)
            moving = _wrapped(moving + road.heading_offset)
        if np.mean(backwards > tol) <= share:
            hint = "it points against its motion: the heading of the other driving direction?"
        elif np.mean(in_degrees > tol) <= share:
            hint = degrees_hint(float(heading[k]))
        else:
            hint = "a heading is against +x, counter-clockwise, in radians"
        said.append(
            f"has a recorded heading of {heading[k]:.3g} rad where its positions' course is "
            f"{moving[k]:.3g} rad ({np.mean(off > tol):.0%} of its samples differ by more than "
            f"{tol:g} rad): {hint}"
        )
    checked = [p for p in said if p is not None]
    if checked and _majority([bool(p) for p in checked]):
        k = next(k for k, p in enumerate(said) if p)
        raise TrackError(
            f"{recording.source}: {sum(map(bool, checked))} of {len(checked)} vehicles' "
            f"recorded headings disagree with the course of their positions; "
            f"{_where(*tracks[k])} {said[k]}"
        )
    return [(TrackProblem(p),) if p else () for p in said]


def _overlap_problems(
    recording: Recording, tracks: list[tuple[Carriageway, Track]]
) -> list[tuple[TrackProblem, ...]]:
    """Vehicles of one carriageway that overlap another at some time (both marked).

    The tracks are compared on the carriageway's grid of its median time step (linear
    between samples), which every track shares whatever its own clock.
    """
    index = {id(tr): k for k, (_, tr) in enumerate(tracks)}
    said: list[list[TrackProblem]] = [[] for _ in tracks]
    for road in recording.carriageways:
        if len(road.tracks) < 2:
            continue
        dt = float(np.median(np.concatenate([np.diff(tr.t) for tr in road.tracks])))
        keys, states, owner = [], [], []
        for n, tr in enumerate(road.tracks):
            grid = np.arange(np.ceil(tr.t[0] / dt - 1e-9), np.floor(tr.t[-1] / dt + 1e-9) + 1)
            # the recorded heading where there is one, else the course of the positions
            phi = np.unwrap(tr.heading if tr.heading is not None else course(tr.x, tr.y))
            keys.append(grid.astype(np.int64))
            states.append(
                np.column_stack([np.interp(grid * dt, tr.t, v) for v in (tr.x, tr.y, phi)])
            )
            owner.append(np.full(grid.size, n))
        who = np.concatenate(owner)
        size = np.array([[tr.length, tr.width] for tr in road.tracks]) * OVERLAP_SHRINK
        key = np.concatenate(keys)
        i, j = overlaps(key, np.concatenate(states), size[who, 0], size[who, 1])
        pairs: dict[tuple[int, int], list[int]] = {}
        for a, b in zip(i.tolist(), j.tolist(), strict=True):
            pair = (min(who[a], who[b]), max(who[a], who[b]))
            pairs.setdefault(pair, []).append(a)
        for (a, b), rows in pairs.items():
            first, last = float(key[min(rows)] * dt), float(key[max(rows)] * dt)
            span = f"at t = {first:g} s" if len(rows) == 1 else f"from t = {first:g} to {last:g} s"
            for me, other in ((a, b), (b, a)):
                text = (
                    f"overlaps vehicle {road.tracks[other].vehicle_id} {span} ({len(rows)} "
                    f"sample(s) {dt:g} s apart): two vehicles cannot share a place; the same "
                    "vehicle under two ids, or positions or sizes in another unit?"
                )
                said[index[id(road.tracks[me])]].append(TrackProblem(text, first, last))
    return [tuple(p) for p in said]


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
    named = "; ".join(
        f"{_where(road, tr)} {tr.problems[0].text}" for road, tr in found[:WARN_VEHICLES]
    )
    rest = len(found) - WARN_VEHICLES
    more = f"; and {rest} more vehicle(s)" if rest > 0 else ""
    return (
        f"warning: {recording.source}: {len(found)} vehicle(s) whose motion is not a road "
        f"vehicle's (kept; a lane change whose window meets it, by the vehicle or one it "
        f"interacts with, is listed unusable in episodes.csv): {named}{more}"
    )


def check_recording(recording: Recording, warn: bool = True) -> Recording:
    """A reader's recording checked by the rules (module docstring).

    Args:
        recording: as a reader built it (tracks without problems).
        warn: print :func:`track_problems_warning` and :func:`single_sample_note` on
            stderr.

    Returns:
        The recording with each track's :attr:`~drivestyle.recorded.tracks.Track.problems` set
        (``meta["track_problems"]``: carriageway, vehicle and problems of each such track).

    Raises:
        TrackError: a rule that most of the file's vehicles break (a unit or convention of
            the file, or most vehicles of a single sample); one line naming the file, the
            value and the likely unit.
    """
    tracks = [(road, tr) for road in recording.carriageways for tr in road.tracks]
    _single_samples(recording, len(tracks))
    note = single_sample_note(recording) if warn else None
    if note:
        print(note, file=sys.stderr, flush=True)
    if not tracks:
        return recording
    # the sampling first: a time in the wrong unit makes every speed wrong too
    sampling, speeds = _sampling_problems(recording, tracks), _speed_problems(recording, tracks)
    _lateral_unit(recording, tracks)  # a rule of the file only: it refuses or says nothing
    rules = [
        sampling,
        speeds,
        _heading_problems(recording, tracks),
        _overlap_problems(recording, tracks),
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
        {
            "carriageway": road.name,
            "vehicle_id": tr.vehicle_id,
            "problems": [dataclasses.asdict(p) for p in tr.problems],
        }
        for road in roads
        for tr in road.tracks
        if tr.problems
    ]
    checked = Recording(recording.source, roads, meta)
    warning = track_problems_warning(checked) if warn else None
    if warning:
        print(warning, file=sys.stderr, flush=True)
    return checked
