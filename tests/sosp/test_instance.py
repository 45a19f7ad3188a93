"""Instance and schedule files: exact round trips, and one-line errors naming the field or row."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest

from sosp.errors import InputError
from sosp.instance import Instance, Resources, load_instance
from sosp.schedule import Schedule, load_schedule, make_observation
from tests.conftest import TINY, tiny_chain, tiny_two_orbits


@pytest.mark.parametrize("layout", ["records", "columns"])
def test_round_trip_is_exact(tmp_path: Path, tiny: Instance, layout: str) -> None:
    path = tmp_path / "i.json"
    tiny.save(path, layout=layout)
    back = load_instance(path)
    assert back == tiny
    assert back.fingerprint == tiny.fingerprint
    for name in (
        "opp_start",
        "opp_end",
        "opp_roll",
        "opp_roll_min",
        "opp_roll_max",
        "target_weight",
        "energy_capacity",
        "max_openings",
    ):
        assert np.array_equal(getattr(back, name), getattr(tiny, name))
    # Saving again gives the same bytes.
    path2 = tmp_path / "j.json"
    back.save(path2, layout=layout)
    assert path.read_text() == path2.read_text()


def test_records_and_columns_have_one_fingerprint(tiny: Instance) -> None:
    a = Instance.from_dict(tiny.to_dict("records"))
    b = Instance.from_dict(tiny.to_dict("columns"))
    assert a.fingerprint == b.fingerprint == tiny.fingerprint


def test_fingerprint_changes_with_content() -> None:
    d = tiny_chain().to_dict()
    d["opportunities"][0]["end"] += 0.5
    assert Instance.from_dict(d).fingerprint != tiny_chain().fingerprint
    d = tiny_chain().to_dict()
    d["name"] = "renamed"
    assert Instance.from_dict(d).fingerprint == tiny_chain().fingerprint


def test_opportunities_sorted_by_orbit_and_start() -> None:
    inst = Instance.build(
        {"a": 1, "b": 2}, [("b", 1, 50, 52, 0.0), ("a", 0, 9, 10, 0.0), ("b", 0, 3, 5, 0.0)]
    )
    assert inst.opp_orbit.tolist() == [0, 0, 1]
    assert inst.opp_start.tolist() == [3, 9, 50]
    assert inst.orbit_opps(0) == slice(0, 2)
    assert [t.tolist() for t in inst.target_opps] == [[1], [0, 2]]
    assert inst.observable_targets == 2


def test_arrays_are_read_only() -> None:
    inst = tiny_chain()
    with pytest.raises(ValueError):
        inst.opp_start[0] = 1.0


def mutate(path_: str, value):
    """Return a function that applies one change to an instance dict."""

    def apply(d):
        target = d
        keys = path_.split(".")
        for k in keys[:-1]:
            target = target[int(k)] if k.isdigit() else target[k]
        last = keys[-1]
        if value is KeyError:
            del target[last]
        else:
            target[int(last) if last.isdigit() else last] = value
        return d

    return apply


BAD = [
    ("missing targets", mutate("targets", KeyError), "missing key 'targets'"),
    ("missing lat", mutate("targets.0.lat", KeyError), "targets[0]: missing key 'lat'"),
    ("lat type", mutate("targets.0.lat", "north"), "targets[0].lat"),
    ("lat NaN", mutate("targets.1.lat", float("nan")), "targets[1].lat"),
    ("lat range", mutate("targets.1.lat", 91.0), "targets[1].lat"),
    ("lon range", mutate("targets.0.lon", 400.0), "targets[0].lon"),
    ("negative weight", mutate("targets.2.weight", -1), "targets[2].weight"),
    ("fractional weight", mutate("targets.2.weight", 2.5), "targets[2].weight"),
    # 1e20 once wrapped to a negative int64 weight: a "feasible" schedule of profit -9.2e18
    (
        "huge weight",
        mutate("targets.2.weight", 10**20),
        "targets[2].weight: expected an integer in",
    ),
    ("duplicate id", mutate("targets.1.id", "a"), "duplicate id 'a'"),
    ("opp start>=end", mutate("opportunities.1.start", 14.0), "opportunities[1]: start must"),
    ("roll out of range", mutate("opportunities.0.roll", 20.0), "roll_min <= roll <= roll_max"),
    ("unknown target", mutate("opportunities.0.target", "zz"), "unknown target 'zz'"),
    ("unknown orbit", mutate("opportunities.0.orbit", "orbit9"), "unknown orbit 'orbit9'"),
    ("orbit start>=end", mutate("orbits.0.end", -5.0), "orbits[0]: start must be < end"),
    ("negative capacity", mutate("orbits.0.energy_capacity", -1), "orbits[0].energy_capacity"),
    ("zero slew rate", mutate("orbits.0.slew_rate", 0), "orbits[0].slew_rate"),
    ("fractional openings", mutate("orbits.0.max_openings", 2.5), "orbits[0].max_openings"),
    # finite and integral, but beyond any integer the planner holds (was cast to garbage)
    ("huge openings", mutate("orbits.0.max_openings", 1e20), "orbits[0].max_openings"),
    ("missing resource", mutate("orbits.0.setup_time", KeyError), "missing key 'setup_time'"),
    ("bad epoch", mutate("epoch", "yesterday"), "epoch"),
    ("local epoch", mutate("epoch", "2026-01-01T00:00:00+02:00"), "must be UTC"),
    ("version", mutate("version", 99), "version"),
    ("table type", mutate("opportunities", 7), "opportunities: expected a list"),
    ("bool number", mutate("opportunities.0.end", True), "opportunities[0].end"),
]


@pytest.mark.parametrize(("case", "change", "needle"), BAD, ids=[b[0] for b in BAD])
def test_bad_instances_name_the_field(case: str, change, needle: str) -> None:
    d = change(copy.deepcopy(tiny_chain().to_dict()))
    with pytest.raises(InputError) as info:
        Instance.from_dict(d, source="x.json")
    msg = str(info.value)
    assert needle in msg
    assert msg.startswith("x.json: ") and "\n" not in msg


def test_unequal_columns_are_named() -> None:
    d = tiny_chain().to_dict("columns")
    d["targets"]["lat"].append(0.0)
    with pytest.raises(InputError, match=r"targets\.lat: has 4 values, expected 3"):
        Instance.from_dict(d)


def test_malformed_json_names_the_file(tmp_path: Path) -> None:
    p = tmp_path / "bad.json"
    p.write_text('{"targets": [')
    with pytest.raises(InputError, match=r"bad.json: malformed JSON at line 1"):
        load_instance(p)
    p.write_text('{"epoch": NaN}')
    with pytest.raises(InputError, match="malformed JSON"):
        load_instance(p)
    with pytest.raises(InputError, match="file not found"):
        load_instance(tmp_path / "nope.json")


def test_resources_validate_in_post_init() -> None:
    with pytest.raises(InputError, match="resources.slew_rate"):
        Resources(slew_rate=0)
    with pytest.raises(InputError, match="resources.max_openings"):
        Resources(max_openings=-1)
    with pytest.raises(InputError, match="resources.max_openings: expected an integer from 0"):
        Resources(max_openings=2**31)
    with pytest.raises(InputError, match="resources.energy_capacity"):
        Resources(energy_capacity=float("inf"))


def test_per_orbit_resources_round_trip(tmp_path: Path) -> None:
    d = tiny_two_orbits().to_dict()
    d["orbits"][1]["energy_capacity"] = 77.0
    inst = Instance.from_dict(d)
    assert inst.resources(1).energy_capacity == 77.0 and inst.resources(0).energy_capacity == 1500
    inst.save(tmp_path / "i.json")
    assert load_instance(tmp_path / "i.json").energy_capacity.tolist() == [1500.0, 77.0]


# ---------------------------------------------------------------------------- schedules
def test_schedule_round_trip(tmp_path: Path) -> None:
    inst = TINY["tiny_cluster"]()
    sched = Schedule(
        (make_observation(inst, [0, 1]), make_observation(inst, [2])),
        method="hand",
        params={"x": np.int64(3)},
        seed=4,
        profit=11.0,
    )
    sched.save(tmp_path / "s.json", inst)
    back = load_schedule(tmp_path / "s.json", inst)
    assert back.observations == sched.observations
    assert (back.method, back.seed, back.profit, dict(back.params)) == ("hand", 4, 11.0, {"x": 3})
    data = json.loads((tmp_path / "s.json").read_text())
    assert data["instance"] == inst.fingerprint
    assert data["observations"][0]["opportunities"] == ["o1", "o2"]


def test_schedule_for_another_instance_is_refused(tmp_path: Path) -> None:
    inst = tiny_chain()
    Schedule((make_observation(inst, [0]),)).save(tmp_path / "s.json", inst)
    with pytest.raises(InputError, match="made for another instance"):
        load_schedule(tmp_path / "s.json", tiny_two_orbits())


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (lambda d: d["observations"][0].update(orbit="nope"), "observations[0].orbit"),
        (lambda d: d["observations"][0].update(opportunities=["zz"]), "unknown opportunity"),
        (lambda d: d["observations"][0].update(start="soon"), "observations[0].start"),
        (lambda d: d["observations"][0].pop("roll"), "missing key 'roll'"),
        (lambda d: d.update(observations={}), "observations: expected a list"),
        (lambda d: d.update(seed=1.5), "seed"),
    ],
)
def test_bad_schedules_name_the_row(tmp_path: Path, change, needle: str) -> None:
    inst = tiny_chain()
    d = Schedule((make_observation(inst, [0]),)).to_dict(inst)
    change(d)
    with pytest.raises(InputError) as info:
        Schedule.from_dict(d, inst, source="s.json")
    assert needle in str(info.value)


def test_index_columns_are_int32_and_times_float64(tiny: Instance) -> None:
    assert tiny.opp_target.dtype == np.int32 and tiny.opp_orbit.dtype == np.int32
    for name in ("opp_start", "opp_end", "opp_roll", "opp_roll_min", "opp_roll_max"):
        assert getattr(tiny, name).dtype == np.float64


def test_gzip_files_round_trip_and_large_ones_default_to_columns(
    tmp_path: Path, tiny: Instance, monkeypatch: pytest.MonkeyPatch
) -> None:
    import gzip

    import sosp.instance as si

    gz = tmp_path / "i.json.gz"
    tiny.save(gz)
    raw = gzip.decompress(gz.read_bytes())
    assert load_instance(gz) == tiny
    assert isinstance(json.loads(raw)["opportunities"], list)  # small: records by default
    monkeypatch.setattr(si, "COLUMNS_FROM", 1)
    tiny.save(gz)
    data = json.loads(gzip.decompress(gz.read_bytes()))
    assert isinstance(data["opportunities"], dict)  # columns from COLUMNS_FROM on
    assert load_instance(gz) == tiny
    bad = tmp_path / "bad.json.gz"
    bad.write_bytes(b"not gzip")
    with pytest.raises(InputError, match="bad.json.gz: cannot read"):
        load_instance(bad)


# --------------------------------------------------------------------------- stations (issue 60)
@pytest.fixture(scope="module")
def c1() -> Instance:
    from sosp.scenarios import generate_scenario

    return generate_scenario("C1", 0, hours=3)


def test_no_stations_keeps_the_bytes_and_fingerprint_of_before(tmp_path: Path, c1) -> None:
    """Hashes computed on main before instances carried stations."""
    import hashlib

    assert c1.stations == () and c1.contacts.shape == (0,)
    assert c1.fingerprint == (
        "sha256:3f91ccafcf754170b49c0a9102b2bfb3b4ffc5a3b915e9e0fdb9ee4e7ff48e8a"
    )
    for name, digest in (
        ("c1.json", "0aae2a5d9f65d10e1d130527c8402cb24a8f6be71f31e391a7a3279c49d43078"),
        ("c1.npz", "7fdb97aada3b03cf0f7e89984316e8f4ac1cf0f1c465d2bbd79b97e6261f4746"),
    ):
        c1.save(tmp_path / name)
        assert hashlib.sha256((tmp_path / name).read_bytes()).hexdigest() == digest


@pytest.mark.parametrize("name", ["s.json", "s.npz", "s.json.gz"])
def test_stations_round_trip(tmp_path: Path, c1, name: str) -> None:
    from sosp.stations import builtin_stations

    inst = c1.with_stations(builtin_stations()[:3])
    assert len(inst.contacts) > 0 and set(inst.contacts["station"]) <= {0, 1, 2}
    assert inst.fingerprint != c1.fingerprint
    inst.save(tmp_path / name)
    back = load_instance(tmp_path / name)
    assert back == inst and back.stations == inst.stations
    assert back.contacts.tobytes() == inst.contacts.tobytes()
    assert back.with_stations(()).fingerprint == c1.fingerprint  # schedules cannot tell


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("contacts"), "missing key 'contacts'"),
        (lambda d: d["stations"][0].update(lat_deg=95), "stations[0].lat_deg: must be in"),
        (lambda d: d["stations"][1].update(id=d["stations"][0]["id"]), "stations[1].id: dup"),
        (lambda d: d["stations"][0].update(description=3), "stations[0].description"),
        (lambda d: d["contacts"][0].update(station="XX"), "contacts[0].station: unknown"),
        (lambda d: d["contacts"][0].update(end_s=-1.0), "contacts[0]: need finite start < end"),
    ],
)
def test_bad_stations_in_a_file(c1, edit, message: str) -> None:
    from sosp.stations import builtin_stations

    d = c1.with_stations(builtin_stations()[:2]).to_dict()
    edit(d)
    with pytest.raises(InputError, match=re.escape(message)):
        Instance.from_dict(d)


@pytest.mark.parametrize(
    ("drop", "change", "message"),
    [
        ("contacts.station", None, "missing array 'contacts.station'"),
        ("stations.id", None, "unexpected array 'contacts.end_s'"),
        (None, ("contacts.station", 7), "contacts[0].station: unknown index 7"),
        (None, ("stations.lat_deg", 95.0), "stations[0].lat_deg: must be in [-90, 90]"),
    ],
)
def test_bad_stations_in_a_npz(tmp_path: Path, c1, drop, change, message: str) -> None:
    from sosp.stations import builtin_stations

    arrays = c1.with_stations(builtin_stations()[:2]).to_npz_arrays()
    if drop:
        arrays.pop(drop)
    if change:
        arrays[change[0]] = arrays[change[0]].copy()
        arrays[change[0]][0] = change[1]
    np.savez(tmp_path / "x.npz", **arrays)
    with pytest.raises(InputError, match=re.escape(message)):
        load_instance(tmp_path / "x.npz")
