"""The posterior-predictive check on behaviour: the verdict on fit of a driver's parameters.

Does the driver of an episode drive like the class with these parameters? Given K
parameter rows θ_1 … θ_K (posterior draws of the amortized estimator, DESIGN §22; in
:data:`~drivestyle.irl.amortized.simulations.PARAMETERS` order), :func:`predictive_check`
simulates one replicate of the episode per row and compares the episode's behaviour
statistics (:mod:`drivestyle.irl.amortized.behaviour`: closest approach, accepted gap,
lane-change start and duration, speed change) with the replicates' (Gelman, Meng & Stern
1996: a posterior-predictive p-value per statistic).

*A replicate* (:mod:`drivestyle.irl.amortized.replicates`) is the stochastic driver of
θ_k in the episode's own scene — its scenario and bounds as identification sees them, its
surrounding vehicles replayed, from its first state, with its measurement noise
(``meta["measurement_noise_m"]`` of a simulated episode; 0 for a recorded one unless
given). The check is deterministic given its seed.

*The p-value* (:func:`predictive_p_value`) is mid-rank and two-sided, valid for any K
under exchangeability (a conformal p-value: the episode's tail count ranked among those of
all K + 1 pooled values). A defined value's tail count is min(L, G) + E/2 (L values below
it, G above, E tied within the statistic's resolution,
:data:`~drivestyle.irl.amortized.behaviour.RESOLUTIONS`, itself included): a value beyond
every replicate has p ≤ 2/(K + 1), the rank p-value 2 (1 + min(L, G))/(K + 1) without ties.
A statistic can be undefined (NaN: no lane change, none completed); "undefined" is a third
tail of its own, whose count is the number of undefined values: an episode that changes
lane where D of K replicates do has p ≤ (D + 1)/(K + 1) (no more than the D + 1 defined
values are as rare as it), one that does not where only U replicates also do not has
p ≈ 3 (U + 1)/(K + 1) (the undefined ones and both tails of the defined ones).
P(p ≤ a) ≤ a under the null for every a and every share undefined (tested by simulation).

*The verdict* is Bonferroni over the S = 5 statistics at level α (:data:`ALPHA`): a
statistic fails when p ≤ α/S, the episode is inside ("drives like the class with these
parameters") when none fails, else outside in the failing ones. A value beyond every
replicate has p = 2/(K + 1) (without ties), so a check needs K ≥ 2S/α − 1 draws
(:func:`min_draws`: 199 at α = 0.05) before such a value fails; fewer are refused.

:func:`predictive_checks` runs many episodes on worker processes, one solver set each.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.amortized.behaviour import RESOLUTIONS, STATISTICS, Behaviour, behaviour
from drivestyle.irl.amortized.replicates import replicate, replicate_seed, scene_of
from drivestyle.irl.amortized.simulations import PARAMETERS
from drivestyle.irl.driver.stochastic import load_planners
from drivestyle.irl.driver.stochastic_prior import StochasticPrior

__all__ = [
    "ALPHA",
    "INSIDE",
    "INTERVAL",
    "PredictiveCheck",
    "StatisticCheck",
    "min_draws",
    "predictive_check",
    "predictive_checks",
    "predictive_p_value",
]

ALPHA = 0.05
"""α of the verdict: the family-wise rate at which a driver of the class is called outside."""
INTERVAL = 0.9
"""Mass of the reported central predictive interval."""
INSIDE = "drives like the class with these parameters"
"""The verdict of an episode no statistic fails."""


def min_draws(alpha: float = ALPHA, n_statistics: int = len(STATISTICS)) -> int:
    """The fewest draws K at which a statistic can fail: 2/(K + 1) ≤ α/S.

    Raises:
        ValueError: α outside (0, 1) or S < 1.
    """
    if not (0 < alpha < 1 and n_statistics >= 1):
        raise ValueError(f"alpha must lie in (0, 1) and n_statistics be >= 1, got {alpha!r}")
    return max(math.ceil(2 * n_statistics / alpha - 1 - 1e-9), 1)


def predictive_p_value(observed: float, replicated: np.ndarray, resolution: float = 0.0) -> float:
    """Two-sided mid-rank posterior-predictive p-value of one statistic (module docstring).

    The conformal form: each of the K + 1 pooled values (the observed first) gets its tail
    count — a defined value min(L, G) + E/2 among the defined pooled values (L below it by
    more than ``resolution``, G above, E within it, itself included), an undefined value the
    number of undefined pooled values — and p is the share of pooled values whose tail count
    is no larger than the observed one's. The counts are a symmetric function of the pool,
    so under exchangeability P(p ≤ a) ≤ a for every a and every share undefined.

    Args:
        observed: the episode's value (NaN: undefined).
        replicated: the replicates' values, shape (K,) (NaN: undefined).
        resolution: values within this of each other are ties (≥ 0).

    Returns:
        p in (0, 1]: at most 2/(K + 1) for a defined value beyond every replicate (two
        values are that rare without ties, itself and the far end), 1 when all are tied.
    """
    pool = np.concatenate([[float(observed)], np.asarray(replicated, float).ravel()])
    undefined = np.isnan(pool)
    tails = np.full(pool.size, float(undefined.sum()))
    values = pool[~undefined]
    if values.size:
        diff = values[:, None] - values[None, :]
        below = np.sum(diff > resolution, axis=1)
        above = np.sum(diff < -resolution, axis=1)
        tails[~undefined] = np.minimum(below, above) + (values.size - below - above) / 2
    return float(np.mean(tails <= tails[0] + 1e-9))


@dataclass(frozen=True)
class StatisticCheck:
    """One statistic of a check: the episode's value against its replicates'."""

    name: str
    """The statistic (:data:`~drivestyle.irl.amortized.behaviour.STATISTICS`)."""
    observed: float
    """The episode's value (NaN: undefined)."""
    median: float
    """The defined replicates' median (NaN: none defined)."""
    interval: tuple[float, float]
    """Their central :data:`INTERVAL` interval."""
    defined: float
    """Share of the replicates in which it is defined."""
    p_value: float
    """The two-sided posterior-predictive p-value (:func:`predictive_p_value`)."""
    fails: bool
    """p ≤ α/S."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (NaN as None)."""
        num = _num
        return {
            "observed": num(self.observed), "median": num(self.median),
            "interval": [num(self.interval[0]), num(self.interval[1])],
            "defined": self.defined, "p_value": self.p_value, "fails": self.fails,
        }  # fmt: skip


def _num(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


@dataclass(frozen=True)
class PredictiveCheck:
    """The verdict on fit of one episode and parameter draws (module docstring)."""

    statistics: tuple[StatisticCheck, ...]
    """Per statistic, in :data:`~drivestyle.irl.amortized.behaviour.STATISTICS` order."""
    inside: bool
    """No statistic fails: the episode drives like the class with these parameters."""
    failing: tuple[str, ...]
    """The statistics that fail (empty when inside)."""
    alpha: float
    """α of the verdict."""
    threshold: float
    """α/S: a statistic fails at or below it."""
    k: int
    """Draws, one replicate each."""
    seed: int
    """The check's seed."""
    noise: float
    """σ of the position noise on the replicates' EV [m]."""
    failed_solves: int
    """Failed solves over all replicates."""
    seconds: float
    """Wall time of the check [s]."""
    observed: Behaviour = field(compare=False)
    """The episode's statistics."""
    replicated: np.ndarray = field(compare=False, repr=False)
    """The replicates' statistics, shape (K, S)."""

    @property
    def p_values(self) -> dict[str, float]:
        """Statistic → p-value."""
        return {s.name: s.p_value for s in self.statistics}

    @property
    def verdict(self) -> str:
        """The verdict in words: :data:`INSIDE`, or outside and in which statistics."""
        if self.inside:
            return INSIDE
        named = ", ".join(
            f"{s.name.replace('_', ' ')} (p = {s.p_value:.3g})" for s in self.statistics if s.fails
        )
        return f"outside the class with these parameters in: {named}"

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the replicates' values left out)."""
        return {
            "inside": self.inside, "verdict": self.verdict, "failing": list(self.failing),
            "alpha": self.alpha, "threshold": self.threshold, "k": self.k, "seed": self.seed,
            "noise": self.noise, "failed_solves": self.failed_solves, "seconds": self.seconds,
            "statistics": {s.name: s.to_json() for s in self.statistics},
        }  # fmt: skip


def _draws(draws: np.ndarray, alpha: float) -> np.ndarray:
    theta = np.asarray(draws, dtype=float)
    if theta.ndim != 2 or theta.shape[1] != len(PARAMETERS) or not np.all(np.isfinite(theta)):
        raise ValueError(
            f"draws must be finite rows of the {len(PARAMETERS)} parameters {PARAMETERS}, shape "
            f"(K, {len(PARAMETERS)}), got shape {theta.shape}"
        )
    need = min_draws(alpha)
    if theta.shape[0] < need:
        raise ValueError(
            f"{theta.shape[0]} draws cannot make a statistic beyond every replicate fail at "
            f"alpha = {alpha:g} over {len(STATISTICS)} statistics (its p is 2/(K + 1)): give at "
            f"least {need}, or a larger alpha"
        )
    return theta


def _summary(name: str, obs: float, rep: np.ndarray, threshold: float) -> StatisticCheck:
    defined = rep[~np.isnan(rep)]
    tail = 50 * (1 - INTERVAL)
    if defined.size:
        median = float(np.median(defined))
        lo, hi = (float(q) for q in np.percentile(defined, [tail, 100 - tail]))
    else:
        median = lo = hi = math.nan
    p = predictive_p_value(obs, rep, RESOLUTIONS[name])
    return StatisticCheck(name, float(obs), median, (lo, hi), defined.size / rep.size, p,
                          p <= threshold)  # fmt: skip


def predictive_check(
    draws: np.ndarray,
    demo: Demonstration,
    *,
    seed: int,
    alpha: float = ALPHA,
    noise: float | None = None,
    prior: StochasticPrior | None = None,
) -> PredictiveCheck:
    """Whether ``demo`` drives like the class with the parameters ``draws`` (module docstring).

    Args:
        draws: θ_1 … θ_K, shape (K, D) in
            :data:`~drivestyle.irl.amortized.simulations.PARAMETERS` order; K ≥
            :func:`min_draws` (``alpha``).
        demo: the episode (simulated or recorded, road frame).
        seed: the check's seed (≥ 0); replicate k is simulated with
            :func:`replicate_seed`(seed, k).
        alpha: the verdict's family-wise level.
        noise: σ of the position noise on the replicates' EV [m]; None: the episode's
            ``meta["measurement_noise_m"]``, else 0.
        prior: the prior whose speed limit bounds the replicates (:func:`replicate`;
            default: :class:`StochasticPrior`'s).

    Returns:
        The :class:`PredictiveCheck`, deterministic given the arguments.

    Raises:
        ValueError: malformed draws, too few of them for ``alpha``, a negative seed or
            noise.
        StochasticStyleError: a row outside the ranges a stochastic style admits.
    """
    t0 = time.perf_counter()
    theta = _draws(draws, alpha)
    if not (isinstance(seed, (int, np.integer)) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    sigma = float(demo.meta.get("measurement_noise_m", 0.0)) if noise is None else float(noise)
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"noise must be >= 0 m, got {noise!r}")
    view, sc = scene_of(demo)
    observed = behaviour(view)
    rows, failed = [], 0
    for k, row in enumerate(theta):
        sim = replicate(row, view, sc, replicate_seed(int(seed), k), sigma, prior)
        rows.append(behaviour(sim).values())
        failed += int(sim.meta["failures"])
    replicated = np.array(rows)
    threshold = alpha / len(STATISTICS)
    per = tuple(
        _summary(name, obs, replicated[:, j], threshold)
        for j, (name, obs) in enumerate(zip(STATISTICS, observed.values(), strict=True))
    )
    failing = tuple(s.name for s in per if s.fails)
    return PredictiveCheck(
        statistics=per, inside=not failing, failing=failing, alpha=float(alpha),
        threshold=threshold, k=int(theta.shape[0]), seed=int(seed), noise=sigma,
        failed_solves=failed, seconds=time.perf_counter() - t0, observed=observed,
        replicated=replicated,
    )  # fmt: skip


def _check_task(
    demo: Demonstration, draws: np.ndarray, seed: int, alpha: float, noise: float | None,
    prior: StochasticPrior | None,
) -> PredictiveCheck:  # fmt: skip
    """Worker: one episode's check."""
    return predictive_check(draws, demo, seed=seed, alpha=alpha, noise=noise, prior=prior)


def predictive_checks(
    demos: Sequence[Demonstration],
    draws: Sequence[np.ndarray],
    *,
    seed: int,
    alpha: float = ALPHA,
    noise: float | None = None,
    prior: StochasticPrior | None = None,
    workers: int = 1,
    on_result: Callable[[int, Any], None] | None = None,
) -> list[PredictiveCheck]:
    """:func:`predictive_check` of many episodes on worker processes.

    Episode i is checked with seed ``seed + i`` (its replicates' seeds are distinct from
    every other episode's, :func:`replicate_seed`). Each worker builds the stochastic
    driver's planners once (:func:`~drivestyle.irl.driver.stochastic.load_planners`: the
    CasADi solvers are not thread-safe, so one set per process).

    Args:
        demos: the episodes.
        draws: per episode its draws, shape (K_i, D).
        seed: the first episode's seed (≥ 0).
        alpha: the verdict's family-wise level.
        noise: as :func:`predictive_check` (None: each episode's own).
        prior: as :func:`predictive_check`.
        workers: worker processes (1: in this process).
        on_result: called with (index, check) as each episode finishes (a progress bar).

    Returns:
        The checks in episode order: deterministic given the arguments (not on
        ``workers``).

    Raises:
        ValueError: as many draws as episodes not given, or as :func:`predictive_check`
            (checked before any work).
    """
    if len(draws) != len(demos):
        raise ValueError(f"{len(demos)} episodes but {len(draws)} sets of draws")
    if not (isinstance(seed, (int, np.integer)) and seed >= 0):
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    tasks = [(d, _draws(th, alpha), int(seed) + i, alpha, noise, prior)
             for i, (d, th) in enumerate(zip(demos, draws, strict=True))]  # fmt: skip
    return parallel_map(_check_task, tasks, workers, on_result, initializer=load_planners)
