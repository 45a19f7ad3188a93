"""Schedule files carry UTC times; ``sosp export`` writes CSV, KML and CZML a planner's tools
read (checked against the schedule and instance, not against stored output)."""

from __future__ import annotations

import csv
import io
import json
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

from sosp.errors import InputError
from sosp.export import CSV_COLUMNS, export_csv, export_czml, export_kml
from sosp.instance import Instance
from sosp.orbits import instance_satellites, utc_at
from sosp.scenarios import custom_scenario, generate_scenario
from sosp.schedule import Schedule, load_schedule, make_observation
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import tiny_cluster, tiny_two_orbits

KML = "{http://www.opengis.net/kml/2.2}"
L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"


def clock(inst: Instance, seconds: float) -> str:
    """Oracle: the UTC time ``seconds`` after the epoch, by datetime arithmetic."""
    epoch = datetime.fromisoformat(inst.epoch.replace("Z", "+00:00"))
    at = epoch + timedelta(milliseconds=round(seconds * 1000))
    text = at.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%S")
    return text + (f".{at.microsecond // 1000:03d}Z" if at.microsecond else "Z")


@pytest.fixture(scope="module")
def c1() -> tuple[Instance, Schedule]:
    inst = generate_scenario("C1", hours=4)
    return inst, solve(inst, "greedy").schedule


@pytest.fixture
def cluster() -> tuple[Instance, Schedule]:
    inst = tiny_cluster()  # a and b in one opening, c alone: 3 targets, 2 observations
    return inst, Schedule((make_observation(inst, [0, 1]), make_observation(inst, [2])))


# --------------------------------------------------------------------------- schedule files
def test_schedule_file_carries_utc_times(cluster) -> None:
    inst, sched = cluster
    data = sched.to_dict(inst)
    for rec, ob in zip(data["observations"], sched.observations, strict=True):
        assert rec["start_utc"] == clock(inst, ob.start)
        assert rec["end_utc"] == clock(inst, ob.end)
    assert Schedule.from_dict(data, inst).observations == sched.observations


def test_old_schedule_files_without_utc_still_load(cluster, tmp_path: Path) -> None:
    inst, sched = cluster
    data = sched.to_dict(inst)
    for rec in data["observations"]:
        del rec["start_utc"], rec["end_utc"]
    (tmp_path / "old.json").write_text(json.dumps(data))
    assert load_schedule(tmp_path / "old.json", inst).observations == sched.observations


@pytest.mark.parametrize(
    ("value", "message"),
    [("2026-06-01T01:00:00Z", "disagrees with start"), ("noon", "not an ISO 8601 time")],
)
def test_utc_time_contradicting_the_seconds_is_refused(cluster, value, message) -> None:
    inst, sched = cluster
    data = sched.to_dict(inst)
    data["observations"][1]["start_utc"] = value
    with pytest.raises(InputError, match=rf"^s\.json: observations\[1\]\.start_utc: .*{message}"):
        Schedule.from_dict(data, inst, source="s.json")


@pytest.mark.parametrize("seconds", [1e300, -1e15, 10**20])
def test_a_time_outside_the_calendar_gets_the_one_line_error(cluster, seconds) -> None:
    """A damaged file's start (found by fuzzing: 1e300) once raised OverflowError while the
    error about it was being written."""
    inst, sched = cluster
    data = sched.to_dict(inst)
    data["observations"][1]["start"] = seconds
    with pytest.raises(InputError, match=r"^s\.json: observations\[1\]\.start_utc: .*disagrees"):
        Schedule.from_dict(data, inst, source="s.json")


def test_utc_at_writes_any_year_of_the_calendar_in_full() -> None:
    epoch = "2026-06-01T00:00:00Z"
    assert utc_at(epoch, 86400.5) == "2026-06-02T00:00:00.500Z"
    assert utc_at(epoch, -2000 * 365 * 86400) == "0027-09-29T00:00:00Z"
    assert utc_at(epoch, 1e300) == "2026-06-01T00:00:00Z +1e+300 s"


# --------------------------------------------------------------------------- CSV
def test_csv_one_row_per_covered_target(c1) -> None:
    inst, sched = c1
    rows = list(csv.DictReader(io.StringIO(export_csv(inst, sched))))
    assert tuple(rows[0]) == CSV_COLUMNS
    covered = {
        inst.target_ids[int(inst.opp_target[i])]: ob for ob in sched.observations for i in ob.opps
    }
    assert sorted(r["target"] for r in rows) == sorted(covered)
    assert sum(int(r["weight"]) for r in rows) == validate(inst, sched).profit
    assert [r["start_utc"] for r in rows] == sorted(r["start_utc"] for r in rows)
    for r in rows:
        ob = covered[r["target"]]
        k = inst.target_ids.index(r["target"])
        assert r["orbit"] == inst.orbit_ids[ob.orbit]
        assert r["satellite"] == inst.orbit_satellite[ob.orbit]
        assert (r["start_utc"], r["end_utc"]) == (clock(inst, ob.start), clock(inst, ob.end))
        assert float(r["roll_deg"]) == pytest.approx(ob.roll, abs=1e-4)
        assert float(r["lat"]) == pytest.approx(inst.target_lat[k], abs=1e-6)


def test_csv_cluster_task_gives_a_row_per_target(cluster) -> None:
    inst, sched = cluster
    rows = list(csv.DictReader(io.StringIO(export_csv(inst, sched))))
    assert [r["target"] for r in rows] == ["a", "b", "c"]
    assert rows[0]["observation"] == rows[1]["observation"] != rows[2]["observation"]


# --------------------------------------------------------------------------- KML
def _folders(root: ET.Element) -> dict[str, ET.Element]:
    return {f.find(f"{KML}name").text.split(" (")[0]: f for f in root.iter(f"{KML}Folder")}


def test_kml_targets_observed_and_not_windows_and_paths(c1) -> None:
    inst, sched = c1
    root = ET.fromstring(export_kml(inst, sched))
    folders = _folders(root)
    marks = folders["targets observed"].findall(f"{KML}Placemark")
    missed = folders["targets not observed"].findall(f"{KML}Placemark")
    covered = {inst.target_ids[int(inst.opp_target[i])] for i in sched.observed_opps()}
    assert {m.find(f"{KML}name").text for m in marks} == covered
    assert len(missed) == inst.n_targets - len(covered)
    spans = [
        (p.find(f"{KML}TimeSpan/{KML}begin").text, p.find(f"{KML}TimeSpan/{KML}end").text)
        for p in folders["observations"].findall(f"{KML}Placemark")
    ]
    assert spans == [(clock(inst, o.start), clock(inst, o.end)) for o in sched.observations]
    paths = folders["satellite paths"].findall(f"{KML}Placemark")
    assert sorted(p.find(f"{KML}name").text for p in paths) == sorted(set(inst.orbit_satellite))
    for p in paths:
        for ls in p.iter(f"{KML}LineString"):
            lons = [float(c.split(",")[0]) for c in ls.find(f"{KML}coordinates").text.split()]
            assert all(-180 <= x <= 180 for x in lons)
            assert max(abs(a - b) for a, b in zip(lons, lons[1:], strict=False)) < 180


def test_kml_without_recorded_orbits_has_no_paths(cluster) -> None:
    inst, sched = cluster
    assert instance_satellites(inst) is None
    folders = _folders(ET.fromstring(export_kml(inst, sched)))
    assert "satellite paths" not in folders
    assert len(folders["targets observed"].findall(f"{KML}Placemark")) == 3


# --------------------------------------------------------------------------- CZML
def test_czml_packets(c1) -> None:
    inst, sched = c1
    packets = json.loads(export_czml(inst, sched))
    assert packets[0]["id"] == "document" and packets[0]["version"] == "1.0"
    ids = [p["id"] for p in packets]
    assert len(ids) == len(set(ids))
    targets = [p for p in packets if p["id"].startswith("target/")]
    assert len(targets) == inst.n_targets
    covered = {inst.target_ids[int(inst.opp_target[i])] for i in sched.observed_opps()}
    assert {p["name"] for p in targets if p["properties"]["observed"]} == covered
    obs = [p for p in packets if p["id"].startswith("observation/")]
    assert [p["availability"] for p in obs] == [
        f"{clock(inst, o.start)}/{clock(inst, o.end)}" for o in sched.observations
    ]
    assert all("polyline" in p for p in obs)  # lines of sight: the orbits are known
    sats = [p for p in packets if p["id"].startswith("satellite/")]
    assert sorted(p["name"] for p in sats) == sorted(set(inst.orbit_satellite))
    for p in sats:
        samples = p["position"]["cartographicDegrees"]
        assert len(samples) % 4 == 0 and samples[0] == pytest.approx(inst.orbit_start.min())
        alt_km = [a / 1000 for a in samples[3::4]]
        assert 400 < min(alt_km) and max(alt_km) < 1000  # low Earth orbits


def test_tle_instances_record_their_orbits_for_the_paths(tmp_path: Path) -> None:
    tle = tmp_path / "s.tle"
    tle.write_text(f"{L1}\n{L2}\n")
    inst = custom_scenario(region=(40, 45, 10, 20), count=10, satellites=tle, hours=3)
    sats = instance_satellites(inst)
    assert [s.name for s in sats] == ["28057"] and sats[0].tle == (L1, L2)
    packets = json.loads(export_czml(inst, Schedule()))
    assert [p["id"] for p in packets if p["id"].startswith("satellite/")] == ["satellite/28057"]


# --------------------------------------------------------------------------- CLI
def _sosp(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    exe = shutil.which("sosp", path=str(Path(sys.executable).parent)) or shutil.which("sosp")
    cmd = [exe] if exe else [sys.executable, "-m", "sosp"]
    return subprocess.run(cmd + list(argv), capture_output=True, text=True, cwd=cwd, timeout=120)


def test_cli_export_by_extension_or_format(tmp_path: Path) -> None:
    inst = tiny_two_orbits()
    inst.save(tmp_path / "i.json")
    Schedule((make_observation(inst, [0]),)).save(tmp_path / "s.json", inst)
    for out, extra in (
        ("a.csv", []),
        ("b.kml", []),
        ("c.czml", []),
        ("d.txt", ["--format", "kml"]),
    ):
        proc = _sosp("export", "i.json", "s.json", "-o", out, *extra, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "a.csv").read_text().splitlines()[1].split(",")[6] == "a"
    ET.fromstring((tmp_path / "d.txt").read_text())
    json.loads((tmp_path / "c.czml").read_text())


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["-o", "e.txt"], "-o: cannot tell the format"),
        (["-o", "e.csv", "--format", "gpx"], "--format"),
        (["-o", "adir"], "-o: adir is a folder"),
        (["-o", "nope/e.csv"], "-o: folder does not exist"),
    ],
)
def test_cli_export_bad_input(tmp_path: Path, argv: list[str], needle: str) -> None:
    inst = tiny_two_orbits()
    inst.save(tmp_path / "i.json")
    Schedule((make_observation(inst, [0]),)).save(tmp_path / "s.json", inst)
    (tmp_path / "adir").mkdir()
    before = sorted(p.name for p in tmp_path.rglob("*"))
    proc = _sosp("export", "i.json", "s.json", *argv, cwd=tmp_path)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith("error: ") and needle in proc.stderr, proc.stderr
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_czml_numbers_at_the_precision_of_the_data(c1) -> None:
    """Issue 63, item 13: 1.7731 is written as 1.7731, not 1.7730999999999995."""
    import re

    text = export_czml(*c1)
    assert not re.search(r"\d\.\d{7,}", text), re.search(r"\S*\d\.\d{7,}", text)[0]
    json.loads(text)


# --------------------------------------------------------------------------- ground stations
@pytest.fixture(scope="module")
def c1s(c1) -> tuple[Instance, Schedule]:
    """C1 with three stations and a schedule whose downlinks the validator accepts."""
    from sosp.stations import builtin_stations

    inst = c1[0].with_stations([s for s in builtin_stations() if s.id in ("SG", "MIY", "KSH")])
    sched = solve(inst, "greedy").schedule
    assert validate(inst, sched).feasible and sched.downlinks and len(inst.contacts)
    return inst, sched


def _whose(inst: Instance, d) -> dict[str, float]:
    return {str(inst.target_ids[int(inst.opp_target[i])]): v for i, v in d.parts}


def test_exports_without_stations_have_no_station_parts(c1) -> None:
    inst, sched = c1
    assert export_csv(inst, sched).splitlines()[0] == ",".join(CSV_COLUMNS)
    assert not {"ground stations", "downlinks"} & set(
        _folders(ET.fromstring(export_kml(inst, sched)))
    )
    ids = [p["id"] for p in json.loads(export_czml(inst, sched))]
    assert not [i for i in ids if i.split("/")[0] in ("station", "contact", "downlink")]


def test_csv_rows_of_each_downlink_after_the_unchanged_observation_rows(c1s) -> None:
    inst, sched = c1s
    rows = list(csv.DictReader(io.StringIO(export_csv(inst, sched))))
    assert tuple(rows[0]) == CSV_COLUMNS + ("kind", "station", "volume", "data")
    obs = [r for r in rows if r["kind"] == "observation"]
    plain = list(csv.DictReader(io.StringIO(export_csv(inst.without_stations(), sched))))
    assert [{k: r[k] for k in CSV_COLUMNS} for r in obs] == plain  # same rows, same order
    down = [r for r in rows if r["kind"] == "downlink"]
    assert rows[len(obs) :] == down and len(down) == len(sched.downlinks)
    want = sorted(sched.downlinks, key=lambda d: (d.start, d.satellite))
    for r, d in zip(down, want, strict=True):
        st = inst.stations[d.station]
        assert (r["satellite"], r["station"]) == (inst.satellite_names[d.satellite], st.id)
        assert (r["start_utc"], r["end_utc"]) == (clock(inst, d.start), clock(inst, d.end))
        assert float(r["lat"]) == pytest.approx(st.lat_deg, abs=1e-6)
        assert float(r["volume"]) == pytest.approx(d.volume, rel=1e-5)
        got = dict(p.split("=") for p in r["data"].split(";"))
        assert {k: float(v) for k, v in got.items()} == pytest.approx(_whose(inst, d), rel=1e-5)
        j = inst.orbit_ids.index(r["orbit"])
        assert inst.orbit_start[j] <= d.start < inst.orbit_end[j]


def test_kml_stations_contacts_and_downlinks_with_time_spans(c1s) -> None:
    inst, sched = c1s
    folders = _folders(ET.fromstring(export_kml(inst, sched)))
    marks = folders["ground stations"].findall(f"{KML}Placemark")
    assert [m.find(f"{KML}name").text for m in marks] == [s.id for s in inst.stations]
    for m, st in zip(marks, inst.stations, strict=True):
        lon, lat, _ = map(float, m.find(f"{KML}Point/{KML}coordinates").text.split(","))
        assert (lat, lon) == pytest.approx((st.lat_deg, st.lon_deg), abs=1e-6)

    def spans(folder: str) -> list[tuple[str, str]]:
        return [
            (p.find(f"{KML}TimeSpan/{KML}begin").text, p.find(f"{KML}TimeSpan/{KML}end").text)
            for p in folders[folder].findall(f"{KML}Placemark")
        ]

    con = inst.contacts
    assert spans("contact windows") == [
        (clock(inst, a), clock(inst, b)) for a, b in zip(con["start_s"], con["end_s"], strict=True)
    ]
    assert spans("downlinks") == [
        (clock(inst, d.start), clock(inst, d.end)) for d in sched.downlinks
    ]
    for p in folders["downlinks"].findall(f"{KML}Placemark"):  # satellite to station
        line = p.find(f"{KML}LineString/{KML}coordinates").text.split()
        assert len(line) == 2 and float(line[0].split(",")[2]) > 300e3


def test_czml_stations_and_a_link_while_each_downlink_is_on(c1s) -> None:
    inst, sched = c1s
    packets = json.loads(export_czml(inst, sched))
    by_id = {p["id"]: p for p in packets}
    assert len(by_id) == len(packets)
    for st in inst.stations:
        lon, lat, alt = by_id[f"station/{st.id}"]["position"]["cartographicDegrees"]
        assert (lat, lon, alt) == pytest.approx((st.lat_deg, st.lon_deg, st.alt_m), abs=1e-6)
    contacts = [p for p in packets if p["id"].startswith("contact/")]
    assert len(contacts) == len(inst.contacts)
    down = [by_id[f"downlink/{n}"] for n in range(len(sched.downlinks))]
    for p, d in zip(down, sched.downlinks, strict=True):
        assert p["availability"] == f"{clock(inst, d.start)}/{clock(inst, d.end)}"
        assert p["properties"]["volume"] == pytest.approx(d.volume, rel=1e-6)
        got = {x["target"]: x["volume"] for x in p["properties"]["data"]}
        assert got == pytest.approx(_whose(inst, d), rel=1e-6)
    for p in contacts + down:  # the link follows both ends: they exist and have positions
        refs = p["polyline"]["positions"]["references"]
        sat, st = (r.removesuffix("#position") for r in refs)
        assert sat == f"satellite/{p['properties']['satellite']}"
        assert st == f"station/{p['properties']['station']}"
        assert "position" in by_id[sat] and "position" in by_id[st]
