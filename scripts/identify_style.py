r"""Identify the driving style (risk level) of one vehicle from its demonstration(s).

With a driver library (the default ``build_style_library.py`` output, DESIGN §15) the
risk is a continuous parameter of the library's one style: its posterior over p ∈ [0.5,
0.99] comes from the demonstration's residuals under that style (``scorer`` is
``likelihood``; ``posterior_density`` holds the continuous posterior, ``posterior`` its
mass per library risk). With a paper-model library (``--model paper``) every style is
scored by reproducing r*_θ in each demonstration's own scenario (``--scorer``, default: the
one validation picked; see irl/identification.py). Writes
``OUT/identify.json`` with ``scorer``, ``risk_estimate`` (posterior mode),
``risk_interpolated`` (posterior mean), ``posterior`` (per library risk), ``risk_interval``
(90 % of the posterior), ``informative`` (false when no TV came near enough for the risk
to matter: the interval is then the whole grid), ``scores``, ``ranking``,
``trigger_fired`` and, where the demonstrations' metadata holds it, ``true_risk``. Several
demonstrations of one vehicle pool into one posterior; a file given twice, or two files of
the same content, count once (one would weigh as two), and a line on stderr says which.

Example:
    python scripts/identify_style.py runs/demo/demo.npz --library runs/library_reactive \\
        --out runs/identify
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import load_demonstration
from drivestyle.irl.identification import DEFAULT_SCORER, SCORERS, identify
from drivestyle.irl.library import DriverLibrary, load_any_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("demos", nargs="+", type=Path, help="demonstration .npz file(s) of one vehicle")
    p.add_argument("--library", type=Path, required=True, help="library folder or its library.json")
    p.add_argument(
        "--scorer",
        default=DEFAULT_SCORER,
        choices=SCORERS,
        help="how a style is scored (paper-model libraries; a driver library uses its likelihood)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/identify"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Identify; returns identify.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out)
    library = load_any_library(args.library)
    paths = _distinct_files(args.demos)
    demos = [load_demonstration(p) for p in paths]
    t0 = time.perf_counter()
    ident = identify(demos, library, scorer=args.scorer)
    payload = ident.to_json() | {
        "identify_s": time.perf_counter() - t0,
        "library": str(args.library),
        "demos": [str(p) for p in paths],
    }
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "identify.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
    known = sorted({p for p in ident.true_risks if p is not None})
    lo, hi = ident.risk_interval
    print(
        f"risk estimate {ident.risk_estimate:g}, 90 % interval [{lo:g}, {hi:g}], "
        f"posterior mean {ident.risk_interpolated:.3f} ({ident.scorer} scorer, "
        f"{len(demos)} demonstration{'s' if len(demos) > 1 else ''}"
        + (f"; true risk {', '.join(f'{p:g}' for p in known)})" if known else ")")
    )
    print(
        "  posterior: " + ", ".join(f"p={p:g}: {q:.2f}" for p, q in ident.posterior_by_risk.items())
    )
    if not ident.informative:
        min_s_e = min(d.min_s_e for d in ident.per_demo)
        print(
            "  not informative: the TV never came near enough for the risk to matter "
            f"(min s_e {min_s_e:.1f}); the interval is the whole grid"
        )
    if not ident.trigger_fired and not isinstance(library, DriverLibrary):
        print("  note: the trigger never fired (the reactive features are inactive)")
    print(f"  {payload['identify_s']:.2f} s; wrote {args.out}/identify.json")
    return payload


def _distinct_files(paths: list[Path]) -> list[Path]:
    """``paths`` without repeats — the same file (resolved) or the same bytes — said on stderr.

    The first of each is kept; a missing file too (loading it names it).
    """
    kept: list[Path] = []
    spelled: dict[Path, Path] = {}  # a resolved file → how it was first given
    given: dict[Path, int] = {}  # … → how often it was given
    by_content: dict[str, Path] = {}
    copies: list[tuple[Path, Path]] = []  # (a file, the kept one of the same bytes)
    for path in paths:
        real = path.resolve()
        if real in spelled:
            given[real] += 1
            continue
        spelled[real], given[real] = path, 1
        digest = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
        if digest is not None and digest in by_content:
            copies.append((path, by_content[digest]))
            continue
        if digest is not None:
            by_content[digest] = path
        kept.append(path)
    said = [f"{spelled[r]} given {n} times" for r, n in given.items() if n > 1]
    said += [f"{p} has the content of {first}" for p, first in copies]
    if said:
        print(f"note: each demonstration counts once: {'; '.join(said)}", file=sys.stderr)
    return kept


if __name__ == "__main__":
    run_cli(main)
