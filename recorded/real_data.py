"""The shipped recorded samples (NGSIM I-80 / US-101, the CATS AV field test) as episodes.

Both samples go through the one extraction every recorded source uses
(:func:`~drivestyle.recorded.readers.read_sample` then
:func:`~drivestyle.recorded.episodes.extract_episodes`, DESIGN §15): the road frame, lane
changes to the right mirrored to +y, resampling to T_s by splines local to each sample
interval, heading and speed from the track, recovered inputs, interacting vehicles chosen
at the window's start, and the scenario from the observed part only. What this module adds
is the samples' curated selection: each row of the converters' ``episodes.csv`` is matched
to the extracted lane change of the same recording and ego vehicle whose crossing lies
within :data:`MATCH_S` of it, and keeps the row's id, quality flags and the documented
selection (``used``). Extracted changes without a row (other vehicles' changes, crossings
the converters rejected) are the extraction's, not the selection's:
``drivestyle extract-episodes DATA --format sample`` writes them all.

Scenario constants follow the loaders' documented rule (DESIGN §10): v_ref from the EV's
speed level and the ellipse scaled with it (l_a = the paper's 15 m at 27.5 m/s with a 5 m
floor, l_b with the lane width), both from the observed part. An episode without an
interacting vehicle has a phantom TV 1 km ahead in the target lane, and
``flags["no_target"]`` says so: its risk cannot be identified.

Units are checked by the reader: lanes no road has (NGSIM's native feet give 12.1 m)
refuse the sample with a message saying to convert.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import recover_inputs
from drivestyle.recorded.episodes import Episode, ExtractionConfig, extract_episodes

__all__ = [
    "DATASETS",
    "MATCH_S",
    "RecordedEpisode",
    "RecordedVehicle",
    "check_data_dir",
    "is_recorded",
    "load_cats",
    "load_ngsim",
    "needs_recorded_bounds",
    "recorded_vehicle",
    "recorded_view",
    "with_recorded_bounds",
]

MATCH_S = 0.5
"""A curated row and an extracted change are the same lane change when their crossing
times differ by at most this [s] (the converters' t_cross is the first sample in the new
lane, the extraction's the interpolated line crossing: I-80 is sampled at 2 Hz)."""


@dataclass(frozen=True)
class RecordedEpisode:
    """One recorded lane change of a curated sample."""

    episode_id: str
    """The sample's id (``episodes.csv``)."""
    dataset: str
    """'ngsim' or 'cats'."""
    used: bool
    """Whether the episode passes the documented selection."""
    reasons: tuple[str, ...]
    """Why it is not used (empty when used)."""
    demo: Demonstration | None
    """The episode as a demonstration (None if it could not be built)."""
    flags: dict[str, Any] = field(default_factory=dict)
    """Source quality flags and episode facts (direction, target relation, set, the
    extraction's id and interacting vehicles, …)."""


DATASETS = {"ngsim": "ngsim", "cats": "cats-av-lanechange"}
"""The shipped samples: dataset key → its folder's name under the data folder
(``../shared/data`` beside a checkout)."""


def check_data_dir(
    data_dir: str | Path,
    datasets: tuple[str, ...] = tuple(DATASETS),
    default: str | Path | None = None,
    otherwise: str = "",
) -> None:
    """Refuse, before any work, a ``--data-dir`` without the shipped samples a command reads.

    The message names the option and, when the folder is the default (a command run away
    from a checkout, where ``../shared/data`` is not beside it), says so: a missing file deep
    under a default the user never typed ("../shared/data/cats-av-lanechange/tracks.csv.gz:
    no such file") does not say which option to give.

    Args:
        data_dir: the folder given (or the default).
        datasets: keys of :data:`DATASETS` the command reads.
        default: the option's default (the message says when ``data_dir`` is it).
        otherwise: what else the user may do (", or --no-recorded"), appended.

    Raises:
        FileNotFoundError: a dataset's folder is missing.
    """
    for ds in datasets:
        folder = DATASETS[ds]
        if not (Path(data_dir) / folder).is_dir():
            said = (
                f"--data-dir {data_dir} (the default, relative to the working folder {Path.cwd()})"
                if default is not None and Path(data_dir) == Path(default)
                else f"--data-dir {data_dir}"
            )
            raise FileNotFoundError(
                f"{said}: no {folder}/ folder; pass --data-dir with the folder holding "
                f"{' and '.join(f'{DATASETS[d]}/' for d in datasets)}{otherwise}"
            )


_DATASETS = {
    "ngsim": ("NGSIM", "load_ngsim", f"../shared/data/{DATASETS['ngsim']}", "recording"),
    "cats": ("CATS", "load_cats", f"../shared/data/{DATASETS['cats']}", "run_id"),
}
"""Dataset key → (name, loader, example folder, the recording column), for messages."""

_COLUMNS: dict[str, tuple[str, ...]] = {
    "ngsim": (
        "episode_id",
        "recording",
        "ego_id",
        "t_cross_s",
        "direction",
        "target_relation",
        "target_selected_at",
        "target_set_complete",
        "rate_hz",
        "complete_window",
        "involves_ramp_or_aux_lane",
    ),
    "cats": (
        "episode_id",
        "set",
        "run_id",
        "leg",
        "ego_id",
        "t_cross_s",
        "lc_direction",
        "from_lane",
        "target_relation",
        "quality_flags",
    ),
}
"""Columns each loader reads from its sample's ``episodes.csv``."""

_NUMERIC = ("t_cross_s", "rate_hz", "from_lane")


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


def _read_episodes(path: Path, dataset: str):
    """The sample's ``episodes.csv``, checked for what the selection reads.

    Raises:
        FileNotFoundError: the file is missing.
        ValueError: an empty file, the other dataset's file, missing columns, no rows, or
            non-numeric values in a numeric column; the message names the file.
    """
    import pandas as pd

    if not path.is_file():
        raise FileNotFoundError(
            f"{path} not found; pass the dataset folder (e.g. "
            "../shared/data/ngsim or ../shared/data/cats-av-lanechange)"
        )
    try:
        df = pd.read_csv(path)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path} is empty (no header, no rows)") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path} is not a readable CSV ({exc})") from None
    required = _COLUMNS[dataset]
    name, loader, folder, _ = _DATASETS[dataset]
    missing = [c for c in required if c not in df.columns]
    if missing:
        for other, theirs in _COLUMNS.items():
            if other != dataset and set(theirs) <= set(df.columns):
                o_name, o_loader, _, _ = _DATASETS[other]
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


RECORDED_PHI_MAX = 0.3
"""Heading bound of the driver model on recorded traffic [rad]. The scenario's 0.05 rad is
a highway lane change's; the recorded EVs reach 0.07–0.22 rad (CATS at 4–7 m/s, NGSIM in
stop-and-go), and a plan from a state outside the bound is infeasible."""
RECORDED_DELTA_MAX = 0.25
"""Steering bound of the driver model on recorded traffic [rad] (the recorded lane changes
need up to 0.16 rad, :func:`~drivestyle.envs.dynamics.recover_inputs`; the scenario's 0.05 rad
is a highway's)."""
HEADING_MARGIN = 1.2
"""A recording needs :func:`driver_demo`'s bounds when its heading exceeds the scenario's
bound by more than this factor (an SMPC recorded as a table stays at its own 0.05 rad, up
to the heading estimate's error; recorded drivers reach 1.3–5× it)."""


def is_recorded(demo: Demonstration) -> bool:
    """Whether a demonstration is a recorded episode (``demo.origin``)."""
    return demo.origin == "recorded"


@dataclass(frozen=True)
class RecordedVehicle:
    """The vehicle a recorded episode is of (:func:`recorded_vehicle`)."""

    source: str
    """The recording's file (``meta["source"]``; empty where unknown)."""
    carriageway: str
    """The carriageway within it (empty where the episode's id does not say)."""
    vehicle_id: str
    """The recording's vehicle id (``meta["vehicle_id"]``)."""

    def __str__(self) -> str:
        return f"{self.carriageway}:{self.vehicle_id}" if self.carriageway else self.vehicle_id


def recorded_vehicle(demo: Demonstration) -> RecordedVehicle | None:
    """Which recorded vehicle a demonstration is of; None where its metadata does not say.

    A vehicle id is unique within its carriageway of one recording (the rule of
    :func:`~drivestyle.recorded.episode_files.read_episodes`, ``<carriageway>:<vehicle
    id>``), so a recorded vehicle is (``meta["source"]``, the carriageway,
    ``meta["vehicle_id"]``). The
    carriageway is read from the extraction's episode id, ``<carriageway>_<vehicle
    id>_<crossing ms>`` (``meta["extraction_id"]`` of a curated episode, else
    ``meta["episode_id"]``). The same car on two carriageways (CATS's vehicle 3 on two days)
    is two vehicles here: nothing in an episode's metadata ties them. A demonstration
    without ``meta["vehicle_id"]`` (a generated SMPC demonstration) is of no known vehicle.
    """
    vehicle_id = demo.meta.get("vehicle_id")
    if vehicle_id is None or str(vehicle_id) == "":
        return None
    vid = str(vehicle_id)
    eid = str(demo.meta.get("extraction_id") or demo.meta.get("episode_id") or "")
    found = re.fullmatch(rf"(.+)_{re.escape(vid)}_\d+", eid)
    return RecordedVehicle(str(demo.meta.get("source") or ""), found[1] if found else "", vid)


def needs_recorded_bounds(demo: Demonstration, until: int | None = None) -> bool:
    """Whether a recorded episode leaves its scenario's heading bound (:data:`HEADING_MARGIN`).

    Under the scenario's bounds such an episode's own states are infeasible and every solve
    fails; one that stays inside keeps its scenario (a simulated driver written to a file
    is identified like its ``.npz``: the SMPC's heading bound binds, and wider bounds move
    an SMPC(0.9)'s identified risk to 0.83).

    Args:
        demo: a demonstration.
        until: the last sample the decision may read (an observer at t_obs has seen
            samples 0 … k_obs only); None: every sample.
    """
    sc = demo.scenario
    if not is_recorded(demo) or sc.phi_max >= RECORDED_PHI_MAX:  # already under them
        return False
    heading = demo.ev[: None if until is None else until + 1, 2]
    return bool(np.abs(heading).max() > HEADING_MARGIN * sc.phi_max)


def recorded_view(demo: Demonstration, until: int | None = None) -> Demonstration:
    """The one view of a demonstration that identification, mining, learning and prediction use.

    A recorded episode whose heading over the samples read (0 … ``until``) leaves its
    scenario's bound (:func:`needs_recorded_bounds`) is seen under the recorded bounds with
    its inputs recovered under them (:func:`with_recorded_bounds`); any other demonstration
    (simulated, or recorded inside the bounds) is returned as it is. The view is
    idempotent, and it reads nothing after ``until``: an observer's view at t_obs is the
    offline view of the samples up to t_obs.

    Args:
        demo: a demonstration (recorded or simulated).
        until: the last sample observed (None: the whole demonstration).

    Returns:
        The demonstration the driver model solves on.
    """
    return with_recorded_bounds(demo) if needs_recorded_bounds(demo, until) else demo


def with_recorded_bounds(demo: Demonstration) -> Demonstration:
    """A recorded episode under the driver model's recorded bounds.

    The heading and steering bounds become :data:`RECORDED_PHI_MAX` and
    :data:`RECORDED_DELTA_MAX`, and the inputs are recovered within them
    (:func:`~drivestyle.envs.dynamics.recover_inputs`); states and vehicles are unchanged.
    This is a recovery of its own, not the extraction's inputs clipped: the bounded
    inverse step's path depends on the bounds, and on the shipped samples the two differ
    at 1044 of 4673 steps, 24 of them with the wider δ inside the scenario's bound.

    Args:
        demo: a recorded episode.

    Returns:
        The demonstration; applying it again changes nothing (so :func:`recorded_view` of
        a viewed episode is the episode).
    """
    sc = replace(demo.scenario, phi_max=RECORDED_PHI_MAX, delta_max=RECORDED_DELTA_MAX)
    return replace(
        demo, u=recover_inputs(demo.ev, sc, demo.t), meta={**demo.meta, "scenario": sc.to_dict()}
    )


def _extracted(data_dir: Path, dt: float) -> list[Episode]:
    """Every lane change of the sample's ``tracks.csv.gz`` (the loaders' scenario rule)."""
    from drivestyle.recorded.readers import read_sample

    try:
        recording = read_sample(data_dir)
    except FileNotFoundError:
        raise FileNotFoundError(
            f"{data_dir / 'tracks.csv.gz'} not found; pass the dataset folder (e.g. "
            "../shared/data/ngsim or ../shared/data/cats-av-lanechange)"
        ) from None
    return extract_episodes(recording, ExtractionConfig(dt=dt, l_a=None))


def _selected(
    dataset: str, row: Any, reasons: list[str], flags: dict[str, Any],
    extracted: list[Episode], neighbours: bool,
) -> RecordedEpisode:  # fmt: skip
    """One curated row as a :class:`RecordedEpisode`, its demonstration the extraction's."""
    recording = str(getattr(row, _DATASETS[dataset][3]))
    matches = [
        e
        for e in extracted
        if e.carriageway == recording
        and e.vehicle_id == str(row.ego_id)
        and abs(e.t_cross - float(row.t_cross_s)) <= MATCH_S
    ]
    if not matches:
        why = (
            "not extracted: a ramp or auxiliary lane (no lane for it on the main carriageway)"
            if "ramp_or_aux_lane" in reasons
            else f"not extracted: no lane change of vehicle {row.ego_id} within {MATCH_S:g} s"
        )
        return RecordedEpisode(row.episode_id, dataset, False, (*reasons, why), None, flags)
    ep = min(matches, key=lambda e: abs(e.t_cross - float(row.t_cross_s)))
    flags = {
        **flags,
        "extraction_id": ep.episode_id,
        "lane_width_m": ep.lane_width,
        "interacting": [list(pair) for pair in ep.interacting],
        "no_target": ep.no_interaction,
    }
    if ep.demo is None:
        return RecordedEpisode(row.episode_id, dataset, False, (*reasons, *ep.reasons), None, flags)
    demo = ep.demo
    meta = {**demo.meta, "episode_id": row.episode_id, "extraction_id": ep.episode_id}
    others = demo.others if neighbours else None
    observed = demo.observed if neighbours or demo.observed is None else demo.observed[:1]
    demo = Demonstration(t=demo.t, ev=demo.ev, tv=demo.tv, u=demo.u, meta=meta, others=others,
                         origin=demo.origin, observed=observed)  # fmt: skip
    reasons = [*reasons, *ep.reasons]
    return RecordedEpisode(row.episode_id, dataset, not reasons, tuple(reasons), demo, flags)


def load_ngsim(
    data_dir: str | Path, dt: float = 0.2, neighbours: bool = True
) -> list[RecordedEpisode]:
    """The NGSIM sample's curated lane changes, extracted from its ``tracks.csv.gz``.

    Selection (the README's "clean" set): a complete ±4 s window and no ramp or auxiliary
    lane.

    Args:
        data_dir: the ``ngsim`` folder.
        dt: learner's sampling time [s].
        neighbours: keep the interacting vehicles beyond the TV (target-lane leader or
            follower, own-lane leader) as the demonstration's ``others``.

    Returns:
        All 19 curated episodes, ``used`` marking the selection.

    Raises:
        FileNotFoundError: ``data_dir`` is a file, or a sample file is missing.
        ValueError: a malformed file (the reader's one-line errors; an empty
            ``episodes.csv``, missing columns, non-numeric values, the other dataset's
            folder), lanes no road has (data in feet), or a bad ``dt``.
    """
    dt = _check_dt(dt)
    data_dir = _dataset_dir(data_dir)
    rows = _read_episodes(data_dir / "episodes.csv", "ngsim")
    extracted = _extracted(data_dir, dt)
    out = []
    for row in rows.itertuples():
        reasons = []
        if not row.complete_window:
            reasons.append("incomplete_window")
        if row.involves_ramp_or_aux_lane:
            reasons.append("ramp_or_aux_lane")
        flags = {
            "direction": row.direction,
            "target_relation": row.target_relation,
            "target_selected_at": row.target_selected_at,
            "target_set_complete": bool(row.target_set_complete),
            "rate_hz": float(row.rate_hz),
            "recording": row.recording,
        }
        out.append(_selected("ngsim", row, reasons, flags, extracted, neighbours))
    return out


def load_cats(
    data_dir: str | Path, dt: float = 0.2, neighbours: bool = True
) -> list[RecordedEpisode]:
    """The CATS sample's curated lane changes of vehicle 3, extracted from ``tracks.csv.gz``.

    Selection: the designed manoeuvres (``leg == "experiment"``: 6 by the computer-driven
    car, 4 by the human driver); the return-leg crossings are kept but not used (the
    README: not AV-style demonstrations). Every designed change goes right and is mirrored.

    Args:
        data_dir: the ``cats-av-lanechange`` folder.
        dt: learner's sampling time [s].
        neighbours: keep the interacting vehicles beyond the TV as ``others``.

    Returns:
        All 31 curated episodes, ``used`` marking the selection; ``flags["set"]`` is AV or
        HV.

    Raises:
        FileNotFoundError: ``data_dir`` is a file, or a sample file is missing.
        ValueError: a malformed file, lanes no road has (data in feet), or a bad ``dt``.
    """
    dt = _check_dt(dt)
    data_dir = _dataset_dir(data_dir)
    rows = _read_episodes(data_dir / "episodes.csv", "cats")
    extracted = _extracted(data_dir, dt)
    out = []
    for row in rows.itertuples():
        reasons = [] if row.leg == "experiment" else ["return_leg"]
        qf = str(row.quality_flags) if isinstance(row.quality_flags, str) else ""
        flags = {
            "set": row.set,
            "leg": row.leg,
            "direction": row.lc_direction,
            "target_relation": row.target_relation
            if isinstance(row.target_relation, str)
            else None,
            "quality_flags": [f for f in qf.split(";") if f],
            "rate_hz": 10.0,
        }
        out.append(_selected("cats", row, reasons, flags, extracted, neighbours))
    return out
