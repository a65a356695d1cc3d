"""Which states of a recorded episode's surrounding vehicles were observed (DESIGN §15).

The extraction resamples each interacting vehicle from its recorded samples where the
window overlaps its track and continues it at constant velocity before its first and
after its last recorded sample (:mod:`drivestyle.recorded.resampling`); it says which is
which in :attr:`~drivestyle.envs.demonstration.Demonstration.observed` (True: a recorded
sample). :func:`observed_mask` is what every consumer calls: that mask where the
demonstration carries one, all True for a simulated demonstration, and for a recorded one
written before the mask was carried the mask :func:`mask_from_repeats` derives — the
fallback rule, in this one function.

The fallback rule: the continuation holds the heading φ and the speed v of the edge state
exactly (bitwise), while recorded states never repeat both bitwise from one sample to the
next; so the leading samples that repeat the first state's (φ, v) are continued up to the
last of them (the first recorded sample, whose state the continuation copies), and the
trailing samples that repeat the last state's are continued after the first of them. On
every shipped episode it gives the extraction's mask exactly (tested); it would take a
vehicle standing still with a recorded heading and speed that repeat bitwise for a
continuation.
"""

from __future__ import annotations

import numpy as np

from drivestyle.envs.demonstration import Demonstration

__all__ = ["mask_from_repeats", "observed_mask"]


def mask_from_repeats(vehicles: np.ndarray) -> np.ndarray:
    """The fallback rule: a vehicle's states are observed unless they repeat an edge's (φ, v).

    For each vehicle, the leading samples whose (φ, v) equal the first sample's bitwise
    are the continuation before its first recorded sample (the last of them is that
    sample); the trailing samples whose (φ, v) equal the last sample's are the
    continuation after its last recorded sample (the first of them is that sample). A
    vehicle whose (φ, v) never change is a continuation throughout (the extraction's
    vehicle recorded at most once in the window).

    Args:
        vehicles: the surrounding vehicles' states [x, y, φ, v], shape (n, m, 4)
            (:attr:`~drivestyle.envs.demonstration.Demonstration.vehicles`).

    Returns:
        True where a state is a recorded sample, shape (m, n) bool.
    """
    vehicles = np.asarray(vehicles, float)
    n, m = vehicles.shape[:2]
    mask = np.ones((m, n), bool)
    for j in range(m):
        heading_speed = vehicles[:, j, 2:4]
        as_first = np.all(heading_speed == heading_speed[0], axis=1)
        if as_first.all():
            mask[j] = False
            continue
        lead = int(np.argmin(as_first))  # samples repeating the first state
        trail = int(np.argmin(np.all(heading_speed == heading_speed[-1], axis=1)[::-1]))
        mask[j, : lead - 1] = False
        mask[j, n - trail + 1 :] = False
    return mask


def observed_mask(demo: Demonstration) -> np.ndarray:
    """Which surrounding vehicle's states are recorded samples, per sample.

    Args:
        demo: a demonstration (recorded or simulated).

    Returns:
        Shape (1 + m, n) bool, rows in ``demo.vehicles`` order (TV first): the
        demonstration's own mask where it carries one; all True for a simulated one; the
        fallback rule (:func:`mask_from_repeats`) for a recorded one without a mask (a
        file written before the mask was carried).
    """
    if demo.observed is not None:
        return demo.observed
    if demo.origin == "recorded":
        return mask_from_repeats(demo.vehicles)
    return np.ones((demo.vehicles.shape[1], demo.n), bool)
