"""The shipped NGSIM and CATS samples through the one extraction (RESULTS §13).

``read_sample`` reads each sample's ``tracks.csv.gz`` (every vehicle of every recording) and
:func:`extract_episodes` finds every lane change in it; the converters' curated
``episodes.csv`` lists the changes the learning studies use, and the loaders of
:mod:`drivestyle.recorded.real_data` match each of its rows to an extracted change. A row
matches when it has the same recording, the same ego vehicle and a crossing time within
±0.5 s (the converters' t_cross is the first sample in the new lane, the extraction's the
interpolated line crossing: I-80 is sampled at 2 Hz). Every *used* curated episode must be
found and usable; the remaining differences are counted and explained below.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest

from drivestyle.recorded.episodes import Episode, extract_episodes
from drivestyle.recorded.readers import READERS
from drivestyle.recorded.real_data import load_cats, load_ngsim

DATA = Path(__file__).resolve().parents[3] / "shared" / "data"
pytestmark = [
    pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not beside the checkout"),
    pytest.mark.slow,  # ~6 s: both loaders and every lane change of 203 tracks
]

MATCH_S = 0.5
"""Crossing times of the same lane change in the two pipelines differ by at most this [s]."""

KNOWN_MISSING: dict[str, str] = {}
"""Used loader episodes the extraction does not find (episode id → why). None today: the
loaders' unused episodes it misses are all ramp/auxiliary-lane changes (below)."""


@dataclass
class Comparison:
    loader: pd.DataFrame
    """``episodes.csv`` with the loader's ``used`` and the matched extraction episode."""
    extracted: list[Episode]
    extra: list[Episode]
    """Extracted episodes no loader episode matches."""

    def counts(self) -> dict[str, int]:
        found = self.loader.match.notna()
        return {
            "loader": len(self.loader),
            "used": int(self.loader.used.sum()),
            "extracted": len(self.extracted),
            "extracted_usable": sum(e.usable for e in self.extracted),
            "matched": int(found.sum()),
            "matched_used": int((found & self.loader.used).sum()),
            "extra": len(self.extra),
            "missing": int((~found).sum()),
            "missing_used": int((~found & self.loader.used).sum()),
        }


def _compare(folder: str, loader, recording: str) -> Comparison:
    extracted = extract_episodes(READERS["sample"](DATA / folder))
    rows = pd.read_csv(DATA / folder / "episodes.csv")
    used = {e.episode_id: e.used for e in loader(DATA / folder, neighbours=False)}
    rows["used"] = rows.episode_id.map(used).astype(bool)
    matches, taken = [], set()
    for r in rows.itertuples():
        m = [
            e
            for e in extracted
            if e.carriageway == str(getattr(r, recording))
            and e.vehicle_id == str(r.ego_id)
            and abs(e.t_cross - r.t_cross_s) <= MATCH_S
        ]
        assert len(m) <= 1, (r.episode_id, [e.episode_id for e in m])
        matches.append(m[0] if m else None)
        taken.update(e.episode_id for e in m)
    rows["match"] = matches
    extra = [e for e in extracted if e.episode_id not in taken]
    return Comparison(rows, extracted, extra)


@pytest.fixture(scope="module")
def ngsim() -> Comparison:
    return _compare("ngsim", load_ngsim, "recording")


@pytest.fixture(scope="module")
def cats() -> Comparison:
    return _compare("cats-av-lanechange", load_cats, "run_id")


@pytest.mark.parametrize("which", ["ngsim", "cats"])
def test_every_used_loader_episode_is_extracted(which, request):
    c = request.getfixturevalue(which)
    print(which, c.counts())
    for r in c.loader[c.loader.used].itertuples():
        if r.episode_id in KNOWN_MISSING:
            continue
        assert r.match is not None, f"{r.episode_id}: not extracted"
        assert r.match.usable, (r.episode_id, r.match.reasons)


def test_ngsim_differences(ngsim):
    c = ngsim
    assert c.counts() == {
        "loader": 19,
        "used": 12,
        "extracted": 19,
        "extracted_usable": 14,
        "matched": 14,
        "matched_used": 12,
        "extra": 5,
        "missing": 5,
        "missing_used": 0,
    }
    # missing: the 5 ramp / auxiliary-lane changes (I-80 lane 7, US-101 lanes 6–8), which the
    # loader does not use either; read_sample gives those lanes index −1 (off the main lanes)
    missing = c.loader[c.loader.match.isna()]
    assert missing.involves_ramp_or_aux_lane.all() and not missing.used.any()
    # unused by the loader for an incomplete ±4 s window but matched: the extraction keeps a
    # window cut to ≥ 3 s before and ≥ 2 s after (v115: usable), v7 has 2.2 s before (not)
    unused = c.loader[c.loader.match.notna() & ~c.loader.used]
    assert {r.episode_id: r.match.usable for r in unused.itertuples()} == {
        "i80_1600_first60s_v7_t17.0": False,
        "i80_1600_first60s_v115_t57.8": True,
    }
    # extra: lane changes the converter rejected (summary.json episode_filter_stats): another
    # change of the same vehicle within ±4 s (I-80 v108 3→4→3 in 1 s, v41 two changes 3.4 s
    # apart: the extraction's rule is only 1 s in each lane) and short coverage (US-101 v329,
    # 1.1 s after the crossing: unusable in the extraction too)
    extra = sorted((e.carriageway, e.vehicle_id, round(e.t_cross, 1), e.usable) for e in c.extra)
    assert extra == [
        ("i80_1600_first60s", "108", 52.5, False),
        ("i80_1600_first60s", "108", 53.5, False),
        ("i80_1600_first60s", "41", 55.2, True),
        ("i80_1600_first60s", "41", 58.6, False),
        ("us101_scene_ego320", "329", 41.7, False),
    ]


def test_cats_differences(cats):
    c = cats
    counts = c.counts()
    assert counts["loader"] == 31 and counts["used"] == 10
    assert counts["matched"] == 31 and counts["missing"] == 0
    # the extraction's only usability difference on matched ones: a return-leg crossing of
    # AV-22-E whose TV (vehicle 4) sits across the lane line the whole window (the source's
    # inferred receiver offsets, README caveat 1) fails the plausibility check
    bad = [r.episode_id for r in c.loader.itertuples() if not r.match.usable]
    assert bad == ["AV-22-E_t102209.1"]
    # extra, (a): the loader's ego is always vehicle 3 (the experiment car); the extraction
    # takes every vehicle's changes, the other cars' included
    others = [e for e in c.extra if e.vehicle_id != "3"]
    # extra, (b): vehicle 3's lane-id changes the converter rejected (summary.json lists each
    # with its reason: outside the straight section, another change within ±4 s, short
    # coverage, small lateral move, U-turn heading); the extraction has no such rules
    rejected = json.loads((DATA / "cats-av-lanechange" / "summary.json").read_text())
    rejected = rejected["rejected_lane_id_changes"]

    def seconds(hms: str) -> float:
        h, m, s = hms.split(":")
        return 3600 * int(h) + 60 * int(m) + float(s)

    reasons = {}
    for e in c.extra:
        if e.vehicle_id != "3":
            continue
        why = [
            r["reason"]
            for r in rejected
            if r["run_id"] == e.carriageway and abs(seconds(r["t_utc"]) - e.t_cross) <= MATCH_S
        ]
        assert why, f"{e.episode_id}: vehicle 3's change is neither an episode nor rejected"
        reasons[e.episode_id] = why[0]
    print("cats extra: other vehicles", len(others), "| vehicle 3 rejected by the converter:")
    print(pd.Series(reasons).value_counts().to_string())
    assert len(others) + len(reasons) == counts["extra"]


@pytest.mark.parametrize("which", ["ngsim", "cats"])
def test_target_vehicle_choice(which, request):
    """The TV differs by design: the loaders take the nearest target-lane car at the
    crossing, the extraction the target-lane follower (else leader, else own-lane leader) at
    the window's start, 4 s earlier (NGSIM: the same TV in 6 of the 12 used episodes; CATS AV:
    vehicle 4 in all 6, ahead of the ego 4 s before the cut-in, so the target-lane leader
    there, the lag car at the crossing). The loader's target is always among the
    extraction's interacting vehicles."""
    c = request.getfixturevalue(which)
    used = c.loader[c.loader.used & c.loader.target_id.notna()]
    same_tv = seen = 0
    for r in used.itertuples():
        ids = [v for _, v in r.match.interacting]
        target = str(int(r.target_id))
        same_tv += bool(ids) and ids[0] == target
        seen += target in ids
    print(which, f"used with a target {len(used)}: same TV {same_tv}, among interacting {seen}")
    assert seen == len(used)
