"""What the readers of :mod:`drivestyle.recorded.readers` share.

Reading a reader's file (:func:`_read_csv`, :func:`_read_frame`: one-line messages for
missing, empty, binary and non-UTF-8 files), the lane lines every reader checks
(:func:`check_lane_lines`: lanes a road has, in metres) and the warning for vehicles outside
the road edges, and the rows of a published format split into tracks
(:func:`_published_tracks`, with its column and number checks).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.plausibility import LANE_WIDTH_RANGE_M
from drivestyle.envs.units import FOOT
from drivestyle.recorded.tracks import Carriageway, TrackError

__all__ = [
    "OUTSIDE_WARN_VEHICLES",
    "PARQUET_SUFFIXES",
    "check_lane_lines",
    "outside_road",
    "outside_road_warning",
]


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


PARQUET_SUFFIXES = (".parquet", ".pq")
"""File endings read as Parquet (every other ending is read as CSV, gzip included)."""


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
    """A lane width a road has, in metres, or a one-line error.

    :data:`~drivestyle.envs.plausibility.LANE_WIDTH_RANGE_M` is the one range of every lane
    width, given or between given lines: checked before any line is computed from it
    (``lane_width=1e308`` would overflow).
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


OUTSIDE_WARN_VEHICLES = 5
"""Vehicles the outside-the-road warning names (the most affected first; the rest counted)."""


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
