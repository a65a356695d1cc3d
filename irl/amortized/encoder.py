"""The trajectory encoder: an observed episode of any length as one fixed-size vector (DESIGN §22).

Two parts, kept apart so that the data side needs no torch:

- :func:`episode_features`, a pure numpy function: the samples 0 … k of a demonstration
  as the encoder reads them, per sample the EV's [x − x_0, y / w, φ, v] (x from the EV's
  first sample: the road frame's origin along travel is arbitrary; y is the road frame's,
  whose lanes matter, in lane widths w: a lane is a lane on a 3.6 m freeway and on the
  paper's 5.25 m road), the input [a, δ] that led into the sample (u_{j−1}, zero at the first:
  u_j itself is known only at sample j + 1, so reading it would leak the next sample) —
  the deviation's scale and correlation time are properties of the input series, which a
  network reading states must otherwise learn to difference twice — and, for each of up
  to ``m`` surrounding vehicles (the TV first, then ``others``), its position and speed
  relative to the EV [x_j − x, (y_j − y) / w, v_j − v] —
  zero where the vehicle is not observed (:func:`~drivestyle.recorded.observed.observed_mask`:
  a recorded episode's constant-velocity continuation, or a vehicle missing from a
  demonstration with fewer than ``m``, or farther than :data:`SIGHT_M` — the extraction's
  phantom TV), so that nothing the observer has not seen reaches the network.
  :func:`encoder_input` appends the mask as channels of its own: a zero offset and an
  unobserved vehicle are told apart.
- :func:`build_encoder`, the torch module: per-sample inputs standardised (mean and
  scale of the training inputs, carried in the module's state), a GRU over the packed
  sequences (every length in one batch, no padding read), and a linear map of its last
  hidden state beside the mean of its outputs over the sequence's samples to the
  embedding the flow is conditioned on. The mean is there because a statistic of the
  whole series (a variance, a correlation over one step) is an average of per-sample
  terms, which the last state alone forgets; on the AR(1) toy of the tests it has not yet
  been shown to help the correlation time (DESIGN §22).

Torch is imported inside :func:`build_encoder` only: importing this module does not need it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.recorded.observed import observed_mask

if TYPE_CHECKING:
    import torch

__all__ = [
    "EV_FEATURES",
    "NEIGHBOUR_FEATURES",
    "SIGHT_M",
    "EncoderConfig",
    "build_encoder",
    "encoder_input",
    "episode_features",
    "input_dim",
]

EV_FEATURES = 6
"""Per-sample EV features: [x − x_0, y / w, φ, v, a, δ] [m, lanes, rad, m/s, m/s², rad]
(the input that led into the sample)."""
NEIGHBOUR_FEATURES = 3
"""Per-sample features of one surrounding vehicle: [x_j − x, (y_j − y) / w, v_j − v]
[m, lanes, m/s]."""
SIGHT_M = 500.0
"""A surrounding vehicle farther than this along the road [m] is out of sight: masked as
not observed. The extraction stands for "no vehicle" by a phantom TV 1 km behind
(:data:`~drivestyle.recorded.episodes.PHANTOM_GAP_M`), recorded as a vehicle for the
planner (far away, it constrains nothing); read as an offset of −1000 m it would be an
input no simulation shows (the prior's scenes stay within ≈ 450 m)."""


def input_dim(m: int) -> int:
    """Per-sample input width of :func:`encoder_input` for ``m`` surrounding vehicles."""
    if m < 0:
        raise ValueError(f"m must be >= 0, got {m}")
    return EV_FEATURES + (NEIGHBOUR_FEATURES + 1) * m


def episode_features(demo: Demonstration, k: int, m: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """The samples 0 … k of a demonstration as the encoder reads them (module docstring).

    Args:
        demo: a simulated or recorded demonstration.
        k: last observed sample, 0 <= k < demo.n.
        m: number of surrounding vehicles read (the TV first, then ``others`` in order);
            vehicles beyond ``demo``'s are padding, never observed.

    Returns:
        (features, mask): features shape (k + 1, 6 + 3 m) — the EV's [x − x_0, y / w, φ, v]
        (w the scenario's lane width),
        the input [a, δ] of the step into each sample (zero at sample 0), then per vehicle
        [Δx, Δy / w, Δv], zero where it is not observed; mask shape (k + 1, m) bool, whether each
        vehicle's state at each sample is observed.

    Raises:
        ValueError: ``k`` outside the demonstration or ``m`` negative.
    """
    if not 0 <= k < demo.n:
        raise ValueError(f"k must lie in [0, {demo.n - 1}], got {k}")
    if m < 0:
        raise ValueError(f"m must be >= 0, got {m}")
    ev = demo.ev[: k + 1]
    own = np.zeros((k + 1, EV_FEATURES))
    own[:, :4] = ev
    own[:, 0] -= ev[0, 0]
    width = float(demo.scenario.lane_width)
    own[:, 1] /= width
    own[1:, 4:] = demo.u[:k]
    vehicles = demo.vehicles[: k + 1]  # (k + 1, 1 + m_demo, 4)
    seen = observed_mask(demo)[:, : k + 1].T  # (k + 1, 1 + m_demo)
    m_read = min(m, vehicles.shape[1])
    rel = np.zeros((k + 1, m, NEIGHBOUR_FEATURES))
    mask = np.zeros((k + 1, m), bool)
    rel[:, :m_read, 0] = vehicles[:, :m_read, 0] - ev[:, None, 0]
    rel[:, :m_read, 1] = (vehicles[:, :m_read, 1] - ev[:, None, 1]) / width
    rel[:, :m_read, 2] = vehicles[:, :m_read, 3] - ev[:, None, 3]
    mask[:, :m_read] = seen[:, :m_read] & (np.abs(rel[:, :m_read, 0]) <= SIGHT_M)
    rel[~mask] = 0.0
    return np.concatenate([own, rel.reshape(k + 1, -1)], axis=1), mask


def encoder_input(features: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """One sequence's encoder input: the features and the mask as 0/1 channels.

    Args:
        features: shape (T, F).
        mask: shape (T, m) bool (m may be 0).

    Returns:
        Shape (T, F + m) float64.
    """
    features = np.asarray(features, float)
    mask = np.asarray(mask, bool)
    if features.ndim != 2 or mask.ndim != 2 or mask.shape[0] != features.shape[0]:
        raise ValueError(
            f"features (T, F) and mask (T, m) must share T, got {features.shape} and {mask.shape}"
        )
    return np.concatenate([features, mask.astype(float)], axis=1)


@dataclass(frozen=True)
class EncoderConfig:
    """The trajectory encoder's shape."""

    input_dim: int
    """Per-sample input width (:func:`input_dim` for episodes; any for other series)."""
    hidden: int = 32
    """GRU hidden units."""
    embedding: int = 16
    """Width of the summary the flow is conditioned on."""
    layers: int = 1
    """Stacked GRU layers."""

    def __post_init__(self) -> None:
        for name in ("input_dim", "hidden", "embedding", "layers"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"EncoderConfig.{name} must be an integer >= 1, got {value!r}")

    def to_dict(self) -> dict[str, Any]:
        """The fields as a JSON-ready dict."""
        return {
            "input_dim": self.input_dim,
            "hidden": self.hidden,
            "embedding": self.embedding,
            "layers": self.layers,
        }


def build_encoder(config: EncoderConfig) -> torch.nn.Module:
    """The torch encoder: standardisation, a GRU over packed sequences, a linear map.

    Its ``forward(x, lengths)`` takes a padded batch ``x`` of shape (B, T_max, input_dim)
    and the true ``lengths`` (B,) (int64, >= 1) and returns (B, embedding): a linear map
    of [last hidden state, mean hidden output over the T_i samples]; the samples
    beyond a sequence's length are never read (packed sequences), so a sequence's
    embedding does not depend on the batch it is in. Its ``set_scaling(mean, scale)``
    stores the input standardisation (buffers: saved with the weights).

    The same map, one sample at a time (an online observer's): ``start(batch)`` is the
    state before any sample, ``step(x_t, state)`` reads one sample per sequence ``x_t``
    (B, input_dim) — one GRU step from the state's hidden state, the running sum of the
    outputs — and returns (the embedding of the samples so far, the next state); after
    T steps it equals ``forward`` of those T samples (to float32 round-off, tested).

    Args:
        config: the encoder's shape.

    Returns:
        A fresh module (weights from torch's global generator: seed it first).
    """
    import torch
    from torch import nn
    from torch.nn.utils.rnn import pack_padded_sequence, pad_packed_sequence

    class TrajectoryEncoder(nn.Module):
        mean: torch.Tensor
        scale: torch.Tensor

        def __init__(self) -> None:
            super().__init__()
            self.register_buffer("mean", torch.zeros(config.input_dim))
            self.register_buffer("scale", torch.ones(config.input_dim))
            self.gru = nn.GRU(
                config.input_dim, config.hidden, num_layers=config.layers, batch_first=True
            )
            self.out = nn.Linear(2 * config.hidden, config.embedding)

        def set_scaling(self, mean: np.ndarray, scale: np.ndarray) -> None:
            self.mean.copy_(torch.as_tensor(mean, dtype=torch.float32))
            self.scale.copy_(torch.as_tensor(scale, dtype=torch.float32))

        def forward(self, x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
            z = (x - self.mean) / self.scale
            packed = pack_padded_sequence(z, lengths.cpu(), batch_first=True, enforce_sorted=False)
            outputs, h = self.gru(packed)
            padded, _ = pad_packed_sequence(outputs, batch_first=True)  # zeros past each length
            mean = padded.sum(dim=1) / lengths.to(padded.dtype)[:, None]
            return self.out(torch.cat([h[-1], mean], dim=1))

        def start(self, batch: int = 1) -> tuple[torch.Tensor, torch.Tensor, int]:
            hidden = torch.zeros(config.layers, batch, config.hidden)
            return hidden, torch.zeros(batch, config.hidden), 0

        def step(
            self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor, int]
        ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor, int]]:
            hidden, total, count = state
            z = (x - self.mean) / self.scale
            output, hidden = self.gru(z[:, None, :], hidden)
            total, count = total + output[:, 0], count + 1
            return self.out(torch.cat([hidden[-1], total / count], dim=1)), (hidden, total, count)

    return TrajectoryEncoder()
