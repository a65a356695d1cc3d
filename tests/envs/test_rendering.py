"""The highway-env renderer: several live envs, pygame's global state, bad inputs.

Headless throughout: tests/conftest.py sets ``SDL_VIDEODRIVER=dummy``.
"""

import gymnasium as gym
import numpy as np
import pygame
import pytest

import drivestyle.envs  # noqa: F401  (registers the ids)
from drivestyle.envs import PAPER
from drivestyle.envs.rendering import HighwayRenderer

ID = "drivestyle/LaneChange-v0"


def _assert_drawn(frame):
    """A real frame: not a uniform fill, with the EV's red and the TV's blue."""
    assert frame is not None and frame.ndim == 3 and frame.dtype == np.uint8
    assert frame.std() > 0
    colours = frame.reshape(-1, 3).astype(int)
    red = (colours[:, 0] > 180) & (colours[:, 1] < 90) & (colours[:, 2] < 90)
    blue = (colours[:, 2] > 180) & (colours[:, 0] < 90)
    assert red.sum() > 50 and blue.sum() > 50


def _env(render_mode="rgb_array"):
    env = gym.make(ID, render_mode=render_mode)
    env.reset(seed=0)
    return env


def test_closing_one_env_keeps_the_others_rendering():
    a, b = _env(), _env()
    _assert_drawn(a.render())
    _assert_drawn(b.render())  # both have drawn their caption: a font is cached
    a.close()
    _assert_drawn(b.render())  # was: pygame.error "Invalid font (font module quit ...)"
    b.step(np.array([1.0, 0.02]))
    _assert_drawn(b.render())
    b.close()
    c = _env()  # after the last renderer has closed, pygame comes back for a new one
    _assert_drawn(c.render())
    c.close()


def test_closing_a_human_env_keeps_offscreen_envs_rendering():
    human, offscreen = _env("human"), _env()
    _assert_drawn(offscreen.render())
    assert human.render() is None
    human.close()
    _assert_drawn(offscreen.render())
    offscreen.close()


def test_renderer_survives_pygame_quit_by_someone_else():
    # e.g. a highway-env env closed in the same process: EnvViewer.close() = pygame.quit()
    env = _env()
    _assert_drawn(env.render())
    pygame.quit()
    _assert_drawn(env.render())
    pygame.font.quit()
    pygame.font.init()  # re-initialised, but the cached font belongs to the old session
    _assert_drawn(env.render())
    env.close()


def test_check_env_closing_its_copies_keeps_a_live_env_rendering():
    # gymnasium's checker makes and closes an env per render mode
    from gymnasium.utils.env_checker import check_env

    live = _env()
    _assert_drawn(live.render())
    with pytest.warns(UserWarning):
        check_env(gym.make(ID))
    _assert_drawn(live.render())
    live.close()


def test_renderer_close_is_idempotent_and_draw_reopens():
    r = HighwayRenderer()
    args = (PAPER, PAPER.ev_initial_state, PAPER.tv_initial_state, "caption")
    _assert_drawn(r.draw(*args))
    r.close()
    r.close()
    _assert_drawn(r.draw(*args))  # was: AttributeError on a None viewer
    r.close()


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"render_mode": "video"}, ValueError, "render_mode"),
        ({"width": 0}, ValueError, "width"),
        ({"height": -5}, ValueError, "height"),
        ({"width": "900"}, TypeError, "width"),
        ({"height": 180.5}, TypeError, "height"),
        ({"scaling": float("nan")}, ValueError, "scaling"),
        ({"scaling": 0.0}, ValueError, "scaling"),
    ],
)
def test_renderer_bad_construction_is_a_clear_error(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        HighwayRenderer(**kwargs)


@pytest.mark.parametrize(
    ("change", "exc", "match"),
    [
        ({"sc": "paper"}, TypeError, "ScenarioConfig"),
        ({"ev": np.full(4, np.nan)}, ValueError, "ev .*finite"),
        ({"tv": np.array([0.0, 1.0, np.inf, 20.0])}, ValueError, "tv .*finite"),
        ({"ev": np.zeros(3)}, ValueError, r"ev .*shape \(4,\)"),
        ({"tv": "state"}, ValueError, "tv"),
        ({"caption": 5}, TypeError, "caption"),
    ],
)
def test_draw_bad_input_is_a_clear_error(change, exc, match):
    args = {
        "sc": PAPER,
        "ev": PAPER.ev_initial_state,
        "tv": PAPER.tv_initial_state,
        "caption": "ok",
    }
    args.update(change)
    r = HighwayRenderer()
    try:
        with pytest.raises(exc, match=match):
            r.draw(**args)
    finally:
        r.close()


def test_gymnasium_record_video_records_an_episode(tmp_path):
    # the `video` extra brings moviepy, which gymnasium's RecordVideo writes with
    pytest.importorskip("moviepy")
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(
        gym.make(ID, render_mode="rgb_array"),
        str(tmp_path),
        episode_trigger=lambda episode: True,
        disable_logger=True,
    )
    env.reset(seed=0)
    done, steps = False, 0
    while not done:
        _, _, terminated, truncated, _ = env.step(np.zeros(2))
        done, steps = terminated or truncated, steps + 1
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1_000
    import imageio.v3 as iio

    assert iio.imread(videos[0]).shape[0] == steps + 1  # the reset frame and one per step


def test_the_video_extra_brings_what_record_video_needs():
    from pathlib import Path

    import tomllib

    pyproject = Path(__file__).resolve().parents[2] / "pyproject.toml"
    video = tomllib.loads(pyproject.read_text())["project"]["optional-dependencies"]["video"]
    assert any(req.startswith("moviepy") for req in video), video
