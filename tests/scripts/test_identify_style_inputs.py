"""identify-style and learn-style: a demonstration given twice (same file or same content)
counts once."""

import json
import shutil
from dataclasses import replace
from pathlib import Path

import pytest

from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.recorded.real_data import recorded_vehicle
from drivestyle.scripts import identify_style

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"


@pytest.mark.slow  # CI runs it (-m slow): margin under the 2-minute default run
def test_repeated_demonstrations_count_once_and_are_named(tmp_path, paper_demo, capsys):
    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    save_demonstration(paper_demo, a)
    save_demonstration(replace(paper_demo, meta={**paper_demo.meta, "note": "b"}), b)
    shutil.copy(a, tmp_path / "c.npz")  # another name, the same bytes
    (tmp_path / "sub").mkdir()
    also_a = tmp_path / "sub" / ".." / "a.npz"  # the same file, spelled differently
    files = [a, a, also_a, b, tmp_path / "c.npz"]
    payload = identify_style.main(
        [*map(str, files), "--library", str(tmp_path), "--out", str(tmp_path / "out")]
    )
    assert payload["n_demos"] == 2 and payload["demos"] == [str(a), str(b)]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"note: each demonstration counts once: {a} given 3 times; "
        f"{tmp_path / 'c.npz'} has the content of {a}"
    ]


def test_plot_writes_a_figure_and_the_summary_says_the_verdict(tmp_path, paper_demo, capsys,
                                                               monkeypatch):  # fmt: skip
    import numpy as np
    from PIL import Image

    from drivestyle.irl.driver.risk_profile import RISK_EVAL, RiskProfile
    from drivestyle.irl.identification.posterior import driver_posterior

    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    demo = tmp_path / "a.npz"
    save_demonstration(paper_demo, demo)
    ssr = np.full(len(RISK_EVAL), 100.0)
    ssr[RISK_EVAL.index(0.7)] = 0.0  # the SMPC(0.7) shape, without the 13 re-solves

    def fake_identify(demos, library, scorer):
        profile = RiskProfile(RISK_EVAL, tuple(ssr), 2 * (paper_demo.n - 1), 30)
        return driver_posterior([profile], library, [2.0], [0.7])

    monkeypatch.setattr(identify_style, "identify", fake_identify)
    out = tmp_path / "out"
    payload = identify_style.main([str(demo), "--library", str(tmp_path), "--out", str(out),
                                   "--plot"])  # fmt: skip
    assert payload["informative"] is True and payload["out_of_class"] is False
    assert payload["verdict"] == "informative"
    first, numbers, fit = capsys.readouterr().out.splitlines()[:3]
    assert first.startswith("informative: the data identify the risk (the data moved the")
    assert numbers.startswith("  risk estimate 0.7, 90 % interval [")
    assert fit.startswith("  residual 0.00 σ_u = 0.0 noise floors")
    png = np.asarray(Image.open(out / "identify.png").convert("L"), float)
    assert png.shape[0] > 200 and png.shape[1] > 600
    assert png.std() > 10  # not blank: lines and text on white


@pytest.mark.slow  # two learnings (≈ 3 s)
def test_learn_style_counts_a_repeated_or_copied_demonstration_once(tmp_path, paper_demo):
    # one rule with identify-style and mine-styles (drivestyle.common.inputs)
    from cli_runner import run_command

    save_demonstration(paper_demo, tmp_path / "a.npz")
    shutil.copy(tmp_path / "a.npz", tmp_path / "copy.npz")
    run = run_command(tmp_path, "learn-style", "a.npz", "copy.npz", "./a.npz", "--model",
                      "paper", "--max-iter", "1", "--out", "style")  # fmt: skip
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert notes == [
        "note: each demonstration counts once: a.npz given 2 times; copy.npz has the content "
        "of a.npz"
    ]
    style = json.loads((tmp_path / "style" / "style.json").read_text())
    assert [d["path"] for d in style["demos"]] == ["a.npz"]


def _recorded(demo, vehicle: str, carriageway: str = "i80_1600", source: str = "tracks.csv"):
    """``demo`` as an extracted episode of ``vehicle`` (the metadata extraction writes)."""
    meta = {**demo.meta, "episode_id": f"{carriageway}_{vehicle}_4000", "vehicle_id": vehicle,
            "source": source}  # fmt: skip
    return replace(demo, meta=meta, origin="recorded")


@pytest.mark.slow  # extracts NGSIM and identifies in a fresh process (≈ 6 s)
@pytest.mark.skipif(not (DATA / "ngsim").is_dir(), reason="../shared/data not beside the checkout")
def test_pooling_several_recorded_vehicles_is_said_and_recorded(tmp_path):
    # before: three vehicles' lane changes pooled into one posterior without a word
    from cli_runner import run_command

    from drivestyle.recorded.benchmark import recorded_episodes

    (_, _, first), (_, _, second) = recorded_episodes(str(DATA), "ngsim")[:2]
    save_demonstration(first, tmp_path / "a.npz")
    save_demonstration(second, tmp_path / "b.npz")
    lib = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    (tmp_path / "library.json").write_text(json.dumps(lib.to_json()))
    run = run_command(tmp_path, "identify-style", "a.npz", "b.npz", "--library",
                      "library.json", "--out", "out")  # fmt: skip
    assert run.returncode == 0, run.stderr
    a, b = str(recorded_vehicle(first)), str(recorded_vehicle(second))
    assert a != b and a.startswith("i80_1600_first60s:")
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert notes == [
        f"note: pooling 2 vehicles into one posterior: {a} (a.npz); {b} (b.npz); identify each "
        "vehicle on its own to tell their risks apart"
    ]
    payload = json.loads((tmp_path / "out" / "identify.json").read_text())
    assert payload["vehicles"] == [a, b] and payload["pools_several_vehicles"] is True


def test_one_vehicles_episodes_pool_silently_and_others_are_named(paper_demo):
    one = [_recorded(paper_demo, "7"), _recorded(paper_demo, "7")]
    assert identify_style.vehicle_names(one) == ["i80_1600:7", "i80_1600:7"]
    paths = [Path("a.npz"), Path("b.npz"), Path("c.npz")]
    assert identify_style.pooling_note(identify_style.vehicle_names(one), paths[:2]) is None
    # generated demonstrations: no vehicle in their metadata, the user's word stands
    assert identify_style.vehicle_names([paper_demo, paper_demo]) == [None, None]
    assert identify_style.pooling_note([None, None], paths[:2]) is None
    # a recorded vehicle with a generated demonstration: at least two
    mixed = identify_style.vehicle_names([_recorded(paper_demo, "7"), paper_demo])
    assert identify_style.pooling_note(mixed, paths[:2]) == (
        "note: pooling at least 2 vehicles into one posterior: i80_1600:7 (a.npz); 1 of no "
        "known vehicle (b.npz); identify each vehicle on its own to tell their risks apart"
    )
    # one carriageway name in two recordings: two vehicles, told apart by their files
    two = [_recorded(paper_demo, "7", source="x.csv"), _recorded(paper_demo, "7", source="y.csv")]
    assert identify_style.vehicle_names(two) == ["i80_1600:7 of x.csv", "i80_1600:7 of y.csv"]
