"""The AV-against-humans study's report: ``av_vs_human.md``."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.studies.av_vs_human.study import GROUPS, QUANTITIES

if TYPE_CHECKING:
    from drivestyle.studies.av_vs_human.study import AVHumanComparison

__all__ = ["av_human_markdown"]


def av_human_markdown(comparison: AVHumanComparison, command: str) -> str:
    """``av_vs_human.md``: per quantity the groups' medians and the AV's differences."""

    def cell(median: float | None, lo: float | None, hi: float | None, n: int | None = None):
        if median is None:
            return "—"
        text = f"{fmt(median, 3)} [{fmt(lo, 3)}, {fmt(hi, 3)}]"
        return text if n is None else f"{text} (n {n})"

    lines = [
        "# The automated car against human drivers (CATS)",
        "",
        f"`{command}`",
        "",
        "Medians with percentile-bootstrap 95 % intervals over each group's lane changes; "
        "a difference is the AV's median minus the group's (its interval excludes 0: "
        "**bold**).",
        "",
        "| quantity | " + " | ".join(GROUPS) + " | AV − same car, human | AV − other humans |",
        "|---|" + "---|" * (len(GROUPS) + 2),
    ]
    for q, meaning in QUANTITIES.items():
        stats = {s.group: s for s in comparison.stats if s.quantity == q}
        row = [cell(stats[g].median, stats[g].lo, stats[g].hi, stats[g].n) for g in GROUPS]
        for d in (d for d in comparison.differences if d.quantity == q):
            text = cell(d.median, d.lo, d.hi)
            row.append(f"**{text}**" if d.excludes_zero else text)
        lines.append(f"| {meaning} | " + " | ".join(row) + " |")
    lines += ["", "Identification verdicts (lane changes):", ""]
    for g in GROUPS:
        counts = comparison.verdicts.get(g, {})
        lines.append(f"- {g}: " + ", ".join(f"{v} {n}" for v, n in sorted(counts.items())))
    return "\n".join(lines) + "\n"
