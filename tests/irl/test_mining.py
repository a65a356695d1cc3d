"""Mining a population: rows, failures as rows, resuming, and identical rows on Ray."""

import csv
import os
import runpy
import sys
from pathlib import Path

import pytest
from drivestyle.agents.demo_generation import draw_interactive_scenarios, generate_demonstrations
from drivestyle.agents.studies.population import draw_vehicle, simulate_population
from drivestyle.irl.identification import learn_library
from drivestyle.irl.mining import COLUMNS, FAULT_ONCE_ENV, TIMING_COLUMNS, mine

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def library():
    scenarios = draw_interactive_scenarios(2, seed=0)
    return learn_library(generate_demonstrations([0.5, 0.95], scenarios, workers=1), workers=1)


@pytest.fixture(scope="module")
def population(tmp_path_factory):
    out = tmp_path_factory.mktemp("pop")
    payload = simulate_population(6, seed=1, out=out, workers=1)
    return out, payload


def _stable(rows):
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def test_population_draws_depend_on_seed_and_index_only(population):
    out, payload = population
    assert payload["n"] == 6 and payload["n_ok"] == 6
    assert payload["vehicles"][3]["risk"] == draw_vehicle(1, 3)["risk"]
    assert all(0.5 <= v["risk"] <= 0.95 for v in payload["vehicles"])
    assert len(list((out / "demos").glob("*.npz"))) == 6


def test_rows_and_failures(population, library, tmp_path):
    out, _ = population
    files = sorted((out / "demos").glob("*.npz"))
    (tmp_path / "broken.npz").write_bytes(b"not a demonstration")
    tasks = [(f.stem, "pop", str(f)) for f in files] + [
        ("broken", "pop", str(tmp_path / "broken.npz"))
    ]
    rows = mine(tasks, library, "local", workers=2)
    assert [r["id"] for r in rows] == [t[0] for t in tasks]
    broken = rows[-1]
    assert broken["status"] == "failed" and "DemonstrationError" in broken["error"]
    for r in rows[:-1]:
        if r["status"] == "ok":
            assert r["risk_lo"] <= r["risk_estimate"] <= r["risk_hi"]
            assert set(r) == set(COLUMNS)
    assert _stable(rows) == _stable(mine(tasks, library, "local", workers=1))


def _run_script(*args: str) -> None:
    old = sys.argv
    sys.argv = ["mine_styles.py", *args]
    try:
        runpy.run_path(str(ROOT / "scripts" / "mine_styles.py"), run_name="__main__")
    except SystemExit as exc:
        assert not exc.code, exc.code
    finally:
        sys.argv = old


def test_a_rerun_skips_finished_rows(population, library, tmp_path):
    from drivestyle.common.io import write_json

    out, _ = population
    write_json(tmp_path / "lib" / "library.json", library.to_json())
    dest = tmp_path / "mined"
    _run_script(str(out), "--library", str(tmp_path / "lib"), "--out", str(dest), "--workers", "1")
    lines = (dest / "styles.csv").read_text().splitlines()
    assert len(lines) == 7
    # an interruption after two rows: the rerun mines only the missing four
    (dest / "styles.csv").write_text("\n".join(lines[:3]) + "\n")
    _run_script(str(out), "--library", str(tmp_path / "lib"), "--out", str(dest), "--workers", "1")
    with (dest / "styles.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["id"] for r in rows) == sorted(p.stem for p in (out / "demos").glob("*.npz"))
    import json

    summary = json.loads((dest / "summary.json").read_text())
    assert summary["n_skipped_finished"] == 2 and summary["n_this_run"] == 4
    assert (dest / "population.png").stat().st_size > 10_000


ray = pytest.importorskip("ray")


@pytest.fixture()
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_rows_equal_local_rows(population, library, local_ray):
    out, _ = population
    tasks = [(f.stem, "pop", str(f)) for f in sorted((out / "demos").glob("*.npz"))]
    assert _stable(mine(tasks, library, "ray", workers=2)) == _stable(
        mine(tasks, library, "local", workers=2)
    )


def test_a_killed_ray_worker_does_not_lose_the_job(population, library, tmp_path, monkeypatch):
    out, _ = population
    marker = tmp_path / "killed"
    monkeypatch.setenv(FAULT_ONCE_ENV, str(marker))
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        tasks = [(f.stem, "pop", str(f)) for f in sorted((out / "demos").glob("*.npz"))]
        rows = mine(tasks, library, "ray", workers=2)
    finally:
        ray.shutdown()
    assert marker.exists()  # a worker did die mid-run
    assert [r["id"] for r in rows] == [t[0] for t in tasks]
    assert all(r["status"] in ("ok", "failed") and "Ray" not in r["error"] for r in rows)


def test_a_local_multi_node_ray_cluster(population, library):
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    cluster.add_node(num_cpus=1)
    try:
        ray.init(address=cluster.address, log_to_driver=False)
        assert len([n for n in ray.nodes() if n["Alive"]]) == 2
        out, _ = population
        tasks = [(f.stem, "pop", str(f)) for f in sorted((out / "demos").glob("*.npz"))][:4]
        rows = mine(tasks, library, "ray", workers=2)
        assert _stable(rows) == _stable(mine(tasks, library, "local", workers=1))
    finally:
        ray.shutdown()
        cluster.shutdown()
        os.environ.pop("RAY_ADDRESS", None)
