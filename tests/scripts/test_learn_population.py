"""learn-population: one style from a benchmark split's recorded episodes (DESIGN §18)."""

import json

import pytest

from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary, load_any_library
from drivestyle.recorded.benchmark import DEFAULT_DATA_DIR, SplitRow, write_split
from drivestyle.scripts import learn_population
from drivestyle.studies.population_style import PopulationSettings

DATA = DEFAULT_DATA_DIR
needs_data = pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file(),
    reason="the shipped datasets are absent",
)


def _one_episode_split(tmp_path):
    from drivestyle.recorded.benchmark import recorded_episodes

    eid, vid, _ = recorded_episodes(str(DATA), "cats")[0]
    split = tmp_path / "split.csv"
    write_split([SplitRow("cats", eid, vid, "train")], split)
    start = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), (0.5, 0.7, 0.9), 4.0)
    lib_path = tmp_path / "start.json"
    lib_path.write_text(json.dumps(start.to_json()))
    return eid, split, start, lib_path


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
@needs_data
@pytest.mark.parametrize(
    "options",
    [
        pytest.param(  # ≈ 20 s: a screened start, one LM iteration and two risk profiles
            ["--objective", "teacher", "--screen", "1", "--max-iter", "1"], marks=pytest.mark.slow
        ),
        ["--max-evals", "4"],
    ],
    ids=["teacher", "closed-loop"],
)
def test_learns_one_style_from_the_train_split_and_writes_a_driver_library(tmp_path, options):
    eid, split, start, lib_path = _one_episode_split(tmp_path)
    out = tmp_path / "people"
    learn_population.main(["--library", str(lib_path), "--split-file", str(split), "--out",
                           str(out), *options])  # fmt: skip
    people = load_any_library(out / "library.json")
    assert isinstance(people, DriverLibrary)
    assert people.risks == start.risks and people.temperature == start.temperature
    assert people.meta["split"]["episodes"] == [eid]
    assert people.fit_residual == pytest.approx(people.meta["fit"]["residual_rms"])
    assert people.style.min_gap is not None  # the region was learned
    fit = people.meta["fit"]
    assert fit["objective"] == ("teacher" if "teacher" in options else "closed-loop")
    if fit["objective"] == "closed-loop":
        assert fit["evaluations"] == 4 and fit["closed_loop_rmse_xy_m"] <= fit["start_rmse_xy_m"]


def test_the_closed_loop_cost_is_the_mean_capped_reproduction_error(paper_demo):
    from drivestyle.irl.driver.driver_style import reproduce
    from drivestyle.studies.population_style import CLOSED_LOOP_CAP_M, closed_loop_cost

    truth = DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0), risk=0.7)  # the SMPC that drove it
    assert closed_loop_cost(truth, [paper_demo]) < 1e-3
    other = DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0), risk=0.5, time_gap=2.0, min_gap=10.0)
    expected = min(reproduce(other, paper_demo).errors(paper_demo)[1], CLOSED_LOOP_CAP_M)
    assert closed_loop_cost(other, [paper_demo, paper_demo]) == pytest.approx(expected)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="restarts"):
        PopulationSettings(screen=1, restarts=2)
    with pytest.raises(ValueError, match="max_iter"):
        PopulationSettings(max_iter=0)
    with pytest.raises(ValueError, match="objective"):
        PopulationSettings(objective="both")
