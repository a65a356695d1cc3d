"""A mined row: its styles.csv columns, round trips, checks and the tables of earlier versions."""

import csv
import dataclasses
import json

import pytest

from drivestyle.irl.identification import mined_row
from drivestyle.irl.identification.mined_row import COLUMNS, MinedRow
from drivestyle.irl.identification.mining_output import read_rows


def test_a_row_round_trips_through_csv_and_keeps_the_documented_columns(tmp_path, ok_row):
    failed = MinedRow.failed("v2", "pop", "DemonstrationError: a.npz:\n  torn", true_risk=0.6)
    assert failed.error == "DemonstrationError: a.npz: torn"  # one line
    path = tmp_path / "styles.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows([ok_row.to_csv(), failed.to_csv()])
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)
    assert read_rows(path) == [ok_row, failed]
    assert tuple(ok_row.to_json()) == COLUMNS
    assert json.loads(json.dumps(ok_row.to_json()))["theta_normalised"] == [0.25, 1.5e-05, 3.0]
    assert failed.to_json()["risk_estimate"] is None and failed.to_csv()["risk_estimate"] == ""
    with pytest.raises(dataclasses.FrozenInstanceError):
        ok_row.status = "failed"  # type: ignore[misc]


@pytest.mark.parametrize(
    "change, message",
    [
        ({"status": "done"}, "status"),
        ({"error": "ok rows have none"}, "no error"),
        ({"risk_estimate": None}, "risk_estimate"),
        ({"risk_lo": 0.95}, "interval"),
        ({"id": ""}, "id"),
    ],
)
def test_an_inconsistent_row_is_refused(change, message, ok_row):
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(ok_row, **change)
    with pytest.raises(ValueError, match="needs its error"):
        MinedRow("v", "pop", "failed")


def test_the_styles_csv_header_is_the_documented_one():
    # the file interface (README "Many vehicles"): a field added to MinedRow changes it
    assert COLUMNS == (
        "id", "source", "status", "error", "true_risk", "risk_estimate", "risk_lo", "risk_hi",
        "risk_mean", "informative", "trigger_fired", "theta_normalised", "rmse_y_m",
        "rmse_xy_m", "iterations", "converged", "learn_s", "identify_s", "failure_kind",
        "residual_rms", "noise_floor", "out_of_class", "kl_nats", "interval_width_ratio",
        "reason", "constraint_binds", "enters_region", "verdict",
    )  # fmt: skip


def test_a_failure_kind_is_validated_and_round_trips():
    row = MinedRow.failed("v", "pop", "worker died", kind="infrastructure")
    assert MinedRow.from_csv(row.to_csv()) == row
    with pytest.raises(ValueError, match="failure_kind"):
        MinedRow.failed("v", "pop", "x", kind="cosmic rays")
    # a row of the version before failure_kind: its failures are data failures
    legacy = {k: v for k, v in MinedRow.failed("v", "pop", "x").to_csv().items()}
    for column in ("failure_kind", *mined_row.VERDICT_COLUMNS, *mined_row.LABEL_COLUMNS):
        del legacy[column]
    assert MinedRow.from_csv(legacy).failure_kind == "data"


def test_the_verdict_columns_round_trip_and_an_older_row_reads():
    row = MinedRow(
        "v", "pop", "ok", risk_estimate=0.7, risk_lo=0.52, risk_hi=0.94, risk_mean=0.7,
        informative=False, theta_normalised=(1.0, 2.0), residual_rms=5.04,
        noise_floor=0.1005, out_of_class=False, kl_nats=0.046, interval_width_ratio=0.94,
        reason="the data barely moved the posterior (KL 0.05 nats, σ_u, a comma)",
        constraint_binds=True, enters_region=False, verdict="prior",
    )  # fmt: skip
    assert mined_row.COLUMNS[-len(mined_row.LABEL_COLUMNS) :] == mined_row.LABEL_COLUMNS
    assert MinedRow.from_csv(row.to_csv()) == row and row.label == "prior"
    # a table of the version before the label columns: the label from the flags it has
    before_label = {k: v for k, v in row.to_csv().items() if k not in mined_row.LABEL_COLUMNS}
    read = MinedRow.from_csv(before_label)
    assert read.constraint_binds is None and read.verdict == "" and read.label == "prior"
    assert read.reason == row.reason
    # … and before the verdict columns
    older = {k: v for k, v in before_label.items() if k not in mined_row.VERDICT_COLUMNS}
    read = MinedRow.from_csv(older)
    assert read.residual_rms is None and read.out_of_class is None and read.reason == ""
    assert read.risk_mean == 0.7 and read.informative is False and read.label == "prior"
    with pytest.raises(ValueError, match="one line"):
        MinedRow("v", "pop", "failed", error="x", failure_kind="data", reason="a\nb")


@pytest.mark.parametrize(
    ("flags", "label"),
    [
        ({"informative": True, "constraint_binds": True}, "informative"),
        ({"constraint_binds": True}, "prior"),
        ({"constraint_binds": False}, "no_constraint"),
        ({"out_of_class": True, "constraint_binds": True, "informative": False}, "out_of_class"),
        ({"out_of_class": True, "enters_region": True, "constraint_binds": True},
         "enters_region"),
    ],
)  # fmt: skip
def test_a_row_label_follows_its_flags_and_a_contradicting_verdict_is_refused(flags, label, ok_row):
    fields = {"informative": False, "out_of_class": False, "enters_region": False} | flags
    row = dataclasses.replace(ok_row, **fields)
    assert row.label == label
    assert dataclasses.replace(row, verdict=label).verdict == label
    other = next(v for v in ("informative", "prior") if v != label)
    with pytest.raises(ValueError, match=f"verdict '{other}' contradicts its flags"):
        dataclasses.replace(row, verdict=other)
    with pytest.raises(ValueError, match="verdict must be one of"):
        dataclasses.replace(row, verdict="uninformative")
