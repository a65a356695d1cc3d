"""The recorded-traffic study's figures keep every reproduction visible."""

from drivestyle.studies.real_traffic import figures


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
