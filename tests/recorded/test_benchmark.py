"""The recorded benchmark's split by vehicle (recorded/benchmark.py)."""

import pytest

from drivestyle.recorded.benchmark import (
    DEFAULT_DATA_DIR,
    SPLIT_ALL_FILE,
    SPLIT_FILE,
    SPLITS,
    SplitRow,
    benchmark_split,
    benchmark_split_all,
    read_split,
    write_split,
)

DATA = DEFAULT_DATA_DIR
needs_data = pytest.mark.skipif(
    not (DATA / "ngsim" / "episodes.csv").is_file(), reason="the shipped datasets are absent"
)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
@needs_data
def test_the_committed_split_is_the_functions_and_no_vehicle_is_in_two_splits():
    rows = benchmark_split(DATA)
    assert read_split(SPLIT_FILE) == rows
    split_of: dict[str, set[str]] = {}
    for r in rows:
        split_of.setdefault(r.vehicle_id, set()).add(r.split)
    assert all(len(s) == 1 for s in split_of.values())
    assert {r.split for r in rows} == set(SPLITS)
    assert {r.dataset for r in rows if r.split == "test"} == {"ngsim", "cats"}
    assert len({r.episode_id for r in rows}) == len(rows)


@pytest.mark.slow  # two extractions of every vehicle (≈ 30 s)
@needs_data
def test_every_vehicles_split_is_the_functions_and_keeps_the_lane_changes_split():
    rows = benchmark_split_all(DATA)
    assert read_split(SPLIT_ALL_FILE) == rows
    lane_changes = read_split(SPLIT_FILE)
    assert set(lane_changes) <= set(rows)  # every lane change, in its split
    split_of: dict[str, set[str]] = {}
    for r in rows:
        split_of.setdefault(r.vehicle_id, set()).add(r.split)
    assert all(len(s) == 1 for s in split_of.values())
    assert len({r.episode_id for r in rows}) == len(rows) > 5 * len(lane_changes)


def test_write_and_read_split_round_trip(tmp_path):
    rows = [
        SplitRow("ngsim", "e1", "ngsim:i80:1", "train"),
        SplitRow("cats", "e2", "cats:AV", "test"),
    ]
    write_split(rows, tmp_path / "s.csv")
    assert read_split(tmp_path / "s.csv") == rows
    (tmp_path / "bad.csv").write_text("dataset,episode_id,vehicle_id,split\nngsim,e,v,holdout\n")
    with pytest.raises(ValueError, match="malformed"):
        read_split(tmp_path / "bad.csv")


@needs_data
@pytest.mark.slow  # extracts the whole CATS sample (≈ 7 s): CI runs it (-m slow)
def test_a_split_naming_an_episode_the_sample_lacks_is_a_clear_error():
    from drivestyle.recorded.benchmark import load_recorded

    with pytest.raises(ValueError, match=r"cats: episode\(s\) \['nope'\].*--write-split"):
        load_recorded(DATA, "cats", ["nope"])
