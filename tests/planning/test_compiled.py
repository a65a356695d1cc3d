"""Compiled solvers (planning/compiled.py, planning/plan_solver.py; DESIGN §16): the same results as
the interpreted solvers, cached on disk for the next process, a clean fallback without gcc."""

import os
import shutil
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.driver_style import DriverStyle, Link, PlanRow, StylePlanner, reproduce
from drivestyle.irl.risk_profile import risk_profile

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


def _probe(cache: str, path: str) -> str:
    code = (
        "from drivestyle.planning.smpc_problem import SMPCConfig, SMPCProblem;"
        "from drivestyle.envs.scenario import PAPER;"
        "p = SMPCProblem(SMPCConfig(weights_as_parameters=True, compiled=True), PAPER);"
        "print(sorted(p._external))"
    )
    env = dict(os.environ, DRIVESTYLE_CACHE=cache, PATH=path)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


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
