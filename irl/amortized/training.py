"""Training the neural posterior estimator on simulations (DESIGN §22).

The loss is the mean −log q(z | s(x)) over a batch of simulations (θ_i, x_i), z the
parameters in unconstrained space (the Jacobian term of q(θ | x) does not depend on the
network): maximum likelihood of the simulated parameters, whose minimiser over a rich
family is the posterior under the prior that drew them (Papamakarios & Murray 2016).
Adam; a held-out share of the simulations (whole groups, where the rows carry them:
an episode and its prefixes) stops training when its loss has not improved
for ``patience`` epochs, and the best epoch's weights are kept. Training is deterministic
given its seed on one thread (weights from ``torch.manual_seed``, the split and the batch
order from the seed). Torch is imported inside :func:`train` only.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from drivestyle.irl.amortized.box import check_box, to_unconstrained
from drivestyle.irl.amortized.estimator import (
    EstimatorConfig,
    NeuralPosterior,
    _build_network,
    _padded,
)

if TYPE_CHECKING:
    import torch

__all__ = ["Simulations", "TrainingConfig", "TrainingResult", "train"]


@dataclass(frozen=True)
class Simulations:
    """Simulated pairs (θ_i, x_i): the estimator's training (or held-out) data."""

    theta: np.ndarray
    """Parameters, shape (N, D), inside the estimator's box."""
    x: tuple[np.ndarray, ...]
    """Per simulation its series, shape (T_i, C): T_i >= 1 samples of one width C."""
    groups: np.ndarray | None = None
    """Per row the simulation it was cut from (rows of one episode: the whole and its
    prefixes), shape (N,) int; training validates on whole groups, so no row validates
    an episode another row trains on. None: every row its own group."""

    def __post_init__(self) -> None:
        theta = np.array(self.theta, float)
        if theta.ndim != 2 or theta.shape[0] < 1:
            raise ValueError(f"theta must have shape (N, D) with N >= 1, got {theta.shape}")
        xs = tuple(np.array(x, float) for x in self.x)
        if len(xs) != theta.shape[0]:
            raise ValueError(f"{theta.shape[0]} parameter rows but {len(xs)} series")
        widths = {x.shape[1] if x.ndim == 2 else -1 for x in xs}
        if len(widths) != 1 or -1 in widths or any(x.shape[0] < 1 for x in xs):
            raise ValueError("every series must have shape (T_i, C), T_i >= 1, one width C")
        if not np.all(np.isfinite(theta)) or not all(np.all(np.isfinite(x)) for x in xs):
            raise ValueError("simulations must be finite")
        if self.groups is not None:
            groups = np.array(self.groups, int)
            if groups.shape != (theta.shape[0],):
                raise ValueError(f"groups must have shape ({theta.shape[0]},), got {groups.shape}")
            groups.setflags(write=False)
            object.__setattr__(self, "groups", groups)
        theta.setflags(write=False)
        for x in xs:
            x.setflags(write=False)
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "x", xs)

    @property
    def n(self) -> int:
        """Number of simulations."""
        return int(self.theta.shape[0])

    def subset(self, index: Sequence[int] | np.ndarray) -> Simulations:
        """The simulations at ``index``, in that order."""
        idx = np.asarray(index, int)
        groups = None if self.groups is None else self.groups[idx]
        return Simulations(self.theta[idx], tuple(self.x[i] for i in idx), groups)


@dataclass(frozen=True)
class TrainingConfig:
    """How the estimator is trained."""

    epochs: int = 200
    """Most passes over the training simulations."""
    batch_size: int = 128
    """Simulations per step."""
    learning_rate: float = 1e-3
    """Adam's step size."""
    validation_fraction: float = 0.1
    """Share of the simulations held out for early stopping (at least one)."""
    patience: int = 10
    """Epochs without a better validation loss before training stops."""
    seed: int = 0
    """Seeds the weights, the split and the batch order."""
    threads: int = 1
    """Torch threads while training (one: deterministic, and one per worker process)."""

    def __post_init__(self) -> None:
        for name in ("epochs", "batch_size", "patience", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"TrainingConfig.{name} must be >= 1, got {getattr(self, name)}")
        if not 0.0 < self.validation_fraction < 1.0:
            raise ValueError(
                f"validation_fraction must lie in (0, 1), got {self.validation_fraction}"
            )
        if not self.learning_rate > 0.0:
            raise ValueError(f"learning_rate must be > 0, got {self.learning_rate}")


@dataclass(frozen=True)
class TrainingResult:
    """What training did."""

    train_loss: tuple[float, ...]
    """Mean −log q(z | x) on the training simulations, per epoch."""
    validation_loss: tuple[float, ...]
    """The same on the held-out simulations, per epoch."""
    best_epoch: int
    """The epoch (0-based) whose weights were kept: the lowest validation loss."""
    stopped_early: bool
    """Whether patience ran out before ``epochs``."""
    seconds: float = field(compare=False)
    """Wall time of training [s]."""

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict of the fields."""
        return {
            "train_loss": list(self.train_loss),
            "validation_loss": list(self.validation_loss),
            "best_epoch": self.best_epoch,
            "stopped_early": self.stopped_early,
            "seconds": self.seconds,
        }


def _scaling(xs: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Mean and scale of every sample of the series, per channel (scale 1 where constant)."""
    stacked = np.concatenate(xs, axis=0)
    mean = stacked.mean(axis=0)
    std = stacked.std(axis=0)
    return mean, np.where(std > 1e-9, std, 1.0)


def train(
    simulations: Simulations,
    config: EstimatorConfig,
    training: TrainingConfig | None = None,
    progress: bool = True,
) -> tuple[NeuralPosterior, TrainingResult]:
    """Train the estimator on simulations (module docstring).

    Args:
        simulations: (θ_i, x_i) with θ inside ``config``'s box and x_i of width
            ``config.encoder.input_dim``.
        config: the estimator's shape.
        training: how to train (default :class:`TrainingConfig`).
        progress: show a progress bar (tqdm, one step per epoch) on stderr.

    Returns:
        (the estimator with the best epoch's weights, what training did).

    Raises:
        ValueError: the simulations do not fit the configuration, or are too few to hold
            one out.
    """
    import torch
    from tqdm import tqdm

    training = training or TrainingConfig()
    if simulations.theta.shape[1] != config.dim:
        raise ValueError(
            f"simulations have {simulations.theta.shape[1]} parameters, not {config.dim}"
        )
    if simulations.x[0].shape[1] != config.encoder.input_dim:
        raise ValueError(
            f"series have width {simulations.x[0].shape[1]}, the encoder reads "
            f"{config.encoder.input_dim}"
        )
    low, high = check_box(np.array(config.low), np.array(config.high))
    outside = np.any((simulations.theta < low) | (simulations.theta > high), axis=1)
    if outside.any():
        raise ValueError(f"{int(outside.sum())} simulation(s) outside the box")
    n_val = round(training.validation_fraction * simulations.n)
    if n_val < 1 or n_val >= simulations.n:
        raise ValueError(f"{simulations.n} simulations leave none to validate or to train on")

    started = time.perf_counter()
    threads = torch.get_num_threads()
    torch.set_num_threads(training.threads)
    try:
        rng = np.random.default_rng(training.seed)
        if simulations.groups is None:
            order = rng.permutation(simulations.n)
            val, fit = simulations.subset(order[:n_val]), simulations.subset(order[n_val:])
        else:  # whole groups validate: the first groups of a random order, ≈ n_val rows
            names = np.unique(simulations.groups)
            picked = rng.permutation(names)
            sizes = np.array([np.sum(simulations.groups == g) for g in picked])
            taken = picked[: max(1, int(np.searchsorted(np.cumsum(sizes), n_val)) + 1)]
            held = np.isin(simulations.groups, taken)
            if held.all():
                raise ValueError(f"{names.size} group(s) leave none to train on")
            val = simulations.subset(np.flatnonzero(held))
            fit = simulations.subset(np.flatnonzero(~held))
        torch.manual_seed(training.seed)
        network = _build_network(config)
        cast(Any, network["encoder"]).set_scaling(*_scaling(fit.x))
        z_fit = torch.as_tensor(to_unconstrained(fit.theta, low, high), dtype=torch.float32)
        z_val = torch.as_tensor(to_unconstrained(val.theta, low, high), dtype=torch.float32)
        optimiser = torch.optim.Adam(network.parameters(), lr=training.learning_rate)
        batches = torch.Generator().manual_seed(training.seed)

        def loss_of(idx: np.ndarray, sims: Simulations, z: torch.Tensor) -> torch.Tensor:
            x, lengths = _padded([sims.x[i] for i in idx])
            context = network["encoder"](x, lengths)
            return -network["flow"](context).log_prob(z[idx]).mean()

        train_loss: list[float] = []
        val_loss: list[float] = []
        best, best_state, waited = np.inf, copy.deepcopy(network.state_dict()), 0
        bar = tqdm(range(training.epochs), desc="training the posterior", unit="epoch",
                   disable=not progress)  # fmt: skip
        for _ in bar:
            network.train()
            perm = torch.randperm(fit.n, generator=batches).numpy()
            total = 0.0
            for start in range(0, fit.n, training.batch_size):
                idx = perm[start : start + training.batch_size]
                loss = loss_of(idx, fit, z_fit)
                optimiser.zero_grad()
                loss.backward()
                optimiser.step()
                total += float(loss.detach()) * len(idx)
            network.eval()
            with torch.no_grad():
                v = (
                    sum(
                        float(loss_of(idx, val, z_val)) * len(idx)
                        for idx in np.array_split(
                            np.arange(val.n), -(-val.n // training.batch_size)
                        )
                    )
                    / val.n
                )
            train_loss.append(total / fit.n)
            val_loss.append(v)
            bar.set_postfix(train=f"{train_loss[-1]:.3f}", validation=f"{v:.3f}")
            if v < best:
                best, best_state, waited = v, copy.deepcopy(network.state_dict()), 0
            else:
                waited += 1
                if waited >= training.patience:
                    break
        bar.close()
        network.load_state_dict(best_state)
    finally:
        torch.set_num_threads(threads)
    result = TrainingResult(
        train_loss=tuple(train_loss),
        validation_loss=tuple(val_loss),
        best_epoch=int(np.argmin(val_loss)),
        stopped_early=len(val_loss) < training.epochs,
        seconds=time.perf_counter() - started,
    )
    return NeuralPosterior(config, network), result
