"""The recorded benchmark: every shipped lane change, split by vehicle (RESULTS §13).

Every lane change the extraction finds in the shipped NGSIM and CATS samples
(:func:`recorded_episodes`: every vehicle's, not only the converters' curated ones) is
assigned once, by *vehicle* (all of a vehicle's episodes in one split), to train /
validation / test (:func:`benchmark_split`, seed :data:`SPLIT_SEED`, stratified by dataset;
committed as ``drivestyle/data/benchmark_split.csv``, :data:`SPLIT_FILE`). A vehicle is an
NGSIM vehicle (``ngsim:<site>:<id>``) or a CATS vehicle on one day (``cats:AV:<id>``, the
automated-driving day, ``cats:HV:<id>``, the human-driven one: vehicle 3 is the automated
car, resp. the human-driven one, and 1, 2, 4 the others). The learning studies' "used"
selection (designed manoeuvres, complete windows) is not applied: every recorded lane
change is one to predict.

A split is a CSV (:func:`write_split`, :func:`read_split`, every row checked) applied to the
episodes at hand with :func:`check_split_vehicles` (no vehicle in two splits);
:func:`load_recorded` takes a sample's episodes of one split. A folder of extracted episodes
(``drivestyle extract-episodes``) is split the same way (:func:`episodes_split`) and loaded
as the benchmark takes it (:func:`load_episodes_folder`).
"""

from __future__ import annotations

import functools
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.recorded.kinds import is_window_id
from drivestyle.recorded.real_data import DATASETS

__all__ = [
    "DEFAULT_DATA_DIR",
    "EPISODES_SET",
    "SPLITS",
    "SPLIT_ALL_FILE",
    "SPLIT_FILE",
    "SPLIT_FRACTIONS",
    "SPLIT_HEADER",
    "SPLIT_SEED",
    "SplitRow",
    "benchmark_split",
    "benchmark_split_all",
    "check_sample_split",
    "check_split_selects",
    "check_split_vehicles",
    "episodes_split",
    "load_episodes_folder",
    "load_recorded",
    "read_split",
    "recorded_episodes",
    "split_by_vehicle",
    "split_contents",
    "write_split",
]

DEFAULT_DATA_DIR = Path("../shared/data")
"""Where the recorded datasets sit beside a checkout (they are not part of the repository)."""

SPLITS = ("train", "validation", "test")
"""The benchmark's splits (``--split all`` of an episodes folder takes every row)."""
EPISODES_SET = "episodes"
"""The set of a folder of extracted episodes (``evaluate-prediction --episodes``)."""
SPLIT_FRACTIONS = {"test": 0.2, "validation": 0.2}
"""Share of each dataset's vehicles held out per split (train: the rest)."""
SPLIT_SEED = 26
"""The seed of the benchmark's split; fixed since the split was committed (:data:`SPLIT_FILE`):
another seed would re-split every study's train, validation and test vehicles."""
_PACKAGE_DATA = Path(str(resources.files("drivestyle") / "data"))  # shipped with the wheel
SPLIT_FILE = _PACKAGE_DATA / "benchmark_split.csv"
"""The committed split (:func:`write_split` of :func:`benchmark_split`)."""
SPLIT_ALL_FILE = _PACKAGE_DATA / "benchmark_split_all.csv"
"""The committed split of every vehicle's episodes (:func:`benchmark_split_all`)."""


@dataclass(frozen=True)
class SplitRow:
    """One episode's place in the benchmark split."""

    dataset: str
    """``ngsim`` or ``cats``."""
    episode_id: str
    vehicle_id: str
    """``ngsim:<site>:<ego id>`` or ``cats:AV`` / ``cats:HV`` (the driver of vehicle 3)."""
    split: str
    """A name of :data:`SPLITS`."""
    source: str = field(default="", compare=False, repr=False)
    """The split file it was read from (:func:`read_split`; empty: made here), for messages."""
    row: int = field(default=0, compare=False, repr=False)
    """Its row in that file (1 = the first below the header)."""

    @property
    def where(self) -> str:
        """The row as a message names it: ``FILE, row N`` (else its episode)."""
        if self.source:
            return f"{self.source}, row {self.row}"
        return f"the split's row of episode {self.episode_id}"


@functools.lru_cache(maxsize=4)
def recorded_episodes(
    data_dir: str, dataset: str, all_vehicles: bool = False
) -> tuple[tuple[str, str, Demonstration], ...]:
    """Every usable lane change of a shipped sample, as the extraction finds it.

    The sample's whole ``tracks.csv.gz`` goes through
    :func:`~drivestyle.recorded.readers.read_sample` and
    :func:`~drivestyle.recorded.episodes.extract_episodes` with the default
    :class:`~drivestyle.recorded.episodes.ExtractionConfig` (the path ``drivestyle
    extract-episodes --format sample`` takes); every vehicle's changes count, not only the
    converters' curated ones.

    Args:
        data_dir: the folder holding the datasets (a string: the result is cached).
        dataset: a key of :data:`DATASETS`.
        all_vehicles: also every vehicle's windows without a lane change
            (``extract-episodes --all-vehicles``, :mod:`drivestyle.recorded.windows`).

    Returns:
        (episode id, vehicle id, demonstration) per usable episode, in extraction order. A
        vehicle is ``ngsim:<site>:<id>`` (site: the recording's prefix, ``i80`` or
        ``us101``) or ``cats:<set>:<id>`` (set: ``AV`` or ``HV``, the day and driver of
        the run, from its ``run_id``).

    Raises:
        ValueError: an unknown dataset; the reader's errors for missing or malformed files.
    """
    from drivestyle.recorded.episodes import extract_episodes
    from drivestyle.recorded.readers import read_sample

    if dataset not in DATASETS:
        raise ValueError(f"unknown dataset {dataset!r}; known: {sorted(DATASETS)}")
    recording = read_sample(Path(data_dir) / DATASETS[dataset])
    out = []
    for e in extract_episodes(recording, all_vehicles=all_vehicles):
        if not e.usable or e.demo is None:
            continue
        group = e.carriageway.split("_" if dataset == "ngsim" else "-")[0]
        out.append((e.episode_id, f"{dataset}:{group}:{e.vehicle_id}", e.demo))
    return tuple(out)


def check_sample_split(data_dir: str | Path, rows: Sequence[SplitRow]) -> None:
    """:func:`check_split_vehicles` of a split applied to the shipped samples in ``data_dir``.

    Raises:
        ValueError: a row's vehicle is not its episode's, or a vehicle in two splits.
    """
    windows = any(is_window_id(r.episode_id) for r in rows)
    vehicles = {
        eid: vid
        for ds in DATASETS
        if any(r.dataset == ds for r in rows)
        for eid, vid, _ in recorded_episodes(str(data_dir), ds, windows)
    }
    check_split_vehicles(rows, vehicles)


def _episode_vehicles(
    data_dir: Path, dataset: str, all_vehicles: bool = False
) -> list[tuple[str, str]]:
    """(episode id, vehicle id) of every usable episode of a sample (:func:`recorded_episodes`)."""
    return [(eid, vid) for eid, vid, _ in recorded_episodes(str(data_dir), dataset, all_vehicles)]


def split_by_vehicle(
    pairs: Sequence[tuple[str, str]], dataset: str, seed: int = SPLIT_SEED, stream: int = 0
) -> list[SplitRow]:
    """Assign episodes to train / validation / test by their vehicle (module docstring).

    The distinct vehicles, sorted, are shuffled by ``default_rng([seed, stream])``; the
    first ⌊0.2 n + ½⌋ (at least 1 where n ≥ 2) go to test, the next ⌊0.2 n + ½⌋ (at least 1
    where n ≥ 3) to validation, the rest to train. With two vehicles one is train and one
    test.

    Args:
        pairs: (episode id, vehicle id) per episode.
        dataset: the rows' dataset (the set their records are summarised under).
        seed: the split's seed.
        stream: the generator's second key (the shipped samples: the dataset's index).

    Returns:
        One row per episode, in the order of ``pairs``.
    """
    vehicles = sorted({v for _, v in pairs})
    order = [vehicles[j] for j in np.random.default_rng([seed, stream]).permutation(len(vehicles))]
    n = len(order)
    n_test = max(1 if n >= 2 else 0, math.floor(SPLIT_FRACTIONS["test"] * n + 0.5))
    n_val = max(1 if n >= 3 else 0, math.floor(SPLIT_FRACTIONS["validation"] * n + 0.5))
    split = {v: "test" for v in order[:n_test]}
    split |= {v: "validation" for v in order[n_test : n_test + n_val]}
    split |= {v: "train" for v in order[n_test + n_val :]}
    return [SplitRow(dataset, e, v, split[v]) for e, v in pairs]


def benchmark_split(
    data_dir: str | Path = DEFAULT_DATA_DIR, seed: int = SPLIT_SEED
) -> list[SplitRow]:
    """Assign every shipped episode to a split by its vehicle (:func:`split_by_vehicle`).

    Each dataset of :data:`DATASETS` is split on its own (stream: its index), so both have
    vehicles in every split.

    Returns:
        One row per episode, sorted by dataset and episode id.
    """
    rows = []
    for i, ds in enumerate(DATASETS):
        rows += split_by_vehicle(_episode_vehicles(Path(data_dir), ds), ds, seed, i)
    return sorted(rows, key=lambda r: (r.dataset, r.episode_id))


def benchmark_split_all(
    data_dir: str | Path = DEFAULT_DATA_DIR,
    lane_changes: Sequence[SplitRow] | None = None,
    seed: int = SPLIT_SEED,
) -> list[SplitRow]:
    """The split of every vehicle's episodes (lane changes and windows) of the shipped samples.

    The split stays by vehicle and extends the lane changes' (``lane_changes``, default
    :data:`SPLIT_FILE`'s): a vehicle with a lane change keeps its split (its lane changes'
    rows are those rows), so the lane-change benchmark's test vehicles are still tested and
    its train vehicles still trained on; the vehicles without one are split by
    :func:`split_by_vehicle` on their own (stream 2 + the dataset's index). Committed as
    :data:`SPLIT_ALL_FILE`.

    Returns:
        One row per usable episode, sorted by dataset and episode id.

    Raises:
        ValueError: a lane-change row whose episode the extraction no longer finds.
    """
    base = read_split() if lane_changes is None else list(lane_changes)
    check_sample_split(data_dir, base)
    known = {(r.dataset, r.vehicle_id): r.split for r in base}
    rows = []
    for i, ds in enumerate(DATASETS):
        pairs = _episode_vehicles(Path(data_dir), ds, True)
        fresh = [(e, v) for e, v in pairs if (ds, v) not in known]
        rows += [SplitRow(ds, e, v, known[ds, v]) for e, v in pairs if (ds, v) in known]
        rows += split_by_vehicle(fresh, ds, seed, 2 + i) if fresh else []
    return sorted(rows, key=lambda r: (r.dataset, r.episode_id))


def write_split(rows: Sequence[SplitRow], path: str | Path = SPLIT_FILE) -> None:
    """Write the split as CSV: ``dataset,episode_id,vehicle_id,split``."""
    lines = ["dataset,episode_id,vehicle_id,split"]
    lines += [f"{r.dataset},{r.episode_id},{r.vehicle_id},{r.split}" for r in rows]
    Path(path).write_text("\n".join(lines) + "\n")


SPLIT_HEADER = ("dataset", "episode_id", "vehicle_id", "split")
"""The columns of a split file (:func:`write_split`)."""


def read_split(path: str | Path = SPLIT_FILE) -> list[SplitRow]:
    """The split :func:`write_split` wrote, every row checked.

    The dataset column names the set a row's records are summarised under: ``ngsim`` and
    ``cats`` for the shipped samples, :data:`EPISODES_SET` (or any label) for a folder of
    extracted episodes. Blank lines and a byte-order mark (a spreadsheet's UTF-8) are
    skipped.

    Raises:
        FileNotFoundError: no such file.
        OSError: not readable (a folder, no permission).
        ValueError: not UTF-8 text, another header, or a row with cells missing or extra,
            an empty cell, a split none of :data:`SPLITS`, or an episode listed twice (the
            message names the file, the row and its line, the column and the value).
    """
    try:
        lines = Path(path).read_text(encoding="utf-8-sig").splitlines()
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{path}: not a text file (byte {exc.start} is not UTF-8): not a split CSV"
        ) from None
    if not lines or tuple(lines[0].split(",")) != SPLIT_HEADER:
        raise ValueError(
            f"{path}: expected the header {','.join(SPLIT_HEADER)}, got "
            f"{lines[0][:80] if lines else 'an empty file'!r}"
        )
    rows: list[SplitRow] = []
    first: dict[str, int] = {}
    for line_no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        where = f"{path}, row {len(rows) + 1} (line {line_no}) is malformed"
        parts = line.split(",")
        if len(parts) != len(SPLIT_HEADER):
            raise ValueError(
                f"{where}: {len(parts)} cells where the header has {len(SPLIT_HEADER)} "
                f"({line[:80]!r})"
            )
        for column, value in zip(SPLIT_HEADER, parts, strict=True):
            if not value.strip():
                raise ValueError(f"{where}: column {column} is empty")
        if parts[3] not in SPLITS:
            raise ValueError(f"{where}: column split {parts[3]!r} is none of {', '.join(SPLITS)}")
        if parts[1] in first:
            raise ValueError(
                f"{where}: column episode_id {parts[1]} again (first in row {first[parts[1]]}): "
                "an episode is in one split"
            )
        first[parts[1]] = len(rows) + 1
        dataset, episode_id, vehicle_id, split = parts
        rows.append(SplitRow(dataset, episode_id, vehicle_id, split, str(path), len(rows) + 1))
    return rows


def check_split_vehicles(rows: Sequence[SplitRow], vehicles: Mapping[str, str]) -> list[SplitRow]:
    """Check a split against the episodes it is applied to; return its rows of no episode.

    The split is by vehicle: a vehicle's episodes all lie in one split, else the benchmark
    judges a vehicle on what it was tuned on. So a row whose vehicle is not its episode's
    (a split written for another extraction, or edited by hand) and a vehicle in two
    splits are refused, in that order (a wrong vehicle id also makes a false leak). A
    vehicle is compared by its id within its recording (after the last ``:``): the shipped
    split's ``ngsim:i80:115`` is an extraction's ``i80_1600_first60s:115``.

    Args:
        rows: the split (:func:`read_split`).
        vehicles: episode id → its vehicle, of the episodes at hand.

    Returns:
        The rows of episodes not in ``vehicles`` (legal: a split may cover more episodes
        than a folder holds; the caller notes how many).

    Raises:
        ValueError: a row's vehicle is not its episode's (the message names the file, the
            row and both vehicles), or a vehicle is in more than one split (it names the
            file, the vehicle and its splits with their rows).
    """
    for r in rows:
        actual = vehicles.get(r.episode_id)
        # the id within its recording, not its prefix: the shipped split names a sample's
        # vehicles ngsim:i80:115, an extraction of the same file i80_1600_first60s:115
        if actual is not None and r.vehicle_id.rpartition(":")[2] != actual.rpartition(":")[2]:
            raise ValueError(
                f"{r.where}: column vehicle_id {r.vehicle_id} is not the vehicle of episode "
                f"{r.episode_id} ({actual}); was the split written for another extraction?"
            )
    splits: dict[tuple[str, str], dict[str, list[SplitRow]]] = {}
    for r in rows:
        splits.setdefault((r.dataset, r.vehicle_id), {}).setdefault(r.split, []).append(r)
    leaks = {key: per for key, per in splits.items() if len(per) > 1}
    if leaks:
        (_, vehicle), per = next(iter(leaks.items()))
        source = next(r.source for rs in per.values() for r in rs) or "the split"
        said = "; ".join(
            f"{split} (row{'s' if len(rs) > 1 else ''} {', '.join(str(r.row) for r in rs)})"
            if rs[0].source
            else f"{split} ({', '.join(r.episode_id for r in rs)})"
            for split, rs in per.items()
        )
        more = f" ({len(leaks) - 1} more vehicle(s) likewise)" if len(leaks) > 1 else ""
        raise ValueError(
            f"{source}: vehicle {vehicle} is in more than one split: {said}{more}; a vehicle's "
            "episodes belong to one split, else the benchmark judges it on what it was tuned on"
        )
    return [r for r in rows if r.episode_id not in vehicles]


def split_contents(rows: Sequence[SplitRow]) -> str:
    """What a split holds, per dataset: ``cats: train 60, test 24; ngsim: …`` (for messages)."""
    counts: dict[str, dict[str, int]] = {}
    for r in rows:
        counts.setdefault(r.dataset, dict.fromkeys(SPLITS, 0))[r.split] += 1
    if not counts:
        return "no episode"
    return "; ".join(
        f"{ds}: " + ", ".join(f"{s} {n}" for s, n in per.items() if n)
        for ds, per in sorted(counts.items())
    )


def check_split_selects(
    rows: Sequence[SplitRow], split: str, datasets: Sequence[str] | None = None
) -> None:
    """Refuse a split that selects no episode: a benchmark of nothing is no result.

    Args:
        rows: the split.
        split: the chosen split (``all``: every row; it selects something if there is one).
        datasets: datasets that must each have an episode in it (None: any will do).

    Raises:
        ValueError: no episode of ``split`` (of one of ``datasets``); the message says what
            the split holds.
    """
    chosen = [r for r in rows if split in ("all", r.split)]
    short = [ds for ds in datasets or () if not any(r.dataset == ds for r in chosen)]
    if not chosen or short:
        of = f" of {' or '.join(short)}" if short else ""
        raise ValueError(f"no {split} episode{of} (the split holds {split_contents(rows)})")


def load_recorded(
    data_dir: str | Path, dataset: str, episodes: Sequence[str] | None = None
) -> list[tuple[str, Demonstration]]:
    """A sample's extracted episodes as (episode id, demonstration).

    Args:
        data_dir: the folder holding the datasets.
        dataset: a key of :data:`DATASETS`.
        episodes: the benchmark's episodes to take (those of one split); None: every usable
            extracted lane change. A window among them (:func:`~drivestyle.recorded.kinds.
            is_window_id`) takes the extraction with every vehicle's windows.

    Raises:
        ValueError: an unknown dataset, an episode the sample does not have; the reader's
            errors for missing or malformed files.
    """
    windows = episodes is not None and any(is_window_id(e) for e in episodes)
    found = recorded_episodes(str(data_dir), dataset, windows)
    if episodes is None:
        return [(eid, demo) for eid, _, demo in found]
    by_id = {eid: demo for eid, _, demo in found}
    missing = [e for e in episodes if e not in by_id]
    if missing:
        raise ValueError(
            f"{dataset}: episode(s) {missing[:3]} of the split are not among the sample's "
            f"{len(by_id)} extracted episodes; was the split written for another data folder "
            "or extraction? (drivestyle evaluate-prediction --write-split)"
        )
    return [(e, by_id[e]) for e in dict.fromkeys(episodes)]


def episodes_split(folder: str | Path, seed: int = SPLIT_SEED) -> list[SplitRow]:
    """The split by vehicle of a folder of extracted episodes (:func:`split_by_vehicle`).

    Its rows' dataset is :data:`EPISODES_SET`; a vehicle is ``<carriageway>:<vehicle id>``
    (:func:`~drivestyle.recorded.episodes.read_episodes`).
    """
    from drivestyle.recorded.episodes import read_episodes

    pairs = [(eid, vehicle) for eid, vehicle, _ in read_episodes(folder)]
    if not pairs:
        raise ValueError(f"{folder}: no usable episode (episodes.csv lists none)")
    return split_by_vehicle(pairs, EPISODES_SET, seed)


def load_episodes_folder(
    folder: str | Path, rows: Sequence[SplitRow] | None, split: str
) -> list[tuple[str, str, Demonstration, str]]:
    """The episodes of an extraction folder that a split selects, as the benchmark takes them.

    Args:
        folder: a folder written by ``drivestyle extract-episodes``.
        rows: the split (None: every episode is in the split ``all``, its own vehicle's); it
            must have a row for every usable episode of the folder and may have rows of
            others (e.g. the shipped benchmark's split for a folder of one sample).
        split: a name of :data:`SPLITS`, or ``all`` (every usable episode).

    Returns:
        (set, episode id, demonstration, bootstrap unit) per selected episode: the set is
        the row's dataset (:data:`EPISODES_SET` without rows), the unit its vehicle.

    Raises:
        ValueError: a usable episode without a row (the message names it), a row whose
            vehicle is not its episode's or a vehicle in two splits
            (:func:`check_split_vehicles`), or a split that selects none. Rows of episodes
            the folder lacks are noted on stderr.
    """
    from drivestyle.recorded.episodes import read_episodes

    found = {eid: (vehicle, demo) for eid, vehicle, demo in read_episodes(folder)}
    if rows is None:
        rows = [SplitRow(EPISODES_SET, e, v, "all") for e, (v, _) in found.items()]
    others = check_split_vehicles(rows, {e: v for e, (v, _) in found.items()})
    if others:  # legal (a split of more than this folder), yet worth saying
        print(
            f"note: {others[0].source or 'the split'}: {len(others)} of its {len(rows)} rows "
            f"name episodes {folder} does not hold (e.g. {others[0].episode_id}); they are "
            "not used",
            file=sys.stderr,
            flush=True,
        )
    named = {r.episode_id for r in rows}
    missing = [e for e in found if e not in named]
    if missing:
        raise ValueError(
            f"the split has no row for {len(missing)} of the {len(found)} usable episode(s) of "
            f"{folder} (e.g. {missing[:3]}); was it written for another folder or extraction?"
        )
    chosen = [r for r in rows if r.episode_id in found and split in ("all", r.split)]
    if not chosen:
        theirs = [r for r in rows if r.episode_id in found]
        raise ValueError(
            f"the split has no {split} episode of {folder} (of its episodes the split holds "
            f"{split_contents(theirs)})"
        )
    return [(r.dataset, r.episode_id, found[r.episode_id][1], r.vehicle_id) for r in chosen]
