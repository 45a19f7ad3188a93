"""The .npz instance file: exact round trips (equality, fingerprint, dtypes, bytes), atomic
writes, and malformed or tampered files answered with one InputError line naming the array."""

from __future__ import annotations

import json
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

from sosp.cli import main
from sosp.errors import InputError
from sosp.instance import (
    NPZ_FORMAT_NAME,
    NPZ_FORMAT_VERSION,
    NPZ_HEADER,
    NPZ_TABLES,
    Instance,
    Resources,
    load_instance,
)
from tests.conftest import small_instances, tiny_chain, tiny_two_orbits

#: Every array attribute of an Instance, whose values and dtypes a round trip must keep.
ARRAY_FIELDS = (
    "target_lat",
    "target_lon",
    "target_weight",
    "orbit_start",
    "orbit_end",
    "memory_capacity",
    "memory_rate",
    "energy_capacity",
    "observe_energy_rate",
    "slew_energy_rate",
    "slew_rate",
    "setup_time",
    "max_openings",
    "max_duration",
    "opp_target",
    "opp_orbit",
    "opp_start",
    "opp_end",
    "opp_roll",
    "opp_roll_min",
    "opp_roll_max",
)


def assert_same(a: Instance, b: Instance) -> None:
    """Equal as instances, and field by field with the same dtypes."""
    assert a == b
    assert a.fingerprint == b.fingerprint
    assert (a.name, a.epoch, dict(a.meta)) == (b.name, b.epoch, dict(b.meta))
    assert (a.target_ids, a.orbit_ids, a.orbit_satellite, a.opp_ids) == (
        b.target_ids,
        b.orbit_ids,
        b.orbit_satellite,
        b.opp_ids,
    )
    for name in ARRAY_FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype, name
        assert np.array_equal(x, y), name


def rich_instance() -> Instance:
    """Per-orbit resources, non-ASCII ids, a name and nested meta: every field travels."""
    base = tiny_two_orbits()
    return Instance.from_arrays(
        epoch="2026-06-01T00:00:00Z",
        target_ids=["Xi'an", "北京"],
        target_lat=[34.26, 39.9],
        target_lon=[108.94, 116.4],
        target_weight=base.target_weight,
        orbit_ids=["CBERS 2#001", "CBERS 2#002"],
        orbit_satellite=["CBERS 2", "CBERS 2"],
        orbit_start=base.orbit_start,
        orbit_end=base.orbit_end,
        resources={
            **Resources().__dict__,
            "memory_capacity": [1000.0, 250.5],
            "max_openings": [3, 7],
        },
        opp_ids=["a@1", "b\0@1", "a@2"],  # a NUL inside an id is kept
        opp_target=base.opp_target,
        opp_orbit=base.opp_orbit,
        opp_start=base.opp_start,
        opp_end=base.opp_end,
        opp_roll=base.opp_roll,
        opp_roll_min=base.opp_roll_min,
        opp_roll_max=base.opp_roll_max,
        name="rich",
        meta={"seed": 3, "generator": "test", "tle": [["S", "1 x", "2 y"]], "sun": None},
    )


# --------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("make", [tiny_chain, rich_instance])
def test_round_trip_is_exact_and_agrees_with_json(
    tmp_path: Path, make: Callable[[], Instance]
) -> None:
    inst = make()
    npz, js = tmp_path / "i.npz", tmp_path / "i.json"
    inst.save(npz)
    inst.save(js)
    from_npz, from_json = load_instance(npz), load_instance(js)
    assert_same(from_npz, inst)
    assert_same(from_npz, from_json)
    assert from_npz.fingerprint == from_json.fingerprint == inst.fingerprint
    # The same instance gives the same bytes (fixed member time stamps), also after a reload,
    # and the JSON file written from the .npz is the original JSON file.
    again, js2 = tmp_path / "j.npz", tmp_path / "j.json"
    from_npz.save(again)
    from_npz.save(js2)
    assert again.read_bytes() == npz.read_bytes()
    assert js2.read_bytes() == js.read_bytes()


def test_every_tiny_instance_round_trips(tmp_path: Path, tiny: Instance) -> None:
    path = tmp_path / "t.npz"
    tiny.save(path)
    assert_same(load_instance(path), tiny)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_instances())
def test_random_instances_round_trip(inst: Instance) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        npz, js = Path(tmp) / "r.npz", Path(tmp) / "r.json.gz"
        inst.save(npz)
        inst.save(js)
        back = load_instance(npz)
        assert_same(back, inst)
        assert back.fingerprint == load_instance(js).fingerprint


def test_file_holds_the_documented_arrays_and_dtypes(tmp_path: Path) -> None:
    path = tmp_path / "i.npz"
    rich_instance().save(path)
    with np.load(path, allow_pickle=False) as data:
        expected = {NPZ_HEADER} | {f"{t}.{k}" for t, spec in NPZ_TABLES.items() for k, _ in spec}
        assert set(data.files) == expected
        header = json.loads(str(data[NPZ_HEADER]))
        assert header["format"] == NPZ_FORMAT_NAME and header["version"] == NPZ_FORMAT_VERSION
        assert header["name"] == "rich" and header["meta"]["seed"] == 3
        assert data["targets.id"].dtype.kind == "U" and data["opportunities.id"].dtype.kind == "U"
        assert data["opportunities.target"].dtype == np.int32
        assert data["targets.weight"].dtype == np.int64
        assert data["orbits.max_openings"].dtype == np.int64
        assert data["opportunities.start"].dtype == np.float64
        assert data["orbits.memory_capacity"].tolist() == [1000.0, 250.5]


def test_write_is_atomic_and_keeps_the_name(tmp_path: Path) -> None:
    path = tmp_path / "I.NPZ"  # the extension is matched case-insensitively
    tiny_chain().save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["I.NPZ"]
    assert zipfile.is_zipfile(path)
    old = path.read_bytes()
    bad = Instance.build({"a\0": 1}, [("a\0", 0, 0, 4, 0.0)])
    with pytest.raises(InputError, match=r"targets\[0\]\.id: ends with a NUL"):
        bad.save(path)
    assert path.read_bytes() == old  # the old file is untouched
    assert [p.name for p in tmp_path.iterdir()] == ["I.NPZ"]  # no temporary file is left
    (tmp_path / "dir.npz").mkdir()
    with pytest.raises(InputError, match="is a folder"):
        tiny_chain().save(tmp_path / "dir.npz")


# --------------------------------------------------------------------------- bad files
def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write arrays as numpy itself does (np.savez pickles object arrays)."""
    with path.open("wb") as fh:
        np.savez(fh, **arrays)


def tampered(change: Callable[[dict[str, np.ndarray]], None]) -> Callable[[Path], None]:
    def make(path: Path) -> None:
        arrays = tiny_chain().to_npz_arrays()
        change(arrays)
        write_npz(path, arrays)

    return make


def set_header(**fields: object) -> Callable[[dict[str, np.ndarray]], None]:
    def change(arrays: dict[str, np.ndarray]) -> None:
        header = json.loads(str(arrays[NPZ_HEADER]))
        header.update(fields)
        arrays[NPZ_HEADER] = np.array(json.dumps(header))

    return change


def put(key: str, value: object) -> Callable[[dict[str, np.ndarray]], None]:
    def change(arrays: dict[str, np.ndarray]) -> None:
        arrays[key] = np.asarray(value)

    return change


def with_nan(key: str, row: int) -> Callable[[dict[str, np.ndarray]], None]:
    def change(arrays: dict[str, np.ndarray]) -> None:
        a = arrays[key].copy()
        a[row] = np.nan
        arrays[key] = a

    return change


def single_npy(path: Path) -> None:
    with path.open("wb") as fh:
        np.save(fh, np.zeros(3))


def truncated(path: Path) -> None:
    tiny_chain().save(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def corrupt_member(path: Path) -> None:
    """Flip bytes inside the deflated data of the last member (its CRC no longer matches)."""
    tiny_chain().save(path)
    with zipfile.ZipFile(path) as zf:
        info = zf.infolist()[-1]
    data = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename.encode()) + 20 + 8
    for i in range(start, start + 8):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))


BAD_FILES: dict[str, tuple[Callable[[Path], None], str]] = {
    "not a zip": (lambda p: p.write_text('{"format": "sosp-instance"}'), "not a .npz file"),
    "empty": (lambda p: p.write_bytes(b""), "not a .npz file"),
    "a single .npy": (single_npy, "not a .npz file"),
    "truncated": (truncated, "not a .npz file"),
    "corrupt member": (corrupt_member, "opportunities.roll_max: cannot read the array"),
    "missing array": (
        tampered(lambda a: a.pop("opportunities.roll")),
        "missing array 'opportunities.roll'",
    ),
    "missing header": (tampered(lambda a: a.pop(NPZ_HEADER)), "missing array 'header'"),
    "unknown array": (
        tampered(put("targets.colour", [1, 2, 3])),
        "unexpected array 'targets.colour'",
    ),
    "wrong length": (
        tampered(put("targets.lat", [0.0, 0.0])),
        r"targets.lat: has 2 values, expected 3",
    ),
    "wrong length of an id column": (
        tampered(put("opportunities.id", ["o1", "o2"])),
        r"opportunities.target: has 3 values, expected 2",
    ),
    "bad version": (
        tampered(set_header(version=2)),
        "header.version: this sosp reads .npz version 1, got 2",
    ),
    "no version": (tampered(set_header(version=None)), "header.version"),
    "bad format": (tampered(set_header(format="sosp-instance")), "header.format: expected"),
    "bad epoch": (tampered(set_header(epoch="yesterday")), "epoch: not an ISO 8601 time"),
    "header not JSON": (tampered(put(NPZ_HEADER, "{not json")), "header: malformed JSON"),
    "header not a string": (tampered(put(NPZ_HEADER, [1, 2])), "header: expected a JSON string"),
    "pickled object array": (
        tampered(put("opportunities.id", np.array(["o1", "o2", None], dtype=object))),
        "opportunities.id: cannot read the array: Object arrays cannot be loaded",
    ),
    "float weight": (
        tampered(put("targets.weight", [5.0, 4.0, 3.0])),
        "targets.weight: expected an integer dtype, got dtype float64",
    ),
    "float32 times": (
        tampered(put("opportunities.start", np.array([0, 10, 30], dtype=np.float32))),
        "opportunities.start: expected float64, got dtype float32",
    ),
    "numeric ids": (
        tampered(put("targets.id", [1, 2, 3])),
        "targets.id: expected a unicode string dtype, got dtype int64",
    ),
    "two-dimensional": (
        tampered(put("targets.lon", np.zeros((3, 1)))),
        r"targets.lon: expected a 1-d array, got shape \(3, 1\)",
    ),
    "NaN": (
        tampered(with_nan("opportunities.end", 1)),
        r"opportunities\[1\].end: expected a finite number, got nan",
    ),
    "index out of range": (
        tampered(put("opportunities.target", np.array([0, 1, 7], dtype=np.int32))),
        r"opportunities\[2\].target: unknown target index 7",
    ),
    "duplicate id": (
        tampered(put("targets.id", ["a", "b", "a"])),
        r"targets\[2\].id: duplicate id 'a'",
    ),
    "negative openings": (
        tampered(put("orbits.max_openings", [-1])),
        r"orbits\[0\].max_openings: expected an integer from 0 to 2147483647, got -1",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_files_give_one_line_naming_the_field(tmp_path: Path, case: str) -> None:
    make, needle = BAD_FILES[case]
    path = tmp_path / "bad.npz"
    make(path)
    with pytest.raises(InputError, match=needle) as info:
        load_instance(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and "\n" not in msg


def test_missing_file_and_folder(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="file not found"):
        load_instance(tmp_path / "none.npz")
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(InputError, match="is a directory"):
        load_instance(tmp_path / "d.npz")


# --------------------------------------------------------------------------- the CLI
def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_scenario_solve_validate_with_npz(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    npz, js = tmp_path / "c1.npz", tmp_path / "c1.json"
    code, out, _ = run(capsys, "scenario", "C1", "--seed", "7", "-o", str(npz), "--json")
    assert code == 0
    made = json.loads(out)
    code, out, _ = run(capsys, "scenario", "C1", "--seed", "7", "-o", str(js), "--json")
    assert code == 0 and json.loads(out)["fingerprint"] == made["fingerprint"]
    code, out, _ = run(capsys, "info", str(npz), "--json")
    assert code == 0 and json.loads(out)["fingerprint"] == made["fingerprint"]
    sched = tmp_path / "s.json"
    code, out, _ = run(capsys, "solve", str(npz), "--method", "greedy", "-o", str(sched), "--json")
    assert code == 0 and json.loads(out)["status"] == "feasible"
    # The schedule names the instance by fingerprint, so the JSON file validates it too.
    for inst_file in (npz, js):
        code, out, _ = run(capsys, "validate", str(inst_file), str(sched), "--json")
        assert code == 0 and json.loads(out)["feasible"]


def test_cli_bad_npz_exit_2_one_line_nothing_written(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    bad = tmp_path / "bad.npz"
    tampered(put("targets.lat", [0.0]))(bad)
    sched = tmp_path / "s.json"
    code, out, err = run(capsys, "solve", str(bad), "--method", "greedy", "-o", str(sched))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("error: ") and "targets.lat" in err
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.npz"]
