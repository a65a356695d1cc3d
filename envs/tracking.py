"""What a tracker would record: noisy positions, smoothed into states (beyond the paper).

:func:`observe` turns a demonstration into the one a roadside or on-board tracker would
produce. The true EV and TV positions get independent Gaussian noise N(0, σ²) per axis and
sample; each vehicle's positions are then smoothed by a Rauch–Tung–Striebel (RTS) smoother
with a constant-acceleration model per axis (white jerk of spectral density q), the
standard offline tracker for vehicle trajectories. From the smoothed velocity (v_x, v_y):

    φ = atan2(v_y, v_x),   v = ‖(v_x, v_y)‖,   a = dv/dt (central differences),   δ = 0,

so the heading is the direction of travel (the side-slip β is not observable from
positions: ``meta["heading"] = "course"`` says so, as for recorded traffic) and the
kinematic control-point rule reproduces the tracked velocities exactly. The inputs are
estimated from the tracked states by :func:`~drivestyle.envs.dynamics.recover_inputs`
(the bounded inverse RK4 step every recorded path uses): the steering too, from the
tracked path's curvature. Before the style class for real traffic (DESIGN §18) the
tracker recorded δ = 0 and a = dv/dt, so a teacher-forced fit's steering residual said
nothing about the driver (0.1 m noise cost 21 points of identification accuracy);
``recover=False`` keeps that model.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import recover_inputs

__all__ = ["DEFAULT_JERK_PSD", "observe", "rts_smooth"]

DEFAULT_JERK_PSD = 4.0
"""q: spectral density of the white jerk [m²/s⁵]; a 1σ jerk of 2 m/s³ per second, enough
for a lane change at the heading bound (lateral jerk ≲ 1.5 m/s³) without following noise."""


def rts_smooth(z: np.ndarray, dt: float, sigma: float, q: float = DEFAULT_JERK_PSD) -> np.ndarray:
    """RTS-smoothed position, velocity and acceleration of one axis.

    Args:
        z: measured positions, shape (n,) [m].
        dt: sampling time [s].
        sigma: measurement noise standard deviation [m] (> 0).
        q: white-jerk spectral density [m²/s⁵].

    Returns:
        Smoothed [r, ṙ, r̈] per sample, shape (n, 3).
    """
    z = np.asarray(z, float)
    n = z.size
    F = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    Q = q * np.array(
        [
            [dt**5 / 20, dt**4 / 8, dt**3 / 6],
            [dt**4 / 8, dt**3 / 3, dt**2 / 2],
            [dt**3 / 6, dt**2 / 2, dt],
        ]
    )
    H = np.array([1.0, 0.0, 0.0])
    R = sigma**2
    # the first two measurements give position and velocity; acceleration unknown
    x = np.array([z[0], (z[1] - z[0]) / dt if n > 1 else 0.0, 0.0])
    P = np.diag([R, 2 * R / dt**2 + 100.0, 100.0])
    xs_f, Ps_f, xs_p, Ps_p = (
        np.zeros((n, 3)),
        np.zeros((n, 3, 3)),
        np.zeros((n, 3)),
        np.zeros((n, 3, 3)),
    )
    for k in range(n):
        if k > 0:
            x, P = F @ x, F @ P @ F.T + Q
        xs_p[k], Ps_p[k] = x, P
        S = H @ P @ H + R
        K = P @ H / S
        x = x + K * (z[k] - H @ x)
        P = P - np.outer(K, H @ P)
        xs_f[k], Ps_f[k] = x, P
    xs = xs_f.copy()
    for k in range(n - 2, -1, -1):
        G = Ps_f[k] @ F.T @ np.linalg.inv(Ps_p[k + 1])
        xs[k] = xs_f[k] + G @ (xs[k + 1] - xs_p[k + 1])
    return xs


def _tracked_states(xy: np.ndarray, dt: float, sigma: float, q: float) -> np.ndarray:
    sx = rts_smooth(xy[:, 0], dt, sigma, q)
    sy = rts_smooth(xy[:, 1], dt, sigma, q)
    vx, vy = sx[:, 1], sy[:, 1]
    return np.column_stack([sx[:, 0], sy[:, 0], np.arctan2(vy, vx), np.hypot(vx, vy)])


def observe(
    demo: Demonstration,
    sigma: float,
    rng: np.random.Generator,
    q: float = DEFAULT_JERK_PSD,
    recover: bool = True,
) -> Demonstration:
    """The demonstration as a tracker with position noise ``sigma`` would record it.

    Args:
        demo: the true demonstration.
        sigma: position noise standard deviation per axis [m] (≥ 0; 0 still smooths, with
            a 1 mm measurement model, so that σ = 0 isolates the tracker's own effect).
        rng: random generator of the noise.
        q: the tracker's white-jerk spectral density [m²/s⁵].
        recover: estimate both inputs from the tracked states (module docstring); False:
            a = dv/dt and δ = 0 (the tracker before DESIGN §18).

    Returns:
        A new demonstration (``meta["observation"]`` records σ and q); the first EV state
        is the tracked one, so the spline's fixed c_0 comes from the tracker too.

    Raises:
        ValueError: ``sigma`` negative or not finite, or ``q`` not positive.
    """
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"noise sigma must be finite and >= 0 m, got {sigma}")
    if not (math.isfinite(q) and q > 0):
        raise ValueError(f"the tracker's jerk density q must be > 0, got {q}")
    dt = float(np.median(np.diff(demo.t)))
    model_sigma = max(sigma, 1e-3)
    ev_xy = demo.ev[:, :2] + sigma * rng.standard_normal((demo.n, 2))
    tv_xy = demo.tv[:, :2] + sigma * rng.standard_normal((demo.n, 2))
    ev = _tracked_states(ev_xy, dt, model_sigma, q)
    tv = _tracked_states(tv_xy, dt, model_sigma, q)
    if recover:
        u = recover_inputs(ev, demo.scenario, demo.t)
    else:
        u = np.zeros_like(demo.u)
        u[:, 0] = np.diff(ev[:, 3]) / np.diff(demo.t)
    observation = {"noise_sigma_m": sigma, "tracker_jerk_psd": q, "inputs_recovered": recover}
    meta = {**demo.meta, "observation": observation}
    if recover:
        meta["heading"] = "course"
    return replace(demo, ev=ev, tv=tv, u=u, meta=meta)
