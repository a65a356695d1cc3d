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
  φ = atan2(ẏ, ẋ) from the resampled positions, speed v from the recorded speed.

Scenario constants adapt to each episode (documented rule, :func:`scenario_from_episode`):
lane width from the data (NGSIM: median spacing of the recording's lane centres; CATS:
its fitted 3.95 m), v_ref from the EV's speed level (its 90th-percentile speed in the
window), the safety ellipse scaled with the lane width (l_b) and the speed (l_a = the
paper's 15 m at 27.5 m/s, i.e. a 0.55 s gap, with a 5 m floor).

Episodes without a target vehicle (CATS human-driven runs) get a phantom TV 1 km behind
in the destination lane: the trigger can never fire, so the reactive features are
inactive, and ``RecordedEpisode.flags["no_target"]`` says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from envs.demonstration import Demonstration
from envs.scenario import ScenarioConfig

__all__ = ["RecordedEpisode", "load_cats", "load_ngsim", "scenario_from_episode"]

PHANTOM_GAP_M = -1000.0
"""Gap of the phantom TV used when an episode has no target vehicle."""


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


def _read_csv(path: Path):
    import pandas as pd

    if not path.is_file():
        raise FileNotFoundError(
            f"{path} not found; pass the dataset folder (e.g. "
            "../shared/data/ngsim or ../shared/data/cats-av-lanechange)"
        )
    return pd.read_csv(path)


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
    v_level = float(np.percentile(ev[:, 3], 90))
    n = ev.shape[0]
    return ScenarioConfig(
        lane_width=lane_width,
        n_lanes=3,
        vehicle_length=length,
        vehicle_width=min(width, 0.9 * lane_width),
        l_f=0.4 * length,
        l_r=0.4 * length,
        v_max=max(70.0, 1.5 * float(ev[:, 3].max())),
        ev_lane=0,
        target_lane=1,
        tv_lane=1,
        ev_x=float(ev[0, 0]),
        ev_speed=float(ev[0, 3]),
        tv_gap=float(tv[0, 0] - ev[0, 0]),
        tv_speed=float(tv[0, 3]),
        v_ref=max(v_level, 1.0),
        dt=dt,
        horizon_s=round((n - 1) * dt, 9),
        l_a=max(5.0, 15.0 * v_level / 27.5),
        l_b=3.0 * lane_width / 5.25,
        check_start=False,
    )


def _resample(
    t_src: np.ndarray, x: np.ndarray, y: np.ndarray, v: np.ndarray, t_new: np.ndarray
) -> np.ndarray:
    """States [x, y, φ, v] on t_new from recorded positions and speeds."""
    from scipy.interpolate import CubicSpline

    sx, sy = CubicSpline(t_src, x), CubicSpline(t_src, y)
    phi = np.arctan2(sy(t_new, 1), sx(t_new, 1))
    return np.column_stack([sx(t_new), sy(t_new), phi, np.interp(t_new, t_src, v)])


def _grid(t_rel: np.ndarray, dt: float) -> np.ndarray:
    start = math.ceil(t_rel.min() / dt - 1e-9) * dt
    stop = math.floor(t_rel.max() / dt + 1e-9) * dt
    return np.round(np.arange(start, stop + dt / 2, dt), 9)


def clean_rows(df) -> tuple[Any, int]:
    """Drop rows with non-finite t/x/y/v or repeated times; returns (rows, dropped count)."""
    cols = ["t_rel_s", "x_m", "y_m", "v_mps"]
    ok = np.isfinite(df[cols].to_numpy(dtype=float)).all(axis=1)
    kept = df[ok].sort_values("t_rel_s").drop_duplicates("t_rel_s")
    return kept, int(len(df) - len(kept))


def _build(
    ep_id: str, ego, tgt, mirror: bool, y_origin_lower: float, lane_width: float, dt: float
) -> Demonstration:
    """Demonstration of one episode in the road frame (rows already cleaned)."""
    if len(ego) < 4:
        raise ValueError(f"only {len(ego)} valid ego rows")
    t_new = _grid(ego.t_rel_s.to_numpy(), dt)
    if t_new.size < 3:
        raise ValueError("fewer than 3 samples at T_s")

    def frame(df, t_query):
        y = df.y_m.to_numpy()
        y = -y if mirror else y
        return _resample(
            df.t_rel_s.to_numpy(),
            df.x_m.to_numpy(),
            y - y_origin_lower,
            df.v_mps.to_numpy(),
            t_query,
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
    L = float(ego.length_m.iloc[0]) if "length_m" in ego else 4.5
    W = float(ego.width_m.iloc[0]) if "width_m" in ego else 1.8
    sc = scenario_from_episode(ev, tv, lane_width, dt, L, W)
    u = np.zeros((t_new.size - 1, 2))  # inputs are not recorded
    return Demonstration(
        t=t_new - t_new[0],
        ev=ev,
        tv=tv,
        u=u,
        meta={"scenario": sc.to_dict(), "episode_id": ep_id, "t_cross_rel_s": float(-t_new[0])},
    )


def _episode(
    dataset: str, reasons: list[str], flags: dict[str, Any], episode_id: str, *build_args: Any
) -> RecordedEpisode:
    """Build one episode with ``_build(episode_id, *build_args)``.

    An unusable episode is kept, marked unused, with the reason.
    """
    try:
        demo = _build(episode_id, *build_args)
    except ValueError as exc:
        return RecordedEpisode(
            episode_id, dataset, False, (*reasons, f"unusable: {exc}"), None, flags
        )
    return RecordedEpisode(episode_id, dataset, not reasons, tuple(reasons), demo, flags)


def _lane_width_ngsim(tracks, recording: str) -> float:
    """Median spacing of the recording's mainline lane centres (lanes 1–5) [m]."""
    g = tracks[(tracks.recording == recording) & (tracks.lane_id.between(1, 5))]
    centres = g.groupby("lane_id").y_m.median().sort_index().to_numpy()
    return float(np.median(np.diff(centres)))


def load_ngsim(data_dir: str | Path, dt: float = 0.2) -> list[RecordedEpisode]:
    """The NGSIM lane-change episodes (``episodes.csv`` + ``episode_tracks.csv.gz``).

    Selection (the README's "clean" set): a complete ±4 s window and no ramp or auxiliary
    lane. Positions are the vehicles' front centres, as recorded. NGSIM's y grows to the
    right, so a lane change "left" (toward lane 1) is mirrored twice to become +y.

    Args:
        data_dir: the ``ngsim`` folder.
        dt: learner's sampling time [s].

    Returns:
        All 19 episodes, ``used`` marking the selection.
    """
    data_dir = Path(data_dir)
    episodes = _read_csv(data_dir / "episodes.csv")
    tracks = _read_csv(data_dir / "episode_tracks.csv.gz")
    all_tracks = _read_csv(data_dir / "tracks.csv.gz")
    out = []
    widths = {r: _lane_width_ngsim(all_tracks, r) for r in episodes.recording.unique()}
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
        # lane boundary: where the front centre crosses the marking (first new-lane sample
        # and the last old-lane one, linearly)
        before = ego[ego.t_rel_s < 0].iloc[-1]
        after = ego[ego.t_rel_s >= 0].iloc[0]
        y_b = 0.5 * (before.y_m + after.y_m)
        y_b = -y_b if mirror else y_b
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
        out.append(
            _episode("ngsim", reasons, flags, row.episode_id, ego, tgt, mirror, y_b - w, w, dt)
        )
    return out


def load_cats(data_dir: str | Path, dt: float = 0.2) -> list[RecordedEpisode]:
    """The CATS field-test lane changes (``episodes.csv`` + ``episode_tracks.csv.gz``).

    Selection: the designed manoeuvres (``leg == "experiment"``: 6 by the computer-driven
    car, 4 by the human driver); the return-leg crossings are kept but not used (the
    README: not AV-style demonstrations). Lanes are the source's 3.95 m grid; every
    designed change goes right (lane 2 → 1) and is mirrored to +y.

    Args:
        data_dir: the ``cats-av-lanechange`` folder.
        dt: learner's sampling time [s].

    Returns:
        All 31 episodes, ``used`` marking the selection; ``flags["set"]`` is AV or HV.
    """
    import json

    data_dir = Path(data_dir)
    episodes = _read_csv(data_dir / "episodes.csv")
    tracks = _read_csv(data_dir / "episode_tracks.csv.gz")
    w = 3.95
    summary = data_dir / "summary.json"
    if summary.is_file():
        w = float(json.loads(summary.read_text()).get("lanes", {}).get("lane_width_m", w))
    out = []
    for row in episodes.itertuples():
        rows = tracks[tracks.episode_id == row.episode_id]
        ego, dropped_ego = clean_rows(rows[rows.role == "ego"])
        tgt, dropped_tgt = clean_rows(rows[rows.role == "target"])
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
            )
        )
    return out
