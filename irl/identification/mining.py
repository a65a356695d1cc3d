"""Styles of a whole population: per demonstration a personal style and an identified risk.

:class:`Miner` (a stateful shell holding one style library) turns one demonstration into one
:class:`~drivestyle.irl.identification.mined_row.MinedRow` (a row of ``styles.csv``,
:mod:`drivestyle.irl.identification.mined_row`): the personal style
learned by ME-IRL (θ normalised per group, fit errors), the identified risk with its 90 %
interval (:func:`drivestyle.irl.identification.posterior.identify`) and timings. A demonstration
that cannot be mined (an unreadable file, malformed data, no lane change, a solver failure, any
error at all) becomes a row with ``status = "failed"`` and a one-line error naming the file,
never a crashed job. Its ``failure_kind`` says whose failure it is: "data" (the
demonstration's: final) or "infrastructure" (a worker process that died or was killed, out
of memory: a resumed run mines it again).

Engines run the rows in parallel and hand each finished row to a callback (so callers can
write them as they come and resume after an interruption):

- ``local`` (default): worker processes on this machine
  (:func:`drivestyle.common.parallel.parallel_map`), one :class:`Miner` per worker; a
  demonstration whose worker dies is tried again alone, and if that worker dies too it is a
  failed row naming the cause (the exit status or signal), so neither loses the job;
- ``ray``: Ray actors, one :class:`Miner` each, on ``ray.init()`` here or a cluster at
  ``address`` (reached within a timeout, else a one-line error); an actor that dies is
  restarted and its task retried (:data:`RAY_TASK_RETRIES` times, then the demonstration
  is a failed row), so a killed worker does not lose the job and a demonstration that kills
  every worker does not stall it. Ray is an optional extra (``pip install -e '.[ray]'``).

Both engines compute identical rows (timings aside): the work is deterministic.

The output folder of a resumable run (fingerprint, lock, repair) is
:mod:`drivestyle.irl.identification.mining_output`.
"""

from __future__ import annotations

import math
import os
import socket
import time
from collections import Counter, deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace
from pathlib import PurePath
from typing import Any

import numpy as np

from drivestyle.common.parallel import EXIT_TERMINATED, parallel_map, sigterm_stops_the_job
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.driver.driver_style import reproduce
from drivestyle.irl.identification.library import DriverLibrary, StyleLibrary
from drivestyle.irl.identification.mined_row import MinedRow, one_line
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.identification.result import Identification
from drivestyle.irl.identification.verdict import (
    ENTERS_REGION,
    INFORMATIVE,
    OUT_OF_CLASS,
    VERDICT_LABELS,
)
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "CONNECT_TIMEOUT_S",
    "ENGINES",
    "RAY_TASK_RETRIES",
    "Miner",
    "MiningTask",
    "mine",
    "summary_numbers",
    "verdict_numbers",
]

ENGINES = ("local", "ray")
RAY_TASK_RETRIES = 2
"""Retries of a demonstration whose Ray worker died (then it is a failed row): a worker
killed once loses nothing, and a demonstration that kills every worker cannot stall the job."""
CONNECT_TIMEOUT_S = 10.0
"""Time to reach a Ray head at ``address`` before giving up [s] (Ray itself retries for
minutes without a word)."""

MiningTask = tuple[str, str, Demonstration | str | os.PathLike[str]]
"""(id, source, demonstration or the path of its ``.npz``)."""


def _round(value: float | None) -> float | None:
    return None if value is None else round(float(value), 6)


def _describe(exc: BaseException, where: str | None) -> str:
    text = f"{type(exc).__name__}: {exc}"
    return text if where is None or where in text else f"{type(exc).__name__}: {where}: {exc}"


class Miner:
    """Learn a personal style and identify the risk of demonstrations (module docstring).

    Args:
        library: the style library (identification, and the feature set of the styles).
        irl: outer-loop settings of the personal styles.
    """

    def __init__(self, library: StyleLibrary | DriverLibrary, irl: IRLConfig | None = None) -> None:
        self.library = library
        self.irl = irl or IRLConfig()

    def mine(
        self, demo_id: str, source: str, demo: Demonstration | str | os.PathLike[str]
    ) -> MinedRow:
        """One row: ``status`` "ok", or "failed" with a one-line error naming the file."""
        where: str | None = None
        true_risk: float | None = None
        try:
            if not isinstance(demo, Demonstration):
                where = os.fspath(demo)
                demo = load_demonstration(where)
            true = demo.meta.get("risk")
            true_risk = None if true is None else float(true)
            if isinstance(self.library, DriverLibrary):
                return self._mine_driver(demo_id, source, demo, true_risk)
            t0 = time.perf_counter()
            result = MaxEntIRL(demo, self.library.features, self.irl).learn()
            learn_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            ident = identify(demo, self.library)
            identify_s = time.perf_counter() - t0
            return _ok_row(
                demo_id,
                source,
                true_risk,
                ident,
                theta_normalised=result.theta_normalised,
                rmse_y_m=result.errors[0]["rmse_y_m"],
                rmse_xy_m=result.errors[0]["rmse_xy_m"],
                iterations=result.iterations,
                converged=result.converged,
                learn_s=learn_s,
                identify_s=identify_s,
            )
        # any error is this demonstration's row, never the job's (Ctrl-C still stops it)
        except MemoryError as exc:  # the machine's, not the demonstration's: retried
            return MinedRow.failed(
                demo_id, source, _describe(exc, where), true_risk, "infrastructure"
            )
        except Exception as exc:
            return MinedRow.failed(demo_id, source, _describe(exc, where), true_risk)

    def _mine_driver(
        self, demo_id: str, source: str, demo: Demonstration, true_risk: float | None
    ) -> MinedRow:
        """A driver library's row: the risk is the vehicle's parameter (the cost is shared).

        ``theta_normalised`` holds the library style's weights over w_a; the errors are
        those of the style driven at the posterior-mean risk in the demonstration's scenario;
        ``learn_s`` times that reproduction.
        """
        assert isinstance(self.library, DriverLibrary)
        demo = recorded_view(demo)  # reproduced on what identify solves on
        t0 = time.perf_counter()
        ident = identify(demo, self.library)
        identify_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        style = replace(self.library.style, risk=round(ident.risk_interpolated, 6))
        rmse_y, rmse_xy = reproduce(style, demo).errors(demo)
        learn_s = time.perf_counter() - t0
        return _ok_row(
            demo_id,
            source,
            true_risk,
            ident,
            theta_normalised=self.library.style.normalised(),
            rmse_y_m=rmse_y,
            rmse_xy_m=rmse_xy,
            iterations=0,
            converged=True,
            learn_s=learn_s,
            identify_s=identify_s,
        )


def _ok_row(
    demo_id: str,
    source: str,
    true_risk: float | None,
    ident: Identification,
    *,
    theta_normalised: np.ndarray,
    rmse_y_m: float | None,
    rmse_xy_m: float | None,
    iterations: int,
    converged: bool,
    learn_s: float,
    identify_s: float,
) -> MinedRow:
    """A successful row from an identification and the vehicle's style and fit."""
    lo, hi = ident.risk_interval
    v = ident.verdict
    return MinedRow(
        id=demo_id,
        source=source,
        status="ok",
        true_risk=true_risk,
        risk_estimate=ident.risk_estimate,
        risk_lo=lo,
        risk_hi=hi,
        risk_mean=round(ident.risk_interpolated, 6),
        informative=ident.informative,
        trigger_fired=ident.trigger_fired,
        theta_normalised=tuple(round(float(v), 6) for v in theta_normalised),
        rmse_y_m=_round(rmse_y_m),
        rmse_xy_m=_round(rmse_xy_m),
        iterations=iterations,
        converged=converged,
        learn_s=learn_s,
        identify_s=identify_s,
        residual_rms=None if v is None else _round(v.residual_rms),
        noise_floor=None if v is None else _round(v.noise_floor),
        out_of_class=None if v is None else v.out_of_class,
        kl_nats=None if v is None else _round(v.kl_nats),
        interval_width_ratio=None if v is None else _round(v.width_ratio),
        reason="" if v is None else one_line(v.reason),
        constraint_binds=None if v is None else v.constraint_binds,
        enters_region=None if v is None else v.enters_region,
        verdict="" if v is None else v.label,
    )


_MINER: Miner | None = None


def _init_miner(library: StyleLibrary | DriverLibrary) -> None:
    global _MINER
    _MINER = Miner(library)


def _mine_task(demo_id: str, source: str, demo: Demonstration | str | os.PathLike[str]) -> MinedRow:
    assert _MINER is not None, "worker not initialised"
    return _MINER.mine(demo_id, source, demo)


def _where(demo_id: str, demo: Demonstration | str | os.PathLike[str]) -> str:
    return str(demo) if isinstance(demo, str | PurePath) else f"demonstration {demo_id}"


def _run_local(
    tasks: Sequence[MiningTask],
    library: StyleLibrary | DriverLibrary,
    workers: int,
    on_row: Callable[[MinedRow], None],
) -> None:
    def crashed(index: int, cause: str) -> MinedRow:
        # the task killed its worker process twice (alone the second time): its row
        demo_id, source, demo = tasks[index]
        return MinedRow.failed(
            demo_id, source, f"{_where(demo_id, demo)}: {cause} (2 tries)", kind="infrastructure"
        )

    parallel_map(
        _mine_task,
        list(tasks),
        workers,
        lambda _, row: on_row(row),
        initializer=_init_miner,
        initargs=(library,),
        on_crash=crashed,
    )


def _head_endpoint(address: str) -> tuple[str, int] | None:
    """(host, port) of a Ray head address; None for ``auto``/``local`` (Ray finds those)."""
    if address in ("auto", "local"):
        return None
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "", address
    rest = rest.split("/", 1)[0]
    default = 10001 if scheme == "ray" else 6379  # Ray client / GCS ports
    if rest.startswith("["):  # [IPv6]:port
        host, _, tail = rest[1:].partition("]")
        port_text = tail.removeprefix(":")
    else:
        host, _, port_text = rest.rpartition(":") if ":" in rest else (rest, "", "")
    if not port_text:
        return host, default
    try:
        return host, int(port_text)
    except ValueError:
        raise ValueError(f"Ray address {address!r}: port {port_text!r} is not a number") from None


def _check_reachable(address: str, timeout_s: float) -> None:
    """Raise ConnectionError unless a TCP connection to the Ray head opens within the time."""
    endpoint = _head_endpoint(address)
    if endpoint is None:
        return
    try:
        with socket.create_connection(endpoint, timeout=timeout_s):
            pass
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise ConnectionError(
            f"cannot reach the Ray head at {address} within {timeout_s:g} s ({why}); "
            "is the cluster running and the address right?"
        ) from None


def _ray_failure(exc: Exception) -> str:
    """One line for a task that Ray could not complete."""
    cause = getattr(exc, "cause", None)  # RayTaskError carries the worker's exception
    if isinstance(cause, BaseException):
        return f"{type(cause).__name__}: {cause}"
    lines = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {lines[0] if lines else ''}"


def _run_ray(
    tasks: Sequence[MiningTask],
    library: StyleLibrary | DriverLibrary,
    workers: int,
    on_row: Callable[[MinedRow], None],
    address: str | None,
    connect_timeout_s: float,
) -> None:
    try:
        import ray
        from ray.exceptions import RayActorError, RayError
    except ImportError:
        raise RuntimeError(
            "the ray engine needs Ray: pip install -c constraints-cpu.txt -e '.[ray]'"
        ) from None
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address:
            _check_reachable(address, connect_timeout_s)
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers, **kwargs)
    # SIGTERM: the same clean stop as Ctrl-C, ending in ray.shutdown() below (Ray's own
    # handler exits with status 1 and no shutdown of ours)
    with sigterm_stops_the_job(replace=True) as sigterm:
        try:
            retried = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=RAY_TASK_RETRIES)
            actor: Any = retried(Miner)
            # the library travels with each actor (small), so a restarted actor rebuilds itself
            free: list[Any] = [actor.remote(library) for _ in range(min(workers, len(tasks)))]
            queue = deque(tasks)
            running: dict[Any, tuple[Any, MiningTask]] = {}
            while queue or running:
                while free and queue:
                    a, task = free.pop(), queue.popleft()
                    running[a.mine.remote(*task)] = (a, task)
                (ref,), _ = ray.wait(list(running), num_returns=1)
                a, (demo_id, source, demo) = running.pop(ref)
                free.append(a)
                try:
                    row = ray.get(ref)
                except RayError as exc:  # the worker died on every try, or Ray failed: a row
                    tries = (
                        f" ({RAY_TASK_RETRIES + 1} tries)" if isinstance(exc, RayActorError) else ""
                    )
                    why = f"the Ray worker failed{tries}: {_ray_failure(exc)}"
                    row = MinedRow.failed(
                        demo_id, source, f"{_where(demo_id, demo)}: {why}", kind="infrastructure"
                    )
                on_row(row)
        except SystemExit:
            if sigterm.received:  # Ray's blocking calls replace our exit status with 1
                raise SystemExit(EXIT_TERMINATED) from None
            raise
        finally:
            if started:
                ray.shutdown()


def mine(
    tasks: Iterable[MiningTask],
    library: StyleLibrary | DriverLibrary,
    engine: str = "local",
    workers: int = 2,
    on_row: Callable[[MinedRow], None] | None = None,
    address: str | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> list[MinedRow]:
    """Mine every task's demonstration; rows are handed to ``on_row`` as they finish.

    Args:
        tasks: (id, source, demonstration or path); ids must be unique.
        library: the style library.
        engine: ``"local"`` or ``"ray"``.
        workers: processes (local) or actors (ray).
        on_row: called with each finished row (completion order).
        address: Ray cluster address (``ray`` only; None: start Ray on this machine).
        connect_timeout_s: time to reach the head at ``address`` [s].

    Returns:
        The rows, in task order; a demonstration that could not be mined is a failed row.

    Raises:
        ValueError: an unknown engine, a bad worker count or repeated ids (rows are matched
            to demonstrations by id).
        RuntimeError: ``ray`` without Ray installed.
        ConnectionError: the Ray head at ``address`` cannot be reached.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if not (connect_timeout_s > 0 and math.isfinite(connect_timeout_s)):
        raise ValueError(f"connect_timeout_s must be a finite number > 0, got {connect_timeout_s}")
    tasks = list(tasks)
    ids = [t[0] for t in tasks]
    if len(set(ids)) < len(ids):
        repeated = sorted(i for i, n in Counter(ids).items() if n > 1)
        raise ValueError(
            f"demonstration ids must be unique (rows are matched by id), repeated: "
            f"{', '.join(repeated[:5])}{' …' if len(repeated) > 5 else ''}"
        )
    rows: dict[str, MinedRow] = {}

    def collect(row: MinedRow) -> None:
        rows[row.id] = row
        if on_row is not None:
            on_row(row)

    if not tasks:
        return []
    if engine == "local":
        _run_local(tasks, library, workers, collect)
    else:
        _run_ray(tasks, library, workers, collect, address, connect_timeout_s)
    return [rows[i] for i in ids]


def _range(values: Sequence[float | None]) -> list[float] | None:
    kept = [float(v) for v in values if v is not None and math.isfinite(v)]
    return [min(kept), max(kept)] if kept else None


def verdict_numbers(rows: Sequence[MinedRow]) -> dict[str, Any]:
    """The verdicts on fit over the ok rows (DESIGN §8): counts and ranges.

    Returns:
        ``verdicts`` (label → rows, every label of
        :data:`~drivestyle.irl.identification.verdict.VERDICT_LABELS`), ``n_informative`` (label
        ``informative``), ``n_out_of_class`` (``out_of_class`` or ``enters_region``: the
        style does not describe the driver) and the [min, max] of the residual in noise
        floors (``residual_floors``), of ``kl_nats`` and of ``interval_width_ratio`` (None
        where no row has the number).
    """
    ok = [r for r in rows if r.status == "ok"]
    floors = [
        r.residual_rms / r.noise_floor for r in ok if r.residual_rms is not None and r.noise_floor
    ]
    labels = Counter(r.label for r in ok)
    return {
        "verdicts": {label: labels[label] for label in VERDICT_LABELS},
        "n_informative": labels[INFORMATIVE],
        "n_out_of_class": labels[OUT_OF_CLASS] + labels[ENTERS_REGION],
        "residual_floors": _range(floors),
        "kl_nats": _range([r.kl_nats for r in ok]),
        "interval_width_ratio": _range([r.interval_width_ratio for r in ok]),
    }


def summary_numbers(rows: Sequence[MinedRow]) -> dict[str, Any]:
    """Accuracy of the estimates where the true risk is known (ok rows), and the verdicts."""
    verdicts = verdict_numbers(rows)
    ok = [r for r in rows if r.status == "ok" and r.true_risk is not None]
    if not ok:
        return {"n_with_truth": 0, **verdicts}
    true = np.array([r.true_risk for r in ok], float)
    mean = np.array([r.risk_mean for r in ok], float)
    lo = np.array([r.risk_lo for r in ok], float)
    hi = np.array([r.risk_hi for r in ok], float)
    return {
        "n_with_truth": len(ok),
        "mae_posterior_mean": float(np.mean(np.abs(mean - true))),
        "interval_coverage": float(np.mean((lo - 1e-9 <= true) & (true <= hi + 1e-9))),
        **verdicts,
    }
