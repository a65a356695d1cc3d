"""The default style model: a receding-horizon driver on :mod:`drivestyle.planning`'s NLP.

- ``driver_style``: the model (cost weights, risk p, desired speed) and its closed loop.
- ``style_planner``: the model's planner, its NLP solved for every style (the model's prediction
  of the driver's inputs).
- ``driver_learning``: teacher-forced learning of a driver style; its optimiser (``descent``) and
  what it returns (``driver_fit``: the fit, per demonstration, and ``style.json``).
- ``risk_profile``: the risk profile S(p), the model's fit per risk.
- ``driver_cost``: the style's per-step cost as the env's reward.
"""
