"""Compiled CasADi code, built once per machine and cached on disk (DESIGN §16).

CasADi's ``jit`` compiles an NLP's functions in every new process (≈ 3–5 s each, then
thrown away). Here a function — a whole fatrop solver, or a generated Newton step — is
turned into C by CasADi's code generator, compiled by gcc into a shared library whose
name is a hash of everything the code depends on (the caller's key, the CasADi version
and the source of the modules that define the NLP), and stored in :func:`cache_dir`.
Every later process, on any core, loads the library in milliseconds.

The cache is checked, never trusted: a library is published atomically (built under a
name of its own in the cache folder, fsync'ed, renamed over the final name, so concurrent
builders of one key never see each other's half-written file) beside a checksum file
(``<library>.sha256``: SHA-256 and size of its bytes). Before a library is loaded its size
and checksum are verified; one that does not verify (cut short by a full disk or a killed
copy, overwritten, of an older version without a checksum) is deleted and rebuilt, with a
line on stderr, and is never loaded (a truncated library loaded by ``dlopen`` kills the
process with SIGBUS, without a word).

The cache is optional: when its folder cannot be had (no home folder, a read-only one),
a private folder under the temp folder is used instead, or none (every process then uses
the interpreted functions), said once on stderr. Without a C compiler (or CasADi's
headers), :func:`compiled_function` returns None and callers keep CasADi's interpreted
functions: slower, same results.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import casadi as ca

__all__ = [
    "CACHE_ENV",
    "cache_dir",
    "cached_library",
    "compile_c",
    "compiled_function",
    "source_digest",
    "verify_library",
]

CACHE_ENV = "DRIVESTYLE_CACHE"
"""Environment variable naming the cache folder (default ``~/.cache/drivestyle``)."""
CHECKSUM_SUFFIX = ".sha256"
"""A library's checksum file is its path with this suffix added."""

_SAID: set[str] = set()
"""Notices already printed by this process (each is said once)."""


def _say_once(text: str) -> None:
    if text not in _SAID:
        _SAID.add(text)
        print(f"drivestyle: {text}", file=sys.stderr, flush=True)


def _wanted_dir() -> tuple[Path | None, str]:
    """The configured cache folder, or None and why there is none."""
    root = os.environ.get(CACHE_ENV)
    if root:
        return Path(root), ""
    base = os.environ.get("XDG_CACHE_HOME")
    if base:
        return Path(base) / "drivestyle", ""
    try:
        return Path.home() / ".cache" / "drivestyle", ""
    except RuntimeError:  # no HOME and no password entry
        return None, f"no home folder (HOME is not set) and no ${CACHE_ENV}"


def _private_temp_dir() -> Path | None:
    """``<tmp>/drivestyle-cache-<uid>``, this user's only (else None: others could plant code)."""
    uid = getattr(os, "getuid", lambda: 0)()
    folder = Path(tempfile.gettempdir()) / f"drivestyle-cache-{uid}"
    try:
        folder.mkdir(mode=0o700, exist_ok=True)
        info = os.lstat(folder)
    except OSError:
        return None
    private = info.st_uid == uid and not info.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
    return folder if stat.S_ISDIR(info.st_mode) and private else None


def cache_dir() -> Path | None:
    """The folder of compiled libraries (created), None when there can be none.

    ``$DRIVESTYLE_CACHE``, else ``$XDG_CACHE_HOME/drivestyle``, else
    ``~/.cache/drivestyle``. When that folder cannot be created or written, a private folder
    under the temp folder, else None; either is said once on stderr, and a fallback folder is
    exported as ``$DRIVESTYLE_CACHE`` so that worker processes share it without a word.
    """
    wanted, why = _wanted_dir()
    if wanted is not None:
        try:
            wanted.mkdir(parents=True, exist_ok=True)
            if os.access(wanted, os.W_OK | os.X_OK):
                return wanted
            why = f"the cache folder {wanted} is not writable"
        except OSError as exc:
            why = f"the cache folder {wanted} cannot be created ({exc.strerror or exc})"
    fallback = _private_temp_dir()
    if fallback is None:
        _say_once(f"{why}: compiled solvers are not cached (every process is slower)")
        return None
    _say_once(f"{why}: compiled solvers are cached in {fallback} instead")
    os.environ[CACHE_ENV] = str(fallback)
    return fallback


def source_digest(modules: Sequence[str]) -> str:
    """Hash of CasADi's version and the source files of ``modules`` (a code change rebuilds).

    Args:
        modules: importable module names whose source defines the generated code.

    Returns:
        A hex digest.
    """
    h = hashlib.sha256(str(ca.__version__).encode())  # type: ignore[attr-defined]
    for name in modules:
        __import__(name)
        path = getattr(sys.modules[name], "__file__", None)
        if path:
            h.update(Path(path).read_bytes())
    return h.hexdigest()


def _casadi_flags() -> list[str]:
    """Include and link flags for code that calls CasADi's bundled fatrop/blasfeo."""
    root = Path(ca.__file__).parent
    return [f"-I{root / 'include'}", f"-L{root}", "-lfatrop", "-lblasfeo", f"-Wl,-rpath,{root}"]


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _checksum_path(library: Path) -> Path:
    return library.with_name(library.name + CHECKSUM_SUFFIX)


def _write_synced(path: Path, data: bytes) -> None:
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def _publish(data: bytes, target: Path) -> None:
    """Write ``data`` to ``target`` and its checksum file, each atomically.

    The checksum goes first, the library last: a reader that finds the library finds its
    checksum (a concurrent builder's checksum of other bytes makes a reader rebuild, never
    load a wrong file). Temporary names carry the pid: builders never share one.
    """
    target.parent.mkdir(parents=True, exist_ok=True)
    checksum = _checksum_path(target)
    parts = {checksum: f"{_sha256(data)} {len(data)}\n".encode(), target: data}
    for path, content in parts.items():
        partial = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            _write_synced(partial, content)
            os.replace(partial, path)
        finally:
            partial.unlink(missing_ok=True)
    try:  # the renames themselves survive a crash once the folder is synced
        fd = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError:
        pass


def verify_library(library: Path) -> str | None:
    """Why the cached ``library`` must not be loaded, or None when it verifies.

    Its size and SHA-256 must be those of its checksum file (:func:`_publish`).
    """
    try:
        recorded = _checksum_path(library).read_text().split()
        expected_sha, expected_size = recorded[0], int(recorded[1])
    except FileNotFoundError:
        return "has no checksum file (cut short, or of an older version)"
    except (OSError, ValueError, IndexError, UnicodeDecodeError):
        return "has an unreadable checksum file"
    try:
        data = library.read_bytes()
    except FileNotFoundError:
        return "is missing"
    if len(data) != expected_size:
        return f"is {len(data)} bytes instead of {expected_size} (cut short?)"
    if _sha256(data) != expected_sha:
        return "does not match its checksum (overwritten or damaged)"
    return None


def cached_library(target: Path, source: Callable[[], str], link_casadi: bool = False) -> Path:
    """``target``, verified, or built from ``source()`` when missing or not verifying.

    A library that does not verify (:func:`verify_library`) is deleted, with a line on
    stderr, before it is rebuilt: it is never loaded.

    Args:
        target: the library's path in the cache folder.
        source: makes the C code (only called when building).
        link_casadi: see :func:`compile_c`.

    Returns:
        ``target``, safe to load.

    Raises:
        RuntimeError: no gcc, or it failed.
        OSError: the cache folder cannot be written.
    """
    why = verify_library(target) if target.exists() else "is missing"
    if why is None:
        return target
    if why != "is missing":
        print(f"drivestyle: the cached {target} {why}: deleted, rebuilding it", file=sys.stderr)
        # unlinking never disturbs a process that has the file loaded (it keeps the inode)
        target.unlink(missing_ok=True)
        _checksum_path(target).unlink(missing_ok=True)
    if shutil.which("gcc") is None:
        raise RuntimeError("no C compiler (gcc) on the PATH")
    compile_c(source(), target, link_casadi)
    return target


def compile_c(source: str, target: Path, link_casadi: bool = False) -> None:
    """Compile C ``source`` into the shared library ``target`` with gcc -O2.

    Written atomically with its checksum file (:func:`_publish`: a concurrent process sees
    no library or a finished one).

    Args:
        source: the C code.
        target: the library path.
        link_casadi: add CasADi's include folder and link its fatrop and blasfeo.

    Raises:
        RuntimeError: no gcc, or it failed (the first line of its error).
    """
    if shutil.which("gcc") is None:
        raise RuntimeError("no C compiler (gcc) on the PATH")
    with tempfile.TemporaryDirectory(prefix="drivestyle_cc_") as tmp:
        Path(tmp, "code.c").write_text(source)
        # one memory slot per live buffer of the function (every planner binds one)
        cmd = ["gcc", "-O2", "-fPIC", "-shared", "-DCASADI_MAX_NUM_THREADS=256", "-o", "lib.so",
               "code.c"]  # fmt: skip
        cmd += (_casadi_flags() if link_casadi else []) + ["-lm"]
        # relative names, run in the temp folder: the library's bytes do not depend on
        # where it was built, so concurrent builders of one key publish the same file
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
        if proc.returncode != 0:
            first = (proc.stderr.strip().splitlines() or ["unknown error"])[0]
            raise RuntimeError(f"gcc failed: {first}")
        _publish(Path(tmp, "lib.so").read_bytes(), target)


def compiled_function(
    name: str, key: str, build: Callable[[], ca.Function], link_casadi: bool = False
) -> ca.Function | None:
    """A CasADi function from the disk cache, generating and compiling it on a miss.

    Args:
        name: the function's name (the generated C symbol).
        key: a digest of everything the function depends on (the caller's).
        build: makes the CasADi function (only called on a cache miss).
        link_casadi: the generated code calls CasADi's fatrop (a generated nlpsol).

    Returns:
        The loaded function, or None when it cannot be compiled here.
    """
    folder = cache_dir()
    if folder is None:
        return None
    target = folder / f"{name}_{key[:20]}.so"
    if str(target) in _LOADED:
        return _LOADED[str(target)]

    def source() -> str:
        generator = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        generator.add(build())
        return generator.dump()

    try:
        function = ca.external(name, str(cached_library(target, source, link_casadi)))
    except (OSError, RuntimeError):
        return None
    # one loaded instance per process: the library's static memory is shared by every
    # Function loading it, and freeing it with a second instance would pull it from under
    # the first
    _LOADED[str(target)] = function
    return function


_LOADED: dict[str, ca.Function] = {}
