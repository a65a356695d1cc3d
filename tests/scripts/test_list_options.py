"""A list option's values are checked one by one before the list is counted: a risk of 1 is
out of range, never "too few risks". Each command is run as a user runs it."""

import pytest

# each test runs a command in its own process, as a user meets the problem (1-6 s each):
# CI runs them with the slow set, the default run stays within its time
pytestmark = pytest.mark.slow


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--risks", "1.0"], "argument --risks: risks must lie in (0, 1), got 1"),
        (["--risks", "0.5,1.0"], "argument --risks: risks must lie in (0, 1), got 1"),
        (["--risks", "0.7,0.7"], "argument --risks: risks must be distinct, got 0.7, 0.7"),
    ],
    ids=["one-at-one", "one-of-two-at-one", "repeated"],
)
def test_build_style_library_says_a_risk_out_of_range_as_such(refused_option, args, said):
    assert "argument " + refused_option("build-style-library", *args, "--out", "lib") == said


def test_build_style_library_checks_the_driver_range_before_the_count(refused):
    # before: "need at least two risks", for a risk the driver model cannot take at all
    assert refused("build-style-library", "--risks", "0.995", "--out", "lib") == (
        "--risks 0.995 outside [0.5, 0.99], the driver model's risk range (the risks it "
        "infers); use --model paper for other risks"
    )
    assert refused("build-style-library", "--risks", "0.7", "--out", "lib") == (
        "--risks: need at least two risks to tell styles apart, got 0.7 (e.g. 0.5,0.7,0.9)"
    )


@pytest.mark.parametrize(
    ("command", "args", "said"),
    [
        ("calibrate-uncertainty", ["--scales", "1,0,-2"],
         "--scales: must be finite numbers > 0, got 0, -2"),
        ("evaluate-identification", ["--library", "nowhere", "--noise", "0,-0.1"],
         "--noise: must be finite numbers >= 0, got -0.1"),
        ("evaluate-identification", ["--library", "nowhere", "--continuous", "-1"],
         "--continuous: must be >= 0, got -1"),
        ("capacity-study", ["--risks", "0.6,1"], "--risks: risks must lie in (0, 1), got 1"),
    ],
    ids=["scales", "noise", "continuous", "capacity-risks"],
)  # fmt: skip
def test_list_and_size_options_are_refused_at_parse_time(refused_option, command, args, said):
    # at parse time: before the library is looked for, before any output
    assert refused_option(command, *args, "--out", "o") == said
