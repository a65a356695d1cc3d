"""The prediction study's report and figure by kind of episode (studies/prediction/report.py,
figures.py)."""

from drivestyle.prediction.regions import kind_region_coverage, kind_region_rates
from drivestyle.studies.formatting import value_interval
from drivestyle.studies.prediction import (
    VALIDATION_SEED,
    PredictionStudy,
    summarise_records,
    summarise_tracking,
)
from drivestyle.studies.prediction.figures import plot_fde_by_kind
from drivestyle.studies.prediction.report import prediction_markdown
from drivestyle.studies.prediction.summaries import ratio_stats, summarise_by_kind


def _study(records, calibration=()):
    """The study :func:`evaluate_prediction` would return on these recorded records."""
    rows = [r.to_json() for r in calibration]
    return PredictionStudy(
        seed=VALIDATION_SEED, t_obs=tuple(sorted({r.t_obs for r in records})), vehicles=(),
        records=tuple(records), skipped=(), summaries=tuple(summarise_records(records, 200)),
        goals=(), tracks=(), tracking=summarise_tracking([]),
        recorded_sets=tuple(dict.fromkeys(r.set for r in records)), n_geometries={}, seconds={},
        kind_summaries=tuple(summarise_by_kind(records, 200)),
        ratios=tuple(ratio_stats(records, 200)),
        kind_regions=tuple(kind_region_coverage(records, kind_region_rates(rows))) if rows else (),
    )  # fmt: skip


def _table(md, title):
    """The rows of the first markdown table under ``title``."""
    blocks = [b.strip() for b in md.split(title + "\n", 1)[1].split("\n\n")]
    table = next(b for b in blocks if b.startswith("|"))
    return table.splitlines()


def test_the_report_has_a_table_per_kind_one_of_ratios_and_the_regions_by_kind(mixed_kinds):
    study = _study(mixed_kinds, calibration=mixed_kinds)
    md = prediction_markdown(study, "drivestyle evaluate-prediction …")
    assert "## By kind of episode: recorded" in md
    assert "lane change 7 episodes of 7 vehicles; car following 5 episodes of 5 vehicles; " in md
    assert "; 2 of the episodes in stop-and-go windows." in md
    for title in ("every kind", "lane change", "car following", "stop-and-go windows (any kind)"):
        rows = _table(md, f"### {title}")
        assert rows[0] == "| method | 1.0 s | 2.0 s |", title
        assert [r.split(" | ")[0] for r in rows[2:]] == ["| n (vehicles)", "| cv", "| mode"]
    cells = [value_interval(study.summary("recorded", t, "mode", "lane_change").stats["fde"],
                            "median") for t in (1.0, 2.0)]  # fmt: skip
    assert f"| mode | {cells[0]} | {cells[1]} |" in _table(md, "### lane change")
    ratios = _table(md, "### FDE relative to CV")
    assert ratios[0] == "| kind | method | FDE 1.0 s | FDE 2.0 s | lateral 1.0 s | lateral 2.0 s |"
    kinds = ["every kind", "lane change", "car following", "stop-and-go windows (any kind)"]
    assert [r.split(" | ")[0] for r in ratios[2:]] == [f"| {k}" for k in kinds]
    assert ratios[3].endswith("✓ |")  # the lateral FDE: half of CV's, well below 0.60
    assert ratios[4].split(" | ")[-1] == "— |"  # no lateral ratio for car following
    regions = _table(md, "### 90 % prediction regions calibrated per kind")
    assert len(regions) == 2 + 4 * 2 and "† (7 cal.)" in regions[4]  # 7 < 20: the pooled rate


def test_with_one_kind_the_report_says_the_pooled_numbers_are_its(mixed_kinds):
    md = prediction_markdown(_study([r for r in mixed_kinds if r.kind == "lane_change"]), "c")
    assert "Every episode is of one kind: its numbers are the pooled ones." in md
    assert "### every kind" not in md and "### lane change" in md
    assert "calibrated per kind" not in md  # no calibration run given


def test_the_figure_shows_each_kinds_median_with_its_interval(mixed_kinds, drawn, tmp_path):
    study = _study(mixed_kinds)
    assert plot_fde_by_kind(study, tmp_path / "k.png") == tmp_path / "k.png"
    (fig,) = drawn
    assert len(fig.axes) == 2  # one panel per t_obs
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == ["all kinds\n12 (8)", "lane change\n7 (7)", "car following\n5 (5)",
                      "stop-and-go\n2 (2)"]  # fmt: skip
    heights = sorted(round(p.get_height(), 9) for p in ax.patches)
    kinds = ("all", "lane_change", "car_following", "stop_and_go")
    medians = [study.summary("recorded", 1.0, m, k).stats["fde"].median
               for m in ("cv", "mode") for k in kinds]  # fmt: skip
    assert heights == sorted(round(m, 9) for m in medians)
    assert plot_fde_by_kind(_study([]), tmp_path / "none.png") is None  # no recorded episode
