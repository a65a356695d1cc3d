"""drivestyle studies: the evaluations, a layer of their own.

Each study combines the layers below it — the world (:mod:`drivestyle.envs`), the planner
(:mod:`drivestyle.planning`), the learners (:mod:`drivestyle.irl`) and the drivers
(:mod:`drivestyle.agents`) — and is a function returning a typed result: the paper's study
(``paper``), the held-out comparisons (``compare``, ``deviation``), identification and its
references (``identification``, ``ceiling``), the uncertainty scan and populations
(``calibration``, ``population``, ``population_style``), capacity (``capacity``), recorded
traffic (``real_traffic``, ``av_vs_human``), prediction (the sub-package ``prediction``,
with its own report and figures), drivers outside the class (``out_of_class``) and the
cut-in planning study (``cut_in_study``). :mod:`.reports` writes their Markdown and
:mod:`.figures` draws their figures. Nothing below imports a
study; scripts parse arguments, call a study, write files.
"""
