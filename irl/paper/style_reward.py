"""The paper model's learned style as the environment's reward.

The per-step reward is the negative learned cost of the step,

    r_t = −θᵀ Δf_t,    Δf_t = Ω f(r_{0:t+1}) − Ω f(r_{0:t}),

where f(r_{0:k}) are the style's features of the EV's own trajectory up to sample k,
represented exactly as a demonstration would be (quintic spline over the samples, the
style's control-point rule, same quadrature). The increments telescope, so an episode's
summed reward is −θᵀ f of the whole episode: replaying a demonstration's inputs returns
−θᵀ f(r_D) up to round-off (tested to 1e-8 relative).

Event times are computed online from the env's trajectory with the demonstration's own
definitions — t_turn where the EV crosses its initial lane's boundary, t_trg at the first
sample with s_e < λ, the reaction window [t_trg, t_trg + T_rct] — which depend on past
samples only, so "online" and "offline" agree. Before t_turn is reached the prefix's f_il
runs to its end, exactly as for a demonstration that never turns.

Collisions and leaving the road end the episode early; since the remaining cost would
then be saved, a crash costs ``crash_penalty`` (default: ten times the style's cost of its
own demonstration, θᵀ f(r_D) — large enough that rushing into the target lane and being
hit there never pays; with 2× an RL policy learned exactly that).

The driver style's reward is :mod:`drivestyle.irl.driver.driver_cost`.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np
from gymnasium.utils import RecordConstructorArgs

from drivestyle.envs.lanes import leaders
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.paper.features import (
    FEATURES,
    SEGMENT_FEATURES,
    EventTimes,
    feature_constants,
    gauss_legendre_nodes,
    segment_integrals,
)
from drivestyle.irl.paper.spline import basis_matrix
from drivestyle.irl.paper.style import Style, StyleError, load_style

__all__ = ["CRASH_FACTOR", "LearnedStyleReward", "StyleReward"]

CRASH_FACTOR = 10.0
"""Default crash penalty as a multiple of the style's cost of its demonstration."""


class StyleReward:
    """Incremental learned cost of a growing trajectory (module docstring).

    It implements the env's reward-model protocol
    (:class:`drivestyle.envs.reward_model.RewardModel`):
    ``reset(scenario, ev, tv)``, ``step(u, ev, tv, dt) -> (reward, Δf)`` and
    ``crash_penalty``.

    Args:
        style: a loaded :class:`drivestyle.irl.paper.style.Style` or the path of a ``style.json``.
        crash_penalty: cost of a collision or leaving the road; None: CRASH_FACTOR·θᵀ f(r_D).

    Raises:
        StyleError: θ overflows the style's cost, or ``feature_values_demo`` is malformed.
        ValueError: ``crash_penalty`` is negative or not finite.
    """

    # Every step is O(1) (the env's hot path; DESIGN §5's features, computed incrementally):
    # a control point settles once its neighbours' velocities do, i.e. two samples late
    # (central differences of velocities that themselves use the sample's input, known one
    # step late), so segment k − 3 is final when sample k arrives and only the segments
    # k − 2 and k − 1 are provisional. Event times depend on past samples only and never move
    # a final segment's integration limits. Full segments are integrated with quadrature
    # weights and spline basis rows precomputed per segment duration; the few segments that
    # an event time cuts go through features.segment_integrals. Equal to the whole-trajectory
    # recomputation to round-off (tests/irl/paper/test_style_reward.py keeps it as the reference).
    SETTLE = 2
    """Samples after which a control point no longer changes."""

    def __init__(self, style: Style | str | Path, crash_penalty: float | None = None) -> None:
        self.style: Style = style if isinstance(style, Style) else load_style(Path(style))
        self.config = self.style.features
        self.names = self.style.names
        self.theta = np.asarray(self.style.theta, float)
        self.idx = np.array([FEATURES.index(n) for n in self.names])
        self.omega = np.asarray(self.config.omega, float)
        self.control_point_rule = self.style.control_point_rule
        source = "" if isinstance(style, Style) else f"{style}: "
        ref_cost = self._reference_cost(source)
        self.crash_penalty = (
            CRASH_FACTOR * abs(ref_cost) if crash_penalty is None else float(crash_penalty)
        )
        if not (np.isfinite(self.crash_penalty) and self.crash_penalty >= 0):
            raise ValueError(f"crash_penalty must be finite and >= 0, got {crash_penalty}")

    def _reference_cost(self, source: str) -> float:
        """The style's cost of its own demonstration, θᵀ f(r_D) (100 when not recorded).

        Raises:
            StyleError: ``feature_values_demo`` is malformed, or θ is so large that this cost
                (times CRASH_FACTOR, the default crash penalty) overflows: every reward of
                such a style would be infinite or lose all precision.
        """
        f_demo = self.style.raw.get("feature_values_demo")
        if f_demo is None:
            return 100.0
        try:
            f = np.asarray(f_demo, dtype=float)
        except (TypeError, ValueError):
            f = np.empty(0)
        if f.shape != self.theta.shape or not np.all(np.isfinite(f)):
            raise StyleError(
                f"{source}feature_values_demo must be {len(self.theta)} finite numbers "
                f"(one per feature), got {f_demo}"
            )
        with np.errstate(over="ignore", invalid="ignore"):
            cost = float(self.theta @ f)
            penalty = CRASH_FACTOR * abs(cost)
        if not np.isfinite(penalty):
            raise StyleError(
                f"{source}style θ overflows: its cost of its own demonstration θᵀ f(r_D) = "
                f"{cost:.3g} (largest θ {np.max(np.abs(self.theta)):.3g}) times the crash "
                f"factor {CRASH_FACTOR:g} is not a finite number; relearn or rescale θ"
            )
        return cost

    def reset(
        self,
        scenario: ScenarioConfig,
        ev: np.ndarray,
        tv: np.ndarray,
        others: np.ndarray | None = None,
    ) -> None:
        """Start a trajectory at the first sample.

        Args:
            scenario: the episode's scenario (lanes, v_ref, λ, ellipse, T_s).
            ev: EV state [x, y, φ, v].
            tv: TV state [x, y, φ, v].
            others: further vehicles' states, shape (m, 4) (traffic; None: the TV only).
        """
        sc = self.sc = scenario
        k = self.constants = feature_constants(self.config, scenario)
        self.ratio = scenario.l_r / (scenario.l_f + scenario.l_r)
        self.m = 0 if others is None else int(np.shape(others)[0])
        upward = sc.target_lane > sc.ev_lane
        self._upward = upward
        self._boundary = sc.lane_width * (sc.ev_lane + 1) if upward else sc.lane_width * sc.ev_lane
        self._lam = k.trigger_lambda
        self._l_a, self._l_b, self._lane_width = float(sc.l_a), float(sc.l_b), float(sc.lane_width)
        self.t: list[float] = []
        self.ev: list[list[float]] = []  # [x, y, φ, v] per sample
        self.vehicles: list[list[list[float]]] = []  # per sample: TV first, then the others
        self.delta: list[float] = []
        self._cp: list[list[float]] = []  # EV control points [x, vx, ax, y, vy, ay] per sample
        self._vcp: list[list[list[float]]] = []  # per sample, per vehicle: the same
        self._speed_grad: list[float] = []  # the paper rule's dv/dt per sample
        self._uniform = True  # np.gradient's test: all sample spacings equal
        self._s_turn: list[float] = []
        self.t_turn: float | None = None
        self.t_trg: float | None = None
        self.critical = 0
        self._ref: list[int] = []  # f_tiv's vehicle per segment (from its first sample)
        self._final = dict.fromkeys(SEGMENT_FEATURES, 0.0)  # sums over the final segments
        self._n_final = 0
        self.f = np.zeros(len(self.omega))
        self._add_sample(0.0, ev, tv, others)

    # ------------------------------------------------------------------ samples
    def _add_sample(self, t: float, ev: Any, tv: Any, others: Any) -> None:
        """Append a sample: states, velocities, the settled accelerations, events."""
        self.t.append(t)
        ev_row = np.asarray(ev, float).reshape(-1)[:4].tolist()
        rows = [np.asarray(tv, float).reshape(-1)[:4].tolist()]
        if self.m:
            rows += np.asarray(others, float).reshape(self.m, 4).tolist()
        self.ev.append(ev_row)
        self.vehicles.append(rows)
        k = len(self.t) - 1
        if k >= 2 and self._uniform and t - self.t[k - 1] != self.t[1] - self.t[0]:
            self._uniform = False
        # velocities: the EV's from the steering applied from the sample (the last one's
        # repeats the previous input until its own is known), the vehicles' from their state
        self._cp.append([ev_row[0], 0.0, 0.0, ev_row[1], 0.0, 0.0])
        self._vcp.append(
            [[x, v * math.cos(phi), 0.0, y, v * math.sin(phi), 0.0] for x, y, phi, v in rows]
        )
        self._speed_grad.append(0.0)
        if k >= 1:
            self._ev_velocity(k - 1, self.delta[k - 1])
            self._ev_velocity(k, self.delta[k - 1])
            # the EV's velocity at k − 1 changed with its input: its accelerations k − 2 … k
            # move; the vehicles' velocities do not change, so only their k − 1 and k do
            for j in range(max(0, k - self.SETTLE), k + 1):
                self._accelerations(j, vehicles=j >= k - 1)
        else:
            self._ev_velocity(0, 0.0)  # replaced at the next sample (no input yet)
        self._events(k, ev_row, rows)

    def _ev_velocity(self, j: int, delta: float) -> None:
        """The EV's control-point velocity at sample j (DESIGN §4's rule)."""
        _, _, phi, v = self.ev[j]
        cp = self._cp[j]
        if self.control_point_rule == "paper":
            cp[1], cp[4] = v * math.cos(phi), v * math.sin(phi)
        else:
            # numpy's tan/arctan: the array rule's rounding (the math module's can differ)
            beta = float(np.arctan(self.ratio * np.tan(delta)))
            cp[1], cp[4] = v * math.cos(phi + beta), v * math.sin(phi + beta)

    def _gradient(self, j: int, f: Callable[[int], float]) -> float:
        """np.gradient(f, t, edge_order=1)[j] over the samples so far (f: sample → value)."""
        t, n = self.t, len(self.t)
        if j == 0:
            return (f(1) - f(0)) / (t[1] - t[0])
        if j == n - 1:
            dx = t[1] - t[0] if self._uniform else t[j] - t[j - 1]
            return (f(j) - f(j - 1)) / dx
        if self._uniform:
            return (f(j + 1) - f(j - 1)) / (2.0 * (t[1] - t[0]))
        dx1, dx2 = t[j] - t[j - 1], t[j + 1] - t[j]
        a = -dx2 / (dx1 * (dx1 + dx2))
        b = (dx2 - dx1) / (dx1 * dx2)
        c = dx1 / (dx2 * (dx1 + dx2))
        return a * f(j - 1) + b * f(j) + c * f(j + 1)

    def _accelerations(self, j: int, vehicles: bool = True) -> None:
        """Control-point accelerations at sample j, of the EV (and of every vehicle)."""
        grad, cp, vcp = self._gradient, self._cp, self._vcp
        if self.control_point_rule == "paper":
            dv = grad(j, lambda i: self.ev[i][3])
            phi = self.ev[j][2]
            cp[j][2], cp[j][5] = dv * math.cos(phi), dv * math.sin(phi)
        else:
            cp[j][2] = grad(j, lambda i: cp[i][1])
            cp[j][5] = grad(j, lambda i: cp[i][4])
        for v in range(len(vcp[j]) if vehicles else 0):
            vcp[j][v][2] = grad(j, lambda i: vcp[i][v][1])  # noqa: B023 (called right here)
            vcp[j][v][5] = grad(j, lambda i: vcp[i][v][4])  # noqa: B023

    def _events(self, k: int, ev: list[float], rows: list[list[float]]) -> None:
        """t_turn, t_trg (and the critical vehicle) and f_tiv's vehicle at a new sample k."""
        t = self.t
        s = ev[1] - self._boundary if self._upward else self._boundary - ev[1]
        self._s_turn.append(s)
        if self.t_turn is None and s > 0:
            if k == 0:
                self.t_turn = t[0]
            else:
                s0 = self._s_turn[k - 1]
                frac = -s0 / (s - s0)
                self.t_turn = float(t[k - 1] + frac * (t[k] - t[k - 1]))
        # elliptical index against every vehicle (numpy squares arrays as z * z)
        s_e = []
        for r in rows:
            zx, zy = (ev[0] - r[0]) / self._l_a, (ev[1] - r[1]) / self._l_b
            s_e.append(zx * zx + zy * zy)
        s_min = min(s_e)
        if self.t_trg is None and s_min < self._lam:
            self.t_trg = t[k]
            self.critical = s_e.index(s_min)
        # tiv_reference: the nearest vehicle ahead in the EV's lane, else the least s_e
        if len(rows) == 1:
            self._ref.append(0)
            return
        xy = np.asarray(rows, float)
        here = np.asarray(ev[:2], float)
        lead = int(leaders(here[:1], here[1:], xy[None, :, 0], xy[None, :, 1], self._lane_width)[0])
        self._ref.append(lead if lead >= 0 else s_e.index(s_min))

    # ------------------------------------------------------------------ segments
    def _segments(self, js: range) -> list[dict[str, float]]:
        """Integral-feature contributions of the segments ``js`` (unscaled)."""
        t = self.t
        t_end = t[-1]
        t_turn = t_end if self.t_turn is None else self.t_turn
        window = None
        if self.t_trg is not None:
            window = (self.t_trg, min(self.t_trg + self.config.t_rct, t_end))
        y_trg = None if self.t_trg is None else self._y_at_knot(self.t_trg)
        out: list[dict[str, float] | None] = []
        fast: list[tuple[int, float, float]] = []  # (segment, il factor, id factor)
        for j in js:
            t0, t1 = t[j], t[j + 1]
            il = _coverage(t0, t1, t0, t_turn)
            idf = 0.0 if window is None else _coverage(t0, t1, *window)
            if il is None or idf is None:  # an event time cuts the segment
                out.append(self._segment_exact(j, t_turn, window, y_trg))
            else:
                out.append(None)
                fast.append((j, il, idf))
        if fast:
            values = self._segments_fast(fast, y_trg)
            it = iter(values)
            out = [next(it) if o is None else o for o in out]
        return out  # type: ignore[return-value]

    def _segment_points(self, j: int) -> tuple[list[float], list[float], list[float]]:
        """(EV x, EV y, f_tiv vehicle's x) control points at both ends of segment j."""
        a, b = self._cp[j], self._cp[j + 1]
        ref = self._ref[j]
        va, vb = self._vcp[j][ref], self._vcp[j + 1][ref]
        return a[:3] + b[:3], a[3:] + b[3:], va[:3] + vb[:3]

    def _segment_exact(
        self, j: int, t_turn: float, window: tuple[float, float] | None, y_trg: float | None
    ) -> dict[str, float]:
        """One segment by :func:`features.segment_integrals` (cut by an event time)."""
        t = self.t
        events = EventTimes(
            t_end=t[-1],
            t_last=t[-2],
            t_turn=t_turn,
            t_trg=None if window is None else window[0],
            t_rct_end=None if window is None else window[1],
            critical=self.critical,
        )
        cx, cy, tx = self._segment_points(j)
        return segment_integrals(
            np.array(cx), np.array(cy), np.array(tx), t[j], t[j + 1], self.config,
            self.constants, events, y_trg, j == 0,
        )  # fmt: skip

    def _segments_fast(
        self, segments: list[tuple[int, float, float]], y_trg: float | None
    ) -> list[dict[str, float]]:
        """Segments whose windows (f_il, f_id) each cover all or none of them, batched."""
        t = self.t
        kernels = [_segment_kernel(t[j], t[j + 1], self.config.n_gauss) for j, _, _ in segments]
        # control points (segment, [EV x, EV y, x_ref], 6) → spline values at the nodes
        # (segment, [EV x, EV y, x_ref], [pos, vel, acc] x nodes)
        P = np.array([self._segment_points(j) for j, _, _ in segments])
        n = self.config.n_gauss
        if all(K is kernels[0] for K in kernels):  # the usual case: one step length
            V = P @ kernels[0].B.T
            W = kernels[0].w.reshape(1, 1, n)
        else:
            V = P @ np.stack([K.B for K in kernels]).transpose(0, 2, 1)
            W = np.stack([K.w for K in kernels]).reshape(-1, 1, n)
        k = self.constants
        y = V[:, 1:2, :n]
        dx = V[:, 2:3, :n] - V[:, 0:1, :n]
        levels = np.array([k.l_des, k.l_initial, k.l_des if y_trg is None else y_trg])
        # the integrands (segment, _FAST_ORDER, node), as features.integrand writes them
        integrands = np.concatenate(
            [
                V[:, :2, 2 * n :] ** 2,  # ax, ay: z²
                (k.v_des - V[:, 0:1, n : 2 * n]) ** 2,  # v
                np.abs(levels[None, :, None] - y),  # l, il, id (|z − y_trg| = |y_trg − z|)
                k.v_lane / np.sqrt(dx * dx + k.tiv_d0**2),  # tiv
            ],
            axis=1,
        )
        sums = (integrands * W).sum(-1).tolist()
        first_weight = self.config.ay_first_segment_weight
        out = []
        for (j, il, idf), (ax, ay, v, lane, initial, reaction, tiv) in zip(
            segments, sums, strict=True
        ):
            out.append(
                {
                    "ax": ax,
                    "ay": ay * first_weight if j == 0 else ay,
                    "v": v,
                    "l": lane,
                    "il": initial if il else 0.0,
                    "tiv": tiv,
                    "id": reaction if idf and y_trg is not None else 0.0,
                }
            )
        return out

    # ------------------------------------------------------------------ spline values
    def _y_at_knot(self, time: float) -> float:
        """y_EV at a sample time, as spline_eval gives it (the last knot via its segment)."""
        return self._spline_y(self._cp, time)

    def _spline_y(self, cps: Any, time: float, vehicle: int | None = None) -> float:
        """The y of a piecewise quintic at ``time`` (spline_eval's segment choice)."""
        t = self.t
        S = len(t) - 1
        j = min(max(bisect.bisect_right(t, time) - 1, 0), S - 1)
        tau = time - t[j]
        a, b = (cps[j], cps[j + 1]) if vehicle is None else (cps[j][vehicle], cps[j + 1][vehicle])
        if tau == 0.0:  # at a knot: its position exactly, as the basis row [1, 0, …] gives
            return a[3]
        return _quintic_value(a[3], a[4], a[5], b[3], b[4], b[5], t[j + 1] - t[j], tau)

    # ------------------------------------------------------------------ features
    def features(self) -> np.ndarray:
        """Scaled features Ω f of the trajectory so far, all ten (FEATURES order)."""
        return self.f.copy()

    def _features(self) -> np.ndarray:
        """Ω f after a new sample: settle one segment, recompute the provisional ones."""
        n = len(self.t)
        final_up_to = n - 2 - self.SETTLE  # segments 0 … final_up_to are final
        first = max(self._n_final, 0)
        newly_final = range(first, max(first, final_up_to + 1))
        provisional = range(max(final_up_to + 1, 0), n - 1)
        segments = self._segments(range(newly_final.start, provisional.stop))
        for seg in segments[: len(newly_final)]:
            for name in SEGMENT_FEATURES:
                self._final[name] += seg[name]
        self._n_final = newly_final.stop
        f = dict.fromkeys(FEATURES, 0.0)
        tail = segments[len(newly_final) :]
        for name in SEGMENT_FEATURES:
            total = self._final[name]
            for seg in tail:
                total += seg[name]
            f[name] = total
        # f_el is f_l's integrand over the last segment (DESIGN §5)
        f["el"] = segments[-1]["l"]
        if self.t_trg is not None:
            window = (self.t_trg, min(self.t_trg + self.config.t_rct, self.t[-1]))
            for name, time in zip(("sd", "ed"), window, strict=True):
                y_ev = self._spline_y(self._cp, time)
                y_tv = self._spline_y(self._vcp, time, self.critical)
                f[name] = math.exp(-abs(y_ev - y_tv))
        return self.omega * np.array([f[k] for k in FEATURES])

    def step(
        self,
        u: np.ndarray,
        ev: np.ndarray,
        tv: np.ndarray,
        dt: float,
        others: np.ndarray | None = None,
    ) -> tuple[float, np.ndarray]:
        """Add the next sample and return the step's reward.

        Args:
            u: the applied input [a, δ] over the step.
            ev: EV state after the step.
            tv: TV state after the step.
            dt: step length [s].
            others: further vehicles after the step, shape (m, 4) (as at reset).

        Returns:
            (reward −θᵀΔf, Δf of the active features).
        """
        self.delta.append(float(np.asarray(u, float).reshape(-1)[1]))
        self._add_sample(self.t[-1] + dt, ev, tv, others)
        f = self._features()
        df = (f - self.f)[self.idx]
        self.f = f
        return -float(self.theta @ df), df


def _coverage(t0: float, t1: float, a: float, b: float) -> float | None:
    """How the integration window [a, b] meets the segment [t0, t1].

    Returns:
        1.0: all of it; 0.0: none (gauss_legendre_nodes' empty interval); None: part of it.
    """
    lo, hi = max(a, t0), min(b, t1)
    if hi <= lo:
        return 0.0
    return 1.0 if (lo == t0 and hi == t1) else None


@dataclass(frozen=True)
class _SegmentKernel:
    """Gauss–Legendre weights and basis rows [pos; vel; acc] of a whole segment."""

    w: np.ndarray
    B: np.ndarray


_KERNELS: dict[tuple[float, int], _SegmentKernel] = {}


def _segment_kernel(t0: float, t1: float, n: int) -> _SegmentKernel:
    """The kernel of the segment [t0, t1] (cached by duration: segments repeat it).

    The nodes as segment_integrals places them (gauss_legendre_nodes, local times rounded
    to 1e-12 s); segments of one duration share them up to that rounding.
    """
    T = t1 - t0
    key = (T, n)
    kernel = _KERNELS.get(key)
    if kernel is None:
        nodes, w = gauss_legendre_nodes(np.array([t0, t1]), t0, t1, n)
        tau = np.round(nodes - t0, 12)
        knots = np.array([0.0, T])
        B = np.vstack([basis_matrix(knots, tau, d) for d in (0, 1, 2)])
        kernel = _KERNELS[key] = _SegmentKernel(w, B)
        if len(_KERNELS) > 4096:  # many scenarios' step lengths: keep the cache bounded
            _KERNELS.clear()
            _KERNELS[key] = kernel
    return kernel


def _quintic_value(
    r0: float, v0: float, a0: float, r1: float, v1: float, a1: float, T: float, tau: float
) -> float:
    """Position of the quintic joining two one-axis control points at local time τ.

    The coefficients of spline._hermite_matrix, evaluated by Horner's rule on floats.
    """
    T2, T3, T4, T5 = T**2, T**3, T**4, T**5
    q3 = -10 / T3 * r0 - 6 / T2 * v0 - 1.5 / T * a0 + 10 / T3 * r1 - 4 / T2 * v1 + 0.5 / T * a1
    q4 = 15 / T4 * r0 + 8 / T3 * v0 + 1.5 / T2 * a0 - 15 / T4 * r1 + 7 / T3 * v1 - 1 / T2 * a1
    q5 = -6 / T5 * r0 - 3 / T4 * v0 - 0.5 / T3 * a0 + 6 / T5 * r1 - 3 / T4 * v1 + 0.5 / T3 * a1
    return r0 + tau * (v0 + tau * (0.5 * a0 + tau * (q3 + tau * (q4 + tau * q5))))


class LearnedStyleReward(gym.Wrapper, RecordConstructorArgs):
    """Replace a drivestyle env's reward with a learned style's negative cost.

    The original reward is kept in ``info["original_env_rew"]`` (the imitation library's
    convention) and the step's feature increment in ``info["style_feature_increment"]``.

    Args:
        env: a drivestyle env (possibly wrapped).
        style: a :class:`drivestyle.irl.paper.style.Style` or the path of a ``style.json`` (or its
            folder).
        crash_penalty: see :class:`StyleReward`.
    """

    def __init__(
        self, env: gym.Env, style: Style | str | Path, crash_penalty: float | None = None
    ) -> None:
        RecordConstructorArgs.__init__(self, style=style, crash_penalty=crash_penalty)
        gym.Wrapper.__init__(self, env)
        self.style_reward = StyleReward(style, crash_penalty)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the env and the style's trajectory."""
        obs, info = self.env.reset(**kwargs)
        tv, others = self._vehicles(obs, info)
        self.style_reward.reset(self._scenario(), obs[:4], tv, others)
        return obs, info

    def _scenario(self) -> ScenarioConfig:
        """The drivestyle env's current scenario (a gym.Env in general has none)."""
        base = self.env.unwrapped
        scenario = getattr(base, "scenario", None)
        if not isinstance(scenario, ScenarioConfig):
            raise TypeError(
                f"the style reward needs a drivestyle env with a scenario, got {base!r}"
            )
        return scenario

    @staticmethod
    def _vehicles(obs: np.ndarray, info: dict) -> tuple[np.ndarray, np.ndarray | None]:
        """TV and further vehicles: from ``info["vehicles"]`` in traffic, else the obs."""
        if "vehicles" in info:
            return info["vehicles"][0], info["vehicles"][1:]
        return obs[4:8], None

    def step(self, action: np.ndarray) -> tuple[np.ndarray, SupportsFloat, bool, bool, dict]:
        """Step the env; the reward becomes −θᵀΔf (minus the crash penalty on a crash)."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        tv, others = self._vehicles(obs, info)
        r, df = self.style_reward.step(info["action"], obs[:4], tv, self._scenario().dt, others)
        if info.get("collision") or info.get("off_road"):
            r -= self.style_reward.crash_penalty
        info = {**info, "original_env_rew": reward, "style_feature_increment": df}
        return obs, r, terminated, truncated, info
