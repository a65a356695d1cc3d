"""Styles of a whole population: per demonstration a personal style and an identified risk.

:class:`Miner` (a stateful shell holding one style library) turns one demonstration into one row of
:data:`COLUMNS`: the personal style learned by ME-IRL (θ normalised per group, fit errors), the
identified risk with its 90 % interval (:func:`drivestyle.irl.identification.identify`) and timings.
A demonstration that cannot be mined (malformed, no lane change, a solver failure) becomes a row
with ``status = "failed"`` and the error, never a crashed job.

Engines run the rows in parallel and hand each finished row to a callback (so callers can
write them as they come and resume after an interruption):

- ``local`` (default): worker processes on this machine
  (:func:`drivestyle.common.parallel.parallel_map`), one :class:`Miner` per worker;
- ``ray``: Ray actors, one :class:`Miner` each, on ``ray.init()`` here or a cluster at
  ``address``; an actor that dies is restarted and its task retried (``max_restarts``,
  ``max_task_retries``), so a killed worker does not lose the job. Ray is an optional
  extra (``pip install -e '.[ray]'``).

Both engines compute identical rows (timings aside): the work is deterministic.
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.identification import StyleLibrary, identify
from drivestyle.irl.inner import InnerSolveError
from drivestyle.irl.learner import IRLConfig, MaxEntIRL

from drivestyle.common.parallel import parallel_map

__all__ = [
    "COLUMNS",
    "ENGINES",
    "FAULT_ONCE_ENV",
    "TIMING_COLUMNS",
    "Miner",
    "MiningTask",
    "finished_ids",
    "mine",
    "read_rows",
    "summary_numbers",
]

ENGINES = ("local", "ray")
FAULT_ONCE_ENV = "DRIVESTYLE_FAULT_ONCE"
"""Fault injection for the fault-tolerance tests: if this environment variable names a file
that does not exist, the first worker to mine creates it and kills its own process."""
COLUMNS = (
    "id",
    "source",
    "status",
    "error",
    "true_risk",
    "risk_estimate",
    "risk_lo",
    "risk_hi",
    "risk_mean",
    "informative",
    "trigger_fired",
    "theta_normalised",
    "rmse_y_m",
    "rmse_xy_m",
    "iterations",
    "converged",
    "learn_s",
    "identify_s",
)
"""Columns of ``styles.csv``; ``theta_normalised`` is a JSON list in the library's feature
order, the interval is [risk_lo, risk_hi]."""
TIMING_COLUMNS = ("learn_s", "identify_s")
"""Columns that differ between runs (wall times)."""

MiningTask = tuple[str, str, Demonstration | str]
"""(id, source, demonstration or the path of its ``.npz``)."""


class Miner:
    """Learn a personal style and identify the risk of demonstrations (module docstring).

    Args:
        library: the style library (identification, and the feature set of the styles).
        irl: outer-loop settings of the personal styles.
    """

    def __init__(self, library: StyleLibrary, irl: IRLConfig | None = None) -> None:
        self.library = library
        self.irl = irl or IRLConfig()

    def mine(self, demo_id: str, source: str, demo: Demonstration | str) -> dict[str, Any]:
        """One row of :data:`COLUMNS` (``status`` "ok" or "failed" with ``error``)."""
        marker = os.environ.get(FAULT_ONCE_ENV)
        if marker and not os.path.exists(marker):
            Path(marker).write_text(str(os.getpid()))
            os._exit(1)  # a worker killed mid-run (tests only)
        row: dict[str, Any] = dict.fromkeys(COLUMNS, "")
        row |= {"id": demo_id, "source": source, "status": "failed"}
        try:
            if not isinstance(demo, Demonstration):
                demo = load_demonstration(demo)
            true = demo.meta.get("risk")
            row["true_risk"] = "" if true is None else float(true)
            t0 = time.perf_counter()
            result = MaxEntIRL(demo, self.library.features, self.irl).learn()
            row["learn_s"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            ident = identify(demo, self.library)
            row["identify_s"] = time.perf_counter() - t0
        except (OSError, ValueError, RuntimeError, InnerSolveError) as exc:
            row["error"] = f"{type(exc).__name__}: {exc}".replace("\n", " ")
            return row
        lo, hi = ident["risk_interval"]
        row |= {
            "status": "ok",
            "risk_estimate": ident["risk_estimate"],
            "risk_lo": lo,
            "risk_hi": hi,
            "risk_mean": round(ident["risk_interpolated"], 6),
            "informative": ident["informative"],
            "trigger_fired": ident["trigger_fired"],
            "theta_normalised": json.dumps([round(v, 6) for v in result.theta_normalised]),
            "rmse_y_m": round(result.errors[0]["rmse_y_m"], 6),
            "rmse_xy_m": round(result.errors[0]["rmse_xy_m"], 6),
            "iterations": result.iterations,
            "converged": result.converged,
        }
        return row


_MINER: Miner | None = None


def _init_miner(library: StyleLibrary) -> None:
    global _MINER
    _MINER = Miner(library)


def _mine_task(demo_id: str, source: str, demo: Demonstration | str) -> dict[str, Any]:
    assert _MINER is not None, "worker not initialised"
    return _MINER.mine(demo_id, source, demo)


def _run_local(
    tasks: Sequence[MiningTask],
    library: StyleLibrary,
    workers: int,
    on_row: Callable[[dict[str, Any]], None],
) -> None:
    parallel_map(
        _mine_task,
        list(tasks),
        workers,
        lambda _, row: on_row(row),
        initializer=_init_miner,
        initargs=(library,),
    )


def _run_ray(
    tasks: Sequence[MiningTask],
    library: StyleLibrary,
    workers: int,
    on_row: Callable[[dict[str, Any]], None],
    address: str | None,
) -> None:
    try:
        import ray
        from ray.util import ActorPool
    except ImportError:
        raise RuntimeError(
            "the ray engine needs Ray: pip install -c constraints-cpu.txt -e '.[ray]'"
        ) from None
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers, **kwargs)
    try:
        actor = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=-1)(Miner)
        # the library travels with each actor (small), so a restarted actor rebuilds itself
        pool = ActorPool([actor.remote(library) for _ in range(workers)])
        for row in pool.map_unordered(lambda a, t: a.mine.remote(*t), list(tasks)):
            on_row(row)
    finally:
        if started:
            ray.shutdown()


def mine(
    tasks: Iterable[MiningTask],
    library: StyleLibrary,
    engine: str = "local",
    workers: int = 2,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    address: str | None = None,
) -> list[dict[str, Any]]:
    """Mine every task's demonstration; rows are handed to ``on_row`` as they finish.

    Args:
        tasks: (id, source, demonstration or path).
        library: the style library.
        engine: ``"local"`` or ``"ray"``.
        workers: processes (local) or actors (ray).
        on_row: called with each finished row (completion order).
        address: Ray cluster address (``ray`` only; None: start Ray on this machine).

    Returns:
        The rows, in task order.

    Raises:
        ValueError: an unknown engine or a bad worker count.
        RuntimeError: ``ray`` without Ray installed.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    tasks = list(tasks)
    rows: dict[str, dict[str, Any]] = {}

    def collect(row: dict[str, Any]) -> None:
        rows[row["id"]] = row
        if on_row is not None:
            on_row(row)

    if engine == "local":
        _run_local(tasks, library, workers, collect)
    else:
        _run_ray(tasks, library, workers, collect, address)
    return [rows[t[0]] for t in tasks]


def read_rows(path: str | Path) -> list[dict[str, str]]:
    """Rows of an existing ``styles.csv`` (empty if there is none).

    Raises:
        ValueError: the file's header is not :data:`COLUMNS` (another file).
    """
    path = Path(path)
    if not path.is_file():
        return []
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        if tuple(reader.fieldnames or ()) != COLUMNS:
            raise ValueError(
                f"{path} is not a styles.csv of this version (columns {reader.fieldnames})"
            )
        return [r for r in reader if r.get("id") and r.get("status") in ("ok", "failed")]


def finished_ids(rows: Iterable[dict[str, Any]]) -> set[str]:
    """Ids of rows that are complete (ok or failed): a resumed job skips them."""
    return {r["id"] for r in rows if r.get("status") in ("ok", "failed")}


def summary_numbers(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Accuracy of the estimates where the true risk is known (ok rows)."""

    def num(v: Any) -> float:
        try:
            return float(v)
        except (TypeError, ValueError):
            return math.nan

    ok = [r for r in rows if r["status"] == "ok" and not math.isnan(num(r["true_risk"]))]
    if not ok:
        return {"n_with_truth": 0}
    true = np.array([num(r["true_risk"]) for r in ok])
    mean = np.array([num(r["risk_mean"]) for r in ok])
    lo = np.array([num(r["risk_lo"]) for r in ok])
    hi = np.array([num(r["risk_hi"]) for r in ok])
    return {
        "n_with_truth": len(ok),
        "mae_posterior_mean": float(np.mean(np.abs(mean - true))),
        "interval_coverage": float(np.mean((lo - 1e-9 <= true) & (true <= hi + 1e-9))),
    }
