"""The demonstration type: sampled EV and TV trajectories of one episode (docs/DESIGN.md §7).

On disk a demonstration is an ``.npz`` with arrays ``t`` (n,), ``ev`` (n, 4), ``tv``
(n, 4) as [x, y, φ, v] in SI units, ``u`` (n−1, 2) as [a, δ], and ``meta``: a JSON string
with at least the scenario's parameters (``meta["scenario"]``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from drivestyle.envs.scenario import ScenarioConfig

__all__ = ["Demonstration", "DemonstrationError", "load_demonstration", "save_demonstration"]

REQUIRED = ("t", "ev", "tv", "u")


class DemonstrationError(ValueError):
    """A demonstration (array set or file) is malformed; the message names the problem."""


@dataclass(frozen=True)
class Demonstration:
    """One recorded or generated lane change, sampled at times ``t``.

    Arrays are validated on construction (shapes, finiteness, strictly increasing time,
    at least 3 samples) and stored as read-only float64 copies.
    """

    t: np.ndarray
    """Sample times, shape (n,) [s], strictly increasing."""
    ev: np.ndarray
    """EV states [x, y, φ, v], shape (n, 4) [m, m, rad, m/s]."""
    tv: np.ndarray
    """TV states [x, y, φ, v], shape (n, 4)."""
    u: np.ndarray
    """EV inputs [a, δ] applied over [t_i, t_{i+1}], shape (n−1, 2) [m/s², rad]."""
    meta: dict[str, Any] = field(default_factory=dict)
    """Free-form metadata; ``meta["scenario"]`` holds the scenario's fields."""
    others: np.ndarray | None = None
    """States of the further surrounding vehicles (traffic, besides the TV), shape
    (n, m, 4); None or m = 0: the single-TV setting (files without it load as m = 0)."""

    def __post_init__(self) -> None:
        arrays = {}
        for name in REQUIRED:
            try:
                a = np.array(getattr(self, name), dtype=float)
            except (TypeError, ValueError) as exc:
                raise DemonstrationError(f"array '{name}' is not numeric: {exc}") from None
            arrays[name] = a
        t = arrays["t"]
        if t.ndim != 1:
            raise DemonstrationError(f"'t' must have shape (n,), got {t.shape}")
        n = t.shape[0]
        if n < 3:
            raise DemonstrationError(f"a demonstration needs at least 3 samples, got {n}")
        expected = {"ev": (n, 4), "tv": (n, 4), "u": (n - 1, 2)}
        for name, shape in expected.items():
            if arrays[name].shape != shape:
                raise DemonstrationError(
                    f"'{name}' must have shape {shape} for n={n} samples, got {arrays[name].shape}"
                )
        for name, a in arrays.items():
            bad = ~np.isfinite(a)
            if bad.any():
                idx = np.argwhere(bad)[0]
                raise DemonstrationError(
                    f"'{name}' contains NaN or inf ({int(bad.sum())} entries, first at index "
                    f"{tuple(int(i) for i in idx)})"
                )
        dt = np.diff(t)
        if np.any(dt <= 0):
            i = int(np.argmax(dt <= 0))
            raise DemonstrationError(
                f"'t' must be strictly increasing; t[{i}]={t[i]} >= t[{i + 1}]={t[i + 1]}"
            )
        others = np.zeros((n, 0, 4)) if self.others is None else self.others
        try:
            others = np.array(others, dtype=float)
        except (TypeError, ValueError) as exc:
            raise DemonstrationError(f"array 'others' is not numeric: {exc}") from None
        if others.ndim != 3 or others.shape[0] != n or others.shape[2] != 4:
            raise DemonstrationError(f"'others' must have shape ({n}, m, 4), got {others.shape}")
        if not np.all(np.isfinite(others)):
            raise DemonstrationError("'others' contains NaN or inf")
        arrays["others"] = others
        for name, a in arrays.items():
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        if not isinstance(self.meta, dict):
            raise DemonstrationError(f"meta must be a dict, got {type(self.meta).__name__}")

    @property
    def vehicles(self) -> np.ndarray:
        """Every surrounding vehicle, TV first: shape (n, 1 + m, 4)."""
        return np.concatenate([self.tv[:, None, :], self.others], axis=1)

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def scenario(self) -> ScenarioConfig:
        """The scenario stored in ``meta["scenario"]``.

        Raises:
            DemonstrationError: no (valid) scenario in the metadata.
        """
        raw = self.meta.get("scenario")
        if not isinstance(raw, dict):
            raise DemonstrationError("demonstration metadata has no 'scenario' entry")
        try:
            return ScenarioConfig(**raw)
        except (TypeError, ValueError) as exc:
            raise DemonstrationError(f"invalid scenario in demonstration metadata: {exc}") from None


def save_demonstration(demo: Demonstration, path: str | Path) -> Path:
    """Write a demonstration to ``path`` (.npz).

    Args:
        demo: the demonstration.
        path: output file; parent folders are created.

    Returns:
        The path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    extra = {"others": demo.others} if demo.others.shape[1] else {}
    np.savez(
        path,
        t=demo.t,
        ev=demo.ev,
        tv=demo.tv,
        u=demo.u,
        meta=np.array(json.dumps(demo.meta)),
        **extra,
    )
    return path


def load_demonstration(path: str | Path) -> Demonstration:
    """Read and validate a demonstration file.

    Args:
        path: an ``.npz`` written by :func:`save_demonstration` (``meta`` and ``others``
            are optional).

    Returns:
        The demonstration.

    Raises:
        FileNotFoundError: no such file.
        DemonstrationError: unreadable file, missing arrays, wrong shapes, NaNs,
            non-increasing times or fewer than 3 samples.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"demonstration file not found: {path}")
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in REQUIRED if k not in data.files]
            if missing:
                raise DemonstrationError(
                    f"{path}: missing array(s) {missing}; a demonstration needs {list(REQUIRED)}"
                )
            arrays = {k: data[k] for k in REQUIRED}
            if "others" in data.files:
                arrays["others"] = data["others"]
            meta = json.loads(str(data["meta"])) if "meta" in data.files else {}
    except DemonstrationError:
        raise
    except (OSError, ValueError, json.JSONDecodeError) as exc:
        raise DemonstrationError(f"{path}: not a readable demonstration file ({exc})") from None
    try:
        return Demonstration(**arrays, meta=meta)
    except DemonstrationError as exc:
        raise DemonstrationError(f"{path}: {exc}") from None
