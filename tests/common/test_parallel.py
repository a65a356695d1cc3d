"""parallel_map: results in task order, errors propagate, an interrupt stops running work."""

import time

import pytest

from drivestyle.common.parallel import parallel_map


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
