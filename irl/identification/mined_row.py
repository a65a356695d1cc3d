"""A mined row: one demonstration's line of ``styles.csv``, its columns and their checks.

:class:`MinedRow` is what mining (:mod:`drivestyle.irl.identification.mining`) makes of one
demonstration — the personal style, the identified risk with its 90 % interval, the
verdict, timings — or, when it could not be mined, a ``failed`` row with a one-line error
and its :data:`FAILURE_KINDS`. Its fields are the table's :data:`COLUMNS`; a row is
validated whole when it is made or read (every number in its range, an ok row complete, a
verdict that agrees with its flags; :class:`RowError` names the column and value), and the
tables of earlier versions read too (:data:`READABLE_HEADERS`). The run's folder and the
reader of a whole table are :mod:`drivestyle.irl.identification.mining_output`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

from drivestyle.irl.identification.result import INTERVAL_MASS
from drivestyle.irl.identification.verdict import VERDICT_LABELS, recorded_verdict_label

__all__ = [
    "COLUMNS",
    "FAILURE_KINDS",
    "LABEL_COLUMNS",
    "LEGACY_COLUMNS",
    "MAX_ERROR_CHARS",
    "NONNEGATIVE_COLUMNS",
    "PRE_LABEL_COLUMNS",
    "PRE_VERDICT_COLUMNS",
    "READABLE_HEADERS",
    "RISK_COLUMNS",
    "STATUSES",
    "TIMING_COLUMNS",
    "VERDICT_COLUMNS",
    "MinedRow",
    "RowError",
    "one_line",
]

STATUSES = ("ok", "failed")
FAILURE_KINDS = ("data", "infrastructure")
"""Why a row failed: its demonstration (final: mining it again fails again) or the machinery
(a worker process that died or was killed, memory; retried when the run is resumed)."""
TIMING_COLUMNS = ("learn_s", "identify_s")
"""Columns that differ between runs (wall times)."""
MAX_ERROR_CHARS = 500
"""A failed row's error is one line of at most this many characters."""


def one_line(text: str) -> str:
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
            one_line(error) or "unknown error",
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
