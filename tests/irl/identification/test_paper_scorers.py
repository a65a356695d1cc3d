"""The paper model's posterior over a library's risks: its likelihood, interval and pooling."""

import numpy as np
import pytest

from drivestyle.agents import generate_demonstration
from drivestyle.envs.scenario import PAPER
from drivestyle.irl.identification.paper_scorers import posterior_from_scores, risk_interval
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.identification.verdict import S_E_INFORMATIVE

RISKS = [0.5, 0.6, 0.7, 0.8, 0.9, 0.95]


def test_posterior_is_the_normalised_relative_gap_likelihood():
    scores = [2.0, 1.0, 3.0]
    post = posterior_from_scores([scores], [True], temperature=1.0)
    expected = np.exp([-1.0, 0.0, -2.0])
    np.testing.assert_allclose(post, expected / expected.sum())
    # scale-free: the same relative gaps give the same posterior
    np.testing.assert_allclose(
        posterior_from_scores([[20.0, 10.0, 30.0]], [True], temperature=1.0), post
    )


def test_uninformative_demos_leave_the_uniform_prior():
    post = posterior_from_scores([[1.0, 5.0, 9.0]], [False])
    np.testing.assert_allclose(post, [1 / 3] * 3)
    assert risk_interval([0.5, 0.7, 0.9], post) == (0.5, 0.9)


def test_pooling_adds_log_likelihoods_and_sharpens():
    one = [1.0, 1.3, 2.0, 3.0, 4.0, 5.0]
    single = posterior_from_scores([one], [True])
    pooled = posterior_from_scores([one, one, one], [True] * 3)
    np.testing.assert_allclose(pooled, single**3 / np.sum(single**3))
    assert pooled.max() > single.max()
    lo1, hi1 = risk_interval(RISKS, single)
    lo3, hi3 = risk_interval(RISKS, pooled)
    assert hi3 - lo3 <= hi1 - lo1


def test_interval_holds_the_requested_mass():
    post = np.array([0.05, 0.6, 0.3, 0.05])
    assert risk_interval([0.5, 0.6, 0.7, 0.8], post, 0.9) == (0.6, 0.7)
    assert risk_interval([0.5, 0.6, 0.7, 0.8], post, 0.5) == (0.6, 0.6)
    assert risk_interval([0.5, 0.6, 0.7, 0.8], post, 0.99) == (0.5, 0.8)


def test_bad_posterior_input():
    with pytest.raises(ValueError, match="temperature"):
        posterior_from_scores([[1.0]], [True], temperature=0)
    with pytest.raises(ValueError, match="at least one"):
        posterior_from_scores([], [])


def test_a_far_tv_gives_a_wide_interval_and_not_informative(style_library):
    far = PAPER.with_overrides(tv_gap=-150.0, tv_speed=28.0, ev_speed=25.0)
    demo, summary = generate_demonstration(0.7, far)
    assert summary["min_s_e"] >= S_E_INFORMATIVE
    res = identify(demo, style_library)
    assert res.informative is False
    assert res.risk_interval == (0.5, 0.95)
    assert res.posterior_by_risk == {0.5: 0.5, 0.95: 0.5}
    assert res.to_json()["posterior"] == {"0.5": 0.5, "0.95": 0.5}


def test_identify_reports_a_posterior_and_interval(style_library, paper_demo):
    res = identify(paper_demo, style_library)
    assert res.verdict is not None and res.verdict.constraint_binds  # the TV came near
    assert sum(res.posterior) == pytest.approx(1.0)
    lo, hi = res.risk_interval
    assert lo <= res.risk_estimate <= hi
    assert min(style_library.risks) <= res.risk_interpolated <= max(style_library.risks)
