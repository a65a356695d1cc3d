"""The prediction study's figures (studies/prediction/figures.py)."""


def test_every_prediction_method_has_a_line_style():
    from drivestyle.prediction.methods import METHODS
    from drivestyle.studies.prediction.figures import METHOD_STYLES

    assert set(METHOD_STYLES) == set(METHODS)


def test_a_joint_scene_is_drawn_with_every_vehicle_and_its_region(tmp_path, paper_demo):
    import numpy as np
    from matplotlib.image import imread

    from drivestyle.prediction.joint import JointPrediction
    from drivestyle.studies.prediction.figures import plot_joint_scene

    k, n = 10, paper_demo.n
    truth = np.concatenate([paper_demo.ev[:, None], paper_demo.vehicles], axis=1)[k:, :, :2]
    rng = np.random.default_rng(0)
    paths = (
        truth[None] + rng.normal(0, 0.3, (5, *truth.shape)) * np.arange(n - k)[None, :, None, None]
    )
    paths[:, 0] = truth[0]
    scene = JointPrediction(paths, (True,) + (False,) * (truth.shape[1] - 1))
    out = plot_joint_scene(scene, paper_demo, k, tmp_path / "scene.png", "a scene", truth[-1, 0])
    image = imread(out)
    assert image.shape[0] > 100 and image[..., :3].std() > 0.05  # drawn, not blank
    assert scene.region_radius().shape == (truth.shape[1],)
