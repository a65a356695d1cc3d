"""The paper's style model: quintic-spline trajectories and maximum-entropy IRL.

- ``spline``: quintic coefficients, spline evaluation, a demonstration's control points.
- ``features``: the ten reaction-aware features, event times, scaling, quadrature.
- ``inner``: the inner problem argmin θᵀf and its θ-sensitivity.
- ``learner``: ME-IRL (:class:`~drivestyle.irl.paper.learner.MaxEntIRL`).
- ``style``: the paper model's learned :class:`~drivestyle.irl.paper.style.Style` and its file.
- ``style_reward``: the learned style as the env's reward, −θᵀΔf of the growing trajectory.
"""
