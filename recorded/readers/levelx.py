"""highD recordings in the levelX format (``NN_tracks.csv`` and its two meta files).

:func:`read_levelx`: bounding boxes in the image frame (y down), two carriageways
('upper', 'lower') driving opposite ways.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.recorded.readers.shared import (
    _label,
    _need_file,
    _published_columns,
    _published_numbers,
    _published_tracks,
    _read_csv,
    check_lane_lines,
)
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "LEVELX_TRACK_COLUMNS",
    "read_levelx",
]

LEVELX_TRACK_COLUMNS = ("frame", "id", "x", "y", "width", "height", "xVelocity", "yVelocity")
"""Columns read from a highD ``NN_tracks.csv``."""


def _levelx_csv(path: Path, required: Sequence[str]) -> Any:

    _need_file(
        path,
        "read_levelx needs NN_tracks.csv, NN_tracksMeta.csv and NN_recordingMeta.csv side by side",
    )
    df = _read_csv(path, f"a levelX {path.name.split('_')[-1]} (highD)")
    _published_columns(df, path, required, "levelX (highD)")
    return df


def _levelx_markings(path: Path, rec: Any, column: str) -> np.ndarray:
    text = str(rec[column].iloc[0])
    try:
        values = np.array([float(v) for v in text.split(";") if v.strip()])
    except ValueError:
        raise TrackError(
            f"{path}: {column} {text!r} is not semicolon-separated numbers [m]"
        ) from None
    if values.size < 3 or not np.all(np.isfinite(values)):
        raise TrackError(f"{path}: {column} {text!r} needs 3 or more finite lane lines [m]")
    return values


def read_levelx(tracks_csv: str | Path) -> Recording:
    """A highD recording (levelX format) in the road frame: carriageways 'upper', 'lower'.

    ``NN_tracks.csv`` gives, per frame and vehicle, the bounding box's upper-left corner
    (x, y) in the image frame scaled to metres (x right, **y down**), its size (width along
    x = the length, height = the vehicle's width) and the velocity (xVelocity, yVelocity).
    ``NN_tracksMeta.csv`` gives each vehicle's ``drivingDirection`` and
    ``NN_recordingMeta.csv`` the ``frameRate`` and the lane lines' image y
    (``upperLaneMarkings``, ``lowerLaneMarkings``, semicolon-separated).

    Conversion, with the centre (cx, cy) = (x + width/2, y + height/2):

    - upper (drivingDirection 1, driving to image −x; its left is image +y, down):
      x = −cx, y = cy, velocity (−xVelocity, yVelocity), lines = upperLaneMarkings;
    - lower (drivingDirection 2, driving to image +x; its left is image −y, up):
      x = cx, y = −cy, velocity (xVelocity, −yVelocity), lines = −lowerLaneMarkings;

    both mirror the image, so the frame is right-handed with y to the left of travel; lines
    are sorted increasing (lane 0 is the outer, rightmost lane of each direction; lanes are
    found from y, highD's ``laneId`` — numbered over both directions — is not used).
    v = |velocity|, heading = atan2(v_y, v_x) in the new frame, t = frame / frameRate,
    length, width = the median box width, height.

    Args:
        tracks_csv: ``NN_tracks.csv`` (its ``NN_tracksMeta.csv`` and
            ``NN_recordingMeta.csv`` beside it).

    Returns:
        The recording (meta: format, frame rate, the files read).

    Raises:
        FileNotFoundError: one of the three files is missing.
        TrackError: a missing column (the exiD/inD/rounD layout is refused), a value that is
            not a number, a repeated frame, a vehicle without or with an unknown
            drivingDirection, a vehicle driving against its direction, or lanes no road has
            (naming the file, and the vehicle and frame for a track's problem).
    """
    import pandas as pd

    path = Path(tracks_csv)
    if not path.name.endswith("_tracks.csv"):
        raise TrackError(
            f"{path}: a levelX tracks file is named NN_tracks.csv (NN_tracksMeta.csv and "
            "NN_recordingMeta.csv beside it)"
        )
    prefix = path.name[: -len("tracks.csv")]
    rec_path = path.with_name(prefix + "recordingMeta.csv")
    meta_path = path.with_name(prefix + "tracksMeta.csv")
    _need_file(path, "a levelX NN_tracks.csv")
    df = _read_csv(path, "a levelX NN_tracks.csv (highD)")
    if "trackId" in df.columns and "xCenter" in df.columns:
        raise TrackError(
            f"{path}: the exiD/inD/rounD layout (trackId, xCenter, yCenter, heading…): their "
            "roads are not straight lanes; read_levelx reads the highD layout (frame, id, x, "
            "y, width, height, xVelocity, yVelocity)"
        )
    _published_columns(df, path, LEVELX_TRACK_COLUMNS, "levelX (highD)")
    rec = _levelx_csv(rec_path, ("frameRate", "upperLaneMarkings", "lowerLaneMarkings"))
    if len(rec) != 1:
        raise TrackError(f"{rec_path}: {len(rec)} rows; a recordingMeta has one")
    rate = pd.to_numeric(rec["frameRate"], errors="coerce").iloc[0]
    if not (math.isfinite(rate) and rate > 0):
        raise TrackError(f"{rec_path}: frameRate {rec['frameRate'].iloc[0]!r} is not > 0 [Hz]")
    upper = _levelx_markings(rec_path, rec, "upperLaneMarkings")
    lower = _levelx_markings(rec_path, rec, "lowerLaneMarkings")
    tm = _levelx_csv(meta_path, ("id", "drivingDirection"))
    tm_num = _published_numbers(tm, meta_path, ["id", "drivingDirection"], ["id"], "id")
    direction_of = dict(
        zip(tm_num["id"].tolist(), tm_num["drivingDirection"].tolist(), strict=True)
    )

    num = _published_numbers(df, path, LEVELX_TRACK_COLUMNS, ["id"], "frame")
    t = num["frame"] / float(rate)
    groups, dropped = _published_tracks(path, num["id"].astype(np.int64), t, num["frame"])
    cx = num["x"] + num["width"] / 2
    cy = num["y"] + num["height"] / 2
    sides = {
        1: ("upper", -1.0, 1.0, np.sort(upper), "−x"),
        2: ("lower", 1.0, -1.0, np.sort(-lower), "+x"),
    }
    found: dict[int, list[Track]] = {1: [], 2: []}
    for vid, rows in groups:
        first = _label(num["frame"][rows[0]])
        d = direction_of.get(float(vid))
        if d not in sides:
            what = "is not in" if d is None else f"has drivingDirection {_label(d)} in"
            raise TrackError(
                f"{path}: vehicle {vid}, frame {first}: {what} {meta_path.name} (1 = upper, "
                "driving to −x; 2 = lower, driving to +x)"
            )
        name, sx, sy, _, way = sides[d]
        vx, vy = sx * num["xVelocity"][rows], sy * num["yVelocity"][rows]
        if np.median(vx) < -1.0:
            raise TrackError(
                f"{path}: vehicle {vid}, frame {first}: drives against its drivingDirection "
                f"{_label(d)} ({name}, to image {way}): median xVelocity "
                f"{np.median(num['xVelocity'][rows]):.3g} m/s"
            )
        found[d].append(
            Track(
                vehicle_id=vid,
                t=t[rows],
                x=sx * cx[rows],
                y=sy * cy[rows],
                frames=num["frame"][rows].astype(np.int64),
                v=np.hypot(vx, vy),
                heading=np.arctan2(vy, vx),
                length=float(np.median(num["width"][rows])),
                width=float(np.median(num["height"][rows])),
                source=str(path),
            )
        )
    carriageways = []
    for d, (name, _, _, lines, _) in sides.items():
        check_lane_lines(lines, rec_path, f"{name}LaneMarkings, in the {name} road frame")
        carriageways.append(Carriageway(name, tuple(lines), tuple(found[d])))
    meta = {
        "format": "highd",
        "rate_hz": float(rate),
        "files": [str(path), str(meta_path), str(rec_path)],
        SINGLE_SAMPLE: dropped,
    }
    return check_recording(Recording(str(path), tuple(carriageways), meta))
