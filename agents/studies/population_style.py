"""The population's style learned from recorded drivers (issue 27, DESIGN §18).

The driver library of :mod:`drivestyle.irl.library` carries the SMPC expert's cost: built
from simulated SMPC(p) lane changes, it was never fitted to people. Here one style — the
cost weights, the risk and the speed-scaled safety region (T, s_0) — is learned by teacher
forcing over every lane change of the recorded benchmark's *train* split (docs/
benchmark_split.csv), each episode as the predictor sees it (:func:`prepare_demo`: the
target lane's centre, no own-line shift). The result is written as a driver library with
the same risk grid and temperature as the library it started from, so identification,
prediction and mining use it unchanged: ``drivestyle evaluate-prediction --library
runs/people`` compares it on the validation split.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from drivestyle.agents.studies.prediction import (
    DATASETS,
    PREDICTION_ERRORS,
    SplitRow,
    load_recorded,
    prepare_demo,
)
from drivestyle.envs.demonstration import Demonstration
from drivestyle.irl.driver_learning import DriverFit, learn_driver
from drivestyle.irl.library import DriverLibrary

__all__ = ["PopulationSettings", "learn_population", "population_library", "split_demos"]


@dataclass(frozen=True)
class PopulationSettings:
    """How the population's style is learned."""

    fit_region: bool = True
    """Learn the speed-scaled region (T, s_0); False: the library's fixed ellipse."""
    screen: int = 4
    """Starting points scored (:func:`learn_driver`)."""
    restarts: int = 1
    """Levenberg–Marquardt runs."""
    max_iter: int = 12
    """Iterations per run."""
    start_risk: float = 0.7
    """The risk the weights start from."""

    def __post_init__(self) -> None:
        for name in ("screen", "restarts", "max_iter"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.restarts > self.screen:
            raise ValueError(f"restarts ({self.restarts}) cannot exceed screen ({self.screen})")
        if not (math.isfinite(self.start_risk) and 0.5 <= self.start_risk <= 0.99):
            raise ValueError(f"start_risk must lie in [0.5, 0.99], got {self.start_risk!r}")


def split_demos(
    data_dir: str | Path, rows: Sequence[SplitRow], split: str = "train"
) -> tuple[list[tuple[str, Demonstration]], list[tuple[str, str]]]:
    """The split's episodes as the predictor sees them, and those it cannot use.

    Returns:
        ([(episode id, demonstration)], [(episode id, why skipped)]).
    """
    demos, skipped = [], []
    for ds in DATASETS:
        ids = [r.episode_id for r in rows if r.dataset == ds and r.split == split]
        for eid, raw in load_recorded(data_dir, ds, ids):
            try:
                demos.append((eid, prepare_demo(raw)[0]))
            except PREDICTION_ERRORS as exc:
                skipped.append((eid, str(exc)))
    return demos, skipped


def learn_population(
    demos: Sequence[Demonstration],
    library: DriverLibrary,
    settings: PopulationSettings | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> DriverFit:
    """One style for every driver of ``demos``, from the library's weights.

    Raises:
        DriverStyleError: no demonstrations (or :func:`learn_driver`'s errors).
    """
    s = settings or PopulationSettings()
    start = replace(library.style, risk=s.start_risk)
    return learn_driver(
        list(demos), initial=start, fit_region=s.fit_region, screen=s.screen,
        restarts=s.restarts, max_iter=s.max_iter, progress=progress,
    )  # fmt: skip


def population_library(
    fit: DriverFit, library: DriverLibrary, meta: dict[str, Any] | None = None
) -> DriverLibrary:
    """The learned style as a driver library with ``library``'s risks and temperature.

    ``meta["fit"]`` records the fit (its ``residual_rms`` sets the noise floor, DESIGN §15).
    """
    fit_meta = {"status": fit.status, "residual_rms": fit.residual_rms,
                "n_residuals": fit.n_residuals, "iterations": fit.iterations,
                "seconds": fit.seconds}  # fmt: skip
    return DriverLibrary(
        fit.style, library.risks, library.temperature,
        {**(meta or {}), "fit": fit_meta, "source": "recorded train split"},
    )  # fmt: skip
