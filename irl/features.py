"""The ten trajectory features of the paper (§II-C, §III-A; SPEC §5).

Order (``FEATURES``): f_ax, f_ay, f_v, f_l, f_il, f_el, f_tiv, f_sd, f_ed, f_id. The
``base`` set is the first six, ``reactive`` (the paper's) all ten.

Every feature is a weighted sum, over fixed Gauss–Legendre nodes (or a single fixed
instant), of a scalar function of a spline value; spline values are linear in the
control points (:func:`irl.spline.basis_matrix`). :func:`feature_basis` precomputes those
linear maps for one demonstration (its event times stay fixed while candidate
trajectories are optimised, SPEC §5) and :func:`feature_values` evaluates the features on
numpy arrays or on CasADi symbols, so the inner problem gets exact derivatives.

Event times (from the demonstration):
- t_turn: the EV centre crosses the boundary of its initial lane (linear interpolation
  between samples); the horizon's end if it never does.
- t_trg: first sample with s_e < λ; the reactive features f_sd, f_ed, f_id are inactive
  (zero) if it never fires. The window [t_trg, t_trg + T_rct] is clipped to the horizon.
- f_el integrates over the last spline segment.

Two guards, used everywhere (not only in the optimiser): the TIV integrand is
v_lane / sqrt((x_TV − x_EV)² + d_0²) with d_0 = 1 m so a passing TV cannot make it
singular; and inside the optimiser only, |z| is smoothed to sqrt(z² + ε²) − ε.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from envs.demonstration import Demonstration
from envs.safety import elliptical_index, trigger_time
from irl.spline import basis_matrix, state_control_points

__all__ = [
    "FEATURES",
    "FEATURE_SETS",
    "X_FEATURES",
    "Y_FEATURES",
    "EventTimes",
    "FeatureBasis",
    "FeatureConfig",
    "event_times",
    "feature_basis",
    "feature_values",
    "gauss_legendre_nodes",
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
    """T_rct: duration of the reaction window [s] (SPEC §1: ≈2 s)."""
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
    """Weight of the first segment in f_ay (0 excludes it; SPEC §4)."""

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

    @property
    def reactive_active(self) -> bool:
        """Whether the trigger fired."""
        return self.t_trg is not None


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


def tv_control_points(demo: Demonstration) -> np.ndarray:
    """Control points of the TV's trajectory, shape (n, 6).

    Velocities v·[cos φ, sin φ]; accelerations by central differences.
    """
    # the kinematic rule without steering: velocity along φ, differenced accelerations
    return state_control_points(demo.t, demo.tv, np.zeros(demo.n), "kinematic", 0.5)


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


def event_times(
    demo: Demonstration,
    config: FeatureConfig,
    lam: float,
    lane_width: float,
    ev_lane: int,
    target_lane: int,
    l_a: float,
    l_b: float,
) -> EventTimes:
    """Event times of a demonstration (module docstring).

    Args:
        demo: the demonstration.
        config: feature configuration (T_rct).
        lam: trigger threshold λ.
        lane_width: lane width [m].
        ev_lane: the EV's initial lane index.
        target_lane: the EV's target lane index.
        l_a: semi-major axis of the ellipse [m].
        l_b: semi-minor axis [m].

    Returns:
        The event times.
    """
    t = demo.t
    upward = target_lane > ev_lane
    boundary = lane_width * (ev_lane + 1) if upward else lane_width * ev_lane
    t_turn = _crossing_time(t, demo.ev[:, 1], boundary, upward)
    s_e = elliptical_index(demo.ev[:, 0] - demo.tv[:, 0], demo.ev[:, 1] - demo.tv[:, 1], l_a, l_b)
    t_trg = trigger_time(t, s_e, lam)
    t_end = float(t[-1])
    return EventTimes(
        t_end=t_end,
        t_last=float(t[-2]),
        t_turn=t_end if t_turn is None else t_turn,
        t_trg=t_trg,
        t_rct_end=None if t_trg is None else min(t_trg + config.t_rct, t_end),
    )


@dataclass(frozen=True)
class FeatureBasis:
    """Precomputed linear maps and constants of the ten features for one demonstration.

    ``B_*`` matrices map one axis's full control-point vector (3(S+1),) to spline values
    at nodes; ``w_*`` are the matching quadrature weights.
    """

    config: FeatureConfig
    events: EventTimes
    t_knots: np.ndarray
    v_des: float
    v_lane: float
    l_des: float
    l_initial: float
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
    lam = config.trigger_lambda if config.trigger_lambda is not None else sc.trigger_lambda
    ev = event_times(demo, config, lam, sc.lane_width, sc.ev_lane, sc.target_lane, sc.l_a, sc.l_b)
    n = config.n_gauss
    t_all, w_all = gauss_legendre_nodes(t, t[0], t[-1], n)
    w_ay = w_all.copy()
    w_ay[t_all < t[1]] *= config.ay_first_segment_weight
    t_il, w_il = gauss_legendre_nodes(t, t[0], ev.t_turn, n)
    t_el, w_el = gauss_legendre_nodes(t, ev.t_last, ev.t_end, n)
    tv_C = tv_control_points(demo)
    x_tv = basis_matrix(t, t_all) @ tv_C[:, :3].ravel()
    extra = {}
    if ev.reactive_active:
        t_id, w_id = gauss_legendre_nodes(t, ev.t_trg, ev.t_rct_end, n)
        y_tv = basis_matrix(t, [ev.t_trg, ev.t_rct_end]) @ tv_C[:, 3:].ravel()
        extra = {
            "B_id": basis_matrix(t, t_id),
            "w_id": w_id,
            "B_trg": basis_matrix(t, [ev.t_trg]),
            "B_rct": basis_matrix(t, [ev.t_rct_end]),
            "y_tv_trg": float(y_tv[0]),
            "y_tv_rct": float(y_tv[1]),
        }
    return FeatureBasis(
        config=config,
        events=ev,
        t_knots=t.copy(),
        v_des=config.v_des if config.v_des is not None else sc.v_ref,
        v_lane=config.v_lane if config.v_lane is not None else sc.v_ref,
        l_des=config.l_des if config.l_des is not None else sc.y_ref,
        l_initial=(
            config.l_initial if config.l_initial is not None else float(sc.lane_centres[sc.ev_lane])
        ),
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

    def absf(z):
        return sqrt(z * z + eps * eps) - eps if smooth else fabs(z)

    out = {}
    need = set(names)
    if "ax" in need:
        out["ax"] = wsum(basis.w_acc, lin(basis.B_acc, cx) ** 2)
    if "ay" in need:
        out["ay"] = wsum(basis.w_ay, lin(basis.B_acc, cy) ** 2)
    if "v" in need:
        out["v"] = wsum(basis.w_all, (basis.v_des - lin(basis.B_vel, cx)) ** 2)
    if "l" in need:
        out["l"] = wsum(basis.w_all, absf(basis.l_des - lin(basis.B_pos, cy)))
    if "il" in need:
        out["il"] = (
            wsum(basis.w_il, absf(basis.l_initial - lin(basis.B_il, cy)))
            if basis.w_il.size
            else 0.0
        )
    if "el" in need:
        out["el"] = wsum(basis.w_el, absf(basis.l_des - lin(basis.B_el, cy)))
    if "tiv" in need:
        dx = const(basis.x_tv) - lin(basis.B_pos, cx)
        out["tiv"] = wsum(basis.w_all, basis.v_lane / sqrt(dx * dx + basis.config.tiv_d0**2))
    active = basis.events.reactive_active
    if "sd" in need:
        out["sd"] = exp(-absf(lin(basis.B_trg, cy)[0] - basis.y_tv_trg)) if active else 0.0
    if "ed" in need:
        out["ed"] = exp(-absf(lin(basis.B_rct, cy)[0] - basis.y_tv_rct)) if active else 0.0
    if "id" in need:
        if active and basis.w_id.size:
            y_trg = lin(basis.B_trg, cy)[0]
            out["id"] = wsum(basis.w_id, absf(lin(basis.B_id, cy) - y_trg))
        else:
            out["id"] = 0.0
    scale = {n: basis.omega[FEATURES.index(n)] for n in names}
    return stack(*[scale[n] * out[n] for n in names])


@functools.lru_cache(maxsize=4096)
def _segment_basis(T: float, tau: tuple[float, ...], d: int) -> np.ndarray:
    """Basis rows of one segment of duration T at local times τ (cached: segments repeat)."""
    return basis_matrix(np.array([0.0, T]), np.array(tau), d)


"""Features that are integrals over time and so add up segment by segment."""


def segment_integrals(
    cx: np.ndarray,
    cy: np.ndarray,
    tv_cx: np.ndarray,
    t0: float,
    t1: float,
    basis_like: FeatureBasis | dict,
    t_turn: float,
    window: tuple[float, float, float] | None,
    first: bool,
) -> dict[str, float]:
    """Unscaled contributions of the integral features over one spline segment [t0, t1].

    Summed over all segments (plus f_el, f_sd, f_ed, see :func:`instant_features`) they
    give :func:`feature_values` exactly: the same Gauss–Legendre nodes, split at the
    window ends. Used to compute features incrementally along a growing trajectory.

    Args:
        cx: EV x control points [r, v, a] at t0 and t1, shape (6,).
        cy: EV y control points at t0 and t1, shape (6,).
        tv_cx: TV x control points at t0 and t1, shape (6,).
        t0: segment start [s].
        t1: segment end [s].
        basis_like: constants (v_des, v_lane, l_des, l_initial, config) — a
            :class:`FeatureBasis` or a dict with those keys.
        t_turn: end of f_il [s].
        window: (t_trg, t_rct_end, y_EV(t_trg)) of f_id, or None if inactive.
        first: this is the first segment (f_ay weighting).

    Returns:
        Feature name → contribution (unscaled).
    """
    get = (
        (lambda k: getattr(basis_like, k))
        if not isinstance(basis_like, dict)
        else basis_like.__getitem__
    )
    config: FeatureConfig = get("config")
    knots = np.array([t0, t1])
    n = config.n_gauss

    def part(a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
        return gauss_legendre_nodes(knots, max(a, t0), min(b, t1), n)

    T = t1 - t0

    def seg_basis(nodes: np.ndarray, d: int = 0) -> np.ndarray:
        return _segment_basis(T, tuple(np.round(nodes - t0, 12)), d)

    tn, w = part(t0, t1)
    B0, B1, B2 = (seg_basis(tn, d) for d in (0, 1, 2))
    out = {
        "ax": float(w @ (B2 @ cx) ** 2),
        "ay": float(w @ (B2 @ cy) ** 2) * (config.ay_first_segment_weight if first else 1.0),
        "v": float(w @ (get("v_des") - B1 @ cx) ** 2),
        "l": float(w @ np.abs(get("l_des") - B0 @ cy)),
        "tiv": float(w @ (get("v_lane") / np.sqrt((B0 @ tv_cx - B0 @ cx) ** 2 + config.tiv_d0**2))),
    }
    ti, wi = part(t0, t_turn)
    out["il"] = float(wi @ np.abs(get("l_initial") - seg_basis(ti) @ cy)) if ti.size else 0.0
    out["id"] = 0.0
    if window is not None:
        td, wd = part(window[0], window[1])
        if td.size:
            out["id"] = float(wd @ np.abs(seg_basis(td) @ cy - window[2]))
    return out
