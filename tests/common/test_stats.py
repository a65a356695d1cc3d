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


def test_auroc_is_the_share_of_pairs_the_score_orders():
    from drivestyle.common.stats import auroc

    assert auroc([3, 4], [1, 2]) == 1.0 and auroc([1, 2], [3, 4]) == 0.0
    assert auroc([1, 3], [2, 2]) == 0.5 and auroc([2], [2]) == 0.5
    assert auroc([1, 2, 3], [0, 2]) == pytest.approx((1 + 1.5 + 2) / 6)
    with pytest.raises(ValueError, match="finite"):
        auroc([1.0, np.nan], [0.0])


def test_the_auroc_interval_holds_its_value_and_narrows_with_more_records():
    from drivestyle.common.stats import auroc, auroc_interval

    rng = np.random.default_rng(3)
    small_pos, small_neg = rng.normal(1, 1, 15), rng.normal(0, 1, 15)
    big_pos, big_neg = rng.normal(1, 1, 400), rng.normal(0, 1, 400)
    lo_s, hi_s = auroc_interval(small_pos, small_neg, 2000, np.random.default_rng(0))
    lo_b, hi_b = auroc_interval(big_pos, big_neg, 2000, np.random.default_rng(0))
    assert lo_s <= auroc(small_pos, small_neg) <= hi_s and lo_b <= auroc(big_pos, big_neg) <= hi_b
    assert hi_b - lo_b < (hi_s - lo_s) / 2
    # Φ(1/√2) = 0.760 for two unit normals one apart
    assert lo_b < 0.760 < hi_b


def test_the_icc_is_the_share_of_variance_between_classes():
    from drivestyle.common.stats import icc_oneway

    rng = np.random.default_rng(1)
    classes = np.repeat(np.arange(40), 3)
    # between-class sd 2, within 1: ICC = 4 / (4 + 1) = 0.8
    values = rng.normal(0, 2, 40)[classes] + rng.normal(0, 1, classes.size)
    icc = icc_oneway(values, classes)
    assert icc is not None and icc.classes == 40 and icc.records == 120
    assert icc.lo < 0.8 < icc.hi and icc.lo < icc.icc < icc.hi
    noise = icc_oneway(rng.normal(0, 1, 120), classes)
    assert noise is not None and noise.lo < 0.0 < noise.hi
    # unequal sizes: a class of one record counts between, not within
    assert icc_oneway([1.0, 2.0, 5.0, 5.5, 9.0], ["a", "a", "b", "b", "c"]).icc > 0.9
    assert icc_oneway([1.0, 2.0, 3.0], ["a", "b", "c"]) is None  # no class with two
    assert icc_oneway([1.0, 1.0, 2.0, 2.0], ["a", "a", "b", "b"]) is None  # no spread within
