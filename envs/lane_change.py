"""The three-lane highway lane-change environment (paper §IV-A).

An ego vehicle (EV) driven by continuous physical inputs [a, δ] changes from ``ev_lane``
to ``target_lane`` while a scripted target vehicle (TV) drives at constant speed. Its
reward, the task's or a :class:`~drivestyle.envs.reward_model.RewardModel`'s, is
:mod:`drivestyle.envs.reward_model`'s.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from drivestyle.envs.dynamics import rk4_step_scalar
from drivestyle.envs.reward_model import (
    COLLISION_PENALTY,
    RewardModel,
    check_reward_model,
    style_reward_model,
)
from drivestyle.envs.safety import rectangles_overlap, vehicle_corners
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges, get_scenario

if TYPE_CHECKING:
    from drivestyle.envs.rendering import HighwayRenderer

__all__ = ["LaneChangeEnv", "TVDeviation"]


@dataclass(frozen=True)
class TVDeviation:
    """A TV that deviates from the constant velocity every predictor assumes.

    From ``t_start`` for ``duration`` seconds the TV accelerates at ``accel`` (negative:
    it brakes; its speed stays ≥ 0), then keeps its new speed. The acceleration applies to
    the steps that start within [t_start, t_start + duration) (with T_s = 0.2 s the
    default 1.5 s from t = 1.5 s covers the 7 steps starting at 1.6 … 2.8 s: 5.6 m/s).
    """

    t_start: float = 1.5
    """Start of the deviation [s]."""
    accel: float = -4.0
    """Longitudinal acceleration during the deviation [m/s²]."""
    duration: float = 1.5
    """Length of the deviation [s]."""

    def __post_init__(self) -> None:
        for name in ("t_start", "accel", "duration"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise ValueError(f"TVDeviation.{name} must be a finite number, got {value!r}")
        if self.t_start < 0 or self.duration <= 0:
            raise ValueError("TVDeviation needs t_start >= 0 and duration > 0")

    def accel_at(self, t: float) -> float:
        """The TV's acceleration over the step starting at t [m/s²]."""
        return self.accel if self.t_start <= t < self.t_start + self.duration else 0.0


class _StepConstants:
    """What a step reads from the scenario and the action space, as plain floats.

    Built once per scenario (scenario properties such as ``y_ref`` build arrays per call);
    the step is the hot path of a training loop.
    """

    __slots__ = (
        "a_hi",
        "a_lo",
        "d_hi",
        "d_lo",
        "dt",
        "half_l",
        "half_w",
        "l_a",
        "l_b",
        "l_f",
        "l_r",
        "lane_width",
        "length",
        "n_steps",
        "road_width",
        "scenario",
        "space",
        "top_lane",
        "v_max",
        "v_ref",
        "width",
        "y_ref",
    )

    def __init__(self, sc: ScenarioConfig, space: spaces.Box) -> None:
        self.scenario, self.space = sc, space
        (self.a_lo, self.d_lo), (self.a_hi, self.d_hi) = space.low.tolist(), space.high.tolist()
        self.dt, self.l_f, self.l_r = float(sc.dt), float(sc.l_f), float(sc.l_r)
        self.v_max, self.v_ref, self.y_ref = float(sc.v_max), float(sc.v_ref), sc.y_ref
        self.lane_width, self.road_width = float(sc.lane_width), float(sc.road_width)
        self.top_lane, self.n_steps = sc.n_lanes - 1, sc.n_steps
        self.l_a, self.l_b = float(sc.l_a), float(sc.l_b)
        self.length, self.width = float(sc.vehicle_length), float(sc.vehicle_width)
        self.half_l, self.half_w = self.length / 2, self.width / 2


_OVERLAP_MARGIN = 1e-6
"""[m] Bounding boxes further apart than this cannot overlap, whatever the round-off of the
exact test (positions are < 1e4 m, round-off < 1e-11 m)."""


def checked_options(
    options: Any, known: tuple[str, ...], example: str | None = None
) -> dict[str, Any]:
    """A reset's ``options``: a dict (None: empty) whose keys are all in ``known``.

    Raises:
        TypeError: not a dict (the message shows ``example`` when given).
        ValueError: an unknown option.
    """
    options = {} if options is None else options
    if not isinstance(options, dict):
        such_as = f" such as {example}" if example else ""
        raise TypeError(f"reset options must be a dict{such_as} or None, got {options!r}")
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise ValueError(f"unknown reset option(s) {unknown}; known: {list(known)}")
    return options


def episode_scenario(
    options: dict[str, Any],
    ranges: ScenarioRanges | None,
    base: ScenarioConfig,
    rng: np.random.Generator,
) -> ScenarioConfig:
    """The episode's scenario.

    ``options["scenario"]`` (a config or a name), else a draw from ``ranges``, else ``base``.

    Raises:
        KeyError: ``options["scenario"]`` names no known scenario.
    """
    if "scenario" in options:
        try:
            return get_scenario(options["scenario"])
        except KeyError as exc:
            raise KeyError(f"reset options['scenario']: {exc.args[0]}") from None
    return ranges.sample(rng) if ranges is not None else base


def two_vehicle_spaces(sc: ScenarioConfig, second_v_max: float) -> tuple[spaces.Box, spaces.Box]:
    """The action space [a, δ] and the observation space of two vehicles' states.

    Both float64: the action within the scenario's input bounds; the observation
    [x, y, φ, v] ++ [x, y, φ, v] with speeds from 0 to v_max (the second vehicle's to
    ``second_v_max``).
    """
    action = spaces.Box(
        low=np.array([sc.a_min, -sc.delta_max]),
        high=np.array([sc.a_max, sc.delta_max]),
        dtype=np.float64,
    )
    inf = np.inf
    observation = spaces.Box(
        low=np.array([-inf, -inf, -inf, 0.0, -inf, -inf, -inf, 0.0]),
        high=np.array([inf, inf, inf, sc.v_max, inf, inf, inf, second_v_max]),
        dtype=np.float64,
    )
    return action, observation


def _vehicles_overlap(
    c: _StepConstants, a: list[float], cos_a: float, sin_a: float, b: list[float]
) -> bool:
    """Whether two vehicles' rectangles overlap (:func:`rectangles_overlap`'s answer).

    Most pairs are far apart: their axis-aligned bounding boxes are separated, which rules
    out an overlap without building corners; the others get the exact separating-axis test.
    """
    dx, dy = abs(a[0] - b[0]), abs(a[1] - b[1])
    ca, sa = abs(cos_a), abs(sin_a)
    phi_b = b[2]
    cb, sb = (1.0, 0.0) if phi_b == 0.0 else (abs(math.cos(phi_b)), abs(math.sin(phi_b)))
    hl, hw, m = c.half_l, c.half_w, _OVERLAP_MARGIN
    if dx > hl * (ca + cb) + hw * (sa + sb) + m or dy > hl * (sa + sb) + hw * (ca + cb) + m:
        return False
    return rectangles_overlap(
        vehicle_corners(a, c.length, c.width), vehicle_corners(b, c.length, c.width)
    )


class LaneChangeEnv(gym.Env):
    """Gymnasium environment of the paper's lane change with an EV and a scripted TV.

    Observation (``Box(8,)``, float64, SI units): ``[x, y, φ, v]`` of the EV then of the TV
    [m, m, rad, m/s], road frame (x along the road, y to the left, lane 0 at y = w_lane/2).
    Action (``Box(2,)``, float64): ``[a, δ]`` within the scenario's bounds [m/s², rad];
    out-of-range actions are clipped (``info["action_clipped"]``).

    Dynamics: the RK4 kinematic bicycle map of :mod:`drivestyle.envs.dynamics` (shared with the
    SMPC); speed is kept in [0, v_max]. The TV keeps its speed and heading.

    Episode end: terminated on collision (vehicle rectangles overlap) or when the EV's
    centre leaves the paved road; truncated after ``scenario.n_steps`` steps (30 for the
    paper: 31 samples t = 0 … 6 s).

    ``info`` carries ``t`` [s], ``s_e`` (elliptical index, eq. 9), ``d_k`` (s_e − 1,
    nominal ellipse), ``collision``, ``off_road``, ``lane_index`` (lane of the EV centre)
    and ``action_clipped``; at reset also ``scenario`` (the :class:`ScenarioConfig`).

    Subclasses change the other vehicles, the episode's start, the task reward's reference
    and the drawing through the hooks :meth:`_advance_others`, :meth:`_collision`,
    :meth:`_start_episode`, :meth:`_initial_states`, :meth:`_task_reference`,
    :meth:`_step_info` and :meth:`_draw`; the step itself (the controlled vehicle's RK4
    step, the clipping, the episode end) stays the base class's.

    Args:
        scenario: a name from :data:`drivestyle.envs.scenario.SCENARIOS` or a config.
        randomize: ``True`` or a :class:`ScenarioRanges` to draw a new scenario at each
            reset from ``np_random`` (``drivestyle/LaneChangeRandom-v0``).
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
        show_ellipse: draw the safety ellipse (and the λ-scaled one) around the TV.
        style: a learned style (``style.json`` path or :class:`drivestyle.irl.paper.style.Style`):
            the reward becomes its negative cost (:mod:`drivestyle.irl.reward`, found as a plugin,
            see :func:`style_reward_model`); the task reward moves to ``info["original_env_rew"]``.
        reward: any :class:`RewardModel` instead of ``style`` (not both).
        tv_deviation: make the TV brake or accelerate mid-episode (:class:`TVDeviation`).
        **overrides: scenario fields to replace, e.g. ``ev_speed=27``.

    Raises:
        KeyError: an unknown scenario name.
        TypeError: an unknown or wrongly typed scenario parameter (e.g. ``ev_speed="fast"``),
            a non-bool ``show_ellipse`` or ``randomize``, or a ``reward`` without the
            :class:`RewardModel` API.
        ValueError: an invalid scenario value (e.g. a NaN speed, an infeasible start),
            an unknown ``render_mode``, or both ``style`` and ``reward``.
    """

    # gymnasium types Env.metadata as an instance variable: __init__ sets the env's render_fps
    metadata: dict[str, Any] = {  # noqa: RUF012 (never mutated; __init__ assigns a copy)
        "render_modes": ["human", "rgb_array"],
        "render_fps": 5,
    }
    _reset_options: ClassVar[tuple[str, ...]] = ("scenario",)
    """The keys ``reset(options=...)`` accepts (:meth:`_start_episode` reads a subclass's)."""
    _reset_options_example: ClassVar[str] = "{'scenario': 'paper'}"
    """A valid ``options`` dict, shown when ``options`` is not a dict."""

    def __init__(
        self,
        scenario: str | ScenarioConfig = "paper",
        randomize: bool | ScenarioRanges = False,
        render_mode: str | None = None,
        show_ellipse: bool = True,
        style: Any = None,
        reward: RewardModel | None = None,
        tv_deviation: TVDeviation | None = None,
        **overrides: Any,
    ) -> None:
        base = get_scenario(scenario).with_overrides(**overrides)
        if tv_deviation is not None and not isinstance(tv_deviation, TVDeviation):
            raise TypeError(f"tv_deviation must be a TVDeviation, got {tv_deviation!r}")
        self.tv_deviation = tv_deviation
        if style is not None and reward is not None:
            raise ValueError("pass style= or reward=, not both")
        if not isinstance(show_ellipse, (bool, np.bool_)):
            raise TypeError(f"show_ellipse must be a bool, got {show_ellipse!r}")
        if reward is not None:
            check_reward_model(reward)
        self._reward_model = style_reward_model(style) if style is not None else reward
        if randomize is True:
            randomize = ScenarioRanges(base=base)
        elif randomize is not False and not isinstance(randomize, ScenarioRanges):
            raise TypeError(f"randomize must be a bool or ScenarioRanges, got {randomize!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.base_scenario = base
        self.ranges: ScenarioRanges | None = randomize or None
        self.render_mode = render_mode
        self.show_ellipse = bool(show_ellipse)
        self.scenario = base
        self.metadata = dict(self.metadata, render_fps=round(1 / base.dt))

        action_space, self.observation_space = two_vehicle_spaces(base, np.inf)
        self.action_space: spaces.Box = action_space
        self.ev, self.tv = self._initial_states()
        self.k = 0
        self._done = False
        self._renderer: HighwayRenderer | None = None
        self._step_constants: _StepConstants | None = None

    # ------------------------------------------------------------------ helpers
    # The step is a training loop's hot path: the helpers work on Python floats (small
    # numpy arrays cost more to build than the arithmetic on them) and read the scenario
    # through _constants(); the results equal the array formulas (tests/envs/test_env.py).
    def _constants(self) -> _StepConstants:
        """The current scenario's step constants (rebuilt when the scenario changes)."""
        c = self._step_constants
        if c is None or c.scenario is not self.scenario or c.space is not self.action_space:
            c = self._step_constants = _StepConstants(self.scenario, self.action_space)
        return c

    def _obs(self) -> np.ndarray:
        return np.concatenate([self.ev, self.tv])

    def _info(self, **extra: Any) -> dict[str, Any]:
        c = self._constants()
        ev, tv = self.ev.tolist(), self.tv.tolist()
        s_e = ((ev[0] - tv[0]) / c.l_a) ** 2 + ((ev[1] - tv[1]) / c.l_b) ** 2
        return {
            "t": self.k * c.dt,
            "s_e": s_e,
            "d_k": s_e - 1.0,
            "collision": self._collision(),
            "off_road": self._off_road(),
            "lane_index": min(max(int(ev[1] // c.lane_width), 0), c.top_lane),
            **extra,
        }

    def _collision(self) -> bool:
        """Hook: whether the controlled vehicle collides with another (here: the TV)."""
        # one pair, without _overlaps_any's generator: the step's hot path
        ev = self.ev.tolist()
        phi = ev[2]
        return _vehicles_overlap(
            self._constants(), ev, math.cos(phi), math.sin(phi), self.tv.tolist()
        )

    def _overlaps_any(self, others: Iterable[list[float]]) -> bool:
        """Whether the controlled vehicle's rectangle overlaps any of ``others``' rectangles.

        Args:
            others: states [x, y, φ, v] as lists of floats (the step works on floats).
        """
        c = self._constants()
        ev = self.ev.tolist()
        cos_phi, sin_phi = math.cos(ev[2]), math.sin(ev[2])
        return any(_vehicles_overlap(c, ev, cos_phi, sin_phi, other) for other in others)

    def _advance_others(self) -> None:
        """Hook: move the other vehicles one step (here the TV).

        :meth:`step` calls it after computing the controlled vehicle's new state and before
        storing it: ``self.ev`` (and ``self.k``) are still those of t_k, so that a driver of
        another vehicle reacts to the state at t_k, as the controlled vehicle's input does.
        The TV keeps its velocity (the paper's scripted TV) or deviates (``tv_deviation``).
        """
        x, y, phi, v = self.tv.tolist()
        dt = self.scenario.dt
        a = 0.0 if self.tv_deviation is None else self.tv_deviation.accel_at(self.k * dt)
        v_new = max(v + a * dt, 0.0)
        step = 0.5 * (v + v_new) * dt
        self.tv = np.array([x + step * math.cos(phi), y + step * math.sin(phi), phi, v_new])

    def _reward_context(self) -> dict[str, Any]:
        """Extra keyword arguments of the reward model's ``step`` (traffic: the others)."""
        return {}

    def _start_episode(self, options: dict[str, Any]) -> None:
        """Hook of :meth:`reset`: prepare the episode once its scenario is chosen.

        Called after ``self.scenario`` is set and before the initial states; a subclass
        checks the scenario, reads its own reset options (:attr:`_reset_options`) and
        restarts its other vehicles' drivers here. The base class has nothing to prepare.

        Args:
            options: the reset's options, their keys already checked.
        """

    def _initial_states(self) -> tuple[np.ndarray, np.ndarray]:
        """Hook: the controlled vehicle's and the other vehicle's states at t = 0.

        The base class controls the scenario's EV; a subclass may control another vehicle.
        """
        return self.scenario.ev_initial_state, self.scenario.tv_initial_state

    def _task_reference(self) -> tuple[float, float]:
        """Hook: the lane centre [m] and the speed [m/s] of the task reward's errors.

        The base class holds the controlled vehicle to the target lane's centre y_ref and
        to v_ref (:func:`~drivestyle.envs.reward_model.task_reward`).
        """
        c = self._constants()
        return c.y_ref, c.v_ref

    def _step_info(self, action: np.ndarray, clipped: bool) -> dict[str, Any]:
        """Hook: a step's ``info``, built once the step's states are stored.

        Args:
            action: the controlled vehicle's applied (clipped) input [a, δ].
            clipped: whether the action was clipped.

        Returns:
            :meth:`_info` with ``action_clipped`` and ``action``; a subclass adds what its
            other vehicles did over the step.
        """
        return self._info(action_clipped=clipped, action=action)

    def _bicycle_step(self, state: list[float], a: float, delta: float) -> list[float]:
        """A vehicle's state [x, y, φ, v] one sampling period later under the input [a, δ].

        One RK4 step of the kinematic bicycle (:func:`rk4_step_scalar`, the SMPC's map),
        the speed then kept in [0, v_max]; for the controlled vehicle and for any other
        vehicle a subclass drives with physical inputs.
        """
        c = self._constants()
        x, y, phi, v = state
        x, y, phi, v = rk4_step_scalar(x, y, phi, v, a, delta, c.dt, c.l_f, c.l_r)
        return [x, y, phi, min(max(v, 0.0), c.v_max)]

    def _off_road(self) -> bool:
        return not (0.0 <= float(self.ev[1]) <= self._constants().road_width)

    @staticmethod
    def _checked_action(action: Any) -> tuple[float, float]:
        """(a, δ) of a step's action as floats.

        Raises:
            ValueError: the action is not numeric, has the wrong shape or is not finite.
        """
        if type(action) is np.ndarray and action.shape == (2,) and action.dtype.kind == "f":
            a, delta = action.tolist()  # the common case: skip the generic conversion
        else:
            try:
                raw = np.asarray(action)
                # not strings, objects (None) or complex numbers: they would convert (to NaN,
                # or silently losing an imaginary part)
                u = raw.astype(float).reshape(-1) if raw.dtype.kind in "biuf" else None
            except (TypeError, ValueError):
                u = None
            if u is None:
                raise ValueError(f"action must be real numbers [a, delta], got {action!r}")
            if u.shape != (2,):
                raise ValueError(
                    f"action must have shape (2,) = [a, delta], got {np.shape(action)}"
                )
            a, delta = u.tolist()
        if not (math.isfinite(a) and math.isfinite(delta)):
            raise ValueError(f"action must be finite, got {np.array([a, delta])}")
        return a, delta

    # ------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode.

        Args:
            seed: seeds ``np_random`` (scenario draws of the random family).
            options: ``{"scenario": ScenarioConfig | name}`` fixes this episode's scenario.

        Returns:
            Observation and info.

        Raises:
            TypeError: ``options`` is not a dict.
            ValueError: an unknown option.
            KeyError: ``options["scenario"]`` names no known scenario.
        """
        super().reset(seed=seed)
        options = checked_options(options, self._reset_options, self._reset_options_example)
        self.scenario = episode_scenario(options, self.ranges, self.base_scenario, self.np_random)
        self._start_episode(options)
        self.ev, self.tv = self._initial_states()
        self.k = 0
        self._done = False
        if self._reward_model is not None:
            self._reward_model.reset(self.scenario, self.ev, self.tv)
        if self.render_mode == "human":
            self.render()
        return self._obs(), self._info(scenario=self.scenario, action_clipped=False)

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict[str, Any]]:
        """Advance one sampling period T_s.

        Args:
            action: [a, δ] [m/s², rad].

        Returns:
            observation, reward, terminated, truncated, info.

        Raises:
            ValueError: the action is not numeric, has the wrong shape or is not finite.
            RuntimeError: the episode has ended (terminated or truncated): call reset().
        """
        if self._done:
            raise RuntimeError(
                "step() called after the episode ended (terminated or truncated); call reset()"
            )
        a, delta = self._checked_action(action)
        sc = self.scenario
        c = self._constants()
        # np.clip's answer for finite numbers
        a_clip = c.a_lo if a < c.a_lo else (c.a_hi if a > c.a_hi else a)
        d_clip = c.d_lo if delta < c.d_lo else (c.d_hi if delta > c.d_hi else delta)
        x, y, phi, v = self._bicycle_step(self.ev.tolist(), a_clip, d_clip)
        self._advance_others()
        self.ev = np.array([x, y, phi, v])
        self.k += 1
        u_clip = np.array([a_clip, d_clip])
        info = self._step_info(u_clip, a_clip != a or d_clip != delta)
        terminated = info["collision"] or info["off_road"]
        truncated = (not terminated) and self.k >= c.n_steps
        self._done = terminated or truncated
        # task_reward, on the floats at hand
        y_ref, v_ref = self._task_reference()
        lane_err = (y - y_ref) / c.lane_width
        speed_err = (v - v_ref) / 10.0
        reward = float(-(lane_err**2 + speed_err**2) - COLLISION_PENALTY * terminated)
        if self._reward_model is not None:
            info["original_env_rew"] = reward
            reward, info["style_feature_increment"] = self._reward_model.step(
                u_clip, self.ev, self.tv, sc.dt, **self._reward_context()
            )
            if terminated:
                reward -= self._reward_model.crash_penalty
        if self.render_mode == "human":
            self.render()
        return self._obs(), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """Draw the scene with highway-env's viewer (RGB array in ``rgb_array`` mode)."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode=...")
            return None
        if self._renderer is None:
            from drivestyle.envs.rendering import HighwayRenderer

            self._renderer = HighwayRenderer(self.render_mode)
        return self._draw(self._renderer)

    def _draw(self, renderer: HighwayRenderer) -> np.ndarray | None:
        """Hook of :meth:`render`: draw the scene with its caption.

        The renderer follows its EV (here the controlled vehicle) and draws the safety
        ellipse around its TV.
        """
        info = self._info()
        caption = f"t = {info['t']:4.1f} s   v = {self.ev[3]:5.2f} m/s   s_e = {info['s_e']:5.2f}"
        return renderer.draw(self.scenario, self.ev, self.tv, caption, self.show_ellipse)

    def close(self) -> None:
        """Release the viewer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
