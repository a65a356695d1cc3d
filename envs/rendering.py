"""Drawing the lane change with highway-env's viewer (pygame).

highway-env draws roads and vehicles of its own ``Road``/``Vehicle`` objects through
``EnvViewer``; this module mirrors the env's state into those objects each frame (EV red,
TV blue), lets the viewer draw them, and adds the safety ellipses and a caption. The
scene is flipped vertically so that lane 0 (the EV's start) is at the bottom, as in the
paper's figures.

Headless use: ``rgb_array`` draws on an off-screen surface. highway-env disables its
viewer when ``SDL_VIDEODRIVER=dummy`` (frames come out blank); off-screen drawing does not
need a display, so the renderer re-enables it.
"""

from __future__ import annotations

import os
from types import SimpleNamespace

import numpy as np

from envs.scenario import ScenarioConfig

__all__ = ["EV_COLOR", "TV_COLOR", "HighwayRenderer"]

EV_COLOR = (220, 40, 40)
TV_COLOR = (40, 90, 230)
ELLIPSE_COLOR = (40, 90, 230)
SCALED_ELLIPSE_COLOR = (230, 160, 30)


class HighwayRenderer:
    """Stateful drawing shell around highway-env's ``EnvViewer``.

    Args:
        render_mode: ``"rgb_array"`` (off-screen) or ``"human"`` (a pygame window).
        width: frame width [px].
        height: frame height [px].
        scaling: pixels per metre.
    """

    def __init__(
        self,
        render_mode: str = "rgb_array",
        width: int = 900,
        height: int = 180,
        scaling: float = 7.0,
    ) -> None:
        if render_mode == "rgb_array":
            # off-screen surfaces need no display; keep pygame from opening one
            os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
        os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
        import pygame
        from highway_env.envs.common.graphics import EnvViewer

        self._pygame = pygame
        self.render_mode = render_mode
        self.config = {
            "screen_width": width,
            "screen_height": height,
            "offscreen_rendering": render_mode != "human",
            "scaling": scaling,
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
        self.viewer = EnvViewer(self._scene, self.config)
        self.viewer.enabled = True  # see module docstring: dummy driver ≠ no drawing
        self._font = None

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
        self._geometry = (sc.n_lanes, sc.lane_width, sc.vehicle_length, sc.vehicle_width)

    def _to_screen(self, sc: ScenarioConfig, x: float, y: float) -> tuple[int, int]:
        return self.viewer.sim_surface.pos2pix(x, sc.road_width - y)

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
        self._pygame.draw.lines(self.viewer.sim_surface, color, True, pts, 2)

    def draw(
        self,
        sc: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        caption: str = "",
        show_ellipse: bool = True,
    ) -> np.ndarray | None:
        """Draw one frame.

        Args:
            sc: scenario (road and vehicle geometry, ellipse axes, λ).
            ev: EV state [x, y, φ, v].
            tv: TV state [x, y, φ, v].
            caption: text drawn in the top-left corner.
            show_ellipse: draw the safety ellipse and the λ-scaled ellipse.

        Returns:
            The frame, shape (height, width, 3) uint8, in ``rgb_array`` mode; else None.
        """
        geometry = (sc.n_lanes, sc.lane_width, sc.vehicle_length, sc.vehicle_width)
        if self._geometry != geometry:
            self._build_road(sc)
        for vehicle, state in ((self._scene.vehicle, ev), (self._tv, tv)):
            vehicle.position = np.array([state[0], sc.road_width - state[1]])
            vehicle.heading = -float(state[2])
            vehicle.speed = float(state[3])
        viewer = self.viewer
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
            if self._font is None:
                self._pygame.font.init()
                self._font = self._pygame.font.SysFont(None, 24)
            text = self._font.render(caption, True, (255, 255, 255), (60, 60, 60))
            viewer.sim_surface.blit(text, (8, 6))
        if self.render_mode == "human":
            viewer.screen.blit(viewer.sim_surface, (0, 0))
            self._pygame.display.flip()
            viewer.handle_events()
            return None
        return viewer.get_image()

    def close(self) -> None:
        """Close the viewer (and its window)."""
        if self.viewer is not None:
            self.viewer.close()
            self.viewer = None
