"""Atomic result files and output folders (drivestyle.common.io)."""

import json
import os
import stat
from pathlib import Path

import pytest

from drivestyle.common import io
from drivestyle.common.io import (
    atomic_output_dir,
    atomic_output_file,
    check_output_dir,
    check_output_file,
    write_json,
    write_text,
)
from drivestyle.common.output_paths import OUTPUT_MARKER, OutputPathError

# a folder that no one, root included, can create files in (sysfs refuses new entries)
UNWRITABLE = Path("/sys")


def _unwritable() -> Path:
    import tempfile

    try:
        os.rmdir(tempfile.mkdtemp(dir=UNWRITABLE))
    except OSError:
        return UNWRITABLE
    pytest.skip(f"{UNWRITABLE} is writable here")


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


# ------------------------------------------------------------ permissions
def test_json_and_text_files_get_ordinary_permissions(tmp_path, umask_022):
    assert _mode(write_json(tmp_path / "a.json", {"x": 1})) == 0o644
    assert _mode(write_text(tmp_path / "b.md", "x")) == 0o644
    os.umask(0o077)  # a private umask is respected
    assert _mode(write_json(tmp_path / "c.json", {"x": 1})) == 0o600


def test_output_folders_get_ordinary_permissions(tmp_path, umask_022):
    with atomic_output_dir(tmp_path / "out") as tmp:
        write_json(tmp / "a.json", {"x": 1})
        (tmp / "sub").mkdir()
    assert _mode(tmp_path / "out") == 0o755
    assert _mode(tmp_path / "out" / "a.json") == 0o644


def test_an_atomic_file_gets_ordinary_permissions(tmp_path, umask_022):
    with atomic_output_file(tmp_path / "v.gif") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".gif"  # writers pick the format by it
        tmp.write_bytes(b"GIF89a")
    assert _mode(tmp_path / "v.gif") == 0o644
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.gif"]


# ------------------------------------------------------------ failures clean up
def _failing_replace(monkeypatch, when):
    real = os.replace

    def replace(src, dst):
        if when(Path(src), Path(dst)):
            raise OSError(28, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(io.os, "replace", replace)


def test_a_failed_final_move_removes_the_temporary_folder(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("old")
    _failing_replace(monkeypatch, lambda src, dst: src.name.endswith(".partial"))
    with pytest.raises(OutputPathError, match=f"--out {out}: could not move"):
        with atomic_output_dir(out) as tmp:
            (tmp / "a.json").write_text("new")
    assert (out / "a.json").read_text() == "old"  # the previous output is back
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_failed_merge_removes_the_temporary_folder(tmp_path, monkeypatch):
    folder = tmp_path / "demo"
    folder.mkdir()
    (folder / "demo.npz").write_text("demo")
    _failing_replace(monkeypatch, lambda src, dst: dst.name == "style.json")
    with pytest.raises(OutputPathError, match=f"--out {folder}: could not move"):
        with atomic_output_dir(folder, replace=False) as tmp:
            (tmp / "style.json").write_text("{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]
    assert sorted(p.name for p in folder.iterdir()) == ["demo.npz"]


def test_a_failed_file_move_removes_the_temporary_file(tmp_path, monkeypatch):
    _failing_replace(monkeypatch, lambda src, dst: True)
    with pytest.raises(OutputPathError, match=r"cannot write .*b\.json: no space"):
        write_json(tmp_path / "b.json", {"x": 1})
    with pytest.raises(OutputPathError, match=r"v\.gif"):
        with atomic_output_file(tmp_path / "v.gif") as tmp:
            tmp.write_bytes(b"GIF89a")
    assert list(tmp_path.iterdir()) == []


def test_an_interrupted_output_leaves_the_previous_folder(tmp_path):
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_output_dir(out) as tmp:
        (tmp / "a.json").write_text("new, half")
        raise KeyboardInterrupt
    assert (out / "a.json").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_the_temporary_folder_is_made_beside_the_output(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    with atomic_output_dir(Path("runs/out")) as tmp:
        assert tmp.parent == (tmp_path / "runs").resolve()
    with atomic_output_file(Path("v.gif")) as tmp:
        assert tmp.parent == tmp_path.resolve()
        tmp.write_bytes(b"x")


# ------------------------------------------------------------ a folder is replaced whole
def test_a_new_run_replaces_the_folder_as_a_whole(tmp_path):
    out = tmp_path / "demo"
    with atomic_output_dir(out) as tmp:
        (tmp / "demo.npz").write_text("p = 0.5")
        (tmp / "demo.png").write_text("figure of p = 0.5")
    with atomic_output_dir(out) as tmp:
        (tmp / "demo.npz").write_text("p = 0.7")
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARKER, "demo.npz"]
    assert _leftovers(tmp_path) == []


def test_merged_output_keeps_other_files(tmp_path):
    (tmp_path / "demo.npz").write_text("demo")
    with atomic_output_dir(tmp_path, replace=False) as tmp:
        (tmp / "style.json").write_text("{}")
    # a folder the user made is not marked as ours (it will not be replaced later)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.npz", "style.json"]


def test_a_folder_not_written_by_drivestyle_is_not_replaced(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("the user's")
    with pytest.raises(OutputPathError, match=r"--out .*mine.*not written by drivestyle"):
        check_output_dir(tmp_path / "mine")
    with pytest.raises(OutputPathError, match="not written by drivestyle"):
        with atomic_output_dir(tmp_path / "mine"):
            pass
    assert (tmp_path / "mine" / "notes.txt").read_text() == "the user's"
    check_output_dir(tmp_path / "mine", replace=False)  # writing into it is fine
    (tmp_path / "empty").mkdir()
    check_output_dir(tmp_path / "empty")  # an empty folder holds nothing to lose


def test_the_working_folder_and_inputs_are_not_replaced(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with atomic_output_dir(out) as tmp:
        (tmp / "style.json").write_text("{}")
    with pytest.raises(OutputPathError, match="holds the input"):
        check_output_dir(out, inputs=[out / "style.json"])
    check_output_dir(out, inputs=[tmp_path / "elsewhere.json", None])
    monkeypatch.chdir(out)
    with pytest.raises(OutputPathError, match="working folder"):
        check_output_dir(Path("."))


def test_an_output_that_is_holds_or_lies_inside_an_input_is_refused(tmp_path):
    # one rule for every command (refuse_inputs, called by check_output_dir and _file)
    data = tmp_path / "episodes"
    data.mkdir()
    (data / "a.npz").write_bytes(b"x")
    (data / OUTPUT_MARKER).write_text("")  # an earlier run's output: it would be replaced
    with pytest.raises(OutputPathError, match=r"holds the input .*a\.npz, which the run would"):
        check_output_dir(data, inputs=[data / "a.npz"])
    with pytest.raises(OutputPathError, match="is the input"):
        check_output_dir(data, replace=False, inputs=[data])
    with pytest.raises(OutputPathError, match="lies inside the input"):
        check_output_dir(data / "sub", replace=False, inputs=[data])
    with pytest.raises(OutputPathError, match="lies inside the input"):
        check_output_file(data / "bench.json", inputs=[data])
    with pytest.raises(OutputPathError, match=r"--video .* is the input"):
        check_output_file(data / "a.npz", "--video", inputs=[data / "a.npz"])
    link = tmp_path / "link"
    link.symlink_to(data)
    with pytest.raises(OutputPathError, match="lies inside the input"):
        check_output_dir(link / "sub", inputs=[data])  # any spelling
    with pytest.raises(OutputPathError, match=r"lies inside .*episodes, which holds .*a\.npz"):
        check_output_dir(data / "id", inputs=[data / "a.npz"])  # a file of a drivestyle folder
    check_output_dir(data, replace=False, inputs=[data / "a.npz"])  # adds files beside it
    check_output_dir(tmp_path / "x", inputs=[tmp_path])  # the user's folder, not drivestyle's
    check_output_dir(tmp_path / "out", inputs=[data, data / "a.npz", None])
    assert sorted(p.name for p in data.iterdir()) == [OUTPUT_MARKER, "a.npz"]


def test_an_output_name_too_long_for_the_file_system_is_named(tmp_path):
    for check in (check_output_dir, check_output_file):
        with pytest.raises(OutputPathError, match=r"^--out .*: the name 'a{20}…a{12}' is 300 "):
            check(tmp_path / ("a" * 300))
        with pytest.raises(OutputPathError, match="is 250 bytes long; an output's name may be"):
            check(tmp_path / ("b" * 250))  # no room for its lock file
        with pytest.raises(OutputPathError, match="is 300 bytes long; the file system takes"):
            check(tmp_path / ("c" * 300) / "out")


# ------------------------------------------------------------ checked before the work
def test_an_unwritable_output_folder_is_named_before_the_work():
    root = _unwritable()
    with pytest.raises(OutputPathError, match=f"--out {root}/drivestyle-out: cannot create"):
        check_output_dir(root / "drivestyle-out")
    with pytest.raises(OutputPathError, match=f"--video {root}/x.gif: cannot create"):
        check_output_file(root / "x.gif", "--video")


def test_an_output_under_a_file_is_named(tmp_path):
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(OutputPathError, match="a_file is not a folder"):
        check_output_dir(tmp_path / "a_file" / "out")
    with pytest.raises(OutputPathError, match="exists and is not a folder"):
        check_output_dir(tmp_path / "a_file")
    with pytest.raises(OutputPathError, match="is a folder"):
        check_output_file(tmp_path, "--video")


def test_checks_leave_nothing_behind(tmp_path):
    check_output_dir(tmp_path / "a" / "b")
    check_output_file(tmp_path / "c" / "x.json")
    assert list(tmp_path.iterdir()) == []


def test_an_unwritable_parent_at_the_end_names_the_users_path(tmp_path, monkeypatch):
    mkdir = os.mkdir

    def refuse(path, *args, **kwargs):
        if str(path).endswith(".partial"):  # the temporary folder beside the output
            raise PermissionError(13, "Permission denied", str(path))
        return mkdir(path, *args, **kwargs)

    monkeypatch.setattr(os, "mkdir", refuse)
    with pytest.raises(OutputPathError) as info:
        with atomic_output_dir(tmp_path / "out"):
            pass
    assert str(tmp_path / "out") in str(info.value) and "partial" not in str(info.value)


def test_write_json_records_the_command(tmp_path):
    path = write_json(tmp_path / "r.json", {"x": 1}, ["scripts/x.py", "--out", "a b"])
    js = json.loads(path.read_text())
    assert js["x"] == 1 and js["command"] == "python scripts/x.py --out 'a b'"


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (
            ["drivestyle reproduce-paper", "--out", "runs/p q"],
            "drivestyle reproduce-paper --out 'runs/p q'",
        ),
        (["scripts/learn_style.py", "a.npz"], "python scripts/learn_style.py a.npz"),
    ],
)
def test_the_recorded_command_can_be_rerun(argv, expected):
    from drivestyle.common.io import command_line

    assert command_line(argv) == expected
