r"""Predict the rest of a vehicle's trajectory after observing its first seconds.

Observes the demonstration for ``--observe`` seconds (a whole number of samples, less than
the demonstration), identifies the vehicle online (its inputs unseen) and predicts the rest
with every method of prediction/methods.py: constant velocity (``cv``) and acceleration (``ca``),
the physics baseline (``physics``: IDM behind the observed leader and a quintic lane
change, with ``--physics``'s parameters, by default the benchmark's calibration), the joint
physics baseline (``joint_physics``: IDM and MOBIL for every observed vehicle rolled out
together, with ``--joint-physics``'s parameters, by default the benchmark's calibration), the
library's style at its middle risk (``population``), the identified style at the
posterior's mode (``mode``) and its mixture over the library's risks (``mixture``), and —
for an SMPC demonstration (``risk`` and ``smpc`` in its metadata) — the SMPC itself
(``oracle``). The prediction is the recorded benchmark's (``evaluate-prediction``) of the
same episode at the same t_obs, method by method: a recorded episode (``episode_id`` in
its metadata, e.g. from ``extract-episodes``) is seen as an observer knows it then (the one
recorded view of its observed samples, its frame shifted by whole lanes so that the current
lane is the middle one, the scenario from the observed samples only;
recorded/observed.py). Writes ``OUT/prediction.json`` (per method ``ade_m``,
``fde_m``, their lateral and longitudinal parts, ``risk`` and the predicted ``path``; the
observed and true paths; the posterior at t_obs; ``lateral_shift_m``: the frame's lateral
shift from the file's, to add back to compare with the file) and ``OUT/prediction.png``
(the road to scale). Deterministic, so there is no ``--seed``.

Example:
    python scripts/predict_trajectory.py runs/demo/demo.npz --library runs/library \\
        --observe 2 --out runs/predict
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drivestyle.common.cli import HelpFormatter, for_option, positive_float, run_cli
from drivestyle.common.io import atomic_output_dir, check_output_dir, write_json
from drivestyle.envs.demonstration import check_plausible, load_demonstration
from drivestyle.irl.identification.library import load_driver_library
from drivestyle.prediction.joint_physics_calibration import JOINT_PHYSICS_FILE, load_joint_params
from drivestyle.prediction.methods import predict_demo
from drivestyle.prediction.physics_calibration import PHYSICS_FILE, load_params
from drivestyle.prediction.style import oracle_style
from drivestyle.recorded.observed import observer_view
from drivestyle.recorded.real_data import is_recorded
from drivestyle.studies.prediction.figures import plot_prediction


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
        "--physics",
        type=Path,
        default=PHYSICS_FILE,
        help="the physics baseline's parameters (default: the benchmark's calibration)",
    )
    p.add_argument(
        "--joint-physics",
        type=Path,
        default=JOINT_PHYSICS_FILE,
        help="the joint physics baseline's parameters (default: the benchmark's calibration)",
    )
    p.add_argument(
        "--out", type=Path, default=Path("runs/predict"), help="output folder (replaced whole)"
    )
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    """Predict; returns prediction.json's payload."""
    args = parse_args(argv)
    check_output_dir(args.out, inputs=[args.demo, args.library, args.physics, args.joint_physics])
    with for_option("--physics"):
        physics = load_params(args.physics)
    with for_option("--joint-physics"):
        joint_physics = load_joint_params(args.joint_physics)
    library = load_driver_library(args.library, "prediction")
    raw = load_demonstration(args.demo)
    check_plausible(raw)  # every step, the future the prediction is scored on included
    seen, scenario = observer_view(raw, args.observe)  # seen once: predicted and drawn in it
    pred = predict_demo(
        raw,
        library,
        args.observe,
        oracle_style(raw.meta),
        physics,
        view=(seen, scenario),
        joint_physics=joint_physics,
    )
    payload = pred.to_json() | {
        "demo": str(args.demo),
        "library": str(args.library),
        "physics": str(args.physics),
        "joint_physics": str(args.joint_physics),
        "recorded": is_recorded(raw),
        "v_ref_mps": (scenario or raw.scenario).v_ref,
        "lateral_shift_m": float(seen.meta.get("observed_shift_m", 0.0)),
    }
    with atomic_output_dir(args.out) as tmp:
        write_json(tmp / "prediction.json", payload, [sys.argv[0], *(argv or sys.argv[1:])])
        name = raw.meta.get("episode_id", args.demo.stem)
        plot_prediction(
            pred, seen, tmp / "prediction.png", f"{name}: prediction after {args.observe:g} s"
        )
    ident = pred.identification
    if ident is not None:
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
    for method, m in pred.methods.items():
        print(f"  {method:<10} ADE {m.ade_m:7.3f} m  FDE {m.fde_m:7.3f} m")
    print(f"wrote {args.out}/prediction.json and prediction.png")
    return payload


if __name__ == "__main__":
    run_cli(main)
