"""drivestyle planning: the receding-horizon planner every driver and every style solves.

- :mod:`~drivestyle.planning.smpc_problem`: the NLP (DESIGN §3) — transcription over the
  horizon, bounds, warm starts, fatrop/IPOPT solvers; the SMPC expert's, and with its
  weights as parameters the style model's.
- :mod:`~drivestyle.planning.chance`: the tangent chance-constraint back-off (eq. 4).
- :mod:`~drivestyle.planning.prediction`: the other vehicles' predicted mean and
  covariance.
- :mod:`~drivestyle.planning.compiled`: generated C of the NLP's functions, compiled once per
  machine and cached on disk (verified before it is loaded).
- :mod:`~drivestyle.planning.plan_solver`: the NLP as one compiled Newton step and a batch
  interior-point solver over it (DESIGN §16).

Its two users are the SMPC expert (:mod:`drivestyle.agents.smpc`) and the style model
(:mod:`drivestyle.irl.driver_style`). It builds on ``envs`` (dynamics, scenario) only.
"""
