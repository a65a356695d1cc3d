"""evaluate-prediction, predict-trajectory and evaluate-out-of-class on bad inputs, as a user
meets them: each run in a fresh process must end in one line ``error: …`` naming the option,
the file and what is wrong with it (exit 2), before any work starts.
"""

import json
from pathlib import Path

import pytest
from cli_runner import DATA

from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.recorded.benchmark import SPLIT_FILE, read_split, write_split

# each test runs a command in its own process, as a user meets the problem (1-6 s each):
# CI runs them with the slow set, the default run stays within its time
pytestmark = pytest.mark.slow

needs_data = pytest.mark.skipif(
    not (DATA / "ngsim").is_dir() or not (DATA / "cats-av-lanechange").is_dir(),
    reason="../shared/data not beside the checkout",
)


@pytest.fixture()
def library(tmp_path) -> Path:
    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9, 0.95))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    return tmp_path / "library.json"


def _benchmark(refused, library: Path, *args) -> str:
    """evaluate-prediction of the recorded benchmark only, refused."""
    return refused("evaluate-prediction", "--library", library, "--no-simulated",
                   "--data-dir", DATA, "--out", "out", *args)  # fmt: skip


# ------------------------------------------------------------------------- --split-file
@needs_data
def test_a_split_file_without_an_episode_of_the_split_is_refused(tmp_path, library, refused):
    # before: "Predictions: 0", exit 0 — a benchmark of nothing
    train_only = [r for r in read_split(SPLIT_FILE) if r.split == "train"]
    write_split(train_only, tmp_path / "train_only.csv")
    said = _benchmark(refused, library, "--split-file", tmp_path / "train_only.csv")
    ngsim = sum(r.dataset == "ngsim" for r in train_only)
    cats = sum(r.dataset == "cats" for r in train_only)
    assert said == (
        f"--split-file {tmp_path / 'train_only.csv'}: no validation episode of ngsim or cats "
        f"(the split holds cats: train {cats}; ngsim: train {ngsim})"
    )
    # one dataset without it is refused too: its set would be summarised over nothing
    rows = [r for r in read_split(SPLIT_FILE) if r.dataset == "ngsim" or r.split != "test"]
    write_split(rows, tmp_path / "no_cats_test.csv")
    said = _benchmark(refused, library, "--split", "test", "--split-file",
                      tmp_path / "no_cats_test.csv")  # fmt: skip
    assert said.startswith(f"--split-file {tmp_path / 'no_cats_test.csv'}: no test episode of cats")


@needs_data
@pytest.mark.parametrize(
    ("content", "said"),
    [
        (None, "{path}: no such file"),
        ("folder", "{path}: Is a directory"),
        ("dataset,episode,vehicle\n", "--split-file {path}: expected the header "
         "dataset,episode_id,vehicle_id,split, got 'dataset,episode,vehicle'"),
        ("dataset,episode_id,vehicle_id,split\nngsim,e1,ngsim:i80:1,val\n",
         "--split-file {path}, row 1 (line 2) is malformed: column split 'val' is none of train, "
         "validation, test"),
        ("dataset,episode_id,vehicle_id,split\nngsim,e1,ngsim:i80:1\n",
         "--split-file {path}, row 1 (line 2) is malformed: 3 cells where the header has 4 "
         "('ngsim,e1,ngsim:i80:1')"),
        ("dataset,episode_id,vehicle_id,split\nngsim,e1,,train\n",
         "--split-file {path}, row 1 (line 2) is malformed: column vehicle_id is empty"),
        ("dataset,episode_id,vehicle_id,split\nngsim,e1,v,train\ncats,e1,w,test\n",
         "--split-file {path}, row 2 (line 3) is malformed: column episode_id e1 again (first in "
         "row 1): "
         "an episode is in one split"),
        ("utf-16", "--split-file {path}: not a text file (byte 0 is not UTF-8): not a split CSV"),
    ],
    ids=["missing", "folder", "header", "unknown-split", "short-row", "empty-cell",
         "episode-twice", "utf-16"],
)  # fmt: skip
def test_a_missing_malformed_or_foreign_split_file_is_named_by_its_option(
    tmp_path, library, refused, content, said
):
    path = tmp_path / "split.csv"
    if content == "folder":
        path.mkdir()
    elif content == "utf-16":
        path.write_text("dataset,episode_id,vehicle_id,split\n", encoding="utf-16")
    elif content is not None:
        path.write_text(content)
    line = _benchmark(refused, library, "--split-file", path)
    expected = said.format(path=path)
    assert line == (expected if expected.startswith("--") else f"--split-file {expected}"), line


def _episodes(folder: Path, paper_demo, episodes: list[tuple[str, int]]) -> Path:
    """A folder as extract-episodes writes it: (episode id, vehicle id) per episode."""
    from dataclasses import replace

    from drivestyle.envs.demonstration import save_demonstration

    folder.mkdir()
    meta = {k: v for k, v in paper_demo.meta.items() if k not in ("risk", "smpc")}
    lines = ["episode_id,file,carriageway,vehicle_id,usable"]
    for i, (episode, vehicle) in enumerate(episodes):
        others = paper_demo.tv[:, None, :].copy()
        others[:, 0, 0] += 30.0 + 5 * i  # a leader in the target lane
        demo = replace(
            paper_demo, others=others, meta={**meta, "episode_id": episode}, origin="recorded"
        )
        save_demonstration(demo, folder / f"{episode}.npz")
        lines.append(f"{episode},{episode}.npz,r,{vehicle},True")
    (folder / "episodes.csv").write_text("\n".join(lines) + "\n")
    return folder


def _split(path: Path, rows: list[tuple[str, str, str]]) -> Path:
    path.write_text("dataset,episode_id,vehicle_id,split\n"
                    + "".join(f"episodes,{e},{v},{s}\n" for e, v, s in rows))  # fmt: skip
    return path


def test_a_split_file_that_leaks_a_vehicle_across_splits_is_refused(
    tmp_path, library, refused, paper_demo
):
    # before: accepted, the vehicle's second episode judged on a split it was tuned on
    eps = _episodes(tmp_path / "eps", paper_demo, [("r_0_1000", 0), ("r_0_2000", 0),
                                                   ("r_1_1000", 1)])  # fmt: skip
    leak = _split(tmp_path / "leak.csv", [("r_0_1000", "r:0", "train"),
                                          ("r_0_2000", "r:0", "validation"),
                                          ("r_1_1000", "r:1", "validation")])  # fmt: skip
    said = refused("evaluate-prediction", "--library", library, "--episodes", eps,
                   "--split-file", leak, "--observe", 2, "--out", "out")  # fmt: skip
    assert said == (
        f"{leak}: vehicle r:0 is in more than one split: train (row 1); validation (row 2); a "
        "vehicle's episodes belong to one split, else the benchmark judges it on what it was "
        "tuned on"
    )


def test_a_split_row_whose_vehicle_is_not_its_episodes_is_refused_naming_the_row(
    tmp_path, library, refused, paper_demo
):
    eps = _episodes(tmp_path / "eps", paper_demo, [("r_0_1000", 0), ("r_1_1000", 1)])
    wrong = _split(tmp_path / "vehsplit.csv", [("r_0_1000", "r:0", "validation"),
                                               ("r_1_1000", "r:0", "validation")])  # fmt: skip
    said = refused("evaluate-prediction", "--library", library, "--episodes", eps,
                   "--split-file", wrong, "--observe", 2, "--out", "out")  # fmt: skip
    assert said == (
        f"{wrong}, row 2: column vehicle_id r:0 is not the vehicle of episode r_1_1000 (r:1); "
        "was the split written for another extraction?"
    )


def test_split_rows_of_episodes_the_folder_lacks_are_noted_with_their_count(
    tmp_path, library, paper_demo
):
    from cli_runner import run_command

    eps = _episodes(tmp_path / "eps", paper_demo, [("r_0_1000", 0), ("r_1_1000", 1)])
    more = _split(tmp_path / "unknown.csv", [("nonexistent_1_1000", "x:1", "validation"),
                                             ("r_0_1000", "r:0", "validation"),
                                             ("r_1_1000", "r:1", "validation")])  # fmt: skip
    # --observe 50: refused once the episodes are read, after the note (no rollout needed)
    done = run_command(tmp_path, "evaluate-prediction", "--library", library, "--episodes", eps,
                       "--split-file", more, "--observe", 50, "--out", "out")  # fmt: skip
    assert done.returncode == 2, done.stderr[-3000:]
    note, error = done.stderr.strip().splitlines()
    assert note == (
        f"note: {more}: 1 of its 3 rows name episodes {eps} does not hold (e.g. "
        "nonexistent_1_1000); they are not used"
    )
    assert error.startswith("error: observed time(s) 50 s: no vehicle of this run lasts")


def test_contradicting_data_options_are_refused(tmp_path, library, refused, paper_demo):
    # before: --data-dir was ignored, the run read --episodes (or nothing) instead
    eps = _episodes(tmp_path / "eps", paper_demo, [("r_0_1000", 0)])
    said = refused("evaluate-prediction", "--library", library, "--episodes", eps,
                   "--data-dir", "nonexist", "--out", "out")  # fmt: skip
    assert said == (
        "--data-dir nonexist and --episodes contradict: --episodes benchmarks its folder "
        "instead of the shipped samples; drop one or the other"
    )
    said = refused("evaluate-prediction", "--library", library, "--no-recorded",
                   "--data-dir", "nonexist", "--out", "out")  # fmt: skip
    assert said.startswith("--data-dir nonexist and --no-recorded contradict")


def test_a_split_file_with_a_byte_order_mark_is_read(tmp_path):
    bom = tmp_path / "split.csv"
    bom.write_text(SPLIT_FILE.read_text(), encoding="utf-8-sig")  # as a spreadsheet saves UTF-8
    assert read_split(bom) == read_split(SPLIT_FILE)


# ------------------------------------------------------------------- evaluate-out-of-class
def _out_of_class(refused, library: Path, *args) -> str:
    return refused("evaluate-out-of-class", "--library", library, "--out", "out", *args)


@pytest.mark.parametrize(
    ("observe", "said"),
    [
        ("50", "--observe: observed time(s) 50 s: no vehicle of this run lasts that long, "
               "nothing would be left to predict (the highway-env lane changes at most 8 s and "
               "SMPC drivers 6 s); observe less than 8 s"),
        ("0.3", "--observe: observed time 0.3 s is not a whole number of the vehicles' T_s = "
                "0.2 s; use 0.2 or 0.4 s"),
        ("7", "--observe: observed time(s) 7 s: no vehicle of this run lasts that long, nothing "
              "would be left to predict (the SMPC drivers 6 s); observe less than 6 s"),
        ("0,1", "--observe: observed times must be finite and > 0 s, got [0.0]"),
    ],
    ids=["beyond-every-lane-change", "not-whole-samples", "beyond-smpc-only", "zero"],
)  # fmt: skip
def test_out_of_class_refuses_an_observed_time_no_lane_change_serves(
    library, refused, observe, said
):
    # before: 6–10 min of simulation, then every prediction skipped
    extra = ["--no-highway"] if observe == "7" else []
    assert _out_of_class(refused, library, "--observe", observe, *extra) == said


def test_out_of_class_checks_its_risks_range_first_then_their_number(
    library, refused, refused_option
):
    # a risk outside the class's range is said as such, not as a count problem
    said = refused_option("evaluate-out-of-class", "--library", library, "--risks", "1.0")
    assert said == "--risks: SMPC risks must lie in [0.5, 1), got 1"
    said = refused_option("evaluate-out-of-class", "--library", library, "--risks", "0.4,0.7")
    assert said == "--risks: SMPC risks must lie in [0.5, 1), got 0.4"
    said = _out_of_class(refused, library, "--risks", "0.7,0.7")
    assert said == (
        "--risks: the SMPC variants need at least two distinct risks to order, got 0.7 (or "
        "--scenarios 0: no SMPC variants)"
    )


def test_out_of_class_refuses_prediction_options_with_no_prediction(library, refused):
    # before: --observe was ignored and the long run started
    assert _out_of_class(refused, library, "--no-prediction", "--observe", "2") == (
        "--observe applies to the prediction, which --no-prediction skips; drop one or the other"
    )
    said = _out_of_class(refused, library, "--no-prediction", "--observe", "2", "--physics", "p")
    assert said.startswith("--observe and --physics apply to the prediction")


@pytest.mark.parametrize(
    ("value", "said"),
    [("-1", "--scenarios: must be >= 0, got -1"),
     ("1000000", "--scenarios: at most 1,000 scenarios (≈ 30 s each: the bound alone is ≈ 8.33 "
                 "hours of work on one core), got 1,000,000"),
     ("two", "--scenarios: 'two' is not an integer")],
)  # fmt: skip
def test_out_of_class_bounds_its_scenarios(library, refused_option, value, said):
    assert refused_option("evaluate-out-of-class", "--library", library, "--scenarios",
                          value) == said  # fmt: skip


# -------------------------------------------------------------------------- --regions-from
def _record(set_name: str, t_obs: float, fde: float = 1.0) -> dict:
    return {"set": set_name, "t_obs_s": t_obs, "horizon_s": 3.0, "fde_m": {"cv": fde}}


@pytest.mark.parametrize(
    ("records", "said"),
    [
        ([], "{path} has no record of a recorded episode (no record): calibrate on a run that "
             "predicted recorded episodes"),
        ([_record("simulated", 1.0)] * 20,
         "{path} has no record of a recorded episode (its 20 records are all simulated): "
         "calibrate on a run that predicted recorded episodes"),
        ([_record("cats", 1.0)] * 20 + [_record("ngsim", 2.0)] * 4,
         "{path} calibrates no 90 % region at t_obs 2 s: a region needs at least 9 recorded "
         "records of its t_obs, the run has 20 at 1 s, 4 at 2 s"),
        ([_record("cats", 1.0, fde=-2.0)],
         "{path}: record 0, fde_m.cv: -2.0 is not a distance >= 0 m"),
        ([{**_record("cats", 1.0), "t_obs_s": "1"}],
         "{path}: record 0, t_obs_s: '1' is not a time > 0 s"),
    ],
    ids=["no-records", "only-simulated", "too-few-at-a-time", "negative-fde", "text-time"],
)  # fmt: skip
def test_regions_from_a_run_that_cannot_calibrate_them_is_refused(
    tmp_path, library, refused, records, said
):
    # before: no regions in the report, without a word
    path = tmp_path / "val.json"
    path.write_text(json.dumps({"split": "validation", "records": records}))
    line = _benchmark(refused, library, "--split", "test", "--observe", "1,2",
                      "--regions-from", path)  # fmt: skip
    assert line == "--regions-from " + said.format(path=path), line


# ------------------------------------------------------------------------------- --physics
@pytest.mark.parametrize(
    "command", ["predict-trajectory", "evaluate-prediction", "evaluate-out-of-class"]
)
def test_a_torn_physics_file_is_one_line_named_by_the_option(
    tmp_path, library, refused, paper_demo, command
):
    # before: json's "Expecting ',' delimiter: line 1 column 29 (char 28)", no file named
    from drivestyle.envs.demonstration import save_demonstration

    physics = tmp_path / "physics.json"
    physics.write_text('{"params": {"v0_factor": 1.1')
    args = {
        "predict-trajectory": [tmp_path / "demo.npz", "--library", library],
        "evaluate-prediction": ["--library", library, "--no-recorded", "--vehicles", "2"],
        "evaluate-out-of-class": ["--library", library],
    }[command]
    if command == "predict-trajectory":
        save_demonstration(paper_demo, tmp_path / "demo.npz")
    said = refused(command, *args, "--physics", physics, "--out", "out")
    assert said == (
        f"--physics {physics}: not JSON (Expecting ',' delimiter at line 1, column 29)"
    ), said
    physics.unlink()
    assert refused(command, *args, "--physics", physics, "--out", "out") == (
        f"--physics {physics}: no such file"
    )


@pytest.mark.parametrize("command", ["predict-trajectory", "evaluate-prediction"])
def test_a_bad_joint_physics_file_is_one_line_named_by_the_option(
    tmp_path, library, refused, paper_demo, command
):
    from drivestyle.envs.demonstration import save_demonstration
    from drivestyle.prediction.joint_physics import JointPhysicsParams

    joint = tmp_path / "joint.json"
    joint.write_text(json.dumps({"params": {**JointPhysicsParams().to_json(), "politeness": -1}}))
    args = {
        "predict-trajectory": [tmp_path / "demo.npz", "--library", library],
        "evaluate-prediction": ["--library", library, "--no-recorded", "--vehicles", "2"],
    }[command]
    if command == "predict-trajectory":
        save_demonstration(paper_demo, tmp_path / "demo.npz")
    said = refused(command, *args, "--joint-physics", joint, "--out", "out")
    assert said == f"--joint-physics {joint}: params.politeness -1 is not a finite number ≥ 0"
    joint.unlink()
    assert refused(command, *args, "--joint-physics", joint, "--out", "out") == (
        f"--joint-physics {joint}: no such file"
    )


# ------------------------------------------------------------------------ learn-population
def test_learn_population_reads_its_split_file_through_the_same_checks(tmp_path, library, refused):
    path = tmp_path / "split.csv"
    write_split([r for r in read_split(SPLIT_FILE) if r.split == "test"], path)
    said = refused("learn-population", "--library", library, "--split-file", path,
                   "--data-dir", tmp_path / "data", "--out", "people")  # fmt: skip
    assert said.startswith(f"--split-file {path}: no train episode (the split holds cats: test ")
    path.write_text("dataset,episode_id,vehicle_id,split\ncats,e1,cats:AV:3,training\n")
    said = refused("learn-population", "--library", library, "--split-file", path,
                   "--data-dir", tmp_path / "data", "--out", "people")  # fmt: skip
    assert said == (
        f"--split-file {path}, row 1 (line 2) is malformed: column split 'training' is none of "
        "train, validation, test"
    )
