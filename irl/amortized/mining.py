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

With ``--check`` each identified demonstration is also checked for fit
(:func:`checked_rows`: the posterior-predictive check of
:mod:`~drivestyle.irl.amortized.predictive_check` with its posterior draws, on worker
processes — one replicate per draw, the costly part): the table gains the verdict, the
failing statistics and each statistic's p-value, the summary the share inside the class
and how often each statistic failed.

The table is written whole by every run given ``--posterior``, so unlike ``styles.csv``
it is not resumed row by row.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.amortized.behaviour import STATISTICS
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import (
    LEVEL,
    SAMPLES,
    AmortizedStyle,
    identify_amortized_batch,
)
from drivestyle.irl.amortized.predictive_check import PredictiveCheck, predictive_checks
from drivestyle.irl.identification.mined_row import one_line
from drivestyle.irl.identification.mining import MiningTask
from drivestyle.irl.identification.mining_output import AMORTIZED_TABLE

__all__ = [
    "AMORTIZED_TABLE",
    "AmortizedRow",
    "amortized_rows",
    "amortized_summary",
    "amortized_table",
    "checked_rows",
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
    check: PredictiveCheck | None = None
    """Its posterior-predictive check with the draws of ``style`` (None: not checked)."""

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


def checked_rows(
    rows: Sequence[AmortizedRow],
    tasks: Sequence[MiningTask],
    seed: int = 0,
    workers: int = 1,
    on_result: Callable[[int, Any], None] | None = None,
) -> list[AmortizedRow]:
    """The identified rows with their posterior-predictive checks (module docstring).

    Each ok row's demonstration is checked with its own posterior draws (as many
    replicates as draws: at least :func:`~drivestyle.irl.amortized.predictive_check.
    min_draws`); a failed row stays as it is.

    Args:
        rows: :func:`amortized_rows` of ``tasks``.
        tasks: the mining run's tasks (the demonstrations are read again from them).
        seed: the checks' first seed (row i of the ok ones: ``seed + i``).
        workers: worker processes.
        on_result: called as each check finishes (a progress bar).

    Returns:
        The rows in order, ok ones with ``check`` set.
    """
    ok = [i for i, r in enumerate(rows) if r.style is not None]
    demos = []
    for i in ok:
        demo = tasks[i][2]
        demos.append(
            demo if isinstance(demo, Demonstration) else load_demonstration(os.fspath(demo))
        )
    draws = [rows[i].style.draws for i in ok if rows[i].style is not None]  # type: ignore[union-attr]
    checks = predictive_checks(demos, draws, seed=seed, workers=workers, on_result=on_result)
    out = list(rows)
    for i, check in zip(ok, checks, strict=True):
        out[i] = dataclasses.replace(rows[i], check=check)
    return out


def table_columns(names: Sequence[str], checked: bool = False) -> list[str]:
    """``amortized.csv``'s header for an estimator's parameters ``names`` (and the checks)."""
    per = [f"{n}_{q}" for n in names for q in ("mean", "median", "q05", "q95")]
    check = ["check", "failing", *(f"p_{s}" for s in STATISTICS)] if checked else []
    return ["id", "status", "error", "true_risk", "samples_observed", *per, *check]


def amortized_table(rows: Sequence[AmortizedRow], names: Sequence[str]) -> str:
    """``amortized.csv``'s text (missing values empty; numbers as Python writes them)."""
    checked = any(r.check is not None for r in rows)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(table_columns(names, checked))
    for r in rows:
        cells: list[Any] = [r.id, r.status, r.error, "" if r.true_risk is None else r.true_risk]
        if r.style is None:
            cells += [""] * (1 + 4 * len(names))
        else:
            s = r.style
            cells.append(s.samples_observed)
            for d in range(len(names)):
                cells += [float(s.mean[d]), float(s.median[d]), float(s.lo[d]), float(s.hi[d])]
        if checked:
            c = r.check
            if c is None:
                cells += [""] * (2 + len(STATISTICS))
            else:
                verdict = "inside" if c.inside else "outside"
                cells += [verdict, " ".join(c.failing), *(c.p_values[n] for n in STATISTICS)]
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
    checks = [r.check for r in rows if r.check is not None]
    if checks:
        inside = sum(c.inside for c in checks)
        out["check"] = {
            "n_checked": len(checks),
            "n_inside": inside,
            "share_inside": inside / len(checks),
            "alpha": checks[0].alpha,
            "draws": checks[0].k,
            "failing": {n: sum(n in c.failing for c in checks) for n in STATISTICS},
            "seconds_per_check_median": float(np.median([c.seconds for c in checks])),
        }
    return out
