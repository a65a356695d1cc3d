"""Numbers no one can mean are refused at parse time: seeds, sizes, worker counts."""

import argparse
import importlib.util
import re
from pathlib import Path

import pytest

from drivestyle.common.cli import count, seed, workers

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p for p in (ROOT / "scripts").glob("*.py") if p.name != "__init__.py")


def _module(script: Path):
    spec = importlib.util.spec_from_file_location(f"_bounds_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _parser(script: Path, monkeypatch) -> argparse.ArgumentParser:
    """The script's parser, captured when its parse_args would parse."""
    captured = []

    def capture(self, *args, **kwargs):
        captured.append(self)
        raise SystemExit(0)

    with monkeypatch.context() as m:
        m.setattr(argparse.ArgumentParser, "parse_args", capture)
        with pytest.raises(SystemExit):
            _module(script).parse_args([])
    return captured[0]


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {o: a for a in parser._actions for o in a.option_strings}


WITH_SEED = [
    s for s in SCRIPTS if '"--seed"' in s.read_text()
]  # read, not assumed: a new command with --seed is checked too


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_every_seed_option_is_a_checked_seed(script, monkeypatch):
    options = _options(_parser(script, monkeypatch))
    seeds = [o for o in options if o == "--seed" or o.endswith("-seed") or o == "--video-scene"]
    for option in seeds:
        assert options[option].type is seed, f"{script.name} {option}: type=seed (common/cli.py)"


@pytest.mark.parametrize("script", WITH_SEED, ids=lambda p: p.stem)
@pytest.mark.parametrize("value", ["-5", "4294967296", "1.5"])
def test_a_negative_or_huge_seed_ends_in_one_error_line(script, value, capsys):
    module = _module(script)
    with pytest.raises(SystemExit) as info:
        module.parse_args(["--seed", value])
    assert info.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error: argument --seed:" in last and value in last, last


@pytest.mark.parametrize(
    ("script", "option", "message"),
    [
        ("evaluate_planning", "--scenes", "at most 100,000 scenes"),
        ("bench_tracker", "--vehicles", "at most 100,000 vehicles"),
        ("evaluate_prediction", "--vehicles", "at most 30,000 vehicles"),
        ("simulate_population", "--vehicles", "at most 1,000,000 vehicles"),
        ("bench_population", "--vehicles", "at most 1,000,000 demonstrations"),
        ("bench_solver_paths", "--demos", "at most 10,000 demonstrations"),
        ("build_style_library", "--scenarios", "at most 10,000 scenarios"),
        ("evaluate_identification", "--scenarios", "at most 10,000 scenarios"),
        ("bench_env", "--steps", "at most 1,000,000,000 env steps"),
        ("compare_av_human", "--samples", "at most 100,000 bootstrap replicates"),
        ("evaluate_out_of_class", "--scenarios", "at most 1,000 scenarios"),
        ("evaluate_identification", "--continuous", "at most 1,000 continuous-risk"),
        ("capacity_study", "--train", "at most 1,000 training scenarios"),
        ("capacity_study", "--test", "at most 10,000 held-out scenarios"),
        ("capacity_study", "--budget", "at most 100,000 objective evaluations"),
        ("compare_baseline", "--heldout", "at most 10,000 held-out scenarios"),
        ("train_baseline", "--timesteps", "at most 100,000,000 training env steps"),
        ("reproduce_paper", "--baseline-timesteps", "at most 100,000,000 training env steps"),
    ],
)
def test_a_size_beyond_its_bound_is_refused_with_the_bound(script, option, message, capsys):
    module = _module(ROOT / "scripts" / f"{script}.py")
    with pytest.raises(SystemExit) as info:
        module.parse_args([option, "1000000000000"])
    assert info.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert message in last and "of work on one core" in last, last
    assert last.endswith("got 1,000,000,000,000"), last


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_every_workers_option_is_bounded(script, monkeypatch):
    options = _options(_parser(script, monkeypatch))
    if "--workers" in options:
        assert options["--workers"].type is workers, script.name


def test_the_types():
    assert seed("0") == 0 and seed("4294967295") == 2**32 - 1
    for bad in ("-1", "4294967296", "x", "1e3"):
        with pytest.raises(argparse.ArgumentTypeError):
            seed(bad)
    scenes = count(100, 6.0, "scenes")
    assert scenes("100") == 100
    with pytest.raises(argparse.ArgumentTypeError, match=r"at most 100 scenes .*10 minutes"):
        scenes("101")
    with pytest.raises(argparse.ArgumentTypeError, match=">= 1"):
        scenes("0")
    held = count(1000, 1e-3, "replicates", bytes_each=2e6)  # a size that costs memory
    with pytest.raises(argparse.ArgumentTypeError, match=r"1 ms and 2 MB each: .* 2 GB of memory"):
        held("1001")
    with pytest.raises(argparse.ArgumentTypeError, match="worker processes on this machine"):
        workers("100000")
    assert workers("1") == 1


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_help_says_each_default_once_and_cites_no_issue(script, monkeypatch):
    parser = _parser(script, monkeypatch)
    formatter = parser._get_formatter()
    text = parser.format_help()
    assert not re.search(r"\bissue \d", text), f"{script.name} --help cites an issue"
    assert "(default: None)" not in text
    for action in parser._actions:
        shown = formatter._get_help_string(action) or ""
        said = re.findall(r"default(?!\)s)", shown.lower())  # not the %(default)s slot
        assert len(said) <= 1, (script.name, action.option_strings, shown)


def test_the_command_list_cites_no_issue():
    from drivestyle.scripts import COMMANDS

    assert not [c for c, what in COMMANDS.items() if re.search(r"\bissue \d", what)]


def test_evaluate_planning_refuses_a_seed_range_past_numpys(capsys):
    from drivestyle.common.cli import SEED_MAX
    from drivestyle.scripts import evaluate_planning

    with pytest.raises(SystemExit) as info:
        evaluate_planning.parse_args(["--library", "x", "--seed", str(SEED_MAX - 5)])
    assert info.value.code == 2
    assert "reaches seed" in capsys.readouterr().err.strip().splitlines()[-1]
