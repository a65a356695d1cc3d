"""The verdict's one label, its phrase and its reason agree with its numbers in every case."""

import itertools

import pytest

from drivestyle.irl.identification.verdict import (
    ENTERS_REGION_S_E,
    KL_INFORMATIVE,
    OUT_OF_CLASS_FACTOR,
    VERDICT_LABELS,
    VERDICT_PHRASES,
    WIDTH_INFORMATIVE,
    Verdict,
    recorded_verdict_label,
    verdict_label,
)

FLOOR = 0.1
# (KL, width ratio): both pass, only KL fails, only the width fails, both fail
MOVEMENTS = {
    "moved": (1.46, 0.25),
    "kl fails": (0.1, 0.25),
    "width fails": (1.46, 0.9),
    "both fail": (0.05, 0.95),
}


def _verdict(binds: bool, movement: str, inside: bool, out: bool) -> Verdict:
    kl, width = MOVEMENTS[movement]
    rms = (2 if out else 0.5) * OUT_OF_CLASS_FACTOR * FLOOR
    min_s_e = ENTERS_REGION_S_E / 2 if inside else 3.0
    return Verdict(rms, FLOOR, kl, width, binds, min_s_e)


def _expected(binds: bool, moved: bool, inside: bool, out: bool) -> str:
    # written out as a table, not by calling the rule: the order the labels take precedence
    if inside:
        return "enters_region"
    if out:
        return "out_of_class"
    if not binds:
        return "no_constraint"
    return "informative" if moved else "prior"


CASES = list(itertools.product([True, False], MOVEMENTS, [True, False], [True, False]))


@pytest.mark.parametrize(("binds", "movement", "inside", "out"), CASES)
def test_label_flags_and_reason_agree_in_every_combination(binds, movement, inside, out):
    v = _verdict(binds, movement, inside, out)
    moved = movement == "moved"
    assert (v.moved, v.enters_region, v.residual_out_of_class) == (moved, inside, out)
    label = _expected(binds, moved, inside, out)
    assert v.label == label == verdict_label(binds, moved, out, inside)
    assert v.informative is (label == "informative")
    assert v.out_of_class is (label in ("out_of_class", "enters_region"))
    assert v.headline == f"{VERDICT_PHRASES[label]} ({v.reason})"
    reason = v.reason
    if binds:
        # the movement is said as it is, whatever else the verdict says
        assert ("the data moved the posterior" in reason) is moved
        assert ("barely moved" in reason) is (not moved)
        kl, width = MOVEMENTS[movement]
        assert (f"> {KL_INFORMATIVE:.3f} nats" in reason) is (kl > KL_INFORMATIVE)
        assert (f"< {WIDTH_INFORMATIVE:.0%}" in reason) is (width < WIDTH_INFORMATIVE)
    else:
        assert "moved" not in reason and "no chance constraint binds" in reason
    assert ("inside the safety region" in reason) is inside
    assert ("noise floor" in reason) is out
    js = v.to_json()
    assert js["verdict"] == label and js["reason"] == reason
    assert (js["informative"], js["out_of_class"]) == (v.informative, v.out_of_class)


@pytest.mark.parametrize(("binds", "movement", "inside", "out"), CASES)
def test_a_recorded_verdict_gets_its_label_back_from_its_flags(binds, movement, inside, out):
    # what styles.csv, out_of_class.json and compare-av-human keep of a verdict
    v = _verdict(binds, movement, inside, out)
    assert recorded_verdict_label(v.informative, v.out_of_class, binds, inside) == v.label


def test_the_reported_contradiction_reads_as_what_it_is():
    # "barely moved (KL 1.46 nats, needs > 0.287682; interval 25 %, needs < 75 %)" with
    # both thresholds met: the posterior moved, but another vehicle entered the region
    v = _verdict(True, "moved", True, False)
    assert v.label == "enters_region" and not v.informative
    assert "barely" not in v.reason and "the data moved the posterior" in v.reason
    assert v.headline.startswith("less cautious than the class: ")


def test_rows_of_older_tables_take_the_documented_defaults():
    # no constraint_binds column: the posterior is the prior either way; no enters_region
    # column: such a driver was flagged out of class
    assert recorded_verdict_label(False, False, None, None) == "prior"
    assert recorded_verdict_label(True, None, None, None) == "informative"
    assert recorded_verdict_label(True, True, None, None) == "out_of_class"
    assert recorded_verdict_label(None, None, None, None) == "prior"


def test_before_the_first_step_the_verdict_is_the_prior_whatever_is_near():
    v = Verdict(None, FLOOR, 0.0, 1.0, False, 0.2)  # a vehicle inside, but no residual yet
    assert v.label == "no_constraint" and not v.enters_region and v.reason == "no step yet"
    assert v.headline.startswith("the prior: nothing in the data can move the risk (")


@pytest.mark.parametrize(
    ("near", "movement", "label", "said"),
    [
        (True, "moved", "informative", "a TV came within s_e 8"),
        (True, "both fail", "prior", "a TV came within s_e 8"),
        (False, "both fail", "no_constraint", "no TV came within s_e 8"),
    ],
)
def test_a_paper_model_verdict_has_no_residual_scale(near, movement, label, said):
    kl, width = MOVEMENTS[movement]
    v = Verdict(None, None, kl, width, near, 0.5)  # s_e 0.5: no region test without residuals
    assert v.label == label and v.floors is None and not v.out_of_class
    assert v.reason.startswith(f"paper model, {said}: closest s_e 0.5")


def test_every_label_has_one_phrase_and_the_prior_says_so_first():
    assert VERDICT_LABELS == tuple(VERDICT_PHRASES)
    assert len(set(VERDICT_PHRASES.values())) == len(VERDICT_LABELS)
    for label in ("prior", "no_constraint"):
        assert VERDICT_PHRASES[label].startswith("the prior: nothing in the data")
