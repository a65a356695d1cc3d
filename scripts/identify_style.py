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
demonstrations of one vehicle pool into one posterior.

Example:
    python scripts/identify_style.py runs/demo/demo.npz --library runs/library_reactive \\
        --out runs/identify
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from drivestyle.common.cli import run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import load_demonstration
from drivestyle.irl.identification import DEFAULT_SCORER, SCORERS, identify
from drivestyle.irl.library import DriverLibrary, load_any_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
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
    demos = [load_demonstration(p) for p in args.demos]
    t0 = time.perf_counter()
    ident = identify(demos, library, scorer=args.scorer)
    payload = ident.to_json() | {
        "identify_s": time.perf_counter() - t0,
        "library": str(args.library),
        "demos": [str(p) for p in args.demos],
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


if __name__ == "__main__":
    run_cli(main)
