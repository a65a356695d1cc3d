"""compare-av-human on a damaged or foreign mine-styles run, as a user meets it.

Each bad table is written the way it happens (a run killed mid-row, a hand edit, another
dataset's run) and the command is run in a fresh process (``python -m drivestyle``): it must
end with one line ``error: …`` naming the file, the row, the column and the value, exit 2,
before any output is written.
"""

import csv
import io
import re
from pathlib import Path

import pytest
from cli_runner import DATA, run_command

from drivestyle.irl.identification.mined_row import COLUMNS, MinedRow

# each test runs a command in its own process, as a user meets the problem (1-6 s each):
# CI runs them with the slow set, the default run stays within its time
pytestmark = pytest.mark.slow

needs_cats = pytest.mark.skipif(
    not (DATA / "cats-av-lanechange" / "tracks.csv.gz").is_file(),
    reason="the CATS sample is absent",
)


def _refused(refused, tmp_path: Path, *args) -> str:
    return "error: " + refused(
        "compare-av-human", *args, "--data-dir", DATA, "--out", tmp_path / "out"
    )


def _ok(i: str, mean: float = 0.7) -> MinedRow:
    return MinedRow(
        i, "cats", "ok", risk_estimate=mean, risk_lo=0.55, risk_hi=0.9, risk_mean=mean,
        informative=True, trigger_fired=True, theta_normalised=(1.0, 2.0), rmse_y_m=0.1,
        rmse_xy_m=0.2, iterations=0, converged=True, learn_s=1.0, identify_s=2.0,
        residual_rms=0.2, noise_floor=0.1, out_of_class=False, kl_nats=0.5,
        interval_width_ratio=0.4, reason="moved", constraint_binds=True, enters_region=False,
        verdict="informative",
    )  # fmt: skip


def _mined(folder: Path, rows, edit=None) -> Path:
    """A mine-styles run folder with ``rows`` (``edit``: a function of the file's text)."""
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "styles.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(r.to_csv() for r in rows)
    if edit is not None:
        path = folder / "styles.csv"
        path.write_text(edit(path.read_text()), newline="")
    return folder


def _set(column: str, value: str, row: int = 2):
    """An edit: ``column`` of data row ``row`` (1-based) set to ``value``."""

    def edit(text: str) -> str:
        lines = text.splitlines(keepends=True)
        cells = next(csv.reader([lines[row]]))
        cells[COLUMNS.index(column)] = value
        out = io.StringIO()
        csv.writer(out).writerow(cells)
        lines[row] = out.getvalue()
        return "".join(lines)

    return edit


ROWS = [_ok("AV-02-E_4_35217018"), _ok("AV-03-W_3_35208176"), _ok("AV-04-W_2_35453703")]


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        # killed while writing the last row: a prefix of it, no line end
        pytest.param(lambda t: t[: t.rstrip().rfind("\n") + 40],
                     r"styles\.csv, row 3 \(line 4\) is incomplete \(no line end\): the mining "
                     r"run was interrupted .*resume the run", id="torn-last-row"),
        # a row cut short in the middle of the file (its line end kept)
        pytest.param(lambda t: t.replace(t.splitlines()[2], t.splitlines()[2].split(',"[')[0]),
                     r"row 2 \(line 3\) \(id AV-03-W_3_35208176\): \d+ cells where the header "
                     rf"has {len(COLUMNS)} \(a torn row: no ", id="short-row"),
        pytest.param(_set("risk_mean", "7.5"),
                     r"row 2 \(line 3\) \(id AV-03-W_3_35208176\): risk_mean 7\.5 is not a risk "
                     r"in \(0, 1\)", id="risk-out-of-range"),
        # before: accepted; a posterior with 90 % of its mass in [0.55, 0.9] has its mean
        # in [0.495, 0.91]
        pytest.param(_set("risk_mean", "0.3"),
                     r"row 2 \(line 3\) \(id AV-03-W_3_35208176\): risk_mean 0\.3 lies outside "
                     r"its own interval \[0\.55, 0\.9\] \(risk_lo, risk_hi\)", id="mean-outside"),
        pytest.param(_set("risk_lo", "banana"),
                     r"row 2 \(line 3\) \(id AV-03-W_3_35208176\), column risk_lo: 'banana' is "
                     r"not a number", id="not-a-number"),
        pytest.param(_set("interval_width_ratio", "-0.2"),
                     r"interval_width_ratio -0\.2 is not a finite number >= 0",
                     id="negative-width"),
        pytest.param(_set("status", "done"),
                     r"row 2 \(line 3\) \(id AV-03-W_3_35208176\): status must be "
                     r"one of \('ok', 'failed'\), got 'done'", id="unknown-status"),
        pytest.param(lambda t: t + t.splitlines()[1] + "\r\n",
                     r"row 4 \(line 5\): id AV-02-E_4_35217018 again \(first in row 1\)",
                     id="row-twice"),
    ],
)  # fmt: skip
def test_a_damaged_styles_table_is_one_error_naming_row_column_and_value(
    tmp_path, refused, edit, said
):
    mined = _mined(tmp_path / "mined", ROWS, edit)
    line = _refused(refused, tmp_path, "--mined", mined)
    assert line.startswith(f"error: {mined / 'styles.csv'}, row "), line
    assert re.search(said, line), line


def _header(edit):
    """An edit of the header line and every row alike (a spreadsheet's reshuffle)."""

    def apply(text: str) -> str:
        rows = list(csv.reader(io.StringIO(text)))
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerows(edit(r) for r in rows)
        return out.getvalue()

    return apply


@pytest.mark.parametrize(
    ("edit", "said"),
    [
        pytest.param(_header(lambda r: [*r, "extra" if r[0] == "id" else "1"]),
                     f"column 'extra' (column {len(COLUMNS) + 1}) is not a column of a "
                     "styles.csv", id="extra-column"),
        pytest.param(_header(lambda r: r[::-1]),
                     f"column {COLUMNS[-1]} is out of place: column 1 of a styles.csv is id "
                     "(its columns in order: id, source, status, …)", id="reordered"),
        pytest.param(_header(lambda r: r[:5] + r[6:]),
                     f"no column {COLUMNS[5]} (a styles.csv has it as column 6)",
                     id="missing-column"),
    ],
)  # fmt: skip
def test_a_styles_header_names_the_column_unexpected_missing_or_out_of_place(
    tmp_path, refused, edit, said
):
    # before: "is not a styles.csv of mine-styles (its columns: …)", the column unnamed
    mined = _mined(tmp_path / "mined", ROWS, edit)
    line = _refused(refused, tmp_path, "--mined", mined)
    assert line == f"error: {mined / 'styles.csv'}: {said}", line


@needs_cats
def test_a_styles_table_saved_with_a_byte_order_mark_is_read(tmp_path):
    # before: "no column id (a mine-styles table?)": the mark glued to the first column
    mined = _mined(tmp_path / "mined", ROWS, lambda t: "\ufeff" + t)
    run = run_command(tmp_path, "compare-av-human", "--mined", mined, "--data-dir", DATA,
                      "--samples", "50", "--out", tmp_path / "out")  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "error" not in run.stderr


@needs_cats
def test_rows_of_no_cats_lane_change_are_counted_in_a_note(tmp_path):
    # before: only "… CATS lane changes have no ok row": the ignored rows went unsaid
    mined = _mined(tmp_path / "mined", [*ROWS, _ok("zz_1"), _ok("zz_2")])
    run = run_command(tmp_path, "compare-av-human", "--mined", mined, "--data-dir", DATA,
                      "--samples", "50", "--out", tmp_path / "out")  # fmt: skip
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert notes[1:] == [
        f"note: 2 of the 5 ok rows of {mined / 'styles.csv'} match no CATS lane change (e.g. "
        "zz_1, zz_2): they are ignored"
    ], run.stderr


def test_a_missing_default_data_dir_names_the_option_and_its_default(tmp_path, refused):
    # before: "../shared/data/cats-av-lanechange/tracks.csv.gz: no such file"
    line = refused("compare-av-human", "--out", "out")
    assert line == (
        f"--data-dir ../shared/data (the default, relative to the working folder {tmp_path}): "
        "no cats-av-lanechange/ folder; pass --data-dir with the folder holding "
        "cats-av-lanechange/"
    )


def test_a_header_only_run_is_an_error_not_a_table_of_not_mined(tmp_path, refused):
    mined = _mined(tmp_path / "mined", [])
    line = _refused(refused, tmp_path, "--mined", mined)
    assert line.endswith(
        f"{mined / 'styles.csv'} has no row: the mining run mined nothing yet (resume it, or "
        "mine the CATS sample: drivestyle mine-styles --dataset cats)"
    ), line


@needs_cats
def test_a_run_of_another_dataset_is_an_error_not_a_table_of_not_mined(tmp_path, refused):
    mined = _mined(tmp_path / "mined", [_ok("i80_1600_first60s_115_57575")])
    line = _refused(refused, tmp_path, "--mined", mined)
    assert (
        line.startswith(f"error: --mined {mined}: the mined rows are of none of the ")
        and "CATS lane changes (their ids: i80_1600_first60s_115_57575); mine the CATS" in line
    )


@needs_cats
def test_a_partial_run_is_compared_with_a_note_naming_what_is_not_mined(tmp_path):
    mined = _mined(tmp_path / "mined", ROWS)
    run = run_command(tmp_path, "compare-av-human", "--mined", mined, "--data-dir", DATA,
                      "--samples", "50", "--out", tmp_path / "out")  # fmt: skip
    assert run.returncode == 0, run.stderr
    notes = [line for line in run.stderr.splitlines() if line.startswith("note: ")]
    assert len(notes) == 1 and notes[0].endswith(
        f"CATS lane changes have no ok row in {mined / 'styles.csv'} (failed, or not mined "
        "yet): they are reported as not mined"
    ), run.stderr
    n_cats = int(notes[0].split(" of the ")[1].split()[0])
    assert notes[0].startswith(f"note: {n_cats - 3} of the {n_cats} ")


def test_a_bootstrap_beyond_memory_is_refused_before_any_work(tmp_path):
    run = run_command(tmp_path, "compare-av-human", "--samples", "100000000000")
    assert run.returncode == 2 and "MemoryError" not in run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert last == (
        "drivestyle compare-av-human: error: argument --samples: at most 100,000 bootstrap "
        "replicates (≈ 20 µs and 1.5 kB each: the bound alone is ≈ 2 s of work on one core "
        "and ≈ 150 MB of memory), got 100,000,000,000"
    )
