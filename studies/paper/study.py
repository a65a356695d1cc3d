"""The paper's simulation study end to end (§IV; the project's main job).

1. The p = 0.7 SMPC demonstration on the paper scenario (Fig. 2).
2. Its style learned with the base (6) and the reactive (10) features.
3. Fig. 3 (reproduced paths over the iterations) and Fig. 4 (lateral motion).
4. Ablations: the paper's own update rule and the control-point rule (DESIGN §4, §6).
5. Optionally, the SB3 baseline trained on the reactive style, compared and rendered.

:func:`paper_study` returns a :class:`PaperStudy`; :func:`write_paper_study` draws and
writes its artefacts, :func:`write_paper_results` its ``results.json`` and ``results.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drivestyle.agents.demo_generation import generate_demonstration
from drivestyle.agents.smpc import SMPCConfig
from drivestyle.common.io import command_line, write_json, write_text
from drivestyle.envs.demonstration import Demonstration, save_demonstration
from drivestyle.irl.paper.features import FeatureConfig, feature_basis, feature_values
from drivestyle.irl.paper.learner import IRLConfig, LearningResult
from drivestyle.irl.paper.spline import demo_control_points
from drivestyle.irl.paper.style import fit_style, locate_demos
from drivestyle.studies.compare.figures import plot_comparison
from drivestyle.studies.compare.report import comparison_markdown
from drivestyle.studies.paper.figures import plot_lateral, plot_reproductions
from drivestyle.studies.paper.report import paper_markdown
from drivestyle.studies.plotting import plot_demonstration

__all__ = [
    "PAPER_REPORTED",
    "BaselineStudy",
    "PaperStudy",
    "ay_first_segment_share",
    "baseline_study",
    "paper_study",
    "write_paper_results",
    "write_paper_study",
]

PAPER_REPORTED = {
    "t_trg_s": 3.0,
    "iterations": {"base": 26, "reactive": 37},
    "reaction_window_x_m": [150.0, 220.0],
}
"""The paper's own numbers for its study (§IV)."""

SUMMARY_KEYS = (
    "iterations",
    "converged",
    "learning_error",
    "rmse_y_m",
    "rmse_xy_m",
    "rmse_y_reaction_m",
    "wall_time_s",
    "inner_solve_ms_median",
)


def ay_first_segment_share(demo: Demonstration, control_point_rule: str) -> float:
    """Share of the demonstration's f_ay that its first spline segment carries (DESIGN §4)."""
    C = demo_control_points(demo, control_point_rule)
    full = feature_basis(demo, FeatureConfig())
    cut = feature_basis(demo, FeatureConfig(ay_first_segment_weight=0.0))
    f = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), full, names=("ay",))[0]
    g = feature_values(C[:, :3].ravel(), C[:, 3:].ravel(), cut, names=("ay",))[0]
    return float((f - g) / f)


def _summary(payload: dict[str, Any]) -> dict[str, Any]:
    return {k: payload[k] for k in SUMMARY_KEYS} | {"theta_normalised": payload["theta_normalised"]}


DEMO_KEYS = ("risk", "t_trg_s", "min_s_e", "x_at_min_s_e", "min_d_k", "collision", "final_lane")
"""The demonstration summary's keys kept in ``results.json``."""


@dataclass(frozen=True)
class BaselineStudy:
    """The SB3 baseline trained on the reactive style, compared and rendered.

    Attributes:
        train: the training summary (``train_summary.json``).
        compare: method name → metrics (``compare.json``'s ``methods``).
        videos: video name → path written.
    """

    train: dict[str, Any]
    compare: dict[str, dict[str, Any]]
    videos: dict[str, str]

    def to_json(self) -> dict[str, Any]:
        """``results.json``'s ``baseline`` entry: ``train``, ``compare``, ``videos``."""
        return {"train": self.train, "compare": self.compare, "videos": self.videos}


@dataclass(frozen=True)
class PaperStudy:
    """The paper's study: the demonstration, its two learned styles, the ablations.

    Attributes:
        demo: the SMPC demonstration.
        demo_summary: its summary (``demo/demo.json``).
        results: feature set ('base', 'reactive') → learning result.
        styles: feature set → ``style.json`` payload.
        learning: feature set → summary (:data:`SUMMARY_KEYS` and ``theta_normalised``).
        reaction_window_x_m: EV x at t_trg and at t_trg + T_rct (None: no trigger).
        paper_rule_alpha: step size of the paper's update rule (None: no ablations).
        paper_rule: feature set → summary with the paper's update rule (empty: none).
        control_point_rule: rule label → f_ay share of segment 0 and summaries per
            feature set (empty: no ablations).
        baseline: the SB3 baseline, if run (:func:`baseline_study`).
        wall_time_total_s: wall time of the whole run, if the caller measured it.
    """

    demo: Demonstration
    demo_summary: dict[str, Any]
    results: dict[str, LearningResult]
    styles: dict[str, dict[str, Any]]
    learning: dict[str, dict[str, Any]]
    reaction_window_x_m: tuple[float, float] | None
    paper_rule_alpha: float | None = None
    paper_rule: dict[str, dict[str, Any]] = field(default_factory=dict)
    control_point_rule: dict[str, dict[str, Any]] = field(default_factory=dict)
    baseline: BaselineStudy | None = None
    wall_time_total_s: float | None = None

    @property
    def reactive_closer_in_reaction_window(self) -> bool:
        """The reactive style reproduces the reaction window better than the base one."""
        react, base = self.learning["reactive"], self.learning["base"]
        return (
            react["rmse_y_reaction_m"] is not None
            and react["rmse_y_reaction_m"] < base["rmse_y_reaction_m"]
        )

    @property
    def reactive_closer_overall(self) -> bool:
        """The reactive style reproduces the whole path better than the base one."""
        return self.learning["reactive"]["rmse_y_m"] < self.learning["base"]["rmse_y_m"]

    def to_json(self) -> dict[str, Any]:
        """``results.json`` (without ``command``): the keys documented in DESIGN §7."""
        out: dict[str, Any] = {
            "paper": PAPER_REPORTED,
            "demo": {k: self.demo_summary[k] for k in DEMO_KEYS},
            "learning": self.learning,
            "reaction_window_x_m": (
                None if self.reaction_window_x_m is None else list(self.reaction_window_x_m)
            ),
            "reactive_closer_in_reaction_window": self.reactive_closer_in_reaction_window,
            "reactive_closer_overall": self.reactive_closer_overall,
        }
        if self.paper_rule_alpha is not None:
            out |= {
                "paper_rule_alpha": self.paper_rule_alpha,
                "paper_rule": self.paper_rule,
                "control_point_rule": self.control_point_rule,
            }
        if self.baseline is not None:
            out["baseline"] = self.baseline.to_json()
        if self.wall_time_total_s is not None:
            out["wall_time_total_s"] = self.wall_time_total_s
        return out


def paper_study(
    risk: float = 0.7,
    t_rct: float = 2.0,
    seed: int = 0,
    ablations: bool = True,
    progress: Callable[[], None] | None = None,
    demo_path: str | Path | None = None,
) -> PaperStudy:
    """Run the paper's study and return its result.

    Args:
        risk: the SMPC's risk p.
        t_rct: reaction window T_rct [s].
        seed: env seed.
        ablations: also learn with the paper's update rule and with the other
            control-point rules.
        progress: called after each step (1 demo + 2 styles + 2 + 1 ablation steps).
        demo_path: where the demonstration will be saved, recorded in the styles.

    Returns:
        The study (:class:`PaperStudy`; its ``to_json()`` is ``results.json``).
    """
    tick = progress or (lambda: None)
    demo, summary = generate_demonstration(risk, "paper", SMPCConfig(risk=risk), seed=seed)
    tick()
    results: dict[str, LearningResult] = {}
    styles: dict[str, dict[str, Any]] = {}
    for name in ("base", "reactive"):
        fc = FeatureConfig(feature_set=name, t_rct=t_rct)
        fitted = fit_style(
            demo, fc, IRLConfig(), demo_paths=[str(demo_path)] if demo_path else None
        )
        results[name], styles[name] = fitted.result, fitted.to_json()
        tick()
    ev = styles["reactive"]
    window = None
    if ev["t_trg_s"] is not None:
        i0 = int(np.argmin(np.abs(demo.t - ev["t_trg_s"])))
        i1 = int(np.argmin(np.abs(demo.t - min(ev["t_trg_s"] + t_rct, demo.t[-1]))))
        window = (float(demo.ev[i0, 0]), float(demo.ev[i1, 0]))
    learning = {n: _summary(p) for n, p in styles.items()}
    alpha: float | None = None
    paper_rule: dict[str, dict[str, Any]] = {}
    control_point_rule: dict[str, dict[str, Any]] = {}
    if ablations:
        alpha = IRLConfig().alpha
        for name in ("base", "reactive"):
            fc = FeatureConfig(feature_set=name, t_rct=t_rct)
            p = fit_style(demo, fc, IRLConfig(method="paper", max_iter=400, alpha=alpha)).to_json()
            paper_rule[name] = _summary(p)
            tick()
        for rule, weight in (
            ("kinematic", 1.0),
            ("paper", 1.0),
            ("kinematic", 0.0),
            ("paper", 0.0),
        ):
            label = rule if weight == 1.0 else f"{rule}, segment 0 excluded from f_ay"
            entry: dict[str, Any] = {
                "ay_first_segment_share": ay_first_segment_share(demo, rule)
                if weight == 1.0
                else 0.0
            }
            for name in ("base", "reactive"):
                if rule == "kinematic" and weight == 1.0:
                    entry[name] = learning[name]
                    continue
                fc = FeatureConfig(feature_set=name, t_rct=t_rct, ay_first_segment_weight=weight)
                p = fit_style(demo, fc, IRLConfig(), control_point_rule=rule).to_json()
                entry[name] = _summary(p)
            control_point_rule[label] = entry
        tick()
    return PaperStudy(
        demo=demo,
        demo_summary=summary,
        results=results,
        styles=styles,
        learning=learning,
        reaction_window_x_m=window,
        paper_rule_alpha=alpha,
        paper_rule=paper_rule,
        control_point_rule=control_point_rule,
    )


def write_paper_study(study: PaperStudy, out: str | Path, argv: list[str]) -> None:
    """Write a :func:`paper_study`'s artefacts into ``out``: demo/, base/, reactive/, figures.

    The results themselves are written by :func:`write_paper_results`.
    """
    out = Path(out)
    demo = study.demo
    save_demonstration(demo, out / "demo" / "demo.npz")
    write_json(out / "demo" / "demo.json", study.demo_summary, argv)
    plot_demonstration(
        demo,
        out / "demo" / "demo.png",
        title=f"SMPC demonstration, p = {study.demo_summary['risk']:g} (Fig. 2)",
    )
    for name, style in study.styles.items():  # each finds the demonstration from its folder
        located = locate_demos(style, out / name, [out / "demo" / "demo.npz"])
        write_json(out / name / "style.json", located, argv)
    C = demo_control_points(demo)
    plot_reproductions(
        demo, study.results, C, out / "fig3_reproductions.png", study.reaction_window_x_m
    )
    plot_lateral(
        demo,
        study.results["reactive"],
        C,
        out / "fig4_lateral.png",
        title="lateral motion with the reactive features (Fig. 4)",
    )


def write_paper_results(study: PaperStudy, out: str | Path, argv: list[str]) -> None:
    """``out/results.json`` and ``out/results.md`` of a :func:`paper_study`."""
    out = Path(out)
    write_json(out / "results.json", study.to_json(), argv)
    write_text(out / "results.md", paper_markdown(study, command_line(argv)))


def baseline_study(
    style_path: str | Path,
    demo: Demonstration,
    smpc_solve_s: float,
    out: str | Path,
    algo: str = "ppo",
    timesteps: int = 60_000,
    seed: int = 0,
    argv: list[str] | None = None,
) -> BaselineStudy:
    """Train the SB3 baseline on a style, compare it with the spline and the SMPC, render videos.

    Needs the ``rl`` and ``video`` extras. Writes ``out/baseline/``, ``out/compare/`` and
    ``out/videos/``.

    Returns:
        The training summary, per-method measures and the videos' paths.
    """
    from drivestyle.agents.sb3_baseline import TrainConfig, train_baseline
    from drivestyle.envs.video import write_video
    from drivestyle.irl.paper.style import load_style
    from drivestyle.studies.compare.study import compare_methods, policy_frames

    out = Path(out)
    style = load_style(style_path)
    train = train_baseline(
        style, out / "baseline", TrainConfig(algo=algo, timesteps=timesteps, seed=seed)
    )
    res = compare_methods(style, demo, smpc_solve_s, out / "baseline")
    plot_comparison(
        demo,
        res.trajectories,
        out / "compare" / "compare.png",
        "driving the learned reactive style",
    )
    write_json(out / "compare" / "compare.json", res.to_json(), argv)
    write_text(out / "compare" / "compare.md", comparison_markdown(res, command_line(argv)))
    risk = demo.meta.get("risk", 0.7)
    videos = {}
    for kind in ("expert", "spline", "sb3"):
        frames = policy_frames(kind, demo.scenario, risk, style, demo, out / "baseline", seed)
        videos[kind] = str(write_video(frames, out / "videos" / f"{kind}.mp4"))
    videos["expert_gif"] = str(
        write_video(policy_frames("expert", demo.scenario, risk), out / "videos" / "expert.gif")
    )
    return BaselineStudy(train, res.methods, videos)
