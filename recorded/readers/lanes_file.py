"""The lanes file: each recording's lane lines as JSON (``--lanes``, :func:`load_lanes`).

The generic table (:mod:`drivestyle.recorded.readers.table`) takes its lane lines from this
file, from ``lane_markings`` or ``lane_width``, or from its ``lane`` column;
:func:`_recording_lines` checks the given lines against the table's recordings and
directions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from drivestyle.recorded.readers.shared import _need_file, _not_text, check_lane_lines
from drivestyle.recorded.tracks import TrackError

__all__ = [
    "DIRECTIONS",
    "LANES_FILE",
    "LaneLines",
    "RoadLines",
    "load_lanes",
]

DIRECTIONS = ("+x", "-x")
"""The driving directions of a table's carriageways (keys of per-direction lane lines)."""
RoadLines = Sequence[float] | Mapping[str, Sequence[float]]
"""One recording's lane lines' y in the table's frame [m], road edges included: one list
for both directions, or ``{"+x": [...], "-x": [...]}`` (a road with a median)."""
LaneLines = Sequence[float] | Mapping[str, RoadLines]
"""Lane lines of a table: one list for every recording, or per recording."""
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
