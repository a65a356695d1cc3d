"""Identification: the posterior over a vehicle's risk and the entry point :func:`identify`.

:func:`identify` answers with either kind of library
(:mod:`drivestyle.irl.identification.library`). With a driver library (the default, DESIGN
§15) the risk is a continuous parameter of the library's one style: each demonstration's
teacher-forced residuals as a function of p (its
:class:`~drivestyle.irl.driver.risk_profile.RiskProfile`) become a likelihood
(:func:`risk_log_likelihood`) and, with a uniform prior on [0.5, 0.99], a posterior over p on
:func:`density_grid` (:func:`identify_driver`, :func:`driver_posterior`), whose temperature a
library's build calibrates (:func:`calibrate_temperature`). With a paper-model library the
scores of :mod:`drivestyle.irl.identification.paper_scorers` give a posterior over the
library's risks. Either way the answer is an
:class:`~drivestyle.irl.identification.result.Identification` with its
:class:`~drivestyle.irl.identification.verdict.Verdict`.

The held-out evaluation is :mod:`drivestyle.studies.identification.study`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.safety import elliptical_index
from drivestyle.irl.driver.driver_style import RESIDUAL_FLOOR, RISK_RANGE, DriverStyleError
from drivestyle.irl.driver.risk_profile import RiskProfile, refined_profile
from drivestyle.irl.identification.library import DriverLibrary, LibraryError, StyleLibrary
from drivestyle.irl.identification.paper_scorers import (
    DEFAULT_SCORER,
    NEAREST_MEMBERS,
    SCORERS,
    demo_scores,
    summarise,
)
from drivestyle.irl.identification.result import (
    INTERVAL_MASS,
    DemoScores,
    Identification,
    check_finite,
    check_identifiable,
)
from drivestyle.irl.identification.verdict import (
    fit_verdict,
)
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "DENSITY_STEP",
    "LIKELIHOOD",
    "TEMPERATURES",
    "Calibration",
    "Identification",
    "LibraryError",
    "StyleLibrary",
    "calibrate_temperature",
    "constraint_binds",
    "density_grid",
    "driver_posterior",
    "grid_estimate",
    "grid_mass",
    "identify",
    "identify_all",
    "identify_driver",
    "risk_log_likelihood",
]

LIKELIHOOD = "likelihood"
"""The scorer of a :class:`~drivestyle.irl.identification.library.DriverLibrary`: the
demonstration's teacher-forced residuals under the one learned style as a function of p
(DESIGN §15)."""
DENSITY_STEP = 0.005
"""Spacing of the continuous posterior's grid over p ∈ [0.5, 0.99]."""


def _as_list(demos: Demonstration | Sequence[Demonstration]) -> list[Demonstration]:
    out = [demos] if isinstance(demos, Demonstration) else list(demos)
    if not out:
        raise ValueError("need at least one demonstration")
    return out


def _true_risk(demo: Demonstration) -> float | None:
    p = demo.meta.get("risk")
    return None if p is None else float(p)


def identify(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary | DriverLibrary,
    scorer: str = DEFAULT_SCORER,
    control_point_rule: str = "kinematic",
    f_floor: float = 0.05,
    nearest: int | None = NEAREST_MEMBERS,
) -> Identification:
    """Identify one vehicle's risk from its demonstration(s), with an honest uncertainty.

    Args:
        demos: one demonstration or several of the same vehicle (their evidence pools).
        library: a driver library (the continuous risk of :func:`identify_driver`; the
            other arguments are unused) or a paper-model style library (at least
            :data:`~drivestyle.irl.identification.paper_scorers.MIN_MEMBERS` training
            scenarios).
        scorer: one of :data:`SCORERS` (lower is better).
        control_point_rule: control-point rule of the demonstrations.
        f_floor: floor of the relative feature error's denominators.
        nearest: per risk, the members of the nearest training scenarios to score (None:
            all).

    Returns:
        The :class:`Identification`: posterior mode, mean and 90 % interval, the
        posterior, the ranking, the scores and the
        :class:`~drivestyle.irl.identification.verdict.Verdict`.

    Raises:
        ValueError: unknown scorer or no demonstrations.
        LibraryError: a demonstration is of another kind or degenerate (no TV, no lane
            change, no motion, a time grid other than its scenario's T_s), or the library
            has too few training scenarios.
    """
    demos = _as_list(demos)
    if isinstance(library, DriverLibrary):
        return identify_driver(demos, library)
    if scorer not in SCORERS:
        raise ValueError(f"scorer must be one of {SCORERS}, got {scorer!r}")
    per_demo = [demo_scores(d, library, control_point_rule, f_floor, nearest) for d in demos]
    return summarise(library.risks, per_demo, scorer, [_true_risk(d) for d in demos])


def identify_all(
    demos: Demonstration | Sequence[Demonstration],
    library: StyleLibrary,
    control_point_rule: str = "kinematic",
    nearest: int | None = NEAREST_MEMBERS,
) -> dict[str, Identification]:
    """:func:`identify` with every scorer (scorer → result) from one set of inner solves."""
    demos = _as_list(demos)
    per_demo = [demo_scores(d, library, control_point_rule, nearest=nearest) for d in demos]
    true = [_true_risk(d) for d in demos]
    return {s: summarise(library.risks, per_demo, s, true) for s in SCORERS}


def _min_s_e(demo: Demonstration) -> float:
    sc = demo.scenario
    vehicles = demo.vehicles
    s_e = elliptical_index(
        demo.ev[:, None, 0] - vehicles[..., 0], demo.ev[:, None, 1] - vehicles[..., 1],
        sc.l_a, sc.l_b,
    )  # fmt: skip
    return float(np.min(s_e))


def density_grid() -> np.ndarray:
    """The continuous posterior's grid over :data:`RISK_RANGE`, :data:`DENSITY_STEP` apart."""
    lo, hi = RISK_RANGE
    return np.round(np.arange(lo, hi + 1e-9, DENSITY_STEP), 4)


def risk_log_likelihood(
    profiles: Sequence[RiskProfile], temperature: float, grid: np.ndarray | None = None
) -> np.ndarray:
    """Log p(demonstrations | p) on ``grid`` (DESIGN §15), up to a constant.

    The residual sums of the demonstrations add (one vehicle, one p); between the solved
    risks they are interpolated linearly. With S(p) that sum, n its residual count and
    s² = min S / n + s_floor² the residual scale the best risk leaves (noise and model
    error; never below :data:`~drivestyle.irl.driver.driver_style.RESIDUAL_FLOOR`),
    ℓ(p) = −(S(p) − min S) / (2 τ² s²). Demonstrations without a step at which p matters
    contribute nothing.

    Args:
        profiles: the demonstrations' :class:`~drivestyle.irl.driver.risk_profile.RiskProfile`.
        temperature: τ > 0 (residuals of neighbouring steps are correlated: τ > 1 widens).
        grid: risks to evaluate at (default :func:`density_grid`).

    Returns:
        ℓ on the grid, max 0.
    """
    if not (np.isfinite(temperature) and temperature > 0):
        raise LibraryError(f"temperature must be a finite number > 0, got {temperature}")
    grid = density_grid() if grid is None else np.asarray(grid, float)
    used = [pr for pr in profiles if pr.n_active > 0]
    if not used:
        return np.zeros(grid.size)
    total = sum(np.interp(grid, pr.risks, pr.ssr) for pr in used)
    n = sum(pr.n_residuals for pr in used)
    s2 = float(np.min(total)) / n + RESIDUAL_FLOOR**2
    # τ² s² as one product of floats: τ**2 of a Python float raises OverflowError
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        ll = -(total - np.min(total)) / (2.0 * np.float64(temperature) ** 2 * s2)
    check_finite(ll, f"temperature {temperature:g}, residual sums {float(np.min(total)):.3g}"
                      f" … {float(np.max(total)):.3g}")  # fmt: skip
    return ll - np.max(ll)


def grid_mass(grid: np.ndarray, density: np.ndarray, risks: Sequence[float]) -> np.ndarray:
    """A posterior's mass in each library risk's cell (midpoints as borders).

    Args:
        grid: where the posterior's mass sits (the continuous posterior's grid, or samples
            of p), shape (G,).
        density: the mass at each, shape (G,) (1/S each for S samples).
        risks: the library's risks, increasing.

    Returns:
        Shape (len(risks),).
    """
    r = np.asarray(risks, float)
    edges = np.concatenate([[-np.inf], (r[1:] + r[:-1]) / 2, [np.inf]])
    cell = np.searchsorted(edges, np.asarray(grid, float), side="right") - 1
    return np.bincount(cell, weights=density, minlength=r.size)[: r.size]


def grid_estimate(grid: np.ndarray, density: np.ndarray, risks: Sequence[float]) -> float:
    """The library risk whose cell holds most of a posterior's mass (the first of equal ones).

    The rule of an :class:`Identification`'s ``risk_estimate`` (:func:`driver_posterior`),
    by which a grid demonstration counts as identified; any posterior over p given as mass
    on points (:func:`grid_mass`'s ``grid``, ``density``) is scored by it.
    """
    return float(np.asarray(risks, float)[int(np.argmax(grid_mass(grid, density, risks)))])


def _quantile(grid: np.ndarray, density: np.ndarray, q: float) -> float:
    return float(grid[min(int(np.searchsorted(np.cumsum(density), q - 1e-12)), grid.size - 1)])


def _interval(grid: np.ndarray, density: np.ndarray) -> tuple[float, float]:
    """The central :data:`INTERVAL_MASS` interval of a mass on ``grid``, to its cells' edges.

    Each grid point's mass stands for its cell [g − h/2, g + h/2] (h = :data:`DENSITY_STEP`),
    so the quantiles' cells are included whole (clipped to the range): with the refined
    profile a posterior can be a few cells wide, and a true risk between two grid points
    then fell outside the points-only interval (validation, continuous risks: 59 % covered
    at the cells' centres, 86 % to their edges).
    """
    tail = (1 - INTERVAL_MASS) / 2
    half = DENSITY_STEP / 2
    lo = max(_quantile(grid, density, tail) - half, float(grid[0]))
    hi = min(_quantile(grid, density, 1 - tail) + half, float(grid[-1]))
    return lo, hi


def _posterior(
    profiles: Sequence[RiskProfile], temperature: float, grid: np.ndarray
) -> tuple[np.ndarray, tuple[float, float]]:
    """The posterior mass on ``grid`` (uniform prior) and its central 90 % interval."""
    density = np.exp(risk_log_likelihood(profiles, temperature, grid))
    density /= density.sum()  # finite: risk_log_likelihood refuses a non-finite posterior
    return density, _interval(grid, density)


def identify_driver(
    demos: Demonstration | Sequence[Demonstration],
    library: DriverLibrary,
    profiles: Sequence[RiskProfile] | None = None,
) -> Identification:
    """One vehicle's risk as a continuous parameter of the library's style (DESIGN §15).

    Each demonstration's teacher-forced residual sum is computed as a function of p
    (:func:`~drivestyle.irl.driver.risk_profile.risk_profile`), turned into a likelihood
    (:func:`risk_log_likelihood`) and, with a uniform prior on [0.5, 0.99], into a
    posterior over p on :func:`density_grid`. Reported: ``risk_interpolated`` its mean,
    ``risk_interval`` its central 90 % interval, ``posterior`` its mass in each library
    risk's cell and ``risk_estimate`` the library risk with most mass. No nearest-scenario
    lookup: the style is the driver's in every scenario.

    Args:
        demos: one demonstration or several of the same vehicle.
        library: the driver library.
        profiles: precomputed risk profiles of ``demos`` (evaluation reuses them).

    Returns:
        The :class:`Identification` (scorer ``"likelihood"``).

    Raises:
        LibraryError: a demonstration is of another kind, degenerate or off its
            scenario's time grid.
    """
    # a recorded episode beyond its scenario's heading bound is seen as the driver model
    # sees recorded traffic (its bounds, its recovered inputs): under the scenario's highway
    # bounds its own states are infeasible and every solve fights them (10–23 s per CATS
    # episode instead of 0.05–3 s)
    demos = [recorded_view(d) for d in _as_list(demos)]
    for d in demos:
        check_identifiable(d)
    if profiles is None:
        try:
            profiles = [refined_profile(library.style, d) for d in demos]
        except DriverStyleError as exc:
            raise LibraryError(f"cannot identify this demonstration: {exc}") from None
    return driver_posterior(
        profiles, library, [_min_s_e(d) for d in demos], [_true_risk(d) for d in demos]
    )


def driver_posterior(
    profiles: Sequence[RiskProfile],
    library: DriverLibrary,
    min_s_e: Sequence[float],
    true_risks: Sequence[float | None],
) -> Identification:
    """The :class:`Identification` of demonstrations' risk profiles (:func:`identify_driver`).

    Shared by the offline identification and the online tracker
    (:class:`drivestyle.irl.identification.online.StyleTracker`), so both report the same posterior.

    Args:
        profiles: each demonstration's (or stream's) residual sums over the risks.
        library: the driver library (its risks, temperature).
        min_s_e: each demonstration's closest approach in ellipse units.
        true_risks: each demonstration's true risk, where known.

    Returns:
        The :class:`Identification` (scorer ``"likelihood"``).
    """
    grid = density_grid()
    density, (lo, hi) = _posterior(profiles, library.temperature, grid)
    uniform = np.full(grid.size, 1.0 / grid.size)
    prior_interval = _interval(grid, uniform)
    verdict = fit_verdict(
        sum((np.interp(grid, pr.risks, pr.ssr) for pr in profiles), np.zeros(grid.size)),
        sum(pr.n_residuals for pr in profiles),
        any(constraint_binds(pr) for pr in profiles),
        library.noise_floor,
        density,
        (lo, hi),
        prior_interval,
        min(min_s_e, default=float("inf")),
    )
    risks = np.asarray(library.risks, float)
    mass = grid_mass(grid, density, library.risks)
    order = np.argsort(-mass, kind="stable")
    per_demo = [
        DemoScores(
            scores={LIKELIHOOD: tuple(np.interp(risks, pr.risks, pr.ssr).tolist())},
            constraint_binds=constraint_binds(pr),
            min_s_e=float(s_e),
            trigger_fired=pr.n_active > 0,
        )
        for pr, s_e in zip(profiles, min_s_e, strict=True)
    ]
    if not verdict.constraint_binds:
        lo, hi = RISK_RANGE  # nothing was learned about p: say so, not a prior's quantiles
    return Identification(
        scorer=LIKELIHOOD,
        risks=tuple(float(p) for p in risks),
        posterior=tuple(float(q) for q in mass),
        risk_estimate=float(risks[order[0]]),
        risk_interpolated=float(density @ grid),
        risk_interval=(lo, hi),
        ranking=tuple(float(risks[i]) for i in order),
        per_demo=tuple(per_demo),
        true_risks=tuple(true_risks),
        density_risks=tuple(float(p) for p in grid),
        density=tuple(float(q) for q in density),
        verdict=verdict,
    )


def constraint_binds(profile: RiskProfile) -> bool:
    """Whether a chance constraint binds at some step of ``profile`` at some risk.

    The solver flags a step active when a chance multiplier exceeds 1e-8
    (:attr:`~drivestyle.irl.driver.risk_profile.RiskProfile.n_active`); an interior-point
    multiplier is never exactly 0, so vehicles 120–150 m away are flagged too. A
    constraint that binds changes a plan, so S(p) is not constant: it binds when S
    varies over the risks by more than one residual entry at the floor,
    max S − min S > s_floor² (the flagged far-TV demonstrations vary by < 1e-5).
    """
    return profile.n_active > 0 and float(np.ptp(profile.ssr)) > RESIDUAL_FLOOR**2


TEMPERATURES = (0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0)
"""Candidates of :func:`calibrate_temperature`."""


@dataclass(frozen=True)
class Calibration:
    """The temperature chosen for a driver library and the coverage behind the choice."""

    temperature: float
    """The smallest candidate τ whose 90 % intervals cover the truth for ≥ 90 % of the
    calibration demonstrations (the largest candidate if none does)."""
    coverage: Mapping[float, float]
    """τ → coverage on the calibration demonstrations."""
    n_demos: int
    """Informative calibration demonstrations."""

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {
            "temperature": self.temperature,
            "coverage": {str(t): c for t, c in self.coverage.items()},
            "n_demos": self.n_demos,
        }


def calibrate_temperature(
    library: DriverLibrary,
    demos: Sequence[Demonstration],
    target: float = INTERVAL_MASS,
    candidates: Sequence[float] = TEMPERATURES,
) -> Calibration:
    """Choose τ so that the 90 % intervals cover the true risks of ``demos`` (DESIGN §15).

    Args:
        library: the driver library (its temperature is ignored).
        demos: calibration demonstrations with ``meta["risk"]`` (scenarios not used for
            learning; continuous risks make the intervals honest between grid risks).
        target: the coverage to reach.
        candidates: increasing temperatures to try.

    Returns:
        The :class:`Calibration`.

    Raises:
        ValueError: no demonstration with a true risk and an active chance constraint.
    """
    pairs = []
    for d in demos:
        truth = _true_risk(d)
        if truth is None:
            continue
        pr = refined_profile(library.style, d)
        if pr.n_active > 0:
            pairs.append((pr, truth))
    if not pairs:
        raise ValueError(
            "no calibration demonstration with a true risk and an active chance constraint"
        )
    grid = density_grid()
    coverage: dict[float, float] = {}
    for tau in candidates:
        hits = 0
        for pr, truth in pairs:
            _, (lo, hi) = _posterior([pr], tau, grid)
            hits += lo - 1e-9 <= truth <= hi + 1e-9  # the interval reaches its cells' edges
        coverage[float(tau)] = hits / len(pairs)
    chosen = next((t for t, c in coverage.items() if c >= target), float(candidates[-1]))
    return Calibration(chosen, coverage, len(pairs))
