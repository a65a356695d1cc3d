"""``--posterior``: the commands that identify a style also give the amortized posterior.

Each command runs as a user runs it (its own process), with a tiny estimator trained in the
test session (``tiny_posterior``: its answers mean nothing, its numbers are checked against
the same estimator in this process); without the option the exact outputs are unchanged.
"""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from cli_runner import DATA, run_command

from drivestyle.common.stats import auroc, icc_oneway
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.amortized.identify import identify_amortized
from drivestyle.irl.amortized.simulations import PARAMETERS
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.studies.out_of_class.caution_order import spearman

pytest.importorskip("zuko")

EXPERT = (0.2, 50.0, 0.2, 1.0, 10.0)  # the SMPC expert's weights: its demos fit exactly
VOLATILE = ("command", "created_utc", "identify_s", "wall_s", "seconds")


@pytest.fixture(scope="module")
def library(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("library")
    lib = DriverLibrary(DriverStyle(EXPERT), risks=(0.5, 0.7, 0.9))
    (folder / "library.json").write_text(json.dumps(lib.to_json()))
    return folder


def _ok(done):
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def _json(path: Path) -> dict:
    return json.loads(Path(path).read_text())


def _steady(payload: dict) -> dict:
    return {k: v for k, v in payload.items() if k not in VOLATILE}


def _meta_sha256(path: Path) -> str:
    return json.loads(str(np.load(path)["meta"][()]))["weights_sha256"]


def test_identify_style_adds_each_demonstrations_amortized_posterior(
    tiny_posterior, library, paper_demo, tmp_path
):
    posterior, estimator = tiny_posterior
    save_demonstration(paper_demo, tmp_path / "demo.npz")
    plain = _ok(run_command(tmp_path, "identify-style", "demo.npz", "--library", library,
                            "--out", "plain"))  # fmt: skip
    done = _ok(run_command(tmp_path, "identify-style", "demo.npz", "--library", library,
                           "--posterior", estimator, "--out", "with"))  # fmt: skip
    before, after = _json(tmp_path / "plain/identify.json"), _json(tmp_path / "with/identify.json")
    amortized = after.pop("amortized")
    assert _steady(after) == _steady(before)  # the exact identification as it was
    # the printed summary: the same lines, and the amortized one before the last
    lines, said = plain.stdout.splitlines(), done.stdout.splitlines()
    assert said[: len(lines) - 1] == lines[:-1] and len(said) == len(lines) + 1
    assert said[-2].startswith("  amortized posterior of demo.npz (mean [90 % interval]): risk ")
    assert amortized["estimator_sha256"] == _meta_sha256(estimator)
    (demo,) = amortized["demos"]
    assert demo["demo"] == "demo.npz" and demo["samples_observed"] == paper_demo.n
    assert list(demo["parameters"]) == list(PARAMETERS)
    here = identify_amortized(posterior, paper_demo)  # one thread, seed 0: the same draws
    for d, name in enumerate(PARAMETERS):
        got = demo["parameters"][name]
        assert got["mean"] == pytest.approx(here.mean[d], rel=1e-9, abs=1e-12), name
        assert got["q05"] == pytest.approx(here.lo[d], rel=1e-9, abs=1e-12), name
        assert got["q05"] <= got["median"] <= got["q95"]
    assert f"risk {here.mean[0]:.3g} [{here.lo[0]:.3g}, {here.hi[0]:.3g}]" in said[-2]


def test_a_missing_or_damaged_estimator_is_one_line_naming_the_option(
    tiny_posterior, library, paper_demo, tmp_path, refused
):
    _, estimator = tiny_posterior
    save_demonstration(paper_demo, tmp_path / "demo.npz")
    said = refused("identify-style", "demo.npz", "--library", library, "--posterior",
                   "nope.npz", "--out", "out")  # fmt: skip
    assert said == "--posterior nope.npz: no such estimator file"
    (tmp_path / "bad.npz").write_bytes(Path(estimator).read_bytes()[:-300])
    said = refused("mine-styles", tmp_path, "--library", library, "--posterior", "bad.npz",
                   "--out", "mined")  # fmt: skip
    assert said.startswith("--posterior bad.npz: not a readable estimator file")


def test_mine_styles_writes_every_demonstrations_amortized_posterior(
    tiny_posterior, library, paper_demo, tmp_path
):
    posterior, estimator = tiny_posterior
    folder = tmp_path / "demos"
    folder.mkdir()
    save_demonstration(paper_demo, folder / "v1.npz")
    (folder / "v2.npz").write_bytes(b"not a demonstration")
    done = _ok(run_command(tmp_path, "mine-styles", folder, "--library", library, "--workers",
                           "1", "--posterior", estimator, "--out", "mined"))  # fmt: skip
    with (tmp_path / "mined" / "amortized.csv").open() as fh:
        rows = {r["id"]: r for r in csv.DictReader(fh)}
    assert set(rows) == {"v1", "v2"}
    assert rows["v2"]["status"] == "failed" and "v2.npz" in rows["v2"]["error"]
    assert rows["v2"]["risk_mean"] == ""
    ok = rows["v1"]
    assert ok["status"] == "ok" and float(ok["true_risk"]) == 0.7
    assert int(ok["samples_observed"]) == paper_demo.n
    here = identify_amortized(posterior, paper_demo)  # the batch of the one readable demo
    for d, name in enumerate(PARAMETERS):
        assert float(ok[f"{name}_mean"]) == pytest.approx(here.mean[d], rel=1e-12)
        assert float(ok[f"{name}_q95"]) == pytest.approx(here.hi[d], rel=1e-12)
    summary = _json(tmp_path / "mined" / "summary.json")["amortized"]
    assert (summary["n"], summary["n_ok"], summary["n_failed"]) == (2, 1, 1)
    assert summary["n_with_truth"] == 1 and summary["estimator_sha256"] == _meta_sha256(estimator)
    assert summary["risk_mae_posterior_mean"] == pytest.approx(abs(here.mean[0] - 0.7))
    assert summary["risk_interval_coverage"] == float(here.lo[0] <= 0.7 <= here.hi[0])
    assert summary["median_posterior_mean"]["risk"] == pytest.approx(here.mean[0])
    assert done.stdout.splitlines()[-1].startswith(
        "amortized posterior: wrote amortized.csv: 1 of 2 demonstrations (1 failed)"
    )
    styles = (tmp_path / "mined" / "styles.csv").read_text()
    assert "amortized" not in styles.splitlines()[0]  # the exact table keeps its columns


def test_bench_tracker_times_the_amortized_tracker(tiny_posterior, tmp_path):
    _, estimator = tiny_posterior
    _ok(run_command(tmp_path, "bench-tracker", "--posterior", estimator, "--vehicles", "1",
                    "--draws", "4", "--out", "tracker.json"))  # fmt: skip
    bench = _json(tmp_path / "tracker.json")
    assert "median_ms" not in bench  # no library: no exact tracker timed
    amortized = bench["amortized"]
    assert amortized["updates"] == 31 and amortized["draws"] == 4  # one per sample of 6 s
    assert amortized["torch_threads"] == 1
    assert amortized["estimator_sha256"] == _meta_sha256(estimator)
    for part in ("update", "update_and_summary"):
        t = amortized[part]
        assert 0 < t["median_ms"] <= t["p95_ms"] <= t["p99_ms"] <= t["max_ms"], part
    assert amortized["goal_met"] == (amortized["update_and_summary"]["median_ms"] <= 2.0)


def test_bench_tracker_needs_a_tracker_to_time(refused):
    assert refused("bench-tracker", "--out", "b.json") == (
        "give --library (the exact tracker), --posterior (the amortized) or both"
    )


needs_data = pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file(),
    reason="the recorded CATS sample is absent",
)


@pytest.mark.slow
@needs_data
def test_compare_av_human_separates_and_checks_consistency_on_the_amortized_posterior(
    tiny_posterior, tmp_path
):
    _, estimator = tiny_posterior
    _ok(run_command(tmp_path, "compare-av-human", "--data-dir", DATA, "--samples", "200",
                    "--out", "plain"))  # fmt: skip
    _ok(run_command(tmp_path, "compare-av-human", "--data-dir", DATA, "--samples", "200",
                    "--posterior", estimator, "--out", "with"))  # fmt: skip
    before = _json(tmp_path / "plain" / "av_vs_human.json")
    after = _json(tmp_path / "with" / "av_vs_human.json")
    amortized = after.pop("amortized")
    assert _steady(after) == _steady(before)
    plain_md = (tmp_path / "plain" / "av_vs_human.md").read_text().splitlines()
    with_md = (tmp_path / "with" / "av_vs_human.md").read_text().splitlines()
    keep = [i for i, line in enumerate(plain_md) if not line.startswith("`")]  # the command
    assert [with_md[i] for i in keep] == [plain_md[i] for i in keep]
    assert "## The amortized posterior" in with_md
    episodes = amortized["episodes"]
    assert len(episodes) == len(before["episodes"])
    assert amortized["estimator_sha256"] == _meta_sha256(estimator)
    # the AUROC of the AV's risk against every human, from the lane changes' posterior means
    av = [e["parameters"]["risk"]["mean"] for e in episodes if e["group"] == "AV"]
    human = [e["parameters"]["risk"]["mean"] for e in episodes if e["group"] != "AV"]
    (row,) = [s for s in amortized["auroc"] if s["quantity"] == "amortized:risk"
              and s["against"] == "humans"]  # fmt: skip
    assert (row["n_av"], row["n_other"]) == (len(av), len(human))
    assert row["auroc"] == pytest.approx(auroc(av, human))
    assert row["lo"] <= row["auroc"] <= row["hi"]
    speed = [s for s in amortized["auroc"] if s["quantity"] == "median_speed_mps"]
    assert len(speed) == 3 and all(0 <= s["auroc"] <= 1 for s in speed)  # the descriptors too
    # the AV's consistency across its runs
    mine = [e for e in episodes if e["group"] == "AV"]
    icc = icc_oneway([e["parameters"]["risk"]["mean"] for e in mine], [e["run"] for e in mine])
    (cons,) = [c for c in amortized["consistency"] if c["group"] == "AV"
               and c["parameter"] == "risk"]  # fmt: skip
    assert cons["classes"] == len({e["run"] for e in mine}) > 1
    assert icc is not None and cons["icc"] == pytest.approx(icc.icc)


@pytest.mark.slow
def test_evaluate_out_of_class_orders_the_classes_by_the_amortized_posterior(
    tiny_posterior, library, tmp_path
):
    _, estimator = tiny_posterior
    # one lane change per highway-env class from one traffic run (≈ 30 s), no prediction
    _ok(run_command(tmp_path, "evaluate-out-of-class", "--library", library,
                    "--per-class", "2", "--max-runs", "1", "--scenarios", "0", "--no-prediction",
                    "--posterior", estimator, "--out", "ooc"))  # fmt: skip
    result = _json(tmp_path / "ooc" / "out_of_class.json")
    amortized = result["amortized"]
    episodes = amortized["episodes"]
    assert len(episodes) == sum(result["highway"]["kept_per_class"].values()) >= 3
    assert amortized["estimator_sha256"] == _meta_sha256(estimator)
    exact = {o["scope"]: o["rho_episodes"] for o in result["order"] if o["subset"] == "all"}
    orders = {(o["scope"], o["parameter"]): o for o in amortized["order"]}
    assert {p for _, p in orders} == {"risk", "time_gap", "min_gap"}
    for name in ("risk", "time_gap", "min_gap"):
        o = orders[("highway-env", name)]
        rho, _ = spearman([e["caution"] for e in episodes],
                          [e["parameters"][name]["mean"] for e in episodes])  # fmt: skip
        assert o["n"] == len(episodes) and o["rho_episodes"] == pytest.approx(rho)
        assert o["rho_exact"] == exact["highway-env"]
    md = (tmp_path / "ooc" / "out_of_class.md").read_text()
    assert "## Caution order by the amortized posterior" in md


def test_mine_styles_check_needs_the_posterior(library, tmp_path, refused):
    said = refused("mine-styles", tmp_path, "--library", library, "--check", "--out", "mined")
    assert said.endswith("--check needs --posterior (the draws it checks)")


@pytest.mark.slow  # ≈ 40 s: 200 replicates of the paper's episode, twice
def test_mine_styles_checks_each_demonstrations_fit(tiny_posterior, library, paper_demo, tmp_path):
    from drivestyle.irl.amortized.behaviour import STATISTICS
    from drivestyle.irl.amortized.predictive_check import predictive_check

    posterior, estimator = tiny_posterior
    folder = tmp_path / "demos"
    folder.mkdir()
    save_demonstration(paper_demo, folder / "v1.npz")
    done = _ok(run_command(tmp_path, "mine-styles", folder, "--library", library, "--workers",
                           "1", "--posterior", estimator, "--check", "--out", "mined"))  # fmt: skip
    with (tmp_path / "mined" / "amortized.csv").open() as fh:
        (row,) = list(csv.DictReader(fh))
    here = predictive_check(identify_amortized(posterior, paper_demo).draws, paper_demo, seed=0)
    assert row["check"] == ("inside" if here.inside else "outside")
    assert row["failing"] == " ".join(here.failing)
    for name in STATISTICS:
        assert float(row[f"p_{name}"]) == pytest.approx(here.p_values[name], rel=1e-12)
    check = _json(tmp_path / "mined" / "summary.json")["amortized"]["check"]
    assert (check["n_checked"], check["n_inside"], check["draws"]) == (1, int(here.inside), 200)
    assert f"{int(here.inside)} of 1 inside the class" in done.stdout
