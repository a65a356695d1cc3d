"""The ten trajectory features of the paper (§II-C, §III-A; docs/DESIGN.md §5).

Order (``FEATURES``): f_ax, f_ay, f_v, f_l, f_il, f_el, f_tiv, f_sd, f_ed, f_id. The
``base`` set is the first six, ``reactive`` (the paper's) all ten.

Every feature is a weighted sum, over fixed Gauss–Legendre nodes (or a single fixed
instant), of a scalar function of a spline value; spline values are linear in the
control points (:func:`drivestyle.irl.paper.spline.basis_matrix`). :func:`feature_basis` precomputes
those linear maps for one demonstration (its event times stay fixed while candidate
trajectories are optimised, DESIGN §5) and :func:`feature_values` evaluates the features on
numpy arrays or on CasADi symbols, so the inner problem gets exact derivatives.

Each feature's integrand is written once (:func:`integrand`, :func:`instant_feature`) and
used by both the whole-trajectory features (:func:`feature_values`) and the
segment-by-segment ones of the learned reward (:func:`segment_integrals`); the constants
and their scenario defaults come from :func:`feature_constants`, the event times from
:func:`event_times`, for demonstrations and growing trajectories alike.

Event times (from the demonstration):
- t_turn: the EV centre crosses the boundary of its initial lane (linear interpolation
  between samples); the horizon's end if it never does.
- t_trg: first sample with s_e < λ; the reactive features f_sd, f_ed, f_id are inactive
  (zero) if it never fires. The window [t_trg, t_trg + T_rct] is clipped to the horizon.
- f_el integrates over the last spline segment.

Two guards, used everywhere (not only in the optimiser): the TIV integrand is
v_lane / sqrt((x_TV − x_EV)² + d_0²) with d_0 = 1 m so a passing TV cannot make it
singular; and inside the optimiser only, |z| is smoothed to sqrt(z² + ε²) − ε.

The module is one concept at ≈ 640 lines: a feature is its integrand, the event times that
bound it and its quadrature, written once here for the whole-trajectory features and the
learned reward's segment integrals alike (the event times need the features' constants,
and the features need the event times, so they do not part).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.lanes import leaders
from drivestyle.envs.safety import elliptical_index, trigger_time
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.paper.spline import basis_matrix, state_control_points

__all__ = [
    "FEATURES",
    "FEATURE_SETS",
    "X_FEATURES",
    "Y_FEATURES",
    "EventTimes",
    "FeatureBasis",
    "FeatureConfig",
    "FeatureConstants",
    "event_times",
    "feature_basis",
    "feature_constants",
    "feature_values",
    "gauss_legendre_nodes",
    "instant_feature",
    "integrand",
    "segment_integrals",
    "tv_control_points",
]

FEATURES = ("ax", "ay", "v", "l", "il", "el", "tiv", "sd", "ed", "id")
FEATURE_SETS = {"base": FEATURES[:6], "reactive": FEATURES}
X_FEATURES = ("ax", "v", "tiv")
"""Features of the longitudinal spline only (the rest depend on y only)."""
Y_FEATURES = ("ay", "l", "il", "el", "sd", "ed", "id")
PAPER_OMEGA = (1.0, 1.0, 1.0, 1.0, 10.0, 10.0, 1.0, 10.0, 10.0, 10.0)


@dataclass(frozen=True)
class FeatureConfig:
    """Feature constants. ``None`` means: take it from the demonstration's scenario."""

    feature_set: str = "reactive"
    """'reactive' (10 features) or 'base' (the first 6)."""
    t_rct: float = 2.0
    """T_rct: duration of the reaction window [s] (DESIGN §1: ≈2 s)."""
    omega: tuple[float, ...] = PAPER_OMEGA
    """Ω: scaling of the ten features, in FEATURES order (§III-C)."""
    v_des: float | None = None
    """Desired longitudinal speed [m/s] (default: scenario v_ref)."""
    v_lane: float | None = None
    """Speed limit of the target lane in f_tiv [m/s] (default: scenario v_ref)."""
    l_des: float | None = None
    """Desired lane centre y [m] (default: the target lane's centre)."""
    l_initial: float | None = None
    """Initial lane centre y [m] (default: the EV's initial lane centre)."""
    trigger_lambda: float | None = None
    """λ of the trigger (default: the scenario's)."""
    n_gauss: int = 5
    """Gauss–Legendre nodes per segment (5: exact for the degree-6 acceleration terms)."""
    tiv_d0: float = 1.0
    """d_0 of the TIV guard [m]."""
    abs_eps: float = 1e-2
    """ε of the |·| smoothing inside the optimiser [m]."""
    ay_first_segment_weight: float = 1.0
    """Weight of the first segment in f_ay (0 excludes it; DESIGN §4)."""

    def __post_init__(self) -> None:
        if self.feature_set not in FEATURE_SETS:
            raise ValueError(
                f"feature_set must be one of {sorted(FEATURE_SETS)}, got {self.feature_set!r}"
            )
        if len(self.omega) != len(FEATURES) or not all(w > 0 for w in self.omega):
            raise ValueError(f"omega must be {len(FEATURES)} positive numbers")
        for name in ("t_rct", "tiv_d0", "abs_eps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not (isinstance(self.n_gauss, int) and 1 <= self.n_gauss <= 20):
            raise ValueError(f"n_gauss must be an integer in [1, 20], got {self.n_gauss}")
        if not 0 <= self.ay_first_segment_weight <= 1:
            raise ValueError("ay_first_segment_weight must lie in [0, 1]")

    @classmethod
    def from_dict(cls, raw: dict[str, Any]) -> FeatureConfig:
        """From its JSON form (``omega`` as a list), validated."""
        return cls(**{**raw, "omega": tuple(raw["omega"])})

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the active features."""
        return FEATURE_SETS[self.feature_set]

    @property
    def indices(self) -> np.ndarray:
        """Indices of the active features in FEATURES."""
        return np.array([FEATURES.index(n) for n in self.names])


@dataclass(frozen=True)
class EventTimes:
    """Times that delimit the features' integrals, from the demonstration [s]."""

    t_end: float
    """Horizon end t_S."""
    t_last: float
    """Start of the last segment t_{S−1} (f_el)."""
    t_turn: float
    """End of f_il."""
    t_trg: float | None
    """Trigger time (None: the reactive features are inactive)."""
    t_rct_end: float | None
    """min(t_trg + T_rct, t_end)."""
    critical: int = 0
    """The vehicle the reactive features refer to (index into the vehicles, TV = 0): the
    one with the least s_e at the trigger sample."""

    @property
    def reactive_active(self) -> bool:
        """Whether the trigger fired."""
        return self.t_trg is not None

    def reactive_window(self) -> tuple[float, float]:
        """(t_trg, t_rct_end) of the fired trigger [s].

        Raises:
            ValueError: the trigger did not fire (:attr:`reactive_active` is False).
        """
        if self.t_trg is None or self.t_rct_end is None:
            raise ValueError("no reactive window: the trigger did not fire (t_trg is None)")
        return self.t_trg, self.t_rct_end


@functools.lru_cache(maxsize=32)
def _leggauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)


def gauss_legendre_nodes(
    t_knots: np.ndarray, a: float, b: float, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights for ∫_a^b, split at the knots.

    Args:
        t_knots: knot times, shape (S+1,) [s].
        a: lower limit [s].
        b: upper limit [s] (≥ a).
        n: nodes per (sub-)segment.

    Returns:
        Node times and weights, each shape (m,); empty if b ≤ a.
    """
    if b <= a:
        return np.zeros(0), np.zeros(0)
    x, w = _leggauss(n)
    cuts = np.concatenate([[a], t_knots[(t_knots > a) & (t_knots < b)], [b]])
    nodes, weights = [], []
    for lo, hi in itertools.pairwise(cuts):
        nodes.append(0.5 * (hi - lo) * x + 0.5 * (hi + lo))
        weights.append(0.5 * (hi - lo) * w)
    return np.concatenate(nodes), np.concatenate(weights)


def tv_control_points(t: np.ndarray, tv: np.ndarray) -> np.ndarray:
    """Control points of the TV's sampled trajectory, shape (n, 6).

    The kinematic rule without steering: velocities v·[cos φ, sin φ], accelerations by
    central differences.

    Args:
        t: sample times, shape (n,) [s].
        tv: TV states [x, y, φ, v], shape (n, 4).
    """
    return state_control_points(t, tv, np.zeros(len(t)), "kinematic", 0.5)


@dataclass(frozen=True)
class FeatureConstants:
    """The features' constants for one scenario (``FeatureConfig`` value or scenario default)."""

    v_des: float
    """Desired speed of f_v [m/s]."""
    v_lane: float
    """Lane speed of f_tiv [m/s]."""
    l_des: float
    """Desired lane centre of f_l and f_el [m]."""
    l_initial: float
    """Initial lane centre of f_il [m]."""
    trigger_lambda: float
    """λ of the trigger."""
    tiv_d0: float
    """d_0 of the TIV guard [m]."""


def feature_constants(config: FeatureConfig, scenario: ScenarioConfig) -> FeatureConstants:
    """Resolve the feature constants: the config's value, else the scenario's (DESIGN §5).

    Args:
        config: feature configuration (``None`` fields take the scenario's value).
        scenario: the demonstration's scenario.

    Returns:
        The constants.
    """

    def pick(value: float | None, default: float) -> float:
        return float(default if value is None else value)

    sc = scenario
    return FeatureConstants(
        v_des=pick(config.v_des, sc.v_ref),
        v_lane=pick(config.v_lane, sc.v_ref),
        l_des=pick(config.l_des, sc.y_ref),
        l_initial=pick(config.l_initial, sc.lane_centres[sc.ev_lane]),
        trigger_lambda=pick(config.trigger_lambda, sc.trigger_lambda),
        tiv_d0=config.tiv_d0,
    )


def integrand(name: str, z, k: FeatureConstants, absf, sqrt, ref=None):
    """Integrand of an integral feature at spline values ``z`` (paper eq. 6–8, 14, 17).

    Works on numpy arrays and CasADi symbols alike (``absf`` and ``sqrt`` are the matching
    operations; ``absf`` may be the smoothed |·| of the optimiser).

    Args:
        name: 'ax', 'ay' (z: acceleration), 'v' (z: longitudinal velocity), 'l', 'el',
            'il', 'id' (z: lateral position) or 'tiv' (z: longitudinal position).
        z: spline values at the quadrature nodes.
        k: feature constants.
        absf: |·| (or its smoothed form).
        sqrt: square root.
        ref: x_TV at the nodes for 'tiv'; y_EV(t_trg) for 'id'.

    Returns:
        The integrand at the nodes (unscaled).
    """
    if name in ("ax", "ay"):
        return z * z
    if name == "v":
        return (k.v_des - z) ** 2
    if name in ("l", "el"):
        return absf(k.l_des - z)
    if name == "il":
        return absf(k.l_initial - z)
    if name == "tiv":
        dx = ref - z
        return k.v_lane / sqrt(dx * dx + k.tiv_d0**2)
    if name == "id":
        return absf(z - ref)
    raise ValueError(f"{name!r} is not an integral feature")


def instant_feature(y_ev, y_tv, exp, absf):
    """f_sd (at t_trg) or f_ed (at t_trg + T_rct): exp(−|y_EV − y_TV|) (paper eq. 15, 16)."""
    return exp(-absf(y_ev - y_tv))


def _crossing_time(t: np.ndarray, y: np.ndarray, boundary: float, upward: bool) -> float | None:
    s = (y - boundary) if upward else (boundary - y)
    idx = np.flatnonzero(s > 0)
    if idx.size == 0:
        return None
    i = int(idx[0])
    if i == 0:
        return float(t[0])
    frac = -s[i - 1] / (s[i] - s[i - 1])
    return float(t[i - 1] + frac * (t[i] - t[i - 1]))


def _vehicles(tv: np.ndarray, others: np.ndarray | None) -> np.ndarray:
    """TV and further vehicles as one array (n, 1 + m, 4)."""
    tv = np.asarray(tv, float)[:, None, :]
    if others is None or np.size(others) == 0:
        return tv
    return np.concatenate([tv, np.asarray(others, float)], axis=1)


def _index_field(ev: np.ndarray, vehicles: np.ndarray, sc: ScenarioConfig) -> np.ndarray:
    """s_e of the EV against every vehicle at every sample, shape (n, 1 + m)."""
    return elliptical_index(
        ev[:, None, 0] - vehicles[:, :, 0], ev[:, None, 1] - vehicles[:, :, 1], sc.l_a, sc.l_b
    )


def event_times(
    t: np.ndarray,
    ev: np.ndarray,
    tv: np.ndarray,
    scenario: ScenarioConfig,
    config: FeatureConfig,
    others: np.ndarray | None = None,
) -> EventTimes:
    """Event times of a sampled trajectory (module docstring; DESIGN §5).

    They depend on past samples only, so the learned reward gets the same times online
    from the growing trajectory as the demonstration's features offline. In traffic the
    trigger fires on the most critical vehicle: t_trg is the first sample at which the
    least s_e over all vehicles drops below λ, and that vehicle is ``critical``.

    Args:
        t: sample times, shape (n,) [s].
        ev: EV states [x, y, φ, v], shape (n, 4).
        tv: TV states, shape (n, 4).
        scenario: lanes (t_turn) and ellipse (t_trg).
        config: feature configuration (T_rct, λ override).
        others: further vehicles' states, shape (n, m, 4) (traffic; None: the TV only).

    Returns:
        The event times.
    """
    sc = scenario
    lam = feature_constants(config, sc).trigger_lambda
    upward = sc.target_lane > sc.ev_lane
    boundary = sc.lane_width * (sc.ev_lane + 1) if upward else sc.lane_width * sc.ev_lane
    t_turn = _crossing_time(t, ev[:, 1], boundary, upward)
    s_e = _index_field(ev, _vehicles(tv, others), sc)
    s_min = s_e.min(axis=1)
    t_trg = trigger_time(t, s_min, lam)
    below = np.flatnonzero(s_min < lam)
    critical = int(np.argmin(s_e[below[0]])) if below.size else 0
    t_end = float(t[-1])
    return EventTimes(
        t_end=t_end,
        t_last=float(t[-2]),
        t_turn=t_end if t_turn is None else t_turn,
        t_trg=t_trg,
        t_rct_end=None if t_trg is None else min(t_trg + config.t_rct, t_end),
        critical=critical,
    )


def tiv_reference(
    ev: np.ndarray, tv: np.ndarray, scenario: ScenarioConfig, others: np.ndarray | None = None
) -> np.ndarray:
    """Which vehicle f_tiv refers to on each segment (index into the vehicles, TV = 0).

    On segment j (from sample j): the nearest vehicle ahead whose centre is in the lane the
    EV's centre occupies at sample j; if there is none, the vehicle with the least s_e at
    sample j. With the TV alone, always the TV (the single-TV features unchanged).

    Args:
        ev: EV states, shape (n, 4).
        tv: TV states, shape (n, 4).
        scenario: lane geometry and ellipse.
        others: further vehicles, shape (n, m, 4).

    Returns:
        Vehicle index per segment, shape (n − 1,).
    """
    vehicles = _vehicles(tv, others)
    n, m = vehicles.shape[:2]
    if m == 1:
        return np.zeros(n - 1, dtype=int)
    sc = scenario
    s_e = _index_field(ev, vehicles, sc)
    lead = leaders(ev[:-1, 0], ev[:-1, 1], vehicles[:-1, :, 0], vehicles[:-1, :, 1], sc.lane_width)
    ref = np.where(lead >= 0, lead, np.argmin(s_e[:-1], axis=1)).astype(int)
    return ref


@dataclass(frozen=True)
class FeatureBasis:
    """Precomputed linear maps and constants of the ten features for one demonstration.

    ``B_*`` matrices map one axis's full control-point vector (3(S+1),) to spline values
    at nodes; ``w_*`` are the matching quadrature weights.
    """

    config: FeatureConfig
    events: EventTimes
    t_knots: np.ndarray
    constants: FeatureConstants
    omega: np.ndarray
    B_acc: np.ndarray
    w_acc: np.ndarray
    w_ay: np.ndarray
    B_vel: np.ndarray
    B_pos: np.ndarray
    w_all: np.ndarray
    B_il: np.ndarray
    w_il: np.ndarray
    B_el: np.ndarray
    w_el: np.ndarray
    x_tv: np.ndarray
    """x of the vehicle f_tiv refers to at each node (:func:`tiv_reference`) [m]."""
    B_id: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    w_id: np.ndarray = field(default_factory=lambda: np.zeros(0))
    B_trg: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    B_rct: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    y_tv_trg: float = 0.0
    y_tv_rct: float = 0.0


def feature_basis(demo: Demonstration, config: FeatureConfig | None = None) -> FeatureBasis:
    """Precompute the features' linear maps on the demonstration's knots.

    Args:
        demo: the demonstration; its sample times are the knots and ``meta["scenario"]``
            supplies lane geometry, v_ref, λ and the ellipse unless ``config`` overrides.
        config: feature configuration.

    Returns:
        The basis.
    """
    config = config or FeatureConfig()
    sc = demo.scenario
    t = demo.t
    events = event_times(t, demo.ev, demo.tv, sc, config, demo.others)
    n = config.n_gauss
    t_all, w_all = gauss_legendre_nodes(t, t[0], t[-1], n)
    w_ay = w_all.copy()
    w_ay[t_all < t[1]] *= config.ay_first_segment_weight
    t_il, w_il = gauss_legendre_nodes(t, t[0], events.t_turn, n)
    t_el, w_el = gauss_legendre_nodes(t, events.t_last, events.t_end, n)
    vehicles = demo.vehicles
    vehicle_C = [tv_control_points(t, vehicles[:, i]) for i in range(vehicles.shape[1])]
    B_all = basis_matrix(t, t_all)
    ref = tiv_reference(demo.ev, demo.tv, sc, demo.others)
    segment = np.clip(np.searchsorted(t, t_all, side="right") - 1, 0, len(t) - 2)
    x_all = np.array([B_all @ C[:, :3].ravel() for C in vehicle_C])
    x_tv = x_all[ref[segment], np.arange(t_all.size)]
    extra: dict[str, Any] = {}  # FeatureBasis's reactive fields (arrays and floats)
    if events.reactive_active:
        t_trg, t_rct_end = events.reactive_window()
        t_id, w_id = gauss_legendre_nodes(t, t_trg, t_rct_end, n)
        tv_C = vehicle_C[events.critical]
        y_tv = basis_matrix(t, [t_trg, t_rct_end]) @ tv_C[:, 3:].ravel()
        extra = {
            "B_id": basis_matrix(t, t_id),
            "w_id": w_id,
            "B_trg": basis_matrix(t, [t_trg]),
            "B_rct": basis_matrix(t, [t_rct_end]),
            "y_tv_trg": float(y_tv[0]),
            "y_tv_rct": float(y_tv[1]),
        }
    return FeatureBasis(
        config=config,
        events=events,
        t_knots=t.copy(),
        constants=feature_constants(config, sc),
        omega=np.asarray(config.omega, float),
        B_acc=basis_matrix(t, t_all, 2),
        w_acc=w_all,
        w_ay=w_ay,
        B_vel=basis_matrix(t, t_all, 1),
        B_pos=basis_matrix(t, t_all),
        w_all=w_all,
        B_il=basis_matrix(t, t_il),
        w_il=w_il,
        B_el=basis_matrix(t, t_el),
        w_el=w_el,
        x_tv=x_tv,
        **extra,
    )


def _sparse_dm(B: np.ndarray) -> ca.DM:
    """B as a sparse CasADi matrix.

    Each spline value depends on 6 control points only, so the expression graph (and the
    Hessian) stays banded.
    """
    r, c = np.nonzero(B)
    return ca.DM.triplet(r.tolist(), c.tolist(), ca.DM(B[r, c]), B.shape[0], B.shape[1])


def _ops(symbolic: bool) -> tuple:
    """(lin, wsum, const, sqrt, exp, fabs, stack) for CasADi or numpy operands."""
    if symbolic:
        return (
            (lambda B, v: ca.mtimes(_sparse_dm(B), v)),
            (lambda w, z: ca.dot(ca.DM(w), z)),
            ca.DM,
            ca.sqrt,
            ca.exp,
            ca.fabs,
            ca.vertcat,
        )
    return (
        (lambda B, v: B @ v),
        (lambda w, z: float(np.dot(w, z))),
        np.asarray,
        np.sqrt,
        np.exp,
        np.abs,
        (lambda *a: np.array(a, dtype=float)),
    )


def feature_values(cx, cy, basis: FeatureBasis, smooth: bool = False, names=FEATURES):
    """Scaled features Ω f(r) of the trajectory with control points ``cx``, ``cy``.

    Args:
        cx: x control points [r, v, a] of every knot, flattened, shape (3(S+1),)
            (numpy or CasADi).
        cy: y control points, same layout.
        basis: from :func:`feature_basis`.
        smooth: smooth |·| (inside the optimiser only).
        names: which features to return, in this order.

    Returns:
        The scaled features, shape (len(names),), same array type as ``cx``.
    """
    symbolic = isinstance(cx, (ca.SX, ca.MX)) or isinstance(cy, (ca.SX, ca.MX))
    lin, wsum, const, sqrt, exp, fabs, stack = _ops(symbolic)
    eps = basis.config.abs_eps
    k = basis.constants

    def absf(z):
        return sqrt(z * z + eps * eps) - eps if smooth else fabs(z)

    def integral(name: str, w: np.ndarray, B: np.ndarray, c, ref=None):
        return wsum(w, integrand(name, lin(B, c), k, absf, sqrt, ref)) if w.size else 0.0

    active = basis.events.reactive_active
    terms = {
        "ax": lambda: integral("ax", basis.w_acc, basis.B_acc, cx),
        "ay": lambda: integral("ay", basis.w_ay, basis.B_acc, cy),
        "v": lambda: integral("v", basis.w_all, basis.B_vel, cx),
        "l": lambda: integral("l", basis.w_all, basis.B_pos, cy),
        "il": lambda: integral("il", basis.w_il, basis.B_il, cy),
        "el": lambda: integral("el", basis.w_el, basis.B_el, cy),
        "tiv": lambda: integral("tiv", basis.w_all, basis.B_pos, cx, const(basis.x_tv)),
        "sd": lambda: instant_feature(lin(basis.B_trg, cy)[0], basis.y_tv_trg, exp, absf),
        "ed": lambda: instant_feature(lin(basis.B_rct, cy)[0], basis.y_tv_rct, exp, absf),
        "id": lambda: integral("id", basis.w_id, basis.B_id, cy, lin(basis.B_trg, cy)[0]),
    }
    reactive = ("sd", "ed", "id")
    return stack(
        *[
            basis.omega[FEATURES.index(n)] * terms[n]() if active or n not in reactive else 0.0
            for n in names
        ]
    )


@functools.lru_cache(maxsize=4096)
def _segment_basis(T: float, tau: tuple[float, ...], d: int) -> np.ndarray:
    """Basis rows of one segment of duration T at local times τ (cached: segments repeat)."""
    return basis_matrix(np.array([0.0, T]), np.array(tau), d)


SEGMENT_FEATURES = ("ax", "ay", "v", "l", "il", "tiv", "id")
"""Features that are integrals over the whole horizon or a window of it, so they add up
segment by segment (f_el, f_sd and f_ed are not: see :mod:`drivestyle.irl.paper.style_reward`)."""


def segment_integrals(
    cx: np.ndarray,
    cy: np.ndarray,
    tv_cx: np.ndarray,
    t0: float,
    t1: float,
    config: FeatureConfig,
    constants: FeatureConstants,
    events: EventTimes,
    y_trg: float | None,
    first: bool,
) -> dict[str, float]:
    """Unscaled contributions of the integral features over one spline segment [t0, t1].

    Summed over all segments they give :func:`feature_values`'s integral features exactly:
    the same integrands and Gauss–Legendre nodes, split at the event times. Used to
    compute features incrementally along a growing trajectory
    (:mod:`drivestyle.irl.paper.style_reward`).

    Args:
        cx: EV x control points [r, v, a] at t0 and t1, shape (6,).
        cy: EV y control points at t0 and t1, shape (6,).
        tv_cx: TV x control points at t0 and t1, shape (6,).
        t0: segment start [s].
        t1: segment end [s].
        config: feature configuration (quadrature, f_ay weighting).
        constants: feature constants.
        events: event times of the trajectory (t_turn; t_trg and t_rct_end for f_id).
        y_trg: y_EV(t_trg) (None: reactive features inactive).
        first: this is the first segment (f_ay weighting).

    Returns:
        Feature name (:data:`SEGMENT_FEATURES`) → contribution (unscaled).
    """
    knots = np.array([t0, t1])
    T = t1 - t0

    def integral(name: str, c: np.ndarray, d: int, a: float, b: float, ref=None) -> float:
        nodes, w = gauss_legendre_nodes(knots, max(a, t0), min(b, t1), config.n_gauss)
        if not nodes.size:
            return 0.0
        B = _segment_basis(T, tuple(np.round(nodes - t0, 12)), d)
        r = None if ref is None else (B @ ref if np.ndim(ref) else ref)
        return float(w @ integrand(name, B @ c, constants, np.abs, np.sqrt, r))

    out = {
        "ax": integral("ax", cx, 2, t0, t1),
        "ay": integral("ay", cy, 2, t0, t1) * (config.ay_first_segment_weight if first else 1),
        "v": integral("v", cx, 1, t0, t1),
        "l": integral("l", cy, 0, t0, t1),
        "il": integral("il", cy, 0, t0, events.t_turn),
        "tiv": integral("tiv", cx, 0, t0, t1, tv_cx),
        "id": 0.0,
    }
    if events.reactive_active and y_trg is not None:
        out["id"] = integral("id", cy, 0, *events.reactive_window(), y_trg)
    return out
