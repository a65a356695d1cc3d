"""Readers of published trajectory formats into a :class:`~drivestyle.envs.tracks.Recording`.

Every reader keeps its source's conventions here, at the edge, and returns tracks in the
one road frame of :mod:`drivestyle.envs.tracks` (x along travel, y to the left, lane 0
rightmost, vehicle centres, SI units). :data:`READERS` maps a format name to its reader.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import LANE_WIDTH_RANGE_M
from drivestyle.envs.tracks import Carriageway, Recording, Track, TrackError

__all__ = ["READERS", "TABLE_COLUMNS", "TABLE_OPTIONAL", "read_table"]

READERS: dict[str, Callable[..., Recording]] = {}
"""Format name → reader (``READERS[name](path, ...)`` returns a :class:`Recording`)."""


# ------------------------------------------------------------------------ generic long format
TABLE_COLUMNS = ("id", "t", "x", "y")
"""Columns every generic table has: vehicle id, time [s], position [m] (centre)."""
TABLE_OPTIONAL = ("v", "heading", "length", "width", "lane", "frame")
"""Columns a generic table may have: speed [m/s], heading against +x [rad], vehicle size
[m], lane id (any numbering), source frame number."""
PARQUET_SUFFIXES = (".parquet", ".pq")
"""File endings read as Parquet (every other ending is read as CSV, gzip included)."""


def _read_frame(path: Path) -> Any:
    """The file as a pandas DataFrame (CSV or Parquet), or a one-line error naming it."""
    import pandas as pd

    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file (a CSV or Parquet table of tracks)")
    if path.suffix.lower() in PARQUET_SUFFIXES:
        try:
            return pd.read_parquet(path)
        except ImportError:
            raise ValueError(
                f"{path}: reading Parquet needs pyarrow, which is not installed: "
                "pip install pyarrow (or save the table as CSV)"
            ) from None
        except (OSError, ValueError) as exc:
            raise ValueError(f"{path} is not a readable Parquet file ({exc})") from None
    try:
        return pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path} is empty (no header, no rows)") from None
    except (pd.errors.ParserError, UnicodeDecodeError, EOFError, OSError) as exc:
        raise ValueError(f"{path} is not a readable CSV ({exc})") from None


def _numeric(df: Any, column: str, path: Path) -> np.ndarray:
    """A column as float64, or a one-line error naming the first non-numeric row's vehicle."""
    import pandas as pd

    values = pd.to_numeric(df[column], errors="coerce").to_numpy(dtype=float)
    bad = df[column].notna().to_numpy() & np.isnan(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TrackError(
            f"{path}: vehicle {df['id'].iloc[i]}, data row {i + 1}: column {column!r} has the "
            f"non-numeric value {df[column].iloc[i]!r}"
        )
    return values


def _markings_from_lanes(y: np.ndarray, lane: np.ndarray, path: Path) -> np.ndarray:
    """Lane lines from a lane column: midway between lanes' median y, half a spacing outside."""
    ids = np.unique(lane)
    centres = np.array([np.median(y[lane == k]) for k in ids])
    order = np.argsort(centres)
    centres = centres[order]
    if centres.size < 2 or np.any(np.diff(centres) <= 0):
        raise TrackError(
            f"{path}: the lane column names {centres.size} lane(s) with distinct median y; "
            "need 2 or more to place the lane lines (or pass lane_width / lane_markings)"
        )
    inner = (centres[1:] + centres[:-1]) / 2
    first, last = centres[0] - (inner[0] - centres[0]), centres[-1] + (centres[-1] - inner[-1])
    return np.concatenate([[first], inner, [last]])


def _check_markings(markings: np.ndarray, path: Path, what: str) -> np.ndarray:
    """Lane lines that increase and lanes a road has (metres), or a one-line error."""
    if markings.size < 3 or not np.all(np.isfinite(markings)) or np.any(np.diff(markings) <= 0):
        raise TrackError(
            f"{path}: lane lines ({what}) must be 3 or more increasing numbers [m], got "
            f"{[round(float(m), 3) for m in markings]}"
        )
    lo, hi = LANE_WIDTH_RANGE_M
    widths = np.diff(markings)
    if widths.min() < lo or widths.max() > hi:
        w = float(widths.max() if widths.max() > hi else widths.min())
        unit = "positions in feet? convert to metres (× 0.3048)" if w > hi else "metres?"
        raise TrackError(
            f"{path}: lanes {w:.3g} m wide ({what}), but a road's lanes are {lo:g}–{hi:g} m "
            f"wide: {unit}"
        )
    return markings


def read_table(
    path: str | Path,
    lane_width: float | None = None,
    lane_markings: Sequence[float] | None = None,
    columns: Mapping[str, str] | None = None,
    default_length: float = 5.0,
    default_width: float = 2.0,
    progress: bool = False,
) -> Recording:
    """A generic long-format table of tracks (CSV, or Parquet with pyarrow) as a recording.

    One row per vehicle and sample: columns ``id``, ``t`` [s], ``x``, ``y`` [m] (the
    vehicle's centre; x along the road, y to its left), optionally ``v`` [m/s],
    ``heading`` [rad against +x], ``length``, ``width`` [m], ``lane`` (any ids) and
    ``frame`` (else the frame is t over the file's median time step). Vehicles that move
    towards −x drive on the other carriageway: their x, y and heading are turned by 180°
    (x → −x, y → −y, which keeps y to the left of travel) and the lane lines with them.
    Lane lines, in the file's y: ``lane_markings``; else lines every ``lane_width`` with
    y = 0 a line; else midway between the ``lane`` column's lanes (median y per lane).

    Args:
        path: the ``.csv`` (``.csv.gz``) or ``.parquet`` file.
        lane_width: lane width [m] (lines at multiples of it).
        lane_markings: the lane lines' y in the file's frame [m], increasing.
        columns: the file's names for the columns above (``{"id": "track_id", …}``).
        default_length: vehicle length without a ``length`` column [m].
        default_width: vehicle width without a ``width`` column [m].
        progress: show a progress bar over the vehicles.

    Returns:
        The recording: one carriageway (``"+x"``) or two (``"+x"``, ``"-x"``).

    Raises:
        FileNotFoundError: no such file.
        ValueError: an unreadable file, Parquet without pyarrow, missing columns, no rows,
            a non-numeric, missing or repeated value, lanes no road has (feet) or no lane
            geometry; one line naming the file, and the vehicle and frame where one is at
            fault.
    """
    path = Path(path)
    df = _read_frame(path)
    if columns:
        df = df.rename(columns={theirs: ours for ours, theirs in columns.items()})
    missing = [c for c in TABLE_COLUMNS if c not in df.columns]
    if missing:
        raise TrackError(
            f"{path}: missing column(s) {', '.join(map(repr, missing))}; a track table has "
            f"{', '.join(TABLE_COLUMNS)} (and optionally {', '.join(TABLE_OPTIONAL)}); "
            f"it has {list(df.columns)}"
        )
    if df.empty:
        raise TrackError(f"{path} has a header but no rows")
    df = df.assign(id=df["id"].astype(str))
    present = [c for c in TABLE_COLUMNS[1:] + TABLE_OPTIONAL if c in df.columns]
    data = {c: _numeric(df, c, path) for c in present}
    ids = df["id"].to_numpy()
    t = data["t"]
    steps = np.diff(np.sort(np.unique(t[np.isfinite(t)])))
    frame_dt = float(np.median(steps)) if steps.size else 1.0
    frames = data["frame"] if "frame" in data else np.round(t / frame_dt)
    for c in ("t", "x", "y", "v", "heading"):
        if c in data and not np.all(np.isfinite(data[c])):
            i = int(np.flatnonzero(~np.isfinite(data[c]))[0])
            raise TrackError(
                f"{path}: vehicle {ids[i]}, frame {_frame(frames[i])}: {c} is missing or not finite"
            )
    order = np.lexsort((t, ids))
    ids, frames = ids[order], frames[order]
    data = {c: a[order] for c, a in data.items()}
    cut = np.flatnonzero(ids[1:] != ids[:-1]) + 1
    starts, stops = np.r_[0, cut], np.r_[cut, ids.size]
    same = np.flatnonzero((ids[1:] == ids[:-1]) & (np.diff(data["t"]) == 0))
    if same.size:
        i = int(same[0]) + 1
        raise TrackError(
            f"{path}: vehicle {ids[i]}, frame {_frame(frames[i])}: two rows at t = "
            f"{data['t'][i]:g} s"
        )
    # the driving direction of each vehicle: its net advance along x
    sign = np.array(
        [
            np.sign(data["x"][b - 1] - data["x"][a]) or 1.0
            for a, b in zip(starts, stops, strict=True)
        ]
    )
    row_sign = np.repeat(sign, stops - starts)
    if lane_markings is not None:
        markings = _check_markings(np.asarray(lane_markings, float), path, "lane_markings")
    elif lane_width is not None:
        if not (math.isfinite(lane_width) and lane_width > 0):
            raise TrackError(f"{path}: lane_width must be a positive number [m], got {lane_width}")
        y = data["y"]
        lo, hi = math.floor(y.min() / lane_width), math.ceil(y.max() / lane_width)
        markings = np.arange(lo, max(hi, lo + 2) + 1) * lane_width
        markings = _check_markings(markings, path, f"lane_width {lane_width:g}")
    elif "lane" in data:
        markings = None  # per carriageway, from its own lanes
    else:
        raise TrackError(
            f"{path}: no lane geometry: pass lane_width (--lane-width) or lane_markings "
            "(--lane-markings), or give the table a 'lane' column"
        )
    carriageways = []
    for direction, s in (("+x", 1.0), ("-x", -1.0)):
        rows = row_sign == s
        if not rows.any():
            continue
        y = s * data["y"][rows]
        if markings is not None:
            lines = np.sort(s * markings) + 0.0
        else:
            lines = _check_markings(
                _markings_from_lanes(y, data["lane"][rows], path), path, "from the lane column"
            )
        lane_index = None
        if "lane" in data:
            # the file's lane ids in this frame's numbering: by median y, rightmost first
            lane = data["lane"][rows]
            ids_here = np.unique(lane)
            centres = np.array([np.median(y[lane == k]) for k in ids_here])
            rank = dict(zip(ids_here, np.argsort(np.argsort(centres)), strict=True))
            if markings is not None:
                # with given lines, a lane id is the lane its median y lies in
                rank = dict(zip(ids_here, np.searchsorted(lines, centres) - 1, strict=True))
            lane_index = np.array([rank[k] for k in lane], dtype=float)
        tracks = []
        where = np.flatnonzero(rows)
        vehicles = [(a, b) for a, b, g in zip(starts, stops, sign, strict=True) if g == s]
        if progress:
            from tqdm import tqdm

            vehicles = tqdm(vehicles, desc=f"reading {direction}", unit="vehicle")
        offset = {int(r): k for k, r in enumerate(where)}
        for a, b in vehicles:
            k0 = offset[int(a)]
            sl = slice(k0, k0 + (b - a))
            vid = str(ids[a])
            heading = None
            if "heading" in data:
                h = data["heading"][a:b] + (0.0 if s > 0 else math.pi)
                heading = np.angle(np.exp(1j * h))
            tracks.append(
                Track(
                    vehicle_id=vid,
                    t=data["t"][a:b],
                    x=s * data["x"][a:b],
                    y=y[sl],
                    frames=frames[a:b],
                    v=data["v"][a:b] if "v" in data else None,
                    heading=heading,
                    lane=None if lane_index is None else lane_index[sl],
                    length=_size(data, "length", a, b, default_length),
                    width=_size(data, "width", a, b, default_width),
                    source=str(path),
                )
            )
        carriageways.append(Carriageway(direction, tuple(float(m) for m in lines), tuple(tracks)))
    return Recording(
        source=str(path),
        carriageways=tuple(carriageways),
        meta={"format": "csv", "frame_dt_s": frame_dt, "vehicles": len(starts)},
    )


READERS["csv"] = read_table


def _frame(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else f"{value:g}"


def _size(data: dict[str, np.ndarray], column: str, a: int, b: int, default: float) -> float:
    """A vehicle's length or width: the median of its column, else ``default`` [m]."""
    if column not in data:
        return default
    values = data[column][a:b]
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else default
