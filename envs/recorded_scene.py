"""A recorded scene as an environment (``drivestyle/Recorded-v0``, DESIGN §24).

``gym.make("drivestyle/Recorded-v0", episode=FILE_OR_DEMO, agent=0, others="log")`` replays a
recorded :class:`~drivestyle.envs.demonstration.Demonstration` (an episode ``.npz`` of
``drivestyle extract-episodes``, or the object) with the agent driving one of its vehicles:
``agent=0`` the EV, ``agent=j`` the j-th vehicle of ``demo.vehicles`` (1 the TV). The scene's
vehicles, their presence (from their first recorded sample on; a phantom TV never) and the
default start are :mod:`drivestyle.envs.scene_log`'s.

- **Start** (``start=``, or ``reset(options={"start": k})``): a sample index; by default the
  end of the episode's observed part (``meta["observed_until_s"]``, where the benchmark's
  predictions start, so that a reactive vehicle's desired speed has recorded speeds to come
  from), else 0. The agent starts from its recorded state there (its speed within
  [0, v_max]) and must be in the scene.
- **The agent** drives the kinematic bicycle of :mod:`drivestyle.envs.dynamics` with
  [a, δ] within the scenario's bounds (clipped, ``info["action_clipped"]``), as in every
  drivestyle env.
- **The other vehicles** (``others=``): ``"log"`` follow their recorded states (beyond a
  vehicle's last recorded sample the extraction's constant velocity); ``"idm"`` react: each
  drives :class:`~drivestyle.envs.reactive.LogLateralIDM` (IDM behind its leader, its log's
  lateral path; ``idm=`` its parameters, highway-env's by default, ``v0_factor=`` ρ of its
  desired speed); ``"style"`` react with their drivers: either given (``drivers=``: one
  :data:`~drivestyle.envs.reactive.Driver` per vehicle, a sequence indexed by vehicle or a
  mapping; None or missing: that vehicle follows its log) or their identified styles
  (``posterior=FILE``: an amortized posterior, drivestyle build-posterior's
  ``OUT/posterior.npz``, or the object; every vehicle in the scene at the start identified
  from the samples up to it, each re-planning with its style at every step against the
  current states of the vehicles ahead of it: :mod:`drivestyle.prediction.scene_drivers`,
  found through the
  ``drivestyle.scene_drivers`` entry points; built again for each start, a vehicle entering
  after it follows its log). The agent's driver is not used for the agent, but its policy
  :func:`drive_style` drives it.
  A reactive vehicle's input comes from the states at t_k (the agent's included) and moves it
  one RK4 step of the bicycle, clipped to the bounds; a vehicle entering the scene after the
  start enters at its recorded state.

  ``gym.make("drivestyle/Recorded-v0", episode=FILE, others="style", posterior=POSTERIOR)``
  replays a scene with every other vehicle driving its identified style; with
  ``run_episode(env, drive_style)`` the agent drives its own.

Observation (``Box(4 + 5K)``, float64, road frame, SI units, K = 6): the agent's
[x, y, φ, v] then K slots [present, x, y, φ, v] of the vehicles in the scene nearest to it
(centre distance), nearest first, zeros when absent — the ``Traffic-v0`` layout, so the RL
wrappers (:mod:`drivestyle.envs.rl`) apply. Episode end: terminated on the agent's collision
(rectangles overlap, any vehicle in the scene) or when its centre leaves the road; truncated
at the log's last sample. Reward: the task reward (:mod:`drivestyle.envs.reward_model`) with
the EV's recorded target lane and v_ref as references, or for another agent its own lane at
the start and its desired speed.

``info``: ``t`` [s since the start], ``time`` [s, the recording's clock], ``sample``,
``s_e`` (the least elliptical index over the vehicles in the scene, eq. 9; inf when none is),
``d_k`` = s_e − 1, ``collision``, ``off_road``, ``lane_index``, ``states`` (every vehicle's
state, shape (N, 4), vehicle order, zeros for vehicles not in the scene as in the
observation's empty slots), ``present`` (N,),
``action_clipped``; after a step also ``action``; at reset also ``scenario``, ``episode_id``,
``start``, ``agent`` and ``others``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from gymnasium import spaces

from drivestyle.envs.demonstration import Demonstration, DemonstrationError, load_demonstration
from drivestyle.envs.dynamics import recover_inputs
from drivestyle.envs.lane_change import LaneChangeEnv
from drivestyle.envs.reactive import Driver, DriverFactory, LogLateralIDM, load_driver_factory
from drivestyle.envs.scene_log import SceneLog, desired_speeds, scene_log
from drivestyle.envs.traffic import IDM, OBS_SLOTS, IDMParams

if TYPE_CHECKING:
    from drivestyle.envs.rendering import HighwayRenderer

__all__ = [
    "OTHERS",
    "RecordedSceneEnv",
    "drive_idm",
    "drive_style",
    "load_episode",
    "replay_log",
]

OTHERS = ("log", "idm", "style")
"""How the vehicles other than the agent move (module docstring)."""
_FAR = 1e4
"""[m] Where the renderer's TV is drawn when no vehicle is in the scene (off screen)."""


def load_episode(episode: Any) -> Demonstration:
    """``episode=``: a :class:`Demonstration`, or the path of its ``.npz``.

    Raises:
        TypeError: neither.
        FileNotFoundError: no such file (the message names ``episode``).
        ValueError: not a demonstration, or one without a scenario (named likewise).
    """
    if isinstance(episode, Demonstration):
        return episode
    if not isinstance(episode, (str, Path)):
        raise TypeError(
            "episode= must be a recorded Demonstration or the path of its .npz (drivestyle "
            f"extract-episodes), got {episode!r}"
        )
    try:
        return load_demonstration(episode)
    except FileNotFoundError:
        raise FileNotFoundError(f"episode={str(episode)!r}: no such file") from None
    except DemonstrationError as exc:
        raise ValueError(f"episode={str(episode)!r}: {exc}") from None


def _checked_log(demo: Demonstration, episode: Any) -> SceneLog:
    try:
        return scene_log(demo)
    except DemonstrationError as exc:
        where = f"{str(episode)!r}" if isinstance(episode, (str, Path)) else "<Demonstration>"
        raise ValueError(f"episode={where}: {exc}") from None


def _checked_agent(agent: Any, log: SceneLog) -> int:
    # ValueErrors, also of a wrong type: gym.make appends its keyword arguments (the whole
    # demonstration) to a TypeError's message
    if not isinstance(agent, (int, np.integer)) or isinstance(agent, (bool, np.bool_)):
        raise ValueError(f"agent must be a vehicle index (an integer), got {agent!r}")
    last = log.n_vehicles - 1
    if not 0 <= int(agent) <= last:
        choices = "0 (the EV)" + (
            f" or 1 … {last} (demo.vehicles)" if last else ", its only vehicle"
        )
        raise ValueError(f"agent must be {choices}, got {agent}")
    return int(agent)


def _checked_sources(drivers: Any, posterior: Any, others: str) -> None:
    """One-line errors unless ``others="style"`` has exactly one of drivers= and posterior=."""
    for name, value in (("drivers", drivers), ("posterior", posterior)):
        if others != "style" and value is not None:
            raise ValueError(
                f"{name}= drives the vehicles of others='style', got others={others!r}"
            )
    if others != "style":
        return
    if drivers is None and posterior is None:
        raise ValueError(
            "others='style' needs drivers= (one driver (j, t, states) → [a, δ] per vehicle) "
            "or posterior= (an amortized posterior or its file: every vehicle's identified style)"
        )
    if drivers is not None and posterior is not None:
        raise ValueError(
            "drivers= and posterior= contradict: posterior= builds the drivers; give one"
        )


def _checked_drivers(drivers: Any, n: int, where: str = "drivers=") -> dict[int, Driver]:
    """``drivers=`` as {vehicle: driver}, or a one-line error naming the argument."""
    if isinstance(drivers, Mapping):
        items = list(drivers.items())
    elif isinstance(drivers, Sequence) and not isinstance(drivers, (str, bytes)):
        if len(drivers) != n:
            raise ValueError(
                f"{where} must hold one entry per vehicle ({n}: the EV and demo.vehicles), "
                f"got {len(drivers)}"
            )
        items = list(enumerate(drivers))
    else:
        raise ValueError(f"{where} must be a sequence or a mapping of drivers, got {drivers!r}")
    out = {}
    for j, driver in items:
        if not isinstance(j, (int, np.integer)) or not 0 <= int(j) < n:
            raise ValueError(f"{where} names vehicle {j!r}; the vehicles are 0 … {n - 1}")
        if driver is None:
            continue
        if not callable(driver):
            raise ValueError(
                f"{where}[{j}] must be callable (j, t, states) → [a, δ], got {driver!r}"
            )
        out[int(j)] = driver
    return out


class RecordedSceneEnv(LaneChangeEnv):
    """A recorded scene with the agent driving one of its vehicles (module docstring).

    Args:
        episode: a recorded :class:`Demonstration` or the path of its ``.npz``.
        agent: the agent's vehicle: 0 the EV, j ≥ 1 the j-th vehicle of ``demo.vehicles``.
        others: ``"log"``, ``"idm"`` or ``"style"`` (module docstring).
        start: the first sample (default: the end of the observed part, else 0).
        drivers: the drivers of ``others="style"``.
        posterior: or, for ``others="style"``, the amortized posterior (or its file) whose
            identified styles drive the vehicles (module docstring).
        idm: the IDM's parameters of ``others="idm"`` (highway-env's by default).
        v0_factor: ρ of ``others="idm"``'s desired speeds.
        render_mode: ``None``, ``"rgb_array"`` or ``"human"``.
        show_ellipse: draw the safety ellipse around the nearest vehicle.

    Raises:
        TypeError: an episode that is neither a demonstration nor a path.
        FileNotFoundError: no such episode file.
        ValueError: an episode that is no replayable demonstration, an agent out of range or
            not in the scene at the start, an unknown ``others``, drivers that do not fit,
            a start outside the episode, an argument of the wrong type (each named with its
            value, in one line; not TypeErrors: ``gym.make`` appends its keyword arguments,
            a whole demonstration, to those).
    """

    _reset_options: ClassVar[tuple[str, ...]] = ("start",)
    _reset_options_example: ClassVar[str] = "{'start': 10}"

    def __init__(
        self,
        episode: Demonstration | str | Path | None = None,
        agent: int = 0,
        others: str = "log",
        start: int | None = None,
        drivers: Sequence[Driver | None] | Mapping[int, Driver] | None = None,
        posterior: Any = None,
        idm: IDMParams = IDM,
        v0_factor: float = 1.0,
        render_mode: str | None = None,
        show_ellipse: bool = True,
    ) -> None:
        if episode is None:
            raise ValueError(
                "episode= is required: a recorded Demonstration or the path of its .npz "
                "(drivestyle extract-episodes)"
            )
        demo = load_episode(episode)
        log = _checked_log(demo, episode)
        if others not in OTHERS:
            raise ValueError(
                f"others must be one of {', '.join(map(repr, OTHERS))}, got {others!r}"
            )
        if not isinstance(idm, IDMParams):
            raise ValueError(f"idm must be an IDMParams, got {idm!r}")
        if not (isinstance(v0_factor, (int, float)) and math.isfinite(v0_factor) and v0_factor > 0):
            raise ValueError(f"v0_factor must be a finite number > 0, got {v0_factor!r}")
        self.log = log
        self.demo = demo
        """The recorded episode (what a driver factory identifies its drivers from)."""
        self.agent = _checked_agent(agent, log)
        self.others = others
        _checked_sources(drivers, posterior, others)
        self.drivers = {} if drivers is None else _checked_drivers(drivers, log.n_vehicles)
        """{vehicle: driver} of ``others="style"`` (the agent's included, for
        :func:`drive_style`)."""
        self._factory: DriverFactory | None = None
        self._built: dict[int, dict[int, Driver]] = {}
        """The factory's drivers per start (built once; a driver starts cold on a reset)."""
        if posterior is not None:
            self._factory = load_driver_factory("style", posterior)
        self.idm = idm
        self.v0_factor = float(v0_factor)
        self.start = log.default_start if start is None else log.check_start(start)
        self._first = self.start
        """The start of a reset without ``options["start"]``."""
        self._begin(self.start)
        self._agent_inputs: np.ndarray | None = None
        super().__init__(log.scenario_from(self.start), False, render_mode, show_ellipse)
        n = 4 + 5 * OBS_SLOTS
        low, high = np.full(n, -np.inf), np.full(n, np.inf)
        low[3], high[3] = 0.0, self.scenario.v_max
        self.observation_space = spaces.Box(low=low, high=high, dtype=np.float64)

    # ------------------------------------------------------------------ the episode
    def _begin(self, start: int) -> None:
        """Prepare a replay from ``start``: check the agent, set the drivers' speeds."""
        log = self.log
        entry = log.entry(self.agent)
        if entry is None or entry > start:
            when = "never" if entry is None else f"from sample {entry} on"
            raise ValueError(
                f"agent {self.agent} is not in the scene at the start (sample {start}); it is "
                f"{when}: choose another agent or a later start"
            )
        self.start = start
        if self._factory is not None:
            if start not in self._built:
                built = self._factory(self.demo, start)
                where = "the drivers of posterior="
                self._built[start] = _checked_drivers(built, log.n_vehicles, where)
            self.drivers = self._built[start]
        self.v0 = desired_speeds(log, start, self.v0_factor)
        self.idm_driver = LogLateralIDM(log, self.v0, self.idm)
        """The driver of ``others="idm"`` (also a policy for the agent: :func:`drive_idm`)."""
        self._states = log.states[start].copy()
        self._states[~log.present[start]] = np.nan

    def _start_episode(self, options: dict[str, Any]) -> None:
        if "start" in options:
            self._begin(self.log.check_start(options["start"], "reset options['start']"))
            self.scenario = self.log.scenario_from(self.start)

    def _initial_states(self) -> tuple[np.ndarray, np.ndarray]:
        state = self.log.states[self.start, self.agent].copy()
        state[3] = min(max(state[3], 0.0), self.scenario.v_max)
        self._states[self.agent] = state
        return state, self._partner(state)

    @property
    def sample(self) -> int:
        """The current sample of the log (start + steps taken)."""
        return self.start + self.k

    @property
    def time(self) -> float:
        """The current time on the recording's clock [s]."""
        return float(self.log.t[self.sample])

    @property
    def states(self) -> np.ndarray:
        """Every vehicle's current state, shape (N, 4), NaN rows for absent vehicles."""
        out = self._states.copy()
        out[self.agent] = self.ev
        return out

    def recorded_inputs(self) -> np.ndarray:
        """The agent's recorded inputs [a, δ] over the log, shape (n − 1, 2).

        The EV's are the demonstration's (recovered from its states); another vehicle's are
        recovered from its recorded states the same way (:func:`recover_inputs`, once).
        """
        if self._agent_inputs is None:
            if self.agent == 0:
                self._agent_inputs = self.log.ev_inputs
            else:
                states = self.log.states[:, self.agent]
                self._agent_inputs = recover_inputs(states, self.log.scenario, self.log.t)
        return self._agent_inputs

    def _present_others(self) -> np.ndarray:
        present = np.isfinite(self._states[:, 0])
        present[self.agent] = False
        return present

    def _partner(self, agent_state: np.ndarray) -> np.ndarray:
        """The vehicle in the scene nearest to the agent (the renderer's TV), else far away."""
        rows = self._states[self._present_others()]
        if not len(rows):
            return np.array([agent_state[0] - _FAR, agent_state[1], 0.0, 0.0])
        d = np.hypot(rows[:, 0] - agent_state[0], rows[:, 1] - agent_state[1])
        return rows[int(np.argmin(d))].copy()

    def _driver_input(self, j: int, driver: Driver, t: float, states: np.ndarray) -> list[float]:
        """A driver's input, checked and clipped to the scenario's bounds."""
        raw = driver(j, t, states.copy())
        try:
            u = np.asarray(raw, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            u = np.empty(0)
        if u.shape != (2,) or not np.all(np.isfinite(u)):
            raise ValueError(
                f"the driver of vehicle {j} must return 2 finite numbers [a, δ], got {raw!r}"
            )
        sc = self.scenario
        a, delta = u.tolist()
        return [min(max(a, sc.a_min), sc.a_max), min(max(delta, -sc.delta_max), sc.delta_max)]

    def _advance_others(self) -> None:
        """Move every other vehicle to sample k + 1 (module docstring), from the states at t_k."""
        log, k = self.log, self.sample
        now = self.states
        t = float(log.t[k])
        new = np.full_like(now, np.nan)
        for j in range(log.n_vehicles):
            if j == self.agent or not log.present[k + 1, j]:
                continue
            driver = self.drivers.get(j)
            if self.others == "log" or not np.isfinite(now[j, 0]):  # the log, or entering now
                new[j] = log.states[k + 1, j]
            elif self.others == "idm":
                new[j] = self.idm_driver.step(j, k, now)
            elif driver is None:
                new[j] = log.states[k + 1, j]
            else:
                a, delta = self._driver_input(j, driver, t, now)
                new[j] = self._bicycle_step(now[j].tolist(), a, delta)
        self._states = new

    # ------------------------------------------------------------------ observation, info
    def _obs(self) -> np.ndarray:
        ev = self.ev.tolist()
        obs = ev + [0.0] * (5 * OBS_SLOTS)
        present = np.flatnonzero(self._present_others())
        rows = self._states[present]
        dist = np.hypot(rows[:, 0] - ev[0], rows[:, 1] - ev[1]).tolist()
        for slot, i in enumerate(sorted(range(len(present)), key=dist.__getitem__)[:OBS_SLOTS]):
            obs[4 + 5 * slot : 9 + 5 * slot] = [1.0, *rows[i].tolist()]
        return np.array(obs)

    def _info(self, **extra: Any) -> dict[str, Any]:
        c = self._constants()
        states = self.states
        present = np.isfinite(states[:, 0])
        x, y = self.ev.tolist()[:2]
        rows = self._states[self._present_others()]
        s_e = math.inf
        if len(rows):
            zx, zy = (x - rows[:, 0]) / c.l_a, (y - rows[:, 1]) / c.l_b
            s_e = float(np.min(zx * zx + zy * zy))
        return {
            "t": self.k * c.dt,
            "time": self.time,
            "sample": self.sample,
            "s_e": s_e,
            "d_k": s_e - 1.0,
            "collision": self._collision(),
            "off_road": self._off_road(),
            "lane_index": min(max(int(y // c.lane_width), 0), c.top_lane),
            "states": np.nan_to_num(states, nan=0.0),
            "present": present,
            **extra,
        }

    def _collision(self) -> bool:
        return self._overlaps_any(self._states[self._present_others()].tolist())

    def _task_reference(self) -> tuple[float, float]:
        """The EV: its recorded target lane and v_ref; another agent: its start lane, its v0."""
        c = self._constants()
        if self.agent == 0:
            return c.y_ref, c.v_ref
        y0 = float(self.log.states[self.start, self.agent, 1])
        lane = min(max(int(y0 // c.lane_width), 0), c.top_lane)
        return (lane + 0.5) * c.lane_width, float(self.v0[self.agent])

    def _step_info(self, action: np.ndarray, clipped: bool) -> dict[str, Any]:
        self.tv = self._partner(self.ev)
        return self._info(action_clipped=clipped, action=action)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start the replay (at ``options["start"]`` when given, else at this env's start).

        Raises:
            TypeError: ``options`` is not a dict.
            ValueError: an unknown option, a start that is no sample of the episode or
                before the agent enters.
        """
        if not (isinstance(options, dict) and "start" in options):
            self._begin(self._first)
        obs, info = super().reset(seed=seed, options=options)
        info.update(
            episode_id=self.log.episode_id, start=self.start, agent=self.agent, others=self.others
        )
        return obs, info

    # ------------------------------------------------------------------ drawing
    def _draw(self, renderer: HighwayRenderer) -> np.ndarray | None:
        """The agent red (followed), the nearest vehicle blue with its ellipse, the rest grey."""
        present = np.flatnonzero(self._present_others())
        rows = self._states[present]
        partner = self._partner(self.ev)
        rest = rows
        if len(rows):
            nearest = int(np.argmin(np.hypot(rows[:, 0] - self.ev[0], rows[:, 1] - self.ev[1])))
            rest = np.delete(rows, nearest, axis=0)
        caption = (
            f"{self.log.episode_id}  t = {self.k * self.scenario.dt:4.1f} s   "
            f"v = {self.ev[3]:5.2f} m/s   agent {self.agent}, others {self.others}"
        )
        show = self.show_ellipse and len(rows) > 0
        return renderer.draw(self.scenario, self.ev, partner, caption, show, others=rest)


def replay_log(env: Any, observation: np.ndarray) -> np.ndarray:
    """A policy (:data:`drivestyle.envs.rollout.Policy`): the agent's recorded inputs.

    Open loop from the recorded start: the agent follows its log within the bicycle model's
    error (:meth:`RecordedSceneEnv.recorded_inputs`).
    """
    base = env.unwrapped
    return np.array(base.recorded_inputs()[base.sample])


def drive_style(env: Any, observation: np.ndarray) -> np.ndarray:
    """A policy: the agent drives as its own entry of ``others="style"``'s drivers does.

    With ``posterior=``: the agent's identified style (every vehicle's driver is built,
    the agent's included).

    Raises:
        ValueError: the agent has no driver.
    """
    base = env.unwrapped
    driver = base.drivers.get(base.agent)
    if driver is None:
        raise ValueError(
            f"drive_style: the agent (vehicle {base.agent}) has no driver; replay with "
            "others='style' and posterior=, or drivers= holding one for it"
        )
    return np.asarray(driver(base.agent, base.time, base.states), float)


def drive_idm(env: Any, observation: np.ndarray) -> np.ndarray:
    """A policy: the agent drives as ``others="idm"``'s vehicles do (IDM, its lateral log)."""
    base = env.unwrapped
    return np.asarray(base.idm_driver(base.agent, base.time, base.states), float)
