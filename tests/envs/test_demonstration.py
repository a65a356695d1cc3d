import json

import numpy as np
import pytest

from drivestyle.envs.demonstration import (
    Demonstration,
    DemonstrationError,
    load_demonstration,
    save_demonstration,
)
from drivestyle.envs.scenario import PAPER


def _arrays(n=5):
    t = np.arange(n) * 0.2
    ev = np.column_stack([80 + 25 * t, np.full(n, 2.625), np.zeros(n), np.full(n, 25.0)])
    tv = np.column_stack([60 + 28 * t, np.full(n, 7.875), np.zeros(n), np.full(n, 28.0)])
    return {"t": t, "ev": ev, "tv": tv, "u": np.zeros((n - 1, 2))}


def test_round_trip(tmp_path):
    demo = Demonstration(**_arrays(), meta={"scenario": PAPER.to_dict(), "risk": 0.7})
    path = save_demonstration(demo, tmp_path / "sub" / "demo.npz")
    back = load_demonstration(path)
    for k in ("t", "ev", "tv", "u"):
        np.testing.assert_array_equal(getattr(back, k), getattr(demo, k))
    assert back.meta == demo.meta and back.scenario == PAPER


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda a: a.pop("tv"), r"missing array\(s\) \['tv'\]"),
        (lambda a: a.__setitem__("ev", a["ev"][:, :3]), r"'ev' must have shape \(5, 4\)"),
        (lambda a: a.__setitem__("u", np.zeros((5, 2))), r"'u' must have shape \(4, 2\)"),
        (lambda a: a["ev"].__setitem__((2, 1), np.nan), "'ev' contains NaN"),
        (lambda a: a["t"].__setitem__(3, 0.2), "strictly increasing"),
    ],
)
def test_malformed_files_raise(tmp_path, mutate, match):
    arrays = _arrays()
    mutate(arrays)
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(DemonstrationError, match=match):
        load_demonstration(path)


def test_too_few_samples_and_unreadable(tmp_path):
    with pytest.raises(DemonstrationError, match="at least 3 samples"):
        Demonstration(**_arrays(2))
    bad = tmp_path / "junk.npz"
    bad.write_text("not a zip")
    with pytest.raises(DemonstrationError, match=r"junk\.npz is a text file \(it begins 'not a"):
        load_demonstration(bad)
    with pytest.raises(FileNotFoundError):
        load_demonstration(tmp_path / "none.npz")


def test_missing_scenario_in_meta():
    demo = Demonstration(**_arrays())
    with pytest.raises(DemonstrationError, match="no 'scenario'"):
        _ = demo.scenario
    assert json.dumps(demo.meta) == "{}"


def test_arrays_are_read_only():
    demo = Demonstration(**_arrays())
    with pytest.raises(ValueError):
        demo.ev[0, 0] = 1.0


def _corrupt_files(tmp_path):
    """A valid demonstration file truncated and with a flipped byte in an array."""
    demo = Demonstration(**_arrays(), meta={"scenario": PAPER.to_dict()})
    raw = save_demonstration(demo, tmp_path / "good.npz").read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(raw[: len(raw) // 2])
    flipped = bytearray(raw)
    flipped[raw.find(b"ev.npy") + 200] ^= 0xFF  # inside the member's data: CRC fails
    crc = tmp_path / "crc.npz"
    crc.write_bytes(bytes(flipped))
    return {truncated: "BadZipFile", crc: "BadZipFile: Bad CRC"}


def test_corrupt_npz_names_the_file(tmp_path):
    for path, cause in _corrupt_files(tmp_path).items():
        with pytest.raises(DemonstrationError) as exc:
            load_demonstration(path)
        message = str(exc.value)
        assert message.startswith(f"{path}: not a readable demonstration ({cause}"), message
        assert "\n" not in message


def test_a_file_that_is_no_archive_is_said_to_be_what_it_is(tmp_path):
    kinds = {
        "empty.npz": (b"", "is empty, not a demonstration"),
        "text.npz": (b"t,x\n0,1\n", "is a text file (it begins 't,x'), not a demonstration"),
        "array.npz": (b"\x93NUMPY\x01\x00", "is a single .npy array, not a demonstration"),
        "binary.npz": (b"\x00\xff\xfe\x00" * 8, "is a binary file of another kind, not a "),
    }
    for name, (content, said) in kinds.items():
        (tmp_path / name).write_bytes(content)
        with pytest.raises(DemonstrationError) as exc:
            load_demonstration(tmp_path / name)
        assert str(exc.value).startswith(f"{tmp_path / name} {said}"), str(exc.value)
        assert "allow_pickle" not in str(exc.value) and "\n" not in str(exc.value)


def test_folder_passed_as_a_demonstration_says_so(tmp_path):
    folder = tmp_path / "demos"
    save_demonstration(Demonstration(**_arrays()), folder / "a.npz")
    with pytest.raises(DemonstrationError, match=r"demos is a folder.*\.npz files \(it holds 1\)"):
        load_demonstration(folder)


def test_other_vehicles_is_the_validated_array():
    single = Demonstration(**_arrays())
    assert single.other_vehicles.shape == (5, 0, 4)
    others = np.zeros((5, 2, 4))
    assert Demonstration(**_arrays(), others=others).other_vehicles.shape == (5, 2, 4)


# ------------------------------------------------------------- origin and observed mask
def test_a_demonstration_is_simulated_unless_said_and_carries_no_mask():
    demo = Demonstration(**_arrays())
    assert demo.origin == "simulated" and demo.observed is None


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"origin": "real"}, r"origin must be one of 'simulated', 'recorded', got 'real'"),
        ({"observed": np.ones((1, 5))}, r"'observed' must be a boolean array .* dtype float64"),
        (
            {"observed": np.ones((2, 5), bool)},
            r"'observed' must have shape \(1 \+ m, n\) = \(1, 5\)",
        ),
        ({"observed": np.ones((1, 4), bool)}, r"got \(1, 4\)"),
    ],
)
def test_an_unknown_origin_or_a_mask_of_another_shape_or_type_is_refused(fields, match):
    with pytest.raises(DemonstrationError, match=match) as info:
        Demonstration(**_arrays(), **fields)
    assert "\n" not in str(info.value)


def test_origin_and_mask_round_trip_read_only(tmp_path):
    others = np.zeros((5, 2, 4))
    others[:, :, 0] = [[200.0, 300.0]]
    observed = np.array([[True] * 5, [False, False, True, True, True], [True] * 4 + [False]])
    demo = Demonstration(**_arrays(), others=others, origin="recorded", observed=observed)
    assert not demo.observed.flags.writeable
    back = load_demonstration(save_demonstration(demo, tmp_path / "rec.npz"))
    assert back.origin == "recorded"
    np.testing.assert_array_equal(back.observed, observed)
    with np.load(tmp_path / "rec.npz") as data:
        assert str(data["origin"]) == "recorded" and data["observed"].dtype == bool
    simulated = load_demonstration(
        save_demonstration(Demonstration(**_arrays()), tmp_path / "s.npz")
    )
    assert simulated.origin == "simulated" and simulated.observed is None


@pytest.mark.parametrize(
    ("meta", "origin"), [({"episode_id": "a_1_2000"}, "recorded"), ({}, "simulated")]
)
def test_a_file_written_before_the_origin_takes_it_from_the_extractions_metadata(
    tmp_path, meta, origin
):
    np.savez(tmp_path / "old.npz", **_arrays(), meta=np.array(json.dumps(meta)))
    demo = load_demonstration(tmp_path / "old.npz")
    assert demo.origin == origin and demo.observed is None


def test_a_file_with_an_unknown_origin_or_a_mask_of_numbers_is_refused(tmp_path):
    np.savez(tmp_path / "a.npz", **_arrays(), origin=np.array("measured"))
    with pytest.raises(DemonstrationError, match=r"a\.npz: origin must be one of"):
        load_demonstration(tmp_path / "a.npz")
    np.savez(tmp_path / "b.npz", **_arrays(), observed=np.ones((1, 5)))
    with pytest.raises(DemonstrationError, match=r"b\.npz: 'observed' must be a boolean array"):
        load_demonstration(tmp_path / "b.npz")
