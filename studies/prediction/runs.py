"""Another prediction run read back: the records that calibrate the prediction regions.

``evaluate-prediction --regions-from`` reads another split's ``prediction_eval.json``
(:func:`read_prediction_run`, every record it uses checked) and takes its recorded records
(:func:`calibration_records`, refusing a run that calibrates no region) for
:func:`~drivestyle.prediction.regions.region_rates` and, per episode kind,
:func:`~drivestyle.prediction.regions.kind_region_rates`. A run written before the kinds
were has records without ``kind`` and ``stop_and_go``: lane changes, not stop-and-go.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivestyle.prediction.regions import REGION_LEVEL, region_rates
from drivestyle.recorded.kinds import EPISODE_KINDS, STOP_AND_GO
from drivestyle.studies.prediction.summaries import SIMULATED

__all__ = [
    "PredictionRun",
    "calibration_records",
    "read_prediction_run",
]


@dataclass(frozen=True)
class PredictionRun:
    """The records of a ``prediction_eval.json`` (:func:`read_prediction_run`)."""

    path: Path
    split: str | None
    """The split its recorded episodes were of (None: not said)."""
    records: tuple[Mapping[str, Any], ...]
    """Its records, each checked (``set``, ``t_obs_s``, ``horizon_s``, ``fde_m``)."""


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def read_prediction_run(path: str | Path) -> PredictionRun:
    """A ``prediction_eval.json`` (or the run folder holding one), every record checked.

    Only what another run reads of it is checked (the region's calibration,
    :func:`region_rates`): each record's ``set`` (a name), ``t_obs_s`` and ``horizon_s``
    (finite, > 0) and ``fde_m`` (method → a distance >= 0, or null / NaN where the method
    gave none); where present, ``kind`` (a name of
    :data:`~drivestyle.recorded.kinds.EPISODE_KINDS`) and ``stop_and_go`` (true or false).

    Raises:
        FileNotFoundError: no such file (or no ``prediction_eval.json`` in the folder).
        ValueError: not UTF-8 JSON, no list of records, or a record as above (the message
            names the file, the record and the field with its value).
    """
    path = Path(path)
    if path.is_dir():
        path = path / "prediction_eval.json"
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not JSON ({exc})") from None
    records = raw.get("records") if isinstance(raw, dict) else None
    if not isinstance(records, list):
        raise ValueError(f"{path}: not a prediction_eval.json (no records)")
    for i, r in enumerate(records):
        where = f"{path}: record {i}"
        if not isinstance(r, dict):
            raise ValueError(f"{where} is not an object: not a prediction_eval.json")
        missing = [k for k in ("set", "t_obs_s", "horizon_s", "fde_m") if k not in r]
        if missing:
            raise ValueError(f"{where} has no {', '.join(missing)}: not a prediction_eval.json")
        if not (isinstance(r["set"], str) and r["set"]):
            raise ValueError(f"{where}, set: {r['set']!r} is not a set's name")
        for key in ("t_obs_s", "horizon_s"):
            if not (_finite(r[key]) and r[key] > 0):
                raise ValueError(f"{where}, {key}: {r[key]!r} is not a time > 0 s")
        if not isinstance(r["fde_m"], dict):
            raise ValueError(f"{where}, fde_m: {r['fde_m']!r} is not method → distance")
        for method, fde in r["fde_m"].items():
            given = fde is not None and not (isinstance(fde, float) and math.isnan(fde))
            if given and not (_finite(fde) and fde >= 0):
                raise ValueError(f"{where}, fde_m.{method}: {fde!r} is not a distance >= 0 m")
        if "kind" in r and r["kind"] not in EPISODE_KINDS:
            raise ValueError(
                f"{where}, kind: {r['kind']!r} is not an episode kind ({', '.join(EPISODE_KINDS)})"
            )
        if STOP_AND_GO in r and not isinstance(r[STOP_AND_GO], bool):
            raise ValueError(f"{where}, {STOP_AND_GO}: {r[STOP_AND_GO]!r} is not true or false")
    split = raw.get("split")
    return PredictionRun(path, split if isinstance(split, str) else None, tuple(records))


def calibration_records(
    run: PredictionRun, t_obs: Sequence[float], level: float = REGION_LEVEL
) -> list[Mapping[str, Any]]:
    """The recorded records of ``run`` that calibrate regions at every ``t_obs``.

    A region needs records of recorded episodes (simulated ones are not calibrated on),
    at least ⌈(n + 1)·level⌉ ≤ n of them at each observed time (:func:`region_rates`):
    otherwise the run would report no region, without a word.

    Raises:
        ValueError: no recorded record, or too few at an observed time (the message says
            what the run has).
    """
    recorded = [r for r in run.records if r["set"] != SIMULATED]
    if not recorded:
        had = f"its {len(run.records)} records are all simulated" if run.records else "no record"
        raise ValueError(
            f"{run.path} has no record of a recorded episode ({had}): calibrate on a run that "
            "predicted recorded episodes"
        )
    rates = region_rates(recorded, level)
    per_time: dict[float, int] = {}
    for r in recorded:
        per_time[float(r["t_obs_s"])] = per_time.get(float(r["t_obs_s"]), 0) + 1
    missing = [t for t in t_obs if not any(key[1] == float(t) for key in rates)]
    if missing:
        has = ", ".join(f"{n} at {t:g} s" for t, n in sorted(per_time.items()))
        need = next(n for n in itertools.count(1) if math.ceil((n + 1) * level) <= n)
        raise ValueError(
            f"{run.path} calibrates no {level * 100:g} % region at t_obs "
            f"{', '.join(f'{t:g}' for t in missing)} s: a region needs at least {need} recorded "
            f"records of its t_obs, the run has {has}"
        )
    return recorded
