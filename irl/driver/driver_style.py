"""The receding-horizon style model: a driver as a planner with a cost and a risk (DESIGN §15).

A :class:`DriverStyle` describes a *driver*, not one scenario. At every sample the
driver solves, from its current state ξ_k and with the surrounding vehicles predicted at
constant velocity under the uncertainty of :mod:`drivestyle.planning.tv_gaussian`,

    min_u  Σ_{i<N} w_y (y_i − y_ref)² + w_φ φ_i² + w_v (v_i − v_ref)² + w_a a_i² + w_δ δ_i²
              + (terminal state terms) + slack penalty
    s.t.   the vehicle's dynamics and limits (heading, speed, road, inputs),
           Pr(outside every nearby vehicle's safety ellipse) ≥ p   (chance constraint),
           the nominal ellipse (hard),

and applies the first input (the transcription is :mod:`drivestyle.planning.transcription`'s,
with the weights as parameters). The five terms are the horizon versions of the paper's
classic features — lane deviation (f_il/f_el), lateral speed (v·φ, the heading term),
speed deviation (f_v), longitudinal acceleration (f_a) and lateral acceleration (∝ δ); the
paper's reaction features (f_sd, f_ed, f_id and the trigger) are what the chance
constraint produces, with the risk p as an explicit parameter. The weights are defined
up to a common scale (the argmin is invariant), so w_a = 1 fixes the gauge.

*Reproduction* (:func:`reproduce`, :func:`closed_loop`) drives the style in closed loop
from a demonstration's first state, re-planning every T_s against the recorded surrounding
vehicles, as the driver did; each plan is the style model's planner's
(:mod:`drivestyle.irl.driver.style_planner`, the model's prediction of the driver's inputs).
Learning a style from demonstrations (teacher forcing) is
:mod:`drivestyle.irl.driver.driver_learning`; its fit per risk, which identification uses, is
:mod:`drivestyle.irl.driver.risk_profile`. The NLP itself is :mod:`drivestyle.planning`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.common.io import read_json
from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.style_planner import StylePlanner, planner_for
from drivestyle.planning.chance import risk_quantile
from drivestyle.planning.description import N_WEIGHTS, PrimalDual, SMPCConfig

__all__ = [
    "DRIVER_STYLE_KIND",
    "GAUGE",
    "INPUT_SCALE",
    "MIN_GAP_RANGE",
    "RESIDUAL_FLOOR",
    "RISK_RANGE",
    "TIME_GAP_RANGE",
    "WEIGHT_NAMES",
    "DriverStyle",
    "DriverStyleError",
    "Reproduction",
    "check_demo",
    "closed_loop",
    "expert_style",
    "initial_weights",
    "load_driver_style",
    "n_vehicles",
    "reproduce",
]

WEIGHT_NAMES = ("lane", "heading", "speed", "accel", "steer")
"""Names of the cost weights [w_y, w_φ, w_v, w_a, w_δ] (w_a = 1 is the gauge)."""
RISK_RANGE = (0.5, 0.99)
"""Risks p the model infers: from the nominal ellipse (0.5) to nearly certain safety."""
RESIDUAL_FLOOR = 0.1
"""s_floor: the residual RMS one driver of the class leaves on its own demonstrations
[σ_u units] (DESIGN §15). Identification's likelihood never assumes a smaller scale (a
demonstration the style fits exactly does not make the posterior a point mass), and
learning calls a fit poor far above it (a simulated driver is fitted exactly; a driver
library's own learning leaves 0.010)."""
INPUT_SCALE = (0.5, 0.005)
"""σ_u: the scale of the input residuals [m/s², rad] (≈ a tenth of the inputs' ranges in
the demonstrations: a and δ then weigh alike)."""
GAUGE = 3
"""Index of the weight fixed at 1 (w_a)."""
TIME_GAP_RANGE = (0.0, 4.0)
"""Time gaps T the style class admits [s] (highway drivers keep 0.5–2.5 s)."""
MIN_GAP_RANGE = (1.0, 60.0)
"""Standstill semi-major axes s_0 the class admits [m]."""


class DriverStyleError(ValueError):
    """A driver style, its file or its demonstrations are unusable."""


def initial_weights() -> np.ndarray:
    """Scale-normalised starting weights: each term ≈ 1 at a typical lane change.

    Typical magnitudes: lane error 5 m, heading 0.05 rad, speed error 5 m/s,
    acceleration 1 m/s², steering 0.02 rad; w = 1 / magnitude². Learning starts here, not
    at any expert's weights.

    Returns:
        [w_y, w_φ, w_v, w_a, w_δ], shape (5,).
    """
    return 1.0 / np.array([5.0, 0.05, 5.0, 1.0, 0.02]) ** 2


@dataclass(frozen=True)
class DriverStyle:
    """One driver: cost weights, risk level and (optionally) desired speed."""

    weights: tuple[float, ...]
    """[w_y, w_φ, w_v, w_a, w_δ] (:data:`WEIGHT_NAMES`), positive."""
    risk: float = 0.7
    """p of the chance constraint, in :data:`RISK_RANGE`."""
    v_ref: float | None = None
    """Desired speed [m/s]; None: the scenario's v_ref."""
    horizon: int = 10
    """N: the planning horizon [steps of T_s]."""
    time_gap: float = 0.0
    """T: the safety region grows with the EV's speed, l_a = s_0 + T·v (:meth:`region`)
    [s]; 0: a fixed ellipse (the SMPC expert's, DESIGN §18)."""
    min_gap: float | None = None
    """s_0: the region's semi-major axis at standstill [m]; None: the scenario's l_a."""

    def __post_init__(self) -> None:
        w = tuple(float(x) for x in self.weights)
        if len(w) != N_WEIGHTS or not all(math.isfinite(x) and x > 0 for x in w):
            raise DriverStyleError(
                f"weights must be {N_WEIGHTS} finite positive numbers, got {self.weights!r}"
            )
        object.__setattr__(self, "weights", w)
        lo, hi = RISK_RANGE
        if not (isinstance(self.risk, (int, float)) and lo <= self.risk <= hi):
            raise DriverStyleError(f"risk must lie in [{lo}, {hi}], got {self.risk!r}")
        if self.v_ref is not None and not (math.isfinite(self.v_ref) and 0 < self.v_ref < 70):
            raise DriverStyleError(f"v_ref must be in (0, 70) m/s, got {self.v_ref!r}")
        if not (isinstance(self.horizon, int) and 1 <= self.horizon <= 50):
            raise DriverStyleError(f"horizon must be an integer in [1, 50], got {self.horizon!r}")
        lo_t, hi_t = TIME_GAP_RANGE
        if not (isinstance(self.time_gap, (int, float)) and lo_t <= self.time_gap <= hi_t):
            raise DriverStyleError(
                f"time_gap must lie in [{lo_t}, {hi_t}] s, got {self.time_gap!r}"
            )
        lo_g, hi_g = MIN_GAP_RANGE
        if self.min_gap is not None and not (
            isinstance(self.min_gap, (int, float)) and lo_g <= self.min_gap <= hi_g
        ):
            raise DriverStyleError(f"min_gap must lie in [{lo_g}, {hi_g}] m, got {self.min_gap!r}")

    def region(self, speed: float, scenario: ScenarioConfig) -> float:
        """l_a = s_0 + T·max(v, 0): the safety region's semi-major axis at speed v [m].

        A headway-like region (DESIGN §18): drivers keep a time gap, not a fixed
        distance; with T = 0 and s_0 the scenario's l_a it is the SMPC expert's ellipse.
        """
        s0 = scenario.l_a if self.min_gap is None else self.min_gap
        return float(s0 + self.time_gap * max(float(speed), 0.0))

    @property
    def kappa(self) -> float:
        """Φ⁻¹(p)."""
        return risk_quantile(self.risk)

    def normalised(self) -> np.ndarray:
        """The weights divided by w_a (the gauge), shape (5,)."""
        w = np.asarray(self.weights)
        return w / w[GAUGE]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (the ``style`` entry of a driver-style file)."""
        return {
            "weights": list(self.weights),
            "weight_names": list(WEIGHT_NAMES),
            "risk": self.risk,
            "v_ref": self.v_ref,
            "horizon": self.horizon,
            "time_gap": self.time_gap,
            "min_gap": self.min_gap,
        }

    @classmethod
    def from_json(cls, raw: Any) -> DriverStyle:
        """Inverse of :meth:`to_json`.

        Raises:
            DriverStyleError: a key is missing or a value is invalid.
        """
        if not isinstance(raw, dict):
            kind = type(raw).__name__
            raise DriverStyleError(f"a driver style must be a JSON object, got {kind}")
        try:
            return cls(
                weights=tuple(float(x) for x in raw["weights"]),
                risk=float(raw["risk"]),
                v_ref=None if raw.get("v_ref") is None else float(raw["v_ref"]),
                horizon=int(raw.get("horizon", 10)),
                time_gap=float(raw.get("time_gap", 0.0)),
                min_gap=None if raw.get("min_gap") is None else float(raw["min_gap"]),
            )
        except KeyError as exc:
            raise DriverStyleError(f"driver style is missing key {exc}") from None
        except (TypeError, ValueError) as exc:
            raise DriverStyleError(f"invalid driver style: {exc}") from None


def expert_style(config: SMPCConfig) -> DriverStyle:
    """The SMPC expert as a member of the style class (its weights, risk and horizon).

    The parametric NLP with w = [Q_y, Q_φ, Q_v, R_a, R_δ] and the expert's risk is the
    expert's own NLP (Q_N = Q), so this style plans the expert's inputs (tested): the oracle
    of the prediction and planning studies.

    Raises:
        DriverStyleError: the expert's terminal weights differ from its stage weights, or
            its risk lies outside :data:`RISK_RANGE`.
    """
    if tuple(config.Q_N) != tuple(config.Q):
        raise DriverStyleError("the style class has Q_N = Q; this expert's terminal weights differ")
    q, r = config.Q, config.R
    return DriverStyle((q[1], q[2], q[3], r[0], r[1]), risk=config.risk, horizon=config.horizon)


def n_vehicles(demo: Demonstration) -> int:
    """M of a demonstration: the TV alone, or up to 4 vehicles in traffic (the expert's)."""
    return 1 if demo.other_vehicles.shape[1] == 0 else 4


def check_demo(demo: Demonstration) -> ScenarioConfig:
    """The demonstration's scenario, after checking its samples are T_s apart."""
    sc = demo.scenario
    dt = np.diff(demo.t)
    if not np.allclose(dt, sc.dt, rtol=1e-6, atol=1e-9):
        raise DriverStyleError(
            f"the demonstration's samples are {dt.min():.3g}–{dt.max():.3g} s apart, but its "
            f"scenario's T_s is {sc.dt} s: resample it to T_s"
        )
    return sc


# ---------------------------------------------------------------------------- closed loop
@dataclass(frozen=True)
class Reproduction:
    """A style driven in closed loop in a demonstration's scenario."""

    t: np.ndarray
    """Sample times, shape (n,) [s]."""
    states: np.ndarray
    """EV states [x, y, φ, v], shape (n, 4)."""
    inputs: np.ndarray
    """Applied inputs [a, δ], shape (n−1, 2)."""
    failures: int
    """Steps whose solve failed (a fallback input was applied)."""
    min_d: float
    """Least nominal ellipse margin d_k = (Δx/l_a)² + (Δy/l_b)² − 1 against any vehicle."""

    def errors(self, demo: Demonstration) -> tuple[float, float]:
        """(rmse_y, rmse_xy) against the demonstration [m]."""
        d = self.states[:, :2] - demo.ev[:, :2]
        return float(np.sqrt(np.mean(d[:, 1] ** 2))), float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def _inside_bounds(xi: np.ndarray, scenario: ScenarioConfig) -> bool:
    """Whether a state lies inside the planner's road (y) and heading bounds."""
    lo, hi = scenario.y_bounds
    return bool(lo <= xi[1] <= hi and abs(xi[2]) <= scenario.phi_max)


def closed_loop(
    style: DriverStyle,
    xi0: np.ndarray,
    vehicles: np.ndarray,
    scenario: ScenarioConfig,
    planner: StylePlanner,
    previous: PrimalDual | None = None,
    *,
    deviation: np.ndarray | None = None,
    y_refs: np.ndarray | None = None,
) -> tuple[np.ndarray, list[PrimalDual | None], np.ndarray, int]:
    """Drive ``style`` from ξ0 past the vehicles' given states, re-planning every T_s.

    A failed solve applies the previous plan's next input while one remains, else brakes
    at a_min/2 (as the expert does). With a ``deviation`` the applied input is
    clip(u_k + e_k) to the input bounds, its acceleration no lower than −v_k/T_s (braking
    stops the car, never reverses it), and the next plan starts from the state it leads to
    (the stochastic driver, :mod:`drivestyle.irl.driver.stochastic`) — unless that state
    lies outside the planner's road and heading bounds, from where no plan exists: then the
    driver applies the plan's input (it corrects rather than leave the road).

    Args:
        style: the driver style.
        xi0: the start state [x, y, φ, v].
        vehicles: the surrounding vehicles' states at each sample, shape (n, m, 4)
            (they do not react to the driven vehicle).
        scenario: target lane, reference speed and bounds.
        planner: the NLP.
        previous: the plan of the step before ξ0, the first solve's warm start (None:
            cold; the NLP is not convex, so a cold start mid-drive may find another plan
            than the driver's warm-started one).
        deviation: e_k added to each applied input [m/s², rad], shape (n−1, 2); None: none.
        y_refs: the lateral position each step's plan aims for [m], shape (n−1,); None:
            the scenario's target lane throughout.

    Returns:
        (states (n, 4), each step's plan or None, inputs (n−1, 2) as applied, failed solves).
    """
    n = vehicles.shape[0]
    xs = np.empty((n, 4))
    us = np.empty((n - 1, 2))
    xs[0] = xi0
    plans: list[PrimalDual | None] = []
    spare = np.empty((0, 2))
    failures = 0
    sc = scenario
    lo, hi = np.array([sc.a_min, -sc.delta_max]), np.array([sc.a_max, sc.delta_max])
    for k in range(n - 1):
        y_ref = None if y_refs is None else float(y_refs[k])
        res = planner.plan(xs[k], vehicles[k], style, sc, previous, y_ref=y_ref)
        if res.ok and res.point is not None:
            us[k] = res.u0
            previous = res.point
            spare = res.point.w[planner.layout.iu][1:]
        else:
            failures += 1
            previous = None
            if len(spare):
                us[k], spare = spare[0], spare[1:]
            else:
                us[k] = res.u0  # braking
        plans.append(previous)
        if deviation is not None:
            deviated = np.clip(us[k] + deviation[k], lo, hi)
            # a driver's foot on the brake stops the car; it never reverses it
            deviated[0] = max(deviated[0], min(-xs[k, 3] / sc.dt, 0.0))
            nxt = rk4_step(xs[k], deviated, sc.dt, sc.l_f, sc.l_r)
            if _inside_bounds(nxt, sc):
                us[k] = deviated
                xs[k + 1] = nxt
                continue
        xs[k + 1] = rk4_step(xs[k], us[k], sc.dt, sc.l_f, sc.l_r)
    return xs, plans, us, failures


def reproduce(
    style: DriverStyle, demo: Demonstration, planner: StylePlanner | None = None
) -> Reproduction:
    """Drive ``style`` from the demonstration's first state, re-planning every T_s.

    The surrounding vehicles move as recorded (they do not react to the reproduction).
    A failed solve applies the previous plan's next input while one remains, else brakes
    at a_min/2 (as the expert does).

    Args:
        style: the driver style.
        demo: the demonstration whose scenario and vehicles to drive in.
        planner: the NLP (default: the cached one of the demo's geometry).

    Returns:
        The closed-loop trajectory.
    """
    sc = check_demo(demo)
    planner = planner or planner_for(sc, style.horizon, n_vehicles(demo))
    vehicles = demo.vehicles
    xs, _, us, failures = closed_loop(style, demo.ev[0], vehicles, sc, planner)
    rel = xs[:, None, :2] - vehicles[:, :, :2]
    d = (rel[..., 0] / sc.l_a) ** 2 + (rel[..., 1] / sc.l_b) ** 2 - 1.0
    return Reproduction(demo.t.copy(), xs, us, failures, float(np.min(d)))


# ---------------------------------------------------------------------------- files
DRIVER_STYLE_KIND = "driver-style"
"""``kind`` of a driver-style file (``style.json`` written by ``learn_style.py``)."""


def load_driver_style(path: str | Path) -> DriverStyle:
    """Read the style of a ``style.json`` written by ``learn_style.py`` (default model).

    Args:
        path: the file or its folder.

    Returns:
        The driver style.

    Raises:
        FileNotFoundError: no such file.
        DriverStyleError: not a driver-style file (a paper-model style says how to make
            one), or its style entry is invalid.
    """
    path, raw = read_json(path, "style.json", DriverStyleError, "style file")
    if raw.get("kind") != DRIVER_STYLE_KIND:
        if "theta" in raw and "features" in raw:
            raise DriverStyleError(
                f"{path} is a paper-model style (whole-horizon weights θ over the ten "
                "features); learn the driver's style with `drivestyle learn-style DEMO… "
                "--out DIR` (default --model driver), or pass it where a paper style is "
                "expected (e.g. compare-baseline --spline-style)"
            )
        raise DriverStyleError(f"{path}: not a driver-style file (kind {raw.get('kind')!r})")
    try:
        return DriverStyle.from_json(raw["style"])
    except KeyError:
        raise DriverStyleError(f"{path}: missing key 'style'") from None
