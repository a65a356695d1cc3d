"""Style libraries: learned styles by risk level, their file ``library.json`` and learning one.

Two kinds of library share the file name and the commands (``build_style_library.py``,
``identify_style.py``, ``mine_styles.py``):

- :class:`DriverLibrary` (``kind: driver-library``, the default, DESIGN §15): one
  receding-horizon cost learned from demonstrations of every risk in shared scenarios
  (each with its known risk), the risk grid, and the likelihood's calibrated temperature.
  Identification infers the risk as a continuous parameter of that one style.
- :class:`StyleLibrary` (the paper model's, described below).

A *library* holds, per SMPC risk level p, one θ learned jointly from K demonstrations of
that risk in shared scenarios of the random family and one θ per demonstration
(*members*, in the order of the K ``training_scenarios``). Identification
(:mod:`drivestyle.irl.identification.paper_scorers`) scores, per risk, the members learned in
the training scenarios nearest to an unseen demonstration's (DESIGN §8).

A library is validated whole when it is built or loaded (:class:`LibraryError`, one line
naming the problem): a known file ``version``; at least two risks (one risk cannot be told
from another: its identification would report that risk whatever the data), in (0, 1),
increasing and distinct; one joint θ and K member θs per risk, each positive and of the
feature set's length; K training scenarios, each with the quantities the scenario distance
needs; a driver library's temperature within :data:`TEMPERATURE_RANGE`. A library that
cannot answer honestly is refused rather than answered from.

The module is one concept at ≈ 600 lines: both kinds share one file (``library.json``, its
version and its loader :func:`load_any_library`) and one validation, so they stay together.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import read_json
from drivestyle.common.parallel import parallel_map
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_fit import DriverFit
from drivestyle.irl.driver.driver_learning import learn_driver
from drivestyle.irl.driver.driver_style import (
    RESIDUAL_FLOOR,
    RISK_RANGE,
    DriverStyle,
    DriverStyleError,
)
from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL

__all__ = [
    "DRIVER_LIBRARY_KIND",
    "LIBRARY_VERSION",
    "MIN_RISKS",
    "SCENARIO_SCALE",
    "TEMPERATURE_RANGE",
    "DriverLibrary",
    "LibraryError",
    "StyleLibrary",
    "check_temperature",
    "learn_driver_library",
    "learn_library",
    "load_any_library",
    "load_library",
]

SCENARIO_SCALE = {"ev_speed": 3.0, "tv_speed": 3.5, "tv_gap": 10.0}
"""Units of the scenario distance: half the random family's range of each quantity."""
_RESERVED = (
    "version", "feature_set", "features", "risks", "theta", "feature_config", "members",
)  # fmt: skip
"""Keys of ``library.json`` that are not metadata (besides ``training_scenarios``)."""
LIBRARY_VERSION = 1
"""The ``library.json`` format this code writes and reads (both kinds); a file without a
``version`` is read as this one (paper-model libraries written before it was recorded)."""
MIN_RISKS = 2
"""Fewest risks a library holds: identification compares risks, and with one the posterior's
mode is that risk whatever the data (``--risks 0.7`` answered 0.7 outside its own interval)."""


class LibraryError(ValueError):
    """A style library is empty, corrupt or inconsistent, or cannot answer a question."""


def _check_risk_count(risks: Sequence[float]) -> None:
    if len(risks) < MIN_RISKS:
        raise LibraryError(
            f"a library needs at least {MIN_RISKS} risks to tell styles apart, got "
            f"{len(risks)} ({', '.join(f'{p:g}' for p in risks)}); build it with two or more "
            "(build-style-library --risks 0.5,0.7,0.9)"
        )


def _check_version(raw: Mapping[str, Any]) -> None:
    version = raw.get("version", LIBRARY_VERSION)
    if isinstance(version, bool) or version != LIBRARY_VERSION:
        raise LibraryError(
            f"unknown library version {version!r}; this drivestyle reads version "
            f"{LIBRARY_VERSION} (rebuild the library with build-style-library)"
        )


def _check_theta(theta: Sequence[float], m: int, what: str) -> None:
    if len(theta) != m or not all(math.isfinite(v) and v > 0 for v in theta):
        raise LibraryError(f"{what} must be {m} positive numbers, got {list(theta)}")


@dataclass(frozen=True)
class StyleLibrary:
    """Learned styles by risk level (module docstring), validated whole on construction."""

    feature_set: str
    """'base' or 'reactive'."""
    risks: tuple[float, ...]
    """Risk levels p in (0, 1), strictly increasing."""
    thetas: tuple[tuple[float, ...], ...]
    """Joint θ per risk (active features, FEATURES order)."""
    features: FeatureConfig = field(default_factory=FeatureConfig)
    """Feature configuration the styles were learned with."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Per-risk fit, timings, seeds (``library.json``'s other keys)."""
    members: tuple[tuple[tuple[float, ...], ...], ...] = ()
    """Per risk, one θ per training scenario (in ``training_scenarios`` order)."""
    training_scenarios: tuple[Mapping[str, Any], ...] = ()
    """The K scenarios the members were learned in (their JSON form, ``ScenarioConfig``
    fields); identification picks members by the distance of these to a demonstration's."""

    def __post_init__(self) -> None:
        if not self.risks:
            raise LibraryError("the library is empty (no risk levels)")
        for p in self.risks:
            if not (isinstance(p, int | float) and 0 < p < 1):
                raise LibraryError(f"library risk {p!r} is not in (0, 1)")
        if list(self.risks) != sorted(self.risks) or len(set(self.risks)) != len(self.risks):
            raise LibraryError(f"library risks must be distinct and increasing, got {self.risks}")
        _check_risk_count(self.risks)
        if self.feature_set != self.features.feature_set:
            raise LibraryError(
                f"feature_set {self.feature_set!r} but the feature configuration is "
                f"{self.features.feature_set!r}"
            )
        if len(self.thetas) != len(self.risks):
            raise LibraryError(f"{len(self.risks)} risks but {len(self.thetas)} joint thetas")
        if len(self.members) != len(self.risks):
            raise LibraryError(
                f"{len(self.risks)} risks but {len(self.members)} member sets (one set of "
                "per-demonstration styles per risk is needed)"
            )
        k = len(self.training_scenarios)
        if k == 0:
            raise LibraryError("the library records no training_scenarios")
        m = len(self.features.names)
        for p, theta, members in zip(self.risks, self.thetas, self.members, strict=True):
            _check_theta(theta, m, f"joint theta of p={p:g}")
            if len(members) != k:
                raise LibraryError(
                    f"p={p:g} has {len(members)} member styles but the library has {k} "
                    "training_scenarios (one member per scenario)"
                )
            for j, theta_j in enumerate(members):
                _check_theta(theta_j, m, f"member {j} of p={p:g}")
        for j, sc in enumerate(self.training_scenarios):
            bad = [
                key
                for key in SCENARIO_SCALE
                if not (
                    isinstance(sc, Mapping)
                    and isinstance(sc.get(key), int | float)
                    and math.isfinite(sc[key])
                )
            ]
            if bad:
                raise LibraryError(f"training scenario {j} has no finite {', '.join(bad)}")

    @property
    def n_scenarios(self) -> int:
        """K: training scenarios, and member styles per risk."""
        return len(self.training_scenarios)

    def styles(
        self, i: int, nearest: int | None = None, scenario: ScenarioConfig | None = None
    ) -> tuple[tuple[float, ...], ...]:
        """The member styles that represent risk i in a scenario.

        The members learned in the ``nearest`` training scenarios closest to ``scenario``
        (distance in :data:`SCENARIO_SCALE` units over EV speed, TV speed and TV gap); all
        members if ``nearest`` is None or not smaller than K.

        Raises:
            ValueError: ``nearest`` is given without a scenario, or is < 1.
        """
        members = self.members[i]
        if nearest is None or nearest >= len(members):
            return members
        if nearest < 1:
            raise ValueError(f"nearest must be >= 1, got {nearest}")
        if scenario is None:
            raise ValueError("choosing the nearest members needs the demonstration's scenario")
        keys = list(SCENARIO_SCALE)
        scale = np.array([SCENARIO_SCALE[k] for k in keys])
        here = np.array([getattr(scenario, k) for k in keys])
        there = np.array([[float(sc[k]) for k in keys] for sc in self.training_scenarios])
        order = np.argsort(np.linalg.norm((there - here) / scale, axis=1), kind="stable")
        return tuple(members[j] for j in order[:nearest])

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``library.json``)."""
        fc = self.features
        return {
            "version": LIBRARY_VERSION,
            "feature_set": self.feature_set,
            "features": list(fc.names),
            "risks": list(self.risks),
            "theta": {str(p): list(t) for p, t in zip(self.risks, self.thetas, strict=True)},
            "members": {
                str(p): [list(t) for t in self.members[i]] for i, p in enumerate(self.risks)
            },
            "feature_config": {k: getattr(fc, k) for k in fc.__dataclass_fields__},
            "training_scenarios": [dict(sc) for sc in self.training_scenarios],
            **self.meta,
        }

    @classmethod
    def from_json(cls, raw: Mapping[str, Any]) -> StyleLibrary:
        """From :meth:`to_json`'s form, validated whole.

        Raises:
            LibraryError: an unknown version, or a key is missing, malformed or inconsistent
                with the others.
        """
        _check_version(raw)
        try:
            features = FeatureConfig.from_dict(raw["feature_config"])
        except KeyError:
            raise LibraryError("no 'feature_config'") from None
        except (TypeError, ValueError) as exc:
            raise LibraryError(f"invalid 'feature_config' ({exc})") from None
        names = raw.get("features")
        if names is not None and list(names) != list(features.names):
            raise LibraryError(
                f"'features' {names} are not those of the {features.feature_set!r} feature set"
            )
        raw_risks = _get_list(raw, "risks")
        risks = tuple(_number(p, "risk") for p in raw_risks)
        thetas = _per_risk(raw, "theta", raw_risks)
        if not raw.get("members"):
            raise LibraryError(
                "the library has no per-demonstration 'members'; identification needs them "
                "(rebuild it with build_style_library.py)"
            )
        members = _per_risk(raw, "members", raw_risks)
        scenarios = _get_list(raw, "training_scenarios")
        try:
            members_t = tuple(tuple(tuple(_vector(t, "member")) for t in ms) for ms in members)
            thetas_t = tuple(tuple(_vector(t, "theta")) for t in thetas)
        except TypeError as exc:
            raise LibraryError(str(exc)) from None
        return cls(
            feature_set=raw.get("feature_set", features.feature_set),
            risks=risks,
            thetas=thetas_t,
            features=features,
            meta={k: v for k, v in raw.items() if k not in (*_RESERVED, "training_scenarios")},
            members=members_t,
            training_scenarios=tuple(scenarios),
        )


def _get_list(raw: Mapping[str, Any], key: str) -> list:
    value = raw.get(key)
    if value is None:
        raise LibraryError(f"no {key!r}")
    if not isinstance(value, list):
        raise LibraryError(f"{key!r} must be a list, got {type(value).__name__}")
    return value


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise LibraryError(f"{what} {value!r} is not a number")
    return float(value)


def _vector(values: Any, what: str) -> list[float]:
    if not isinstance(values, list):
        raise TypeError(f"a {what} style must be a list of numbers, got {values!r}")
    return [_number(v, f"{what} style entry") for v in values]


def _per_risk(raw: Mapping[str, Any], key: str, risks: list) -> list:
    """``raw[key]``'s entry of every risk (keyed by the risk as written, e.g. "0.5")."""
    table = raw.get(key)
    if not isinstance(table, dict):
        raise LibraryError(f"no {key!r} table (risk → values)")
    missing = [str(p) for p in risks if str(p) not in table]
    if missing:
        raise LibraryError(f"{key!r} has no entry for risk {', '.join(missing)}")
    extra = sorted(set(table) - {str(p) for p in risks})
    if extra:
        raise LibraryError(f"{key!r} has entries for risks not in 'risks': {', '.join(extra)}")
    return [table[str(p)] for p in risks]


def load_library(path: str | Path) -> StyleLibrary:
    """Read ``library.json`` (or a folder holding it), validated whole.

    Raises:
        FileNotFoundError: no such file.
        LibraryError: malformed, empty or inconsistent library (one line naming the file and
            the problem).
    """
    path, raw = read_json(path, "library.json", LibraryError, "style library")
    try:
        return StyleLibrary.from_json(raw)
    except LibraryError as exc:
        raise LibraryError(f"{path}: {exc}") from None


def _learn_risk(risk: float, demos: list[Demonstration], feature_set: str) -> dict[str, Any]:
    """Worker: one θ learned jointly from a risk's demonstrations and one per demonstration."""
    t0 = time.perf_counter()
    features = FeatureConfig(feature_set=feature_set)
    learner = MaxEntIRL(demos, features, IRLConfig())
    result = learner.learn()
    members = [MaxEntIRL(d, features, IRLConfig()).learn().theta.tolist() for d in demos]
    per_demo = [
        {
            "rmse_y_m": e["rmse_y_m"],
            "rmse_y_reaction_m": e["rmse_y_reaction_m"],
            "trigger_fired": p.basis.events.reactive_active,
        }
        for e, p in zip(result.errors, learner.problems, strict=True)
    ]
    return {
        "risk": risk,
        "theta": result.theta.tolist(),
        "members": members,
        "theta_normalised": result.theta_normalised.tolist(),
        "iterations": result.iterations,
        "converged": result.converged,
        "learning_error": result.learning_error,
        "per_demo": per_demo,
        "learn_s": time.perf_counter() - t0,
    }


def learn_library(
    demos_by_risk: Mapping[float, Sequence[Demonstration]],
    feature_set: str = "reactive",
    workers: int = 2,
    progress: Callable[[dict[str, Any]], None] | None = None,
    meta: dict[str, Any] | None = None,
) -> StyleLibrary:
    """Learn a style library from demonstrations grouped by risk (in parallel processes).

    Args:
        demos_by_risk: risk p → its demonstrations, one per training scenario, the same
            scenarios in the same order for every risk (so that the styles differ only by p).
        feature_set: 'reactive' or 'base'.
        workers: processes (1: in this process).
        progress: called with each finished risk's record.
        meta: stored in the library (seeds, observation, …).

    Returns:
        The library; its training scenarios are the demonstrations' own, and
        ``meta["per_risk"]`` holds each risk's fit and timing.

    Raises:
        ValueError: fewer than two risks (:class:`LibraryError`), a risk without
            demonstrations, or risks demonstrated in different scenarios.
    """
    risks = sorted(float(p) for p in demos_by_risk)
    if not risks:
        raise ValueError("need demonstrations of at least one risk level")
    _check_risk_count(risks)  # before the learning, not after it
    by_risk = {float(p): list(ds) for p, ds in demos_by_risk.items()}
    if any(not by_risk[p] for p in risks):
        raise ValueError("every risk level needs at least one demonstration")
    scenarios = [d.scenario.to_dict() for d in by_risk[risks[0]]]
    for p in risks[1:]:
        if [d.scenario.to_dict() for d in by_risk[p]] != scenarios:
            raise ValueError(
                f"the demonstrations of p={p:g} are not in the same scenarios (same order) as "
                f"those of p={risks[0]:g}; a library compares risks in shared scenarios"
            )
    given = (meta or {}).get("training_scenarios")
    if given is not None and list(given) != scenarios:
        raise ValueError("meta['training_scenarios'] are not the demonstrations' scenarios")
    args = [(p, by_risk[p], feature_set) for p in risks]
    done = parallel_map(
        _learn_risk, args, workers, None if progress is None else lambda _, rec: progress(rec)
    )
    records = {rec["risk"]: rec for rec in done}
    return StyleLibrary(
        feature_set=feature_set,
        risks=tuple(risks),
        thetas=tuple(tuple(records[p]["theta"]) for p in risks),
        members=tuple(tuple(tuple(t) for t in records[p]["members"]) for p in risks),
        features=FeatureConfig(feature_set=feature_set),
        meta={
            **{k: v for k, v in (meta or {}).items() if k != "training_scenarios"},
            "per_risk": {
                str(p): {k: v for k, v in records[p].items() if k not in ("theta", "members")}
                for p in risks
            },
        },
        training_scenarios=tuple(scenarios),
    )


# ---------------------------------------------------------------------------- driver libraries
DRIVER_LIBRARY_KIND = "driver-library"
"""``kind`` of a :class:`DriverLibrary` file."""
TEMPERATURE_DEFAULT = 1.0
"""τ of a library whose build did not calibrate one."""
TEMPERATURE_RANGE = (0.1, 100.0)
"""The temperatures τ a driver library may hold. The log-likelihood is
−(S − min S)/(2 τ² s²) with s² the residual variance the best risk leaves (DESIGN §15):
τ = 1 treats the residuals as independent, the calibration chooses among 0.5 … 16. Below
0.1 one residual's worth of difference (S − min S = s²) already weighs e^−50: the posterior
is a point mass whatever the data (and τ² underflows to 0 for τ < 1e-162: NaN). Above 100
a whole demonstration's evidence (≈ 100 residuals, S − min S ≲ 100 s²) moves the
log-likelihood by at most 0.005: the posterior is the prior (and τ² overflows for
τ > 1e154)."""


def check_temperature(temperature: float) -> float:
    """Refuse a likelihood temperature outside :data:`TEMPERATURE_RANGE`.

    Returns:
        ``temperature`` as a float.

    Raises:
        LibraryError: not a number, or outside the range (the message says what it would do).
    """
    lo, hi = TEMPERATURE_RANGE
    if isinstance(temperature, bool) or not isinstance(temperature, int | float):
        raise LibraryError(f"temperature must be a number, got {temperature!r}")
    if not (math.isfinite(temperature) and lo <= temperature <= hi):
        raise LibraryError(
            f"temperature {temperature:g} is outside [{lo:g}, {hi:g}]: below, the posterior "
            "is a point mass whatever the data; above, it is the prior (calibrated "
            "temperatures lie in 0.5 … 16)"
        )
    return float(temperature)


@dataclass(frozen=True)
class DriverLibrary:
    """One driver cost shared by every risk, for identifying the risk (module docstring)."""

    style: DriverStyle
    """The learned weights (its ``risk`` is unused: identification infers it)."""
    risks: tuple[float, ...]
    """The risk grid of the training demonstrations (the grid estimates are reported on)."""
    temperature: float = TEMPERATURE_DEFAULT
    """τ of the likelihood (DESIGN §15), calibrated on the build's calibration demos."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Fit, timings, seeds and calibration (``library.json``'s other keys)."""

    def __post_init__(self) -> None:
        lo, hi = RISK_RANGE
        if not self.risks:
            raise LibraryError("the library is empty (no risk levels)")
        if list(self.risks) != sorted(set(self.risks)):
            raise LibraryError(f"library risks must be distinct and increasing, got {self.risks}")
        if not all(lo <= p <= hi for p in self.risks):
            raise LibraryError(f"library risks must lie in [{lo}, {hi}], got {self.risks}")
        _check_risk_count(self.risks)
        check_temperature(self.temperature)

    @property
    def fit_residual(self) -> float:
        """The residual RMS its learning left on the training demonstrations [σ_u units].

        ``fit.residual_rms`` of ``library.json``; 0 when the file does not record one.
        """
        fit = self.meta.get("fit")
        value = fit.get("residual_rms") if isinstance(fit, Mapping) else None
        if isinstance(value, bool) or not isinstance(value, int | float):
            return 0.0
        value = float(value)
        return value if math.isfinite(value) and value >= 0 else 0.0

    @property
    def noise_floor(self) -> float:
        """The residual RMS one driver of the class leaves under the style [σ_u units].

        √(fit_residual² + s_floor²) (DESIGN §15), s_floor =
        :data:`~drivestyle.irl.driver.driver_style.RESIDUAL_FLOOR`.

        The learned cost misses its own class by ``fit_residual`` (model error of the
        shared cost), and a driver of the class is never assumed to be fitted closer than
        s_floor (the likelihood's own floor); the two are independent, so they add in
        quadrature. Identification compares a demonstration's residual RMS at its best
        risk with this floor to say whether the style describes the driver at all.
        """
        return math.hypot(self.fit_residual, RESIDUAL_FLOOR)

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (``library.json``)."""
        return {
            "kind": DRIVER_LIBRARY_KIND,
            "version": LIBRARY_VERSION,
            "style": self.style.to_json(),
            "risks": list(self.risks),
            "temperature": self.temperature,
            **self.meta,
        }

    @classmethod
    def from_json(cls, raw: Mapping[str, Any]) -> DriverLibrary:
        """From :meth:`to_json`'s form.

        Raises:
            LibraryError: an unknown version, or a key is missing or invalid.
        """
        if raw.get("kind") != DRIVER_LIBRARY_KIND:
            raise LibraryError(f"not a driver library (kind {raw.get('kind')!r})")
        _check_version(raw)
        try:
            style = DriverStyle.from_json(raw["style"])
        except KeyError:
            raise LibraryError("no 'style'") from None
        except DriverStyleError as exc:
            raise LibraryError(str(exc)) from None
        risks = tuple(_number(p, "risk") for p in _get_list(raw, "risks"))
        temperature = _number(raw.get("temperature", TEMPERATURE_DEFAULT), "temperature")
        reserved = ("kind", "version", "style", "risks", "temperature")
        meta = {k: v for k, v in raw.items() if k not in reserved}
        return cls(style, risks, temperature, meta)


def load_any_library(path: str | Path) -> StyleLibrary | DriverLibrary:
    """Read a ``library.json`` of either kind (module docstring), validated whole.

    Raises:
        FileNotFoundError: no such file.
        LibraryError: malformed or inconsistent (one line naming the file and the problem).
    """
    path, raw = read_json(path, "library.json", LibraryError, "style library")
    try:
        if raw.get("kind") == DRIVER_LIBRARY_KIND:
            return DriverLibrary.from_json(raw)
        return StyleLibrary.from_json(raw)
    except LibraryError as exc:
        raise LibraryError(f"{path}: {exc}") from None


def load_driver_library(path: str | Path, purpose: str) -> DriverLibrary:
    """Read a driver ``library.json``; a paper-model one is refused.

    Args:
        path: the file or its folder.
        purpose: what needs the driver library, for the error (e.g. "prediction").

    Raises:
        FileNotFoundError: no such file.
        LibraryError: malformed, or a paper-model library (one line naming the file).
    """
    library = load_any_library(path)
    if not isinstance(library, DriverLibrary):
        raise LibraryError(
            f"{path} is a paper-model style library; {purpose} needs a driver library "
            "(build-style-library's default)"
        )
    return library


def learn_driver_library(
    demos_by_risk: Mapping[float, Sequence[Demonstration]],
    meta: dict[str, Any] | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> tuple[DriverLibrary, DriverFit]:
    """Learn the one cost shared by demonstrations of several risks (each risk known).

    Args:
        demos_by_risk: risk p → demonstrations of SMPC(p) (p within
            :data:`~drivestyle.irl.driver.driver_style.RISK_RANGE`).
        meta: stored in the library (seeds, scenarios, …).
        progress: called with (iteration, cost) by the learner.

    Returns:
        The library (temperature :data:`TEMPERATURE_DEFAULT` until calibrated) and the fit.

    Raises:
        ValueError: no demonstrations, fewer than two risks (:class:`LibraryError`), or a
            risk outside the model's range.
    """
    risks = sorted(float(p) for p in demos_by_risk)
    demos = [d for p in risks for d in demos_by_risk[p]]
    known = [p for p in risks for _ in demos_by_risk[p]]
    if not demos:
        raise ValueError("need demonstrations of at least one risk level")
    _check_risk_count(risks)  # before the learning, not after it
    # one LM run: the known risks pin the chance constraint, which removes most of the
    # local minima that a free risk brings (DESIGN §15)
    fit = learn_driver(demos, risks=known, progress=progress, screen=16, restarts=1)
    library = DriverLibrary(
        style=fit.style,
        risks=tuple(risks),
        meta={**(meta or {}), "fit": {k: v for k, v in fit.to_json().items() if k != "style"}},
    )
    return library, fit
