"""learn-population: one style from a benchmark split's recorded episodes (issue 27)."""

import json

import pytest

from drivestyle.agents.studies.population_style import PopulationSettings
from drivestyle.agents.studies.prediction import DEFAULT_DATA_DIR, SplitRow, write_split
from drivestyle.irl.driver_style import DriverStyle
from drivestyle.irl.library import DriverLibrary, load_any_library
from drivestyle.scripts import learn_population

DATA = DEFAULT_DATA_DIR
needs_data = pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file(),
    reason="the shipped datasets are absent",
)


@needs_data
def test_learns_one_style_from_the_train_split_and_writes_a_driver_library(tmp_path):
    from drivestyle.agents.studies.prediction import recorded_episodes

    eid, vid, _ = recorded_episodes(str(DATA), "cats")[0]
    split = tmp_path / "split.csv"
    write_split([SplitRow("cats", eid, vid, "train")], split)
    start = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), (0.5, 0.7, 0.9), 4.0)
    lib_path = tmp_path / "start.json"
    lib_path.write_text(json.dumps(start.to_json()))
    out = tmp_path / "people"
    learn_population.main(["--library", str(lib_path), "--split-file", str(split), "--out",
                           str(out), "--screen", "1", "--max-iter", "1"])  # fmt: skip
    people = load_any_library(out / "library.json")
    assert isinstance(people, DriverLibrary)
    assert people.risks == start.risks and people.temperature == start.temperature
    assert people.meta["split"]["episodes"] == [eid]
    assert people.fit_residual == pytest.approx(people.meta["fit"]["residual_rms"])
    assert people.style.min_gap is not None  # the region was learned


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="restarts"):
        PopulationSettings(screen=1, restarts=2)
    with pytest.raises(ValueError, match="max_iter"):
        PopulationSettings(max_iter=0)
