"""identify-style and learn-style: a demonstration given twice (same file or same content)
counts once."""

import json
import shutil
from dataclasses import replace

import pytest

from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.driver_style import DriverStyle
from drivestyle.irl.library import DriverLibrary
from drivestyle.scripts import identify_style


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

    from drivestyle.irl.identification import driver_posterior
    from drivestyle.irl.risk_profile import RISK_EVAL, RiskProfile

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
