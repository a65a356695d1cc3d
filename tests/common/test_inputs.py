"""distinct_files: the same file (any spelling) or the same bytes counts once, and is said."""

import os

from drivestyle.common.inputs import NOTE_LISTS, distinct_files


def test_the_same_file_or_content_counts_once_in_the_given_order(tmp_path):
    a, b, c = (tmp_path / f"{n}.npz" for n in "abc")
    a.write_bytes(b"one")
    b.write_bytes(b"two")  # the same size as a, other bytes: kept
    c.write_bytes(b"one")  # a copy of a
    (tmp_path / "sub").mkdir()
    link = tmp_path / "link.npz"
    os.symlink(a, link)  # the same file under another name
    missing = tmp_path / "none.npz"
    files = distinct_files([a, b, tmp_path / "sub" / ".." / "a.npz", c, link, missing, b])
    assert files.kept == (a, b, missing)  # a missing file is kept: reading it names it
    assert files.repeated == ((a, 3), (b, 2))
    assert files.copies == ((c, a),)
    assert files.note == (
        f"note: each demonstration counts once: {a} and {link} are one file (a link), given "
        f"3 times; {b} given 2 times; {c} has the content of {a}"
    )
    assert distinct_files([a, b]).note is None


def test_a_long_note_names_the_first_few(tmp_path):
    first = tmp_path / "v0.npz"
    first.write_bytes(b"same")
    for i in range(1, 9):
        (tmp_path / f"v{i}.npz").write_bytes(b"same")
    files = distinct_files(sorted(tmp_path.glob("*.npz")))
    assert files.kept == (first,) and len(files.copies) == 8
    assert files.note.count("has the content of") == NOTE_LISTS
    assert files.note.endswith("; … (8 in all)")


def test_a_link_names_every_file_that_is_the_same(tmp_path):
    a = tmp_path / "a.npz"
    a.write_bytes(b"a")
    (tmp_path / "b.npz").symlink_to("a.npz")
    found = distinct_files([a, tmp_path / "b.npz", tmp_path / "x" / ".." / "a.npz"])
    assert found.kept == (a,)
    assert found.note == (
        f"note: each demonstration counts once: {a} and {tmp_path / 'b.npz'} are one file "
        "(a link), given 3 times"
    )
