"""The amortized posterior's training data: stochastic drivers simulated from a prior (DESIGN §22).

The estimator of :mod:`~drivestyle.irl.amortized.training` learns from pairs (θ_i, x_i).
Here θ_i are the parameters :class:`~drivestyle.irl.driver.stochastic_prior.StochasticPrior`
varies of a :class:`~drivestyle.irl.driver.stochastic.StochasticStyle` (:data:`PARAMETERS`:
the risk p, the desired speed as its ratio to the EV's start speed — the prior draws it so,
and a box must not depend on the scene —, T, s_0, the lateral factor, the onset, σ_a, σ_δ,
τ) and x_i the episode the driver produced as an observer records it
(:func:`episode_series`: the encoder's input, :func:`~drivestyle.irl.amortized.encoder.
episode_features` with the mask channels, for the TV and up to :data:`NEIGHBOURS` − 1
further vehicles), measurement noise included.

:func:`simulate_set` draws n parameter sets from the prior with a seed (episode i is
simulated with seed ``seed + i``) and runs them on worker processes
(:func:`~drivestyle.common.parallel.parallel_map`); every episode is kept, failed solves
and implausible courses included — they are the simulator's. :func:`with_prefixes` turns
full episodes into training rows: each episode whole, and ``prefixes`` more of its
prefixes 0 … k with k uniform over the allowed lengths, so the estimator learns to read an
episode observed for any time (a prefix of a simulated episode's series is the series of
the episode observed up to k: every feature is per sample, x measured from the first).

Simulating is most of a build's time, so a set is kept: :func:`save_simulated` writes it
to one ``.npz`` with what made it (the prior's ranges, the seed, the series' width and
the features' version), and :func:`load_simulated` reads it back only for the same
prior, seed and features (a set drawn otherwise would silently train another posterior).
"""

from __future__ import annotations

import dataclasses
import json
import time
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import atomic_output_file
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.amortized.encoder import encoder_input, episode_features, input_dim
from drivestyle.irl.amortized.estimator import EstimatorFileError, NeuralPosterior
from drivestyle.irl.amortized.training import Simulations
from drivestyle.irl.driver.stochastic import StochasticStyle, load_planners
from drivestyle.irl.driver.stochastic_prior import EpisodeParams, StochasticPrior, simulate_params

__all__ = [
    "EPISODE_FEATURES",
    "FEATURES_VERSION",
    "NEIGHBOURS",
    "PARAMETERS",
    "SimulatedSet",
    "SimulationsFileError",
    "check_episode_estimator",
    "episode_series",
    "expert_parameters",
    "load_simulated",
    "parameter_box",
    "parameters_of",
    "save_simulated",
    "series_width",
    "simulate_set",
    "style_of",
    "style_parameters",
    "with_prefixes",
]

PARAMETERS: tuple[str, ...] = (
    "risk", "speed_ratio", "time_gap", "min_gap", "lateral", "onset", "sigma_a",
    "sigma_delta", "tau",
)  # fmt: skip
"""The inferred parameters, in order (names of :class:`StochasticPrior`'s ranges)."""

NEIGHBOURS = 3
"""Surrounding vehicles the encoder reads: the TV and the prior's two possible leaders."""

FEATURES_VERSION = 2
"""The version of :func:`episode_series`' per-sample features (2: the EV's inputs added,
vehicles beyond sight masked); a kept simulation set of another version is not reused."""
EPISODE_FEATURES = f"episode-v{FEATURES_VERSION}"
"""The ``features`` an estimator trained on :func:`episode_series` states
(:class:`~drivestyle.irl.amortized.estimator.EstimatorConfig`)."""


def parameter_box(prior: StochasticPrior) -> tuple[np.ndarray, np.ndarray]:
    """The box of :data:`PARAMETERS` under ``prior``: its ranges, (low, high) each (D,).

    Raises:
        ValueError: a range is a single value (the prior does not vary it; the box needs
            low < high).
    """
    low = np.array([getattr(prior, name)[0] for name in PARAMETERS], float)
    high = np.array([getattr(prior, name)[1] for name in PARAMETERS], float)
    fixed = [name for name, lo, hi in zip(PARAMETERS, low, high, strict=True) if lo >= hi]
    if fixed:
        raise ValueError(f"the prior does not vary {fixed}: nothing to infer there")
    return low, high


def parameters_of(params: EpisodeParams) -> np.ndarray:
    """θ of one drawn episode, in :data:`PARAMETERS`' order: shape (D,).

    A style's unset v_ref and s_0 are the scene's (as its planner reads them).
    """
    return style_parameters(params.style, params.scene.base)


def expert_parameters(scenario: ScenarioConfig, risk: float) -> np.ndarray:
    """θ of the SMPC expert of risk ``risk`` in ``scenario``: shape (D,), :data:`PARAMETERS`' order.

    The expert is the stochastic driver with no deviation and no onset
    (:meth:`~drivestyle.irl.driver.stochastic.StochasticStyle.expert`): the scenario's
    v_ref (as a ratio to its EV's start speed) and fixed region (T = 0, s_0 = l_a), λ_y = 1,
    t_on = 0, σ_a = σ_δ = 0. Its τ is the style's default and means nothing (a deviation
    of scale zero has no correlation time). A value may lie outside the prior's box (a
    scenario's v_ref / v_EV(0) above its 1.3, say): it is returned as it is.
    """
    return style_parameters(dataclasses.replace(StochasticStyle.expert(), risk=risk), scenario)


def style_parameters(style: StochasticStyle, scenario: ScenarioConfig) -> np.ndarray:
    """θ of ``style`` driving in ``scenario``, in :data:`PARAMETERS`' order: shape (D,).

    A style's unset v_ref and s_0 are the scenario's (as its planner reads them).
    """
    s = style
    v_ref = s.v_ref if s.v_ref is not None else scenario.v_ref
    ratio = float(v_ref) / float(scenario.ev_speed)
    min_gap = s.min_gap if s.min_gap is not None else scenario.l_a
    values = {
        "risk": s.risk, "speed_ratio": ratio, "time_gap": s.time_gap, "min_gap": min_gap,
        "lateral": s.lateral, "onset": s.onset, "sigma_a": s.sigma_a,
        "sigma_delta": s.sigma_delta, "tau": s.tau,
    }  # fmt: skip
    return np.array([float(values[name]) for name in PARAMETERS])


def style_of(theta: np.ndarray, ev_speed: float) -> StochasticStyle:
    """The driver of θ in a scene whose EV starts at ``ev_speed``: :func:`parameters_of` inverted.

    v_ref = speed_ratio × ``ev_speed``, within [0.5, 69] m/s as the prior draws it; s_0 is
    set (never the scene's); the weights and horizon are the stochastic style's defaults
    (the expert's), which the prior does not vary. ``style_of(parameters_of(params),
    params.scene.base.ev_speed)`` is ``params.style`` with its s_0 made explicit.

    Args:
        theta: θ in :data:`PARAMETERS`' order, shape (D,).
        ev_speed: the EV's start speed in the scene [m/s] (the scenario's ``ev_speed``).

    Returns:
        The style.

    Raises:
        ValueError: θ not of shape (D,) or not finite.
        StochasticStyleError: a parameter outside the range a style admits.
    """
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (len(PARAMETERS),) or not np.all(np.isfinite(theta)):
        raise ValueError(
            f"theta must be {len(PARAMETERS)} finite numbers {PARAMETERS}, got {theta}"
        )
    v = {name: float(x) for name, x in zip(PARAMETERS, theta, strict=True)}
    return StochasticStyle(
        risk=v["risk"], v_ref=float(min(max(ev_speed * v["speed_ratio"], 0.5), 69.0)),
        time_gap=v["time_gap"], min_gap=v["min_gap"], lateral=v["lateral"], onset=v["onset"],
        sigma_a=v["sigma_a"], sigma_delta=v["sigma_delta"], tau=v["tau"],
    )  # fmt: skip


def episode_series(demo: Demonstration, k: int | None = None) -> np.ndarray:
    """The encoder's input of samples 0 … k of an episode (all: ``k`` None): (k + 1, C)."""
    last = demo.n - 1 if k is None else k
    return encoder_input(*episode_features(demo, last, NEIGHBOURS))


@dataclass(frozen=True)
class SimulatedSet:
    """Simulated episodes: their parameters, their observed series and what they cost."""

    theta: np.ndarray
    """θ per episode, shape (n, D), :data:`PARAMETERS`' order."""
    series: tuple[np.ndarray, ...]
    """Per episode its whole series (:func:`episode_series`), shape (T_i, C)."""
    seconds: np.ndarray
    """Per episode its simulation's time on its worker [s], shape (n,)."""
    failures: np.ndarray
    """Per episode its failed solves, shape (n,)."""
    wall_s: float
    """Wall time of the whole batch, the workers' planner loading included [s]."""

    @property
    def n(self) -> int:
        """Number of episodes."""
        return int(self.theta.shape[0])

    def subset(self, index: np.ndarray | range) -> SimulatedSet:
        """The episodes at ``index`` (``wall_s`` kept: the batch's)."""
        idx = np.asarray(index, int)
        return SimulatedSet(self.theta[idx], tuple(self.series[i] for i in idx),
                            self.seconds[idx], self.failures[idx], self.wall_s)  # fmt: skip


def _simulate(raw: dict[str, Any], episode_seed: int) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Worker: one episode's θ, series, time and failed solves."""
    params = EpisodeParams.from_json(raw)
    t0 = time.perf_counter()
    demo = simulate_params(params, episode_seed)
    seconds = time.perf_counter() - t0
    return parameters_of(params), episode_series(demo), seconds, int(demo.meta["failures"])


def simulate_set(
    prior: StochasticPrior,
    n: int,
    seed: int,
    workers: int = 1,
    on_result: Callable[[int, Any], None] | None = None,
) -> SimulatedSet:
    """Draw n episodes from ``prior`` (seed ``seed``) and simulate them (module docstring).

    Args:
        prior: the prior over drivers and scenes.
        n: episodes (>= 1).
        seed: seeds the draws; episode i is simulated with seed ``seed + i``.
        workers: worker processes (1: in this process).
        on_result: called as each episode finishes (a progress bar).

    Returns:
        The episodes in draw order: deterministic given ``prior``, ``n`` and ``seed`` (not
        on ``workers``).
    """
    if not (isinstance(n, int) and n >= 1):
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    parameter_box(prior)
    draws = prior.draw(n, seed)
    tasks = [(d.to_json(), seed + i) for i, d in enumerate(draws)]
    t0 = time.perf_counter()
    rows = parallel_map(_simulate, tasks, workers, on_result, initializer=load_planners)
    wall = time.perf_counter() - t0
    return SimulatedSet(
        theta=np.stack([r[0] for r in rows]),
        series=tuple(r[1] for r in rows),
        seconds=np.array([r[2] for r in rows]),
        failures=np.array([r[3] for r in rows], int),
        wall_s=wall,
    )


def with_prefixes(
    sims: SimulatedSet, prefixes: int, min_samples: int, seed: int, low: np.ndarray,
    high: np.ndarray,
) -> Simulations:  # fmt: skip
    """Training rows: every episode whole, then ``prefixes`` random prefixes of each.

    Args:
        sims: simulated episodes.
        prefixes: prefixes per episode (0: whole episodes only).
        min_samples: shortest prefix [samples] (>= 1); an episode no longer than it adds
            no prefix.
        seed: seeds the prefixes' lengths.
        low: the parameters' box's lower bounds; θ is clipped into the box (a ratio
            computed from a clipped v_ref may sit a rounding error outside).
        high: its upper bounds.

    Returns:
        (θ, series) rows: the n whole episodes first, then their prefixes episode by
        episode; each prefix's θ is its episode's, its group its episode's index (training
        validates on whole episodes: a prefix never validates the episode it was cut
        from).
    """
    if prefixes < 0 or min_samples < 1:
        raise ValueError(
            f"prefixes must be >= 0 and min_samples >= 1, got {prefixes}, {min_samples}"
        )
    rng = np.random.default_rng(seed)
    theta = np.clip(sims.theta, low, high)
    rows_theta = list(theta)
    rows_x = list(sims.series)
    groups = list(range(sims.n))
    for i, x in enumerate(sims.series):
        t = x.shape[0]
        if t <= min_samples:
            continue
        for length in rng.integers(min_samples, t, size=prefixes):  # shorter than whole
            rows_theta.append(theta[i])
            rows_x.append(x[: int(length)])
            groups.append(i)
    return Simulations(np.array(rows_theta), tuple(rows_x), np.array(groups))


def check_episode_estimator(posterior: NeuralPosterior, path: str | Path) -> NeuralPosterior:
    """The estimator if it reads this drivestyle's :func:`episode_series` of :data:`PARAMETERS`.

    Raises:
        EstimatorFileError: it was trained on other features or other parameters (one
            line, naming ``path``: build it again).
    """
    config = posterior.config
    if config.features != EPISODE_FEATURES or config.encoder.input_dim != series_width():
        raise EstimatorFileError(
            f"{path}: an estimator of features {config.features or 'unstated'!r} "
            f"({config.encoder.input_dim} channels); this drivestyle reads {EPISODE_FEATURES!r} "
            f"({series_width()} channels): build it again (drivestyle build-posterior)"
        )
    if config.names != PARAMETERS:
        raise EstimatorFileError(
            f"{path}: an estimator of {list(config.names)}, not of {list(PARAMETERS)}: "
            "build it again (drivestyle build-posterior)"
        )
    return posterior


def series_width() -> int:
    """Width C of :func:`episode_series`."""
    return input_dim(NEIGHBOURS)


class SimulationsFileError(ValueError):
    """A kept simulation set cannot be used here; the message (one line) says why."""


def _provenance(prior: StochasticPrior, seed: int) -> dict[str, Any]:
    return {
        "format": "drivestyle-simulated-drivers",
        "prior": dataclasses.asdict(prior),
        "seed": int(seed),
        "features_version": FEATURES_VERSION,
        "series_width": series_width(),
        "parameters": list(PARAMETERS),
    }


def save_simulated(sims: SimulatedSet, prior: StochasticPrior, seed: int, path: str | Path) -> Path:
    """Write a simulated set to one ``.npz`` (atomically) with what made it (module docstring).

    Args:
        sims: the set, drawn from ``prior`` with ``seed`` (:func:`simulate_set`).
        prior: its prior.
        seed: its seed.
        path: the file.

    Returns:
        The path written.
    """
    lengths = np.array([x.shape[0] for x in sims.series], np.int64)
    meta = {**_provenance(prior, seed), "n": sims.n, "wall_s": sims.wall_s}
    path = Path(path)
    with atomic_output_file(path, option="the simulations file") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, meta=np.array(json.dumps(meta)), theta=sims.theta, lengths=lengths,
                 series=np.concatenate(sims.series), seconds=sims.seconds,
                 failures=sims.failures)  # fmt: skip
    return path


def load_simulated(
    path: str | Path, prior: StochasticPrior, seed: int, n: int | None = None
) -> SimulatedSet:
    """The first ``n`` episodes of a set :func:`save_simulated` wrote, if made as asked.

    Args:
        path: the file.
        prior: the prior the caller would draw from.
        seed: the seed it would draw with.
        n: the episodes it needs (None: all the file holds).

    Returns:
        Its first ``n`` episodes: the same as :func:`simulate_set` (prior, n, seed) returns
        (episode i's draw and seed do not depend on n).

    Raises:
        SimulationsFileError: the file is missing or unreadable, made with another prior,
            seed or features, or holds fewer than ``n`` episodes (one line, naming it).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"][()]))
            theta, lengths, series = data["theta"], data["lengths"], data["series"]
            seconds, failures = data["seconds"], data["failures"]
    except FileNotFoundError:
        raise SimulationsFileError(f"{path}: no such simulations file") from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SimulationsFileError(f"{path}: not a readable simulations file ({reason})") from None
    want = _provenance(prior, seed)
    # JSON turns the prior's tuples into lists: compare as JSON.
    differ = [k for k in want if json.dumps(meta.get(k)) != json.dumps(want[k])]
    if differ:
        raise SimulationsFileError(
            f"{path}: made with another {', '.join(differ)} than this build asks for; not reused"
        )
    n = theta.shape[0] if n is None else n
    if int(meta.get("n", 0)) < n or theta.shape[0] < n:
        raise SimulationsFileError(f"{path}: holds {theta.shape[0]} episodes, this build needs {n}")
    ends = np.cumsum(lengths)
    starts = ends - lengths
    return SimulatedSet(
        theta=np.array(theta[:n]),
        series=tuple(np.array(series[a:b]) for a, b in zip(starts[:n], ends[:n], strict=True)),
        seconds=np.array(seconds[:n]),
        failures=np.array(failures[:n], int),
        wall_s=float(meta.get("wall_s", float("nan"))),
    )
