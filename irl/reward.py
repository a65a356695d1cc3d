"""The learned styles as the environment's reward: where ``style=`` and the README find them.

The paper model's reward (:class:`StyleReward`, −θᵀΔf of the growing trajectory, and its
env wrapper :class:`LearnedStyleReward`) is :mod:`drivestyle.irl.paper.style_reward`; the
driver style's per-step cost (``DriverCost``, ``DriverCostReward``) is
:mod:`drivestyle.irl.driver.driver_cost`. This module names the paper model's under the path
the ``drivestyle.rewards`` entry point ``style`` (``pyproject.toml``, which
``gym.make(id, style=...)`` resolves) and the README's examples use.
"""

from drivestyle.irl.paper.style_reward import LearnedStyleReward, StyleReward

__all__ = ["LearnedStyleReward", "StyleReward"]
