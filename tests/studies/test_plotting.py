"""The shared figures say what they show: true shapes, whole counts (studies/plotting.py)."""

import pytest

from drivestyle.studies import plotting


def test_demonstration_road_is_drawn_to_scale(paper_demo, drawn, tmp_path):
    plotting.plot_demonstration(paper_demo, tmp_path / "demo.png")
    road = drawn[0].axes[1]
    # equal axes: 5 m × 2 m cars and the 15 m × 3 m ellipse keep their shape (was 'auto')
    assert road.get_aspect() == 1.0
    drawn[0].canvas.draw()  # the aspect is applied when drawn
    (x0, y0), (x1, y1) = road.transData.transform([(0.0, 0.0), (10.0, 10.0)])
    assert abs(x1 - x0) == pytest.approx(abs(y1 - y0), rel=1e-6)


def test_population_histogram_counts_whole_vehicles(drawn, tmp_path):
    rows = [
        {"status": "ok", "risk_mean": m, "true_risk": "", "risk_lo": m, "risk_hi": m}
        for m in (0.6, 0.7, 0.8)
    ]
    plotting.plot_population(rows, tmp_path / "population.png")
    hist = drawn[0].axes[1]
    ticks = [t for t in hist.get_yticks() if hist.get_ylim()[0] <= t <= hist.get_ylim()[1]]
    assert ticks and all(float(t).is_integer() for t in ticks), ticks  # was 0.2, 0.4, …
