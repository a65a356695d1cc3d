"""The AV-against-humans study's report: ``av_vs_human.md`` (and its amortized section)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drivestyle.common.io import fmt
from drivestyle.irl.amortized.identify import SAMPLES
from drivestyle.studies.av_vs_human.amortized import AGAINST, ALL_VEHICLES, AMORTIZED
from drivestyle.studies.av_vs_human.study import GROUPS, QUANTITIES

if TYPE_CHECKING:
    from drivestyle.studies.av_vs_human.amortized import AmortizedComparison
    from drivestyle.studies.av_vs_human.study import AVHumanComparison

__all__ = ["amortized_markdown", "av_human_markdown"]


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


def _meaning(quantity: str) -> str:
    if quantity.startswith(AMORTIZED):
        return f"amortized posterior mean of {quantity.removeprefix(AMORTIZED)}"
    return QUANTITIES[quantity]


def amortized_markdown(amortized: AmortizedComparison) -> str:
    """The report's section on the amortized posterior (appended to ``av_vs_human.md``)."""

    def cell(value: float | None, lo: float | None, hi: float | None) -> str:
        return "—" if value is None else f"{fmt(value, 3)} [{fmt(lo, 3)}, {fmt(hi, 3)}]"

    lines = [
        "",
        "## The amortized posterior",
        "",
        f"Every lane change identified by the amortized posterior `{amortized.estimator}` "
        f"(weights SHA-256 {amortized.estimator_sha256[:12]}…, {SAMPLES} draws; DESIGN §22).",
        "",
        "AUROC of the AV against each group: P(AV > other) + ½ P(tie), 0.5 = no separation; "
        f"percentile-bootstrap 95 % intervals ({amortized.samples} replicates of the lane "
        "changes within each group).",
        "",
        "| quantity | " + " | ".join(f"AV vs {a}" for a in AGAINST) + " |",
        "|---|" + "---|" * len(AGAINST),
    ]
    quantities = list(dict.fromkeys(s.quantity for s in amortized.separations))
    for q in quantities:
        row = {s.against: s for s in amortized.separations if s.quantity == q}
        cells = [cell(row[a].auroc, row[a].lo, row[a].hi) for a in AGAINST]
        lines.append(f"| {_meaning(q)} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Consistency across runs: the intra-class correlation ICC(1) of each posterior mean "
        "over one vehicle's lane changes grouped by run (near 0: the runs agree; near 1: each "
        f"run its own), and over the vehicles ({ALL_VEHICLES}: the share that is the "
        "vehicle's); 95 % intervals from the F distribution.",
        "",
        "| parameter | " + " | ".join(dict.fromkeys(c.group for c in amortized.consistency)) + " |",
        "|---|" + "---|" * len({c.group for c in amortized.consistency}),
    ]
    groups = list(dict.fromkeys(c.group for c in amortized.consistency))
    for name in dict.fromkeys(c.parameter for c in amortized.consistency):
        row_c = {c.group: c for c in amortized.consistency if c.parameter == name}
        cells = [f"{cell(row_c[g].icc, row_c[g].lo, row_c[g].hi)} (k {row_c[g].classes}, "
                 f"n {row_c[g].lane_changes})" for g in groups]  # fmt: skip
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
