"""The path ceiling (studies/identification/path_ceiling.py): distances, gaps, identifiability."""

import numpy as np
import pytest

from drivestyle.studies.identification.path_ceiling import (
    IDENTIFIABLE_GAP_M,
    is_identifiable,
    neighbour_gap,
    path_distance,
)


def _path(y: np.ndarray) -> np.ndarray:
    return np.column_stack([np.arange(len(y), dtype=float), y])


def test_the_identifiable_rule_uses_the_rms_gap_to_both_neighbours():
    n = 25
    flat = np.zeros(n)
    spike = flat.copy()
    spike[10] = 0.1  # parts for one step only: max 10 cm, RMS 2 cm
    paths = {0.5: _path(flat), 0.6: _path(spike), 0.7: _path(flat + 0.2), 0.8: _path(flat + 0.25)}
    grid = [0.5, 0.6, 0.7, 0.8]
    assert path_distance(paths[0.5], paths[0.6]) == pytest.approx(0.1 / np.sqrt(n))
    assert neighbour_gap(paths, 0.6, grid) == pytest.approx(0.02)  # nearer neighbour 0.5
    assert not is_identifiable(neighbour_gap(paths, 0.5, grid))  # its one neighbour is 0.6
    assert neighbour_gap(paths, 0.7, grid) == pytest.approx(0.05)  # 0.8 is 5 cm away
    assert is_identifiable(0.05) and not is_identifiable(0.0499) and not is_identifiable(None)
    assert IDENTIFIABLE_GAP_M == 0.05
    assert neighbour_gap(paths, 0.65, grid) is None  # off the grid
    assert neighbour_gap({0.5: paths[0.5], 0.6: paths[0.6]}, 0.6, grid) is None  # 0.7 missing
    # paths of unequal length are compared over their common part (as the ceiling does)
    assert path_distance(_path(flat + 0.2), _path(np.zeros(10))) == pytest.approx(0.2)
