"""The cut-in scenario (``drivestyle/CutIn-v0``): an automated ego and a lane changer ahead.

The observer is itself an automated vehicle: the agent-controlled **ego** drives in the
target lane while a vehicle of unknown risk (the **cutter**, by default SMPC(p)) changes
into that lane in front of it or waits for it to pass.

Frame: a :class:`ScenarioConfig` means what it means everywhere else in the project, seen
from the lane changer. The cutter is the scenario's EV (starts in ``ev_lane`` at ``ev_x``
with ``ev_speed``, heads for ``target_lane`` at the desired speed ``v_ref``); the ego is
the scenario's TV (lane ``tv_lane``, which must be ``target_lane``; initial
x = ``ev_x + tv_gap``, initial speed ``tv_speed``, which is also its desired speed).

The cutter's driver is a plug-in (:class:`CutInDriver`): the env package does not import
the agents package (layering ``envs ← irl ← agents``), so the default driver, SMPC(p)
(:class:`drivestyle.agents.smpc.SMPCDriver`), is found through the entry point ``smpc``
of the group :data:`DRIVER_PLUGINS`, as :func:`drivestyle.envs.reward_model.style_reward_model`
finds the learned reward.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from drivestyle.envs.lane_change import LaneChangeEnv, two_vehicle_spaces
from drivestyle.envs.scenario import ScenarioConfig, ScenarioRanges, get_scenario

if TYPE_CHECKING:
    from drivestyle.envs.rendering import HighwayRenderer

__all__ = [
    "CUT_IN",
    "DRIVER_PLUGINS",
    "RISK_BOUNDS",
    "CutInDriver",
    "CutInEnv",
    "load_driver",
]

CUT_IN = ScenarioConfig(horizon_s=8.0)
"""Base scenario: the paper's, over 8 s (40 steps) so that the cut-in's consequences for
the ego play out."""

DRIVER_PLUGINS = "drivestyle.drivers"
"""Entry-point group of cutter drivers; the env's default is its ``smpc`` entry."""

RISK_BOUNDS = (0.5, 0.99)
"""Admissible cutter risks p: from p = 0.5 (κ = Φ⁻¹(p) = 0, the nominal ellipse only) to the
most cautious driver of the project's risk range."""


class CutInDriver(Protocol):
    """The cutter's driver: a policy of the lane changer given both vehicles' states."""

    def reset(self, scenario: ScenarioConfig, risk: float) -> None:
        """Start an episode of ``scenario`` (the cutter is its EV) with risk p = ``risk``."""

    def act(self, cutter: np.ndarray, ego: np.ndarray) -> np.ndarray:
        """The cutter's input [a, δ] at t_k from both states [x, y, φ, v] at t_k."""


def load_driver(name: str = "smpc") -> CutInDriver:
    """A new cutter driver from the ``drivestyle.drivers`` plug-ins (module docstring).

    Args:
        name: the entry point's name (``smpc``: SMPC(p), the demonstrations' expert).

    Raises:
        RuntimeError: no such driver plug-in is installed (install the project with pip).
    """
    found = entry_points(group=DRIVER_PLUGINS, name=name)
    if not found:
        raise RuntimeError(
            f"CutInEnv needs the cutter driver plug-in {name!r} of the entry-point group "
            f"{DRIVER_PLUGINS!r}; install the project (pip install -e .) or pass driver="
        )
    return next(iter(found)).load()()


def _check_driver(driver: Any) -> None:
    """Raise a TypeError naming ``driver=`` unless it has the :class:`CutInDriver` API."""
    missing = [name for name in ("reset", "act") if not callable(getattr(driver, name, None))]
    if missing:
        raise TypeError(
            f"driver must be a CutInDriver (reset(scenario, risk), act(cutter, ego)); "
            f"{type(driver).__name__} lacks {missing}"
        )


def _check_risk(name: str, value: Any) -> float:
    """The risk p as a float, or a one-line error naming ``name`` and the value."""
    if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(
        value, (bool, np.bool_)
    ):
        raise TypeError(f"{name} must be a number p, got {value!r}")
    lo, hi = RISK_BOUNDS
    if not lo <= float(value) <= hi:  # also rejects NaN
        raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
    return float(value)


def _check_risk_range(value: Any) -> tuple[float, float]:
    """``risk_range`` as (low, high) within :data:`RISK_BOUNDS`, or a one-line error."""
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise TypeError(f"risk_range must be a pair (low, high), got {value!r}")
    low = _check_risk("risk_range[0]", value[0])
    high = _check_risk("risk_range[1]", value[1])
    if low > high:
        raise ValueError(f"risk_range must have low <= high, got {tuple(value)!r}")
    return low, high


def _check_scenario(sc: ScenarioConfig, where: str) -> ScenarioConfig:
    """``sc`` if the ego (its TV) starts in the target lane within v_max, else a ValueError."""
    if sc.tv_lane != sc.target_lane:
        raise ValueError(
            f"{where}: the ego (the scenario's TV) must start in the target lane, got "
            f"tv_lane={sc.tv_lane} and target_lane={sc.target_lane}"
        )
    if sc.tv_speed > sc.v_max:
        raise ValueError(f"{where}: the ego's tv_speed={sc.tv_speed} exceeds v_max={sc.v_max}")
    return sc


class CutInEnv(LaneChangeEnv):
    """Gymnasium environment of a cut-in in front of an agent-controlled ego (module docstring).

    Observation (``Box(8,)``, float64, SI units): ``[x, y, φ, v]`` of the ego, then of the
    cutter [m, m, rad, m/s], road frame (x along the road, y to the left, lane 0 at
    y = w_lane/2). Action (``Box(2,)``, float64): the ego's ``[a, δ]`` within the scenario's
    bounds [m/s², rad]; out-of-range actions are clipped (``info["action_clipped"]``).

    Step: both vehicles' inputs are computed from the states at t_k (the cutter's driver
    sees (cutter, ego) at t_k), then both move one RK4 step of the kinematic bicycle
    (:mod:`drivestyle.envs.dynamics`), speeds kept in [0, v_max]; the cutter's input is
    clipped to the same bounds.

    The step, the clipping, the collision test and the episode end are
    :class:`LaneChangeEnv`'s; its controlled vehicle (``ev``) is the ego, its other vehicle
    (``tv``) the cutter (:attr:`ego` and :attr:`cutter` name them), and the hooks add the
    cutter's driver, the ego's reward reference and the info entries.

    Reward (the ego's task): −((y_e − y_lane)/w_lane)² − ((v_e − v_des)/10 m/s)² −
    10·terminated, with y_lane the ego's lane centre and v_des its initial speed.
    Terminated on a collision (the rectangles overlap) or when the ego's centre leaves the
    paved road; truncated after ``scenario.n_steps`` steps (40 for :data:`CUT_IN`).

    ``info``: ``t`` [s]; ``s_e`` = ((x_c − x_e)/l_a)² + ((y_c − y_e)/l_b)² (eq. 9 between
    the two) and ``d_k`` = s_e − 1; ``collision``; ``off_road`` (the ego); ``ego_lane_index``;
    ``cutter`` (its state); ``cutter_risk``; ``action_clipped``; after a step also
    ``action`` (the ego's clipped input) and ``cutter_input`` (the cutter's applied input);
    at reset also ``scenario``.

    Randomness (``np_random``, seeded by ``reset(seed=...)``): per reset the scenario is
    drawn from the ranges (when randomizing), then the cutter's risk uniformly from
    ``risk_range``; the risk is drawn even when ``risk=`` or ``options["risk"]`` fixes it,
    so that a seed gives the same scenarios whichever risk is imposed.

    Args:
        scenario: a name from :data:`drivestyle.envs.scenario.SCENARIOS` or a config (the
            cutter's frame, module docstring); default :data:`CUT_IN`.
        randomize: ``True`` draws the scenario per reset from
            ``ScenarioRanges(base=scenario)`` (cutter 22–28 m/s, ego 25–32 m/s and 10–30 m
            behind); a :class:`ScenarioRanges` draws from it; ``False`` keeps ``scenario``.
        risk: fix the cutter's risk p (else drawn per reset from ``risk_range``).
        risk_range: (low, high) of the drawn risk, within :data:`RISK_BOUNDS`.
        driver: the cutter's :class:`CutInDriver` (default: the ``smpc`` plug-in, SMPC(p),
            loaded once per env, :func:`load_driver`).
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
        show_ellipse: draw the safety ellipse (and the λ-scaled one) around the ego.
        **overrides: scenario fields to replace, e.g. ``tv_gap=-25``.

    Raises:
        KeyError: an unknown scenario name.
        TypeError: an unknown or wrongly typed scenario parameter, a non-bool
            ``show_ellipse`` or ``randomize``, a non-numeric risk, or a ``driver`` without
            the :class:`CutInDriver` API.
        ValueError: an invalid scenario (e.g. the ego not in the target lane), a risk or
            risk range outside :data:`RISK_BOUNDS` (or reversed), an unknown
            ``render_mode``.
        RuntimeError: no ``driver`` and no driver plug-in installed.
    """

    _reset_options: ClassVar[tuple[str, ...]] = ("risk", "scenario")
    _reset_options_example: ClassVar[str] = "{'risk': 0.7}"

    def __init__(
        self,
        scenario: str | ScenarioConfig = CUT_IN,
        randomize: bool | ScenarioRanges = True,
        risk: float | None = None,
        risk_range: tuple[float, float] = RISK_BOUNDS,
        driver: CutInDriver | None = None,
        render_mode: str | None = None,
        show_ellipse: bool = True,
        **overrides: Any,
    ) -> None:
        base = _check_scenario(get_scenario(scenario).with_overrides(**overrides), "scenario")
        if randomize is True:
            # the default ranges put the TV in lane 1: here it is the ego, in the target lane
            randomize = ScenarioRanges(base=base, tv_lanes=(base.target_lane,))
        elif randomize is not False and not isinstance(randomize, ScenarioRanges):
            raise TypeError(f"randomize must be a bool or ScenarioRanges, got {randomize!r}")
        if isinstance(randomize, ScenarioRanges):
            _check_scenario(randomize.base, "randomize.base")
            if set(randomize.tv_lanes) != {randomize.base.target_lane}:
                raise ValueError(
                    f"randomize: the ego (the TV) must start in the target lane "
                    f"{randomize.base.target_lane}, got tv_lanes={randomize.tv_lanes}"
                )
            if randomize.tv_speed[1] > randomize.base.v_max:
                raise ValueError(
                    f"randomize: the ego's tv_speed range {randomize.tv_speed} exceeds "
                    f"v_max={randomize.base.v_max}"
                )
        if not isinstance(show_ellipse, (bool, np.bool_)):
            raise TypeError(f"show_ellipse must be a bool, got {show_ellipse!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, "
                f"got {render_mode!r}"
            )
        self.fixed_risk = None if risk is None else _check_risk("risk", risk)
        self.risk_range = _check_risk_range(risk_range)
        if driver is None:
            driver = load_driver()
        else:
            _check_driver(driver)
        self.driver: CutInDriver = driver
        self.risk = (
            self.fixed_risk if self.fixed_risk is not None else float(np.mean(self.risk_range))
        )
        """The current episode's cutter risk p."""
        self._v_des = float(base.tv_speed)
        self._y_lane = float(base.lane_centres[base.tv_lane])
        self._cutter_u = np.zeros(2)
        """The cutter's input over the last step (``info["cutter_input"]``)."""
        # the arguments are checked: the base class sets the spaces, the states and the viewer
        super().__init__(base, randomize, render_mode, bool(show_ellipse))
        # the cutter's speed is bounded by v_max too (the base class's TV keeps any speed)
        _, self.observation_space = two_vehicle_spaces(base, base.v_max)

    # ------------------------------------------------------------------ the two vehicles
    @property
    def ego(self) -> np.ndarray:
        """The ego's state [x, y, φ, v] (the base class's controlled vehicle, ``ev``)."""
        return self.ev

    @ego.setter
    def ego(self, state: np.ndarray) -> None:
        self.ev = state

    @property
    def cutter(self) -> np.ndarray:
        """The cutter's state [x, y, φ, v] (the base class's other vehicle, ``tv``)."""
        return self.tv

    @cutter.setter
    def cutter(self, state: np.ndarray) -> None:
        self.tv = state

    # ------------------------------------------------------------------ hooks
    def _initial_states(self) -> tuple[np.ndarray, np.ndarray]:
        """The ego starts as the scenario's TV, the cutter as its EV (module docstring)."""
        return self.scenario.tv_initial_state, self.scenario.ev_initial_state

    def _start_episode(self, options: dict[str, Any]) -> None:
        """Check the episode's scenario, draw or take the risk, restart the driver.

        Raises:
            TypeError: a non-numeric ``options["risk"]``.
            ValueError: a risk outside :data:`RISK_BOUNDS`, a scenario whose ego is not in
                the target lane.
        """
        sc = self.scenario
        if "scenario" in options:
            _check_scenario(sc, "reset options['scenario']")
        drawn = float(self.np_random.uniform(*self.risk_range))  # always: module docstring
        if "risk" in options:
            self.risk = _check_risk("reset options['risk']", options["risk"])
        else:
            self.risk = drawn if self.fixed_risk is None else self.fixed_risk
        self._v_des = float(sc.tv_speed)
        self._y_lane = float(sc.lane_centres[sc.tv_lane])
        self.driver.reset(sc, self.risk)

    def _task_reference(self) -> tuple[float, float]:
        """The ego keeps its own lane and its initial speed."""
        return self._y_lane, self._v_des

    def _cutter_input(self) -> tuple[float, float]:
        """The driver's input at t_k, clipped to the scenario's bounds.

        Raises:
            ValueError: the driver returned something other than 2 finite numbers.
        """
        raw = self.driver.act(self.cutter.copy(), self.ego.copy())
        try:
            u = np.asarray(raw, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            u = np.empty(0)
        if u.shape != (2,) or not np.all(np.isfinite(u)):
            raise ValueError(
                f"the cutter's driver must return 2 finite numbers [a, δ], got {raw!r}"
            )
        sc = self.scenario
        a, delta = u.tolist()
        return min(max(a, sc.a_min), sc.a_max), min(max(delta, -sc.delta_max), sc.delta_max)

    def _advance_others(self) -> None:
        """Move the cutter one RK4 step with its driver's input from the states at t_k.

        Raises:
            ValueError: the driver returned no valid input (no state has changed).
        """
        a_c, d_c = self._cutter_input()
        self.cutter = np.array(self._bicycle_step(self.cutter.tolist(), a_c, d_c))
        self._cutter_u = np.array([a_c, d_c])

    def _info(self, **extra: Any) -> dict[str, Any]:
        """The base class's info, its lane index named the ego's, and the cutter's."""
        info = super()._info()
        info["ego_lane_index"] = info.pop("lane_index")
        info["cutter"] = self.cutter.copy()
        info["cutter_risk"] = self.risk
        info.update(extra)
        return info

    def _step_info(self, action: np.ndarray, clipped: bool) -> dict[str, Any]:
        """The step's info with the cutter's applied input."""
        return self._info(action=action, action_clipped=clipped, cutter_input=self._cutter_u)

    def _draw(self, renderer: HighwayRenderer) -> np.ndarray | None:
        """Draw the cutter as the renderer's EV, the ego as its TV.

        The EV is red and followed by the camera, the TV blue with the safety ellipse.
        """
        caption = (
            f"t = {self.k * self.scenario.dt:4.1f} s   ego v = {self.ego[3]:5.2f} m/s   "
            f"cutter p = {self.risk:.2f}"
        )
        return renderer.draw(self.scenario, self.cutter, self.ego, caption, self.show_ellipse)
