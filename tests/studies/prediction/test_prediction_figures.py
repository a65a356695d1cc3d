"""The prediction study's figures (studies/prediction/figures.py)."""


def test_every_prediction_method_has_a_line_style():
    from drivestyle.prediction.methods import METHODS
    from drivestyle.studies.prediction.figures import METHOD_STYLES

    assert set(METHOD_STYLES) == set(METHODS)
