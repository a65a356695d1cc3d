"""The comparison study's figure is written (studies/compare/figures.py)."""

import numpy as np

from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.studies.compare import figures


def test_the_comparison_writes_a_png(paper_demo, tmp_path):
    C = demo_control_points(paper_demo)
    path = figures.plot_comparison(paper_demo, {"smpc": C}, tmp_path / "c.png", "t")
    assert path.stat().st_size > 5_000
    assert np.isfinite(C).all()
