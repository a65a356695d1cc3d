"""drivestyle planning: the receding-horizon planner every driver and every style solves.

- :mod:`~drivestyle.planning.description`: what the NLP is (DESIGN §3) — its
  configuration, the layout of variables and constraints, parameters, bounds and the
  primal-dual point; the SMPC expert's, and with its weights as parameters the style
  model's.
- :mod:`~drivestyle.planning.transcription`: the NLP as CasADi symbols — variables,
  objective and constraints over the horizon, the discrete dynamics.
- :mod:`~drivestyle.planning.smpc_problem`: the transcribed NLP and its solvers (fatrop,
  the IPOPT retry), :class:`~drivestyle.planning.smpc_problem.SMPCProblem`.
- :mod:`~drivestyle.planning.warm_starts`: the next solve's initial guess (the last
  solution shifted by one stage, or a cold rollout).
- :mod:`~drivestyle.planning.chance`: the tangent chance-constraint back-off (eq. 4).
- :mod:`~drivestyle.planning.tv_gaussian`: the other vehicles' predicted mean and
  covariance.
- :mod:`~drivestyle.planning.compiled`: generated C of the NLP's functions, compiled once per
  machine and cached on disk (verified before it is loaded).
- :mod:`~drivestyle.planning.plan_solver`: the NLP as one compiled Newton step and a batch
  interior-point solver over it, driven by C shipped beside it (``plan_solver_driver.c``;
  DESIGN §16).

Its two users are the SMPC expert (:mod:`drivestyle.agents.smpc`) and the style model
(:mod:`drivestyle.irl.driver.style_planner`). It builds on ``envs`` (dynamics, scenario) only.
"""
