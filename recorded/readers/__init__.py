"""Readers of published trajectory formats into a :class:`~drivestyle.recorded.tracks.Recording`.

One module per format, each keeping its source's conventions at the edge and returning
tracks in the one road frame of :mod:`drivestyle.recorded.tracks` (x along travel, y to the
left, lane 0 rightmost, vehicle centres, SI units), checked by their physics by the one
home of the readers' rules, :func:`~drivestyle.recorded.track_checks.check_recording`,
which every reader calls last:

- :mod:`~drivestyle.recorded.readers.table`: the generic long-format table (CSV or
  Parquet), read and written; its lanes file in :mod:`~drivestyle.recorded.readers.lanes_file`;
- :mod:`~drivestyle.recorded.readers.ngsim`: raw NGSIM (US-101, I-80);
- :mod:`~drivestyle.recorded.readers.levelx`: highD's levelX;
- :mod:`~drivestyle.recorded.readers.interaction`: INTERACTION;
- :mod:`~drivestyle.recorded.readers.sample`: the shipped NGSIM and CATS samples;
- :mod:`~drivestyle.recorded.readers.shared`: what they share (every CSV is read through
  ``_read_csv``: one-line messages for empty, binary and non-UTF-8 files; the lane lines'
  checks; the rows of a published format split into tracks).

:data:`READERS` maps a format name to its reader. Every public name of the modules is
importable from here.
"""

from __future__ import annotations

from collections.abc import Callable

from drivestyle.recorded.readers.interaction import (
    INTERACTION_COLUMNS,
    INTERACTION_VEHICLES,
    read_interaction,
)
from drivestyle.recorded.readers.lanes_file import (
    DIRECTIONS,
    LANES_FILE,
    LaneLines,
    RoadLines,
    load_lanes,
)
from drivestyle.recorded.readers.levelx import LEVELX_TRACK_COLUMNS, read_levelx
from drivestyle.recorded.readers.ngsim import (
    NGSIM_COLUMNS,
    NGSIM_FILE,
    NGSIM_FREEWAYS,
    NGSIM_LANE_FT,
    NGSIM_MAIN_LANES,
    NGSIM_MAIN_LANES_BY_FREEWAY,
    NGSIM_REUSED_ID_GAP_S,
    read_ngsim,
)
from drivestyle.recorded.readers.sample import SAMPLE_MAIN_LANES, read_sample
from drivestyle.recorded.readers.shared import (
    OUTSIDE_WARN_VEHICLES,
    PARQUET_SUFFIXES,
    check_lane_lines,
    outside_road,
    outside_road_warning,
)
from drivestyle.recorded.readers.table import (
    ROAD_LANES_MAX,
    TABLE_COLUMNS,
    TABLE_OPTIONAL,
    TABLE_TEXT,
    read_table,
    write_table,
)
from drivestyle.recorded.tracks import Recording

__all__ = [
    "DIRECTIONS",
    "INTERACTION_COLUMNS",
    "INTERACTION_VEHICLES",
    "LANES_FILE",
    "LEVELX_TRACK_COLUMNS",
    "NGSIM_COLUMNS",
    "NGSIM_FILE",
    "NGSIM_FREEWAYS",
    "NGSIM_LANE_FT",
    "NGSIM_MAIN_LANES",
    "NGSIM_MAIN_LANES_BY_FREEWAY",
    "NGSIM_REUSED_ID_GAP_S",
    "OUTSIDE_WARN_VEHICLES",
    "PARQUET_SUFFIXES",
    "READERS",
    "ROAD_LANES_MAX",
    "SAMPLE_MAIN_LANES",
    "TABLE_COLUMNS",
    "TABLE_OPTIONAL",
    "TABLE_TEXT",
    "LaneLines",
    "RoadLines",
    "check_lane_lines",
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

READERS: dict[str, Callable[..., Recording]] = {
    "csv": read_table,
    "ngsim": read_ngsim,
    "highd": read_levelx,
    "interaction": read_interaction,
    "sample": read_sample,
}
"""Format name → reader (``READERS[name](path, ...)`` returns a
:class:`~drivestyle.recorded.tracks.Recording`)."""
