"""The automated car against human drivers in the CATS field test (DESIGN §18).

CATS drove the same car (vehicle 3) on some days by computer (``cats:AV:3``) and on others
by a human (``cats:HV:3``), among human-driven vehicles. Each extracted lane change
(:func:`~drivestyle.recorded.benchmark.recorded_episodes`) is described by

* what the style model identifies: the posterior mean and 90 % interval width of the risk p
  (of lane changes within the class: an out-of-class driver has no risk of the class) and
  the verdict, read from a ``drivestyle mine-styles --dataset cats`` run (the same
  identification, not repeated here);
* what a cautious driver shows directly, measured on the observed trajectory alone: the
  least time gap to the vehicle ahead in the EV's lane, the closest approach to any vehicle
  (centre distance), the median speed, the peak lateral speed and the
  10–90 % lane-change duration.

Each quantity is compared between groups by its median with a percentile-bootstrap 95 %
interval over the group's episodes, and by the difference of medians (AV minus the other
group) with its interval. The AV is one vehicle, so the intervals describe its lane
changes, not a population of automated cars.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.stats import bootstrap_rows, percentile_interval
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lanes import leaders
from drivestyle.irl.identification.mined_row import MinedRow as MiningRow
from drivestyle.irl.identification.mining_output import TABLE, read_table
from drivestyle.irl.identification.verdict import (
    ENTERS_REGION,
    OUT_OF_CLASS,
    recorded_verdict_label,
)
from drivestyle.studies.real_traffic.study import lane_change_stats

AV_VEHICLE = "cats:AV:3"
"""The computer-driven car (CATS vehicle 3 on its AV days)."""
SAME_CAR_HUMAN = "cats:HV:3"
"""The same car driven by a human (its HV days)."""
GROUPS = ("AV", "same car, human", "other humans")
"""The compared groups, in report order."""
QUANTITIES = {
    "risk_mean": "identified risk p: posterior mean",
    "risk_interval_width": "identified risk p: 90 % interval width",
    "min_time_gap_s": "least time gap to the vehicle ahead in the EV's lane [s]",
    "min_distance_m": "closest approach to any vehicle (centres) [m]",
    "median_speed_mps": "median speed [m/s]",
    "peak_lateral_speed_mps": "peak lateral speed [m/s]",
    "duration_10_90_s": "10–90 % lane-change duration [s]",
}
"""Quantity → its meaning (the report's rows)."""
NEAR_M = 100.0
"""Closest approaches beyond this are no approach (a vehicle absent or far) [m]."""
NOT_MINED = "not mined"
"""The verdict of a lane change the mine-styles run has no ok row of."""
MIN_LANE_CHANGES = 3
"""Fewer lane changes in a group give its median but no interval and no difference (a
bootstrap of one or two values is no interval)."""
BOOTSTRAP_SAMPLES = 2000
BOOTSTRAP_SEED = 27


def group_of(vehicle: str) -> str:
    """The comparison group of a CATS vehicle id (``cats:<set>:<id>``).

    Raises:
        ValueError: not a CATS vehicle id.
    """
    if not vehicle.startswith("cats:"):
        raise ValueError(f"{vehicle!r} is not a CATS vehicle (cats:<AV|HV>:<id>)")
    if vehicle == AV_VEHICLE:
        return "AV"
    return "same car, human" if vehicle == SAME_CAR_HUMAN else "other humans"


def time_gaps(demo: Demonstration) -> np.ndarray:
    """Time gap to the EV's leader at every sample.

    The leader is the nearest vehicle ahead in the EV's lane (the one rule,
    :func:`drivestyle.envs.lanes.leaders`); the gap is bumper to bumper (centre distance
    minus one vehicle length).

    Args:
        demo: a demonstration (TV and ``others``).

    Returns:
        Shape (n,) [s]; inf where no vehicle is ahead in the lane or the EV stands.
    """
    sc = demo.scenario
    vehicles, ev = demo.vehicles, demo.ev
    lead = leaders(ev[:, 0], ev[:, 1], vehicles[..., 0], vehicles[..., 1], sc.lane_width)
    ahead_x = np.take_along_axis(vehicles[..., 0], np.maximum(lead, 0)[:, None], axis=1)[:, 0]
    gap = np.where(lead >= 0, np.maximum(ahead_x - ev[:, 0] - sc.vehicle_length, 0.0), np.inf)
    v = ev[:, 3]
    return np.where(v > 0.5, gap / np.maximum(v, 0.5), np.inf)


def closest_distance(demo: Demonstration, within: float = NEAR_M) -> float | None:
    """The least centre distance to any vehicle over the episode [m].

    None when no vehicle comes within ``within`` metres (recordings place absent vehicles
    far away).
    """
    v = demo.vehicles
    d = np.hypot(v[..., 0] - demo.ev[:, None, 0], v[..., 1] - demo.ev[:, None, 1])
    least = float(d.min()) if d.size else math.inf
    return least if least <= within else None


@dataclass(frozen=True)
class MinedRow:
    """One identification of a ``mine-styles`` run (``styles.csv``)."""

    risk_mean: float | None
    risk_lo: float | None
    risk_hi: float | None
    informative: bool
    out_of_class: bool
    constraint_binds: bool | None = None
    """None: a table written before the column (:func:`recorded_verdict_label`)."""
    enters_region: bool | None = None
    """None: a table written before the column."""

    @property
    def verdict(self) -> str:
        """The identification's label, by the identification's own rule."""
        return recorded_verdict_label(
            self.informative, self.out_of_class, self.constraint_binds, self.enters_region
        )


NEEDED_COLUMNS = ("id", "status", "risk_mean", "risk_lo", "risk_hi", "informative", "out_of_class")
"""The columns of ``styles.csv`` the comparison reads."""


def read_mined(folder: str | Path) -> dict[str, MinedRow]:
    """The ``ok`` rows of a mine-styles output folder, by episode id.

    Every row is validated as it is read
    (:func:`drivestyle.irl.identification.mining_output.read_table`): a torn row (an interrupted
    run, to be resumed), a value that does not parse or lies outside its range (a risk outside
    (0, 1), a negative width, an unknown status) is an error naming the file, the row, the
    column and the value, never a lane change quietly counted as not mined.

    Raises:
        FileNotFoundError: no ``styles.csv`` in ``folder``.
        ValueError: the file lacks the identification's columns, is not a mine-styles table,
            has a damaged row, no row at all or no ``ok`` row.
    """
    path = Path(folder) / TABLE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found; run drivestyle mine-styles --dataset cats")
    # utf-8-sig: a byte-order mark (a spreadsheet's UTF-8) is no part of the first column
    with path.open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        header = next(csv.reader(fh), [])
    missing = sorted(c for c in NEEDED_COLUMNS if c not in header)
    if missing:
        raise ValueError(f"{path}: no column {', '.join(missing)} (a mine-styles table?)")
    rows = read_table(path)
    if not rows:
        raise ValueError(
            f"{path} has no row: the mining run mined nothing yet (resume it, or mine the "
            "CATS sample: drivestyle mine-styles --dataset cats)"
        )
    ok = {r.id: _mined(r) for r in rows if r.status == "ok"}
    if not ok:
        failed = next(r for r in rows if r.status == "failed")
        raise ValueError(
            f"{path}: all {len(rows)} rows failed, none identified a risk (row {failed.id}: "
            f"{failed.error})"
        )
    return ok


def _mined(row: MiningRow) -> MinedRow:
    """What the comparison takes of a mined row."""
    return MinedRow(
        row.risk_mean,
        row.risk_lo,
        row.risk_hi,
        bool(row.informative),
        bool(row.out_of_class),
        row.constraint_binds,
        row.enters_region,
    )


def unmined(
    episodes: Sequence[tuple[str, str, Demonstration]], mined: Mapping[str, MinedRow]
) -> list[str]:
    """The episodes without an ``ok`` row in ``mined``, refusing rows of none of them.

    A run of another dataset (or of nothing CATS) would leave every lane change "not
    mined": a table of nothing, read as a finding.

    Args:
        episodes: (episode id, vehicle id, demonstration) of the CATS lane changes.
        mined: a mine-styles run's ok rows by id (:func:`read_mined`).

    Returns:
        The ids of the episodes ``mined`` has no row of, in episode order.

    Raises:
        ValueError: ``mined`` has a row of none of the episodes.
    """
    ids = [eid for eid, _, _ in episodes]
    if not mined.keys() & set(ids):
        theirs = sorted(mined)[:3]
        raise ValueError(
            f"the mined rows are of none of the {len(ids)} CATS lane changes (their ids: "
            f"{', '.join(theirs)}{' …' if len(mined) > 3 else ''}); mine the CATS sample: "
            "drivestyle mine-styles --dataset cats"
        )
    return [eid for eid in ids if eid not in mined]


@dataclass(frozen=True)
class EpisodeCaution:
    """One lane change's identified and observed caution."""

    episode_id: str
    vehicle: str
    group: str
    values: dict[str, float | None]
    """:data:`QUANTITIES` key → value (None: not available, e.g. not mined)."""
    verdict: str
    """The identification's label (:data:`~drivestyle.irl.identification.posterior.VERDICT_LABELS`),
    or :data:`NOT_MINED`."""


def episode_caution(
    episode_id: str, vehicle: str, demo: Demonstration, mined: MinedRow | None
) -> EpisodeCaution:
    """Describe one lane change (module docstring)."""
    gaps = time_gaps(demo)
    stats = lane_change_stats(demo)
    values: dict[str, float | None] = {
        "risk_mean": None,
        "risk_interval_width": None,
        "min_time_gap_s": float(gaps.min()) if np.isfinite(gaps).any() else None,
        "min_distance_m": closest_distance(demo),
        "median_speed_mps": float(np.median(demo.ev[:, 3])),
        "peak_lateral_speed_mps": stats["peak_lateral_speed_mps"],
        "duration_10_90_s": stats["duration_10_90_s"],
    }
    verdict = NOT_MINED
    if mined is not None:
        verdict = mined.verdict
        # a driver the style does not describe has no risk of the class: its posterior
        # may have moved, but not towards anything the class means
        if verdict not in (OUT_OF_CLASS, ENTERS_REGION):
            values["risk_mean"] = mined.risk_mean
            if mined.risk_lo is not None and mined.risk_hi is not None:
                values["risk_interval_width"] = mined.risk_hi - mined.risk_lo
    return EpisodeCaution(episode_id, vehicle, group_of(vehicle), values, verdict)


@dataclass(frozen=True)
class GroupStat:
    """A quantity's median in one group, with its bootstrap 95 % interval."""

    quantity: str
    group: str
    n: int
    median: float | None
    lo: float | None
    hi: float | None


@dataclass(frozen=True)
class Difference:
    """Median of the AV minus median of another group, with its bootstrap 95 % interval."""

    quantity: str
    against: str
    median: float | None
    lo: float | None
    hi: float | None

    @property
    def excludes_zero(self) -> bool:
        """Whether the interval lies on one side of 0 (a difference the data support)."""
        return self.lo is not None and self.hi is not None and (self.lo > 0 or self.hi < 0)


def _median_draws(values: np.ndarray, rng: np.random.Generator, samples: int) -> np.ndarray:
    """The median over bootstrap replicates of lane changes (each its own unit)."""
    rows = bootstrap_rows(range(values.size), samples, rng)
    return np.median(values[np.array(rows)], axis=1)


@dataclass(frozen=True)
class AVHumanComparison:
    """The comparison (``av_vs_human.json``)."""

    episodes: tuple[EpisodeCaution, ...]
    stats: tuple[GroupStat, ...]
    differences: tuple[Difference, ...]
    verdicts: dict[str, dict[str, int]]
    """Group → verdict → lane changes."""
    samples: int = BOOTSTRAP_SAMPLES
    """Bootstrap replicates the intervals were drawn with."""
    seed: int = BOOTSTRAP_SEED
    """Their seed."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "quantities": QUANTITIES,
            "bootstrap": {
                "samples": self.samples,
                "seed": self.seed,
                "unit": "episode (lane change)",
            },
            "verdicts": self.verdicts,
            "stats": [vars(s) for s in self.stats],
            "differences": [vars(d) | {"excludes_zero": d.excludes_zero} for d in self.differences],
            "episodes": [vars(e) for e in self.episodes],
        }


def compare_av_human(
    episodes: Sequence[tuple[str, str, Demonstration]],
    mined: Mapping[str, MinedRow] | None = None,
    samples: int = BOOTSTRAP_SAMPLES,
    seed: int = BOOTSTRAP_SEED,
) -> AVHumanComparison:
    """Compare the AV's lane changes with the humans' (module docstring).

    Args:
        episodes: (episode id, vehicle id, demonstration) of CATS lane changes, as
            :func:`~drivestyle.recorded.benchmark.recorded_episodes` returns them.
        mined: a mine-styles run's rows by episode id (None: no identified quantities).
        samples: bootstrap replicates.
        seed: their seed (deterministic given it).

    Returns:
        The comparison.

    Raises:
        ValueError: no episode of the AV, or none of a human; ``mined`` rows of none of
            the episodes (a run of another dataset).
    """
    if mined is not None:
        unmined(episodes, mined)
    rows = tuple(
        episode_caution(eid, vid, demo, (mined or {}).get(eid)) for eid, vid, demo in episodes
    )
    present = {r.group for r in rows}
    if "AV" not in present or present == {"AV"}:
        raise ValueError(
            f"need lane changes of the AV ({AV_VEHICLE}) and of humans; got groups "
            f"{sorted(present)}"
        )
    rng = np.random.default_rng(seed)
    stats, diffs = [], []
    for q in QUANTITIES:
        draws: dict[str, np.ndarray | None] = {}
        medians: dict[str, float | None] = {}
        for g in GROUPS:
            x = np.array([r.values[q] for r in rows if r.group == g and r.values[q] is not None])
            medians[g] = float(np.median(x)) if x.size else None
            d = _median_draws(x, rng, samples) if x.size >= MIN_LANE_CHANGES else None
            lo: float | None = None
            hi: float | None = None
            if d is not None:
                lo, hi = percentile_interval(d)
            stats.append(GroupStat(q, g, int(x.size), medians[g], lo, hi))
            draws[g] = d
        for g in GROUPS[1:]:
            a, b, med, other = draws["AV"], draws[g], medians["AV"], medians[g]
            if a is None or b is None or med is None or other is None:
                diffs.append(Difference(q, g, None, None, None))
                continue
            lo_d, hi_d = percentile_interval(a - b)
            diffs.append(Difference(q, g, med - other, lo_d, hi_d))
    verdicts: dict[str, dict[str, int]] = {}
    for r in rows:
        verdicts.setdefault(r.group, {}).setdefault(r.verdict, 0)
        verdicts[r.group][r.verdict] += 1
    return AVHumanComparison(rows, tuple(stats), tuple(diffs), verdicts, samples, seed)
