"""The figures say what they show: true shapes, explained spikes, visible curves, whole counts."""

from dataclasses import replace

import numpy as np
import pytest

from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL
from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.studies import figures


@pytest.fixture
def drawn(monkeypatch):
    """The figures drawn, kept open instead of saved."""
    kept = []

    def keep(fig, path, title=None, dpi=130):
        kept.append(fig)
        return path

    monkeypatch.setattr(figures, "save_figure", keep)
    yield kept
    for fig in kept:
        figures.plt.close(fig)


def test_demonstration_road_is_drawn_to_scale(paper_demo, drawn, tmp_path):
    figures.plot_demonstration(paper_demo, tmp_path / "demo.png")
    road = drawn[0].axes[1]
    # equal axes: 5 m × 2 m cars and the 15 m × 3 m ellipse keep their shape (was 'auto')
    assert road.get_aspect() == 1.0
    drawn[0].canvas.draw()  # the aspect is applied when drawn
    (x0, y0), (x1, y1) = road.transData.transform([(0.0, 0.0), (10.0, 10.0)])
    assert abs(x1 - x0) == pytest.approx(abs(y1 - y0), rel=1e-6)


def test_lateral_figure_explains_the_first_segment_spike(paper_demo, drawn, tmp_path):
    result = MaxEntIRL(paper_demo, FeatureConfig(), IRLConfig(max_iter=2)).learn()
    C = demo_control_points(paper_demo)
    figures.plot_lateral(paper_demo, result, C, tmp_path / "fig4.png")
    texts = [t.get_text() for t in drawn[0].axes[1].texts]
    assert len(texts) == 1 and "heading bound" in texts[0] and "segment 0" in texts[0]
    assert texts[0].startswith("10.6 m/s² at t = 0.04 s")
    # the note names the cause only when the peak lies in segment 0
    calm, u = paper_demo.ev.copy(), paper_demo.u.copy()
    calm[:, 1], calm[:, 2], u[:, 1] = calm[0, 1], 0.0, 0.0
    straight = replace(paper_demo, ev=calm, u=u)
    assert figures.first_segment_note(straight, demo_control_points(straight)) is None


def test_episode_reproductions_stay_visible_when_they_coincide(paper_demo, drawn, tmp_path):
    xy = paper_demo.ev[:, :2]
    names = ("personal reactive", "personal base", "general (leave-one-out)", "constant velocity")
    paths = {name: xy for name in names}  # all four on the same path
    figures.plot_episode(paper_demo, paths, tmp_path / "episode.png")
    lines = {ln.get_label(): ln for ln in drawn[0].axes[0].get_lines()}
    drawn_styles = [(lines[n].get_linestyle(), lines[n].get_linewidth()) for n in paths]
    assert len(set(drawn_styles)) == len(paths)  # was: four identical solid lines
    base, reactive = lines["personal base"], lines["personal reactive"]
    # the base line is drawn over the reactive one, dashed and thinner: both show
    assert base.get_zorder() > reactive.get_zorder()
    assert base.get_linestyle() != "-" and base.get_linewidth() < reactive.get_linewidth()


def test_population_histogram_counts_whole_vehicles(drawn, tmp_path):
    rows = [
        {"status": "ok", "risk_mean": m, "true_risk": "", "risk_lo": m, "risk_hi": m}
        for m in (0.6, 0.7, 0.8)
    ]
    figures.plot_population(rows, tmp_path / "population.png")
    hist = drawn[0].axes[1]
    ticks = [t for t in hist.get_yticks() if hist.get_ylim()[0] <= t <= hist.get_ylim()[1]]
    assert ticks and all(float(t).is_integer() for t in ticks), ticks  # was 0.2, 0.4, …


def test_every_plot_writes_a_png(paper_demo, tmp_path):
    C = demo_control_points(paper_demo)
    path = figures.plot_comparison(paper_demo, {"smpc": C}, tmp_path / "c.png", "t")
    assert path.stat().st_size > 5_000
    path = figures.plot_risk_sweep({0.7: paper_demo}, tmp_path / "r.png")
    assert path.stat().st_size > 5_000
    assert np.isfinite(C).all()


def test_only_the_figures_modules_import_matplotlib():
    # studies/figures.py (shared) and a study's own figures.py (studies/<study>/figures.py)
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    importers = []
    for folder in (
        "drivestyle", "envs", "recorded", "planning", "irl", "prediction", "agents", "studies",
        "scripts",
    ):  # fmt: skip
        for path in (root / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                names = (
                    [a.name for a in node.names]
                    if isinstance(node, ast.Import)
                    else [node.module or ""]
                    if isinstance(node, ast.ImportFrom)
                    else []
                )
                if any(n.split(".")[0] == "matplotlib" for n in names):
                    importers.append(str(path.relative_to(root)))
                    break
    assert "studies/figures.py" in importers, importers
    assert all(
        p == "studies/figures.py" or (p.startswith("studies/") and p.endswith("/figures.py"))
        for p in importers
    ), importers
