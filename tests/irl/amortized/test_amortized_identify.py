"""One episode identified by the amortized posterior: what it reads, what it returns."""

import json
from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.amortized.identify import (
    LEVEL,
    AmortizedStyle,
    identify_amortized,
    identify_amortized_batch,
    observed_series,
    open_posterior,
)
from drivestyle.irl.amortized.simulations import PARAMETERS, episode_series

pytest.importorskip("zuko")


def test_the_result_holds_every_parameter_in_order_with_its_interval(tiny_posterior, paper_demo):
    posterior, path = tiny_posterior
    style = identify_amortized(posterior, paper_demo, k=9, samples=300, seed=1)
    assert isinstance(style, AmortizedStyle)
    assert style.names == PARAMETERS and style.names[0] == "risk"
    assert style.draws.shape == (300, len(PARAMETERS)) and style.samples_observed == 10
    assert np.all(style.lo <= style.median) and np.all(style.median <= style.hi)
    low, high = np.array(posterior.config.low), np.array(posterior.config.high)
    assert np.all(style.draws >= low) and np.all(style.draws <= high)
    np.testing.assert_allclose(style.mean, style.draws.mean(axis=0))
    np.testing.assert_allclose(style.lo, np.percentile(style.draws, 5, axis=0))
    np.testing.assert_allclose(style.hi, np.percentile(style.draws, 95, axis=0))
    meta = json.loads(str(np.load(path)["meta"][()]))
    assert style.estimator_sha256 == meta["weights_sha256"]
    doc = style.to_json()
    assert list(doc["parameters"]) == list(PARAMETERS) and doc["level"] == LEVEL
    assert doc["parameters"]["risk"]["q05"] == pytest.approx(style.lo[0])
    assert "posterior_draws" not in doc and len(style.to_json(draws=True)["posterior_draws"]) == 300
    assert style.describe().startswith(f"risk {style.mean[0]:.3g} [")
    assert style.index("time_gap") == 2
    with pytest.raises(KeyError, match="no parameter 'p'"):
        style.index("p")


def test_nothing_after_k_is_read(tiny_posterior, paper_demo, change_the_future, as_recorded):
    posterior, _ = tiny_posterior
    for demo in (paper_demo, as_recorded(paper_demo)):
        k = 12
        moved = change_the_future(demo, k)
        a = identify_amortized(posterior, demo, k=k, seed=3)
        b = identify_amortized(posterior, moved, k=k, seed=3)
        assert np.array_equal(a.draws, b.draws) and a.samples_observed == k + 1
        whole = identify_amortized(posterior, moved, seed=3)  # the altered future is read
        assert whole.samples_observed == demo.n and not np.array_equal(whole.draws, a.draws)


def test_the_series_is_the_identification_view_of_the_observed_samples(paper_demo, as_recorded):
    for demo in (paper_demo, as_recorded(paper_demo)):
        assert np.array_equal(observed_series(demo, 7), episode_series(demo, 7))
        assert observed_series(demo).shape[0] == demo.n
    with pytest.raises(ValueError, match="k must lie"):
        observed_series(paper_demo, paper_demo.n)


def test_the_batch_is_one_sampling_call_per_chunk(tiny_posterior, paper_demo):
    posterior, _ = tiny_posterior
    demos = [paper_demo, replace(paper_demo), paper_demo]
    ks = [5, None, 20]
    one_call = identify_amortized_batch(posterior, demos, ks, samples=50, seed=4)
    assert [s.samples_observed for s in one_call] == [6, paper_demo.n, 21]
    series = [observed_series(d, k) for d, k in zip(demos, ks, strict=True)]
    draws = posterior.sample_batch(series, 50, seed=4)
    assert all(np.array_equal(s.draws, d) for s, d in zip(one_call, draws, strict=True))
    # chunk j is seeded seed + j; a chunk of one is identify_amortized
    chunked = identify_amortized_batch(posterior, demos, ks, samples=50, seed=4, batch=1)
    for j, s in enumerate(chunked):
        alone = identify_amortized(posterior, demos[j], ks[j], 50, 4 + j)
        assert np.array_equal(s.draws, alone.draws)
    with pytest.raises(ValueError, match="observed samples"):
        identify_amortized_batch(posterior, demos, [1, 2])


def test_a_bad_estimator_file_is_one_line_naming_the_option(tiny_posterior, tmp_path, monkeypatch):
    _, path = tiny_posterior
    missing = r"^--posterior .*nope\.npz: no such estimator file$"
    with pytest.raises(FileNotFoundError, match=missing):
        open_posterior(tmp_path / "nope.npz")
    bad = tmp_path / "bad.npz"
    bad.write_bytes(path.read_bytes()[:-200])
    with pytest.raises(ValueError, match=r"^--posterior .*bad\.npz: not a readable estimator file"):
        open_posterior(bad)
    import drivestyle.irl.amortized.identify as identify

    def no_torch(_path):
        raise ImportError("No module named 'torch'")

    monkeypatch.setattr(identify, "load_posterior", no_torch)
    needs = r"^--posterior .*: the amortized posterior needs the sbi"
    with pytest.raises(RuntimeError, match=needs):
        open_posterior(path)
