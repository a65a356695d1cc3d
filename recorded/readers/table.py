"""The generic long-format table of tracks (CSV, or Parquet with pyarrow): read and written.

One row per vehicle and sample (:data:`TABLE_COLUMNS`, :data:`TABLE_OPTIONAL`):
:func:`read_table` reads any recording saved so (``drivestyle extract-episodes --format
csv``), :func:`write_table` writes any reader's recording back as such a table and its
lanes file (:mod:`drivestyle.recorded.readers.lanes_file`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.recorded.readers.lanes_file import (
    DIRECTIONS,
    LaneLines,
    _recording_lines,
    load_lanes,
)
from drivestyle.recorded.readers.shared import (
    _check_lane_width,
    _read_frame,
    _warn_outside_road,
    check_lane_lines,
)
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "ROAD_LANES_MAX",
    "TABLE_COLUMNS",
    "TABLE_OPTIONAL",
    "TABLE_TEXT",
    "read_table",
    "write_table",
]

TABLE_COLUMNS = ("id", "t", "x", "y")
"""Columns every generic table has: vehicle id, time [s], position [m] (centre)."""
TABLE_OPTIONAL = ("recording", "v", "heading", "length", "width", "lane", "frame")
"""Columns a generic table may have: the recording's name (vehicle ids are unique within a
recording and may restart in the next), speed [m/s], heading against +x [rad], vehicle size
[m], lane id (any numbering), source frame number."""
TABLE_TEXT = ("recording", "id")
"""Columns read as text: names, not numbers (``007`` stays ``007``)."""
ROAD_LANES_MAX = 50
"""The most lanes the lines every ``lane_width`` may span across a recording's y: a road has
at most a few dozen (both directions); more is a y in another unit or a wrong row."""


def _numeric(df: Any, column: str, path: Path) -> np.ndarray:
    """A column as float64, or a one-line error naming the first non-numeric row's vehicle."""
    import pandas as pd

    values = pd.to_numeric(df[column], errors="coerce").to_numpy(dtype=float)
    bad = df[column].notna().to_numpy() & np.isnan(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise TrackError(
            f"{path}: {_row_vehicle(df, i)}, data row {i + 1}: column {column!r} has the "
            f"non-numeric value {df[column].iloc[i]!r}"
        )
    return values


def _row_vehicle(df: Any, i: int) -> str:
    """'recording r, vehicle v' (or 'vehicle v' without a recording column) of row ``i``."""
    where = f"vehicle {df['id'].iloc[i]}"
    return f"recording {df['recording'].iloc[i]}, {where}" if "recording" in df else where


def _markings_from_lanes(y: np.ndarray, lane: np.ndarray, path: Path | str) -> np.ndarray:
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


def read_table(
    path: str | Path,
    lane_width: float | None = None,
    lane_markings: LaneLines | None = None,
    columns: Mapping[str, str] | None = None,
    default_length: float = 5.0,
    default_width: float = 2.0,
    progress: bool = False,
    lanes: str | Path | None = None,
) -> Recording:
    """A generic long-format table of tracks (CSV, or Parquet with pyarrow) as a recording.

    One row per vehicle and sample: columns ``id``, ``t`` [s], ``x``, ``y`` [m] (the
    vehicle's centre; x along the road, y to its left), optionally ``recording``, ``v``
    [m/s], ``heading`` [rad against +x], ``length``, ``width`` [m], ``lane`` (any ids) and
    ``frame`` (else the frame is t over the recording's median time step). A table may hold
    several recordings (``recording``: vehicle ids and times may restart in each); each gets
    its own carriageways and lane lines. Vehicles that move towards −x drive on the other
    carriageway: their x, y and heading are turned by 180° (x → −x, y → −y, which keeps y
    to the left of travel) and the lane lines with them.

    Carriageways are named so that episode ids (``<carriageway>_<vehicle>_<t_c ms>``) say
    where a lane change was: without a ``recording`` column ``"+x"`` and ``"-x"``; a
    recording all of whose vehicles drive to +x is one carriageway named by the recording
    (as :func:`read_sample` names them); a recording with vehicles driving to −x becomes
    ``"<recording>+x"`` and ``"<recording>-x"`` (those present), so a name never hides
    that its coordinates were turned.

    Lane lines, in the file's y, road edges included (the outermost lines are the edges:
    a vehicle outside them is in no lane): ``lanes`` (a JSON file, :func:`load_lanes`) or
    ``lane_markings`` (one list for every recording, or a mapping recording → list, or →
    ``{"+x": list, "-x": list}`` for a road with a median); else lines every
    ``lane_width`` with y = 0 a line, over each recording's y; else midway between the
    ``lane`` column's lanes (median y per lane). Given lines that leave samples
    outside the road print a warning on stderr naming the vehicles
    (:func:`outside_road_warning`; also in ``meta["outside_road"]``).

    Args:
        path: the ``.csv`` (``.csv.gz``) or ``.parquet`` file.
        lane_width: lane width [m] (lines at multiples of it).
        lane_markings: the lane lines' y in the file's frame [m], increasing: one list, or
            a mapping from each recording to its list (or to ``{"+x": …, "-x": …}``).
        columns: the file's names for the columns above (``{"id": "track_id", …}``).
        default_length: vehicle length without a ``length`` column [m].
        default_width: vehicle width without a ``width`` column [m].
        progress: show a progress bar over the vehicles.
        lanes: a JSON lanes file (:func:`load_lanes`) instead of ``lane_markings``.

    Returns:
        The recording: per recording one carriageway or two, named as above.

    Raises:
        FileNotFoundError: no such file.
        ValueError: an unreadable file, Parquet without pyarrow, missing columns, no rows,
            a non-numeric, missing or repeated value, a row without a vehicle id or a
            recording, a vehicle whose time goes back in file order, lanes no road has
            (feet), lines that do not increase, a recording without lines or lines of a
            recording the table lacks, two of ``lanes``, ``lane_width`` and
            ``lane_markings``, no lane geometry, or a file the readers' checks refuse
            (:func:`~drivestyle.recorded.track_checks.check_recording`: times, speeds or
            headings in another unit); one line naming the file, and the recording,
            vehicle, row and frame where one is at fault.
    """
    import pandas as pd

    path = Path(path)
    if lanes is not None and (lane_width is not None or lane_markings is not None):
        raise TrackError(
            f"{lanes}: lanes and lane_width / lane_markings contradict: give the lane lines once"
        )
    if lane_width is not None and lane_markings is not None:
        raise TrackError(
            f"{path}: lane_width (--lane-width) and lane_markings (--lane-markings) contradict: "
            "give the lane lines once"
        )
    renamed = dict(columns or {})
    df = _read_frame(path, [renamed.get(c, c) for c in TABLE_TEXT])
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
    blank = df["id"].isna().to_numpy() | (df["id"].astype(str).str.strip() == "").to_numpy()
    if blank.any():
        i = int(np.flatnonzero(blank)[0])
        raise TrackError(
            f"{path}: data row {i + 1} (line {i + 2}): no vehicle id (column "
            f"{renamed.get('id', 'id')!r} is empty; {int(blank.sum())} such row(s)): every row "
            "names its vehicle"
        )
    has_recordings = "recording" in df.columns
    if has_recordings and df["recording"].isna().any():
        i = int(np.flatnonzero(df["recording"].isna().to_numpy())[0])
        raise TrackError(
            f"{path}: vehicle {df['id'].iloc[i]}, data row {i + 1}: no recording (a table with "
            "a 'recording' column names the recording of every row)"
        )
    df = df.assign(id=df["id"].astype(str))
    if has_recordings:
        df = df.assign(recording=df["recording"].astype(str))
    present = [c for c in TABLE_COLUMNS[1:] + TABLE_OPTIONAL if c in df.columns]
    data = {c: _numeric(df, c, path) for c in present if c != "recording"}
    ids = df["id"].to_numpy()
    rec_codes, rec_names = pd.factorize(
        df["recording"] if has_recordings else pd.Series("", index=df.index), sort=True
    )
    recordings = [str(r) for r in rec_names]
    t = data["t"]
    # each recording's own sample rate numbers its frames (recordings may differ)
    frame_dt = np.array([_median_step(t[rec_codes == k]) for k in range(len(recordings))])
    frames = data["frame"] if "frame" in data else np.round(t / frame_dt[rec_codes])
    for c in ("t", "x", "y", "v", "heading", "lane"):
        if c in data and not np.all(np.isfinite(data[c])):
            i = int(np.flatnonzero(~np.isfinite(data[c]))[0])
            raise TrackError(
                f"{path}: {_row_vehicle(df, i)}, frame {_frame(frames[i])}: {c} is missing or "
                "not finite"
            )
    lines_from = None
    if lanes is not None:
        lane_markings, lines_from = load_lanes(lanes), str(lanes)
        given = _recording_lines(lane_markings, recordings, has_recordings, Path(lanes), "lanes")
    elif lane_markings is not None:
        lines_from = "lane_markings (--lane-markings)"
        given = _recording_lines(lane_markings, recordings, has_recordings, path, "lane_markings")
    elif lane_width is not None:
        if not (math.isfinite(lane_width) and lane_width > 0):
            raise TrackError(f"{path}: lane_width must be a positive number [m], got {lane_width}")
        _check_lane_width(lane_width, path, f"lane_width (--lane-width) {lane_width:g}")
        given = {}
        for k, name in enumerate(recordings):
            y = data["y"][rec_codes == k]
            lo, hi = math.floor(y.min() / lane_width), math.ceil(y.max() / lane_width)
            if hi - lo > ROAD_LANES_MAX:  # before the lines are allocated
                i = int(np.flatnonzero(rec_codes == k)[np.argmax(np.abs(y - np.median(y)))])
                raise TrackError(
                    f"{path}: the vehicles' y spans {y.min():.4g} to {y.max():.4g} m, "
                    f"{hi - lo} lanes of lane_width (--lane-width) {lane_width:g} m, more than "
                    f"a road's {ROAD_LANES_MAX} ({_row_vehicle(df, i)}, data row {i + 1}: y = "
                    f"{data['y'][i]:.4g}): y in another unit, or a wrong row?"
                )
            lines = np.arange(lo, max(hi, lo + 2) + 1) * lane_width
            lines = check_lane_lines(lines, path, f"lane_width (--lane-width) {lane_width:g}")
            given[name] = dict.fromkeys(DIRECTIONS, lines)
    elif "lane" in data:
        given = {}  # per carriageway, from its own lanes
    else:
        raise TrackError(
            f"{path}: no lane geometry: pass lane_width (--lane-width), lane_markings "
            "(--lane-markings) or lanes (--lanes), or give the table a 'lane' column"
        )
    in_file = (ids, rec_codes, t)
    order = np.lexsort((t, ids, rec_codes))
    ids, frames, rec_codes = ids[order], frames[order], rec_codes[order]
    data = {c: a[order] for c, a in data.items()}
    same_vehicle = (ids[1:] == ids[:-1]) & (rec_codes[1:] == rec_codes[:-1])
    same = np.flatnonzero(same_vehicle & (np.diff(data["t"]) == 0))
    if same.size:
        i = int(same[0]) + 1
        where = f"recording {recordings[rec_codes[i]]}, " if has_recordings else ""
        raise TrackError(
            f"{path}: {where}vehicle {ids[i]}, frame {_frame(frames[i])}: two rows at t = "
            f"{data['t'][i]:g} s"
        )
    _check_time_order(path, df, *in_file)
    cut = np.flatnonzero(~same_vehicle) + 1
    starts, stops = np.r_[0, cut], np.r_[cut, ids.size]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(starts), desc="reading", unit="vehicle")
    carriageways: list[Carriageway] = []
    named: dict[str, str] = {}  # carriageway → the recording (and direction) it holds
    dropped: list[str] = []  # vehicles of a single sample
    try:
        for k, name in enumerate(recordings):
            mine = rec_codes[starts] == k
            every = list(zip(starts[mine], stops[mine], strict=True))
            # a vehicle of one sample has no motion, no lane change: skipped, noted
            vehicles = [(a, b) for a, b in every if b - a >= 2]
            dropped += [
                f"{ids[a]} (recording {name})" if has_recordings else str(ids[a])
                for a, b in every
                if b - a < 2
            ]
            roads = _table_carriageways(
                name if has_recordings else None, vehicles, ids, frames, data, given.get(name),
                path, default_length, default_width, lines_from or str(path),
            )  # fmt: skip
            for road in roads:
                said = f"recording {name!r}" + (
                    "" if road.name == name else f" (its traffic to {road.name[len(name) :]})"
                )
                if road.name in named:
                    raise TrackError(
                        f"{path}: {named[road.name]} and {said} would both be carriageway "
                        f"{road.name!r} (a two-way recording's traffic is '<recording>+x' and "
                        "'<recording>-x'): their vehicles and episode ids would mix; rename one "
                        "recording"
                    )
                named[road.name] = said
            carriageways += roads
            if bar is not None:
                bar.update(len(every))
    finally:
        if bar is not None:
            bar.close()  # before any error: the message gets a line of its own
    meta: dict[str, object] = {
        "format": "csv",
        "frame_dt_s": _median_step(t),
        "vehicles": len(starts),
        SINGLE_SAMPLE: dropped,
    }
    if has_recordings:
        meta["recordings"] = recordings
    checked = check_recording(Recording(str(path), tuple(carriageways), meta))
    if lines_from is not None:  # after the checks: a file they refuse gets its error alone
        checked.meta["outside_road"] = _warn_outside_road(carriageways, lines_from)
    return checked


def write_table(
    recording: Recording, csv_path: str | Path, lanes_path: str | Path
) -> tuple[Path, Path]:
    """A recording as a generic table and its lanes file, which :func:`read_table` reads back.

    One row per sample: ``recording`` (the carriageway's name), ``id``, ``t``, ``x``, ``y``,
    ``v`` and ``heading`` (when every track has them), ``length``, ``width``, ``lane`` (when
    every track has one), ``frame``; all in the road frame, so every vehicle drives to +x
    and ``read_table(csv_path, lanes=lanes_path)`` gives each carriageway back under its
    name with its lines (the episodes of both recordings are the same). The lanes file
    (:func:`load_lanes`) maps each carriageway to its lane lines. Numbers are written in
    full precision. One thing does not come back: lane ids beyond the road's edges (CATS
    numbers lanes off its grid −2, −3, …) read back as −1 right of the road and the lane
    count left of it (:func:`read_table` places a lane id by its median y); the
    extraction treats both alike, as off the road.

    Args:
        recording: any reader's recording.
        csv_path: the table to write (``.csv``; ``.csv.gz`` compressed).
        lanes_path: the JSON lanes file to write.

    Returns:
        (csv_path, lanes_path).

    Raises:
        ValueError: a track that some tracks' columns lack (e.g. a speed), or one that ends
            behind its start (read back, it would drive to −x: another carriageway); one line
            naming the carriageway and vehicle.
    """
    import json

    import pandas as pd

    tracks = [(road, tr) for road in recording.carriageways for tr in road.tracks]
    optional = {}
    for column in ("v", "heading", "lane"):
        has = [getattr(tr, column) is not None for _, tr in tracks]
        if any(has) and not all(has):
            road, tr = tracks[has.index(False)]
            raise ValueError(
                f"{recording.source}: carriageway {road.name!r}, vehicle {tr.vehicle_id} has no "
                f"{column} while others have one: a table's column is every vehicle's"
            )
        optional[column] = all(has) and bool(tracks)
    frames = []
    for road, tr in tracks:
        if tr.x[-1] < tr.x[0]:
            raise ValueError(
                f"{recording.source}: carriageway {road.name!r}, vehicle {tr.vehicle_id} ends "
                f"behind its start (x from {tr.x[0]:g} to {tr.x[-1]:g} m): read back it would "
                "drive to −x, on another carriageway"
            )
        columns: dict[str, object] = {
            "recording": road.name, "id": tr.vehicle_id, "t": tr.t, "x": tr.x, "y": tr.y,
        }  # fmt: skip
        columns |= {c: getattr(tr, c) for c in ("v", "heading") if optional[c]}
        columns |= {"length": tr.length, "width": tr.width}
        if optional["lane"]:
            columns["lane"] = tr.lane
        columns["frame"] = tr.frames
        frames.append(pd.DataFrame(columns))
    csv_path, lanes_path = Path(csv_path), Path(lanes_path)
    pd.concat(frames, ignore_index=True).to_csv(csv_path, index=False, float_format="%.17g")
    lanes = {road.name: list(road.markings) for road in recording.carriageways}
    lanes_path.write_text(json.dumps(lanes, indent=1) + "\n")
    return csv_path, lanes_path


def _check_time_order(
    path: Path, df: Any, ids: np.ndarray, rec_codes: np.ndarray, t: np.ndarray
) -> None:
    """Refuse a vehicle whose rows' times go back in file order (one line naming the rows).

    A vehicle's rows are read in file order, and its time must not fall from one row to
    the next (rows of different vehicles may interleave; equal times are the caller's
    "two rows" error). Sorting them instead would silently move a sample with a swapped
    or mistyped time stamp, e.g. across a lane change.
    """
    rows = np.lexsort((np.arange(t.size), ids, rec_codes))  # per vehicle, in file order
    same = (ids[rows][1:] == ids[rows][:-1]) & (rec_codes[rows][1:] == rec_codes[rows][:-1])
    back = np.flatnonzero(same & (np.diff(t[rows]) < 0))
    if back.size:
        i, before = int(rows[back[0] + 1]), int(rows[back[0]])
        raise TrackError(
            f"{path}: {_row_vehicle(df, i)}, data row {i + 1}: t = {t[i]:g} s comes after "
            f"t = {t[before]:g} s (data row {before + 1}): a vehicle's rows must be in time "
            "order (rows of different vehicles may interleave); sort the table by vehicle and "
            "time if its row order means nothing"
        )


def _median_step(t: np.ndarray) -> float:
    """The median step between a table's distinct finite times [s] (1 s with one time)."""
    steps = np.diff(np.unique(t[np.isfinite(t)]))
    return float(np.median(steps)) if steps.size else 1.0


def _table_carriageways(
    recording: str | None,
    vehicles: Sequence[tuple[int, int]],
    ids: np.ndarray,
    frames: np.ndarray,
    data: dict[str, np.ndarray],
    markings: Mapping[str, np.ndarray] | None,
    path: Path,
    default_length: float,
    default_width: float,
    lines_from: str,
) -> list[Carriageway]:
    """One recording's carriageways (:func:`read_table`: directions, names, lane lines).

    Args:
        recording: its name, None for a table without a ``recording`` column.
        vehicles: each vehicle's rows [a, b) in the sorted columns.
        ids: vehicle id per row.
        frames: frame per row.
        data: the numeric columns, sorted like ``ids``.
        markings: the lane lines in the file's y per direction [m], None: from the ``lane``
            column.
        path: the table (for messages and the tracks' source).
        default_length: vehicle length without a ``length`` column [m].
        default_width: vehicle width without a ``width`` column [m].
        lines_from: where given lines came from (a direction without lines is its error).
    """
    # the driving direction of each vehicle: its net advance along x
    sign = np.array([np.sign(data["x"][b - 1] - data["x"][a]) or 1.0 for a, b in vehicles])
    both = bool(np.any(sign > 0) and np.any(sign < 0))
    out = []
    for direction, s in (("+x", 1.0), ("-x", -1.0)):
        mine = [v for v, g in zip(vehicles, sign, strict=True) if g == s]
        if not mine:
            continue
        if recording is None:
            name = direction
        else:
            name = recording if s > 0 and not both else f"{recording}{direction}"
        rows = np.concatenate([np.arange(a, b) for a, b in mine])
        y_rows = s * data["y"][rows]
        if markings is not None:
            if direction not in markings:
                raise TrackError(
                    f"{lines_from}: recording {recording!r} has vehicles driving to {direction} "
                    f"(vehicle {ids[mine[0][0]]}, …) but lane lines only for "
                    f"{', '.join(markings)}"
                )
            lines = np.sort(s * markings[direction]) + 0.0
        else:
            where = str(path) if recording is None else f"{path}, recording {recording!r}"
            lines = check_lane_lines(
                _markings_from_lanes(y_rows, data["lane"][rows], where),
                where,
                "from the lane column",
            )
        ids_here = index = None
        if "lane" in data:
            # the file's lane ids in this frame's numbering: by median y, rightmost first
            lane = data["lane"][rows]
            ids_here = np.unique(lane)
            centres = np.array([np.median(y_rows[lane == k]) for k in ids_here])
            if markings is not None:
                # with given lines, a lane id is the lane its median y lies in
                index = np.searchsorted(lines, centres) - 1
            else:
                index = np.argsort(np.argsort(centres))
        tracks = []
        for a, b in mine:
            heading = None
            if "heading" in data:
                h = data["heading"][a:b] + (0.0 if s > 0 else math.pi)
                heading = np.angle(np.exp(1j * h))
            lane_index = None
            if ids_here is not None and index is not None:
                lane_index = index[np.searchsorted(ids_here, data["lane"][a:b])].astype(float)
            tracks.append(
                Track(
                    vehicle_id=str(ids[a]),
                    t=data["t"][a:b],
                    x=s * data["x"][a:b],
                    y=s * data["y"][a:b],
                    frames=frames[a:b],
                    v=data["v"][a:b] if "v" in data else None,
                    heading=heading,
                    lane=lane_index,
                    length=_size(data, "length", a, b, default_length),
                    width=_size(data, "width", a, b, default_width),
                    source=str(path),
                )
            )
        out.append(
            Carriageway(
                name,
                tuple(float(m) for m in lines),
                tuple(tracks),
                heading_offset=0.0 if s > 0 else math.pi,
            )
        )
    return out


def _frame(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else f"{value:g}"


def _size(data: dict[str, np.ndarray], column: str, a: int, b: int, default: float) -> float:
    """A vehicle's length or width: the median of its column, else ``default`` [m]."""
    if column not in data:
        return default
    values = data[column][a:b]
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else default
