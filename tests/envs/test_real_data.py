from pathlib import Path

import numpy as np
import pytest

from envs.real_data import load_cats, load_ngsim

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
    assert all(e.demo is not None for e in ngsim)


def test_cats_counts_match_readme(cats):
    assert len(cats) == 31
    used = [e for e in cats if e.used]
    assert sum(e.flags["set"] == "AV" for e in used) == 6
    assert sum(e.flags["set"] == "HV" for e in used) == 4
    # the human-driven manoeuvres have no target: reactive features inactive, said so
    assert all(e.flags["no_target"] for e in used if e.flags["set"] == "HV")
    assert not any(e.flags["no_target"] for e in used if e.flags["set"] == "AV")
    assert all("return_leg" in e.reasons for e in cats if e.flags["leg"] == "return")


@pytest.mark.parametrize("which", ["ngsim", "cats"])
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


def test_lane_width_and_units(ngsim, cats):
    widths = {e.demo.scenario.lane_width for e in ngsim}
    assert all(3.3 < w < 3.9 for w in widths)  # 12 ft lanes ≈ 3.66 m
    assert {e.demo.scenario.lane_width for e in cats} == {3.95}
    speeds = np.concatenate([e.demo.ev[:, 3] for e in cats if e.used])
    assert 2 < speeds.min() and speeds.max() < 10  # README: 4–8 m/s manoeuvres
    # scenario constants adapt: never the paper's 5.25 m lanes or 30 m/s
    for e in ngsim + cats:
        sc = e.demo.scenario
        assert sc.lane_width != 5.25 and sc.v_ref < 30


def test_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"episodes\.csv not found"):
        load_ngsim(tmp_path)


def test_bad_rows_are_dropped_and_counted(tmp_path):
    import shutil

    import pandas as pd

    for f in ("episodes.csv", "tracks.csv.gz"):
        shutil.copy(DATA / "ngsim" / f, tmp_path / f)
    tracks = pd.read_csv(DATA / "ngsim" / "episode_tracks.csv.gz")
    first = "us101_scene_ego320_v323_t16.7"
    idx = tracks.index[(tracks.episode_id == first) & (tracks.role == "ego")][10]
    tracks.loc[idx, "y_m"] = np.nan
    tracks.to_csv(tmp_path / "episode_tracks.csv.gz", index=False)
    episodes = {e.episode_id: e for e in load_ngsim(tmp_path)}
    assert episodes[first].flags["dropped_rows"] == 1
    assert episodes[first].used and np.all(np.isfinite(episodes[first].demo.ev))
    assert all(e.flags["dropped_rows"] == 0 for k, e in episodes.items() if k != first)
