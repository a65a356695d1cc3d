"""The paper's study (the project's main job) and the calibration it rests on.

- :mod:`.study`: the SMPC demonstration, its style learned with the base and the reactive
  features, the ablations, the optional SB3 baseline (``reproduce-paper``);
- :mod:`.calibration`: the TV-uncertainty scan against the paper's demonstration
  (``calibrate-uncertainty``, DESIGN §3);
- :mod:`.report`: ``results.md`` and the printed summary;
- :mod:`.figures`: Figs. 3 and 4 and the risk sweep (Fig. 2 is
  :func:`drivestyle.studies.plotting.plot_demonstration`).

The study's and the report's names are re-exported here.
"""

from drivestyle.studies.paper.calibration import (
    PAPER_CALIBRATION,
    SCAN_KEYS,
    UncertaintyScan,
    uncertainty_scan,
)
from drivestyle.studies.paper.report import paper_console, paper_markdown
from drivestyle.studies.paper.study import (
    PAPER_REPORTED,
    BaselineStudy,
    PaperStudy,
    ay_first_segment_share,
    baseline_study,
    paper_study,
    write_paper_results,
    write_paper_study,
)

__all__ = [
    "PAPER_CALIBRATION",
    "PAPER_REPORTED",
    "SCAN_KEYS",
    "BaselineStudy",
    "PaperStudy",
    "UncertaintyScan",
    "ay_first_segment_share",
    "baseline_study",
    "paper_console",
    "paper_markdown",
    "paper_study",
    "uncertainty_scan",
    "write_paper_results",
    "write_paper_study",
]
