"""The posterior-predictive check: its p-value, its replicates, its verdict, its batch."""

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.amortized.behaviour import STATISTICS, behaviour
from drivestyle.irl.amortized.predictive_check import (
    INSIDE,
    min_draws,
    predictive_check,
    predictive_checks,
    predictive_p_value,
)
from drivestyle.irl.amortized.replicates import replicate_seed
from drivestyle.irl.amortized.simulations import PARAMETERS, parameters_of
from drivestyle.irl.driver.stochastic_prior import StochasticPrior, simulate_params

SHORT = StochasticPrior(horizon_s=4.0)  # 21 samples: a replicate in ≈ 0.05 s
ALPHA = 0.5  # resolved by K = 19 draws: a check of the default tests in ≈ 1 s
K = min_draws(ALPHA)


@pytest.fixture(scope="module")
def episode():
    params = SHORT.draw(1, 3)[0]
    return params, simulate_params(params, 3)


def test_the_p_value_is_mid_rank_and_two_sided():
    rep = np.arange(1.0, 20.0)  # K = 19
    assert predictive_p_value(0.0, rep) == pytest.approx(2 / 20)  # below every replicate
    assert predictive_p_value(25.0, rep) == pytest.approx(2 / 20)  # above every one
    assert predictive_p_value(10.0, rep) == 1.0  # the median
    assert predictive_p_value(3.5, rep) == pytest.approx(2 * (1 + 3) / 20)  # 3 below
    # within 0.6 of 3 and 4: 2 below, 3 tied (a count of 3.5), as rare as 1, 2, 3, 16 … 19
    assert predictive_p_value(3.5, rep, resolution=0.6) == pytest.approx(8 / 20)
    assert predictive_p_value(5.0, np.full(19, 5.0)) == 1.0  # all tied: no evidence


def test_an_undefined_statistic_is_a_tail_of_its_own():
    none = np.full(19, math.nan)
    some = np.r_[np.full(17, math.nan), 1.0, 2.0]  # 2 of 19 replicates changed lane
    assert predictive_p_value(math.nan, none) == 1.0
    assert predictive_p_value(1.5, none) == pytest.approx(1 / 20)  # none did, this one did
    assert predictive_p_value(1.5, some) == pytest.approx(3 / 20)
    # it did not where all did: as rare as the two extreme replicates
    assert predictive_p_value(math.nan, np.arange(19.0)) == pytest.approx(3 / 20)


def test_the_p_value_is_valid_whatever_the_share_undefined(rng):
    k, n = 19, 10000
    for undefined in (0.0, 0.3, 0.9):
        values = rng.standard_normal((n, k + 1))
        values[rng.random((n, k + 1)) < undefined] = math.nan
        p = np.array([predictive_p_value(v[0], v[1:]) for v in values])
        for a in (0.05, 0.1, 0.2, 0.5):
            assert np.mean(p <= a) <= a + 3 * math.sqrt(a * (1 - a) / n)


def test_the_fewest_draws_are_those_whose_smallest_p_value_reaches_the_threshold():
    assert min_draws(0.05) == 199 and min_draws(0.1) == 99 and min_draws(ALPHA) == K == 19
    for alpha in (0.05, 0.1, 0.2, 0.5):
        k = min_draws(alpha)
        assert 2 / (k + 1) <= alpha / len(STATISTICS) + 1e-12 < 2 / k


def test_malformed_or_too_few_draws_are_refused(episode):
    _, demo = episode
    with pytest.raises(ValueError, match="at least 199"):
        predictive_check(np.zeros((50, len(PARAMETERS))), demo, seed=0)
    with pytest.raises(ValueError, match="shape"):
        predictive_check(np.zeros((K, 3)), demo, seed=0, alpha=ALPHA)
    with pytest.raises(ValueError, match="seed"):
        predictive_check(np.zeros((K, len(PARAMETERS))), demo, seed=-1, alpha=ALPHA)


def test_a_check_compares_the_episode_with_its_replicates_deterministically(episode):
    params, demo = episode
    draws = np.tile(parameters_of(params), (K, 1))
    check = predictive_check(draws, demo, seed=4, alpha=ALPHA)
    assert [s.name for s in check.statistics] == list(STATISTICS)
    assert check.k == K and check.seed == 4 and check.replicated.shape == (K, len(STATISTICS))
    np.testing.assert_array_equal(check.observed.values(), behaviour(demo).values())
    assert check.threshold == ALPHA / len(STATISTICS)
    assert check.inside == (not check.failing) and (check.verdict == INSIDE) == check.inside
    for s in check.statistics:
        assert 0 < s.p_value <= 1 and 0 <= s.defined <= 1 and s.fails == (s.p_value <= 0.1)
    json.dumps(check.to_json(), allow_nan=False)
    again = predictive_check(draws, demo, seed=4, alpha=ALPHA)
    np.testing.assert_array_equal(again.replicated, check.replicated)
    other = predictive_check(draws, demo, seed=5, alpha=ALPHA)
    assert not np.array_equal(other.replicated, check.replicated, equal_nan=True)
    assert replicate_seed(4, 0) != replicate_seed(5, 0) != replicate_seed(4, 1)


def test_an_episode_nothing_like_its_replicates_is_outside_and_says_in_what(episode):
    params, demo = episode
    draws = np.tile(parameters_of(params), (K, 1))
    ev = demo.ev.copy()
    ev[:, 3] = np.linspace(ev[0, 3], ev[0, 3] + 15.0, demo.n)  # 15 m/s faster in 4 s
    check = predictive_check(draws, replace(demo, ev=ev), seed=0, alpha=ALPHA)
    assert not check.inside and "speed_change" in check.failing
    assert check.verdict.startswith("outside the class with these parameters in:")
    assert "speed change (p = " in check.verdict


def test_the_batch_checks_episode_i_with_seed_plus_i(episode):
    params, demo = episode
    draws = np.tile(parameters_of(params), (K, 1))
    seen = []
    checks = predictive_checks([demo, demo], [draws, draws], seed=2, alpha=ALPHA,
                               on_result=lambda i, c: seen.append(i))  # fmt: skip
    assert sorted(seen) == [0, 1] and [c.seed for c in checks] == [2, 3]
    alone = predictive_check(draws, demo, seed=3, alpha=ALPHA)
    np.testing.assert_array_equal(checks[1].replicated, alone.replicated)
    with pytest.raises(ValueError, match="2 episodes but 1"):
        predictive_checks([demo, demo], [draws], seed=0, alpha=ALPHA)


# ---------------------------------------------------------------------------- measured (slow)
def _checks_of_true_drivers(n, seed, alpha, make=lambda demos, i: demos[i]):
    """Checks of n prior episodes (or counterfeits of them) with their true θ as the draws."""
    params = StochasticPrior().draw(n, seed)
    demos = [simulate_params(p, seed + i) for i, p in enumerate(params)]
    draws = [np.tile(parameters_of(p), (min_draws(alpha), 1)) for p in params]
    made = [make(demos, i) for i in range(n)]
    return predictive_checks(made, draws, seed=seed, alpha=alpha, workers=2)


@pytest.mark.slow  # 40 checks of 49 replicates: ≈ 2 min on two cores
def test_with_its_true_parameters_a_driver_is_called_outside_at_most_at_the_nominal_rate():
    n, alpha = 40, 0.2
    checks = _checks_of_true_drivers(n, 21, alpha)
    outside = sum(not c.inside for c in checks)
    print(f"\nfalse outside: {outside}/{n} at alpha = {alpha} (K = {checks[0].k})")
    assert outside / n <= alpha + 2 * math.sqrt(alpha * (1 - alpha) / n)
