"""Readers of published trajectory formats into a :class:`~drivestyle.recorded.tracks.Recording`.

Every reader keeps its source's conventions here, at the edge, and returns tracks in the
one road frame of :mod:`drivestyle.recorded.tracks` (x along travel, y to the left, lane 0
rightmost, vehicle centres, SI units), checked by their physics by the one home of the
readers' rules, :func:`~drivestyle.recorded.track_checks.check_recording`, which every reader
calls last. Every CSV is read through :func:`_read_csv` (one-line messages for empty,
binary and non-UTF-8 files). :data:`READERS` maps a format name to its reader.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import LANE_WIDTH_RANGE_M
from drivestyle.envs.units import FOOT
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "INTERACTION_COLUMNS",
    "LEVELX_TRACK_COLUMNS",
    "NGSIM_COLUMNS",
    "READERS",
    "TABLE_COLUMNS",
    "TABLE_OPTIONAL",
    "load_lanes",
    "outside_road",
    "outside_road_warning",
    "read_interaction",
    "read_levelx",
    "read_ngsim",
    "read_sample",
    "read_table",
    "write_table",
]

READERS: dict[str, Callable[..., Recording]] = {}
"""Format name → reader (``READERS[name](path, ...)`` returns a :class:`Recording`)."""


# ------------------------------------------------------------------------ generic long format
TABLE_COLUMNS = ("id", "t", "x", "y")
"""Columns every generic table has: vehicle id, time [s], position [m] (centre)."""
TABLE_OPTIONAL = ("recording", "v", "heading", "length", "width", "lane", "frame")
"""Columns a generic table may have: the recording's name (vehicle ids are unique within a
recording and may restart in the next), speed [m/s], heading against +x [rad], vehicle size
[m], lane id (any numbering), source frame number."""
TABLE_TEXT = ("recording", "id")
"""Columns read as text: names, not numbers (``007`` stays ``007``)."""
PARQUET_SUFFIXES = (".parquet", ".pq")
"""File endings read as Parquet (every other ending is read as CSV, gzip included)."""
ROAD_LANES_MAX = 50
"""The most lanes the lines every ``lane_width`` may span across a recording's y: a road has
at most a few dozen (both directions); more is a y in another unit or a wrong row."""
OUTSIDE_WARN_VEHICLES = 5
"""Vehicles the outside-the-road warning names (the most affected first; the rest counted)."""

DIRECTIONS = ("+x", "-x")
"""The driving directions of a table's carriageways (keys of per-direction lane lines)."""
RoadLines = Sequence[float] | Mapping[str, Sequence[float]]
"""One recording's lane lines' y in the table's frame [m], road edges included: one list
for both directions, or ``{"+x": [...], "-x": [...]}`` (a road with a median)."""
LaneLines = Sequence[float] | Mapping[str, RoadLines]
"""Lane lines of a table: one list for every recording, or per recording."""


def _utf16_without_bom(head: bytes) -> bool:
    """Whether bytes are mostly ASCII text in UTF-16 without a byte-order mark.

    Every other byte is NUL then, the NULs all at even or all at odd offsets.
    """
    pairs = len(head) // 2
    if pairs < 4:
        return False
    even, odd = head[0 : 2 * pairs : 2], head[1 : 2 * pairs : 2]
    return max(even.count(0), odd.count(0)) >= 0.9 * pairs > min(even.count(0), odd.count(0))


def _not_text(path: Path) -> str:
    """What a file that is not UTF-8 is: UTF-16/32, binary (NUL bytes) or another encoding.

    Said with the first byte that is not UTF-8, its offset and line in the file (binary,
    another 8-bit encoding).
    """
    import codecs
    import gzip

    opener = gzip.open if path.suffix.lower() == ".gz" else open
    decoder = codecs.getincrementaldecoder("utf-8")()
    seen, lines, binary, head = 0, 1, False, b""
    where = "a byte that is not UTF-8"
    try:
        with opener(path, "rb") as f:
            while chunk := f.read(1 << 20):
                head = head or chunk[:8192]
                binary |= seen == 0 and b"\x00" in chunk[:8192]
                try:
                    decoder.decode(chunk)
                except UnicodeDecodeError as exc:
                    k = exc.start
                    line = lines + chunk[:k].count(b"\n")
                    where = f"byte 0x{chunk[k]:02x} at offset {seen + k}, line {line}"
                    break
                seen, lines = seen + len(chunk), lines + chunk.count(b"\n")
    except OSError:
        pass
    if head.startswith((codecs.BOM_UTF32_LE, codecs.BOM_UTF32_BE)):
        return "is UTF-32 text, not UTF-8: save it as UTF-8"
    if head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)) or _utf16_without_bom(head):
        return (
            "is UTF-16 text (as Excel's 'Unicode text' and Windows tools save it), not UTF-8: "
            "save it as UTF-8"
        )
    if binary:
        return f"is a binary file, not text ({where})"
    return (
        f"is not UTF-8 text ({where}): text in another encoding (latin-1, Windows-1252?); "
        "save it as UTF-8"
    )


def _need_file(path: Path, what: str) -> None:
    """Refuse a missing file, or a folder where a file is expected (one line naming it).

    Args:
        path: the file.
        what: what it should be, for the message (e.g. "a CSV or Parquet table of tracks").

    Raises:
        IsADirectoryError: a folder.
        FileNotFoundError: nothing there.
    """
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a folder, not a file ({what}): pass the file itself")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file ({what})")


def _read_csv(path: Path, what: str, **options: Any) -> Any:
    """``pandas.read_csv`` of a reader's file, or a one-line error naming it and what it is.

    Never a decoder's or parser's words alone: the message says what the file is (empty,
    binary, another encoding, not gzip, not CSV) and what was expected.

    Args:
        path: the file (``.gz`` decompressed).
        what: what the file should be, for the message (e.g. "an NGSIM trajectory file").
        options: passed to ``pandas.read_csv``.

    Raises:
        ValueError: an empty or blank file, a binary file or text not in UTF-8, a file that
            is not gzip though named so, or not CSV.
    """
    import gzip
    import zlib

    import pandas as pd

    try:
        return pd.read_csv(path, **options)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path} is empty (no header, no rows): expected {what}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path} {_not_text(path)}; expected {what}") from None
    except (gzip.BadGzipFile, zlib.error, EOFError) as exc:
        raise ValueError(f"{path} is not a readable gzip file ({exc}); expected {what}") from None
    except pd.errors.ParserError as exc:
        said = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"{path} is not a readable CSV ({said}); expected {what}") from None


def _read_frame(
    path: Path,
    text: Sequence[str] = (),
    what: str = "a CSV table of tracks (columns id, t, x, y, …)",
) -> Any:
    """The file as a pandas DataFrame (CSV or Parquet), or a one-line error naming it.

    ``text``: columns of a CSV read as text, not parsed as numbers; ``what``: what the file
    should be, for messages.
    """
    import pandas as pd

    if path.is_dir() and (path / "tracks.csv.gz").is_file():
        raise IsADirectoryError(
            f"{path} is a folder, not a file (a CSV or Parquet table of tracks): a shipped "
            "sample's folder? --format sample reads it"
        )
    _need_file(path, "a CSV or Parquet table of tracks")
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
    df = _read_csv(path, what, dtype=dict.fromkeys(text, str))
    if df.empty:
        raise ValueError(f"{path} has a header but no rows")
    return df


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


def check_lane_lines(markings: np.ndarray, path: Path | str, what: str) -> np.ndarray:
    """Lane lines that increase and lanes a road has (metres), or a one-line error.

    Args:
        markings: the lines' y [m], road edges included, shape (n,).
        path: the file (or the option) that gave them, first in the message.
        what: what they are called there, in the message's parentheses.
    """
    if markings.size < 3 or not np.all(np.isfinite(markings)) or np.any(np.diff(markings) <= 0):
        raise TrackError(
            f"{path}: lane lines ({what}) must be 3 or more increasing numbers [m], road "
            f"edges included, got {[round(float(m), 3) for m in markings]}"
        )
    lo, hi = LANE_WIDTH_RANGE_M
    widths = np.diff(markings)
    if widths.min() < lo or widths.max() > hi:
        _check_lane_width(float(widths.max() if widths.max() > hi else widths.min()), path, what)
    return markings


def _check_lane_width(w: float, path: Path | str, what: str) -> float:
    """A lane width a road has (:data:`LANE_WIDTH_RANGE_M`, metres), or a one-line error.

    The one range of every lane width, given or between given lines: checked before any
    line is computed from it (``lane_width=1e308`` would overflow).
    """
    lo, hi = LANE_WIDTH_RANGE_M
    if lo <= w <= hi:
        return w
    if lo <= w * FOOT <= hi:
        unit = "positions in feet? convert to metres (× 0.3048)"
    elif w < lo:
        unit = "metres?"
    else:
        unit = "lane widths are in metres"
    raise TrackError(
        f"{path}: lanes {w:.3g} m wide ({what}), but a road's lanes are {lo:g}–{hi:g} m wide: "
        f"{unit}"
    )


LANES_FILE = "a JSON lanes file: each recording's lane lines' y [m]"
"""What :func:`load_lanes` reads, for messages."""


def load_lanes(path: str | Path) -> list[float] | dict[str, list[float] | dict[str, list[float]]]:
    """A lanes file: every recording's lane lines, road edges included.

    JSON: an object mapping each recording (the table's ``recording`` column) to its lane
    lines' y [m] in the table's frame, e.g. ``{"r1": [0, 3.6, 7.2, 10.8], "r2": [...]}``,
    or one list for every recording. A recording with traffic both ways takes one list for
    both directions, or ``{"+x": [...], "-x": [...]}``: each direction's lines, still in the
    table's frame (a median between the roads is no lane). The outermost lines are the
    road edges: a table's lanes are the spaces between consecutive lines, so lines without
    the edges lose the outer lanes and their lane changes (:func:`read_table` warns of
    samples outside).

    Args:
        path: the ``.json`` file.

    Returns:
        The lines per recording (a dict) or the lines of every recording (a list) [m], as
        written (:func:`read_table` checks that they increase and match the recordings).

    Raises:
        FileNotFoundError: no such file.
        TrackError: not UTF-8 text, not JSON, a key twice, neither an object nor a list, or
            a value that is neither a list of numbers nor an object of directions; one line
            naming the file (and the recording or key).
    """
    import json

    path = Path(path)
    _need_file(path, LANES_FILE)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise TrackError(f"{path} {_not_text(path)}; expected {LANES_FILE}") from None

    def once(pairs: list[tuple[str, object]]) -> dict[str, object]:
        # JSON keeps the last of two equal keys: a recording's lines given twice would be
        # read silently as its second
        seen: dict[str, object] = {}
        for key, value in pairs:
            if key in seen:
                raise TrackError(
                    f"{path}: the key {key!r} appears twice (JSON would keep the second, "
                    f"{json.dumps(value)[:60]}, silently): give each recording's lines once"
                )
            seen[key] = value
        return seen

    if not text.strip():
        raise TrackError(f"{path} is empty: expected {LANES_FILE}")
    try:
        data = json.loads(text, object_pairs_hook=once)
    except json.JSONDecodeError as exc:
        raise TrackError(
            f"{path} is not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno}); "
            f"expected {LANES_FILE}"
        ) from None

    def lines(value: object, where: str) -> list[float]:
        if not isinstance(value, list):
            raise TrackError(
                f"{path}: {where}: expected a list of the lane lines' y [m], got "
                f"{json.dumps(value)[:60]}"
            )
        for v in value:
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise TrackError(f"{path}: {where}: {json.dumps(v)[:60]} is not a number [m]")
        return [float(v) for v in value]

    def road(value: object, where: str) -> list[float] | dict[str, list[float]]:
        if not isinstance(value, dict):
            return lines(value, where)
        odd = [k for k in value if k not in DIRECTIONS]
        if odd or not value:
            raise TrackError(
                f"{path}: {where}: an object of lane lines has the keys '+x' and/or '-x' (each "
                f"direction's lines), got {json.dumps(list(value))[:60]}"
            )
        return {k: lines(v, f"{where}, {k}") for k, v in value.items()}

    if isinstance(data, list):
        return lines(data, "the lane lines of every recording")
    if isinstance(data, dict) and data:
        return {str(k): road(v, f"recording {k!r}") for k, v in data.items()}
    raise TrackError(
        f"{path}: expected an object mapping each recording to its lane lines' y [m] (road "
        f"edges included) or one list for every recording, got {json.dumps(data)[:60]}"
    )


def _recording_lines(
    lane_markings: LaneLines, recordings: Sequence[str], has_recordings: bool, source: Path,
    label: str,
) -> dict[str, dict[str, np.ndarray]]:  # fmt: skip
    """Each recording's checked lane lines per direction, or a one-line error.

    ``source`` is the file at fault (the lanes file, or the table for ``lane_markings``),
    ``label`` what the lines are called in messages. One list serves both directions.
    """

    def checked(value: RoadLines, what: str) -> dict[str, np.ndarray]:
        if not isinstance(value, Mapping):
            lines = check_lane_lines(np.asarray(value, float), source, what)
            return dict.fromkeys(DIRECTIONS, lines)
        odd = [k for k in value if k not in DIRECTIONS]
        if odd:
            raise TrackError(
                f"{source}: {what}: lane lines per direction have the keys '+x' and/or '-x', "
                f"got {odd[0]!r}"
            )
        return {
            k: check_lane_lines(np.asarray(v, float), source, f"{what}, {k}")
            for k, v in value.items()
        }

    if not isinstance(lane_markings, Mapping):
        return dict.fromkeys(recordings, checked(lane_markings, label))
    if not has_recordings:
        raise TrackError(
            f"{source}: lane lines per recording ({label}), but the table has no 'recording' "
            "column: give one list of lines"
        )
    missing = [r for r in recordings if r not in lane_markings]
    unknown = [k for k in lane_markings if k not in set(recordings)]
    if missing:
        raise TrackError(
            f"{source}: no lane lines for recording {missing[0]!r} ({len(missing)} of the "
            f"table's {len(recordings)} recordings have none)"
        )
    if unknown:
        known = ", ".join(map(repr, recordings[:5])) + (", …" if len(recordings) > 5 else "")
        raise TrackError(
            f"{source}: recording {unknown[0]!r} is not in the table (its recordings: {known})"
        )
    return {r: checked(lane_markings[r], f"{label}, recording {r!r}") for r in recordings}


def outside_road(y: np.ndarray, markings: Sequence[float]) -> np.ndarray:
    """How far each lateral position lies outside the outermost lane lines (the road edges).

    Args:
        y: lateral positions, shape (n,) [m].
        markings: the lane lines, increasing, road edges first and last [m].

    Returns:
        Distance beyond the nearer edge, 0 on the road, shape (n,) [m].
    """
    y = np.asarray(y, float)
    return np.maximum(np.maximum(markings[0] - y, y - markings[-1]), 0.0)


def outside_road_warning(carriageways: Sequence[Carriageway], lines_from: str) -> str | None:
    """A one-line warning naming the vehicles with samples outside the road, or None.

    Args:
        carriageways: the recording's carriageways (their lines given by the user).
        lines_from: where the lines came from (a file or an option), said first.

    Returns:
        ``warning: …`` naming up to :data:`OUTSIDE_WARN_VEHICLES` vehicles (most samples
        outside first) with how many samples and how far, or None when none is outside.
    """
    found = []
    for road in carriageways:
        for track in road.tracks:
            d = outside_road(track.y, road.markings)
            if d.max() > 0:
                found.append((int((d > 0).sum()), float(d.max()), road.name, track.vehicle_id))
    if not found:
        return None
    found.sort(key=lambda f: (-f[0], -f[1]))
    named = "; ".join(
        f"vehicle {vid} ({name}): {k} sample(s), up to {far:.2f} m out"
        for k, far, name, vid in found[:OUTSIDE_WARN_VEHICLES]
    )
    rest = len(found) - OUTSIDE_WARN_VEHICLES
    more = f"; and {rest} more vehicle(s)" if rest > 0 else ""
    return (
        f"warning: {lines_from}: {len(found)} vehicle(s) drive outside the outermost lane lines "
        f"(the road edges): {named}{more}; outside the lines is no lane, and changes into or "
        "out of it are not found (are the road edges the outermost lines?)"
    )


def _warn_outside_road(
    carriageways: Sequence[Carriageway], lines_from: str
) -> list[dict[str, object]]:
    """Print :func:`outside_road_warning` on stderr (if any); the vehicles outside, for meta.

    Returns:
        Per vehicle with samples outside: carriageway, vehicle_id, samples, max_m [m].
    """
    warning = outside_road_warning(carriageways, lines_from)
    if warning:
        print(warning, file=sys.stderr, flush=True)
    return [
        {"carriageway": road.name, "vehicle_id": track.vehicle_id,
         "samples": int(np.count_nonzero(d)), "max_m": float(d.max())}
        for road in carriageways for track in road.tracks
        for d in [outside_road(track.y, road.markings)] if d.max() > 0
    ]  # fmt: skip


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


READERS["csv"] = read_table


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


# ------------------------------------------- published formats: NGSIM, levelX, INTERACTION

NGSIM_COLUMNS = (
    "Vehicle_ID",
    "Frame_ID",
    "Total_Frames",
    "Global_Time",
    "Local_X",
    "Local_Y",
    "Global_X",
    "Global_Y",
    "v_Length",
    "v_Width",
    "v_Class",
    "v_Vel",
    "v_Acc",
    "Lane_ID",
    "Preceding",
    "Following",
    "Space_Headway",
    "Time_Headway",
)
"""The 18 columns of the classic US-101 / I-80 text files (whitespace separated, no header)."""

NGSIM_FREEWAYS = ("i-80", "us-101")
"""``Location`` values kept from the data.transportation.gov CSV (the arterials are not)."""

NGSIM_MAIN_LANES = 5
"""US-101's main lanes are Lane_ID 1 (leftmost) to 5 (6 auxiliary, 7 on-ramp, 8 off-ramp)."""
NGSIM_MAIN_LANES_BY_FREEWAY = {"i-80": 6, "us-101": NGSIM_MAIN_LANES}
"""Main lanes per freeway: I-80 has six (Lane_ID 1, the HOV lane, to 6; 7 is the on-ramp)."""


def _ngsim_main_lanes(name: str, lane_id: np.ndarray) -> int:
    """Main lanes of a freeway by its name, or for a headerless file by its lane ids.

    A Lane_ID 8 (US-101's off-ramp) says US-101; a 7 without an 8 says I-80 (its on-ramp);
    otherwise US-101's five.
    """
    if name in NGSIM_MAIN_LANES_BY_FREEWAY:
        return NGSIM_MAIN_LANES_BY_FREEWAY[name]
    ids = set(np.unique(lane_id).astype(int).tolist())
    return 6 if 7 in ids and 8 not in ids else NGSIM_MAIN_LANES


NGSIM_LANE_FT = 12.0
"""Nominal NGSIM lane width [ft] (``markings="nominal"``: lane k spans 12(k − 1)…12k ft of
Local_X from the left road edge)."""

NGSIM_REUSED_ID_GAP_S = 60.0
"""A vehicle id seen again after a longer gap is another vehicle [s]: NGSIM numbers the
vehicles of each 15-minute period from 1 again, and a vehicle crosses the study area in
minutes, so a reused id comes back 10 minutes or more later. A shorter gap is a gap in one
vehicle's track, the extraction's rule for every reader (``ExtractionConfig.max_gap_s``):
its lane change is kept unusable, not lost between two tracks."""

INTERACTION_VEHICLES = frozenset({"car", "truck", "bus", "truck_bus", "van", "motorcycle"})
"""INTERACTION ``agent_type`` values kept (pedestrians and bicycles are dropped)."""

_AXES = {"x+": 0.0, "y+": math.pi / 2, "x-": math.pi, "y-": -math.pi / 2}
"""Named road directions of :func:`read_interaction` → angle of travel in the map [rad]."""


def _label(value: object) -> str:
    """A source id or frame as text (12.0 → '12')."""
    if isinstance(value, (float, np.floating)) and math.isfinite(value) and value == int(value):
        return str(int(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return str(value)


def _published_columns(df: Any, path: Path, required: Sequence[str], fmt: str) -> None:
    """Refuse a table without ``required`` columns (one line naming the file)."""
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise TrackError(
            f"{path}: missing column(s) {', '.join(repr(c) for c in missing)} of the {fmt} "
            f"format; it has {list(df.columns)}"
        )


def _published_numbers(
    df: Any, path: Path, columns: Sequence[str], ids: Sequence[str], frame: str
) -> dict[str, np.ndarray]:
    """The ``columns`` of ``df`` as finite floats.

    Raises:
        TrackError: a value is missing, not a number or infinite; the message names the file,
            the vehicle (``ids`` columns), the frame and the column.
    """
    import pandas as pd

    values = {c: pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float) for c in columns}
    bad = np.column_stack([~np.isfinite(values[c]) for c in columns])
    rows = np.flatnonzero(bad.any(axis=1))
    if rows.size:
        i = int(rows[0])
        column = columns[int(np.flatnonzero(bad[i])[0])]
        vehicle = ":".join(_label(df[c].iloc[i]) for c in ids)
        raw = df[column].iloc[i]
        shown = repr(raw) if isinstance(raw, str) else str(raw)
        raise TrackError(
            f"{path}: vehicle {vehicle}, frame {_label(df[frame].iloc[i])}: {column} is "
            f"{shown}, not a finite number"
        )
    return values


def _published_tracks(
    path: Path, ids: np.ndarray, t: np.ndarray, frames: np.ndarray, max_gap_s: float | None = None
) -> tuple[list[tuple[str, np.ndarray]], list[str]]:
    """Split rows into tracks: (vehicle id, row indices in time order) and the dropped ones.

    Rows may come in any order; a track is a vehicle's rows sorted by time, cut where the
    time jumps by more than ``max_gap_s`` (a reused id: the later parts are named
    ``'<id>@<first frame>'``; a gap in one vehicle's track is the extraction's rule,
    ``ExtractionConfig.max_gap_s``). Tracks of a single sample are dropped (their names
    returned: the readers' :data:`~drivestyle.recorded.track_checks.SINGLE_SAMPLE` meta, which
    :func:`~drivestyle.recorded.track_checks.check_recording` notes).

    Raises:
        TrackError: a vehicle has two rows at one time or one frame, or frames that do not
            increase with time; the message names the file, the vehicle and the frame.
    """
    from itertools import pairwise

    import pandas as pd

    codes, names = pd.factorize(pd.Series(ids, dtype=str), sort=True)
    order = np.lexsort((frames, t, codes))
    c, tt, ff = codes[order], t[order], frames[order]
    dt, df = np.diff(tt), np.diff(ff)
    cut = c[1:] != c[:-1]
    if max_gap_s is not None:
        cut |= dt > max_gap_s
    bad = np.flatnonzero(~cut & ((dt <= 0) | (df <= 0)))
    if bad.size:
        k = int(bad[0]) + 1
        here, before = _label(ff[k]), _label(ff[k - 1])
        if df[k - 1] == 0:
            problem = "appears twice (each frame once per vehicle)"
        elif dt[k - 1] == 0:
            problem = f"has the same time as frame {before} ({tt[k]:.15g} s)"
        else:
            problem = f"comes after frame {before} in time (frames must increase with time)"
        raise TrackError(f"{path}: vehicle {names[c[k]]}, frame {here}: {problem}")
    bounds = np.concatenate([[0], np.flatnonzero(cut) + 1, [len(order)]])
    out: list[tuple[str, np.ndarray]] = []
    dropped: list[str] = []
    seen: set[str] = set()
    for a, b in pairwise(bounds):
        name = str(names[c[a]])
        key = name if name not in seen else f"{name}@{_label(ff[a])}"
        seen.add(name)
        if b - a < 2:
            dropped.append(key)
            continue
        out.append((key, order[a:b]))
    return out, dropped


# ------------------------------------------------------------------------------ raw NGSIM


NGSIM_FILE = "an NGSIM trajectory file (US-101, I-80)"
"""What :func:`read_ngsim` reads, for messages."""


def _ngsim_table(path: Path) -> Any:
    """The rows of an NGSIM trajectory file with the standard column names."""
    import gzip

    _need_file(path, NGSIM_FILE)
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", errors="replace") as f:
        first = f.readline().strip()
    if not first:
        raise TrackError(f"{path}: empty (an NGSIM trajectory file has one row per vehicle frame)")
    sep = "," if "," in first else r"\s+"
    token = first.split(",")[0] if sep == "," else first.split()[0]
    try:
        float(token)
        header = False
    except ValueError:
        header = True
    if header:
        df = _read_csv(path, NGSIM_FILE, sep=sep, low_memory=False, thousands=",")
        canonical = {c.lower(): c for c in (*NGSIM_COLUMNS, "Location")}
        df = df.rename(columns={c: canonical.get(str(c).strip().lower(), c) for c in df.columns})
    else:
        df = _read_csv(path, NGSIM_FILE, sep=sep, header=None)
        if df.shape[1] != len(NGSIM_COLUMNS):
            kind = (
                " (the 24 columns of the arterial Lankershim / Peachtree files, not a freeway)"
                if df.shape[1] == 24
                else ""
            )
            raise TrackError(
                f"{path}: {df.shape[1]} columns{kind}; a headerless NGSIM freeway file (US-101, "
                f"I-80) has the {len(NGSIM_COLUMNS)} columns {', '.join(NGSIM_COLUMNS)}"
            )
        df.columns = list(NGSIM_COLUMNS)
    return df


def _left_numbered_lanes(
    lateral: np.ndarray, lane_id: np.ndarray, n_main: int
) -> tuple[np.ndarray, float, float, np.ndarray]:
    """Lane lines of lanes numbered from the left (NGSIM's Lane_ID 1 leftmost).

    ``lateral`` grows to the right from the left road edge. The main lanes (Lane_ID ≤
    ``n_main``) are taken as equally wide: lateral = a + w·Lane_ID is fitted through each
    present main lane's median position, the lines lie at a + w·(k − ½), k = 1 … n_main + 1.

    Args:
        lateral: lateral position of every row, shape (r,) [the source's unit].
        lane_id: its Lane_ID, shape (r,).
        n_main: the number of main lanes.

    Returns:
        (the present main Lane_IDs, w, a, our lane index per row: the rightmost main lane
        0, auxiliary lanes and ramps −1).
    """
    main = lane_id <= n_main
    present = np.unique(lane_id[main])
    if present.size < 2:
        return present, math.nan, math.nan, np.where(main, n_main - lane_id, -1.0)
    centres = np.array([np.median(lateral[main & (lane_id == k)]) for k in present])
    slope, intercept = np.polyfit(present, centres, 1)
    return present, float(slope), float(intercept), np.where(main, n_main - lane_id, -1.0)


def _ngsim_carriageway(
    path: Path, name: str, df: Any, markings: str
) -> tuple[Carriageway, float, list[str]]:
    """One NGSIM freeway's rows: its carriageway, Global_Time origin [ms], dropped tracks."""
    ids, frame = ["Vehicle_ID"], "Frame_ID"
    cols = ["Vehicle_ID", "Frame_ID", "Global_Time", "Local_X", "Local_Y"]
    cols += ["v_Length", "v_Width", "v_Vel", "Lane_ID"]
    num = _published_numbers(df, path, cols, ids, frame)
    lane_id = num["Lane_ID"]
    bad = np.flatnonzero((lane_id < 1) | (lane_id != np.round(lane_id)))
    if bad.size:
        i = int(bad[0])
        raise TrackError(
            f"{path}: vehicle {_label(num['Vehicle_ID'][i])}, frame {_label(num[frame][i])}: "
            f"Lane_ID {_label(lane_id[i])} is not an NGSIM lane (1 = leftmost, …)"
        )
    # lane lines from the data: median Local_X of each main lane against its Lane_ID
    n_main = _ngsim_main_lanes(name, lane_id)
    present, slope, intercept, lane = _left_numbered_lanes(num["Local_X"], lane_id, n_main)
    if present.size < 2:
        raise TrackError(
            f"{path} ({name}): vehicles in {present.size} main lane(s) (Lane_ID 1–"
            f"{n_main}); need 2 to check the unit and place the lane lines"
        )
    width_m = slope * FOOT
    lo, hi = LANE_WIDTH_RANGE_M
    if not lo <= width_m <= hi:
        hint = (
            "the file looks already in metres: NGSIM files are in feet (multiply Local_X, "
            "Local_Y, v_Length, v_Width, v_Vel, v_Acc by 1/0.3048 = 3.2808 to give feet), or "
            "read metres with the generic CSV reader"
            if 0 < width_m < lo
            else "Local_X does not grow by a lane per Lane_ID (feet from the left road edge)"
        )
        raise TrackError(
            f"{path} ({name}): lanes {width_m:.3g} m wide after the feet → metres conversion "
            f"(median Local_X per main lane), but a road's lanes are {lo:g}–{hi:g} m: {hint}"
        )
    k = np.arange(1, n_main + 2)
    if markings == "data":
        lines_ft = intercept + slope * (k - 0.5)
    else:
        lines_ft = NGSIM_LANE_FT * (k - 1)
    lines = np.sort(-FOOT * lines_ft)
    t_ms = num["Global_Time"]
    t0 = float(t_ms.min())
    t = (t_ms - t0) / 1000.0
    groups, dropped = _published_tracks(
        path, num["Vehicle_ID"].astype(np.int64), t, num[frame], NGSIM_REUSED_ID_GAP_S
    )
    tracks = []
    for vid, rows in groups:
        length = float(np.median(num["v_Length"][rows])) * FOOT
        tracks.append(
            Track(
                vehicle_id=vid,
                t=t[rows],
                x=num["Local_Y"][rows] * FOOT - length / 2,  # front centre → centre
                y=-num["Local_X"][rows] * FOOT,
                frames=num[frame][rows].astype(np.int64),
                v=num["v_Vel"][rows] * FOOT,
                lane=lane[rows],
                length=length,
                width=float(np.median(num["v_Width"][rows])) * FOOT,
                source=str(path),
            )
        )
    return Carriageway(name, tuple(lines), tuple(tracks)), t0, dropped


def read_ngsim(path: str | Path, markings: str = "data") -> Recording:
    """A raw NGSIM trajectory file (US-101 or I-80) in the road frame.

    Reads both the classic text files (the 18 columns of :data:`NGSIM_COLUMNS`, whitespace
    separated, no header) and the data.transportation.gov CSV (a header, more columns and
    ``Location``: only ``i-80`` and ``us-101`` rows are kept, one carriageway per freeway;
    column names are matched ignoring case). Rows may come in any order; exact duplicate
    rows (known in that CSV) are dropped and counted.

    Conversion (NGSIM is 10 Hz, in feet; Local_Y along travel, Local_X from the left road
    edge growing to the right, both at the vehicle's front centre; Lane_ID 1 leftmost):

    - x = Local_Y·0.3048 − length/2 [m] (front centre → centre), y = −Local_X·0.3048 [m];
    - v = v_Vel·0.3048 [m/s]; length, width = v_Length, v_Width·0.3048 (per-vehicle median);
    - t = (Global_Time − the freeway's first Global_Time)/1000 [s]; frames = Frame_ID;
    - lane = M − Lane_ID for the M main lanes (US-101: 5, Lane_ID 6 auxiliary, 7 on-ramp,
      8 off-ramp; I-80: 6, Lane_ID 7 on-ramp; a headerless file's freeway is told by its
      lane ids, :func:`_ngsim_main_lanes`): lane 0 is the rightmost main lane; −1 for the
      auxiliary lanes and ramps, which lie right of the main lanes;
    - lane lines (M + 1, converted to increasing y): ``markings="data"``
      fits Local_X = a + w·Lane_ID through the median Local_X of each main lane and puts
      the lines at a + w·(k − ½), k = 1…M + 1 (equal lanes of the data's width, ≈ 12 ft);
      ``"nominal"`` puts them at 12 ft steps from the left road edge (Local_X = 0).
    - a vehicle id seen again more than a minute later (ids are reused across the
      15-minute periods of the CSV, :data:`NGSIM_REUSED_ID_GAP_S`) is a new track named
      ``'<id>@<first frame>'``.

    Args:
        path: the trajectory file (``.txt``/``.csv``, optionally ``.gz``).
        markings: ``"data"`` or ``"nominal"`` (above).

    Returns:
        The recording (meta: format, rate, units, dropped rows, each freeway's Global_Time
        origin [ms] and lane width [m]).

    Raises:
        FileNotFoundError: no such file.
        TrackError: a missing column, a value that is not a number, a repeated or
            non-increasing frame (naming the file, vehicle and frame), no freeway rows, or
            lanes no road has (a file already in metres: the conversion to apply).
    """
    if markings not in ("data", "nominal"):
        raise ValueError(f"markings must be 'data' or 'nominal', got {markings!r}")
    path = Path(path)
    df = _ngsim_table(path)
    required = ["Vehicle_ID", "Frame_ID", "Global_Time", "Local_X", "Local_Y"]
    required += ["v_Length", "v_Width", "v_Vel", "Lane_ID"]
    _published_columns(df, path, required, "NGSIM")
    n_rows = len(df)
    df = df.drop_duplicates(ignore_index=True)
    meta: dict[str, object] = {
        "format": "ngsim",
        "rate_hz": 10.0,
        "units": "feet → metres (× 0.3048); Local_Y front centre → centre",
        "duplicate_rows_dropped": n_rows - len(df),
    }
    if "Location" in df.columns:
        location = df["Location"].astype(str).str.strip().str.lower()
        kept = location.isin(NGSIM_FREEWAYS)
        meta["rows_dropped_not_freeway"] = {
            str(k): int(v) for k, v in location[~kept].value_counts().items()
        }
        if not kept.any():
            raise TrackError(
                f"{path}: no freeway rows (Location {sorted(set(location))}); read_ngsim reads "
                f"{' and '.join(NGSIM_FREEWAYS)} (the arterials are not straight carriageways)"
            )
        parts = [(loc, df[location == loc]) for loc in NGSIM_FREEWAYS if (location == loc).any()]
    else:
        parts = [("ngsim", df)]
    carriageways, origins, widths, dropped = [], {}, {}, []
    for name, rows in parts:
        cw, t0, skipped = _ngsim_carriageway(path, name, rows.reset_index(drop=True), markings)
        carriageways.append(cw)
        origins[name] = t0
        widths[name] = float(np.median(cw.lane_widths))
        dropped += [f"{v} ({name})" if len(parts) > 1 else v for v in skipped]
    meta.update(
        global_time_origin_ms=origins,
        lane_width_m=widths,
        markings=markings,
    )
    meta[SINGLE_SAMPLE] = dropped
    return check_recording(Recording(str(path), tuple(carriageways), meta))


# ------------------------------------------------------------------------- levelX (highD)

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


# ---------------------------------------------------------------------------- INTERACTION

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


READERS["ngsim"] = read_ngsim
READERS["highd"] = read_levelx
READERS["interaction"] = read_interaction


# ------------------------------------------------- the project's shipped samples (shared/data)

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


READERS["sample"] = read_sample
