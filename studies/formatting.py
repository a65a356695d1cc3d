"""How the studies' reports and figures print numbers: times, percentages, intervals.

Numbers are rounded here once, so a time reads ``2.4 s`` and never
``2.4000000000000004 s``; every study's ``report.py`` and ``figures.py`` (and the commands
that print a time) use these, beside :func:`drivestyle.common.io.fmt` for plain numbers.
"""

from __future__ import annotations

from typing import Any

__all__ = ["percent", "seconds", "value_interval"]


def seconds(t: float | None, digits: int = 1) -> str:
    """A time for people to read: ``2.4 s`` (rounded to ``digits`` decimals), ``never`` for None.

    Sample times are multiples of the step (k·0.2 s) and carry floating-point residue;
    every print, caption and report shows them through this function.
    """
    return "never" if t is None else f"{t:.{digits}f} s"


def percent(value: float | None) -> str:
    """A share for people to read: ``0.314`` → ``31 %``; ``—`` for None."""
    return "—" if value is None else f"{100 * value:.0f} %"


def value_interval(stat: Any, kind: str) -> str:
    """``value [lo, hi]`` of a bootstrap statistic's mean or median [m], two decimals.

    Args:
        stat: an object with ``<kind>``, ``<kind>_lo`` and ``<kind>_hi`` (the prediction
            study's ``ErrorStat``).
        kind: ``mean`` or ``median``.
    """
    v, lo, hi = (getattr(stat, f"{kind}{s}") for s in ("", "_lo", "_hi"))
    return f"{v:.2f} [{lo:.2f}, {hi:.2f}]"
