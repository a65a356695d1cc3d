"""Warm starts of the SMPC planner's NLP: the previous solution shifted, or a cold rollout.

A receding-horizon planner re-solves the NLP every T_s from a state one step along its
last plan: that plan, shifted by one stage (primal and dual), is the next solve's initial
guess (:func:`warm_start`); without one, a zero-input rollout (:func:`cold_primal`). The
compiled batch solver shifts its guesses the same way in C
(:mod:`drivestyle.planning.plan_solver`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from drivestyle.envs.dynamics import rk4_step
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.planning.description import NU, NX, NLPLayout, PrimalDual
from drivestyle.planning.smpc_problem import SMPCProblem

__all__ = [
    "cold_primal",
    "shifted_duals",
    "shifted_primal",
    "warm_start",
]


def cold_primal(layout: NLPLayout, xi0: np.ndarray, scenario: ScenarioConfig) -> np.ndarray:
    """A zero-input rollout from ξ0 as initial guess (inputs and slacks 0).

    Args:
        layout: the NLP's layout.
        xi0: the plan's first state [x, y, φ, v].
        scenario: T_s and the wheelbase of the rollout.

    Returns:
        w, shape (n_w,).
    """
    N = layout.iu.shape[0]
    xs = np.empty((N + 1, NX))
    xs[0] = xi0
    for k in range(N):
        xs[k + 1] = rk4_step(xs[k], np.zeros(NU), scenario.dt, scenario.l_f, scenario.l_r)
    w = np.zeros(layout.n_w)
    w[layout.ix] = xs
    return w


def shifted_primal(
    layout: NLPLayout,
    previous: np.ndarray,
    xi0: np.ndarray,
    dynamics: Callable[[np.ndarray, np.ndarray], Any],
) -> np.ndarray:
    """The previous solution shifted by one stage: the last input repeated, ξ_0 set to ξ0.

    Args:
        layout: the NLP's layout.
        previous: the previous step's solution w.
        xi0: the new first state.
        dynamics: F(ξ, u), to extend the plan by one stage.

    Returns:
        w, shape (n_w,).
    """
    ix, iu, i_s = layout.ix, layout.iu, layout.i_s
    xs, us = previous[ix], previous[iu]
    x_tail = np.asarray(dynamics(xs[-1], us[-1])).ravel()
    w = np.zeros(layout.n_w)
    w[ix] = np.vstack([xs[1:], x_tail])
    w[iu] = np.vstack([us[1:], us[-1:]])
    w[i_s] = np.vstack([previous[i_s][1:], previous[i_s][-1:]])
    w[ix[0]] = xi0
    return w


def shifted_duals(layout: NLPLayout, previous: PrimalDual) -> tuple[np.ndarray, np.ndarray]:
    """Multipliers of ``previous`` shifted by one stage (last stage repeated).

    Args:
        layout: the NLP's layout.
        previous: the previous step's primal-dual solution.

    Returns:
        (λ_g, λ_x) of the shifted guess.
    """
    N = layout.iu.shape[0]
    lg, lx = previous.lam_g, previous.lam_x
    new_g, new_x = lg.copy(), lx.copy()
    nxt = np.minimum(np.arange(N) + 1, N - 1)
    new_g[layout.ig_dyn] = lg[layout.ig_dyn[nxt]]
    new_g[layout.ig_path[:-1]] = lg[layout.ig_path[1:]]
    new_x[layout.ix[1:-1]] = lx[layout.ix[2:]]
    new_x[layout.iu] = lx[layout.iu[nxt]]
    new_x[layout.i_s[:-1]] = lx[layout.i_s[1:]]
    return new_g, new_x


def warm_start(
    problem: SMPCProblem, xi0: np.ndarray, previous: PrimalDual | None, scenario: ScenarioConfig
) -> PrimalDual:
    """The next solve's initial guess: the previous solution shifted, or a cold start.

    ``previous`` is shifted by one stage (primal and dual); without one, a zero-input
    rollout from ξ0 with zero multipliers.

    Args:
        problem: the NLP (layout and dynamics).
        xi0: the new first state.
        previous: the last accepted solution, or None (cold start).
        scenario: T_s and wheelbase of the cold rollout.

    Returns:
        The guess.
    """
    layout = problem.layout
    if previous is None:
        zeros = np.zeros(layout.n_g), np.zeros(layout.n_w)
        return PrimalDual(cold_primal(layout, xi0, scenario), *zeros)
    lam_g, lam_x = shifted_duals(layout, previous)
    return PrimalDual(shifted_primal(layout, previous.w, xi0, problem.step), lam_g, lam_x)
