"""Raw NGSIM trajectory files (US-101, I-80): feet, front centres, lanes numbered from the left.

:func:`read_ngsim` reads the classic 18-column text files and the data.transportation.gov
CSV. The lane rule of lanes numbered from the left (:func:`_left_numbered_lanes`) also
serves the shipped NGSIM sample (:mod:`drivestyle.recorded.readers.sample`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.plausibility import LANE_WIDTH_RANGE_M
from drivestyle.envs.units import FOOT
from drivestyle.recorded.readers.shared import (
    _label,
    _need_file,
    _published_columns,
    _published_numbers,
    _published_tracks,
    _read_csv,
)
from drivestyle.recorded.track_checks import SINGLE_SAMPLE, check_recording
from drivestyle.recorded.tracks import Carriageway, Recording, Track, TrackError

__all__ = [
    "NGSIM_COLUMNS",
    "NGSIM_FILE",
    "NGSIM_FREEWAYS",
    "NGSIM_LANE_FT",
    "NGSIM_MAIN_LANES",
    "NGSIM_MAIN_LANES_BY_FREEWAY",
    "NGSIM_REUSED_ID_GAP_S",
    "read_ngsim",
]

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
