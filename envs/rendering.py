"""Drawing the lane change with highway-env's viewer (pygame).

highway-env draws roads and vehicles of its own ``Road``/``Vehicle`` objects through
``EnvViewer``; this module mirrors the env's state into those objects each frame (EV red,
TV blue), lets the viewer draw them, and adds the safety ellipses and a caption. The
scene is flipped vertically so that lane 0 (the EV's start) is at the bottom, as in the
paper's figures.

Headless use: ``rgb_array`` draws on an off-screen surface. highway-env disables its
viewer when ``SDL_VIDEODRIVER=dummy`` (frames come out blank); off-screen drawing does not
need a display, so the renderer re-enables it.

Several renderers per process: highway-env's ``EnvViewer.close()`` calls ``pygame.quit()``,
which would invalidate every other live renderer's font (and window). A renderer therefore
only quits pygame when it is the last live one; closing the last human-mode renderer while
off-screen ones live only shuts the window (``pygame.display.quit()``). If pygame is quit
from elsewhere (e.g. a highway-env env closed in the same process), the next ``draw``
re-creates what it needs (font, window).
"""

from __future__ import annotations

import math
import os
import weakref
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from drivestyle.envs.scenario import ScenarioConfig

if TYPE_CHECKING:  # imported lazily at run time (pygame starts up on import)
    from highway_env.envs.common.graphics import EnvViewer
    from highway_env.vehicle.kinematics import Vehicle
    from pygame.font import Font

__all__ = ["EV_COLOR", "OTHER_COLOR", "TV_COLOR", "HighwayRenderer"]

EV_COLOR = (220, 40, 40)
TV_COLOR = (40, 90, 230)
OTHER_COLOR = (120, 120, 120)
"""Further vehicles in traffic scenes."""
ELLIPSE_COLOR = (40, 90, 230)
SCALED_ELLIPSE_COLOR = (230, 160, 30)
RENDER_MODES = ("rgb_array", "human")

_LIVE: weakref.WeakSet[HighwayRenderer] = weakref.WeakSet()
"""Renderers whose viewer is open; pygame is quit only when the last one closes."""


def _positive_int(name: str, value: object) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer number of pixels, got {value!r}")
    if value <= 0:
        raise ValueError(f"{name} must be > 0 pixels, got {value}")
    return int(value)


def _vehicle_state(name: str, value: object) -> np.ndarray:
    """A state [x, y, φ, v] as 4 finite floats, or a ValueError naming the argument."""
    try:
        state = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        state = None
    if state is None or state.shape != (4,):
        shape = "?" if state is None else state.shape
        raise ValueError(
            f"{name} must be a state [x, y, phi, v] of shape (4,), got {value!r} (shape {shape})"
        )
    if not np.all(np.isfinite(state)):
        raise ValueError(f"{name} must be finite to be drawn, got {state}")
    return state


class HighwayRenderer:
    """Stateful drawing shell around highway-env's ``EnvViewer``.

    Args:
        render_mode: ``"rgb_array"`` (off-screen) or ``"human"`` (a pygame window).
        width: frame width [px].
        height: frame height [px].
        scaling: pixels per metre.

    Raises:
        ValueError: unknown ``render_mode``, non-positive size or scaling.
        TypeError: a size that is not an integer.
    """

    def __init__(
        self,
        render_mode: str = "rgb_array",
        width: int = 900,
        height: int = 180,
        scaling: float = 7.0,
    ) -> None:
        if render_mode not in RENDER_MODES:
            raise ValueError(
                f"render_mode must be one of {list(RENDER_MODES)}, got {render_mode!r}"
            )
        width = _positive_int("width", width)
        height = _positive_int("height", height)
        if not isinstance(scaling, (int, float, np.integer, np.floating)) or isinstance(
            scaling, bool
        ):
            raise TypeError(f"scaling must be a number [px/m], got {scaling!r}")
        if not (math.isfinite(scaling) and scaling > 0):
            raise ValueError(f"scaling must be finite and > 0 [px/m], got {scaling}")
        if render_mode == "rgb_array":
            # off-screen surfaces need no display; keep pygame from opening one
            os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        import pygame

        self._pygame = pygame
        self.render_mode = render_mode
        self.config = {
            "screen_width": width,
            "screen_height": height,
            "offscreen_rendering": render_mode != "human",
            "scaling": float(scaling),
            "centering_position": [0.35, 0.5],
            "simulation_frequency": 5,
            "real_time_rendering": render_mode == "human",
            "render_agent": render_mode == "human",
        }
        self._scene = SimpleNamespace(
            config=self.config,
            road=None,
            vehicle=None,
            observation_type=None,
            action_type=None,
            close=self.close,
        )
        self._geometry: tuple | None = None
        self._font: Font | None = None
        self.viewer: EnvViewer | None = None
        self._open()

    def _open(self) -> None:
        """(Re)create highway-env's viewer (and, in human mode, its window)."""
        from highway_env.envs.common.graphics import EnvViewer

        self.viewer = EnvViewer(self._scene, self.config)
        self.viewer.enabled = True  # see module docstring: dummy driver ≠ no drawing
        self._font = None
        _LIVE.add(self)

    def _ensure_open(self) -> None:
        """Reopen after ``close()`` or after pygame's display was quit under a window."""
        display = self._pygame.display
        window_lost = self.render_mode == "human" and (
            not display.get_init() or display.get_surface() is None
        )
        if self.viewer is None or window_lost:
            self._open()

    def _live_viewer(self) -> EnvViewer:
        """The open viewer (drawing runs after ``_ensure_open``)."""
        if self.viewer is None:
            raise RuntimeError("the renderer's viewer is closed; draw() reopens it")
        return self.viewer

    def _caption_surface(self, caption: str):
        """The caption as a surface, drawn with a font valid in pygame's current session."""
        font = self._pygame.font
        colours = ((255, 255, 255), (60, 60, 60))
        if not font.get_init():  # pygame was quit elsewhere
            font.init()
            self._font = None
        if self._font is None:
            self._font = font.SysFont(None, 24)
        try:
            return self._font.render(caption, True, *colours)
        except self._pygame.error:  # the font outlived a font.quit() + init() elsewhere
            self._font = font.SysFont(None, 24)
            return self._font.render(caption, True, *colours)

    def _build_road(self, sc: ScenarioConfig) -> None:
        from highway_env.road.lane import LineType, StraightLane
        from highway_env.road.road import Road, RoadNetwork
        from highway_env.vehicle.kinematics import Vehicle

        net = RoadNetwork()
        for i in range(sc.n_lanes):
            y = sc.road_width - sc.lane_centres[i]  # flipped: lane 0 at the bottom
            lines = (
                LineType.CONTINUOUS if i == sc.n_lanes - 1 else LineType.STRIPED,
                LineType.CONTINUOUS if i == 0 else LineType.NONE,
            )
            net.add_lane(
                "a",
                "b",
                StraightLane([-1e3, y], [1e4, y], width=sc.lane_width, line_types=lines),
            )
        road = Road(network=net)
        ev = Vehicle(road, [0.0, 0.0])
        tv = Vehicle(road, [0.0, 0.0])
        for v, color in ((ev, EV_COLOR), (tv, TV_COLOR)):
            v.LENGTH, v.WIDTH, v.color = sc.vehicle_length, sc.vehicle_width, color
            road.vehicles.append(v)
        self._scene.road, self._scene.vehicle = road, ev
        self._tv = tv
        self._others: list[Vehicle] = []
        self._geometry = (sc.n_lanes, sc.lane_width, sc.vehicle_length, sc.vehicle_width)

    def _ensure_other_vehicles(self, sc: ScenarioConfig, m: int) -> None:
        """Keep exactly m extra vehicles on the drawn road."""
        from highway_env.vehicle.kinematics import Vehicle

        road = self._scene.road
        while len(self._others) < m:
            v = Vehicle(road, [0.0, 0.0])
            v.LENGTH, v.WIDTH, v.color = sc.vehicle_length, sc.vehicle_width, OTHER_COLOR
            self._others.append(v)
        keep = {id(self._scene.vehicle), id(self._tv), *(id(v) for v in self._others[:m])}
        road.vehicles = [v for v in road.vehicles if id(v) in keep]
        for v in self._others[:m]:
            if v not in road.vehicles:
                road.vehicles.append(v)

    def _to_screen(self, sc: ScenarioConfig, x: float, y: float) -> tuple[int, int]:
        return self._live_viewer().sim_surface.pos2pix(x, sc.road_width - y)

    def _draw_ellipse(
        self, sc: ScenarioConfig, centre: np.ndarray, scale: float, color: tuple[int, int, int]
    ) -> None:
        th = np.linspace(0, 2 * np.pi, 90)
        pts = [
            self._to_screen(
                sc, centre[0] + scale * sc.l_a * np.cos(t), centre[1] + scale * sc.l_b * np.sin(t)
            )
            for t in th
        ]
        self._pygame.draw.lines(self._live_viewer().sim_surface, color, True, pts, 2)

    def draw(
        self,
        sc: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        caption: str = "",
        show_ellipse: bool = True,
        others: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """Draw one frame.

        Args:
            sc: scenario (road and vehicle geometry, ellipse axes, λ).
            ev: EV state [x, y, φ, v].
            tv: TV state [x, y, φ, v].
            caption: text drawn in the top-left corner.
            show_ellipse: draw the safety ellipse and the λ-scaled ellipse.
            others: further vehicles' states [x, y, φ, v], shape (m, 4) (drawn grey).

        Returns:
            The frame, shape (height, width, 3) uint8, in ``rgb_array`` mode; else None.

        Raises:
            TypeError: ``sc`` is not a :class:`ScenarioConfig` or ``caption`` not a string.
            ValueError: a state that is not 4 finite numbers.
        """
        if not isinstance(sc, ScenarioConfig):
            raise TypeError(f"sc must be a ScenarioConfig, got {type(sc).__name__}")
        ev = _vehicle_state("ev", ev)
        tv = _vehicle_state("tv", tv)
        if not isinstance(caption, str):
            raise TypeError(f"caption must be a string, got {type(caption).__name__}")
        self._ensure_open()
        geometry = (sc.n_lanes, sc.lane_width, sc.vehicle_length, sc.vehicle_width)
        if self._geometry != geometry:
            self._build_road(sc)
        others = np.zeros((0, 4)) if others is None else np.asarray(others, float).reshape(-1, 4)
        if not np.all(np.isfinite(others)):
            raise ValueError("others must hold finite states [x, y, phi, v]")
        self._ensure_other_vehicles(sc, len(others))
        for vehicle, state in (
            (self._scene.vehicle, ev),
            (self._tv, tv),
            *zip(self._others[: len(others)], others, strict=True),
        ):
            vehicle.position = np.array([state[0], sc.road_width - state[1]])
            vehicle.heading = -float(state[2])
            vehicle.speed = float(state[3])
        viewer = self._live_viewer()
        # camera: follow the EV along x, keep the road centred vertically
        viewer.observer_vehicle = SimpleNamespace(position=np.array([ev[0], sc.road_width / 2]))
        offscreen = viewer.offscreen
        viewer.offscreen = True  # draw first, blit to the window after the overlays
        viewer.display()
        viewer.offscreen = offscreen
        if show_ellipse:
            self._draw_ellipse(sc, tv, 1.0, ELLIPSE_COLOR)
            self._draw_ellipse(sc, tv, float(np.sqrt(sc.trigger_lambda)), SCALED_ELLIPSE_COLOR)
        if caption:
            viewer.sim_surface.blit(self._caption_surface(caption), (8, 6))
        if self.render_mode == "human":
            viewer.screen.blit(viewer.sim_surface, (0, 0))
            self._pygame.display.flip()
            viewer.handle_events()
            return None
        return viewer.get_image()

    def close(self) -> None:
        """Close the viewer (and its window); a later ``draw`` reopens it.

        pygame itself is quit only by the last live renderer (module docstring).
        """
        if self.viewer is None:
            return
        viewer, self.viewer, self._font = self.viewer, None, None
        _LIVE.discard(self)
        if not _LIVE:
            viewer.close()  # pygame.quit(), as highway-env's own envs do
        elif self.render_mode == "human" and not any(r.render_mode == "human" for r in _LIVE):
            self._pygame.display.quit()  # shut the window; off-screen drawing needs none
