"""A command's input files, each counted once: the same file, or the same content, once.

Every command that takes several demonstrations (``identify-style a.npz b.npz``,
``learn-style``, ``mine-styles FOLDER``) pools or counts them; a file given twice, or two
files of the same bytes (a copy under another name), would weigh twice in a posterior, a
learned style or a population's summary. :func:`distinct_files` keeps the first of each
and says which it dropped (:attr:`DistinctFiles.note`, for the command to print on stderr).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["NOTE_LISTS", "DistinctFiles", "distinct_files"]

NOTE_LISTS = 5
"""The note names at most this many dropped files (a folder of copies would fill a screen)."""
_CHUNK = 1 << 20


@dataclass(frozen=True)
class DistinctFiles:
    """The files to use and the ones dropped as repeats (:func:`distinct_files`)."""

    kept: tuple[Path, ...]
    """The first of each file and of each content, in the given order (a missing file is
    kept: reading it names it)."""
    repeated: tuple[tuple[Path, int], ...] = ()
    """(a file as first given, how often it was given) for a file given more than once
    (under any spelling: resolved paths, symbolic links)."""
    copies: tuple[tuple[Path, Path], ...] = ()
    """(a file, the kept file of the same bytes)."""
    names: tuple[tuple[Path, ...], ...] = ()
    """Per entry of :attr:`repeated`, the different names it was given under (a symbolic
    link ``b.npz → a.npz``: both; ``a.npz`` and ``sub/../a.npz`` are one name)."""

    @property
    def note(self) -> str | None:
        """The line a command prints on stderr (None: nothing was dropped)."""
        said = []
        for i, (path, n) in enumerate(self.repeated):
            names = self.names[i] if i < len(self.names) else (path,)
            if len(names) > 1:  # a link: name every file that is this one
                listed = ", ".join(map(str, names[:-1])) + f" and {names[-1]}"
                more = f", given {n} times" if n > len(names) else ""
                said.append(f"{listed} are one file (a link){more}")
            else:
                said.append(f"{path} given {n} times")
        said += [f"{path} has the content of {first}" for path, first in self.copies]
        if not said:
            return None
        more = f"; … ({len(said)} in all)" if len(said) > NOTE_LISTS else ""
        return f"note: each demonstration counts once: {'; '.join(said[:NOTE_LISTS])}{more}"


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        while chunk := fh.read(_CHUNK):
            h.update(chunk)
    return h.hexdigest()


def distinct_files(paths: Sequence[str | Path]) -> DistinctFiles:
    """``paths`` without repeats: the same file (resolved) or the same bytes, first kept.

    Only files of equal size are read (a copy has its original's size), so a folder of
    distinct demonstrations costs one ``stat`` each.

    Args:
        paths: the files, as given (or as found in a folder).

    Returns:
        The files to use and what was dropped.
    """
    given: dict[Path, tuple[Path, int]] = {}  # resolved → (as first given, times)
    spelled: dict[Path, dict[str, Path]] = {}  # resolved → its names (lexically normalised)
    for p in map(Path, paths):
        real = p.resolve()
        first, n = given.get(real, (p, 0))
        given[real] = (first, n + 1)
        spelled.setdefault(real, {}).setdefault(os.path.normpath(p.absolute()), p)
    sizes: dict[int, int] = {}
    for real in given:
        if real.is_file():
            size = real.stat().st_size
            sizes[size] = sizes.get(size, 0) + 1
    kept: list[Path] = []
    copies: list[tuple[Path, Path]] = []
    by_content: dict[str, Path] = {}
    for real, (path, _) in given.items():
        if real.is_file() and sizes[real.stat().st_size] > 1:
            digest = _digest(real)
            if digest in by_content:
                copies.append((path, by_content[digest]))
                continue
            by_content[digest] = path
        kept.append(path)
    repeated = tuple((path, n) for path, n in given.values() if n > 1)
    names = tuple(tuple(spelled[real].values()) for real, (_, n) in given.items() if n > 1)
    return DistinctFiles(tuple(kept), repeated, tuple(copies), names)
