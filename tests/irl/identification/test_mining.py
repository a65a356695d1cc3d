"""Mining a population: typed rows, any failure as a row, resuming, and identical rows on Ray.

The output folder's resume, fingerprint, repair and lock logic is tested through the script
in ``tests/scripts/test_mine_styles.py`` (fast), a row's own checks in ``test_mined_row.py``;
here the miner and the engines.
"""

import dataclasses
import inspect
import json
import os
import runpy
import sys
from pathlib import Path

import pytest

from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.identification import mining
from drivestyle.irl.identification.library import StyleLibrary
from drivestyle.irl.identification.mined_row import MinedRow
from drivestyle.irl.identification.mining import mine, summary_numbers
from drivestyle.irl.identification.mining_output import read_rows
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.studies.identification.population import draw_vehicle, simulate_population

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def library(style_library):
    return style_library  # tests/conftest.py: identification needs >= 5 training scenarios


@pytest.fixture(scope="module")
def population(tmp_path_factory):
    out = tmp_path_factory.mktemp("pop")
    payload = simulate_population(6, seed=1, out=out, workers=1).to_json()
    return out, payload


def _placeholder_library() -> StyleLibrary:
    """A valid library with placeholder styles (for tests that never reach scoring)."""
    fc = FeatureConfig()
    one = (1.0,) * len(fc.names)
    scenario = {"ev_speed": 20.0, "tv_speed": 18.0, "tv_gap": 20.0}
    members = ((one,) * 5,) * 2
    return StyleLibrary(fc.feature_set, (0.5, 0.9), (one, one), fc, {}, members, (scenario,) * 5)


def _stable(rows):
    return [r.without_timings() for r in rows]


def test_summary_numbers_use_ok_rows_with_a_true_risk(ok_row):
    rows = [
        ok_row,
        dataclasses.replace(ok_row, id="v2", true_risk=None),
        MinedRow.failed("v3", "p", "x"),
    ]
    summary = summary_numbers(rows)
    assert summary["n_with_truth"] == 1
    assert summary["mae_posterior_mean"] == pytest.approx(0.031)
    assert summary["interval_coverage"] == 1.0
    # the verdicts count every ok row, with or without a true risk
    assert summary["n_informative"] == sum(bool(r.informative) for r in rows[:2])
    assert summary["n_out_of_class"] == sum(bool(r.out_of_class) for r in rows[:2])


def test_verdict_ranges_are_in_noise_floors(ok_row):
    from drivestyle.irl.identification.mining import verdict_numbers

    rows = [
        dataclasses.replace(ok_row, id="a", residual_rms=0.2, noise_floor=0.1, kl_nats=0.5,
                            interval_width_ratio=0.4, informative=True, out_of_class=False),
        dataclasses.replace(ok_row, id="b", residual_rms=6.0, noise_floor=0.1, kl_nats=0.01,
                            interval_width_ratio=0.99, informative=False, out_of_class=True),
        MinedRow.failed("c", "p", "x"),
    ]  # fmt: skip
    v = verdict_numbers(rows)
    assert v["n_informative"] == 1 and v["n_out_of_class"] == 1
    assert v["verdicts"] == {"informative": 1, "prior": 0, "no_constraint": 0,
                             "out_of_class": 1, "enters_region": 0}  # fmt: skip
    assert v["residual_floors"] == pytest.approx([2.0, 60.0])
    assert v["kl_nats"] == pytest.approx([0.01, 0.5])
    assert v["interval_width_ratio"] == pytest.approx([0.4, 0.99])
    assert verdict_numbers([])["residual_floors"] is None


def test_any_error_while_mining_a_demonstration_is_its_failed_row(
    paper_demo, tmp_path, monkeypatch
):
    class Crashes:  # an unexpected exception type from deep inside learning
        def __init__(self, *args, **kwargs):
            raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(mining, "MaxEntIRL", Crashes)
    path = tmp_path / "demo.npz"
    save_demonstration(paper_demo, path)
    tasks = [("from_file", "pop", str(path)), ("in_memory", "pop", paper_demo)]
    rows = mine(tasks, _placeholder_library(), "local", workers=1)  # in this process: patched
    assert [r.status for r in rows] == ["failed", "failed"]
    assert rows[0].error == f"ZeroDivisionError: {path}: float division by zero"
    assert rows[1].error == "ZeroDivisionError: float division by zero"
    assert rows[0].true_risk == pytest.approx(0.7)


def test_duplicate_ids_are_refused(tmp_path):
    tasks = [("a", "x", str(tmp_path / "a.npz")), ("a", "y", str(tmp_path / "b.npz"))]
    with pytest.raises(ValueError, match=r"unique.*repeated: a"):
        mine(tasks, _placeholder_library(), "local", workers=1)


def test_no_test_hook_in_library_code():
    source = inspect.getsource(mining)
    assert "os._exit" not in source and "environ" not in source


@pytest.mark.parametrize(
    "address, endpoint",
    [
        ("10.0.0.2:6380", ("10.0.0.2", 6380)),
        ("head", ("head", 6379)),
        ("ray://head:10002", ("head", 10002)),
        ("ray://head", ("head", 10001)),
        ("[::1]:6379", ("::1", 6379)),
        ("auto", None),
    ],
)
def test_ray_head_addresses(address, endpoint):
    assert mining._head_endpoint(address) == endpoint


@pytest.mark.slow
def test_population_draws_depend_on_seed_and_index_only(population):
    out, payload = population
    assert payload["n"] == 6 and payload["n_ok"] == 6
    assert payload["vehicles"][3]["risk"] == draw_vehicle(1, 3)["risk"]
    assert all(0.5 <= v["risk"] <= 0.95 for v in payload["vehicles"])
    assert len(list((out / "demos").glob("*.npz"))) == 6


@pytest.mark.slow
def test_rows_and_failures(population, library, tmp_path):
    out, _ = population
    files = sorted((out / "demos").glob("*.npz"))
    (tmp_path / "broken.npz").write_bytes(b"not a demonstration")
    tasks = [(f.stem, "pop", str(f)) for f in files] + [
        ("broken", "pop", str(tmp_path / "broken.npz"))
    ]
    rows = mine(tasks, library, "local", workers=2)
    assert [r.id for r in rows] == [t[0] for t in tasks]
    broken = rows[-1]
    assert broken.status == "failed" and "DemonstrationError" in broken.error
    assert str(tmp_path / "broken.npz") in broken.error
    ok = [r for r in rows[:-1] if r.status == "ok"]
    assert len(ok) >= 4
    for r in ok:
        assert r.risk_lo <= r.risk_estimate <= r.risk_hi
        assert len(r.theta_normalised) == len(library.features.names)
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


@pytest.mark.slow
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
    rows = read_rows(dest / "styles.csv")
    # ids are paths under the input folder
    assert sorted(r.id for r in rows) == sorted(
        f"demos/{p.stem}" for p in (out / "demos").glob("*.npz")
    )
    summary = json.loads((dest / "summary.json").read_text())
    assert summary["n_skipped_finished"] == 2 and summary["n_this_run"] == 4
    assert summary["n_with_truth"] == summary["n_ok"] > 0
    assert (dest / "population.png").stat().st_size > 10_000


ray = pytest.importorskip("ray")


@pytest.fixture()
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.slow
def test_ray_rows_equal_local_rows(population, library, local_ray, tmp_path):
    out, _ = population
    tasks = [(f.stem, "pop", str(f)) for f in sorted((out / "demos").glob("*.npz"))]
    raw = Path(tasks[0][2]).read_bytes()
    (tmp_path / "torn.npz").write_bytes(raw[: len(raw) // 2])  # a truncated file
    tasks.append(("torn", "pop", str(tmp_path / "torn.npz")))
    rows = mine(tasks, library, "ray", workers=2)
    assert _stable(rows) == _stable(mine(tasks, library, "local", workers=2))
    torn = rows[-1]
    assert torn.status == "failed" and str(tmp_path / "torn.npz") in torn.error


@pytest.mark.slow
def test_a_killed_ray_worker_does_not_lose_the_job(population, library, tmp_path, local_ray):
    marker = tmp_path / "killed"

    # defined here, so that Ray ships the class by value to its workers: the fault is the
    # test's, the library code has no hook for it
    class KillsItsWorkerOnce(os.PathLike):
        def __init__(self, path: str, marker: str) -> None:
            self.path, self.marker = path, marker

        def __fspath__(self) -> str:
            if not os.path.exists(self.marker):
                Path(self.marker).write_text(str(os.getpid()))
                os._exit(1)  # the worker process dies mid-task
            return self.path

    class KillsEveryWorker(os.PathLike):
        def __fspath__(self) -> str:
            os._exit(1)

    out, _ = population
    files = sorted((out / "demos").glob("*.npz"))
    tasks = [(f.stem, "pop", str(f)) for f in files[:3]]
    tasks[0] = (tasks[0][0], "pop", KillsItsWorkerOnce(tasks[0][2], str(marker)))
    tasks.append(("poison", "pop", KillsEveryWorker()))
    rows = mine(tasks, library, "ray", workers=2)
    assert marker.exists()  # a worker did die mid-run
    assert [r.id for r in rows] == [t[0] for t in tasks]
    assert all(r.status == "ok" for r in rows[:3]), [r.error for r in rows]
    # a demonstration that kills every worker is retried, then a failed row: no endless loop
    poison = rows[-1]
    assert poison.status == "failed" and "Ray worker failed" in poison.error
    assert f"{mining.RAY_TASK_RETRIES + 1} tries" in poison.error


@pytest.mark.slow
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


def test_a_driver_library_mines_the_risk_and_the_reproduction(paper_demo):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary

    weights = (0.2, 50.0, 0.2, 1.0, 10.0)  # the expert's: the demo is reproduced exactly
    library = DriverLibrary(DriverStyle(weights), risks=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95))
    row = mining.Miner(library).mine("paper", "sim", paper_demo)
    assert row.status == "ok", row.error
    assert row.risk_estimate == 0.7 and row.risk_lo <= 0.7 <= row.risk_hi
    assert row.theta_normalised == weights
    assert row.rmse_y_m is not None and row.rmse_y_m < 0.05
    assert row.iterations == 0 and row.converged


def _crash_on_boom(self, demo_id, source, demo):
    """Miner.mine of a test: the worker process dies on demonstration "boom"."""
    if demo_id == "boom":
        os._exit(3)  # a crash (segfault, OOM kill), not an exception
    return MinedRow.failed(demo_id, source, f"DemonstrationError: {demo}: not readable")


def test_a_worker_crash_on_the_local_engine_is_an_infrastructure_row(monkeypatch):
    # forked workers inherit the patched class
    monkeypatch.setattr(mining.Miner, "mine", _crash_on_boom)
    tasks = [(f"v{i}", "pop", f"/nowhere/v{i}.npz") for i in range(4)]
    tasks.insert(2, ("boom", "pop", "/nowhere/boom.npz"))
    rows = mine(tasks, _placeholder_library(), "local", workers=2)
    assert [r.id for r in rows] == [t[0] for t in tasks]  # before: BrokenProcessPool, no rows
    boom = rows[2]
    assert boom.status == "failed" and boom.failure_kind == "infrastructure"
    assert "/nowhere/boom.npz" in boom.error and "exited with status 3" in boom.error
    assert all(r.failure_kind == "data" for r in rows if r.id != "boom")


def test_a_driver_library_row_carries_the_verdict(paper_demo):
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.driver.risk_profile import RISK_EVAL, RiskProfile
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.irl.identification.posterior import driver_posterior

    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    flat = RiskProfile(RISK_EVAL, (0.6,) * len(RISK_EVAL), 60, 0)
    ident = driver_posterior([flat], library, [95.0], [None])
    row = mining._ok_row(
        "v", "pop", None, ident, theta_normalised=(1.0,) * 5, rmse_y_m=0.1, rmse_xy_m=0.2,
        iterations=0, converged=True, learn_s=0.0, identify_s=0.0,
    )  # fmt: skip
    assert row.informative is False and row.out_of_class is False
    assert row.kl_nats == 0.0 and row.interval_width_ratio == 1.0
    assert row.residual_rms == pytest.approx(0.1, abs=1e-6)
    assert "no chance constraint binds" in row.reason
    assert row.verdict == row.label == ident.verdict.label == "no_constraint"
    assert (row.constraint_binds, row.enters_region) == (False, False)


_RAY_JOB = """
import os, sys, time
from pathlib import Path
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.identification.library import StyleLibrary
from drivestyle.irl.identification.mining import mine

class Sleeps(os.PathLike):  # defined in __main__: Ray ships it by value to its workers
    def __init__(self, folder):
        self.folder = folder

    def __fspath__(self):
        Path(self.folder, str(os.getpid())).touch()
        time.sleep(120)
        return "/nowhere.npz"

fc = FeatureConfig()
one = (1.0,) * len(fc.names)
sc = {"ev_speed": 20.0, "tv_speed": 18.0, "tv_gap": 20.0}
lib = StyleLibrary(fc.feature_set, (0.5, 0.9), (one, one), fc, {}, ((one,) * 5,) * 2, (sc,) * 5)
mine([(f"v{i}", "pop", Sleeps(sys.argv[1])) for i in range(4)], lib, "ray", workers=2)
"""


def _gone(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rpartition(")")[2].split()[0] in ("Z", "X")


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", ["SIGTERM", "SIGKILL"])
def test_ray_workers_die_with_a_killed_driver(tmp_path, sig):
    import signal
    import subprocess
    import time

    (tmp_path / "job.py").write_text(_RAY_JOB)
    pids = tmp_path / "pids"
    pids.mkdir()
    job = subprocess.Popen(
        [sys.executable, str(tmp_path / "job.py"), str(pids)],
        stderr=subprocess.PIPE,
        text=True,
        env={k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"},
    )
    deadline = time.monotonic() + 120
    while len(os.listdir(pids)) < 2:
        assert job.poll() is None and time.monotonic() < deadline
        time.sleep(0.2)
    workers = [int(p) for p in os.listdir(pids)]
    try:
        job.send_signal(getattr(signal, sig))
        code = job.wait(60)
        if sig == "SIGTERM":
            assert code == 143  # our clean stop (ray.shutdown), not Ray's exit status 1
        deadline = time.monotonic() + 30
        while not all(_gone(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert all(_gone(p) for p in workers)
    finally:
        for pid in workers:
            if not _gone(pid):
                os.kill(pid, signal.SIGKILL)
