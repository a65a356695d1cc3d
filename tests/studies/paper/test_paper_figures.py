"""The paper study's figures say what they show: explained spikes; they are written."""

from dataclasses import replace

from drivestyle.irl.paper.features import FeatureConfig
from drivestyle.irl.paper.learner import IRLConfig, MaxEntIRL
from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.studies.paper import figures


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


def test_the_risk_sweep_writes_a_png(paper_demo, tmp_path):
    path = figures.plot_risk_sweep({0.7: paper_demo}, tmp_path / "r.png")
    assert path.stat().st_size > 5_000
