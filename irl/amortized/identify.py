"""A driver identified by the amortized posterior, from any observed part of an episode (§22).

:func:`identify_amortized` reads the samples 0 … k of one demonstration — never a later
one — and returns its :class:`AmortizedStyle`: per parameter of the estimator (in its
order, the risk p first for an estimator of :data:`~drivestyle.irl.amortized.simulations.
PARAMETERS`) the posterior mean, median and central 90 % interval from ``samples`` draws,
the draws themselves, how many samples were observed and the SHA-256 of the estimator's
weights (the checksum its file carries), so that every number says which estimator gave
it. :func:`identify_amortized_batch` does the same for many episodes with one batched
:meth:`~drivestyle.irl.amortized.estimator.NeuralPosterior.sample_batch` call per chunk
(the network's passes shared: much faster than a loop).

The episode is read as the exact identification reads it: through
:func:`~drivestyle.recorded.real_data.recorded_view` of the samples observed (a recorded
episode beyond its scenario's heading bound under the recorded bounds, anything else as
it is), then :func:`~drivestyle.irl.amortized.simulations.episode_series`, the encoder's
input (:func:`observed_series`; both read nothing after k, tested by altering the future).

:func:`open_posterior` loads a command's ``--posterior FILE`` with the commands' one-line
errors. Torch is imported only where the estimator is used.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.cli import for_option
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.estimator import NeuralPosterior, load_posterior
from drivestyle.irl.amortized.simulations import check_episode_estimator, episode_series
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "BATCH",
    "LEVEL",
    "SAMPLES",
    "AmortizedStyle",
    "identify_amortized",
    "identify_amortized_batch",
    "observed_series",
    "one_thread",
    "open_posterior",
    "summarise_draws",
]

SAMPLES = 200
"""Posterior draws per episode (the build's calibration draws as many)."""
LEVEL = 0.9
"""The central interval's mass: the 5 % and 95 % quantiles."""
BATCH = 64
"""Episodes per batched sampling call."""


@dataclass(frozen=True)
class AmortizedStyle:
    """One episode's amortized posterior over a driver's parameters (module docstring)."""

    names: tuple[str, ...]
    """The parameters, in the estimator's order."""
    mean: np.ndarray
    """Posterior mean per parameter, shape (D,)."""
    median: np.ndarray
    """Posterior median, shape (D,)."""
    lo: np.ndarray
    """The central interval's lower end (the 5 % quantile), shape (D,)."""
    hi: np.ndarray
    """Its upper end (the 95 % quantile), shape (D,)."""
    draws: np.ndarray
    """The posterior draws, shape (K, D), every one inside the estimator's box."""
    samples_observed: int
    """The episode's samples read: k + 1 (samples 0 … k)."""
    estimator_sha256: str
    """SHA-256 of the estimator's weights (its file's checksum)."""

    def __post_init__(self) -> None:
        d = len(self.names)
        for name in ("mean", "median", "lo", "hi"):
            a = np.array(getattr(self, name), float)
            if a.shape != (d,):
                raise ValueError(f"AmortizedStyle.{name} must have shape ({d},), got {a.shape}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        draws = np.array(self.draws, float)
        if draws.ndim != 2 or draws.shape[1] != d or draws.shape[0] < 1:
            raise ValueError(f"draws must have shape (K >= 1, {d}), got {draws.shape}")
        draws.setflags(write=False)
        object.__setattr__(self, "draws", draws)
        if self.samples_observed < 1:
            raise ValueError(f"samples_observed must be >= 1, got {self.samples_observed}")

    def index(self, name: str) -> int:
        """The position of parameter ``name``.

        Raises:
            KeyError: the estimator has no such parameter (the message lists its names).
        """
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no parameter {name!r}; the estimator's are {self.names}") from None

    def parameters(self) -> dict[str, dict[str, float]]:
        """Per parameter (in order) its ``mean``, ``median``, ``q05`` and ``q95``."""
        return {
            n: {"mean": float(self.mean[d]), "median": float(self.median[d]),
                "q05": float(self.lo[d]), "q95": float(self.hi[d])}
            for d, n in enumerate(self.names)
        }  # fmt: skip

    def to_json(self, draws: bool = False) -> dict[str, Any]:
        """JSON-ready dict: the counts, the checksum, :meth:`parameters` (and the draws)."""
        out: dict[str, Any] = {
            "samples_observed": self.samples_observed,
            "draws": int(self.draws.shape[0]),
            "level": LEVEL,
            "estimator_sha256": self.estimator_sha256,
            "parameters": self.parameters(),
        }
        if draws:
            out["posterior_draws"] = self.draws.tolist()
        return out

    def describe(self) -> str:
        """One line: every parameter's mean and 90 % interval, in order."""
        return ", ".join(
            f"{n} {_g(self.mean[d])} [{_g(self.lo[d])}, {_g(self.hi[d])}]"
            for d, n in enumerate(self.names)
        )


def _g(value: float) -> str:
    return f"{value:.3g}"


def summarise_draws(
    draws: np.ndarray, names: Sequence[str], samples_observed: int, estimator_sha256: str
) -> AmortizedStyle:
    """The :class:`AmortizedStyle` of posterior draws (K, D): means, medians, 5/95 % quantiles."""
    draws = np.asarray(draws, float)
    tail = 50.0 * (1.0 - LEVEL)
    lo, median, hi = np.percentile(draws, [tail, 50.0, 100.0 - tail], axis=0)
    return AmortizedStyle(tuple(names), draws.mean(axis=0), median, lo, hi, draws,
                          int(samples_observed), estimator_sha256)  # fmt: skip


def observed_series(demo: Demonstration, k: int | None = None) -> np.ndarray:
    """The estimator's input of samples 0 … k (all: ``k`` None), as identification sees them.

    :func:`~drivestyle.recorded.real_data.recorded_view` of the samples observed, then
    :func:`~drivestyle.irl.amortized.simulations.episode_series`: shape (k + 1, C).

    Raises:
        ValueError: ``k`` outside the demonstration.
    """
    last = demo.n - 1 if k is None else int(k)
    if not 0 <= last < demo.n:
        raise ValueError(f"k must lie in [0, {demo.n - 1}], got {k}")
    return episode_series(recorded_view(demo, last), last)


def identify_amortized_batch(
    posterior: NeuralPosterior,
    demos: Sequence[Demonstration],
    ks: Sequence[int | None] | None = None,
    samples: int = SAMPLES,
    seed: int = 0,
    batch: int = BATCH,
) -> list[AmortizedStyle]:
    """:func:`identify_amortized` of many episodes, ``batch`` at a time in one sampling call.

    Chunk j (episodes j·batch …) is drawn with seed ``seed + j``, on one torch thread (as
    training, and the build's timing: the numbers do not depend on the machine's cores, and
    small batches gain nothing from more threads, which on a busy machine only wait on each
    other): deterministic given the episodes, their order and the seed (an episode's draws
    depend on its chunk, not its posterior).

    Args:
        posterior: the estimator.
        demos: the episodes.
        ks: per episode its last observed sample (None: every sample); None: all whole.
        samples: draws per episode (>= 2).
        seed: seeds the draws.
        batch: episodes per sampling call (>= 1).

    Returns:
        One :class:`AmortizedStyle` per episode, in order.
    """
    if samples < 2 or batch < 1:
        raise ValueError(f"samples must be >= 2 and batch >= 1, got {samples} and {batch}")
    last = [None] * len(demos) if ks is None else list(ks)
    if len(last) != len(demos):
        raise ValueError(f"{len(demos)} episodes but {len(last)} observed samples")
    series = [observed_series(d, k) for d, k in zip(demos, last, strict=True)]
    digest = posterior.weights_sha256()
    names = posterior.config.names
    out: list[AmortizedStyle] = []
    with one_thread():
        for j, start in enumerate(range(0, len(series), batch)):
            chunk = series[start : start + batch]
            draws = posterior.sample_batch(chunk, samples, seed=seed + j)
            for d, x in zip(draws, chunk, strict=True):
                out.append(summarise_draws(d, names, x.shape[0], digest))
    return out


@contextmanager
def one_thread() -> Iterator[None]:
    """Torch on one thread inside the block (its thread count restored after)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def identify_amortized(
    posterior: NeuralPosterior,
    demo: Demonstration,
    k: int | None = None,
    samples: int = SAMPLES,
    seed: int = 0,
) -> AmortizedStyle:
    """The amortized posterior of one episode observed up to sample ``k`` (module docstring).

    Args:
        posterior: the estimator (:func:`open_posterior`, or a trained one).
        demo: the episode (simulated or recorded).
        k: the last observed sample (None: the whole episode); nothing after it is read.
        samples: posterior draws (>= 2).
        seed: seeds the draws.

    Returns:
        Its :class:`AmortizedStyle`.
    """
    return identify_amortized_batch(posterior, [demo], [k], samples, seed)[0]


def open_posterior(path: str | Path, option: str = "--posterior") -> NeuralPosterior:
    """A command's estimator file, its errors one line naming the option and the file.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a damaged file, another format or version
            (:class:`~drivestyle.irl.amortized.estimator.EstimatorFileError`).
        RuntimeError: torch or zuko (the ``sbi`` extra) missing.
    """
    with for_option(option):
        if not Path(path).is_file():
            raise FileNotFoundError(f"{path}: no such estimator file")
        try:
            # on one torch thread: a process that loaded the estimator with its thread pool
            # started and then forks workers (parallel_map) leaves them hanging at their
            # first torch operation (GNU OpenMP's pool does not survive a fork)
            with one_thread():
                posterior = load_posterior(path)
            # an estimator of other features or parameters would read the episode wrongly
            return check_episode_estimator(posterior, path)
        except ImportError as exc:
            text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            if "sbi extra" not in text:
                text = (
                    f"the amortized posterior needs the sbi extra ({text}): "
                    "pip install -c constraints-cpu.txt -e '.[sbi]'"
                )
            raise RuntimeError(f"{option} {path}: {text}") from None
