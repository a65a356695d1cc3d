"""A mining run's demonstrations identified by the amortized posterior (``--posterior``).

Beside each demonstration's exact row of ``styles.csv``
(:mod:`drivestyle.irl.identification.mining`), :func:`amortized_rows` gives its amortized
posterior (:func:`~drivestyle.irl.amortized.identify.identify_amortized_batch`: the whole
episode, in batched sampling calls, in this process — seconds for hundreds of episodes);
a demonstration that cannot be read is a failed row with a one-line error, never a
crashed job. :func:`amortized_table` is ``amortized.csv`` (one row per demonstration: per
parameter the posterior mean, median and 90 % interval, the risk p first) and
:func:`amortized_summary` its numbers for ``summary.json``: counts, the estimator's
checksum, each parameter's median posterior mean over the rows and, where the true risk is
known, the posterior mean's MAE and the 90 % intervals' coverage of it.

The table is written whole by every run given ``--posterior`` (it is cheap), so unlike
``styles.csv`` it is not resumed row by row.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import (
    LEVEL,
    SAMPLES,
    AmortizedStyle,
    identify_amortized_batch,
)
from drivestyle.irl.identification.mined_row import one_line
from drivestyle.irl.identification.mining import MiningTask
from drivestyle.irl.identification.mining_output import AMORTIZED_TABLE

__all__ = [
    "AMORTIZED_TABLE",
    "AmortizedRow",
    "amortized_rows",
    "amortized_summary",
    "amortized_table",
    "table_columns",
]


@dataclass(frozen=True)
class AmortizedRow:
    """One demonstration's amortized identification (a row of ``amortized.csv``)."""

    id: str
    """The demonstration's id (as in ``styles.csv``)."""
    style: AmortizedStyle | None
    """Its amortized posterior (None: failed)."""
    true_risk: float | None = None
    """The risk in the demonstration's metadata (simulated vehicles), else None."""
    error: str = ""
    """Why it failed (one line), empty when ok."""

    @property
    def status(self) -> str:
        """``ok`` or ``failed``."""
        return "ok" if self.style is not None else "failed"


def amortized_rows(
    tasks: Sequence[MiningTask],
    posterior: NeuralPosterior,
    samples: int = SAMPLES,
    seed: int = 0,
) -> list[AmortizedRow]:
    """Every task's demonstration identified by the amortized posterior (module docstring).

    Args:
        tasks: the mining run's (id, source, demonstration or its path).
        posterior: the estimator.
        samples: draws per demonstration.
        seed: seeds the draws (deterministic given the tasks in order).

    Returns:
        One row per task, in order.
    """
    demos: dict[int, Demonstration] = {}
    failed: dict[int, str] = {}
    for i, (_, _, demo) in enumerate(tasks):
        if isinstance(demo, Demonstration):
            demos[i] = demo
            continue
        try:
            demos[i] = load_demonstration(os.fspath(demo))
        except Exception as exc:  # the demonstration's row, never the job's
            where = os.fspath(demo)
            said = str(exc) if where in str(exc) else f"{where}: {exc}"
            failed[i] = one_line(f"{type(exc).__name__}: {said}")
    ok = sorted(demos)
    found = identify_amortized_batch(posterior, [demos[i] for i in ok], samples=samples, seed=seed)
    styles = dict(zip(ok, found, strict=True))
    rows = []
    for i, (demo_id, _, _) in enumerate(tasks):
        risk = demos[i].meta.get("risk") if i in demos else None
        true = None if risk is None else float(risk)
        rows.append(AmortizedRow(demo_id, styles.get(i), true, failed.get(i, "")))
    return rows


def table_columns(names: Sequence[str]) -> list[str]:
    """``amortized.csv``'s header for an estimator's parameters ``names``."""
    per = [f"{n}_{q}" for n in names for q in ("mean", "median", "q05", "q95")]
    return ["id", "status", "error", "true_risk", "samples_observed", *per]


def amortized_table(rows: Sequence[AmortizedRow], names: Sequence[str]) -> str:
    """``amortized.csv``'s text (missing values empty; numbers as Python writes them)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(table_columns(names))
    for r in rows:
        cells: list[Any] = [r.id, r.status, r.error, "" if r.true_risk is None else r.true_risk]
        if r.style is None:
            cells += [""] * (1 + 4 * len(names))
        else:
            s = r.style
            cells.append(s.samples_observed)
            for d in range(len(names)):
                cells += [float(s.mean[d]), float(s.median[d]), float(s.lo[d]), float(s.hi[d])]
        writer.writerow(cells)
    return out.getvalue()


def amortized_summary(rows: Sequence[AmortizedRow], names: Sequence[str]) -> dict[str, Any]:
    """The table's numbers (module docstring) as a JSON-ready dict.

    Returns:
        ``n``, ``n_ok``, ``n_failed``, ``estimator_sha256``, ``samples``, ``level``,
        ``median_posterior_mean`` (parameter → the median over ok rows, in order) and
        ``n_with_truth`` with, where it is > 0 and the estimator infers ``risk``,
        ``risk_mae_posterior_mean`` and ``risk_interval_coverage``.
    """
    ok = [r for r in rows if r.style is not None]
    styles = [r.style for r in ok if r.style is not None]
    means = np.array([s.mean for s in styles]) if styles else np.zeros((0, len(names)))
    out: dict[str, Any] = {
        "n": len(rows),
        "n_ok": len(ok),
        "n_failed": len(rows) - len(ok),
        "estimator_sha256": styles[0].estimator_sha256 if styles else None,
        "samples": int(styles[0].draws.shape[0]) if styles else None,
        "level": LEVEL,
        "median_posterior_mean": {
            n: float(np.median(means[:, d])) if styles else None for d, n in enumerate(names)
        },
    }
    known = [r for r in ok if r.true_risk is not None and r.style is not None]
    out["n_with_truth"] = len(known)
    if known and "risk" in names:
        d = list(names).index("risk")
        true = np.array([r.true_risk for r in known], float)
        mean = np.array([r.style.mean[d] for r in known if r.style is not None])
        lo = np.array([r.style.lo[d] for r in known if r.style is not None])
        hi = np.array([r.style.hi[d] for r in known if r.style is not None])
        out["risk_mae_posterior_mean"] = float(np.mean(np.abs(mean - true)))
        out["risk_interval_coverage"] = float(np.mean((lo <= true) & (true <= hi)))
    return out
