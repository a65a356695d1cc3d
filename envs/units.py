"""Physical bounds of road vehicles, and the unit slips a value beyond them reveals.

A recorded value no road vehicle can show is most often a value in another unit: positions
in feet, speeds in km/h, times in milliseconds, headings in degrees. The bounds here are
the one statement of what a road vehicle can do; the readers' checks
(:mod:`drivestyle.recorded.track_checks`), the plausibility of a demonstration
(:mod:`drivestyle.envs.demonstration`) and the scenario's speed bound
(:class:`~drivestyle.envs.scenario.ScenarioConfig`) use them, and the hints name the
conversion that would make the value a road vehicle's. :func:`off_grid` is the one rule
for a time that must be a whole number of time steps (an observed time, ``--observe``).
"""

from __future__ import annotations

import math

__all__ = [
    "FOOT",
    "KMH",
    "MAX_GAP_S",
    "MPH",
    "ROAD_SPEED_MAX_MPS",
    "SAMPLE_PERIOD_MAX_S",
    "degrees_hint",
    "off_grid",
    "speed_unit_hint",
    "time_unit_hint",
]

ROAD_SPEED_MAX_MPS = 70.0
"""The fastest a road vehicle drives [m/s] (252 km/h): the model's speed bound v_max and
the limit every recorded speed is checked against. Production cars are limited to
250 km/h and the recorded samples drive below 22 m/s; 120 m/s (432 km/h) is km/h read as
m/s or positions in feet, never a car."""

SAMPLE_PERIOD_MAX_S = 1.0
"""The longest median time step between a track's samples [s]: a lane change takes
3–6 s, so a track sampled less often than once a second cannot show one (the recorded
samples are 2–10 Hz); a step of 100 is a time in milliseconds."""

MAX_GAP_S = 1.0
"""The longest time between two of a track's samples that the extraction bridges with a
spline [s]: over a longer gap the spline invents the motion (a whole lane change fits in
4 s). Every recorded sample (2–10 Hz) has none longer than 0.5 s. An episode's window is
cut at a longer gap, and a crossing inside one is unusable (``ExtractionConfig.max_gap_s``,
``--max-gap``)."""

FOOT = 0.3048
"""Metres per foot."""
KMH = 1 / 3.6
"""Metres per second per km/h."""
MPH = 0.44704
"""Metres per second per mile per hour."""

_SPEED_SLIPS = {
    "speeds": (("km/h given as m/s", KMH), ("mph", MPH), ("ft/s", FOOT)),
    "positions": (("positions in feet", FOOT), ("positions computed from a speed in km/h", KMH)),
}
"""The usual unit slips of a speed column and of positions, most likely first."""


def _speed(value: float) -> str:
    return f"{value:.3g} m/s"


def speed_unit_hint(speed: float, of: str) -> str:
    """The unit slips that would make a speed beyond :data:`ROAD_SPEED_MAX_MPS` a car's.

    Args:
        speed: the speed as read, above the bound [m/s as read].
        of: ``"speeds"`` (a speed column) or ``"positions"`` (a speed the positions imply).

    Returns:
        E.g. ``"km/h given as m/s (÷ 3.6: 33.3 m/s)? mph (× 0.447: 53.6 m/s)?"``; the slips
        that bring the speed within the bound, or a request to check the units.
    """
    said = []
    for slip, factor in _SPEED_SLIPS[of]:
        converted = speed * factor
        if 0 < converted <= ROAD_SPEED_MAX_MPS:
            op = f"÷ {1 / factor:g}" if factor == KMH else f"× {factor:g}"
            said.append(f"{slip} ({op}: {_speed(converted)})?")
    if not said:
        unit = "m and s" if of == "positions" else "m/s"
        return f"check the units (SI: {unit})"
    return " or ".join(said)


def time_unit_hint(step: float) -> str:
    """The unit slip that makes a median time step too long for a recording of vehicles.

    Args:
        step: the median time step as read [s as read].

    Returns:
        E.g. ``"times in milliseconds? divide by 1000 (a step of 0.1 s, 10 Hz)"``, where
        the conversion gives a recorder's rate (1–200 Hz); else what a step must be.
    """
    for unit, factor in (("milliseconds", 1e3), ("microseconds", 1e6), ("nanoseconds", 1e9)):
        if 1 / 200 <= step / factor <= SAMPLE_PERIOD_MAX_S:
            return (
                f"times in {unit}? divide by {factor:g} (a step of {step / factor:.3g} s, "
                f"{factor / step:.3g} Hz)"
            )
    return f"a track needs a sample at least every {SAMPLE_PERIOD_MAX_S:g} s (times in seconds)"


def degrees_hint(value: float) -> str:
    """A heading read as radians that is likely in degrees, said with its conversion.

    Args:
        value: the heading as read [rad as read].

    Returns:
        E.g. ``"degrees? (3.2° = 0.0559 rad; × π/180)"``.
    """
    return f"degrees? ({value:.3g}° = {math.radians(value):.3g} rad; × π/180)"


def off_grid(duration: float, dt: float, step: str = "T_s") -> str | None:
    """Why a time is not a whole number of time steps, said with the nearest that are.

    The one rule of every time that must fall on a sampling grid (an observed time of
    predict-trajectory, evaluate-prediction, evaluate-out-of-class and extract-episodes'
    ``--observe``): never rounded silently.

    Args:
        duration: the time [s].
        dt: the step [s] (a difference of sample times may be 0.20000000000000018: said
            rounded).
        step: what the step is called in the message (``"T_s"``, ``"dt (--dt)"``).

    Returns:
        None on the grid (within 1e-6 of a step), else e.g. ``"is not a whole number of
        T_s = 0.2 s; use 0.2 or 0.4 s"`` (the whole numbers of steps around it, at least
        one step).
    """
    k = duration / dt
    if abs(k - round(k)) <= 1e-6:
        return None
    near = sorted({max(math.floor(k), 1) * dt, math.ceil(k) * dt})
    return (
        f"is not a whole number of {step} = {dt:.6g} s; use "
        f"{' or '.join(f'{n:.6g}' for n in near)} s"
    )
