"""The capacity study's Nelder–Mead (studies/capacity/nelder_mead.py): minimum, budget, input."""

import math

import numpy as np
import pytest

from drivestyle.studies.capacity.nelder_mead import nelder_mead


def test_nelder_mead_finds_an_ill_conditioned_quadratics_minimum():
    target = np.array([1.0, -2.0, 3.0])

    def f(x):
        return float(np.sum(np.array([1.0, 10.0, 100.0]) * (x - target) ** 2))

    result = nelder_mead(f, np.zeros(3), 1.0, 500)
    np.testing.assert_allclose(result.x, target, atol=1e-3)
    assert result.fun < 1e-6
    assert result.evaluations <= 500
    assert list(result.history) == sorted(result.history, reverse=True)  # best so far


def test_nelder_mead_stops_at_its_budget_and_keeps_the_best_point():
    calls = []

    def f(x):
        calls.append(x.copy())
        return float((x[0] - 5.0) ** 2 + x[1] ** 2)

    result = nelder_mead(f, [0.0, 0.0], 1.0, 7)
    assert len(calls) == result.evaluations == 7
    assert result.fun == min(f(x) for x in calls[:7])
    assert result.fun < 25.0  # moved towards the minimum from f(x0) = 25


def test_nelder_mead_counts_non_finite_values_as_worst():
    result = nelder_mead(lambda x: math.nan if x[0] < 0 else (x[0] - 1) ** 2, [0.5], 0.6, 80)
    assert abs(result.x[0] - 1.0) < 1e-3


@pytest.mark.parametrize(
    "kwargs", [{"budget": 0}, {"step": 0.0}, {"x0": [math.inf]}], ids=["budget", "step", "x0"]
)
def test_nelder_mead_refuses_bad_input(kwargs):
    args = {"x0": [0.0], "step": 1.0, "budget": 5, **kwargs}
    with pytest.raises(ValueError):
        nelder_mead(lambda x: 0.0, **args)
