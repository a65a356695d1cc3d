"""Episodes no driver drives: what the predictive check must keep outside (its power).

Issue goal (DESIGN §22): the posterior-predictive check on behaviour
(:mod:`drivestyle.irl.amortized.predictive_check`) calls recorded people inside the class
only if it keeps its power — "what no driver does (a trajectory played backwards, one
driven through another vehicle, another scene's path pasted into this one) stays outside".
Each function here makes one such counterfeit of an episode, changing the EV's states only
(the scene, its vehicles and metadata stay), so a check of the counterfeit with the
original driver's parameters measures the power against that kind of path:

- :func:`played_backwards`: the EV's states in reverse time order, the tape run backwards
  (its heading and speed columns reversed as recorded: the car moves against its heading);
- :func:`driven_through`: the EV's path bent onto another vehicle's and back, so that it
  passes through that vehicle mid-episode, from and to the original start and end;
- :func:`pasted`: another episode's EV path, shifted along x to start where this EV
  started, in this episode's scene.

The inputs are those of the changed path only in form (reversed, or the other episode's):
no statistic reads them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration

__all__ = ["driven_through", "pasted", "played_backwards"]


def played_backwards(demo: Demonstration) -> Demonstration:
    """The episode with the EV's states in reverse time order (its inputs reversed too).

    Args:
        demo: the episode.

    Returns:
        The counterfeit: ev[k] = the original ev[n − 1 − k]; everything else unchanged.
    """
    return replace(demo, ev=demo.ev[::-1].copy(), u=demo.u[::-1].copy())


def driven_through(demo: Demonstration, vehicle: int = 0) -> Demonstration:
    """The episode with the EV's path bent through a surrounding vehicle mid-episode.

    ev'(t) = ev(t) + s(t) (veh(t) − ev(t)) for every state component, s(t) =
    sin²(π (t − t_0) / (t_end − t_0)): the original start and end, and the vehicle's own
    state at the middle of the episode (the two overlap there).

    Args:
        demo: the episode.
        vehicle: the surrounding vehicle's index in ``demo.vehicles`` (0: the TV).

    Returns:
        The counterfeit.
    """
    t = demo.t
    s = np.sin(np.pi * (t - t[0]) / (t[-1] - t[0]))[:, None] ** 2
    other = demo.vehicles[:, vehicle]
    return replace(demo, ev=demo.ev + s * (other - demo.ev))


def pasted(demo: Demonstration, other: Demonstration) -> Demonstration:
    """The episode with another episode's EV path in it, shifted along x to start at its start.

    The lateral positions stay the other's: both are in the road frame (lane 0 at y = 0).

    Args:
        demo: the episode whose scene it is.
        other: the episode whose EV path is pasted (as many samples).

    Returns:
        The counterfeit (the other's EV states and inputs).

    Raises:
        ValueError: the episodes have different numbers of samples.
    """
    if other.n != demo.n:
        raise ValueError(f"the pasted path has {other.n} samples, the episode {demo.n}")
    ev = other.ev.copy()
    ev[:, 0] += demo.ev[0, 0] - other.ev[0, 0]
    return replace(demo, ev=ev, u=other.u.copy())
