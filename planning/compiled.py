"""Compiled CasADi code, built once per machine and cached on disk (DESIGN §16).

CasADi's ``jit`` compiles an NLP's functions in every new process (≈ 3–5 s each, then
thrown away). Here a function — a whole fatrop solver, or a generated Newton step — is
turned into C by CasADi's code generator, compiled by gcc into a shared library whose
name is a hash of everything the code depends on (the caller's key, the CasADi version
and the source of the modules that define the NLP), and stored in :func:`cache_dir`.
Every later process, on any core, loads the library in milliseconds.

Without a C compiler (or CasADi's headers), :func:`compiled_function` returns None and
callers keep CasADi's interpreted functions: slower, same results.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import casadi as ca

__all__ = ["CACHE_ENV", "cache_dir", "compile_c", "compiled_function", "source_digest"]

CACHE_ENV = "DRIVESTYLE_CACHE"
"""Environment variable naming the cache folder (default ``~/.cache/drivestyle``)."""


def cache_dir() -> Path:
    """The folder of compiled libraries: ``$DRIVESTYLE_CACHE`` or ~/.cache/drivestyle."""
    root = os.environ.get(CACHE_ENV)
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "drivestyle"


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


def compile_c(source: str, target: Path, link_casadi: bool = False) -> None:
    """Compile C ``source`` into the shared library ``target`` with gcc -O2.

    Written atomically (a concurrent process sees no library or the finished one).

    Args:
        source: the C code.
        target: the library path.
        link_casadi: add CasADi's include folder and link its fatrop and blasfeo.

    Raises:
        RuntimeError: no gcc, or it failed (the first line of its error).
    """
    if shutil.which("gcc") is None:
        raise RuntimeError("no C compiler (gcc) on the PATH")
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="drivestyle_cc_") as tmp:
        c_file = Path(tmp) / "code.c"
        c_file.write_text(source)
        out = Path(tmp) / "lib.so"
        # one memory slot per live buffer of the function (every planner binds one)
        cmd = ["gcc", "-O2", "-fPIC", "-shared", "-DCASADI_MAX_NUM_THREADS=256", "-o", str(out),
               str(c_file)]  # fmt: skip
        cmd += (_casadi_flags() if link_casadi else []) + ["-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            first = (proc.stderr.strip().splitlines() or ["unknown error"])[0]
            raise RuntimeError(f"gcc failed: {first}")
        partial = target.with_name(f"{target.name}.{os.getpid()}.tmp")
        shutil.copyfile(out, partial)
        os.replace(partial, target)


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
    target = cache_dir() / f"{name}_{key[:20]}.so"
    if str(target) in _LOADED:
        return _LOADED[str(target)]
    try:
        if not target.exists():
            generator = ca.CodeGenerator(f"{name}.c", {"with_header": False})
            generator.add(build())
            compile_c(generator.dump(), target, link_casadi)
        function = ca.external(name, str(target))
    except (OSError, RuntimeError):
        return None
    # one loaded instance per process: the library's static memory is shared by every
    # Function loading it, and freeing it with a second instance would pull it from under
    # the first
    _LOADED[str(target)] = function
    return function


_LOADED: dict[str, ca.Function] = {}
