"""The amortized posterior online: one GRU step per sample, the offline answer on demand."""

import numpy as np
import pytest

from drivestyle.irl.amortized.encoder import EncoderConfig, build_encoder
from drivestyle.irl.amortized.identify import identify_amortized, observed_series
from drivestyle.irl.amortized.tracker import AmortizedTracker, track_amortized
from drivestyle.irl.identification.online import TrackerError
from drivestyle.recorded.observed import observed_mask

torch = pytest.importorskip("torch")
pytest.importorskip("zuko")


@pytest.mark.parametrize("layers", [1, 2])
def test_the_encoder_step_by_step_is_its_forward_on_every_prefix(layers):
    torch.manual_seed(0)
    encoder = build_encoder(EncoderConfig(5, hidden=12, embedding=6, layers=layers)).eval()
    encoder.set_scaling(np.arange(5.0), np.linspace(0.5, 2.0, 5))
    x = torch.randn(1, 30, 5) * 3
    state = encoder.start(1)
    with torch.no_grad():
        for t in range(30):
            summary, state = encoder.step(x[:, t], state)
            whole = encoder(x[:, : t + 1], torch.tensor([t + 1]))
            assert torch.allclose(summary, whole, atol=1e-5, rtol=0), t


def _feed(tracker, demo, k):
    seen = observed_mask(demo)
    for j in range(k + 1):
        tracker.update(demo.ev[j], demo.vehicles[j], demo.u[j - 1] if j else None, seen[:, j])


def test_the_tracker_is_the_offline_identification_of_the_samples_so_far(
    tiny_posterior, paper_demo, as_recorded
):
    posterior, _ = tiny_posterior
    encoder = posterior.network["encoder"]
    for demo in (paper_demo, as_recorded(paper_demo)):
        tracker = AmortizedTracker(posterior, demo.scenario, draws=64, seed=2, origin=demo.origin)
        seen = observed_mask(demo)
        for k in range(demo.n):
            tracker.update(demo.ev[k], demo.vehicles[k], demo.u[k - 1] if k else None, seen[:, k])
            x = torch.as_tensor(observed_series(demo, k)[None], dtype=torch.float32)
            with torch.no_grad():
                offline = encoder(x, torch.tensor([k + 1]))[0].double().numpy()
            np.testing.assert_allclose(tracker.embedding, offline, atol=1e-5, rtol=0)
        online = tracker.summary()
        offline_style = identify_amortized(posterior, demo, samples=64, seed=2)
        assert online.samples_observed == offline_style.samples_observed == demo.n
        np.testing.assert_allclose(online.draws, offline_style.draws, rtol=1e-4, atol=1e-6)


def test_inputs_recovered_or_given_and_every_summary_on_demand(tiny_posterior, paper_demo):
    posterior, _ = tiny_posterior
    given = track_amortized(posterior, paper_demo, draws=8)
    recovered = track_amortized(posterior, paper_demo, draws=8, use_inputs=False)
    assert len(given) == paper_demo.n and [s.samples_observed for s in given][:3] == [1, 2, 3]
    assert given[-1].draws.shape == (8, len(posterior.config.names))
    # the features read states only: the inputs do not move the posterior (yet)
    np.testing.assert_allclose(given[-1].mean, recovered[-1].mean, atol=1e-9)


def test_a_refused_sample_leaves_the_tracker_as_it_was(tiny_posterior, paper_demo):
    posterior, _ = tiny_posterior
    tracker = AmortizedTracker(posterior, paper_demo.scenario, draws=16)
    with pytest.raises(TrackerError, match="no sample yet"):
        tracker.summary()
    _feed(tracker, paper_demo, 5)
    before, embedding = tracker.summary(), tracker.embedding
    jump = paper_demo.ev[6] + np.array([80.0, 0.0, 0.0, 0.0])
    with pytest.raises(TrackerError, match="sample 6 refused"):
        tracker.update(jump, paper_demo.vehicles[6])
    with pytest.raises(TrackerError, match="surrounding vehicles"):
        tracker.update(paper_demo.ev[6], np.repeat(paper_demo.vehicles[6], 2, axis=0))
    with pytest.raises(TrackerError, match="observed must have shape"):
        tracker.update(paper_demo.ev[6], paper_demo.vehicles[6], observed=[True, False, True])
    assert tracker.n_samples == 6 and np.array_equal(tracker.embedding, embedding)
    assert np.array_equal(tracker.summary().draws, before.draws)
    tracker.update(paper_demo.ev[6], paper_demo.vehicles[6])
    assert tracker.n_samples == 7
    tracker.reset()
    assert tracker.n_samples == 0 and tracker.embedding is None
