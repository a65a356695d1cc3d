import re
from pathlib import Path

import numpy as np
import pytest

from drivestyle.recorded.real_data import load_cats, load_ngsim

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout")


@pytest.fixture(scope="module")
def ngsim():
    return load_ngsim(DATA / "ngsim")


@pytest.fixture(scope="module")
def cats():
    return load_cats(DATA / "cats-av-lanechange")


def test_ngsim_counts_match_readme(ngsim):
    assert len(ngsim) == 19  # README: 19 episodes
    assert sum(e.used for e in ngsim) == 12  # 12 complete, non-ramp
    assert sum(e.flags["direction"] == "left" for e in ngsim) == 9
    assert sum(e.flags["target_relation"] == "lead" for e in ngsim) == 13
    assert all(e.demo is not None for e in ngsim if e.used)
    # the 5 ramp / auxiliary-lane changes have no lane in the extraction: said so
    ramp = [e for e in ngsim if "ramp_or_aux_lane" in e.reasons]
    assert len(ramp) == 5
    assert all(any(r.startswith("not extracted") for r in e.reasons) for e in ramp)
    assert all(e.demo is None for e in ramp)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_cats_counts_match_readme(cats):
    assert len(cats) == 31
    used = [e for e in cats if e.used]
    assert sum(e.flags["set"] == "AV" for e in used) == 6
    assert sum(e.flags["set"] == "HV" for e in used) == 4
    # the human-driven manoeuvres have no target: reactive features inactive, said so
    assert all(e.flags["no_target"] for e in used if e.flags["set"] == "HV")
    assert all(e.flags["extraction_id"].startswith(e.episode_id.split("_")[0]) for e in used)
    assert not any(e.flags["no_target"] for e in used if e.flags["set"] == "AV")
    assert all("return_leg" in e.reasons for e in cats if e.flags["leg"] == "return")


@pytest.mark.parametrize("which", ["ngsim", pytest.param("cats", marks=pytest.mark.slow)])
def test_frame_normalised_to_plus_y(which, request):
    episodes = request.getfixturevalue(which)
    for e in episodes:
        if not e.used:
            continue
        d, sc = e.demo, e.demo.scenario
        w = sc.lane_width
        # the EV starts in lane 0 and ends in lane 1, whichever side it changed to
        assert 0 <= d.ev[0, 1] < w + 0.3, (e.episode_id, d.ev[0, 1])
        assert w - 0.3 < d.ev[-1, 1] < 2 * w, (e.episode_id, d.ev[-1, 1])
        assert d.ev[-1, 1] - d.ev[0, 1] > 0.5 * w
        # travelling +x at the recorded speed, sampled at the learner's T_s
        assert np.all(np.diff(d.ev[:, 0]) > 0)
        np.testing.assert_allclose(np.diff(d.t), 0.2, atol=1e-9)
        assert abs(np.median(np.diff(d.ev[:, 0]) / 0.2 - d.ev[1:, 3])) < 0.5


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_lane_width_and_units(ngsim, cats):
    ngsim, cats = [e for e in ngsim if e.demo], [e for e in cats if e.demo]
    widths = {e.demo.scenario.lane_width for e in ngsim}
    assert all(3.3 < w < 3.9 for w in widths)  # 12 ft lanes ≈ 3.66 m
    assert all(abs(e.demo.scenario.lane_width - 3.95) < 1e-9 for e in cats)
    speeds = np.concatenate([e.demo.ev[:, 3] for e in cats if e.used])
    assert 2 < speeds.min() and speeds.max() < 10  # README: 4–8 m/s manoeuvres
    # scenario constants adapt: never the paper's 5.25 m lanes or 30 m/s
    for e in ngsim + cats:
        sc = e.demo.scenario
        assert sc.lane_width != 5.25 and sc.v_ref < 30


def test_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"episodes\.csv not found"):
        load_ngsim(tmp_path)


def test_a_non_finite_track_value_names_the_vehicle(tmp_path):
    folder = _copy(tmp_path)

    def corrupt(df):
        df.loc[10, "y_m"] = np.nan
        return df

    _rewrite(folder / "tracks.csv.gz", corrupt)
    with pytest.raises(ValueError, match=r"tracks\.csv\.gz.*vehicle"):
        load_ngsim(folder)


# --------------------------------------------------------------- malformed files
NGSIM_FILES = ("episodes.csv", "tracks.csv.gz")
CATS_FILES = ("episodes.csv", "tracks.csv.gz", "summary.json")


def _copy(tmp_path, dataset="ngsim"):
    """A writable copy of a dataset folder (the shared one is read-only)."""
    import shutil

    src = DATA / dataset
    dst = tmp_path / dataset
    dst.mkdir()
    for f in NGSIM_FILES if dataset == "ngsim" else CATS_FILES:
        shutil.copyfile(src / f, dst / f)
    return dst


def _rewrite(path, change):
    import pandas as pd

    change(pd.read_csv(path)).to_csv(path, index=False)


LOADERS = {"ngsim": load_ngsim, "cats-av-lanechange": load_cats}


@pytest.mark.parametrize("dataset", ["ngsim", "cats-av-lanechange"])
def test_not_gzip_is_a_clear_error(tmp_path, dataset):
    folder = _copy(tmp_path, dataset)
    (folder / "tracks.csv.gz").write_text("episode_id,role\nx,ego\n")  # plain text
    with pytest.raises(ValueError, match=r"tracks\.csv\.gz.*(not a readable|gzip)"):
        LOADERS[dataset](folder)


def test_truncated_gzip_is_a_clear_error(tmp_path):
    folder = _copy(tmp_path)
    path = folder / "tracks.csv.gz"
    path.write_bytes(path.read_bytes()[:2000])
    with pytest.raises(ValueError, match=r"tracks\.csv\.gz.*(truncated|corrupt|end-of-stream)"):
        load_ngsim(folder)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
@pytest.mark.parametrize(
    ("dataset", "file", "drop"),
    [
        ("ngsim", "episodes.csv", ["direction"]),
        ("ngsim", "tracks.csv.gz", ["y_m"]),
        ("ngsim", "tracks.csv.gz", ["lane_id"]),
        ("cats-av-lanechange", "episodes.csv", ["leg", "lc_direction"]),
        ("cats-av-lanechange", "tracks.csv.gz", ["v_mps"]),
        ("ngsim", "episodes.csv", ["ego_id"]),
    ],
)
def test_missing_columns_are_named(tmp_path, dataset, file, drop):
    folder = _copy(tmp_path, dataset)
    _rewrite(folder / file, lambda df: df.drop(columns=drop))
    with pytest.raises(ValueError, match=rf"{re.escape(file)}.*missing column") as exc:
        LOADERS[dataset](folder)
    assert all(repr(c) in str(exc.value) for c in drop)


@pytest.mark.parametrize("dataset", ["ngsim", "cats-av-lanechange"])
@pytest.mark.parametrize("file", ["episodes.csv", "tracks.csv.gz"])
def test_header_only_csv_is_a_clear_error(tmp_path, dataset, file):
    folder = _copy(tmp_path, dataset)
    _rewrite(folder / file, lambda df: df.iloc[:0])
    with pytest.raises(ValueError, match=rf"{re.escape(file)}.*no rows"):
        LOADERS[dataset](folder)


def test_empty_file_is_a_clear_error(tmp_path):
    folder = _copy(tmp_path)
    (folder / "episodes.csv").write_text("")
    with pytest.raises(ValueError, match=r"episodes\.csv.*empty"):
        load_ngsim(folder)


def test_loader_pointed_at_the_other_dataset_says_so():
    with pytest.raises(ValueError, match=r"episodes\.csv.*looks like the NGSIM.*load_ngsim"):
        load_cats(DATA / "ngsim")
    with pytest.raises(ValueError, match=r"episodes\.csv.*looks like the CATS.*load_cats"):
        load_ngsim(DATA / "cats-av-lanechange")


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_non_numeric_track_value_is_named(tmp_path):
    folder = _copy(tmp_path)

    def corrupt(df):
        df["x_m"] = df["x_m"].astype(object)
        df.loc[3, "x_m"] = "abc"
        return df

    _rewrite(folder / "tracks.csv.gz", corrupt)
    with pytest.raises(ValueError, match=r"tracks\.csv\.gz.*vehicle \d+.*x_m.*'abc'"):
        load_ngsim(folder)


@pytest.mark.slow  # reloads the whole NGSIM sample: CI runs it (pytest -m slow)
def test_episode_without_track_rows_is_kept_unused(tmp_path):
    folder = _copy(tmp_path)
    first = "us101_scene_ego320_v323_t16.7"
    _rewrite(
        folder / "tracks.csv.gz",
        lambda df: df[~((df.recording == "us101_scene_ego320") & (df.vehicle_id == 323))],
    )
    episodes = {e.episode_id: e for e in load_ngsim(folder)}
    assert len(episodes) == 19
    assert not episodes[first].used and episodes[first].demo is None
    assert any("not extracted" in r for r in episodes[first].reasons)
    assert sum(e.used for e in episodes.values()) == 11


def test_bad_cats_summary_is_a_clear_error(tmp_path):
    folder = _copy(tmp_path, "cats-av-lanechange")
    (folder / "summary.json").write_text("{not json")
    with pytest.raises(ValueError, match=r"summary\.json.*JSON"):
        load_cats(folder)
    (folder / "summary.json").write_text('{"lanes": {"width_m": "wide"}}')
    with pytest.raises(ValueError, match=r"summary\.json.*width_m"):
        load_cats(folder)


def test_a_file_instead_of_the_folder_is_a_clear_error():
    with pytest.raises(FileNotFoundError, match="not a folder"):
        load_ngsim(DATA / "ngsim" / "episodes.csv")


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_recorded_neighbours_become_others(ngsim, cats):
    with_neighbours = [e for e in ngsim if e.used]
    alone = [e for e in load_ngsim(DATA / "ngsim", neighbours=False) if e.used]
    for with_n, without in zip(with_neighbours, alone, strict=True):
        d = with_n.demo
        # the interacting vehicles beyond the TV (target-lane leader, own-lane leader)
        roles = [role for role, _ in with_n.flags["interacting"]]
        assert d.others.shape[1] == len(roles) - 1, with_n.episode_id
        assert without.demo.others.shape[1] == 0
        np.testing.assert_array_equal(d.ev, without.demo.ev)  # the EV is untouched
        assert d.origin == without.demo.origin == "recorded"
        np.testing.assert_array_equal(without.demo.observed, d.observed[:1])  # the TV's row
    used = [e for e in cats if e.used]
    assert max(e.demo.others.shape[1] for e in used) >= 1


# ------------------------------------------------------------------- plausibility
@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_every_recorded_episode_is_plausible(ngsim, cats):
    from drivestyle.envs.demonstration import plausibility_problems

    for e in ngsim + cats:
        if e.used:
            assert plausibility_problems(e.demo) == [], e.episode_id
        elif e.demo is None:  # ramp lanes, or too little track around the crossing
            assert any(r.startswith(("not extracted", "only")) for r in e.reasons), e.reasons
        else:  # a return leg whose nearest target-lane car drifts between lanes
            problems = [r for r in e.reasons if r.startswith("implausible")]
            assert problems == [f"implausible: {p}" for p in plausibility_problems(e.demo)]


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_ngsim_in_feet_is_refused_with_convert(tmp_path):
    folder = _copy(tmp_path)
    feet = 1 / 0.3048

    def to_feet(df):
        for c in ("x_m", "y_m", "v_mps"):
            df[c] = df[c] * feet
        return df

    _rewrite(folder / "tracks.csv.gz", to_feet)
    with pytest.raises(ValueError, match=r"tracks\.csv\.gz.*lanes 1[12]\.\d m wide.*feet.*convert"):
        load_ngsim(folder)


def test_cats_lane_width_in_feet_is_refused(tmp_path):
    folder = _copy(tmp_path, "cats-av-lanechange")
    (folder / "summary.json").write_text('{"lanes": {"width_m": 12.1}}')
    with pytest.raises(ValueError, match=r"summary\.json.*lanes 12.1 m wide.*feet.*convert"):
        load_cats(folder)


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_implausible_episode_is_kept_unused_with_the_reason(tmp_path):
    folder = _copy(tmp_path)
    first = "us101_scene_ego320_v323_t16.7"

    def on_top(df):  # the own-lane leader (320) drives 1 m ahead of the ego's centre
        scene = df.recording == "us101_scene_ego320"
        ego = df[scene & (df.vehicle_id == 323)].set_index("time_s")
        lead = scene & (df.vehicle_id == 320) & df.time_s.isin(ego.index)
        times = df.loc[lead, "time_s"]
        df.loc[lead, "x_m"] = ego.loc[times, "x_m"].to_numpy() + 1.0
        df.loc[lead, "y_m"] = ego.loc[times, "y_m"].to_numpy()
        return df

    _rewrite(folder / "tracks.csv.gz", on_top)
    episodes = {e.episode_id: e for e in load_ngsim(folder)}
    bad = episodes[first]
    assert not bad.used and bad.demo is not None
    assert any(r.startswith("implausible: traffic vehicle 0 overlaps the EV") for r in bad.reasons)
    assert sum(e.used for e in episodes.values()) == 11


# the loaders check dt before reading anything (moved from the former test_defects.py)
@pytest.mark.parametrize("loader", [load_ngsim, load_cats])
@pytest.mark.parametrize("dt", [0.0, -0.2, float("nan"), "0.2"])
def test_loaders_reject_a_bad_dt(tmp_path, loader, dt):
    with pytest.raises((ValueError, TypeError), match="dt must be"):
        loader(tmp_path, dt=dt)
