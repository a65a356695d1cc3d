"""The extraction's numbers (:class:`ExtractionConfig`) and their checks against a recording.

:class:`ExtractionConfig` holds how lane changes are found and turned into demonstrations
(the rules: :mod:`drivestyle.recorded.episodes`), each number checked on construction;
:func:`check_sampling` refuses settings a recording's sampling cannot meet, and
:func:`sampling_note` says when T_s is much finer than the data's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drivestyle.envs.units import MAX_GAP_S, ROAD_SPEED_MAX_MPS, off_grid
from drivestyle.recorded.tracks import Recording

__all__ = [
    "FINE_DT_RATIO",
    "SECONDS_PER_SAMPLE",
    "WINDOW_SAMPLES_MAX",
    "ExtractionConfig",
    "check_sampling",
    "sampling_note",
]

WINDOW_SAMPLES_MAX = 2000
"""The most samples an episode's window may hold (``(before_s + after_s) / dt``): each costs
≈ :data:`SECONDS_PER_SAMPLE` of input recovery, so the bound is ≈ 1.2 s per lane change
(the model's T_s of 0.2 s gives 40 samples over 8 s; 25 Hz data at its own rate 200)."""
SECONDS_PER_SAMPLE = 6e-4
"""Rough time one demonstration sample costs on one core [s] (the step inversion of
:func:`~drivestyle.envs.dynamics.recover_inputs` dominates), said with
:data:`WINDOW_SAMPLES_MAX`."""
FINE_DT_RATIO = 2.0
"""A T_s finer than the data's median time step by more than this factor is said in a note
(:func:`sampling_note`): most samples of a demonstration are then the splines', not the
data's."""


@dataclass(frozen=True)
class ExtractionConfig:
    """How lane changes become demonstrations (rules: :mod:`drivestyle.recorded.episodes`)."""

    dt: float = 0.2
    """T_s of the demonstrations [s]."""
    before_s: float = 4.0
    """Window before the crossing, as far as the track goes [s]."""
    after_s: float = 4.0
    """Window after the crossing, as far as the track goes [s]."""
    min_before_s: float = 3.0
    """Track the window must keep before the crossing [s]."""
    min_after_s: float = 2.0
    """Track the window must keep after the crossing [s]."""
    min_stay_s: float = 1.0
    """Time in the old lane before and in the new lane after a crossing [s] (shorter is a
    wobble on the line, not a lane change)."""
    min_lateral_move: float = 0.5
    """The least lateral move towards the new lane across the window, in lane widths (w,
    the mean width of the two lanes; :func:`lateral_move`): less is a drift along the line,
    kept unusable. 0 turns the rule off. Half a lane: a change from lane centre to lane
    centre moves about w, and a window cut short (3 s before, 2 s after) still holds most
    of it (the shipped samples' usable changes move 0.55–1.6 w; CATS's converter keeps
    changes that move 0.5 w over its window)."""
    max_gap_s: float = MAX_GAP_S
    """The longest time between two samples a window may hold [s]
    (:data:`~drivestyle.envs.units.MAX_GAP_S`): the window is cut at a longer gap of the
    lane changer's track, a crossing inside one is unusable, and so is an episode whose
    interacting vehicle has one in the window (the spline would invent its motion)."""
    observe_s: float = 2.0
    """The observed part: the window's first ``observe_s`` [s] (≤ ``min_before_s``), a whole
    number of ``dt`` (:func:`~drivestyle.envs.units.off_grid`)."""
    interaction_range_m: float = 100.0
    """Leaders and followers farther along x at the window's start do not interact [m]."""
    v_ref: float | None = None
    """The EV's desired speed when known (e.g. the speed limit) [m/s]; None: from the
    observed part (:func:`observed_scenario`)."""
    l_a: float | None = 15.0
    """The safety ellipse's semi-major axis [m]. The ellipse is the style model's constant,
    not a property of the data: every library is trained with the paper's 15 m (DESIGN §1),
    and scaling it with the observed speed moved a simulated SMPC(0.9) identified from its
    10 Hz CSV to 0.82 (15 m: 0.90). None: scaled with the observed speed level
    (:func:`observed_scenario`)."""

    def __post_init__(self) -> None:
        for name in (
            "dt",
            "before_s",
            "after_s",
            "min_before_s",
            "min_after_s",
            "min_stay_s",
            "observe_s",
            "interaction_range_m",
            "max_gap_s",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if self.min_before_s > self.before_s or self.min_after_s > self.after_s:
            raise ValueError(
                f"the window ({self.before_s:g} s before, {self.after_s:g} s after: before_s, "
                f"after_s, --before, --after) is shorter than its minimum "
                f"({self.min_before_s:g} s, {self.min_after_s:g} s: --min-before, --min-after)"
            )
        if self.observe_s > self.min_before_s:
            raise ValueError(
                f"observe_s (--observe) = {self.observe_s:g} s exceeds min_before_s "
                f"(--min-before) = {self.min_before_s:g} s: the observed part must end before "
                "the lane crossing"
            )
        # T_s against the windows: every episode needs an observed part of two samples or
        # more and three samples at least (what a Demonstration holds)
        if self.dt > self.observe_s:
            raise ValueError(
                f"dt (--dt) = {self.dt:g} s, T_s of the demonstrations, is longer than the "
                f"observed part observe_s (--observe) = {self.observe_s:g} s, which would hold "
                f"a single sample: T_s is a fraction of a second (the model's is 0.2 s)"
            )
        # the window's samples bounded before any is allocated (--dt 1e-9: 8e9 samples)
        most = (self.before_s + self.after_s) / self.dt
        if most > WINDOW_SAMPLES_MAX:
            each = SECONDS_PER_SAMPLE
            least = (self.before_s + self.after_s) / WINDOW_SAMPLES_MAX
            advice = (
                f"T_s is a fraction of a second (the model's is 0.2 s): give --dt {least:.2g} s "
                "or more"
                if least <= 0.2
                else "a lane change's window is a few seconds (a change takes 3–6 s)"
            )
            said = f"{most:,.0f}" if most < 1e6 else f"{most:.3g}"
            raise ValueError(
                f"dt (--dt) = {self.dt:g} s gives a window of {self.before_s + self.after_s:g} s "
                f"(--before {self.before_s:g} + --after {self.after_s:g}) {said} samples, more "
                f"than {WINDOW_SAMPLES_MAX:,} (≈ {each * 1e3:.2g} ms of work each: the bound "
                f"alone is ≈ {WINDOW_SAMPLES_MAX * each:.2g} s per lane change); {advice}"
            )
        # the observed part ends on a sample: never rounded silently (--observe 0.3 at
        # T_s 0.2 would observe 0.2 s), the rule every observed time of the project keeps
        miss = off_grid(self.observe_s, self.dt, "T_s = dt (--dt)")
        if miss:
            raise ValueError(f"observe_s (--observe) = {self.observe_s:g} s {miss}")
        shortest = self.min_before_s + self.min_after_s
        if 2 * self.dt > shortest:
            raise ValueError(
                f"dt (--dt) = {self.dt:g} s leaves the shortest window ({shortest:g} s: "
                f"--min-before {self.min_before_s:g} + --min-after {self.min_after_s:g}) fewer "
                "than 3 samples: T_s is a fraction of a second (the model's is 0.2 s)"
            )
        f = self.min_lateral_move
        if not (isinstance(f, (int, float)) and math.isfinite(f) and 0 <= f <= 1):
            raise ValueError(
                f"min_lateral_move must be a fraction of the lane width in [0, 1] (0: no "
                f"minimum), got {f!r}"
            )
        bound = ROAD_SPEED_MAX_MPS
        if self.v_ref is not None and not (math.isfinite(self.v_ref) and 0 < self.v_ref <= bound):
            raise ValueError(
                f"v_ref (--v-ref) must be in (0, {bound:g}] m/s ({bound:g} m/s = "
                f"{bound * 3.6:.0f} km/h, the fastest a road vehicle drives), got {self.v_ref!r}"
                + (": km/h given as m/s?" if self.v_ref > bound else "")
            )
        if self.l_a is not None and not (math.isfinite(self.l_a) and self.l_a > 0):
            raise ValueError(f"l_a must be a finite number > 0 [m], got {self.l_a!r}")


def check_sampling(recording: Recording, config: ExtractionConfig) -> None:
    """Refuse settings the recording's sampling cannot meet, before any work.

    Against the recording's median time step (over every track's steps): ``max_gap_s``
    must not be shorter (every step would be a gap, every episode unusable) and neither
    must ``min_stay_s`` (the lanes held around a crossing would hold no sample, so the rule
    would hold for any wobble on a line).

    Args:
        recording: the tracks (any reader).
        config: the extraction's numbers.

    Raises:
        ValueError: one line naming the setting (and its option), its value and the step.
    """
    steps = [np.diff(tr.t) for road in recording.carriageways for tr in road.tracks]
    if not steps:
        return
    step = float(np.median(np.concatenate(steps)))
    where = f"{recording.source}: the data's median time step is {step:.3g} s"
    if config.max_gap_s < step:
        raise ValueError(
            f"{where}, longer than max_gap_s (--max-gap) = {config.max_gap_s:g} s: every step "
            "would be a gap; give --max-gap at least the time step"
        )
    if config.min_stay_s < step:
        raise ValueError(
            f"{where}, longer than min_stay_s (--min-stay) = {config.min_stay_s:g} s: no "
            "sample would show the lanes held around a crossing; give --min-stay at least the "
            "time step"
        )


def sampling_note(recording: Recording, config: ExtractionConfig) -> str | None:
    """A note when T_s is much finer than the recording's own sampling, or None.

    Legal (cubic splines pass through the samples), but surprising: with ``dt`` more than
    :data:`FINE_DT_RATIO` times finer than the data's median time step, most of a
    demonstration's samples, and the inputs recovered between them, are the splines'.

    Args:
        recording: the tracks (any reader).
        config: the extraction's numbers.

    Returns:
        ``note: …`` naming ``--dt``, the step and the share of interpolated samples.
    """
    steps = [np.diff(tr.t) for road in recording.carriageways for tr in road.tracks]
    if not steps:
        return None
    step = float(np.median(np.concatenate(steps)))
    ratio = step / config.dt
    if ratio <= FINE_DT_RATIO:
        return None
    return (
        f"note: {recording.source}: dt (--dt) = {config.dt:g} s is {ratio:.3g}× finer than the "
        f"data's median time step {step:.3g} s: {1 - 1 / ratio:.0%} of a demonstration's "
        "samples lie between recorded ones (the splines', not the data's; so are the inputs "
        "recovered there); the demonstrations are written as asked"
    )
