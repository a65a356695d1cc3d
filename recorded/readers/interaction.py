"""INTERACTION ``vehicle_tracks_NNN.csv`` files: map coordinates, a road direction given.

:func:`read_interaction` turns the map frame into the road frame of one direction of
travel (``direction``) with the caller's lane lines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from drivestyle.recorded.readers.shared import (
    _label,
    _need_file,
    _published_columns,
    _published_numbers,
    _published_tracks,
    _read_csv,
    _warn_outside_road,
    check_lane_lines,
)
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "INTERACTION_COLUMNS",
    "INTERACTION_VEHICLES",
    "read_interaction",
]

INTERACTION_VEHICLES = frozenset({"car", "truck", "bus", "truck_bus", "van", "motorcycle"})
"""INTERACTION ``agent_type`` values kept (pedestrians and bicycles are dropped)."""
_AXES = {"x+": 0.0, "y+": math.pi / 2, "x-": math.pi, "y-": -math.pi / 2}
"""Named road directions of :func:`read_interaction` → angle of travel in the map [rad]."""
INTERACTION_COLUMNS = (
    "case_id",
    "track_id",
    "frame_id",
    "timestamp_ms",
    "agent_type",
    "x",
    "y",
    "vx",
    "vy",
    "psi_rad",
    "length",
    "width",
)
"""Columns of an INTERACTION ``vehicle_tracks_NNN.csv``."""


def _interaction_direction(direction: str | float) -> float:
    """Angle of travel in the map [rad] from 'x+', 'x-', 'y+', 'y-' or a number."""
    if isinstance(direction, str):
        if direction not in _AXES:
            raise ValueError(
                f"direction must be one of {', '.join(_AXES)} or an angle [rad], got {direction!r}"
            )
        return _AXES[direction]
    angle = float(direction)
    if not math.isfinite(angle):
        raise ValueError(f"direction must be a finite angle [rad], got {direction!r}")
    return angle


def _interaction_lines(
    lane_markings: Sequence[float | Sequence[float]], direction: str | float, angle: float
) -> np.ndarray:
    """Lane lines' lateral positions in the road frame (y = −sin θ·x + cos θ·y), increasing."""
    out = []
    for m in lane_markings:
        if isinstance(m, (int, float, np.integer, np.floating)):
            if not isinstance(direction, str):
                raise ValueError(
                    f"lane line {m!r}: with a direction given as an angle, give each lane line "
                    "as an (x, y) map point on it"
                )
            px, py = (0.0, float(m)) if direction[0] == "x" else (float(m), 0.0)
        else:
            px, py = (float(v) for v in m)
        out.append(-math.sin(angle) * px + math.cos(angle) * py)
    return np.sort(np.array(out, dtype=float))


def read_interaction(
    path: str | Path,
    lane_markings: Sequence[float | Sequence[float]],
    *,
    direction: str | float,
) -> Recording:
    """An INTERACTION ``vehicle_tracks_NNN.csv`` of a straight road, in the road frame.

    The file (map frame, metres, 10 Hz) has no lanes, so the caller gives the road: its
    direction of travel and its lane lines. Map positions and velocities are rotated by the
    direction's angle θ: x = cos θ·x_map + sin θ·y_map, y = −sin θ·x_map + cos θ·y_map
    (a rotation: y stays to the left of travel); heading = psi_rad − θ (wrapped), v = |(vx,
    vy)|, t = timestamp_ms/1000, frames = frame_id, length and width per track (median).
    Each ``case_id`` is a separate scene and becomes its own carriageway (``'case <id>'``,
    all with the same lane lines); a track is a (case_id, track_id), named
    ``'<case_id>:<track_id>'``. Only vehicles (:data:`INTERACTION_VEHICLES`) are kept, and
    tracks driving against the direction (median speed along it < −1 m/s: the other
    carriageway) are dropped; both counted in ``meta``.

    Args:
        path: the ``vehicle_tracks_NNN.csv``.
        lane_markings: the lane lines in the map frame, road edges included (the
            outermost lines are the edges; vehicles outside them are warned of on stderr):
            for ``direction`` 'x+'/'x-' each line's map y [m], for 'y+'/'y-' its map x
            [m]; or, for any direction, a map point (x, y) [m] on each line.
        direction: the direction of travel in the map: 'x+', 'x-', 'y+', 'y-' or an angle
            from the map's +x axis, counter-clockwise [rad].

    Returns:
        The recording (meta: format, rate, direction angle, dropped agents and tracks,
        vehicles outside the road).

    Raises:
        FileNotFoundError: no such file.
        ValueError: a bad direction, or numbers as lane lines with an angle.
        TrackError: a missing column, a value that is not a number, a repeated or
            non-increasing frame (naming the file, the track and the frame), no vehicle, or
            lane lines no road has.
    """
    path = Path(path)
    angle = _interaction_direction(direction)
    lines = _interaction_lines(lane_markings, direction, angle)
    check_lane_lines(lines, path, f"lane_markings along {direction!r}, in the road frame")
    _need_file(path, "an INTERACTION vehicle_tracks_NNN.csv")
    df = _read_csv(path, "an INTERACTION vehicle_tracks_NNN.csv")
    _published_columns(df, path, INTERACTION_COLUMNS, "INTERACTION")
    agent = df["agent_type"].astype(str).str.strip().str.lower()
    vehicle = agent.isin(INTERACTION_VEHICLES)
    not_vehicles = {str(k): int(v) for k, v in agent[~vehicle].value_counts().items()}
    df = df[vehicle].reset_index(drop=True)
    if df.empty:
        raise TrackError(
            f"{path}: no vehicle rows (agent_type {sorted(not_vehicles)}); kept types are "
            f"{sorted(INTERACTION_VEHICLES)}"
        )
    columns = [c for c in INTERACTION_COLUMNS if c != "agent_type"]
    num = _published_numbers(df, path, columns, ["case_id", "track_id"], "frame_id")
    c, s = math.cos(angle), math.sin(angle)
    x = c * num["x"] + s * num["y"]
    y = -s * num["x"] + c * num["y"]
    vx = c * num["vx"] + s * num["vy"]
    heading = np.angle(np.exp(1j * (num["psi_rad"] - angle)))
    t = num["timestamp_ms"] / 1000.0
    keys = np.array(
        [f"{_label(a)}:{_label(b)}" for a, b in zip(num["case_id"], num["track_id"], strict=True)]
    )
    groups, dropped = _published_tracks(path, keys, t, num["frame_id"])
    per_case: dict[str, list[Track]] = {}
    against = []
    for vid, rows in groups:
        if np.median(vx[rows]) < -1.0:
            against.append(vid)
            continue
        per_case.setdefault(vid.split(":")[0], []).append(
            Track(
                vehicle_id=vid,
                t=t[rows],
                x=x[rows],
                y=y[rows],
                frames=num["frame_id"][rows].astype(np.int64),
                v=np.hypot(num["vx"][rows], num["vy"][rows]),
                heading=heading[rows],
                length=float(np.median(num["length"][rows])),
                width=float(np.median(num["width"][rows])),
                source=str(path),
            )
        )
    cases = sorted(per_case, key=lambda k: (len(k), k))
    carriageways = tuple(
        Carriageway(f"case {k}", tuple(lines), tuple(per_case[k]), heading_offset=angle)
        for k in cases
    )
    meta = {
        "format": "interaction",
        "rate_hz": 10.0,
        "direction_rad": angle,
        "agents_dropped": not_vehicles,
        "tracks_against_direction_dropped": against,
        SINGLE_SAMPLE: dropped,
    }
    checked = check_recording(Recording(str(path), carriageways, meta))
    # after the checks: a file they refuse gets its error alone
    lines_from = "lane_markings (--lane-markings)"
    checked.meta["outside_road"] = _warn_outside_road(carriageways, lines_from)
    return checked
