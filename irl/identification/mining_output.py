"""The output folder of a resumable mining run (``mine_styles.py --out``).

``styles.csv`` gets one :class:`~drivestyle.irl.identification.mined_row.MinedRow` per
demonstration, appended and flushed as each finishes, so a killed run loses at most the rows in
flight and a rerun skips the rows already there. :class:`MiningOutput` makes that safe to rely on:

- ``fingerprint.json`` records which input and which library (:class:`RunFingerprint`, the
  library by its content's SHA-256) the rows come from; a run with another input or library
  is refused (its rows would be credited to the wrong input, or never mined), unless it
  starts over (``force``);
- the folder's lock (:func:`~drivestyle.common.output_lock.output_lock`, the one every command's
  output has: ``flock`` on a file beside the folder, recording the holder) is held while a
  run writes: a second run into the same folder is refused, naming the holder's pid,
  instead of writing every row twice. A killed run is no obstacle: its lock is taken over
  with a one-line notice on stderr. In ``mine_styles.py`` the command took the lock before
  any work (:func:`~drivestyle.common.io.check_output_dir`) and the folder uses it;
- a last row torn by a kill (no line end) is dropped, and so are malformed and repeated
  rows, so their demonstrations are mined again instead of being glued to the next row;
- rows that failed for an infrastructure reason (``failure_kind``: a worker that died, was
  killed, ran out of memory) are dropped on entering, so a resumed run mines them again;
  data failures are final. A table of the version before ``failure_kind`` is read (its
  failures are data failures) and rewritten with the new header; so are those of the
  versions before the verdict columns and before the label columns (their rows keep those
  cells empty; a row's label is derived from the flags it has);
- a demonstration's id is its path under the input folder (:data:`ID_SCHEME`), whatever the
  other files are; rows of an earlier version (stem ids) are given their path ids on
  entering, or dropped and mined again where a stem is ambiguous now; rows of
  demonstrations no longer in the input are dropped (the table is the input's).
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path, PurePosixPath
from types import TracebackType
from typing import Any

from drivestyle.common.io import write_text
from drivestyle.common.output_lock import OutputInUseError, output_lock
from drivestyle.irl.identification.library import DriverLibrary, StyleLibrary
from drivestyle.irl.identification.mined_row import COLUMNS, READABLE_HEADERS, MinedRow, RowError

__all__ = [
    "AMORTIZED_TABLE",
    "FINGERPRINT",
    "ID_SCHEME",
    "RESULTS",
    "TABLE",
    "MiningOutput",
    "MiningOutputError",
    "RunFingerprint",
    "header_problem",
    "library_digest",
    "read_rows",
    "read_table",
]

TABLE = "styles.csv"
FINGERPRINT = "fingerprint.json"
AMORTIZED_TABLE = "amortized.csv"
"""The amortized posteriors of a run given ``--posterior``
(:mod:`drivestyle.irl.amortized.mining`), written whole by every such run."""
RESULTS = (TABLE, "summary.json", "population.png", FINGERPRINT, AMORTIZED_TABLE)
ID_SCHEME = "path"
"""A demonstration's id is its path under the input folder, without suffix, with ``/``
(``sub/v1``; a recorded episode's id): it does not depend on the other files."""
LEGACY_ID_SCHEME = "stem-or-path"
"""The ids of earlier versions: every file's stem, or every file's path when two stems
were equal (so adding one file renamed every row)."""
"""The files a run writes in its output folder (``force`` removes exactly these)."""


class MiningOutputError(ValueError):
    """An output folder cannot take this run (another run's rows, in use, not a mining table)."""


def library_digest(library: StyleLibrary | DriverLibrary) -> str:
    """SHA-256 of a library's content (its ``library.json`` form, keys sorted)."""
    text = json.dumps(library.to_json(), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class RunFingerprint:
    """Which input and which library the rows of an output folder come from."""

    input: str
    """The input folder (resolved), or ``dataset:FOLDER`` for a recorded dataset."""
    library: str
    """Where the library was read from (resolved; for messages)."""
    library_sha256: str
    """The library's identity (:func:`library_digest`): a moved copy is the same library,
    one rebuilt in place is not."""
    id_scheme: str = ID_SCHEME
    """How the rows' ids were made: :data:`ID_SCHEME`, or :data:`LEGACY_ID_SCHEME` (a
    fingerprint without this key) whose ids :class:`MiningOutput` maps on entering."""

    @classmethod
    def of(
        cls, input_id: str, library_path: str | Path, library: StyleLibrary | DriverLibrary
    ) -> RunFingerprint:
        """The fingerprint of mining ``input_id`` with ``library`` read from ``library_path``."""
        return cls(input_id, str(Path(library_path).resolve()), library_digest(library))

    def same_run(self, other: RunFingerprint) -> bool:
        """Whether rows of ``other`` belong to this run (same input, same library content)."""
        return self.input == other.input and self.library_sha256 == other.library_sha256

    def to_json(self) -> dict[str, str]:
        """JSON-ready dict (``fingerprint.json``)."""
        return asdict(self)

    @classmethod
    def from_json(cls, raw: Any) -> RunFingerprint:
        """From :meth:`to_json`'s form.

        Raises:
            ValueError: not such a dict.
        """
        required = ("input", "library", "library_sha256")
        if not isinstance(raw, dict) or not all(isinstance(raw.get(k), str) for k in required):
            raise ValueError(f"not a mining fingerprint: {raw!r}")
        scheme = raw.get("id_scheme", LEGACY_ID_SCHEME)  # written before ids were paths
        if scheme not in (ID_SCHEME, LEGACY_ID_SCHEME):
            raise ValueError(f"unknown id_scheme {scheme!r}")
        return cls(**{k: raw[k] for k in required}, id_scheme=scheme)

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The JSON keys."""
        return tuple(cls.__dataclass_fields__)


def _parse_table(text: str, what: str) -> tuple[list[MinedRow], int, bool]:
    """(valid rows, first of each id; rows dropped; whether the header is this version's).

    Raises:
        MiningOutputError: the header is none of :data:`READABLE_HEADERS`.
    """
    reader = csv.DictReader(io.StringIO(text.removeprefix("\ufeff"), newline=""))
    if reader.fieldnames is None:
        return [], 0, False
    if tuple(reader.fieldnames) not in READABLE_HEADERS:
        raise MiningOutputError(f"{what}: {header_problem(reader.fieldnames)}")
    rows: list[MinedRow] = []
    seen: set[str] = set()
    dropped = 0
    for record in reader:
        try:
            row = MinedRow.from_csv(record)
        except (ValueError, TypeError):
            dropped += 1
            continue
        if row.id in seen:  # written twice (an older version's concurrent runs)
            dropped += 1
            continue
        seen.add(row.id)
        rows.append(row)
    return rows, dropped, tuple(reader.fieldnames) == COLUMNS


def _csv_line(row: MinedRow | None) -> str:
    """The header (None) or one row as CSV text."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS)
    if row is None:
        writer.writeheader()
    else:
        writer.writerow(row.to_csv())
    return buf.getvalue()


def read_rows(path: str | Path) -> list[MinedRow]:
    """The valid rows of an existing ``styles.csv`` (empty if there is none).

    A torn last line, malformed rows and repeated ids (all but the first) are skipped.

    Raises:
        MiningOutputError: the file's header is not :data:`COLUMNS` (another file).
    """
    path = Path(path)
    if not path.is_file():
        return []
    raw = path.read_bytes()
    text = raw[: raw.rfind(b"\n") + 1].decode("utf-8", errors="replace")
    return _parse_table(text, str(path))[0]


def header_problem(names: Sequence[str]) -> str:
    """What is wrong with a header that is none of :data:`READABLE_HEADERS`, in words.

    Against the readable header it shares most columns with: a column it does not have
    (an extra one), a column missing, or a column out of place (the columns reordered, as
    a spreadsheet may save them). A header sharing fewer than half its columns with every
    readable one is another table altogether.
    """
    names = list(names)
    closest = max(READABLE_HEADERS, key=lambda h: (len(set(h) & set(names)), -len(h)))
    if 2 * len(set(closest) & set(names)) < len(names):
        more = " …" if len(names) > 6 else ""
        return f"not a styles.csv of mine-styles (its columns: {', '.join(names[:6])}{more})"
    twice = [c for c in dict.fromkeys(names) if names.count(c) > 1]
    if twice:
        return f"column {twice[0]} appears {names.count(twice[0])} times"
    extra = [c for c in names if c not in closest]
    if extra:
        return (
            f"column {extra[0]!r} (column {names.index(extra[0]) + 1}) is not a column of a "
            f"styles.csv{f' ({len(extra)} such columns)' if len(extra) > 1 else ''}"
        )
    missing = [c for c in closest if c not in names]
    if missing:
        return (
            f"no column {missing[0]} (a styles.csv has it as column "
            f"{closest.index(missing[0]) + 1})"
            + (f"; {len(missing)} columns missing" if len(missing) > 1 else "")
        )
    i = next(i for i, (a, b) in enumerate(zip(names, closest, strict=True)) if a != b)
    return (
        f"column {names[i]} is out of place: column {i + 1} of a styles.csv is {closest[i]} "
        f"(its columns in order: {', '.join(closest[:3])}, …)"
    )


def read_table(path: str | Path) -> list[MinedRow]:
    """Every row of a mining run's ``styles.csv``, each validated: what its readers read.

    A resumed run drops a damaged row and mines it again (:class:`MiningOutput`); a reader
    of the results has no such remedy, so here a damaged row is an error that names it:
    a last row without its line end (the run was interrupted while writing it: resume the
    run), a header with a column extra, missing or out of place (:func:`header_problem`;
    a UTF-8 byte-order mark, as a spreadsheet saves, is read), a row with cells missing or
    extra, a value that does not parse or lies outside
    its range (:meth:`MinedRow.from_csv`), an id twice.

    Args:
        path: the ``styles.csv``.

    Returns:
        The rows, in file order (an empty list for a table of a header only).

    Raises:
        FileNotFoundError: no such file.
        MiningOutputError: not a text file, not a ``styles.csv`` of any version
            (:data:`READABLE_HEADERS`), or a row as above (the message names the file,
            the row and its line, the column and the value).
    """
    path = Path(path)
    if path.is_dir():
        raise MiningOutputError(f"{path} is a folder, not a styles.csv")
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MiningOutputError(
            f"{path} is not a text file (byte {exc.start} is not UTF-8): not a styles.csv"
        ) from None
    text = text.removeprefix("\ufeff")  # a spreadsheet's UTF-8 byte-order mark
    reader = csv.DictReader(io.StringIO(text, newline=""))
    if reader.fieldnames is None:
        raise MiningOutputError(f"{path} is empty: not a styles.csv written by mine-styles")
    if tuple(reader.fieldnames) not in READABLE_HEADERS:
        raise MiningOutputError(f"{path}: {header_problem(reader.fieldnames)}")
    records = [(record, reader.line_num) for record in reader]
    # a last line without its line end is what a kill leaves (MiningOutput drops it too)
    torn_last = not raw.endswith(b"\n")
    rows: list[MinedRow] = []
    first: dict[str, int] = {}
    for n, (record, line) in enumerate(records, start=1):
        where = f"{path}, row {n} (line {line})"
        if torn_last and n == len(records):
            raise MiningOutputError(
                f"{where} is incomplete (no line end): the mining run was interrupted while "
                "writing it; resume the run (drivestyle mine-styles with the same input, "
                "library and --out mines that row again) before reading its results"
            )
        try:
            row = MinedRow.from_csv(record)
        except RowError as exc:
            row_id = record.get("id") or ""
            named = f" (id {row_id})" if row_id and exc.column != "id" else ""
            # a range error names its column already ("risk_mean 7.5 is not a risk …")
            said = exc.column is None or exc.problem.startswith(exc.column)
            column = "" if said else f", column {exc.column}"
            raise MiningOutputError(f"{where}{named}{column}: {exc.problem}") from None
        if row.id in first:
            raise MiningOutputError(
                f"{where}: id {row.id} again (first in row {first[row.id]}): one row per "
                "demonstration"
            )
        first[row.id] = n
        rows.append(row)
    return rows


class MiningOutput:
    """The output folder of a resumable mining run (module docstring); a context manager.

    On entering: takes the folder's lock (:func:`~drivestyle.common.output_lock.output_lock`, the
    running command's if it holds it; a second run is refused; the lock of a run that has
    ended is taken over, with a notice on stderr), checks ``fingerprint.json`` against this
    run's (``force``: delete the earlier run's results first), repairs ``styles.csv`` (drops
    a torn last row, malformed rows, repeated ids and infrastructure failures, so those
    demonstrations are mined again) and opens it for appending. On leaving: closes the
    table and releases the lock.

    Args:
        folder: the output folder (created).
        fingerprint: this run's input and library.
        force: start over, deleting the results of any earlier run (:data:`RESULTS`).
        ids: the ids of this run's demonstrations (:data:`ID_SCHEME`); when given, rows of
            an earlier version's ids are mapped to them (:meth:`_match_ids`) and rows of
            demonstrations no longer in the input are dropped.

    Raises (on entering):
        MiningOutputError: the folder is in use by another run, holds the rows of another
            input or library (or of a version without fingerprints), or its ``styles.csv``
            is another file.
    """

    def __init__(
        self,
        folder: str | Path,
        fingerprint: RunFingerprint,
        force: bool = False,
        ids: Sequence[str] | None = None,
    ) -> None:
        self.folder = Path(folder)
        self.fingerprint = fingerprint
        self.force = force
        self.ids = None if ids is None else list(ids)
        self._old_scheme = fingerprint.id_scheme
        self.renamed = 0
        """Rows of an earlier version's stem ids given their path ids on entering."""
        self.unmappable: list[str] = []
        """Earlier-version ids that name several demonstrations now: dropped, mined again."""
        self.removed: list[str] = []
        """Ids of rows whose demonstrations are no longer in the input: dropped."""
        self.table = self.folder / TABLE
        self.repaired = 0
        """Rows dropped from the table on entering (torn, malformed or repeated)."""
        self.retrying: list[str] = []
        """Ids whose rows failed for an infrastructure reason: dropped on entering, so that
        this run mines them again (data failures stay: they would fail again)."""
        self._rows: dict[str, MinedRow] = {}
        self._lock = contextlib.ExitStack()
        self._fh: io.TextIOWrapper | None = None

    # -- context manager
    def __enter__(self) -> MiningOutput:
        self.folder.mkdir(parents=True, exist_ok=True)
        self._acquire_lock()
        try:
            if self.force:
                for name in RESULTS:
                    (self.folder / name).unlink(missing_ok=True)
            self._check_fingerprint()
            self._load_table()
            # ids not matched here (no ``ids``) keep the scheme they were written with
            written = (
                self.fingerprint
                if self.ids is not None
                else replace(self.fingerprint, id_scheme=self._old_scheme)
            )
            write_text(self.folder / FINGERPRINT, json.dumps(written.to_json(), indent=2) + "\n")
            self._fh = self.table.open("a", newline="")
        except BaseException:
            self._release_lock()
            raise
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        self._release_lock()

    # -- rows
    @property
    def rows(self) -> list[MinedRow]:
        """Every row of the table (the earlier runs' and this one's), in file order."""
        return list(self._rows.values())

    def finished_ids(self) -> set[str]:
        """Ids already in the table (a resumed run skips them)."""
        return set(self._rows)

    def append(self, row: MinedRow) -> bool:
        """Write a row and flush it (a row on disk is a row a rerun skips).

        Returns:
            False if a row of this id is already in the table (it is not written twice).
        """
        if self._fh is None:
            raise RuntimeError("MiningOutput.append outside its with-block")
        if row.id in self._rows:
            return False
        self._fh.write(_csv_line(row))
        self._fh.flush()
        self._rows[row.id] = row
        return True

    # -- internals
    def _acquire_lock(self) -> None:
        try:
            self._lock.enter_context(output_lock(self.folder))
        except OutputInUseError as exc:
            raise MiningOutputError(
                f"{self.folder} is in use by another mining run (pid "
                f"{exc.pid if exc.pid is not None else 'unknown'}); wait for it to finish or "
                "choose another --out"
            ) from None

    def _release_lock(self) -> None:
        self._lock.close()

    def _check_fingerprint(self) -> None:
        path = self.folder / FINGERPRINT
        has_rows = self.table.is_file() and self.table.stat().st_size > 0
        if not path.is_file():
            if has_rows:
                raise MiningOutputError(
                    f"{self.table} has no {FINGERPRINT} beside it (an older version's output): "
                    "its input and library are unknown; choose another --out or pass --force "
                    "to start over"
                )
            return
        try:
            old = RunFingerprint.from_json(json.loads(path.read_text()))
        except (ValueError, UnicodeDecodeError) as exc:
            raise MiningOutputError(
                f"{path} is malformed ({exc}); pass --force to start over"
            ) from None
        self._old_scheme = old.id_scheme
        if not has_rows or old.same_run(self.fingerprint):
            return
        new = self.fingerprint
        diff = []
        if old.input != new.input:
            diff.append(f"input {old.input} (this run: {new.input})")
        if old.library_sha256 != new.library_sha256:
            diff.append(
                f"library {old.library} sha256 {old.library_sha256[:12]} (this run: "
                f"{new.library} sha256 {new.library_sha256[:12]})"
            )
        raise MiningOutputError(
            f"{self.folder} holds the rows of another run: {'; '.join(diff)}; choose another "
            "--out or pass --force to start over"
        )

    def _match_ids(self, rows: list[MinedRow]) -> list[MinedRow]:
        """The rows of this run's demonstrations (``ids``), earlier-version ids mapped.

        An earlier version's id was a file's stem (unless two stems were equal): a row whose
        id is no demonstration's id now but the stem of exactly one demonstration's path is
        that demonstration's row; one whose stem several paths share cannot be placed and
        is dropped (mined again). Rows of demonstrations no longer in the input are dropped.
        """
        if self.ids is None:
            return rows
        wanted = set(self.ids)
        if self._old_scheme == LEGACY_ID_SCHEME:
            by_stem: dict[str, list[str]] = {}
            for i in self.ids:
                by_stem.setdefault(PurePosixPath(i).name, []).append(i)
            taken = {r.id for r in rows} & wanted
            mapped = []
            for row in rows:
                paths = by_stem.get(row.id, [])
                if row.id in wanted or not paths:
                    mapped.append(row)
                elif len(paths) == 1 and paths[0] not in taken:
                    mapped.append(replace(row, id=paths[0]))
                    taken.add(paths[0])
                    self.renamed += 1
                else:
                    self.unmappable.append(row.id)
            rows = mapped
        self.removed = [r.id for r in rows if r.id not in wanted]
        return [r for r in rows if r.id in wanted]

    def _load_table(self) -> None:
        if not self.table.is_file():
            write_text(self.table, _csv_line(None))
            return
        raw = self.table.read_bytes()
        complete = raw[: raw.rfind(b"\n") + 1]  # a last line without its end was torn by a kill
        text = complete.decode("utf-8", errors="replace")
        rows, dropped, current_header = _parse_table(text, str(self.table))
        self.repaired = dropped + (len(complete) < len(raw))
        self.retrying = [r.id for r in rows if r.failure_kind == "infrastructure"]
        rows = [r for r in rows if r.failure_kind != "infrastructure"]
        n_before = len(rows)
        rows = self._match_ids(rows)
        self._rows = {r.id: r for r in rows}
        changed = self.renamed or len(rows) < n_before
        if self.repaired or self.retrying or changed or not current_header:
            # rewritten whole (atomically): appending after a torn line would glue rows
            write_text(self.table, _csv_line(None) + "".join(_csv_line(r) for r in rows))
