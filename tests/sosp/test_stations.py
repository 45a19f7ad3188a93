"""Ground stations: the CSV reader, the built-in list, ``--stations`` text and contact
windows checked against skyfield's own rise and set search (``EarthSatellite.find_events``)."""

from __future__ import annotations

import csv
from importlib import resources as importlib_resources

import numpy as np
import pytest

from sosp.errors import InputError
from sosp.orbits import builtin_satellites
from sosp.stations import (
    Station,
    builtin_stations,
    contact_windows,
    read_stations,
    stations_from_arg,
)

skyfield_api = pytest.importorskip("skyfield.api")

EPOCH = "2026-06-01T00:00:00Z"
TS = skyfield_api.load.timescale(builtin=True)
HEADER = "id,lat_deg,lon_deg,alt_m,min_elevation_deg,antennas,description"
GOOD = f"# a comment\n{HEADER}\nA,10.5,-20,100,5,1,first\nB,-45,350,-20,10.5,3,\n"


def test_reads_a_good_file(tmp_path):
    path = tmp_path / "st.csv"
    path.write_text(GOOD)
    a, b = read_stations(path)
    assert a == Station("A", 10.5, -20.0, 100.0, 5.0, 1, "first")
    assert b == Station("B", -45.0, 350.0, -20.0, 10.5, 3, "")
    assert isinstance(b.antennas, int)
    with pytest.raises(AttributeError):  # immutable
        a.lat_deg = 0.0  # type: ignore[misc]


@pytest.mark.parametrize(
    "row, message",
    [
        ("B,95,0,0,5,1,x", "line 4: lat_deg must be in [-90, 90], got '95'"),
        ("B,0,400,0,5,1,x", "line 4: lon_deg must be"),
        ("B,0,0,-600,5,1,x", "line 4: alt_m must be in [-500, 10000]"),
        ("B,0,0,0,90,1,x", "line 4: min_elevation_deg must be in [0, 90)"),
        ("B,0,0,0,-1,1,x", "line 4: min_elevation_deg must be"),
        ("B,0,0,0,5,0,x", "line 4: antennas must be a positive integer, got '0'"),
        ("B,0,0,0,5,-2,x", "line 4: antennas must be a positive integer"),
        ("B,0,0,0,5,1.5,x", "line 4: antennas must be a positive integer"),
        ("B,north,0,0,5,1,x", "line 4: lat_deg is not a number: 'north'"),
        ("B,nan,0,0,5,1,x", "line 4: lat_deg must be"),
        ("B,0,,0,5,1,x", "line 4: lon_deg is not a number: ''"),
        ("A,0,0,0,5,1,x", "line 4: duplicate id 'A' (first on line 3)"),
        (",0,0,0,5,1,x", "line 4: empty id"),
        ("B,0,0,0,5,1", "line 4: expected 7 fields, got 6"),
    ],
)
def test_bad_rows_name_file_line_and_field(tmp_path, row, message):
    path = tmp_path / "st.csv"
    path.write_text(f"# a comment\n{HEADER}\nA,10,20,0,5,1,x\n{row}\n")
    with pytest.raises(InputError) as err:
        read_stations(path)
    assert str(err.value).startswith(f"{path}: {message}")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "id,lat_deg,lon_deg,alt_m,min_elevation_deg\nA,0,0,0,5\n",
            "line 1: header lacks antennas",
        ),
        ("# only a comment\n", "empty file"),
        (HEADER + "\n", "no stations after the header"),
    ],
)
def test_bad_files(tmp_path, text, message):
    path = tmp_path / "st.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_stations(path)
    with pytest.raises(InputError, match="file not found"):
        read_stations(tmp_path / "missing.csv")


def test_builtin_stations_are_real_cited_and_in_range():
    stations = builtin_stations()
    ids = [s.id for s in stations]
    assert len(stations) >= 11 and len(set(ids)) == len(ids)
    assert {"SG", "KIR", "INU", "FBK", "MCM", "TRL", "HBK", "SAN", "MIY", "KSH", "SYA"} <= set(ids)
    for s in stations:
        assert -90 <= s.lat_deg <= 90 and -180 <= s.lon_deg <= 180 and -500 <= s.alt_m < 5000
        assert 0 <= s.min_elevation_deg < 90 and s.antennas >= 1 and s.description
    ref = importlib_resources.files("sosp").joinpath("data", "stations.csv")
    lines = ref.read_text("utf-8").splitlines()
    assert any("Where the numbers come from" in line for line in lines if line.startswith("#"))
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    assert [r["id"] for r in rows] == ids and all(len(r["source"]) > 20 for r in rows)


def test_stations_from_arg(tmp_path):
    assert stations_from_arg("builtin") == builtin_stations()
    by_id = {s.id: s for s in builtin_stations()}
    assert stations_from_arg("TRL, SG") == (by_id["TRL"], by_id["SG"])
    path = tmp_path / "mine.txt"
    path.write_text(GOOD)
    assert [s.id for s in stations_from_arg(str(path))] == ["A", "B"]
    with pytest.raises(InputError, match="file not found"):
        stations_from_arg(str(tmp_path / "missing.csv"))
    with pytest.raises(InputError) as err:
        stations_from_arg("SG,XYZ")
    assert "unknown built-in station 'XYZ'" in str(err.value)
    assert "known: " + ", ".join(by_id) in str(err.value)
    with pytest.raises(InputError, match="repeated built-in station 'SG'"):
        stations_from_arg("SG,KIR,SG")


# ---------------------------------------------------------------------------- contacts


def _skyfield_windows(sat, station: Station, hours: float) -> np.ndarray:
    """(start, end) seconds of every pass above the mask, from skyfield alone; a pass
    across an end of the horizon is clipped to it."""
    t0, t1 = TS.utc(2026, 6, 1), TS.utc(2026, 6, 1, hours)
    where = skyfield_api.wgs84.latlon(station.lat_deg, station.lon_deg, station.alt_m)
    esat = skyfield_api.EarthSatellite.from_satrec(sat.satrec, TS)
    times, events = esat.find_events(where, t0, t1, altitude_degrees=station.min_elevation_deg)
    seconds = (times - t0) * 86400.0
    starts = [s for s, e in zip(seconds, events, strict=True) if e == 0]
    ends = [s for s, e in zip(seconds, events, strict=True) if e == 2]
    if events.size and events[events != 1][0] == 2:
        starts.insert(0, 0.0)
    if events.size and events[events != 1][-1] == 0:
        ends.append(hours * 3600.0)
    return np.array([starts, ends]).T.reshape(-1, 2)


def _check_against_skyfield(sats, stations, hours: float) -> float:
    """Assert the same windows as skyfield within 1 s at each end; the largest difference."""
    got = contact_windows(sats, stations, EPOCH, 0.0, hours * 3600.0)
    worst = 0.0
    for i, sat in enumerate(sats):
        for j, station in enumerate(stations):
            rows = got[(got["satellite"] == i) & (got["station"] == j)]
            ref = _skyfield_windows(sat, station, hours)
            assert len(rows) == len(ref), (sat.name, station.id)
            diff = np.abs(np.stack([rows["start_s"], rows["end_s"]], axis=1) - ref)
            worst = max(worst, float(diff.max(initial=0.0)))
    assert worst < 1.0
    return worst


def test_contacts_match_skyfield():
    sats = builtin_satellites(["CBERS-2", "JB-3A"])
    by_id = {s.id: s for s in builtin_stations()}
    stations = [by_id["SG"], by_id["HBK"], by_id["MIY"]]
    got = contact_windows(sats, stations, EPOCH, 0.0, 86400.0)
    assert len(got) > 20 and set(got["station"]) == {0, 1, 2}
    assert np.all(got["end_s"] > got["start_s"])
    assert np.all((got["max_elevation_deg"] >= 5.0) & (got["max_elevation_deg"] <= 90.0))
    _check_against_skyfield(sats, stations, 24.0)


def test_contacts_high_mask_polar_station_and_horizon_cut():
    """A 40 degree mask over Troll (few, short passes) and a horizon that starts and ends
    inside passes."""
    sats = builtin_satellites(["CBERS-1", "JB-3C"])
    by_id = {s.id: s for s in builtin_stations()}
    troll = Station("TRL40", by_id["TRL"].lat_deg, by_id["TRL"].lon_deg, 1270.0, 40.0)
    _check_against_skyfield(sats, [troll, by_id["MCM"]], 24.0)
    got = contact_windows(sats, [by_id["SG"]], EPOCH, 0.0, 86400.0)
    cut = got[1]["start_s"] + 60.0, got[3]["end_s"] - 60.0  # inside passes 1 and 3
    part = contact_windows(sats, [by_id["SG"]], EPOCH, *cut)
    assert part[0]["start_s"] == cut[0] and part[part["satellite"] == 0][-1]["end_s"] == cut[1]


def test_a_coarse_step_finds_the_same_windows():
    """Passes between samples are found from the samples' local maxima."""
    sats = builtin_satellites(["CBERS-2"])
    stations = [Station("HI", -72.0, 2.5, 0.0, 60.0), Station("LOW", 40.0, 116.0)]
    fine = contact_windows(sats, stations, EPOCH, 0.0, 86400.0)
    coarse = contact_windows(sats, stations, EPOCH, 0.0, 86400.0, step_s=120.0)
    assert len(fine) == len(coarse) > 0
    for key in ("start_s", "end_s", "max_elevation_deg"):
        assert np.allclose(fine[key], coarse[key], atol=1e-3)
    cell = np.floor((fine["start_s"] + 120.0) / 120.0)  # the samples are at -120 + 120 k s
    assert np.any(cell == np.floor((fine["end_s"] + 120.0) / 120.0))  # a pass between two
    with pytest.raises(InputError, match="horizon"):
        contact_windows(sats, stations, EPOCH, 10.0, 10.0)
