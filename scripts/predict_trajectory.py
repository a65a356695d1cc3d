r"""Predict the rest of a vehicle's trajectory after observing its first seconds.

Observes the demonstration for ``--observe`` seconds (a whole number of samples, less than
the demonstration), identifies the vehicle online (its inputs unseen) and predicts the rest
with every method of irl/forecast.py: constant velocity (``cv``) and acceleration (``ca``),
the library's style at its middle risk (``population``), the identified style at the
posterior's mode (``mode``) and its mixture over the library's risks (``mixture``), and —
for an SMPC demonstration (``risk`` and ``smpc`` in its metadata) — the SMPC itself
(``oracle``). Writes ``OUT/prediction.json`` (per method ``ade_m``, ``fde_m``, ``risk``
and the predicted ``path``; the observed and true paths; the posterior at t_obs) and
``OUT/prediction.png`` (the road to scale). A recorded episode (``episode_id`` in its
metadata, e.g. from ``real-traffic``) is used as the driver model sees it (recovered inputs,
widened bounds, no own-line shift) and its style methods take v_ref from the observed
speeds only (agents/studies/prediction.py). Deterministic, so there is no ``--seed``.

Example:
    python scripts/predict_trajectory.py runs/demo/demo.npz --library runs/library \\
        --observe 2 --out runs/predict
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.agents.studies.figures import plot_prediction
from drivestyle.agents.studies.prediction import observed_scenario, oracle_style, prepare_demo
from drivestyle.common.cli import HelpFormatter, positive_float, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import check_plausible, load_demonstration
from drivestyle.irl.forecast import predict
from drivestyle.irl.library import load_driver_library


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line arguments."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=HelpFormatter)
    p.add_argument("demo", type=Path, help="the vehicle's demonstration (.npz)")
    p.add_argument(
        "--library", type=Path, required=True, help="driver library folder or its library.json"
    )
    p.add_argument(
        "--observe",
        type=positive_float,
        default=2.0,
        help="seconds observed before predicting (a whole number of samples)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/predict"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Predict; returns prediction.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.demo])
    library = load_driver_library(args.library, "prediction")
    raw = load_demonstration(args.demo)
    check_plausible(raw)  # every step, the future the prediction is scored on included
    demo, recorded = prepare_demo(raw)
    scenario = observed_scenario(demo, args.observe) if recorded else None
    pred = predict(demo, library, args.observe, oracle=oracle_style(demo.meta), scenario=scenario)
    payload = pred.to_json() | {
        "demo": str(args.demo),
        "library": str(args.library),
        "recorded": recorded,
        "v_ref_mps": (scenario or demo.scenario).v_ref,
    }
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "prediction.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        name = raw.meta.get("episode_id", args.demo.stem)
        plot_prediction(
            pred, demo, tmp / "prediction.png", f"{name}: prediction after {args.observe:g} s"
        )
    ident = pred.identification
    if ident is None:  # no style method was run: nothing identified to report
        return payload
    lo, hi = ident.risk_interval
    # only an informative posterior is an identified risk; the others say what they are first
    v = ident.verdict
    said = (
        "posterior mean"
        if v is None
        else ("identified risk" if v.informative else f"{v.phrase}; posterior mean")
    )
    print(
        f"observed {args.observe:g} s, predicted {payload['horizon_s']:.1f} s; {said} "
        f"{ident.risk_interpolated:.3f} (90 % [{lo:g}, {hi:g}])"
        + ("" if pred.true_risk is None else f", true {pred.true_risk:g}")
    )
    for name, m in pred.methods.items():
        print(f"  {name:<10} ADE {m.ade_m:7.3f} m  FDE {m.fde_m:7.3f} m")
    print(f"wrote {args.out}/prediction.json and prediction.png")
    return payload


if __name__ == "__main__":
    run_cli(main)
