"""Styles of a whole population: per demonstration a personal style and an identified risk.

:class:`Miner` (a stateful shell holding one style library) turns one demonstration into one
:class:`MinedRow` (a row of ``styles.csv``, columns :data:`COLUMNS`): the personal style
learned by ME-IRL (θ normalised per group, fit errors), the identified risk with its 90 %
interval (:func:`drivestyle.irl.identification.posterior.identify`) and timings. A demonstration
that cannot be mined (an unreadable file, malformed data, no lane change, a solver failure, any
error at all) becomes a row with ``status = "failed"`` and a one-line error naming the file,
never a crashed job. Its ``failure_kind`` says whose failure it is: "data" (the
demonstration's: final) or "infrastructure" (a worker process that died or was killed, out
of memory: a resumed run mines it again).

Engines run the rows in parallel and hand each finished row to a callback (so callers can
write them as they come and resume after an interruption):

- ``local`` (default): worker processes on this machine
  (:func:`drivestyle.common.parallel.parallel_map`), one :class:`Miner` per worker; a
  demonstration whose worker dies is tried again alone, and if that worker dies too it is a
  failed row naming the cause (the exit status or signal), so neither loses the job;
- ``ray``: Ray actors, one :class:`Miner` each, on ``ray.init()`` here or a cluster at
  ``address`` (reached within a timeout, else a one-line error); an actor that dies is
  restarted and its task retried (:data:`RAY_TASK_RETRIES` times, then the demonstration
  is a failed row), so a killed worker does not lose the job and a demonstration that kills
  every worker does not stall it. Ray is an optional extra (``pip install -e '.[ray]'``).

Both engines compute identical rows (timings aside): the work is deterministic.

The output folder of a resumable run (fingerprint, lock, repair) is
:mod:`drivestyle.irl.identification.mining_output`.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import PurePath
from typing import Any

import numpy as np

from drivestyle.common.parallel import EXIT_TERMINATED, parallel_map, sigterm_stops_the_job
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.driver.driver_style import reproduce
from drivestyle.irl.identification.library import DriverLibrary, StyleLibrary
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.identification.result import INTERVAL_MASS, Identification
from drivestyle.irl.identification.verdict import (
    ENTERS_REGION,
    INFORMATIVE,
    OUT_OF_CLASS,
    VERDICT_LABELS,
    recorded_verdict_label,
)
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL
from drivestyle.recorded.real_data import recorded_view

__all__ = [
    "COLUMNS",
    "CONNECT_TIMEOUT_S",
    "ENGINES",
    "FAILURE_KINDS",
    "LABEL_COLUMNS",
    "LEGACY_COLUMNS",
    "NONNEGATIVE_COLUMNS",
    "PRE_LABEL_COLUMNS",
    "PRE_VERDICT_COLUMNS",
    "RAY_TASK_RETRIES",
    "READABLE_HEADERS",
    "RISK_COLUMNS",
    "TIMING_COLUMNS",
    "VERDICT_COLUMNS",
    "MinedRow",
    "Miner",
    "MiningTask",
    "RowError",
    "mine",
    "summary_numbers",
    "verdict_numbers",
]

ENGINES = ("local", "ray")
STATUSES = ("ok", "failed")
FAILURE_KINDS = ("data", "infrastructure")
"""Why a row failed: its demonstration (final: mining it again fails again) or the machinery
(a worker process that died or was killed, memory; retried when the run is resumed)."""
TIMING_COLUMNS = ("learn_s", "identify_s")
"""Columns that differ between runs (wall times)."""
MAX_ERROR_CHARS = 500
"""A failed row's error is one line of at most this many characters."""
RAY_TASK_RETRIES = 2
"""Retries of a demonstration whose Ray worker died (then it is a failed row): a worker
killed once loses nothing, and a demonstration that kills every worker cannot stall the job."""
CONNECT_TIMEOUT_S = 10.0
"""Time to reach a Ray head at ``address`` before giving up [s] (Ray itself retries for
minutes without a word)."""

MiningTask = tuple[str, str, Demonstration | str | os.PathLike[str]]
"""(id, source, demonstration or the path of its ``.npz``)."""


def _one_line(text: str) -> str:
    """``text`` on one line (whitespace runs collapsed), cut to :data:`MAX_ERROR_CHARS`."""
    flat = " ".join(text.split())
    return flat if len(flat) <= MAX_ERROR_CHARS else flat[: MAX_ERROR_CHARS - 1] + "…"


class RowError(ValueError):
    """A ``styles.csv`` row that is no mined row, and where: the column and its value.

    A table reader names the file and the row around it
    (:func:`drivestyle.irl.identification.mining_output.read_table`); a resumed run drops the row
    and mines it again.

    Args:
        problem: what is wrong, in words (naming the value).
        column: the column at fault (None: the row as a whole, e.g. a torn row).
        value: its value.
        row_id: the row's id, when known (the message starts with it).
    """

    def __init__(
        self, problem: str, column: str | None = None, value: Any = None, row_id: str = ""
    ) -> None:
        super().__init__(f"row {row_id}: {problem}" if row_id else problem)
        self.problem = problem
        self.column = column
        self.value = value


RISK_COLUMNS = ("true_risk", "risk_estimate", "risk_lo", "risk_hi", "risk_mean")
"""Columns that hold a risk level p, in (0, 1) wherever present."""
NONNEGATIVE_COLUMNS = (
    "rmse_y_m", "rmse_xy_m", "learn_s", "identify_s",
    "residual_rms", "noise_floor", "kl_nats", "interval_width_ratio",
)  # fmt: skip
"""Columns of errors, times, widths and divergences: finite and >= 0 wherever present."""


def _opt_float(text: str, column: str) -> float | None:
    if text == "":
        return None
    try:
        return float(text)
    except ValueError:
        raise RowError(f"{text!r} is not a number", column, text) from None


def _opt_int(text: str, column: str) -> int | None:
    if text == "":
        return None
    try:
        return int(text)
    except ValueError:
        raise RowError(f"{text!r} is not a whole number", column, text) from None


def _opt_bool(text: str, column: str) -> bool | None:
    if text == "":
        return None
    if text not in ("True", "False"):
        raise RowError(f"expected True or False, got {text!r}", column, text)
    return text == "True"


def _opt_theta(text: str, column: str = "theta_normalised") -> tuple[float, ...] | None:
    if text == "":
        return None
    try:
        values = json.loads(text)
        if not isinstance(values, list):
            raise ValueError
        return tuple(float(v) for v in values)
    except (ValueError, TypeError):
        raise RowError(
            f"theta_normalised must be a JSON list of numbers, got {text!r}", column, text
        ) from None


@dataclass(frozen=True)
class MinedRow:
    """One demonstration's mining result: a row of ``styles.csv`` (fields = :data:`COLUMNS`).

    An ``ok`` row has every estimate; a ``failed`` row has its one-line ``error`` and only
    what was known before the failure (the true risk, at most). Missing values are None
    (empty cells in the CSV).
    """

    id: str
    """The demonstration's id (its file's stem, or its path under the input folder when
    stems repeat; a recorded episode's id)."""
    source: str
    """The input folder or dataset it came from."""
    status: str
    """"ok" or "failed"."""
    error: str = ""
    """Why mining failed (one line naming the file), empty when ok."""
    true_risk: float | None = None
    """The risk in the demonstration's metadata (simulated vehicles), else None."""
    risk_estimate: float | None = None
    """Posterior mode."""
    risk_lo: float | None = None
    """Lower end of the 90 % interval."""
    risk_hi: float | None = None
    """Upper end of the 90 % interval."""
    risk_mean: float | None = None
    """Posterior mean."""
    informative: bool | None = None
    """Whether the verdict is ``informative`` (:attr:`label`; tables before
    :data:`LABEL_COLUMNS`: whether the data moved the posterior, or the TV came near)."""
    trigger_fired: bool | None = None
    """Whether the reaction trigger fired."""
    theta_normalised: tuple[float, ...] | None = None
    """The personal style, normalised per feature group (the library's feature order)."""
    rmse_y_m: float | None = None
    """Lateral fit error of the personal style [m]."""
    rmse_xy_m: float | None = None
    """Position fit error of the personal style [m]."""
    iterations: int | None = None
    """ME-IRL outer iterations."""
    converged: bool | None = None
    """Whether ME-IRL reached its stopping criterion."""
    learn_s: float | None = None
    """Wall time of learning the style [s]."""
    identify_s: float | None = None
    """Wall time of identification [s]."""
    failure_kind: str = ""
    """A failed row's :data:`FAILURE_KINDS` ("data" or "infrastructure"), empty when ok.
    Appended after the first version's columns: the earlier columns keep their places."""
    residual_rms: float | None = None
    """The verdict (:class:`~drivestyle.irl.identification.verdict.Verdict`, the columns
    :data:`VERDICT_COLUMNS`, appended last): residual RMS at the best risk [σ_u units]."""
    noise_floor: float | None = None
    """The library's noise floor [σ_u units] (driver libraries)."""
    out_of_class: bool | None = None
    """Whether the residual RMS exceeds the out-of-class factor times the floor."""
    kl_nats: float | None = None
    """KL(posterior ‖ prior) [nats]."""
    interval_width_ratio: float | None = None
    """The 90 % interval's width over the prior's."""
    reason: str = ""
    """Why the verdict is what it is (one line: the verdict's ``reason``)."""
    constraint_binds: bool | None = None
    """Whether a chance constraint binds at some step (the columns :data:`LABEL_COLUMNS`,
    appended last; None in tables written before them)."""
    enters_region: bool | None = None
    """Whether another vehicle came inside the safety region every risk keeps clear of."""
    verdict: str = ""
    """The verdict's label (:data:`~drivestyle.irl.identification.verdict.VERDICT_LABELS`), the
    one :attr:`label` derives from the row's flags; empty in failed rows and tables written
    before the column."""

    def __post_init__(self) -> None:
        if not (isinstance(self.id, str) and self.id):
            raise RowError(f"a mined row needs a non-empty id, got {self.id!r}", "id", self.id)
        bad = self._bad
        if self.status not in STATUSES:
            raise bad("status", f"status must be one of {STATUSES}, got {self.status!r}")
        if "\n" in self.error or "\r" in self.error:
            raise bad("error", "the error must be one line")
        if "\n" in self.reason or "\r" in self.reason:
            raise bad("reason", "the reason must be one line")
        if self.verdict not in ("", *VERDICT_LABELS):
            raise bad("verdict", f"verdict must be one of {VERDICT_LABELS}, got {self.verdict!r}")
        self._check_ranges()
        if self.status == "failed":
            if not self.error:
                raise bad("error", "a failed row needs its error")
            if self.failure_kind not in FAILURE_KINDS:
                raise bad(
                    "failure_kind",
                    f"failure_kind must be one of {FAILURE_KINDS}, got {self.failure_kind!r}",
                )
            return
        if self.error or self.failure_kind:
            column = "error" if self.error else "failure_kind"
            raise bad(column, f"an ok row has no error, got {self.error!r}")
        if self.verdict and self.verdict != self.label:
            raise bad("verdict", f"verdict {self.verdict!r} contradicts its flags ({self.label})")
        needed = ("risk_estimate", "risk_lo", "risk_hi", "risk_mean", "theta_normalised")
        missing = [k for k in needed if getattr(self, k) is None]
        if missing:
            raise bad(missing[0], f"an ok row needs {', '.join(missing)}")
        assert self.risk_lo is not None and self.risk_hi is not None  # checked above
        lo, hi, mean = self.risk_lo, self.risk_hi, self.risk_mean
        if not lo <= hi:
            raise bad("risk_hi", f"interval [{lo}, {hi}] is empty")
        # the interval holds INTERVAL_MASS of the posterior, so its mean lies in it but for
        # what the rest (risks in (0, 1)) can pull it by: [m lo, hi + (1 − m)(1 − hi)]
        outside = 1.0 - INTERVAL_MASS
        least, most = lo - outside * lo, hi + outside * (1.0 - hi)
        assert mean is not None  # checked above
        if not least - 1e-9 <= mean <= most + 1e-9:
            raise bad(
                "risk_mean",
                f"risk_mean {mean} lies outside its own interval [{lo}, {hi}] (risk_lo, "
                f"risk_hi): the mean of a posterior with {INTERVAL_MASS:.0%} of its mass "
                f"there lies in [{least:.4g}, {most:.4g}]",
            )

    def _bad(self, column: str, problem: str) -> RowError:
        """The error of this row's ``column`` (its message names the row by id)."""
        return RowError(problem, column, getattr(self, column, None), self.id)

    def _check_ranges(self) -> None:
        """Every number in its range: a value no mining writes is a damaged or foreign row.

        Risks lie in (0, 1) (a posterior mean of 7.5 is no risk), errors, times, widths and
        divergences are finite and >= 0, iterations a whole number >= 0, θ finite.
        """
        for column in RISK_COLUMNS:
            p = getattr(self, column)
            if p is not None and not (isinstance(p, int | float) and 0 < p < 1):
                raise self._bad(column, f"{column} {p!r} is not a risk in (0, 1)")
        for column in NONNEGATIVE_COLUMNS:
            x = getattr(self, column)
            if x is not None and not (isinstance(x, int | float) and math.isfinite(x) and x >= 0):
                raise self._bad(column, f"{column} {x!r} is not a finite number >= 0")
        n = self.iterations
        if n is not None and not (isinstance(n, int) and n >= 0):
            raise self._bad("iterations", f"iterations {n!r} is not a whole number >= 0")
        theta = self.theta_normalised
        if theta is not None and not all(math.isfinite(v) for v in theta):
            raise self._bad("theta_normalised", f"theta_normalised {list(theta)} is not finite")

    @property
    def label(self) -> str | None:
        """The verdict's label from the row's flags (None: a failed row).

        :func:`~drivestyle.irl.identification.verdict.recorded_verdict_label`: the same function
        as the identification's, so a row of an older table (flags missing) is labelled
        the way every reader labels it.
        """
        if self.status != "ok":
            return None
        return recorded_verdict_label(
            self.informative, self.out_of_class, self.constraint_binds, self.enters_region
        )

    @classmethod
    def failed(
        cls,
        demo_id: str,
        source: str,
        error: str,
        true_risk: float | None = None,
        kind: str = "data",
    ) -> MinedRow:
        """A failed row (``error`` is flattened to one line; ``kind``: :data:`FAILURE_KINDS`)."""
        return cls(
            demo_id,
            source,
            "failed",
            _one_line(error) or "unknown error",
            true_risk,
            failure_kind=kind,
        )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict keyed by :data:`COLUMNS` (missing values None, θ a list)."""
        out = asdict(self)
        if self.theta_normalised is not None:
            out["theta_normalised"] = list(self.theta_normalised)
        return out

    def to_csv(self) -> dict[str, str]:
        """The ``styles.csv`` cells (missing values empty, θ as a JSON list)."""
        cells = {}
        for key, value in asdict(self).items():
            if value is None:
                cells[key] = ""
            elif key == "theta_normalised":
                cells[key] = json.dumps(list(value))
            else:
                cells[key] = str(value)
        return cells

    @classmethod
    def from_csv(cls, record: Mapping[str | None, Any]) -> MinedRow:
        """A row from ``styles.csv``'s cells (a ``csv.DictReader`` record).

        Tables of earlier versions read too (:data:`READABLE_HEADERS`): before the label
        (:data:`PRE_LABEL_COLUMNS`) its cells are missing (None, verdict empty: :attr:`label`
        derives it); before the verdict (:data:`PRE_VERDICT_COLUMNS`) those too; before
        ``failure_kind`` (:data:`LEGACY_COLUMNS`) the failed rows are data failures (its
        local engine wrote no others).

        Raises:
            RowError: a torn or malformed row (cells missing or extra, a value that does
                not parse or lies outside its range, an inconsistent row), naming the column.
        """
        columns = next((h for h in READABLE_HEADERS if h[-1] in record), COLUMNS)
        missing = [c for c in columns if record.get(c) is None]
        if None in record or missing:
            have = sum(v is not None for k, v in record.items() if k is not None)
            extra = len(record.get(None) or ())
            why = (
                f"a torn row: no {', '.join(missing[:3])}{' …' if len(missing) > 3 else ''}"
                if missing
                else "a cell with an unquoted comma?"
            )
            raise RowError(f"{have + extra} cells where the header has {len(columns)} ({why})")
        cell = {c: str(record[c]) for c in columns}
        if columns is LEGACY_COLUMNS:
            cell["failure_kind"] = "data" if cell["status"] == "failed" else ""
        for c in (*VERDICT_COLUMNS, *LABEL_COLUMNS):
            cell.setdefault(c, "")

        def number(c: str) -> float | None:
            return _opt_float(cell[c], c)

        def flag(c: str) -> bool | None:
            return _opt_bool(cell[c], c)

        return cls(
            id=cell["id"],
            source=cell["source"],
            status=cell["status"],
            error=cell["error"],
            true_risk=number("true_risk"),
            risk_estimate=number("risk_estimate"),
            risk_lo=number("risk_lo"),
            risk_hi=number("risk_hi"),
            risk_mean=number("risk_mean"),
            informative=flag("informative"),
            trigger_fired=flag("trigger_fired"),
            theta_normalised=_opt_theta(cell["theta_normalised"]),
            rmse_y_m=number("rmse_y_m"),
            rmse_xy_m=number("rmse_xy_m"),
            iterations=_opt_int(cell["iterations"], "iterations"),
            converged=flag("converged"),
            learn_s=number("learn_s"),
            identify_s=number("identify_s"),
            failure_kind=cell["failure_kind"],
            residual_rms=number("residual_rms"),
            noise_floor=number("noise_floor"),
            out_of_class=flag("out_of_class"),
            kl_nats=number("kl_nats"),
            interval_width_ratio=number("interval_width_ratio"),
            reason=cell["reason"],
            constraint_binds=flag("constraint_binds"),
            enters_region=flag("enters_region"),
            verdict=cell["verdict"],
        )

    def without_timings(self) -> MinedRow:
        """The row with the wall times removed (what two runs must agree on)."""
        return replace(self, learn_s=None, identify_s=None)


COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(MinedRow))
"""Columns of ``styles.csv``, in :class:`MinedRow`'s field order; ``theta_normalised`` is a
JSON list in the library's feature order, the interval is [risk_lo, risk_hi]."""
LABEL_COLUMNS: tuple[str, ...] = ("constraint_binds", "enters_region", "verdict")
"""The flags the verdict's label needs beside ``informative`` and ``out_of_class``, and the
label itself: the last columns of :data:`COLUMNS`."""
assert COLUMNS[-len(LABEL_COLUMNS) :] == LABEL_COLUMNS
PRE_LABEL_COLUMNS: tuple[str, ...] = COLUMNS[: -len(LABEL_COLUMNS)]
"""The columns of a table written before the label (read, and rewritten)."""
VERDICT_COLUMNS: tuple[str, ...] = (
    "residual_rms", "noise_floor", "out_of_class", "kl_nats", "interval_width_ratio", "reason",
)  # fmt: skip
"""The verdict's numbers, the last columns of :data:`PRE_LABEL_COLUMNS`."""
assert PRE_LABEL_COLUMNS[-len(VERDICT_COLUMNS) :] == VERDICT_COLUMNS
PRE_VERDICT_COLUMNS: tuple[str, ...] = PRE_LABEL_COLUMNS[: -len(VERDICT_COLUMNS)]
"""The columns of a table written before the verdict (read, and rewritten)."""
LEGACY_COLUMNS: tuple[str, ...] = PRE_VERDICT_COLUMNS[:-1]
"""The columns of a table written before ``failure_kind`` (read, and rewritten)."""
READABLE_HEADERS: tuple[tuple[str, ...], ...] = (
    COLUMNS, PRE_LABEL_COLUMNS, PRE_VERDICT_COLUMNS, LEGACY_COLUMNS,
)  # fmt: skip
"""Every header :meth:`MinedRow.from_csv` reads, newest first (each extends the next)."""


def _round(value: float | None) -> float | None:
    return None if value is None else round(float(value), 6)


def _describe(exc: BaseException, where: str | None) -> str:
    text = f"{type(exc).__name__}: {exc}"
    return text if where is None or where in text else f"{type(exc).__name__}: {where}: {exc}"


class Miner:
    """Learn a personal style and identify the risk of demonstrations (module docstring).

    Args:
        library: the style library (identification, and the feature set of the styles).
        irl: outer-loop settings of the personal styles.
    """

    def __init__(self, library: StyleLibrary | DriverLibrary, irl: IRLConfig | None = None) -> None:
        self.library = library
        self.irl = irl or IRLConfig()

    def mine(
        self, demo_id: str, source: str, demo: Demonstration | str | os.PathLike[str]
    ) -> MinedRow:
        """One row: ``status`` "ok", or "failed" with a one-line error naming the file."""
        where: str | None = None
        true_risk: float | None = None
        try:
            if not isinstance(demo, Demonstration):
                where = os.fspath(demo)
                demo = load_demonstration(where)
            true = demo.meta.get("risk")
            true_risk = None if true is None else float(true)
            if isinstance(self.library, DriverLibrary):
                return self._mine_driver(demo_id, source, demo, true_risk)
            t0 = time.perf_counter()
            result = MaxEntIRL(demo, self.library.features, self.irl).learn()
            learn_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            ident = identify(demo, self.library)
            identify_s = time.perf_counter() - t0
            return _ok_row(
                demo_id,
                source,
                true_risk,
                ident,
                theta_normalised=result.theta_normalised,
                rmse_y_m=result.errors[0]["rmse_y_m"],
                rmse_xy_m=result.errors[0]["rmse_xy_m"],
                iterations=result.iterations,
                converged=result.converged,
                learn_s=learn_s,
                identify_s=identify_s,
            )
        # any error is this demonstration's row, never the job's (Ctrl-C still stops it)
        except MemoryError as exc:  # the machine's, not the demonstration's: retried
            return MinedRow.failed(
                demo_id, source, _describe(exc, where), true_risk, "infrastructure"
            )
        except Exception as exc:
            return MinedRow.failed(demo_id, source, _describe(exc, where), true_risk)

    def _mine_driver(
        self, demo_id: str, source: str, demo: Demonstration, true_risk: float | None
    ) -> MinedRow:
        """A driver library's row: the risk is the vehicle's parameter (the cost is shared).

        ``theta_normalised`` holds the library style's weights over w_a; the errors are
        those of the style driven at the posterior-mean risk in the demonstration's scenario;
        ``learn_s`` times that reproduction.
        """
        assert isinstance(self.library, DriverLibrary)
        demo = recorded_view(demo)  # reproduced on what identify solves on
        t0 = time.perf_counter()
        ident = identify(demo, self.library)
        identify_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        style = replace(self.library.style, risk=round(ident.risk_interpolated, 6))
        rmse_y, rmse_xy = reproduce(style, demo).errors(demo)
        learn_s = time.perf_counter() - t0
        return _ok_row(
            demo_id,
            source,
            true_risk,
            ident,
            theta_normalised=self.library.style.normalised(),
            rmse_y_m=rmse_y,
            rmse_xy_m=rmse_xy,
            iterations=0,
            converged=True,
            learn_s=learn_s,
            identify_s=identify_s,
        )


def _ok_row(
    demo_id: str,
    source: str,
    true_risk: float | None,
    ident: Identification,
    *,
    theta_normalised: np.ndarray,
    rmse_y_m: float | None,
    rmse_xy_m: float | None,
    iterations: int,
    converged: bool,
    learn_s: float,
    identify_s: float,
) -> MinedRow:
    """A successful row from an identification and the vehicle's style and fit."""
    lo, hi = ident.risk_interval
    v = ident.verdict
    return MinedRow(
        id=demo_id,
        source=source,
        status="ok",
        true_risk=true_risk,
        risk_estimate=ident.risk_estimate,
        risk_lo=lo,
        risk_hi=hi,
        risk_mean=round(ident.risk_interpolated, 6),
        informative=ident.informative,
        trigger_fired=ident.trigger_fired,
        theta_normalised=tuple(round(float(v), 6) for v in theta_normalised),
        rmse_y_m=_round(rmse_y_m),
        rmse_xy_m=_round(rmse_xy_m),
        iterations=iterations,
        converged=converged,
        learn_s=learn_s,
        identify_s=identify_s,
        residual_rms=None if v is None else _round(v.residual_rms),
        noise_floor=None if v is None else _round(v.noise_floor),
        out_of_class=None if v is None else v.out_of_class,
        kl_nats=None if v is None else _round(v.kl_nats),
        interval_width_ratio=None if v is None else _round(v.width_ratio),
        reason="" if v is None else _one_line(v.reason),
        constraint_binds=None if v is None else v.constraint_binds,
        enters_region=None if v is None else v.enters_region,
        verdict="" if v is None else v.label,
    )


_MINER: Miner | None = None


def _init_miner(library: StyleLibrary | DriverLibrary) -> None:
    global _MINER
    _MINER = Miner(library)


def _mine_task(demo_id: str, source: str, demo: Demonstration | str | os.PathLike[str]) -> MinedRow:
    assert _MINER is not None, "worker not initialised"
    return _MINER.mine(demo_id, source, demo)


def _where(demo_id: str, demo: Demonstration | str | os.PathLike[str]) -> str:
    return str(demo) if isinstance(demo, str | PurePath) else f"demonstration {demo_id}"


def _run_local(
    tasks: Sequence[MiningTask],
    library: StyleLibrary | DriverLibrary,
    workers: int,
    on_row: Callable[[MinedRow], None],
) -> None:
    def crashed(index: int, cause: str) -> MinedRow:
        # the task killed its worker process twice (alone the second time): its row
        demo_id, source, demo = tasks[index]
        return MinedRow.failed(
            demo_id, source, f"{_where(demo_id, demo)}: {cause} (2 tries)", kind="infrastructure"
        )

    parallel_map(
        _mine_task,
        list(tasks),
        workers,
        lambda _, row: on_row(row),
        initializer=_init_miner,
        initargs=(library,),
        on_crash=crashed,
    )


def _head_endpoint(address: str) -> tuple[str, int] | None:
    """(host, port) of a Ray head address; None for ``auto``/``local`` (Ray finds those)."""
    if address in ("auto", "local"):
        return None
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "", address
    rest = rest.split("/", 1)[0]
    default = 10001 if scheme == "ray" else 6379  # Ray client / GCS ports
    if rest.startswith("["):  # [IPv6]:port
        host, _, tail = rest[1:].partition("]")
        port_text = tail.removeprefix(":")
    else:
        host, _, port_text = rest.rpartition(":") if ":" in rest else (rest, "", "")
    if not port_text:
        return host, default
    try:
        return host, int(port_text)
    except ValueError:
        raise ValueError(f"Ray address {address!r}: port {port_text!r} is not a number") from None


def _check_reachable(address: str, timeout_s: float) -> None:
    """Raise ConnectionError unless a TCP connection to the Ray head opens within the time."""
    endpoint = _head_endpoint(address)
    if endpoint is None:
        return
    try:
        with socket.create_connection(endpoint, timeout=timeout_s):
            pass
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise ConnectionError(
            f"cannot reach the Ray head at {address} within {timeout_s:g} s ({why}); "
            "is the cluster running and the address right?"
        ) from None


def _ray_failure(exc: Exception) -> str:
    """One line for a task that Ray could not complete."""
    cause = getattr(exc, "cause", None)  # RayTaskError carries the worker's exception
    if isinstance(cause, BaseException):
        return f"{type(cause).__name__}: {cause}"
    lines = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {lines[0] if lines else ''}"


def _run_ray(
    tasks: Sequence[MiningTask],
    library: StyleLibrary | DriverLibrary,
    workers: int,
    on_row: Callable[[MinedRow], None],
    address: str | None,
    connect_timeout_s: float,
) -> None:
    try:
        import ray
        from ray.exceptions import RayActorError, RayError
    except ImportError:
        raise RuntimeError(
            "the ray engine needs Ray: pip install -c constraints-cpu.txt -e '.[ray]'"
        ) from None
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address:
            _check_reachable(address, connect_timeout_s)
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=workers, **kwargs)
    # SIGTERM: the same clean stop as Ctrl-C, ending in ray.shutdown() below (Ray's own
    # handler exits with status 1 and no shutdown of ours)
    with sigterm_stops_the_job(replace=True) as sigterm:
        try:
            retried = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=RAY_TASK_RETRIES)
            actor: Any = retried(Miner)
            # the library travels with each actor (small), so a restarted actor rebuilds itself
            free: list[Any] = [actor.remote(library) for _ in range(min(workers, len(tasks)))]
            queue = deque(tasks)
            running: dict[Any, tuple[Any, MiningTask]] = {}
            while queue or running:
                while free and queue:
                    a, task = free.pop(), queue.popleft()
                    running[a.mine.remote(*task)] = (a, task)
                (ref,), _ = ray.wait(list(running), num_returns=1)
                a, (demo_id, source, demo) = running.pop(ref)
                free.append(a)
                try:
                    row = ray.get(ref)
                except RayError as exc:  # the worker died on every try, or Ray failed: a row
                    tries = (
                        f" ({RAY_TASK_RETRIES + 1} tries)" if isinstance(exc, RayActorError) else ""
                    )
                    why = f"the Ray worker failed{tries}: {_ray_failure(exc)}"
                    row = MinedRow.failed(
                        demo_id, source, f"{_where(demo_id, demo)}: {why}", kind="infrastructure"
                    )
                on_row(row)
        except SystemExit:
            if sigterm.received:  # Ray's blocking calls replace our exit status with 1
                raise SystemExit(EXIT_TERMINATED) from None
            raise
        finally:
            if started:
                ray.shutdown()


def mine(
    tasks: Iterable[MiningTask],
    library: StyleLibrary | DriverLibrary,
    engine: str = "local",
    workers: int = 2,
    on_row: Callable[[MinedRow], None] | None = None,
    address: str | None = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
) -> list[MinedRow]:
    """Mine every task's demonstration; rows are handed to ``on_row`` as they finish.

    Args:
        tasks: (id, source, demonstration or path); ids must be unique.
        library: the style library.
        engine: ``"local"`` or ``"ray"``.
        workers: processes (local) or actors (ray).
        on_row: called with each finished row (completion order).
        address: Ray cluster address (``ray`` only; None: start Ray on this machine).
        connect_timeout_s: time to reach the head at ``address`` [s].

    Returns:
        The rows, in task order; a demonstration that could not be mined is a failed row.

    Raises:
        ValueError: an unknown engine, a bad worker count or repeated ids (rows are matched
            to demonstrations by id).
        RuntimeError: ``ray`` without Ray installed.
        ConnectionError: the Ray head at ``address`` cannot be reached.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if not (isinstance(workers, int) and workers >= 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if not (connect_timeout_s > 0 and math.isfinite(connect_timeout_s)):
        raise ValueError(f"connect_timeout_s must be a finite number > 0, got {connect_timeout_s}")
    tasks = list(tasks)
    ids = [t[0] for t in tasks]
    if len(set(ids)) < len(ids):
        repeated = sorted(i for i, n in Counter(ids).items() if n > 1)
        raise ValueError(
            f"demonstration ids must be unique (rows are matched by id), repeated: "
            f"{', '.join(repeated[:5])}{' …' if len(repeated) > 5 else ''}"
        )
    rows: dict[str, MinedRow] = {}

    def collect(row: MinedRow) -> None:
        rows[row.id] = row
        if on_row is not None:
            on_row(row)

    if not tasks:
        return []
    if engine == "local":
        _run_local(tasks, library, workers, collect)
    else:
        _run_ray(tasks, library, workers, collect, address, connect_timeout_s)
    return [rows[i] for i in ids]


def _range(values: Sequence[float | None]) -> list[float] | None:
    kept = [float(v) for v in values if v is not None and math.isfinite(v)]
    return [min(kept), max(kept)] if kept else None


def verdict_numbers(rows: Sequence[MinedRow]) -> dict[str, Any]:
    """The verdicts on fit over the ok rows (DESIGN §8): counts and ranges.

    Returns:
        ``verdicts`` (label → rows, every label of
        :data:`~drivestyle.irl.identification.verdict.VERDICT_LABELS`), ``n_informative`` (label
        ``informative``), ``n_out_of_class`` (``out_of_class`` or ``enters_region``: the
        style does not describe the driver) and the [min, max] of the residual in noise
        floors (``residual_floors``), of ``kl_nats`` and of ``interval_width_ratio`` (None
        where no row has the number).
    """
    ok = [r for r in rows if r.status == "ok"]
    floors = [
        r.residual_rms / r.noise_floor for r in ok if r.residual_rms is not None and r.noise_floor
    ]
    labels = Counter(r.label for r in ok)
    return {
        "verdicts": {label: labels[label] for label in VERDICT_LABELS},
        "n_informative": labels[INFORMATIVE],
        "n_out_of_class": labels[OUT_OF_CLASS] + labels[ENTERS_REGION],
        "residual_floors": _range(floors),
        "kl_nats": _range([r.kl_nats for r in ok]),
        "interval_width_ratio": _range([r.interval_width_ratio for r in ok]),
    }


def summary_numbers(rows: Sequence[MinedRow]) -> dict[str, Any]:
    """Accuracy of the estimates where the true risk is known (ok rows), and the verdicts."""
    verdicts = verdict_numbers(rows)
    ok = [r for r in rows if r.status == "ok" and r.true_risk is not None]
    if not ok:
        return {"n_with_truth": 0, **verdicts}
    true = np.array([r.true_risk for r in ok], float)
    mean = np.array([r.risk_mean for r in ok], float)
    lo = np.array([r.risk_lo for r in ok], float)
    hi = np.array([r.risk_hi for r in ok], float)
    return {
        "n_with_truth": len(ok),
        "mae_posterior_mean": float(np.mean(np.abs(mean - true))),
        "interval_coverage": float(np.mean((lo - 1e-9 <= true) & (true <= hi + 1e-9))),
        **verdicts,
    }
