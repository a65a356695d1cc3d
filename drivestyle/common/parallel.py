"""Running independent tasks in worker processes that never outlive their parent.

CasADi solvers are not thread-safe, so parallel work runs in processes. Workers use one
BLAS thread each (two solvers on two cores should not fight over four threads) and:

- ignore SIGINT: on Ctrl-C the parent terminates them and drops the queue, instead of
  waiting for every running task to finish (``ProcessPoolExecutor``'s own shutdown waits);
- die with their parent, whatever ends it: on Linux each worker asks the kernel for SIGKILL
  when its parent dies (``prctl(PR_SET_PDEATHSIG)``), so ``kill -9`` of a job leaves no
  orphan workers behind (they would hold the job's files and locks forever); while
  :func:`parallel_map` runs in the main thread, SIGTERM stops the job as Ctrl-C does
  (workers terminated, cleanup run) and exits with status 143 (128 + SIGTERM).

A worker that dies while running a task (a segfault, ``os._exit``, the OOM killer, a
``kill``) breaks a ``ProcessPoolExecutor`` and every task in flight with it. Here the tasks
that had started are run again, each alone in a fresh process: the one that kills its
process again is reported (``on_crash``, or :class:`WorkerCrashError`), the others finish, and
the rest of the queue goes on in a new pool. A task thus runs at most twice.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

__all__ = [
    "EXIT_TERMINATED",
    "SigtermState",
    "WorkerCrashError",
    "parallel_map",
    "sigterm_stops_the_job",
]

_ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
EXIT_TERMINATED = 128 + signal.SIGTERM
"""Exit status of a job stopped by SIGTERM while :func:`parallel_map` ran (the shell's)."""

_STARTED: Any = None
"""In a worker: the shared flags of the tasks that started (set by :func:`_worker_init`)."""


class WorkerCrashError(RuntimeError):
    """A worker process died while running a task (the task raised nothing: it was killed)."""


def _die_with_parent(parent: int | None) -> None:
    """Ask the kernel to SIGKILL this process when its parent dies (Linux; else nothing).

    Args:
        parent: the pid the parent had; if this process's parent is already another one
            (it died before the request took effect), die now.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # no prctl: the SIGTERM path still stops workers
        return
    # the parent may have died between fork and prctl: the request then never fires
    if parent is not None and os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGKILL)


def _worker_init(
    parent: int | None,
    started: Any,
    initializer: Callable[..., None] | None = None,
    initargs: tuple = (),
) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # the parent's handler is the parent's
    _die_with_parent(parent)
    global _STARTED
    _STARTED = started
    for name in _ONE_THREAD:
        os.environ.setdefault(name, "1")
    if initializer is not None:
        initializer(*initargs)


def _run_task(fn: Callable[..., Any], index: int, args: tuple[Any, ...]) -> Any:
    """In a worker: mark task ``index`` as started (a crash then names it), run it."""
    _STARTED[index] = 1
    return fn(*args)


@dataclass
class SigtermState:
    """What :func:`sigterm_stops_the_job` saw."""

    received: bool = False
    """Whether SIGTERM arrived (a library that turns our SystemExit into its own, as Ray's
    blocking calls do, can be corrected with it)."""


@contextmanager
def sigterm_stops_the_job(replace: bool = False) -> Iterator[SigtermState]:
    """While active, SIGTERM raises ``SystemExit(143)`` here (cleanup runs, as on Ctrl-C).

    Only in the main thread (Python runs handlers there). SIGTERM and Ctrl-C's
    ``KeyboardInterrupt`` are raised outside the code whose exceptions C discards
    (:data:`_DROPPING_PACKAGES`): one that lands there is raised again :data:`_RETRY_S`
    later, so a stop is never lost (it was: the job ran on to exit 0).

    Args:
        replace: also replace a handler installed by someone else (Ray's driver installs
            one that exits with status 1); by default only the default action is replaced.

    Yields:
        Whether SIGTERM arrived.
    """
    state = SigtermState()
    if threading.current_thread() is not threading.main_thread() or (
        not replace and signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield state
        return
    owner = os.getpid()

    def on_sigterm(signum: int, frame: Any) -> None:
        if os.getpid() != owner:  # a worker forked before its initializer reset this
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        if not state.received:
            state.received = True
            print("terminated: stopping the job", file=sys.stderr, flush=True)
        _raise_where_kept(signum, frame, SystemExit(EXIT_TERMINATED))

    def on_sigint(signum: int, frame: Any) -> None:
        if os.getpid() != owner:  # as Python's own handler does, before the initializer's
            raise KeyboardInterrupt
        _raise_where_kept(signum, frame, KeyboardInterrupt())

    previous = {signal.SIGTERM: signal.signal(signal.SIGTERM, on_sigterm)}
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        previous[signal.SIGINT] = signal.signal(signal.SIGINT, on_sigint)
    if signal.getsignal(signal.SIGALRM) is signal.SIG_DFL:  # an outer block's serves too
        previous[signal.SIGALRM] = signal.signal(signal.SIGALRM, _on_retry)
    try:
        yield state
    finally:
        if signal.SIGALRM in previous:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            _PENDING.clear()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


_RETRY_S = 0.02
"""Delay [s] before a stop deferred out of a frame that drops exceptions is raised again."""

_DROPPING_PACKAGES = (f"{os.sep}casadi{os.sep}",)
"""Packages whose Python code C calls and whose exceptions C discards: CasADi's SWIG
wrappers call type checks such as ``DM_from_csc`` while choosing an overload and take any
exception there for "not this type" — a SystemExit or KeyboardInterrupt raised in them is
lost and the job runs on to its end (seen: SIGTERM while an expert was being built, and
Ctrl-C of mine-styles in 2 of 9 runs, each exit 0)."""

_PENDING: list[int] = []
"""The signal whose stop was deferred out of such code (at most one), for :func:`_on_retry`."""


def _drops_exceptions(frame: Any) -> bool:
    """Whether an exception raised in ``frame`` (a signal handler's) may be discarded."""
    return frame is not None and any(p in frame.f_code.co_filename for p in _DROPPING_PACKAGES)


def _raise_where_kept(signum: int, frame: Any, stop: BaseException) -> None:
    """Raise ``stop`` now, or, in code that drops exceptions, once that code has returned.

    The timer is touched only while SIGALRM is :func:`_on_retry`'s: another holder's alarm
    (a caller's timeout) is neither fired early nor cancelled; there the stop is raised at
    once, as before the deferral.
    """
    ours = signal.getsignal(signal.SIGALRM) is _on_retry
    if ours and _drops_exceptions(frame):
        _PENDING[:] = [signum]
        signal.setitimer(signal.ITIMER_REAL, _RETRY_S)
        return
    if ours:
        _PENDING.clear()
        signal.setitimer(signal.ITIMER_REAL, 0.0)
    raise stop


def _on_retry(signum: int, frame: Any) -> None:
    """SIGALRM: hand a deferred stop to the handler now installed for its signal."""
    if _PENDING:
        pending = _PENDING[0]
        handler = signal.getsignal(pending)
        if callable(handler):
            handler(pending, frame)


def _how_it_died(exitcode: int | None) -> str:
    if exitcode is None:
        return "the worker process died"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"the worker process was killed by {name}"
    return f"the worker process exited with status {exitcode} while running it"


def _stop(pool: ProcessPoolExecutor) -> None:
    """Terminate the pool's workers now and drop its queue."""
    # private, but the only handle on the workers: stop running tasks now
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


class _Pool:
    """One ``parallel_map`` call's state: results, started flags, the pools' settings."""

    def __init__(
        self,
        fn: Callable[..., Any],
        tasks: Sequence[tuple[Any, ...]],
        on_result: Callable[[int, Any], None] | None,
        initializer: Callable[..., None] | None,
        initargs: tuple,
    ) -> None:
        self.fn = fn
        self.tasks = tasks
        self.on_result = on_result
        self.results: list[Any] = [None] * len(tasks)
        self.done = [False] * len(tasks)
        self.context = multiprocessing.get_context()
        self.started = self.context.Array("b", len(tasks), lock=False)
        # a forkserver's workers are its children, not ours: their parent check is moot
        forked = self.context.get_start_method() in ("fork", "spawn")
        self.initargs = (os.getpid() if forked else None, self.started, initializer, initargs)

    def finish(self, index: int, result: Any) -> None:
        self.results[index] = result
        self.done[index] = True
        if self.on_result is not None:
            self.on_result(index, result)

    def executor(self, workers: int) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=workers,
            mp_context=self.context,
            initializer=_worker_init,
            initargs=self.initargs,
        )

    def run(self, indices: list[int], workers: int) -> list[int]:
        """Run ``indices`` in one pool; the tasks in flight when a worker died (else [])."""
        pool = self.executor(min(workers, len(indices)))
        try:
            futures = {pool.submit(_run_task, self.fn, i, self.tasks[i]): i for i in indices}
            for fut in as_completed(futures):
                self.finish(futures[fut], fut.result())
        except BrokenProcessPool as exc:
            pool.shutdown(wait=True, cancel_futures=True)
            suspects = [i for i in indices if not self.done[i] and self.started[i]]
            if not suspects:
                raise WorkerCrashError(
                    f"a worker process died before running a task ({exc})"
                ) from None
            return suspects
        except BaseException:
            _stop(pool)
            raise
        pool.shutdown()
        return []

    def isolate(self, suspects: list[int]) -> dict[int, str]:
        """Run each suspect alone in a process of its own; {index: cause} of those that died."""
        pools: dict[Future[Any], tuple[int, ProcessPoolExecutor]] = {}
        crashed: dict[int, str] = {}
        try:
            for i in suspects:
                self.started[i] = 0
                pool = self.executor(1)
                pools[pool.submit(_run_task, self.fn, i, self.tasks[i])] = (i, pool)
            for fut in as_completed(pools):
                i, pool = pools[fut]
                procs = list((getattr(pool, "_processes", None) or {}).values())
                try:
                    result = fut.result()
                except BrokenProcessPool:
                    pool.shutdown(wait=True)
                    for proc in procs:
                        proc.join(timeout=5)
                    crashed[i] = _how_it_died(procs[0].exitcode if procs else None)
                    continue
                pool.shutdown()
                self.finish(i, result)
        except BaseException:
            for _, pool in pools.values():
                _stop(pool)
            raise
        return crashed


def parallel_map(
    fn: Callable[..., Any],
    tasks: Sequence[tuple[Any, ...]],
    workers: int,
    on_result: Callable[[int, Any], None] | None = None,
    initializer: Callable[..., None] | None = None,
    initargs: tuple = (),
    on_crash: Callable[[int, str], Any] | None = None,
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
        on_crash: called with a task's index and the cause (one line) when the task killed
            its worker process twice (module docstring); its return value is the task's
            result (and goes to ``on_result``). None: :class:`WorkerCrashError` is raised.

    Returns:
        The results in task order.

    Raises:
        Whatever a task raised (the remaining tasks are cancelled), KeyboardInterrupt,
        ``SystemExit(143)`` on SIGTERM, or WorkerCrashError (a task killed its worker and
        ``on_crash`` is None, or a worker died before running any task).
    """
    if workers <= 1 or len(tasks) <= 1:
        results: list[Any] = [None] * len(tasks)
        if initializer is not None:
            initializer(*initargs)
        for i, args in enumerate(tasks):
            results[i] = fn(*args)
            if on_result is not None:
                on_result(i, results[i])
        return results
    state = _Pool(fn, tasks, on_result, initializer, initargs)
    with sigterm_stops_the_job():
        todo = list(range(len(tasks)))
        while todo:
            suspects = state.run(todo, workers)
            for i, cause in state.isolate(suspects).items():
                if on_crash is None:
                    raise WorkerCrashError(f"task {i}: {cause}")
                state.finish(i, on_crash(i, cause))
            todo = [i for i in todo if not state.done[i]]
    return state.results
