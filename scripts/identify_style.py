r"""Identify the driving style (risk level) of one vehicle from its demonstration(s).

Scores every style of a library by reproducing r*_θ in each demonstration's own scenario
(``--scorer``: suboptimality [default], rmse_y or feature; see irl.library) and writes
``OUT/identify.json`` with ``risk_estimate``, ``risk_interpolated``, ``scores`` (per
library risk, all scorers under ``all_scores``) and ``ranking``.

Example:
    python scripts/identify_style.py runs/demo/demo.npz --library runs/library_reactive \\
        --out runs/identify
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from envs import load_demonstration
from envs.demonstration import DemonstrationError
from envs.results import write_json
from irl.library import SCORERS, LibraryError, identify, load_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("demos", nargs="+", type=Path, help="demonstration(s) of one vehicle")
    p.add_argument("--library", type=Path, required=True, help="library folder or json")
    p.add_argument("--scorer", default="suboptimality", choices=SCORERS)
    p.add_argument("--out", type=Path, default=Path("runs/identify"))
    p.add_argument("--seed", type=int, default=0, help="unused: identification is deterministic")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Identify; returns identify.json's payload."""
    args = parse_args(argv)
    try:
        library = load_library(args.library)
        demos = [load_demonstration(p) for p in args.demos]
        t0 = time.perf_counter()
        result = identify(demos, library, scorer=args.scorer)
    except (FileNotFoundError, DemonstrationError, LibraryError) as exc:
        sys.exit(f"error: {exc}")
    result |= {
        "identify_s": time.perf_counter() - t0,
        "library": str(args.library),
        "demos": [str(p) for p in args.demos],
        "true_risk": [d.meta.get("risk") for d in demos],
    }
    write_json(args.out / "identify.json", result, [sys.argv[0], *(argv or sys.argv[1:])])
    print(
        f"risk estimate {result['risk_estimate']:g} (interpolated "
        f"{result['risk_interpolated']:.3f}); ranking {result['ranking']}; "
        f"{result['identify_s']:.2f} s"
    )
    return result


if __name__ == "__main__":
    main()
