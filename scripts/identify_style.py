r"""Identify the driving style (risk level) of one vehicle from its demonstration(s).

With a driver library (the default ``build_style_library.py`` output, DESIGN §15) the
risk is a continuous parameter of the library's one style: its posterior over p ∈ [0.5,
0.99] comes from the demonstration's residuals under that style (``scorer`` is
``likelihood``; ``posterior_density`` holds the continuous posterior, ``posterior`` its
mass per library risk). With a paper-model library (``--model paper``) every style is
scored by reproducing r*_θ in each demonstration's own scenario (``--scorer``, default: the
one validation picked; see irl/identification/paper_scorers.py). Writes
``OUT/identify.json`` with ``scorer``, ``risk_estimate`` (the library risk of the
largest posterior mass; the printed estimate is the density's mode, ``risk_mode``),
``risk_interpolated`` (posterior mean), ``posterior`` (per library risk), ``risk_interval``
(90 % of the posterior), ``scores``, ``ranking``, ``trigger_fired``, per demonstration
``constraint_binds_per_demo`` and ``min_s_e_per_demo`` and, where the demonstrations'
metadata holds it, ``true_risk``. The verdict
(:class:`~drivestyle.irl.identification.verdict.Verdict`): ``verdict``, one label of
``informative``, ``prior``, ``no_constraint``, ``out_of_class`` and ``enters_region``
(:func:`~drivestyle.irl.identification.verdict.verdict_label`), the flags it comes from
(``informative`` is the label ``informative``; ``out_of_class`` is either label of a driver the
class does not describe; ``constraint_binds``, ``enters_region``), the numbers (``residual_rms``,
``noise_floor``, ``residual_floors``, ``kl_nats``, ``interval_width_ratio``, ``min_s_e``) and
``reason``. The printed summary says the verdict first; only an informative one is headed by a risk
estimate. ``--plot`` also writes ``OUT/identify.png``: the posterior with the prior and the 90 %
interval, and the library's style driven in closed loop at the identified risk over each
recorded path (driver libraries). ``--posterior FILE`` (an estimator ``drivestyle
build-posterior`` wrote, its ``posterior.npz``) also identifies each demonstration with the
amortized posterior over the stochastic driver's parameters (DESIGN §22; each demonstration
on its own: an amortized posterior does not pool): ``identify.json``'s ``amortized`` holds,
per demonstration, every parameter's posterior mean, median and 90 % interval (the risk p
first) from 200 draws, with the estimator's checksum, and the summary prints them. Several
demonstrations of one vehicle pool into one posterior; a file given twice, or two files of
the same content, count once (one would weigh as two), and a line on stderr says which.
Demonstrations of several recorded vehicles pool too, but a note on stderr names the
vehicles and ``identify.json`` says so (``vehicles``: each demonstration's,
``pools_several_vehicles``). A recorded vehicle is ``<carriageway>:<vehicle id>`` of its
recording, from the episode's metadata (``meta["vehicle_id"]``, ``meta["source"]``, the
carriageway in the extraction's ``episode_id``; recorded/real_data.py ``recorded_vehicle``); a
generated demonstration names no vehicle and is taken to be the vehicle of the others.

Example:
    python scripts/identify_style.py runs/demo/demo.npz --library runs/library_reactive \\
        --out runs/identify
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, run_cli
from drivestyle.common.inputs import distinct_files
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import Demonstration, load_demonstration
from drivestyle.irl.amortized.identify import (
    SAMPLES,
    AmortizedStyle,
    identify_amortized_batch,
    open_posterior,
)
from drivestyle.irl.driver.driver_style import DriverStyleError, Reproduction, reproduce
from drivestyle.irl.identification.library import DriverLibrary, StyleLibrary, load_any_library
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER, SCORERS
from drivestyle.irl.identification.posterior import identify
from drivestyle.irl.identification.result import Identification
from drivestyle.irl.identification.verdict import (
    INFORMATIVE,
    NO_CONSTRAINT,
    OUT_OF_CLASS_FACTOR,
    PRIOR,
)
from drivestyle.recorded.real_data import recorded_vehicle


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
    p.add_argument(
        "--plot",
        action="store_true",
        help="also write identify.png: the posterior with the prior and the 90 %% interval, "
        "and the style's reproduction at the identified risk over the recorded path",
    )
    p.add_argument(
        "--posterior",
        type=Path,
        default=None,
        help="an amortized posterior (build-posterior's posterior.npz): also each "
        "demonstration's posterior mean and 90 %% interval of every driver parameter",
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Identify; returns identify.json's payload."""
    args = parse_args(argv)
    estimator = [args.posterior] if args.posterior is not None else []
    check_output_dir(args.out, inputs=[*args.demos, args.library, *estimator])
    library = load_any_library(args.library)
    posterior = open_posterior(args.posterior) if args.posterior is not None else None
    files = distinct_files(args.demos)
    if files.note:
        print(files.note, file=sys.stderr)
    paths = list(files.kept)
    demos = [load_demonstration(p) for p in paths]
    vehicles = vehicle_names(demos)
    pooled = pooling_note(vehicles, paths)
    if pooled:  # legal, but the posterior is then of no one vehicle
        print(pooled, file=sys.stderr)
    t0 = time.perf_counter()
    ident = identify(demos, library, scorer=args.scorer)
    payload = ident.to_json() | {
        "identify_s": time.perf_counter() - t0,
        "library": str(args.library),
        "demos": [str(p) for p in paths],
        "vehicles": vehicles,
        "pools_several_vehicles": pooled is not None,
    }
    amortized: list[AmortizedStyle] = []
    if posterior is not None:
        t0 = time.perf_counter()
        amortized = identify_amortized_batch(posterior, demos)
        payload["amortized"] = {
            "estimator": str(args.posterior),
            "estimator_sha256": amortized[0].estimator_sha256,
            "samples": SAMPLES,
            "seed": 0,
            "seconds": time.perf_counter() - t0,
            "demos": [
                {"demo": str(p)} | a.to_json() for p, a in zip(paths, amortized, strict=True)
            ],
        }
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "identify.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        if args.plot:
            _plot(ident, demos, library, tmp / "identify.png")
    for line in summary_lines(ident, len(demos)):
        print(line)
    print(
        "  posterior: " + ", ".join(f"p={p:g}: {q:.2f}" for p, q in ident.posterior_by_risk.items())
    )
    if not ident.trigger_fired and not isinstance(library, DriverLibrary):
        print("  note: the trigger never fired (the reactive features are inactive)")
    for path, style in zip(paths, amortized, strict=True) if amortized else ():
        print(f"  amortized posterior of {path.name} (mean [90 % interval]): {style.describe()}")
    wrote = "identify.json" + (" and identify.png" if args.plot else "")
    print(f"  {payload['identify_s']:.2f} s; wrote {wrote} in {args.out}")
    return payload


def vehicle_names(demos: list[Demonstration]) -> list[str | None]:
    """Each demonstration's vehicle as ``<carriageway>:<vehicle id>`` (None: none known).

    The rule is :func:`~drivestyle.recorded.real_data.recorded_vehicle`'s (a generated
    demonstration is of no known vehicle); two recordings that share a carriageway's name
    are told apart by their files.
    """
    keys = [recorded_vehicle(d) for d in demos]
    named = {k: str(k) for k in keys if k is not None}
    if len(set(named.values())) < len(named):  # one name, two recordings
        named = {k: f"{k} of {k.source}" for k in named}
    return [None if k is None else named[k] for k in keys]


def pooling_note(vehicles: list[str | None], paths: list[Path]) -> str | None:
    """The note that a pooled identification is of several vehicles (None: of one).

    Several vehicles: two or more known ones, or a known one with a demonstration of no
    known vehicle. Demonstrations of no known vehicle alone are the one vehicle the user
    says they are (nothing in their metadata says otherwise).
    """
    known = list(dict.fromkeys(v for v in vehicles if v is not None))
    unknown = [p for v, p in zip(vehicles, paths, strict=True) if v is None]
    if len(known) + (1 if unknown and known else 0) < 2:
        return None
    files = {v: [p.name for w, p in zip(vehicles, paths, strict=True) if w == v] for v in known}
    said = [f"{v} ({', '.join(files[v])})" for v in known]
    if unknown:
        said.append(f"{len(unknown)} of no known vehicle ({', '.join(p.name for p in unknown)})")
    n = len(known) + (1 if unknown else 0)
    return (
        f"note: pooling {'at least ' if unknown else ''}{n} vehicles into one posterior: "
        f"{'; '.join(said)}; identify each vehicle on its own to tell their risks apart"
    )


def summary_lines(ident: Identification, n_demos: int) -> list[str]:
    """The printed summary: the verdict first (its phrase and why), then the numbers.

    Only an ``informative`` verdict is headed by a risk estimate; for the others the
    numbers follow as what they are (the prior's, or the nearest style's of a class that
    does not describe the driver), so a posterior that is the prior never reads as an answer.

    Args:
        ident: the identification (with its verdict, as :func:`identify` returns it).
        n_demos: how many demonstrations it pooled.
    """
    v = ident.verdict
    assert v is not None  # identify attaches one to every identification
    known = sorted({p for p in ident.true_risks if p is not None})
    lo, hi = ident.risk_interval
    numbers = (
        f"90 % interval [{lo:g}, {hi:g}], posterior mean {ident.risk_interpolated:.3f} "
        f"({ident.scorer} scorer, {n_demos} demonstration{'s' if n_demos > 1 else ''}"
        + (f"; true risk {', '.join(f'{p:g}' for p in known)})" if known else ")")
    )
    if v.label == INFORMATIVE:
        numbers = f"risk estimate {ident.risk_mode:g}, {numbers}"
    elif v.label in (PRIOR, NO_CONSTRAINT):
        numbers = f"posterior ≈ the prior: {numbers}"
    else:
        numbers = f"the risk of the class's nearest style, not this driver's: {numbers}"
    lines = [v.headline, f"  {numbers}"]
    if v.floors is not None:
        lines.append(
            f"  residual {v.residual_rms:.2f} σ_u = {v.floors:.1f} noise floors (out of class "
            f"above {OUT_OF_CLASS_FACTOR:g})"
        )
    return lines


def _plot(
    ident: Identification,
    demos: list[Demonstration],
    library: DriverLibrary | StyleLibrary,
    path: Path,
) -> None:
    """identify.png: posterior and prior, and the reproduction at the identified risk."""
    # matplotlib: on demand
    from drivestyle.studies.identification.figures import plot_identification

    reproductions: list[Reproduction | None] = []
    for demo in demos:
        rep = None
        if isinstance(library, DriverLibrary):
            style = replace(library.style, risk=ident.risk_interpolated)
            try:
                rep = reproduce(style, demo)
            except DriverStyleError as exc:  # the posterior is still worth a figure
                print(f"  note: no reproduction drawn: {exc}", file=sys.stderr)
        reproductions.append(rep)
    plot_identification(ident, demos, reproductions, path)


if __name__ == "__main__":
    run_cli(main)
