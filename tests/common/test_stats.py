"""The one bootstrap: resampling units, not records."""

import numpy as np
import pytest

from drivestyle.common.stats import bootstrap_rows, percentile_interval


def test_a_replicate_takes_every_record_of_each_drawn_unit():
    units = ["b", "a", "b", "c", "a"]
    rows = bootstrap_rows(units, 200, np.random.default_rng(0))
    assert len(rows) == 200
    for r in rows:
        labels = [units[i] for i in r]
        for u in set(labels):  # a drawn unit brings all its records, as often as drawn
            assert labels.count(u) % units.count(u) == 0
        assert len(labels) >= 3  # three draws of units of 1–2 records


def test_one_record_per_unit_draws_records_as_the_generator_does():
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    rows = bootstrap_rows(range(7), 50, rng_a)
    assert np.array_equal(np.array(rows), rng_b.integers(0, 7, (50, 7)))
    # the generator advanced by exactly that draw
    assert rng_a.integers(0, 100) == rng_b.integers(0, 100)


def test_the_percentile_interval_is_central():
    lo, hi = percentile_interval(np.arange(1001.0))
    assert (lo, hi) == pytest.approx((25.0, 975.0))
    assert percentile_interval(np.arange(101.0), level=0.5) == pytest.approx((25.0, 75.0))
