"""The walk from a recorded table to a prediction, as the modules whose functions run.

DESIGN §20, RESULTS §18. Writes the shipped NGSIM sample as one generic table (with its
lanes file), runs ``extract-episodes`` on it and ``predict-trajectory`` on the first
episode, both in this process under a profiler, and prints (and writes to
``OUT/walk.json``) the drivestyle modules whose functions ran, per package, and how often
the view was made and the inputs recovered. Run from a checkout beside ``../shared/data``::

    python tools/walk_trace.py OUT LIBRARY
"""

from __future__ import annotations

import collections
import json
import shutil
import sys
from pathlib import Path
from typing import Any


def main(out: Path, library: str) -> dict[str, Any]:
    """Trace the walk; returns (and writes) what ran."""
    from drivestyle.recorded.readers import read_sample, write_table
    from drivestyle.scripts import extract_episodes, predict_trajectory

    out.mkdir(parents=True, exist_ok=True)
    table, lanes = out / "ngsim.csv", out / "ngsim_lanes.json"
    write_table(read_sample("../shared/data/ngsim"), str(table), str(lanes))
    calls: collections.Counter[tuple[str, str]] = collections.Counter()

    def profile(frame: Any, event: str, arg: Any) -> None:
        if event == "call":
            name = frame.f_globals.get("__name__", "")
            if name.startswith("drivestyle."):
                calls[(name, frame.f_code.co_name)] += 1

    def traced(fn: Any, argv: list[str]) -> None:
        sys.setprofile(profile)
        try:
            fn(argv)
        finally:
            sys.setprofile(None)

    episodes, prediction = out / "episodes", out / "prediction"
    for folder in (episodes, prediction):
        shutil.rmtree(folder, ignore_errors=True)
    traced(extract_episodes.main, [str(table), "--lanes", str(lanes), "--out", str(episodes)])
    demo = sorted(episodes.glob("*.npz"))[0]
    argv = [str(demo), "--library", library, "--observe", "2", "--out", str(prediction)]
    traced(predict_trajectory.main, argv)
    modules = sorted({m for m, _ in calls})
    counted = ("recover_inputs", "observed_view", "recorded_view", "with_recorded_bounds")
    result = {
        "command": " ".join(["python", *sys.argv]),
        "episode": demo.name,
        "modules": len(modules),
        "packages": dict(collections.Counter(m.split(".")[1] for m in modules)),
        "calls": {f: sum(n for (_, g), n in calls.items() if g == f) for f in counted},
        "module_list": modules,
    }
    (out / "walk.json").write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python tools/walk_trace.py OUT LIBRARY")
    res = main(Path(sys.argv[1]), sys.argv[2])
    print(json.dumps({k: v for k, v in res.items() if k != "module_list"}, indent=1))
