"""Loaders for recorded lane changes: NGSIM (I-80, US-101) and the CATS AV field test.

Each episode becomes a :class:`Demonstration` in the project's road frame and a
:class:`RecordedEpisode` that keeps the source's quality flags and says whether the
episode is used (and if not, why).

Road frame (the same for both sources):
- x along the EV's travel direction; y lateral with the lane change going to **+y**
  (a lane change to the other side is mirrored);
- lane 0 is the EV's origin lane, lane 1 its destination; lanes are ``lane_width`` wide
  and lane k covers [k·w, (k+1)·w);
- states [x, y, φ, v] are resampled to the learner's T_s (default 0.2 s) by cubic
  splines through the recorded positions (both sources are already smoothed upstream:
  NGSIM by its uploaders, CATS by Savitzky–Golay filtering, see their READMEs), heading
  φ = atan2(ẏ, ẋ) from the resampled positions, speed v from the recorded speed
  (:func:`~drivestyle.envs.episodes.resample_states`);
- the inputs [a, δ] are not recorded and stored as zeros (the driver model recovers them
  with :func:`~drivestyle.envs.episodes.recover_inputs`).

Scenario constants adapt to each episode (documented rule, :func:`scenario_from_episode`):
lane width from the data (NGSIM: median spacing of the recording's lane centres; CATS:
its fitted 3.95 m), v_ref from the EV's speed level (its 90th-percentile speed in the
window), the safety ellipse scaled with the lane width (l_b) and the speed (l_a = the
paper's 15 m at 27.5 m/s, i.e. a 0.55 s gap, with a 5 m floor).

Episodes without a target vehicle (CATS human-driven runs) get a phantom TV 1 km behind
in the destination lane: the trigger can never fire, so the reactive features are
inactive, and ``RecordedEpisode.flags["no_target"]`` says so.

Units are checked: a lane width outside
:data:`~drivestyle.envs.demonstration.LANE_WIDTH_RANGE_M` (NGSIM's native feet give 12.1)
refuses the dataset with a message saying to convert; an episode that fails
:func:`~drivestyle.envs.demonstration.check_plausible` is kept unused with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import (
    LANE_WIDTH_RANGE_M,
    Demonstration,
    plausibility_problems,
)
from drivestyle.envs.episodes import (
    PHANTOM_GAP_M,
    observed_scenario,
    recover_inputs,
    resample_states,
)
from drivestyle.envs.episodes import time_grid as _grid
from drivestyle.envs.scenario import ScenarioConfig

__all__ = ["RecordedEpisode", "load_cats", "load_ngsim", "scenario_from_episode"]


@dataclass(frozen=True)
class RecordedEpisode:
    """One recorded lane change."""

    episode_id: str
    dataset: str
    """'ngsim' or 'cats'."""
    used: bool
    """Whether the episode passes the documented selection."""
    reasons: tuple[str, ...]
    """Why it is not used (empty when used)."""
    demo: Demonstration | None
    """The episode as a demonstration (None if it could not be built)."""
    flags: dict[str, Any] = field(default_factory=dict)
    """Source quality flags and episode facts (direction, target relation, set, …)."""


_GZIP_MAGIC = b"\x1f\x8b"

_DATASETS = {
    "ngsim": ("NGSIM", "load_ngsim", "../shared/data/ngsim"),
    "cats": ("CATS", "load_cats", "../shared/data/cats-av-lanechange"),
}
"""Dataset key → (name, loader, example folder), for error messages."""

_COLUMNS: dict[str, dict[str, tuple[str, ...]]] = {
    "ngsim": {
        "episodes.csv": (
            "episode_id",
            "recording",
            "direction",
            "target_relation",
            "target_selected_at",
            "target_set_complete",
            "rate_hz",
            "complete_window",
            "involves_ramp_or_aux_lane",
        ),
        "episode_tracks.csv.gz": (
            "episode_id",
            "role",
            "t_rel_s",
            "x_m",
            "y_m",
            "v_mps",
            "interpolated",
        ),
        "tracks.csv.gz": ("recording", "lane_id", "y_m"),
    },
    "cats": {
        "episodes.csv": (
            "episode_id",
            "set",
            "leg",
            "lc_direction",
            "from_lane",
            "target_relation",
            "quality_flags",
        ),
        "episode_tracks.csv.gz": ("episode_id", "role", "t_rel_s", "x_m", "y_m", "v_mps"),
    },
}
"""Columns each loader reads from each file of its dataset."""

_NUMERIC = ("t_rel_s", "x_m", "y_m", "v_mps", "lane_id", "rate_hz", "from_lane")
"""Columns used as numbers (whichever of them a file is required to have)."""


def _dataset_dir(data_dir: str | Path) -> Path:
    data_dir = Path(data_dir)
    if data_dir.exists() and not data_dir.is_dir():
        raise FileNotFoundError(
            f"{data_dir} is not a folder; pass the dataset folder (e.g. "
            "../shared/data/ngsim or ../shared/data/cats-av-lanechange), not one of its files"
        )
    return data_dir


def _check_dt(dt: float) -> float:
    if not isinstance(dt, (int, float, np.integer, np.floating)) or isinstance(dt, bool):
        raise TypeError(f"dt must be a number [s], got {dt!r}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be finite and > 0 [s], got {dt}")
    return float(dt)


def _read_csv(path: Path, dataset: str):
    """Read one file of ``dataset`` ('ngsim' or 'cats') and check it has what we use.

    Raises:
        FileNotFoundError: the file is missing.
        ValueError: not gzip (for ``.gz``) or a truncated gzip, an empty file, a file of
            the other dataset, missing columns, no rows, or non-numeric values in a
            numeric column; the message names the file and the problem.
    """
    import gzip
    import zlib

    import pandas as pd

    if not path.is_file():
        raise FileNotFoundError(
            f"{path} not found; pass the dataset folder (e.g. "
            "../shared/data/ngsim or ../shared/data/cats-av-lanechange)"
        )
    gz = path.suffix == ".gz"
    if gz:
        with path.open("rb") as f:
            head = f.read(2)
        if head != _GZIP_MAGIC:
            raise ValueError(
                f"{path}: bad gzip: the file is not gzip-compressed (it starts with "
                f"{head!r}, not {_GZIP_MAGIC!r}); the dataset ships it as a gzipped CSV"
            )
    try:
        df = pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path} is empty (no header, no rows)") from None
    except (EOFError, gzip.BadGzipFile, zlib.error) as exc:
        if not gz:
            raise
        raise ValueError(f"{path}: bad gzip: truncated or corrupt ({exc})") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not a readable CSV ({exc})") from None

    required = _COLUMNS[dataset][path.name]
    missing = [c for c in required if c not in df.columns]
    if missing:
        name, loader, folder = _DATASETS[dataset]
        for other, columns in _COLUMNS.items():
            theirs = columns.get(path.name, ())
            if other != dataset and theirs and set(theirs) <= set(df.columns):
                o_name, o_loader, _ = _DATASETS[other]
                marks = ", ".join(repr(c) for c in theirs if c not in required)
                raise ValueError(
                    f"{path} looks like the {o_name} dataset (it has the {o_name} columns "
                    f"{marks}), not {name}: {loader} reads the {name} folder (e.g. {folder}); "
                    f"load this folder with {o_loader}"
                )
        raise ValueError(
            f"{path} is missing column(s) {', '.join(repr(c) for c in missing)} needed by "
            f"{loader}; it has {list(df.columns)}"
        )
    if df.empty:
        raise ValueError(f"{path} has a header but no rows")
    for column in (c for c in _NUMERIC if c in required):
        values = df[column]
        if not pd.api.types.is_numeric_dtype(values):
            bad = values.notna() & pd.to_numeric(values, errors="coerce").isna()
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise ValueError(
                f"{path}: column {column!r} has the non-numeric value {values.iloc[i]!r} "
                f"(data row {i + 1})"
            )
    return df


def scenario_from_episode(
    ev: np.ndarray, tv: np.ndarray, lane_width: float, dt: float, length: float, width: float
) -> ScenarioConfig:
    """Scenario constants of a recorded episode (module docstring's rule).

    Args:
        ev: EV states in the road frame, shape (n, 4).
        tv: TV states, shape (n, 4).
        lane_width: lane width from the data [m].
        dt: sampling time [s].
        length: EV length [m].
        width: EV width [m].

    Returns:
        The scenario (its start-inside-ellipse check disabled: recorded traffic may start
        closer than any ellipse).
    """
    # the whole window is "observed" here: the loaders' documented rule (DESIGN §10); the
    # extraction of envs.episodes passes its observed part only
    return observed_scenario(ev, tv[0], 1, lane_width, dt, ev.shape[0], length, width)


NEIGHBOUR_RANGE = 100.0
"""Further vehicles are kept when they come within this longitudinal distance of the EV [m]."""


def clean_rows(df) -> tuple[Any, int]:
    """Drop rows with non-finite t/x/y/v or repeated times; returns (rows, dropped count)."""
    cols = ["t_rel_s", "x_m", "y_m", "v_mps"]
    ok = np.isfinite(df[cols].to_numpy(dtype=float)).all(axis=1)
    kept = df[ok].sort_values("t_rel_s").drop_duplicates("t_rel_s")
    return kept, int(len(df) - len(kept))


def _build(
    ep_id: str,
    ego,
    tgt,
    mirror: bool,
    y_origin_lower: float,
    lane_width: float,
    dt: float,
    neighbours: list | None = None,
) -> Demonstration:
    """Demonstration of one episode in the road frame (rows already cleaned).

    ``neighbours`` (cleaned rows of further vehicles) become ``others``: each is resampled
    where it was recorded and continued at constant velocity before and after
    (:data:`NEIGHBOUR_RANGE` decides who counts).
    """
    if len(ego) < 4:
        raise ValueError(f"only {len(ego)} valid ego rows")
    t_new = _grid(ego.t_rel_s.to_numpy(), dt)
    if t_new.size < 3:
        raise ValueError("fewer than 3 samples at T_s")

    def frame(df, t_query):
        y = df.y_m.to_numpy()
        y = -y if mirror else y
        return resample_states(
            df.t_rel_s.to_numpy(),
            df.x_m.to_numpy(),
            y - y_origin_lower,
            t_query,
            v=df.v_mps.to_numpy(),
        )

    ev = frame(ego, t_new)
    inside = np.zeros(t_new.size, bool)
    if tgt is not None and len(tgt) >= 2:
        inside = (t_new >= tgt.t_rel_s.min() - 1e-9) & (t_new <= tgt.t_rel_s.max() + 1e-9)
    if inside.any():
        # the target may not cover the whole window: hold its first/last covered state
        tv = np.empty_like(ev)
        tv[inside] = frame(tgt, t_new[inside])
        idx = np.flatnonzero(inside)
        tv[: idx[0]] = tv[idx[0]]
        tv[idx[-1] + 1 :] = tv[idx[-1]]
    else:
        tv = ev.copy()
        tv[:, 0] += PHANTOM_GAP_M
        tv[:, 1] = 1.5 * lane_width
        tv[:, 2] = 0.0
    others = []
    for df in neighbours or []:
        if len(df) < 2:
            continue
        covered = (t_new >= df.t_rel_s.min() - 1e-9) & (t_new <= df.t_rel_s.max() + 1e-9)
        if covered.sum() < 2:
            continue
        states = np.empty_like(ev)
        states[covered] = frame(df, t_new[covered])
        idx = np.flatnonzero(covered)
        for edge, span in ((idx[0], slice(0, idx[0])), (idx[-1], slice(idx[-1] + 1, None))):
            x, y, phi, v = states[edge]
            tau = t_new[span] - t_new[edge]
            states[span] = np.column_stack(
                [
                    x + v * np.cos(phi) * tau,
                    y + v * np.sin(phi) * tau,
                    np.full_like(tau, phi),
                    np.full_like(tau, v),
                ]
            )
        if np.min(np.abs(states[:, 0] - ev[:, 0])) <= NEIGHBOUR_RANGE:
            others.append(states)
    L = float(ego.length_m.iloc[0]) if "length_m" in ego else 4.5
    W = float(ego.width_m.iloc[0]) if "width_m" in ego else 1.8
    sc = scenario_from_episode(ev, tv, lane_width, dt, L, W)
    # inputs are not recorded: the closest ones the model has (identification compares its
    # plans with them; zeros moved a simulated p = 0.9 to 0.73). φ here is the course
    # atan2(ẏ, ẋ) = φ + β, which meta["heading"] says, so the spline does not add β again
    u = recover_inputs(ev, sc, t_new)
    return Demonstration(
        t=t_new - t_new[0],
        ev=ev,
        tv=tv,
        u=u,
        meta={
            "scenario": sc.to_dict(),
            "episode_id": ep_id,
            "t_cross_rel_s": float(-t_new[0]),
            "heading": "course",
        },
        others=np.stack(others, axis=1) if others else None,
    )


def _episode(
    dataset: str, reasons: list[str], flags: dict[str, Any], episode_id: str, *build_args: Any
) -> RecordedEpisode:
    """Build one episode with ``_build(episode_id, *build_args)``.

    An unusable episode is kept, marked unused, with the reason; so is an implausible one
    (:func:`~drivestyle.envs.demonstration.plausibility_problems`), with its demonstration.
    """
    try:
        demo = _build(episode_id, *build_args)
    except ValueError as exc:
        return RecordedEpisode(
            episode_id, dataset, False, (*reasons, f"unusable: {exc}"), None, flags
        )
    reasons = [*reasons, *(f"implausible: {p}" for p in plausibility_problems(demo))]
    return RecordedEpisode(episode_id, dataset, not reasons, tuple(reasons), demo, flags)


def _check_lane_width(width: float, source: str) -> float:
    """Refuse a lane width no road has: the data is in another unit (NGSIM's is feet).

    Raises:
        ValueError: the width lies outside ``LANE_WIDTH_RANGE_M``; the message names
            ``source`` and says to convert.
    """
    lo, hi = LANE_WIDTH_RANGE_M
    if lo <= width <= hi:
        return width
    unit = (
        "positions in feet (NGSIM's native unit: its 12 ft lanes are 3.66 m)? convert "
        "x_m, y_m to metres and v_mps to m/s (× 0.3048)"
        if width > hi
        else "positions in another unit than metres? convert x_m, y_m to metres"
    )
    raise ValueError(
        f"{source}: lanes {width:.3g} m wide, but a road's lanes are {lo:g}–{hi:g} m wide: {unit}"
    )


def _lane_width_ngsim(tracks, recording: str, source: Path) -> float:
    """Median spacing of the recording's mainline lane centres (lanes 1–5) [m]."""
    g = tracks[(tracks.recording == recording) & (tracks.lane_id.between(1, 5))]
    centres = g.groupby("lane_id").y_m.median().sort_index().to_numpy()
    if centres.size < 2:
        raise ValueError(
            f"{source} has {centres.size} mainline lane(s) (lane_id 1–5) of recording "
            f"{recording!r}, named in episodes.csv; need 2 to measure its lane width"
        )
    width = float(np.median(np.diff(centres)))
    return _check_lane_width(width, f"{source} (recording {recording!r}, lane centres' spacing)")


def load_ngsim(
    data_dir: str | Path, dt: float = 0.2, neighbours: bool = True
) -> list[RecordedEpisode]:
    """The NGSIM lane-change episodes (``episodes.csv`` + ``episode_tracks.csv.gz``).

    Selection (the README's "clean" set): a complete ±4 s window and no ramp or auxiliary
    lane. Positions are the vehicles' front centres, as recorded. NGSIM's y grows to the
    right, so a lane change "left" (toward lane 1) is mirrored twice to become +y.

    Args:
        data_dir: the ``ngsim`` folder.
        dt: learner's sampling time [s].
        neighbours: keep every further vehicle of ``tracks.csv.gz`` that comes within
            :data:`NEIGHBOUR_RANGE` of the EV in the window, as the demonstration's ``others``.

    Returns:
        All 19 episodes, ``used`` marking the selection.

    Raises:
        FileNotFoundError: ``data_dir`` is a file, or a dataset file is missing.
        ValueError: a malformed file (not gzip, truncated, empty, header only, missing
            columns, non-numeric values, the other dataset's folder), lanes no road has
            (data in feet: convert to metres) or a bad ``dt``; the message names the file
            and the problem.
    """
    dt = _check_dt(dt)
    data_dir = _dataset_dir(data_dir)
    episodes = _read_csv(data_dir / "episodes.csv", "ngsim")
    tracks = _read_csv(data_dir / "episode_tracks.csv.gz", "ngsim")
    all_tracks = _read_csv(data_dir / "tracks.csv.gz", "ngsim")
    out = []
    widths = {
        r: _lane_width_ngsim(all_tracks, r, data_dir / "tracks.csv.gz")
        for r in episodes.recording.unique()
    }
    for row in episodes.itertuples():
        rows = tracks[tracks.episode_id == row.episode_id]
        ego, dropped_ego = clean_rows(rows[rows.role == "ego"])
        tgt, dropped_tgt = clean_rows(rows[rows.role == "target"])
        reasons = []
        if not row.complete_window:
            reasons.append("incomplete_window")
        if row.involves_ramp_or_aux_lane:
            reasons.append("ramp_or_aux_lane")
        w = widths[row.recording]
        # NGSIM y grows to the right (toward higher lane ids); a change to the left (toward
        # lane 1) already goes to smaller y, so mirror it; a change right is kept
        mirror = row.direction == "left"
        flags = {
            "direction": row.direction,
            "target_relation": row.target_relation,
            "target_selected_at": row.target_selected_at,
            "target_set_complete": bool(row.target_set_complete),
            "rate_hz": float(row.rate_hz),
            "lane_width_m": w,
            "interpolated_target": bool(tgt.interpolated.any()) if len(tgt) else None,
            "no_target": len(tgt) == 0,
            "recording": row.recording,
            "dropped_rows": dropped_ego + dropped_tgt,
        }
        # lane boundary: where the front centre crosses the marking (first new-lane sample
        # and the last old-lane one, linearly)
        before, after = ego[ego.t_rel_s < 0], ego[ego.t_rel_s >= 0]
        if before.empty or after.empty:
            reasons.append(
                f"unusable: the ego track has {len(before)} valid row(s) before the lane "
                f"crossing (t_rel_s < 0) and {len(after)} after; need both"
            )
            out.append(RecordedEpisode(row.episode_id, "ngsim", False, tuple(reasons), None, flags))
            continue
        y_b = 0.5 * (before.iloc[-1].y_m + after.iloc[0].y_m)
        y_b = -y_b if mirror else y_b
        near = []
        if neighbours:
            t0, t1 = ego.time_s.min(), ego.time_s.max()
            pool = all_tracks[
                (all_tracks.recording == row.recording)
                & (~all_tracks.vehicle_id.isin([row.ego_id, row.target_id]))
                & all_tracks.time_s.between(t0 - 1.0, t1 + 1.0)
            ]
            for _, g in pool.groupby("vehicle_id"):
                g = g.assign(t_rel_s=g.time_s - row.t_cross_s)
                near.append(clean_rows(g)[0])
        out.append(
            _episode(
                "ngsim", reasons, flags, row.episode_id, ego, tgt, mirror, y_b - w, w, dt, near
            )
        )
    return out


def _cats_lane_width(summary: Path, default: float) -> float:
    """The lane width of CATS's ``summary.json`` (``lanes.width_m``), else ``default`` [m]."""
    import json

    if not summary.is_file():
        return default
    try:
        meta = json.loads(summary.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{summary} is not valid JSON ({exc})") from None
    lanes = meta.get("lanes", {}) if isinstance(meta, dict) else None
    if not isinstance(lanes, dict):
        raise ValueError(f"{summary}: expected a JSON object whose 'lanes' is an object")
    key = next((k for k in ("width_m", "lane_width_m") if k in lanes), None)
    if key is None:
        return default
    w = lanes[key]
    if not isinstance(w, (int, float)) or isinstance(w, bool) or not (math.isfinite(w) and w > 0):
        raise ValueError(f"{summary}: lanes.{key} must be a positive number [m], got {w!r}")
    return _check_lane_width(float(w), f"{summary} (lanes.{key})")


def load_cats(
    data_dir: str | Path, dt: float = 0.2, neighbours: bool = True
) -> list[RecordedEpisode]:
    """The CATS field-test lane changes (``episodes.csv`` + ``episode_tracks.csv.gz``).

    Selection: the designed manoeuvres (``leg == "experiment"``: 6 by the computer-driven
    car, 4 by the human driver); the return-leg crossings are kept but not used (the
    README: not AV-style demonstrations). Lanes are the source's 3.95 m grid; every
    designed change goes right (lane 2 → 1) and is mirrored to +y.

    Args:
        data_dir: the ``cats-av-lanechange`` folder.
        dt: learner's sampling time [s].
        neighbours: keep the run's further vehicles (``role == "other"``) that come within
            :data:`NEIGHBOUR_RANGE` of the EV, as the demonstration's ``others``.

    Returns:
        All 31 episodes, ``used`` marking the selection; ``flags["set"]`` is AV or HV.

    Raises:
        FileNotFoundError: ``data_dir`` is a file, or a dataset file is missing.
        ValueError: a malformed file (not gzip, truncated, empty, header only, missing
            columns, non-numeric values, the other dataset's folder), lanes no road has
            (data in feet: convert to metres) or a bad ``dt``; the message names the file
            and the problem.
    """
    dt = _check_dt(dt)
    data_dir = _dataset_dir(data_dir)
    episodes = _read_csv(data_dir / "episodes.csv", "cats")
    tracks = _read_csv(data_dir / "episode_tracks.csv.gz", "cats")
    w = _cats_lane_width(data_dir / "summary.json", 3.95)
    out = []
    for row in episodes.itertuples():
        rows = tracks[tracks.episode_id == row.episode_id]
        ego, dropped_ego = clean_rows(rows[rows.role == "ego"])
        tgt, dropped_tgt = clean_rows(rows[rows.role == "target"])
        near = []
        if neighbours:
            for _, g in rows[rows.role == "other"].groupby("vehicle_id"):
                near.append(clean_rows(g)[0])
        reasons = [] if row.leg == "experiment" else ["return_leg"]
        qf = str(row.quality_flags) if isinstance(row.quality_flags, str) else ""
        mirror = row.lc_direction == "right"
        y_origin_lower = (-(row.from_lane + 1) * w) if mirror else row.from_lane * w
        flags = {
            "set": row.set,
            "leg": row.leg,
            "direction": row.lc_direction,
            "target_relation": row.target_relation
            if isinstance(row.target_relation, str)
            else None,
            "quality_flags": [f for f in qf.split(";") if f],
            "no_target": len(tgt) == 0,
            "lane_width_m": w,
            "rate_hz": 10.0,
            "dropped_rows": dropped_ego + dropped_tgt,
        }
        out.append(
            _episode(
                "cats",
                reasons,
                flags,
                row.episode_id,
                ego,
                tgt if len(tgt) else None,
                mirror,
                y_origin_lower,
                w,
                dt,
                near,
            )
        )
    return out
