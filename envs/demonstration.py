"""The demonstration type: sampled EV and TV trajectories of one episode (docs/DESIGN.md §7).

On disk a demonstration is an ``.npz`` with arrays ``t`` (n,), ``ev`` (n, 4), ``tv``
(n, 4) as [x, y, φ, v] in SI units, ``u`` (n−1, 2) as [a, δ], and ``meta``: a JSON string
with at least the scenario's parameters (``meta["scenario"]``) and, for generated
demonstrations, the SMPC's risk level ``meta["risk"]`` in (0, 1). Optional keys: ``others``
(n, m, 4), the further surrounding vehicles; ``origin``, a 0-d string, ``"simulated"`` or
``"recorded"`` (:attr:`Demonstration.origin`); ``observed`` (1 + m, n) bool, which
surrounding vehicle's states are recorded samples (:attr:`Demonstration.observed`).
:func:`save_demonstration` writes ``origin`` always and ``observed`` when the demonstration
carries one. A file written before these keys loads as before: its origin is
``"recorded"`` when its ``meta`` holds an ``episode_id`` (what the extraction wrote) and
``"simulated"`` otherwise, and its mask is None (for a recorded episode
:func:`drivestyle.recorded.observed.observed_mask` derives it by the fallback rule).

Construction checks the arrays' form (shapes, finiteness, time order);
:func:`~drivestyle.envs.plausibility.check_plausible` checks the physics against the model
every learner and identifier assumes (one lane change to +y, forward driving, lateral speed
within what the heading allows, every step within a vehicle's reach of speed and
acceleration, lanes that fit the data, no vehicle overlapping the EV at any time): the
checks and their thresholds live in :mod:`drivestyle.envs.plausibility` and are re-exported
here.
"""

from __future__ import annotations

import json
import math
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

import numpy as np

from drivestyle.envs.plausibility import (
    ACCEL_MAX_MPS2,
    BACKWARD_RATE_MPS,
    BACKWARD_SPEED_MPS,
    HEADING_FACTOR,
    LANE_TOLERANCE,
    LANE_WIDTH_RANGE_M,
    LATERAL_NOISE_MPS,
    OVERLAP_SHRINK,
    SPEED_CHECK_MIN_M,
    SPEED_RATIO_MAX,
    SPEED_TOLERANCE_MPS,
    STANDING_DRIFT_M,
    STANDING_SPEED_MPS,
    check_plausible,
    plausibility_problems,
    step_problems,
)
from drivestyle.envs.scenario import ScenarioConfig

__all__ = [
    "ACCEL_MAX_MPS2",
    "BACKWARD_RATE_MPS",
    "BACKWARD_SPEED_MPS",
    "HEADING_FACTOR",
    "LANE_TOLERANCE",
    "LANE_WIDTH_RANGE_M",
    "LATERAL_NOISE_MPS",
    "OVERLAP_SHRINK",
    "REQUIRED",
    "SPEED_CHECK_MIN_M",
    "SPEED_RATIO_MAX",
    "SPEED_TOLERANCE_MPS",
    "STANDING_DRIFT_M",
    "STANDING_SPEED_MPS",
    "Demonstration",
    "DemonstrationError",
    "check_plausible",
    "load_demonstration",
    "plausibility_problems",
    "save_demonstration",
    "step_problems",
]

REQUIRED = ("t", "ev", "tv", "u")

Origin = Literal["simulated", "recorded"]
"""Where a demonstration's states come from (:attr:`Demonstration.origin`)."""
ORIGINS: tuple[Origin, ...] = get_args(Origin)
"""The origins a demonstration may have."""


class DemonstrationError(ValueError):
    """A demonstration (array set or file) is malformed; the message names the problem."""


@dataclass(frozen=True)
class Demonstration:
    """One recorded or generated lane change, sampled at times ``t``.

    Arrays are validated on construction (shapes, finiteness, strictly increasing time,
    at least 3 samples) and stored as read-only float64 copies; a ``meta["risk"]`` must lie
    in (0, 1), since it is read as the true risk. The physics is checked separately
    (:func:`check_plausible`), so that any demonstration can still be loaded and drawn.
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
    origin: Origin = "simulated"
    """Where the states come from: ``"simulated"`` (an environment's rollout, an SMPC
    demonstration, a tracker's view of one) or ``"recorded"`` (a lane change extracted
    from tracks, :func:`drivestyle.recorded.episodes.extract_episodes`: recorded traffic,
    or a simulator's traffic written as tracks, which is then seen as recorded traffic is).
    The recorded views read it (:func:`drivestyle.recorded.real_data.is_recorded`)."""
    observed: np.ndarray | None = None
    """Per surrounding vehicle (rows in :attr:`vehicles` order: the TV, then ``others``) and
    sample, whether its state is a recorded sample (True) or the extraction's
    constant-velocity continuation before the vehicle's first or after its last recorded
    sample (False), shape (1 + m, n) bool. None: not carried — every state of a simulated
    demonstration is observed; for a recorded one (a file written before the mask was),
    :func:`drivestyle.recorded.observed.observed_mask` derives it by the fallback rule.
    Like ``u``, it belongs to the states: a transformation that changes which vehicle is
    which carries it along (or passes None)."""

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
        if self.origin not in ORIGINS:
            raise DemonstrationError(
                f"origin must be one of {', '.join(map(repr, ORIGINS))}, got {self.origin!r}"
            )
        if self.observed is not None:
            mask = np.array(self.observed)
            if mask.dtype != bool:
                raise DemonstrationError(
                    f"'observed' must be a boolean array (True: a recorded sample), got dtype "
                    f"{mask.dtype}"
                )
            if mask.shape != (1 + others.shape[1], n):
                raise DemonstrationError(
                    f"'observed' must have shape (1 + m, n) = ({1 + others.shape[1]}, {n}), one "
                    f"row per surrounding vehicle (TV, then others), got {mask.shape}"
                )
            mask.setflags(write=False)
            object.__setattr__(self, "observed", mask)
        if not isinstance(self.meta, dict):
            raise DemonstrationError(f"meta must be a dict, got {type(self.meta).__name__}")
        risk = self.meta.get("risk")
        if risk is not None:
            # the risk in the metadata is read as the true risk (mining, identification)
            if not isinstance(risk, (int, float, np.integer, np.floating)) or isinstance(
                risk, bool
            ):
                raise DemonstrationError(f"meta 'risk' must be a number in (0, 1), got {risk!r}")
            if not (math.isfinite(risk) and 0 < risk < 1):
                raise DemonstrationError(
                    f"meta 'risk' must lie in (0, 1) (the SMPC's risk level p), got {risk}"
                )

    @property
    def vehicles(self) -> np.ndarray:
        """Every surrounding vehicle, TV first: shape (n, 1 + m, 4)."""
        return np.concatenate([self.tv[:, None, :], self.others], axis=1)

    @property
    def other_vehicles(self) -> np.ndarray:
        """``others`` as validated: shape (n, m, 4), m = 0 in the single-TV setting."""
        if self.others is None:  # __post_init__ stores an (n, 0, 4) array for None
            raise DemonstrationError("'others' is None: the demonstration was not validated")
        return self.others

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
    others = demo.other_vehicles
    extra: dict[str, np.ndarray] = {"others": others} if others.shape[1] else {}
    extra["origin"] = np.array(demo.origin)
    if demo.observed is not None:
        extra["observed"] = demo.observed
    np.savez(
        path,
        t=demo.t,
        ev=demo.ev,
        tv=demo.tv,
        u=demo.u,
        meta=np.array(json.dumps(demo.meta)),
        allow_pickle=True,  # numpy's default, named so that **extra cannot stand for it
        **extra,
    )
    return path


def _not_npz(path: Path) -> str:
    """What a file is when it is not a zip archive (an .npz is one), else ''.

    ``np.load`` reads a file that is neither a zip nor an .npy as a pickle and refuses it
    with "allow_pickle=False": a user who named a text file ``.npz`` learns nothing from it.
    """
    with path.open("rb") as f:
        head = f.read(4096)
    if head.startswith(b"PK"):
        return ""
    if not head:
        return "empty"
    if head.startswith(b"\x93NUMPY"):
        return "a single .npy array"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not only a character cut at the 4 KB boundary
            return "a binary file of another kind"
    first = head.splitlines()[0][:40].decode("utf-8", "replace") if head.strip() else ""
    return f"a text file (it begins {first!r})" if first else "a text file"


def load_demonstration(path: str | Path) -> Demonstration:
    """Read and validate a demonstration file.

    A file without ``origin`` (written before the key was) is recorded when its ``meta``
    holds an ``episode_id`` (the extraction's) and simulated otherwise; one without
    ``observed`` carries no mask (module docstring).

    Args:
        path: an ``.npz`` written by :func:`save_demonstration` (``meta``, ``others``,
            ``origin`` and ``observed`` are optional).

    Returns:
        The demonstration.

    Raises:
        FileNotFoundError: no such file.
        DemonstrationError: a folder instead of a file, a file of another kind (text, an
            .npy, empty: said as such), an unreadable archive (truncated, failed CRC,
            pickled objects), missing arrays, wrong shapes, NaNs,
            non-increasing times, fewer than 3 samples, a metadata risk outside (0, 1), an
            unknown origin or an ``observed`` mask of another shape or not boolean; the
            message starts with the path.
    """
    path = Path(path)
    if path.is_dir():
        held = len(list(path.glob("*.npz")))
        raise DemonstrationError(
            f"{path} is a folder, not a demonstration file: pass its .npz files (it holds "
            f"{held or 'none'}); a demonstration is one .npz with arrays "
            f"{', '.join(REQUIRED)} and meta"
        )
    if not path.is_file():
        raise FileNotFoundError(f"demonstration file not found: {path}")
    kind = _not_npz(path)
    if kind:
        raise DemonstrationError(
            f"{path} is {kind}, not a demonstration: a demonstration is an .npz archive with "
            f"arrays {', '.join(REQUIRED)} and meta (written by drivestyle, e.g. "
            "extract-episodes or build-style-library)"
        )
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in REQUIRED if k not in data.files]
            if missing:
                raise DemonstrationError(
                    f"{path}: missing array(s) {missing}; a demonstration needs {list(REQUIRED)}"
                )
            arrays: dict[str, Any] = {k: data[k] for k in REQUIRED}
            if "others" in data.files:
                arrays["others"] = data["others"]
            meta = json.loads(str(data["meta"])) if "meta" in data.files else {}
            if "origin" in data.files:
                arrays["origin"] = str(data["origin"])
            else:  # a file written before the origin was: the extraction's metadata says
                arrays["origin"] = "recorded" if "episode_id" in meta else "simulated"
            if "observed" in data.files:
                arrays["observed"] = data["observed"]
    except DemonstrationError:
        raise
    except (
        OSError,
        ValueError,
        EOFError,
        TypeError,
        KeyError,
        zipfile.BadZipFile,
        zlib.error,
    ) as exc:
        # a truncated or CRC-corrupt archive raises zipfile/zlib errors, an object array
        # ValueError, a truncated member EOFError: all mean "this file is not one"
        raise DemonstrationError(
            f"{path}: not a readable demonstration ({type(exc).__name__}: {exc})"
        ) from None
    try:
        return Demonstration(**arrays, meta=meta)
    except DemonstrationError as exc:
        raise DemonstrationError(f"{path}: {exc}") from None
