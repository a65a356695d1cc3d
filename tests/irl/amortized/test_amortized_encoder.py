import numpy as np
import pytest

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.amortized.encoder import (
    EncoderConfig,
    build_encoder,
    encoder_input,
    episode_features,
    input_dim,
)

N = 12
META = {"scenario": ScenarioConfig(lane_width=3.5).to_dict()}  # lateral features in lanes


def _demo(shift_unseen: float = 0.0, shift_seen: float = 0.0, late: float = 0.0) -> Demonstration:
    """EV at 20 m/s from x = 100, a TV ahead, two others; the last unobserved for 5 samples."""
    t = np.arange(N) * 0.1
    ev = np.zeros((N, 4))
    ev[:, 0] = 100 + 20 * t
    ev[:, 3] = 20
    ev[6:, 1] += late  # after the observed part
    tv = ev.copy()
    tv[:, 0] += 30
    tv[:, 1] = 3.5
    tv[:, 3] = 18
    behind = ev + np.array([-20.0, 3.5, 0.0, 1.0])
    ahead = ev + np.array([50.0, 0.0, 0.0, -2.0])
    ahead[:5, 0] += shift_unseen
    ahead[5:, 0] += shift_seen
    observed = np.ones((3, N), bool)
    observed[2, :5] = False
    return Demonstration(
        t, ev, tv, np.zeros((N - 1, 2)), META, others=np.stack([behind, ahead], 1),
        observed=observed, origin="recorded",
    )  # fmt: skip


def test_features_read_the_road_frame_relative_to_the_ev():
    feats, mask = episode_features(_demo(), k=7, m=4)
    assert feats.shape == (8, input_dim(4) - 4) and mask.shape == (8, 4)
    assert feats[0, :6].tolist() == [0.0, 0.0, 0.0, 20.0, 0.0, 0.0]  # x from the first sample
    assert feats[3, 0] == pytest.approx(6.0)
    assert feats[0, 6:9].tolist() == [30.0, 1.0, -2.0]  # the TV first, a lane to the left
    assert feats[0, 9:12].tolist() == [-20.0, 1.0, 1.0]
    assert mask[:, 2].tolist() == [False] * 5 + [True] * 3
    assert np.all(feats[:5, 12:15] == 0) and feats[6, 12] == pytest.approx(50.0)
    assert not mask[:, 3].any() and np.all(feats[:, 15:] == 0)  # padding: no fourth vehicle


def test_lateral_positions_are_read_in_lane_widths():
    wide = _demo()
    wide = Demonstration(wide.t, wide.ev * [1, 1.5, 1, 1], wide.tv * [1, 1.5, 1, 1], wide.u,
                         {"scenario": ScenarioConfig(lane_width=5.25).to_dict()},
                         others=wide.others * [1, 1.5, 1, 1], observed=wide.observed,
                         origin="recorded")  # fmt: skip
    np.testing.assert_allclose(episode_features(wide, 7, 3)[0], episode_features(_demo(), 7, 3)[0])


def test_each_sample_reads_the_input_that_led_into_it_never_the_next():
    demo = _demo()
    inputs = np.column_stack([np.arange(N - 1) * 0.1, np.arange(N - 1) * 0.001])
    demo = Demonstration(demo.t, demo.ev, demo.tv, inputs, META, others=demo.others,
                         observed=demo.observed, origin="recorded")  # fmt: skip
    feats, _ = episode_features(demo, k=5, m=1)
    assert feats[0, 4:6].tolist() == [0.0, 0.0]
    assert np.allclose(feats[1:, 4:6], inputs[:5])  # u_0 … u_4: u_5 needs sample 6
    later = inputs + (np.arange(N - 1) >= 5)[:, None]  # u_5 onwards: not yet known at k = 5
    changed = Demonstration(demo.t, demo.ev, demo.tv, later, META, others=demo.others,
                            observed=demo.observed, origin="recorded")  # fmt: skip
    assert np.array_equal(episode_features(changed, k=5, m=1)[0], feats)


def test_what_is_not_observed_never_reaches_the_features():
    base = episode_features(_demo(), k=7, m=3)
    unseen = episode_features(_demo(shift_unseen=40.0), k=7, m=3)
    later = episode_features(_demo(late=2.0), k=5, m=3)
    assert np.array_equal(base[0], unseen[0]) and np.array_equal(base[1], unseen[1])
    assert np.array_equal(episode_features(_demo(), k=5, m=3)[0], later[0])
    seen = episode_features(_demo(shift_seen=40.0), k=7, m=3)
    assert not np.array_equal(base[0], seen[0])


def test_arguments_are_checked():
    with pytest.raises(ValueError, match="k must lie"):
        episode_features(_demo(), k=N)
    with pytest.raises(ValueError, match="share T"):
        encoder_input(np.zeros((3, 4)), np.zeros((2, 1), bool))
    with pytest.raises(ValueError, match="hidden"):
        EncoderConfig(input_dim=4, hidden=0)


@pytest.fixture(scope="module")
def encoder():
    torch = pytest.importorskip("torch")
    torch.manual_seed(0)
    enc = build_encoder(EncoderConfig(input_dim=input_dim(3), hidden=8, embedding=4)).eval()
    return enc


def _embed(encoder, *series):
    import torch

    from drivestyle.irl.amortized.estimator import _padded

    x, lengths = _padded(list(series))
    with torch.no_grad():
        return encoder(x, lengths).numpy()


def test_any_length_and_padding_is_never_read(encoder):
    short = encoder_input(*episode_features(_demo(), k=3, m=3))
    long = encoder_input(*episode_features(_demo(), k=11, m=3))
    alone = _embed(encoder, short)
    batched = _embed(encoder, short, long)
    assert batched.shape == (2, 4)
    assert np.allclose(alone[0], batched[0], atol=1e-6)
    assert not np.allclose(batched[0], batched[1])


def test_the_mask_changes_the_output_only_where_it_should(encoder):
    base = encoder_input(*episode_features(_demo(), k=7, m=3))
    unseen = encoder_input(*episode_features(_demo(shift_unseen=40.0), k=7, m=3))
    assert np.allclose(_embed(encoder, base), _embed(encoder, unseen))
    flipped = base.copy()
    flipped[2, -1] = 1.0  # the third vehicle said observed at sample 2
    assert not np.allclose(_embed(encoder, base), _embed(encoder, flipped))


def test_a_phantom_far_behind_is_no_vehicle():
    demo = _demo()
    tv = demo.tv.copy()
    tv[:, 0] = demo.ev[:, 0] - 1000.0  # the extraction's phantom TV: "no target vehicle"
    phantom = Demonstration(demo.t, demo.ev, tv, demo.u, META, others=demo.others,
                            observed=demo.observed, origin="recorded")  # fmt: skip
    feats, mask = episode_features(phantom, k=7, m=3)
    assert not mask[:, 0].any() and np.all(feats[:, 6:9] == 0)
    assert mask[:, 1].all()  # the others are read as before
