"""Identification with a small library: typed results, identify.json's keys, refusals."""

import json
import runpy
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from drivestyle.agents import generate_demonstration
from drivestyle.agents.demo_generation import draw_interactive_scenarios
from drivestyle.common.io import write_json
from drivestyle.envs import Demonstration
from drivestyle.irl.identification.library import LibraryError, StyleLibrary
from drivestyle.irl.identification.paper_scorers import DEFAULT_SCORER, MIN_MEMBERS, SCORERS
from drivestyle.irl.identification.posterior import identify, identify_all
from drivestyle.irl.identification.result import Identification

ROOT = Path(__file__).resolve().parents[3]
IDENTIFY_JSON_KEYS = {
    "scorer",
    "risk_estimate",
    "risk_mode",
    "risk_interpolated",
    "risk_interval",
    "interval_mass",
    "posterior",
    "informative",
    "constraint_binds_per_demo",
    "min_s_e_per_demo",
    "scores",
    "all_scores",
    "ranking",
    "n_demos",
    "trigger_fired",
    "trigger_fired_per_demo",
    "true_risk",
    # the verdict
    "verdict",
    "out_of_class",
    "residual_rms",
    "noise_floor",
    "residual_floors",
    "kl_nats",
    "interval_width_ratio",
    "constraint_binds",
    "enters_region",
    "min_s_e",
    "reason",
}


def test_small_library_identifies_fresh_demos(style_library):
    held_out = draw_interactive_scenarios(1, seed=123)[0]
    for p in (0.5, 0.95):
        demo, _ = generate_demonstration(p, held_out)
        results = identify_all(demo, style_library)
        assert set(results) == set(SCORERS)
        sub = results["suboptimality"]
        assert sub.risk_estimate == p == sub.ranking[0], sub
        assert sub.true_risks == (p,) and sub.covers(p)


def test_identify_returns_a_typed_result_with_the_documented_json(style_library, paper_demo):
    res = identify([paper_demo, paper_demo], style_library)
    assert isinstance(res, Identification) and res.scorer == DEFAULT_SCORER
    assert res.risks == style_library.risks and sum(res.posterior) == pytest.approx(1.0)
    js = res.to_json()
    assert set(js) == IDENTIFY_JSON_KEYS
    assert js["risk_interval"] == list(res.risk_interval)
    assert set(js["posterior"]) == set(js["scores"]) == {"0.5", "0.95"}
    assert (
        set(js["all_scores"]) == set(SCORERS) and js["all_scores"][DEFAULT_SCORER] == js["scores"]
    )
    assert js["n_demos"] == 2 and js["true_risk"] == [0.7, 0.7]
    assert js["ranking"] == [
        js["risk_estimate"],
        *(p for p in (0.5, 0.95) if p != res.risk_estimate),
    ]
    json.dumps(js)  # JSON-ready


def _first_scenarios(library: StyleLibrary, k: int) -> StyleLibrary:
    """The same library learned in only its first k training scenarios."""
    return replace(
        library,
        members=tuple(ms[:k] for ms in library.members),
        training_scenarios=library.training_scenarios[:k],
    )


def test_a_library_with_too_few_scenarios_is_refused(style_library, paper_demo):
    # a 3-scenario library answered the paper demo of p = 0.7 with posterior 0.996 on p = 0.5
    # (irl.identification.paper_scorers.MIN_MEMBERS); it now says how many scenarios it needs
    small = _first_scenarios(style_library, 3)
    with pytest.raises(LibraryError, match=f"has 3 training scenarios .* at least {MIN_MEMBERS}"):
        identify(paper_demo, small)
    with pytest.raises(LibraryError, match="at least 10"):
        identify(paper_demo, style_library, nearest=10)
    answer = identify(paper_demo, _first_scenarios(style_library, MIN_MEMBERS))
    assert answer.verdict is not None and answer.verdict.constraint_binds  # the TV came near


def test_demo_of_another_kind_is_rejected(style_library, paper_demo):
    tv = paper_demo.tv.copy()
    tv[:, 0] = tv[0, 0]
    tv[:, 3] = 0.0  # a TV that never moves: no interaction partner
    no_tv = Demonstration(paper_demo.t, paper_demo.ev, tv, paper_demo.u, dict(paper_demo.meta))
    with pytest.raises(LibraryError, match="no target vehicle"):
        identify(no_tv, style_library)
    with pytest.raises(ValueError, match="scorer"):
        identify(paper_demo, style_library, scorer="likelihood")
    with pytest.raises(ValueError, match="at least one"):
        identify([], style_library)


def test_identify_script(tmp_path, style_library, paper_demo):
    from drivestyle.envs import save_demonstration

    write_json(tmp_path / "lib" / "library.json", style_library.to_json())
    demo = save_demonstration(paper_demo, tmp_path / "demo.npz")
    main = runpy.run_path(str(ROOT / "scripts" / "identify_style.py"), run_name="x")["main"]
    res = main([str(demo), "--library", str(tmp_path / "lib"), "--out", str(tmp_path / "o")])
    js = json.loads((tmp_path / "o" / "identify.json").read_text())
    assert set(js) >= IDENTIFY_JSON_KEYS | {"identify_s", "library", "demos"}
    assert js["true_risk"] == [0.7] and res["risk_estimate"] in (0.5, 0.95)


def test_identify_script_has_no_seed_option():
    # --seed was accepted and did nothing (the work is deterministic)
    parse = runpy.run_path(str(ROOT / "scripts" / "identify_style.py"), run_name="x")["parse_args"]
    with pytest.raises(SystemExit):
        parse(["demo.npz", "--library", "lib", "--seed", "3"])


def test_scrambled_inputs_are_out_of_class(paper_demo):
    # an SMPC(0.7) drive whose recorded inputs carry noise of 10 σ_u: far above the floor
    from drivestyle.irl.driver.driver_style import INPUT_SCALE, DriverStyle
    from drivestyle.irl.driver.risk_profile import risk_profile
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.irl.identification.posterior import driver_posterior

    n = 8  # a prefix keeps the test fast
    demo = Demonstration(t=paper_demo.t[:n], ev=paper_demo.ev[:n], tv=paper_demo.tv[:n],
                         u=paper_demo.u[: n - 1], meta=paper_demo.meta)  # fmt: skip
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    noise = np.random.default_rng(0).normal(0.0, 10.0, demo.u.shape) * np.asarray(INPUT_SCALE)
    verdicts = {}
    for name, d in [("exact", demo), ("scrambled", replace(demo, u=demo.u + noise))]:
        res = driver_posterior([risk_profile(library.style, d)], library, [5.0], [None])
        verdicts[name] = res.verdict
    assert not verdicts["exact"].out_of_class and verdicts["exact"].residual_rms < 0.1
    assert verdicts["scrambled"].out_of_class and verdicts["scrambled"].residual_rms > 5.0
    assert verdicts["scrambled"].label == "out_of_class"
    assert verdicts["scrambled"].headline.startswith("out of class: ")
    assert "89× the class's noise floor" in verdicts["scrambled"].reason


def test_a_recorded_episode_beyond_its_heading_bound_is_identified_under_the_recorded_bounds(
    monkeypatch, paper_demo
):
    from dataclasses import replace as dc_replace

    import drivestyle.irl.identification.posterior as ident
    from drivestyle.irl.driver.driver_style import DriverStyle
    from drivestyle.irl.identification.library import DriverLibrary
    from drivestyle.irl.identification.posterior import identify_driver
    from drivestyle.recorded.real_data import RECORDED_DELTA_MAX, RECORDED_PHI_MAX, recorded_view

    # a recording that turns 3× the scenario's heading bound (as recorded drivers do)
    ev = paper_demo.ev * [1.0, 1.0, 3.0, 1.0]
    recorded = dc_replace(
        paper_demo, ev=ev, meta={**paper_demo.meta, "episode_id": "e1"}, origin="recorded"
    )
    prepared = recorded_view(recorded)
    sc = prepared.scenario
    assert (sc.phi_max, sc.delta_max) == (RECORDED_PHI_MAX, RECORDED_DELTA_MAX)
    assert recorded_view(prepared) is prepared  # idempotent
    assert recorded_view(paper_demo) is paper_demo  # a simulated demonstration as it is
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    seen = []
    real = ident.refined_profile
    monkeypatch.setattr(ident, "refined_profile", lambda st, d: seen.append(d) or real(st, d))
    a, b = identify_driver(recorded, library), identify_driver(prepared, library)
    assert a.posterior == b.posterior and a.risk_interpolated == b.risk_interpolated
    assert (seen[0].scenario.phi_max, seen[0].scenario.delta_max) == (
        RECORDED_PHI_MAX, RECORDED_DELTA_MAX,
    )  # fmt: skip
    # within its bounds a recording keeps its scenario: an SMPC written to a file is
    # identified like its .npz
    within = dc_replace(paper_demo, meta={**paper_demo.meta, "episode_id": "e2"}, origin="recorded")
    identify_driver(within, library)
    assert seen[2].scenario.phi_max == paper_demo.scenario.phi_max < RECORDED_PHI_MAX
    assert seen[2].u.tolist() == paper_demo.u.tolist()


def test_the_printed_estimate_is_the_densitys_mode_inside_its_interval():
    """A posterior peaked between two library risks gives its grid mass to one of them (the
    documented ``risk_estimate``), which may lie outside the interval; ``risk_mode`` may not."""
    from drivestyle.irl.identification.result import Identification

    grid = np.linspace(0.5, 0.99, 197)
    density = np.exp(-0.5 * ((grid - 0.7) / 0.003) ** 2)
    density /= density.sum()
    ident = Identification(
        scorer="likelihood", risks=(0.5, 0.9), posterior=(0.4, 0.6), risk_estimate=0.9,
        risk_interpolated=0.7, risk_interval=(0.6975, 0.7025), ranking=(0.9, 0.5), per_demo=(),
        density_risks=tuple(grid), density=tuple(density),
    )  # fmt: skip
    assert ident.risk_mode == pytest.approx(0.7, abs=0.003)
    lo, hi = ident.risk_interval
    assert lo <= ident.risk_mode <= hi and not lo <= ident.risk_estimate <= hi
