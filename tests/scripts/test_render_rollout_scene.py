"""``render-rollout --episode``: a recorded scene rendered to a video."""

import json

import pytest

from drivestyle.envs import save_demonstration
from drivestyle.scripts.render_rollout import main


def test_a_recorded_scene_is_rendered_with_its_summary(recorded_scene, tmp_path):
    episode = save_demonstration(recorded_scene, tmp_path / "scene.npz")
    video = tmp_path / "scene.gif"
    summary = main(["--episode", str(episode), "--policy", "replay", "--agent", "1",
                    "--others", "idm", "--video", str(video)])  # fmt: skip
    assert summary["frames"] == recorded_scene.n - 5 and video.stat().st_size > 1000
    written = json.loads(video.with_suffix(".json").read_text())
    assert (written["episode"], written["agent"], written["others"]) == (str(episode), 1, "idm")


def test_a_scene_of_identified_styles_is_rendered(recorded_scene, tiny_posterior, tmp_path):
    _, posterior = tiny_posterior
    episode = save_demonstration(recorded_scene, tmp_path / "scene.npz")
    video = tmp_path / "styles.gif"
    summary = main(["--episode", str(episode), "--policy", "style", "--others", "style",
                    "--posterior", str(posterior), "--video", str(video)])  # fmt: skip
    assert summary["frames"] == recorded_scene.n - 5 and video.stat().st_size > 1000
    written = json.loads(video.with_suffix(".json").read_text())
    assert (written["others"], written["posterior"]) == ("style", str(posterior))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--policy", "style", "--episode", "e.npz"], "--policy style drives the agent by its"),
        (
            ["--policy", "idm", "--episode", "e.npz", "--others", "style"],
            "--others style and --posterior go together",
        ),
        (["--policy", "expert", "--posterior", "p.npz"], "--posterior identifies the styles"),
        (["--policy", "idm"], "--policy idm drives a recorded scene: give --episode"),
        (["--policy", "expert", "--episode", "e.npz"], "--policy must be one of"),
        (["--policy", "expert", "--others", "idm"], "--agent and --others choose the vehicles"),
    ],
)
def test_scene_options_out_of_place_are_refused(tmp_path, args, message):
    with pytest.raises(ValueError, match=message):
        main([*args, "--video", str(tmp_path / "v.gif")])
