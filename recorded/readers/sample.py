"""The project's shipped samples (``shared/data``): the NGSIM and CATS ``tracks.csv.gz``.

:func:`read_sample` reads either (NGSIM's lane rule from
:mod:`drivestyle.recorded.readers.ngsim`; CATS's lane width from its ``summary.json``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from drivestyle.envs.plausibility import LANE_WIDTH_RANGE_M
from drivestyle.recorded.readers.ngsim import (
    NGSIM_MAIN_LANES,
    NGSIM_MAIN_LANES_BY_FREEWAY,
    _left_numbered_lanes,
)
from drivestyle.recorded.readers.shared import (
    _published_columns,
    _published_numbers,
    _published_tracks,
    _read_frame,
    check_lane_lines,
)
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "SAMPLE_MAIN_LANES",
    "read_sample",
]


def _cats_lane_width(summary: Path) -> float:
    """CATS's lane width [m] from ``summary.json`` (3.95 m without one), or a one-line error."""
    import json

    if not summary.is_file():
        return 3.95
    try:
        meta = json.loads(summary.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise TrackError(f"{summary} is not valid JSON ({exc})") from None
    lanes = meta.get("lanes", {}) if isinstance(meta, dict) else None
    w = lanes.get("width_m", 3.95) if isinstance(lanes, dict) else None
    if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w <= 0:
        raise TrackError(f"{summary}: expected 'lanes.width_m', a positive number of metres")
    lo, hi = LANE_WIDTH_RANGE_M
    if not lo <= w <= hi:
        unit = (
            "positions in feet (NGSIM's native unit: its 12 ft lanes are 3.66 m)? convert to "
            "metres (× 0.3048)"
            if w > hi
            else "positions in another unit than metres? convert to metres"
        )
        raise TrackError(
            f"{summary} (lanes.width_m): lanes {w:.3g} m wide, but a road's lanes are "
            f"{lo:g}–{hi:g} m wide: {unit}"
        )
    return float(w)


SAMPLE_MAIN_LANES = {"i80": NGSIM_MAIN_LANES_BY_FREEWAY["i-80"], "us101": NGSIM_MAIN_LANES}
"""Main lanes of the NGSIM sample's freeways by recording prefix (README: I-80 lane 7 and
US-101 lanes 6–8 are ramps or the auxiliary lane)."""


def read_sample(folder: str | Path) -> Recording:
    """A shipped sample's ``tracks.csv.gz`` (``shared/data/ngsim`` or ``cats-av-lanechange``).

    One carriageway per recording (NGSIM ``recording``, CATS ``run_id``); positions are
    already in metres. NGSIM: x along travel and y from the left road edge growing right,
    both at the front centre, lane_id 1 leftmost: x → x − length/2, y → −y, lane = (main
    lanes) − lane_id, −1 for ramps and the auxiliary lane; the lane lines are equal lanes
    fitted through the main lanes' median y. CATS: already our frame (y to the left, y = 0
    the right edge of lane 0, lane k in [k·w, (k+1)·w), w from ``summary.json``, 3.95 m),
    antenna positions, no vehicle sizes (5 m × 2 m); its lane column is kept (ids outside
    0…2 are off the grid).

    Raises:
        FileNotFoundError: no ``tracks.csv.gz`` in ``folder``.
        TrackError: neither sample's columns, or a malformed track (naming the vehicle).
    """
    folder = Path(folder)
    path = folder / "tracks.csv.gz"
    if folder.is_file() or (folder.is_dir() and not path.exists()):
        raise FileNotFoundError(
            f"{folder}: not a shipped sample's folder (one holding tracks.csv.gz, such as "
            "shared/data/ngsim or shared/data/cats-av-lanechange)"
            + ("; a table of tracks is read with --format csv" if folder.is_file() else "")
        )
    df = _read_frame(path, what="a shipped sample's tracks (NGSIM or CATS), gzip-compressed CSV")
    cats = "run_id" in df.columns
    key, t_col = ("run_id", "t_s") if cats else ("recording", "time_s")
    lane_col = "lane" if cats else "lane_id"
    _published_columns(
        df, path, [key, "vehicle_id", t_col, "x_m", "y_m", "v_mps", lane_col], "sample"
    )
    if cats:
        w = _cats_lane_width(Path(folder) / "summary.json")
    carriageways, dropped = [], []
    for name, g in df.groupby(key, sort=True):
        g = g.reset_index(drop=True)
        num = _published_numbers(
            g, path, [t_col, "x_m", "y_m", "v_mps", lane_col], ["vehicle_id"], t_col
        )
        t, lane_id = num[t_col], num[lane_col]
        if cats:
            frames, x, y, lane = np.round(t * 10), num["x_m"], num["y_m"], lane_id
            lines = np.arange(4) * w
            size = np.full(len(g), 5.0), np.full(len(g), 2.0)
        else:
            n_main = SAMPLE_MAIN_LANES.get(str(name).split("_")[0], NGSIM_MAIN_LANES)
            _, slope, intercept, lane = _left_numbered_lanes(num["y_m"], lane_id, n_main)
            lines = np.sort(-(intercept + slope * (np.arange(1, n_main + 2) - 0.5)))
            size = g["length_m"].to_numpy(float), g["width_m"].to_numpy(float)
            frames, x, y = g["frame"].to_numpy(), num["x_m"] - size[0] / 2, -num["y_m"]
        lines = check_lane_lines(lines, path, f"{key} {name}")
        groups, skipped = _published_tracks(path, g["vehicle_id"].to_numpy(), t, frames)
        dropped += [f"{v} ({name})" for v in skipped]
        tracks = [
            Track(
                vid,
                t[r],
                x[r],
                y[r],
                frames[r],
                v=num["v_mps"][r],
                lane=lane[r],
                length=float(np.median(size[0][r])),
                width=float(np.median(size[1][r])),
                source=str(path),
            )
            for vid, r in groups
        ]
        carriageways.append(Carriageway(str(name), tuple(lines), tuple(tracks)))
    meta: dict[str, object] = {
        "format": "sample",
        "dataset": "cats" if cats else "ngsim",
        "units": "metres",
        SINGLE_SAMPLE: dropped,
    }
    return check_recording(Recording(str(path), tuple(carriageways), meta))
