"""parallel_map: results in task order, errors propagate, an interrupt stops running work."""

import os
import signal
import time

import pytest

from drivestyle.common.parallel import EXIT_TERMINATED, parallel_map, sigterm_stops_the_job


def _square_after(x: int, delay: float) -> int:
    time.sleep(delay)
    return x * x


def _fail(x: int) -> int:
    raise ValueError(f"task {x} failed")


@pytest.mark.parametrize("workers", [1, 2])
def test_results_come_back_in_task_order(workers):
    seen = []
    out = parallel_map(
        _square_after, [(3, 0.2), (2, 0.0), (1, 0.1)], workers, lambda i, r: seen.append(i)
    )
    assert out == [9, 4, 1]
    assert sorted(seen) == [0, 1, 2]


def test_a_failing_task_raises_its_error():
    with pytest.raises(ValueError, match=r"task \d failed"):
        parallel_map(_fail, [(1,), (2,)], 2)


def test_an_interrupt_does_not_wait_for_running_tasks():
    def interrupt(i, result):
        raise KeyboardInterrupt

    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        parallel_map(_square_after, [(1, 0.0), (2, 30.0), (3, 30.0)], 2, interrupt)
    assert time.perf_counter() - t0 < 10  # the 30 s tasks were terminated, not awaited


# CasADi's SWIG wrappers run Python type checks from C and drop any exception raised there:
# a SIGTERM landing in one was lost and the job ran on to exit 0. A stand-in with a CasADi
# file name that drops every exception, as SWIG does; the signal arrives inside it.
_DROPPING = """
def build(busy):
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(busy):
            pass
    except BaseException:
        return "dropped"
    return "kept"
"""


def test_a_stop_that_lands_where_exceptions_are_dropped_is_raised_after_it(capsys):
    code = compile(_DROPPING, os.path.join(os.sep, "site", "casadi", "casadi.py"), "exec")
    namespace = {"os": os, "signal": signal}
    exec(code, namespace)
    with pytest.raises(SystemExit) as stop, sigterm_stops_the_job():
        assert namespace["build"](10**5) == "kept"  # nothing raised inside it
        time.sleep(5)  # the deferred stop lands here
        pytest.fail("SIGTERM did not stop the job")
    assert stop.value.code == EXIT_TERMINATED
    assert capsys.readouterr().err.count("terminated: stopping the job") == 1
    assert signal.getsignal(signal.SIGALRM) is signal.SIG_DFL
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)


@pytest.fixture
def ctrl_c_raises():
    """Python's own Ctrl-C handler, as in a terminal: a job started in the background by a
    non-interactive shell (nohup, ``&``, some CI runners) inherits SIGINT ignored, and
    Python then installs no handler — there is no Ctrl-C to defer."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def test_a_ctrl_c_that_lands_where_exceptions_are_dropped_is_raised_after_it(ctrl_c_raises):
    code = compile(
        _DROPPING.replace("signal.SIGTERM", "signal.SIGINT"),
        os.path.join(os.sep, "site", "casadi", "casadi.py"),
        "exec",
    )
    namespace = {"os": os, "signal": signal}
    exec(code, namespace)
    with pytest.raises(KeyboardInterrupt), sigterm_stops_the_job():
        assert namespace["build"](10**5) == "kept"  # nothing raised inside it
        time.sleep(5)  # the deferred Ctrl-C lands here
        pytest.fail("Ctrl-C did not stop the job")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.getitimer(signal.ITIMER_REAL) == (0.0, 0.0)
