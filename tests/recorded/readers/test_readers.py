"""Every reader of recorded/readers/: in READERS, and checked by the one home of the rules."""

import numpy as np
import pandas as pd
import pytest
from published_files import (
    _cats_sample,
    _interaction_vehicle,
    _levelx_vehicle,
    _ngsim_table,
    _write_classic,
    _write_levelx,
)

from drivestyle.recorded.readers import (
    READERS,
    read_interaction,
    read_levelx,
    read_ngsim,
)
from drivestyle.recorded.tracks import TrackError


def test_readers_are_registered():
    assert READERS["ngsim"] is read_ngsim
    assert READERS["highd"] is read_levelx
    assert READERS["interaction"] is read_interaction


@pytest.mark.parametrize(
    ("fmt", "unit"),
    [("ngsim", "6 of 6 vehicles drive at a median 152 m/s by the speed column"),
     ("highd", "km/h given as m/s (÷ 3.6: 30 m/s)?"),
     ("interaction", "degrees?"), ("sample", "times in milliseconds? divide by 1000")],
)  # fmt: skip
def test_every_reader_applies_the_readers_checks(tmp_path, fmt, unit):
    """One home for the rules: a fleet in another unit is refused whatever the format."""
    if fmt == "ngsim":
        df = _ngsim_table()
        df["v_Vel"] *= 10  # 500 ft/s
        read = lambda: read_ngsim(_write_classic(df, tmp_path / "t.txt"))  # noqa: E731
    elif fmt == "highd":
        vehicles = [_levelx_vehicle(k, 100.0 + 20 * k, 20.0, 20.0, -30.0 * 3.6) for k in (1, 2)]
        path = _write_levelx(tmp_path, vehicles, {1: 1, 2: 1})
        read = lambda: read_levelx(path)  # noqa: E731
    elif fmt == "interaction":
        rows = [_interaction_vehicle(1, k, (15.25, 900.0 + 50 * k), (0.0, 20.0), (-3.5, 0.0))
                for k in (1, 2)]  # fmt: skip
        df = pd.concat(rows, ignore_index=True)
        df["psi_rad"] = np.degrees(df["psi_rad"])
        path = tmp_path / "vehicle_tracks_000.csv"
        df.to_csv(path, index=False)
        read = lambda: read_interaction(path, [10.0, 13.5, 17.0, 20.5], direction="y+")  # noqa: E731
    else:
        folder = _cats_sample(tmp_path / "sample", t_s=lambda t: t * 1000)
        read = lambda: READERS["sample"](folder)  # noqa: E731
    with pytest.raises(TrackError) as info:
        read()
    assert unit in str(info.value) and "\n" not in str(info.value)
