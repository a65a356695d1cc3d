"""The walk from a recorded table to a prediction (DESIGN §20), traced call by call.

A recording goes up the layers and never down: read (``recorded.readers``), episodes
(``recorded``, on ``envs``' types and dynamics), the observer's view (``recorded.observed``),
the predictors (``prediction``). Nothing of ``studies`` or ``agents`` takes part, the view is
made once per prediction, and an episode's inputs are recovered once at extraction and
again only under the recorded bounds its observed heading needs.
"""

import sys
from collections import Counter
from pathlib import Path

import pytest

from drivestyle.prediction.methods import predict_demo
from drivestyle.recorded.episodes import ExtractionConfig, extract_episodes
from drivestyle.recorded.readers import read_sample

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
pytestmark = pytest.mark.skipif(
    not (DATA / "ngsim" / "tracks.csv.gz").is_file(), reason="the shipped datasets are absent"
)


def _traced(fn, *args, **kwargs):
    """``fn``'s result and the drivestyle (module, function) pairs it called, counted."""
    calls: Counter = Counter()

    def profile(frame, event, arg):
        if event == "call":
            name = frame.f_globals.get("__name__", "")
            if name.startswith("drivestyle."):
                calls[(name, frame.f_code.co_name)] += 1

    sys.setprofile(profile)
    try:
        result = fn(*args, **kwargs)
    finally:
        sys.setprofile(None)
    return result, calls


def _count(calls, function):
    return sum(n for (_, f), n in calls.items() if f == function)


def _packages(calls):
    return {module.split(".")[1] for module, _ in calls}


def test_a_recording_goes_up_the_layers_to_a_prediction():
    recording = read_sample(DATA / "ngsim")
    episodes, extraction = _traced(extract_episodes, recording, ExtractionConfig())
    demos = [e.demo for e in episodes if e.usable]
    assert demos and all(d.origin == "recorded" and d.observed is not None for d in demos)
    assert _count(extraction, "recover_inputs") == sum(e.demo is not None for e in episodes)
    assert _packages(extraction) <= {"common", "envs", "recorded"}

    # the episode whose observed heading needs the recorded bounds, and one that does not
    for demo in demos[:3]:
        pred, prediction = _traced(predict_demo, demo, None, 2.0, methods=("cv", "ca", "physics"))
        assert set(pred.methods) == {"cv", "ca", "physics"}
        assert _packages(prediction) <= {"common", "envs", "recorded", "prediction"}
        assert _count(prediction, "observed_view") == 1
        assert _count(prediction, "recover_inputs") == _count(prediction, "with_recorded_bounds")
        assert _count(prediction, "with_recorded_bounds") <= 1
