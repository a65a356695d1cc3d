"""Neural posterior estimation: a posterior over a driver's parameters in one pass (DESIGN §22).

From simulations (θ_i, x_i) — parameters drawn from a prior over a box, a series simulated
with them — a conditional density q(θ | x) is trained to maximise Σ_i log q(θ_i | x_i)
(Papamakarios & Murray 2016; Greenberg et al. 2019 with the prior as proposal): its
minimiser over a rich enough family is the posterior p(θ | x) under that prior, for every x
at once (amortized). Here q is

- the trajectory encoder (:func:`~drivestyle.irl.amortized.encoder.build_encoder`: a GRU over
  the observed series, any length) giving a summary s(x), and
- a conditional normalizing flow of zuko (neural spline flow ``"nsf"`` or masked
  autoregressive flow ``"maf"``) over z, the parameters in unconstrained space
  (:mod:`drivestyle.irl.amortized.box`: the logit of their position in the box), so that
  every sample lies in the box and log q(θ | x) = log q(z | s(x)) + log |dz/dθ|.

Its training is :mod:`drivestyle.irl.amortized.training`.

A trained estimator is saved as one ``.npz`` (no pickle): its weights, its configuration,
a format version and the SHA-256 of the weights; :func:`load_posterior` recomputes the
checksum and refuses a file that does not verify with a one-line error (as
:mod:`drivestyle.planning.compiled` refuses a damaged library).

Torch and zuko are imported inside the functions that need them: importing this module
does not.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from drivestyle.common.io import atomic_output_file
from drivestyle.irl.amortized.box import (
    check_box,
    from_unconstrained,
    log_abs_det,
    to_unconstrained,
)
from drivestyle.irl.amortized.encoder import EncoderConfig, build_encoder

if TYPE_CHECKING:
    import torch

__all__ = [
    "FILE_FORMAT",
    "FILE_VERSION",
    "EstimatorConfig",
    "EstimatorFileError",
    "NeuralPosterior",
    "load_posterior",
]

FILE_FORMAT = "drivestyle-neural-posterior"
"""The ``format`` field of a saved estimator's metadata."""
FILE_VERSION = 1
"""The file layout's version; a file of another version is refused."""

Flow = Literal["nsf", "maf"]
FLOWS: tuple[Flow, ...] = get_args(Flow)


class EstimatorFileError(ValueError):
    """A saved estimator cannot be used; the message (one line) says why."""


@dataclass(frozen=True)
class EstimatorConfig:
    """What the estimator is: its parameters' box, its encoder and its flow."""

    names: tuple[str, ...]
    """Parameter names, one per coordinate."""
    low: tuple[float, ...]
    """The box's lower bounds (the prior's support)."""
    high: tuple[float, ...]
    """The box's upper bounds."""
    encoder: EncoderConfig
    """The trajectory encoder's shape."""
    flow: Flow = "nsf"
    """zuko's neural spline flow (``"nsf"``) or masked autoregressive flow (``"maf"``)."""
    transforms: int = 3
    """Autoregressive transforms in the flow."""
    flow_hidden: tuple[int, ...] = (64, 64)
    """Hidden widths of each transform's network."""
    features: str = ""
    """What the series are (a name and version, e.g. the episode features'
    ``"episode-v2"``); a reader of another kind refuses the file
    (:func:`~drivestyle.irl.amortized.simulations.check_episode_estimator`). Empty: not
    stated (the toy series of the tests)."""
    passes: int | None = None
    """Passes to invert one transform (zuko's ``passes``): None, autoregressive — sampling
    runs each transform's network once per coordinate (D times); 2, a coupling transform
    — half the coordinates condition the other half, sampling runs it twice. Coupling
    is the faster to sample; autoregressive the more expressive per transform."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "names", tuple(str(n) for n in self.names))
        object.__setattr__(self, "low", tuple(float(v) for v in self.low))
        object.__setattr__(self, "high", tuple(float(v) for v in self.high))
        object.__setattr__(self, "flow_hidden", tuple(int(v) for v in self.flow_hidden))
        check_box(np.array(self.low), np.array(self.high))
        if len(self.names) != len(self.low) or len(set(self.names)) != len(self.names):
            raise ValueError(f"need one distinct name per coordinate, got {self.names}")
        if self.flow not in FLOWS:
            raise ValueError(f"flow must be one of {FLOWS}, got {self.flow!r}")
        if self.transforms < 1 or not self.flow_hidden or min(self.flow_hidden) < 1:
            raise ValueError("transforms and flow_hidden widths must be >= 1")
        if self.passes is not None and not (
            isinstance(self.passes, int) and 2 <= self.passes <= len(self.names)
        ):
            raise ValueError(
                f"passes must be None or an integer in [2, {len(self.names)}], got {self.passes!r}"
            )

    @property
    def dim(self) -> int:
        """Number of parameters D."""
        return len(self.names)

    def to_dict(self) -> dict[str, Any]:
        """The fields as a JSON-ready dict (:meth:`from_dict` reads it back)."""
        return {
            "names": list(self.names),
            "low": list(self.low),
            "high": list(self.high),
            "encoder": self.encoder.to_dict(),
            "flow": self.flow,
            "transforms": self.transforms,
            "flow_hidden": list(self.flow_hidden),
            "passes": self.passes,
            "features": self.features,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> EstimatorConfig:
        """The configuration :meth:`to_dict` wrote."""
        return cls(
            names=tuple(data["names"]),
            low=tuple(data["low"]),
            high=tuple(data["high"]),
            encoder=EncoderConfig(**data["encoder"]),
            flow=data["flow"],
            transforms=int(data["transforms"]),
            flow_hidden=tuple(data["flow_hidden"]),
            passes=data.get("passes"),  # absent in files written before it existed
            features=str(data.get("features", "")),
        )


def _build_network(config: EstimatorConfig) -> torch.nn.ModuleDict:
    """The encoder and the flow as one module (``.encoder``, ``.flow``)."""
    try:
        import zuko
        from torch import nn
    except ImportError as exc:
        raise ImportError(
            f"the amortized posterior needs the sbi extra ({exc}): "
            "pip install -c constraints-cpu.txt -e '.[sbi]'"
        ) from None

    flow_cls = zuko.flows.NSF if config.flow == "nsf" else zuko.flows.MAF
    flow = flow_cls(
        config.dim,
        config.encoder.embedding,
        transforms=config.transforms,
        hidden_features=list(config.flow_hidden),
        passes=config.passes,
    )
    return nn.ModuleDict({"encoder": build_encoder(config.encoder), "flow": flow})


def _padded(xs: Sequence[np.ndarray]) -> tuple[torch.Tensor, torch.Tensor]:
    """A batch of series as a zero-padded float32 tensor (B, T_max, C) and their lengths."""
    import torch

    lengths = np.array([x.shape[0] for x in xs])
    batch = np.zeros((len(xs), int(lengths.max()), xs[0].shape[1]), np.float32)
    for i, x in enumerate(xs):
        batch[i, : x.shape[0]] = x
    return torch.from_numpy(batch), torch.from_numpy(lengths.astype(np.int64))


class NeuralPosterior:
    """A trained estimator: q(θ | x) for any observed series x (module docstring).

    Built by :func:`~drivestyle.irl.amortized.training.train` or :func:`load_posterior`;
    holds the configuration and the network (in evaluation mode).
    """

    def __init__(self, config: EstimatorConfig, network: torch.nn.ModuleDict) -> None:
        self.config = config
        self.network = network.eval()
        self._low, self._high = check_box(np.array(config.low), np.array(config.high))

    def _embed(self, xs: Sequence[np.ndarray]) -> torch.Tensor:
        x, lengths = _padded([np.asarray(x, float) for x in xs])
        return self.network["encoder"](x, lengths)

    def _check(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        want = self.config.encoder.input_dim
        if x.ndim != 2 or x.shape[0] < 1 or x.shape[1] != want:
            raise ValueError(f"a series must have shape (T >= 1, {want}), got {x.shape}")
        return x

    def sample_batch(self, xs: Sequence[np.ndarray], n: int, seed: int = 0) -> np.ndarray:
        """``n`` posterior samples for each of several series.

        Args:
            xs: the observed series, each (T_i, C).
            n: samples per series.
            seed: seeds torch's generator for these draws only (the global state is kept).

        Returns:
            Shape (len(xs), n, D), every sample inside the box.
        """
        import torch

        xs = [self._check(x) for x in xs]
        with torch.no_grad():
            context = self._embed(xs)
        return self.sample_embedded(context, n, seed)

    def sample_embedded(self, context: torch.Tensor, n: int, seed: int = 0) -> np.ndarray:
        """``n`` posterior samples for each of several encoder summaries.

        Args:
            context: the encoder's summaries, shape (B, embedding) (its ``forward``, or its
                ``step`` of an online observer).
            n: samples per summary.
            seed: seeds torch's generator for these draws only (the global state is kept).

        Returns:
            Shape (B, n, D), every sample inside the box.
        """
        import torch

        with torch.random.fork_rng(devices=[]), torch.no_grad():
            torch.manual_seed(seed)
            z = self.network["flow"](context).sample((n,))  # (n, B, D)
        return from_unconstrained(z.double().numpy().transpose(1, 0, 2), self._low, self._high)

    def sample(self, x: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
        """``n`` posterior samples given one observed series ``x`` (T, C): shape (n, D)."""
        return self.sample_batch([x], n, seed)[0]

    def log_prob(self, x: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Density log q(θ | x) of parameter rows ``theta`` (K, D) in the box: shape (K,)."""
        import torch

        x = self._check(x)
        theta = np.atleast_2d(np.asarray(theta, float))
        z = torch.as_tensor(to_unconstrained(theta, self._low, self._high), dtype=torch.float32)
        with torch.no_grad():
            xb, lengths = _padded([x])
            context = self.network["encoder"](xb, lengths).expand(len(theta), -1)
            log_q = self.network["flow"](context).log_prob(z).double().numpy()
        return log_q + log_abs_det(theta, self._low, self._high)

    def weights_sha256(self) -> str:
        """The SHA-256 of the weights: the checksum its file carries and loading verifies."""
        return _weights_digest(
            {k: v.detach().cpu().numpy() for k, v in self.network.state_dict().items()}
        )

    def save(self, path: str | Path) -> Path:
        """Write the estimator to one ``.npz`` (atomically): weights, configuration, checksum.

        Returns:
            The path written.
        """
        import torch
        import zuko

        from drivestyle import __version__

        weights = {k: v.detach().cpu().numpy() for k, v in self.network.state_dict().items()}
        meta = {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "config": self.config.to_dict(),
            "weights_sha256": _weights_digest(weights),
            "drivestyle": __version__,
            "torch": torch.__version__,
            "zuko": zuko.__version__,
        }
        arrays = {f"w:{k}": v for k, v in weights.items()}
        path = Path(path)
        with atomic_output_file(path, option="the estimator file") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
        return path


def _weights_digest(weights: dict[str, np.ndarray]) -> str:
    """SHA-256 over the weights: per name (sorted) its name, dtype, shape and bytes."""
    h = hashlib.sha256()
    for name in sorted(weights):
        a = np.ascontiguousarray(weights[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def load_posterior(path: str | Path) -> NeuralPosterior:
    """The estimator :meth:`NeuralPosterior.save` wrote, its checksum verified.

    Raises:
        EstimatorFileError: the file is missing, unreadable, of another format or version,
            or its weights do not match their checksum (one line, naming the file).
    """
    import torch

    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"][()]))
            weights = {k[2:]: data[k] for k in data.files if k.startswith("w:")}
    except FileNotFoundError:
        raise EstimatorFileError(f"{path}: no such estimator file") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise EstimatorFileError(f"{path}: not a readable estimator file ({reason})") from None
    if not isinstance(meta, dict) or meta.get("format") != FILE_FORMAT:
        raise EstimatorFileError(f"{path}: not a drivestyle estimator file")
    if meta.get("version") != FILE_VERSION:
        raise EstimatorFileError(
            f"{path}: estimator file version {meta.get('version')!r}, this drivestyle reads "
            f"{FILE_VERSION}: train it again"
        )
    if _weights_digest(weights) != meta.get("weights_sha256"):
        raise EstimatorFileError(
            f"{path}: its weights do not match their SHA-256 (damaged or altered); refused"
        )
    try:
        config = EstimatorConfig.from_dict(meta["config"])
        network = _build_network(config)
        network.load_state_dict({k: torch.from_numpy(np.array(v)) for k, v in weights.items()})
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        reason = str(exc).splitlines()[0]
        raise EstimatorFileError(f"{path}: its configuration does not fit ({reason})") from None
    return NeuralPosterior(config, network)
