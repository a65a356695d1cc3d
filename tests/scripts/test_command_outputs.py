"""A command's ``--out`` against its own inputs, as a user meets it (``python -m drivestyle``).

The rule (``drivestyle.common.output_paths.refuse_inputs``, applied by every command's output
check): an output that is, holds or lies inside one of the run's inputs is refused before any work,
naming the option, the output and the input; the input is left as it was. Without it,
``identify-style ob/a.npz --out ob`` (``ob`` an extract-episodes output) said "wrote identify.json"
and the whole folder of episodes was gone.
"""

import json
from pathlib import Path

import pytest
from cli_runner import run_command

from drivestyle.common.output_paths import OUTPUT_MARKER
from drivestyle.envs.demonstration import save_demonstration
from drivestyle.irl.driver.driver_style import DriverStyle
from drivestyle.irl.identification.library import DriverLibrary

# each test runs a command in its own process (1-3 s each): CI runs them with the slow set
pytestmark = pytest.mark.slow


def _one_error(done) -> str:
    assert done.returncode == 2, f"exit {done.returncode}\n{done.stderr[-3000:]}"
    assert "Traceback" not in done.stderr, done.stderr[-3000:]
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr[-3000:]
    return lines[0]


def _episodes(tmp_path: Path, paper_demo) -> tuple[Path, Path, list[str]]:
    """An extract-episodes output folder (marked: a run may replace it) and a library."""
    ob = tmp_path / "ob"
    ob.mkdir()
    save_demonstration(paper_demo, ob / "+x_1_8000.npz")
    (ob / "episodes.csv").write_text("episode_id\n+x_1_8000\n")
    (ob / "extract.json").write_text("{}")
    (ob / OUTPUT_MARKER).write_text("written by drivestyle\n")
    lib = tmp_path / "lib"
    lib.mkdir()
    library = DriverLibrary(DriverStyle((0.2, 50.0, 0.2, 1.0, 10.0)), risks=(0.5, 0.7, 0.9))
    (lib / "library.json").write_text(json.dumps(library.to_json()))
    return ob, lib, sorted(p.name for p in ob.iterdir())


def test_identify_style_refuses_an_out_that_holds_its_demonstration(tmp_path, paper_demo):
    ob, lib, before = _episodes(tmp_path, paper_demo)
    done = run_command(tmp_path, "identify-style", "ob/+x_1_8000.npz", "--library", lib,
                       "--out", "ob")  # fmt: skip
    assert _one_error(done) == (
        "error: --out ob holds the input ob/+x_1_8000.npz, which the run would replace; "
        "choose another --out"
    )
    assert sorted(p.name for p in ob.iterdir()) == before  # nothing lost


def test_mine_styles_refuses_an_out_that_is_or_lies_inside_its_input_folder(tmp_path, paper_demo):
    ob, lib, before = _episodes(tmp_path, paper_demo)
    done = run_command(tmp_path, "mine-styles", "ob", "--library", lib, "--out", "ob")
    assert _one_error(done) == (
        "error: --out ob is the input ob: the run would write over what it reads; "
        "choose another --out"
    )
    done = run_command(tmp_path, "mine-styles", "ob", "--library", lib, "--out", "ob/mined")
    assert _one_error(done) == (
        "error: --out ob/mined lies inside the input ob, which the run reads (and the run that "
        "wrote it replaces whole); choose an --out outside it"
    )
    assert sorted(p.name for p in ob.iterdir()) == before


def test_render_rollout_refuses_a_video_whose_summary_would_overwrite_its_style(tmp_path):
    style = tmp_path / "style.json"
    style.write_text('{"kept": true}')
    done = run_command(tmp_path, "render-rollout", "--policy", "spline", "--style",
                       "style.json", "--video", "style.mp4")  # fmt: skip
    assert _one_error(done) == (
        "error: --video style.json is the input style.json: the run would write over what it "
        "reads; choose another --video"
    )
    assert style.read_text() == '{"kept": true}'


def test_an_out_name_too_long_for_the_file_system_is_one_line_naming_out(tmp_path):
    done = run_command(tmp_path, "simulate-population", "--vehicles", 1, "--out", "a" * 300)
    assert _one_error(done) == (
        f"error: --out {'a' * 20}…{'a' * 12}: the name '{'a' * 20}…{'a' * 12}' is 300 bytes "
        "long; an output's name may be at most 223 (the file system's 255 less 32 for its "
        "lock and temporary files)"
    )
    assert list(tmp_path.iterdir()) == []
