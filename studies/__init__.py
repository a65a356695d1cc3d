"""drivestyle studies: the evaluations, a layer of their own.

Each study combines the layers below it — the world (:mod:`drivestyle.envs`), the planner
(:mod:`drivestyle.planning`), the learners (:mod:`drivestyle.irl`) and the drivers
(:mod:`drivestyle.agents`) — and is a function returning a typed result. Each study is a
sub-package holding its module(s), its ``report.py`` (Markdown from its typed result) and
its ``figures.py`` (its plots): the paper's study and its TV-uncertainty calibration
(``paper``), the drivers of a learned style compared (``compare``), identification, its
references and simulated populations (``identification``), capacity (``capacity``),
recorded traffic (``real_traffic``), the automated car against humans (``av_vs_human``),
drivers outside the class (``out_of_class``) and the cut-in planning study (``cut_in``);
prediction (``prediction``)
and the population's style learned from recorded drivers (``population_style``). What the
reports share is :mod:`.formatting`, what the figures share :mod:`.plotting` (the one
module that selects matplotlib's backend). Nothing below imports a study; scripts parse
arguments, call a study, write files.
"""
