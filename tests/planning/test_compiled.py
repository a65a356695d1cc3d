"""Compiled solvers (planning/compiled.py, planning/plan_solver.py; DESIGN §16): the same results as
the interpreted solvers, cached on disk for the next process, a clean fallback without gcc."""

import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.irl.driver.driver_style import DriverStyle, reproduce
from drivestyle.irl.driver.risk_profile import risk_profile
from drivestyle.irl.driver.style_planner import Link, PlanRow, StylePlanner
from drivestyle.planning import compiled
from drivestyle.planning.compiled import verify_library

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs a C compiler")

WEIGHTS = (0.2, 50.0, 0.2, 1.0, 10.0)


@pytest.fixture(scope="module")
def planners(paper_demo):
    sc = paper_demo.scenario
    return StylePlanner(sc, compiled=True), StylePlanner(sc, compiled=False)


def test_the_compiled_fatrop_is_the_interpreted_one(paper_demo, planners):
    fast, slow = planners
    assert "fatrop" in fast.problem._external  # really the generated solver
    assert not slow.problem._external
    style = DriverStyle(WEIGHTS, risk=0.8)
    rows = [PlanRow(paper_demo.ev[k], paper_demo.vehicles[k], style,
                    Link(shift=k - 1 if k else None)) for k in range(paper_demo.n - 1)]  # fmt: skip
    a, b = fast.solve_rows(rows, paper_demo.scenario), slow.solve_rows(rows, paper_demo.scenario)
    assert np.max(np.abs(a.u0 - b.u0)) < 1e-6  # inputs: the style model's features
    assert np.array_equal(a.chance_active, b.chance_active)
    for k in (0, 10, 20):
        xa = a.points(k).w[fast.layout.ix]
        xb = b.points(k).w[slow.layout.ix]
        assert np.max(np.abs(xa - xb)[:, :2]) < 1e-4  # planned trajectories [m]
    ra, rb = reproduce(style, paper_demo, fast), reproduce(style, paper_demo, slow)
    assert np.max(np.abs(ra.states[:, :2] - rb.states[:, :2])) < 1e-4
    pa = risk_profile(style, paper_demo, (0.6, 0.8, 0.95), fast)
    pb = risk_profile(style, paper_demo, (0.6, 0.8, 0.95), slow)
    assert np.allclose(pa.ssr, pb.ssr, rtol=1e-6, atol=1e-9)


def test_the_buffered_shift_is_the_plain_dynamics_call(rng, planners):
    fast, _ = planners
    problem = fast.problem
    for _ in range(20):
        xi, u = rng.normal(size=4) * [10, 2, 0.1, 10], rng.normal(size=2) * [2, 0.05]
        assert np.array_equal(problem.step(xi, u), np.asarray(problem.dynamics(xi, u)).ravel())


def test_the_buffered_stationarity_check_is_the_plain_calls(paper_demo, planners):
    """The generated solver's KKT check reads bound numpy buffers: the same gradient as a
    plain CasADi call, to the bit, at every step of a teacher-forced pass."""
    fast, _ = planners
    problem = fast.problem
    style = DriverStyle(WEIGHTS, risk=0.8)
    grads = []
    real = problem._stationary

    def spy(w, lam_g, lam_x):
        verdict = real(w, lam_g, lam_x)
        kkt = problem._kkt
        plain = np.asarray(kkt.fn(w, problem._inputs["p"], lam_g, lam_x)).ravel()
        grads.append((kkt.outputs[0].copy(), plain))
        return verdict

    rows = [PlanRow(paper_demo.ev[k], paper_demo.vehicles[k], style,
                    Link(shift=k - 1 if k else None)) for k in range(paper_demo.n - 1)]  # fmt: skip
    problem._stationary = spy
    try:
        fast.solve_rows(rows, paper_demo.scenario)
    finally:
        del problem._stationary
    assert len(grads) >= paper_demo.n - 1
    for buffered, plain in grads:
        assert np.array_equal(buffered, plain)


def _probe(cache: str, path: str) -> str:
    code = (
        "from drivestyle.planning.description import SMPCConfig;"
        "from drivestyle.planning.smpc_problem import SMPCProblem;"
        "from drivestyle.envs.scenario import PAPER;"
        "p = SMPCProblem(SMPCConfig(weights_as_parameters=True, compiled=True), PAPER);"
        "print(sorted(p._external))"
    )
    env = dict(os.environ, DRIVESTYLE_CACHE=cache, PATH=path)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.slow  # an end-to-end job: CI runs it (pytest -m slow)
def test_a_second_process_loads_the_cached_library_without_a_compiler(tmp_path):
    no_gcc = str(tmp_path / "empty-bin")  # a PATH without gcc
    os.makedirs(no_gcc)
    cache = str(tmp_path / "cache")
    # without gcc and without a cached library: the interpreted solver (clean fallback)
    assert _probe(cache, no_gcc) == "[]"
    assert not os.path.exists(cache) or not os.listdir(cache)
    # with gcc the first process compiles it into the cache ...
    assert _probe(cache, os.environ["PATH"]) == "['fatrop']"
    assert any(f.endswith(".so") for f in os.listdir(cache))
    # ... and a later process loads it, with no compiler on its PATH
    assert _probe(cache, no_gcc) == "['fatrop']"


def test_the_experimental_interior_point_solver_agrees_with_fatrop(paper_demo):
    sc = paper_demo.scenario
    ipm = StylePlanner(sc, compiled=False, ipm=True)
    assert ipm.fast is not None
    slow = StylePlanner(sc, compiled=False)
    style = replace(DriverStyle(WEIGHTS), risk=0.7)
    rows = [PlanRow(paper_demo.ev[k], paper_demo.vehicles[k], style,
                    Link(shift=k - 1 if k else None)) for k in range(paper_demo.n - 1)]  # fmt: skip
    a = ipm.solve_rows(rows, sc)
    b = slow.solve_rows(rows, sc)
    # rows the compiled solver could not solve went to fatrop: every row is solved, and
    # the first inputs agree to fatrop's own accuracy (its tolerance 1e-6 on the scaled
    # KKT residual leaves up to ≈ 1e-4 m/s² in the inputs; the IPM's is tighter)
    assert a.ok.all() and b.ok.all()
    assert ipm.fallbacks < len(rows)  # the compiled solver solved some rows itself
    assert np.max(np.abs(a.u0 - b.u0)) < 2e-4


# -- the cache under faults: a small function, so that a rebuild costs a fraction of a second

_SQUARE = """
import casadi as ca
from drivestyle.planning.compiled import compiled_function
x = ca.SX.sym("x")
build = lambda: ca.Function("ds_test_square", [x], [x * x + 1])
f = compiled_function("ds_test_square", "0" * 20, build)
print("compiled" if f is not None else "interpreted", float(f(3)) if f is not None else "")
"""
needs_gcc = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")


def _square(env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", _SQUARE], env=env, capture_output=True, text=True, timeout=60
    )


def _cache_env(cache) -> dict[str, str]:
    return dict(os.environ, DRIVESTYLE_CACHE=str(cache))


def _built(cache) -> Path:
    out = _square(_cache_env(cache))
    assert out.returncode == 0 and out.stdout.split() == ["compiled", "10.0"], out.stderr
    (lib,) = Path(cache).glob("ds_test_square_*.so")
    assert verify_library(lib) is None
    return lib


@needs_gcc
@pytest.mark.parametrize(
    "damage, why",
    [
        pytest.param(  # cut short: dlopen would die of SIGBUS
            lambda b: b[: len(b) // 2], "instead of", marks=pytest.mark.slow
        ),
        (lambda b: os.urandom(len(b)), "does not match its checksum"),
        pytest.param(lambda b: b"", "instead of", marks=pytest.mark.slow),
    ],
    ids=["truncated", "random", "empty"],
)
def test_a_damaged_cached_library_is_rebuilt_never_loaded(tmp_path, damage, why):
    lib = _built(tmp_path)
    good = lib.read_bytes()
    lib.write_bytes(damage(good))
    out = _square(_cache_env(tmp_path))
    assert out.returncode == 0, out.stderr  # before: SIGBUS (exit 135) or a silent slow path
    assert out.stdout.split() == ["compiled", "10.0"]  # the same result, compiled
    assert why in out.stderr and "deleted, rebuilding" in out.stderr
    assert verify_library(lib) is None and lib.read_bytes() == good  # rebuilt, same bytes
    # and a later process loads it without a word
    again = _square(_cache_env(tmp_path))
    assert again.returncode == 0 and again.stderr == ""


@needs_gcc
def test_a_cached_library_without_its_checksum_is_rebuilt(tmp_path):
    lib = _built(tmp_path)
    Path(str(lib) + ".sha256").unlink()
    out = _square(_cache_env(tmp_path))
    assert out.returncode == 0 and "no checksum" in out.stderr
    assert verify_library(lib) is None


@needs_gcc
def test_without_a_usable_home_the_cache_falls_back_to_the_temp_folder(tmp_path):
    (tmp_path / "a-file").write_text("")
    env = {k: v for k, v in os.environ.items() if k not in ("DRIVESTYLE_CACHE", "XDG_CACHE_HOME")}
    env.update(HOME=str(tmp_path / "a-file" / "home"), TMPDIR=str(tmp_path / "tmp"))
    os.makedirs(env["TMPDIR"])
    out = _square(env)
    assert out.returncode == 0 and out.stdout.split() == ["compiled", "10.0"], out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "cached in" in out.stderr
    assert list((tmp_path / "tmp").glob("drivestyle-cache-*/ds_test_square_*.so"))
    # HOME unset altogether: the command still works (home from the password file, or the
    # temp folder)
    del env["HOME"]
    out = _square(env)
    assert out.returncode == 0 and out.stdout.split() == ["compiled", "10.0"], out.stderr


def test_no_home_at_all_is_said_once_and_shared_with_workers(tmp_path, monkeypatch, capsys):
    for name in ("DRIVESTYLE_CACHE", "XDG_CACHE_HOME"):
        # set first, so that monkeypatch restores the variable (or its absence) afterwards:
        # cache_dir() exports its fallback, and a later test in this worker process would
        # otherwise compile every solver again into this test's temp folder
        monkeypatch.setenv(name, "")
        monkeypatch.delenv(name)
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR

    def no_home() -> Path:
        raise RuntimeError("Could not determine home directory.")

    monkeypatch.setattr(Path, "home", staticmethod(no_home))
    monkeypatch.setattr(compiled, "_SAID", set())
    first = compiled.cache_dir()
    assert first is not None and first.parent == tmp_path
    assert os.environ["DRIVESTYLE_CACHE"] == str(first)  # worker processes inherit it
    assert compiled.cache_dir() == first
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "HOME is not set" in err[0]
