"""The prediction study's figures (studies/figures.py): a line style for every method."""


def test_every_prediction_method_has_a_line_style():
    from drivestyle.irl.forecast import METHODS
    from drivestyle.studies.figures import METHOD_STYLES

    assert set(METHOD_STYLES) == set(METHODS)
