"""Running independent tasks in worker processes, with Ctrl-C that stops at once.

CasADi solvers are not thread-safe, so parallel work runs in processes. Workers use one
BLAS thread each (two solvers on two cores should not fight over four threads) and ignore
SIGINT: on Ctrl-C the parent terminates them and drops the queue, instead of waiting for
every running task to finish (``ProcessPoolExecutor``'s own shutdown waits).
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

__all__ = ["parallel_map"]

_ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _worker_init(initializer: Callable[..., None] | None = None, initargs: tuple = ()) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    for name in _ONE_THREAD:
        os.environ.setdefault(name, "1")
    if initializer is not None:
        initializer(*initargs)


def parallel_map(
    fn: Callable[..., Any],
    tasks: Sequence[tuple[Any, ...]],
    workers: int,
    on_result: Callable[[int, Any], None] | None = None,
    initializer: Callable[..., None] | None = None,
    initargs: tuple = (),
) -> list[Any]:
    """``[fn(*t) for t in tasks]``, in ``workers`` processes (1: in this process).

    Args:
        fn: a picklable top-level function.
        tasks: its argument tuples.
        workers: processes; ≤ 1 runs in this process.
        on_result: called as each task finishes, with its index and result (in completion
            order; for progress bars and incremental output).
        initializer: called once per worker process with ``initargs`` before its first
            task (e.g. to build solvers once per worker); in this process when workers ≤ 1.
        initargs: its arguments.

    Returns:
        The results in task order.

    Raises:
        Whatever a task raised (the remaining tasks are cancelled), or KeyboardInterrupt.
    """
    results: list[Any] = [None] * len(tasks)
    if workers <= 1 or len(tasks) <= 1:
        if initializer is not None:
            initializer(*initargs)
        for i, args in enumerate(tasks):
            results[i] = fn(*args)
            if on_result is not None:
                on_result(i, results[i])
        return results
    pool = ProcessPoolExecutor(
        max_workers=min(workers, len(tasks)),
        initializer=_worker_init,
        initargs=(initializer, initargs),
    )
    try:
        futures = {pool.submit(fn, *args): i for i, args in enumerate(tasks)}
        for fut in as_completed(futures):
            i = futures[fut]
            results[i] = fut.result()
            if on_result is not None:
                on_result(i, results[i])
    except BaseException:
        # private, but the only handle on the workers: stop running tasks now
        for proc in list(getattr(pool, "_processes", {}).values()):
            proc.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return results
