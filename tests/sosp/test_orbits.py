"""Satellites from TLEs and elements, the Earth-fixed frame and revolutions (skyfield oracle)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sosp.errors import InputError
from sosp.orbits import (
    builtin_satellites,
    element_epoch,
    ephemeris_grids,
    format_epoch,
    from_elements,
    gmst,
    parse_epoch,
    parse_tle,
    propagate,
    read_tle,
    revolutions,
    stale_elements,
    sun_direction_ecef,
    tle_checksum,
    utc_iso,
)

skyfield_api = pytest.importorskip("skyfield.api")
from skyfield.framelib import itrs  # noqa: E402

EPOCH = "2026-06-01T00:00:00Z"
TS = skyfield_api.load.timescale(builtin=True)

L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"
GOOD = f"# comment\nCBERS 2\n{L1}\n{L2}\n\n"


def _with_checksum(line: str) -> str:
    return line[:68] + str(tle_checksum(line))


# ----------------------------------------------------------------------------- TLE parsing


def test_parse_good_tle():
    (sat,) = parse_tle(GOOD, source="x.tle")
    assert sat.name == "CBERS 2" and sat.norad == 28057
    assert sat.satrec.inclo == pytest.approx(math.radians(98.4283))
    assert sat.period / 60 == pytest.approx(1440 / 14.35478080)


def test_name_line_with_zero_prefix_and_trailing_spaces():
    (sat,) = parse_tle(f"0 CBERS 2\n{L1}   \n{L2}\n")
    assert sat.name == "CBERS 2"


def test_checksum_rule():
    assert tle_checksum(L1) == 6 and tle_checksum(L2) == 0


def test_bad_checksum_names_file_and_line():
    bad = L2[:68] + "7"
    with pytest.raises(InputError, match=r"^sats\.tle: line 3: bad checksum"):
        parse_tle(f"CBERS 2\n{L1}\n{bad}\n", source="sats.tle")


def test_wrong_line_length():
    with pytest.raises(InputError, match=r"line 2: TLE line 1 must be 69 characters, got 68"):
        parse_tle(f"CBERS 2\n{L1[:-1]}\n{L2}\n", source="s.tle")


def test_satellite_number_mismatch():
    l2 = _with_checksum(L2[:2] + "28058" + L2[7:])
    with pytest.raises(InputError, match=r"line 3: satellite number '28058' does not match"):
        parse_tle(f"CBERS 2\n{L1}\n{l2}\n")


def test_elements_sgp4_rejects_get_the_one_line_error():
    """Found by fuzzing the TLE file: the error was raised with its source as a positional
    argument, a TypeError (a traceback) instead of the message."""
    # eccentricity field "00008840" shifts the argument of perigee: sgp4 rejects the set
    l2 = _with_checksum(L2[:26] + "00008840 88.1964" + L2[42:])
    with pytest.raises(InputError, match=r"^s\.tle: line 2: sgp4 rejects the elements"):
        parse_tle(f"CBERS 2\n{L1}\n{l2}\n", source="s.tle")


def test_swapped_or_missing_lines():
    with pytest.raises(InputError, match="expected TLE line 1"):
        parse_tle(f"CBERS 2\n{L2}\n{L1}\n")
    with pytest.raises(InputError, match="lacks its two element lines"):
        parse_tle(f"CBERS 2\n{L1}\n")
    with pytest.raises(InputError, match="no satellites"):
        parse_tle("# only a comment\n")
    with pytest.raises(InputError, match="duplicate satellite name"):
        parse_tle(GOOD + GOOD)


def test_read_tle_file(tmp_path):
    p = tmp_path / "two.tle"
    p.write_text(GOOD)
    assert [s.name for s in read_tle(p)] == ["CBERS 2"]
    with pytest.raises(InputError, match="file not found"):
        read_tle(tmp_path / "missing.tle")


def test_two_line_sets_are_named_by_catalogue_number_and_mix_with_three_line_ones():
    # A second satellite: the same elements under another catalogue number.
    m1 = _with_checksum(L1[:2] + "40001" + L1[7:])
    m2 = _with_checksum(L2[:2] + "40001" + L2[7:])
    sats = parse_tle(f"{L1}\n{L2}\n0 OTHER\n{m1}\n{m2}\n{m1}\n{m2}\n")
    assert [s.name for s in sats] == ["28057", "OTHER", "40001"]
    assert [s.norad for s in sats] == [28057, 40001, 40001]
    assert sats[0].tle == (L1, L2) and sats[2].tle == (m1, m2)
    assert sats[0].satrec.inclo == sats[1].satrec.inclo
    with pytest.raises(InputError, match=r"s\.tle: line 3: TLE line 1 lacks its line 2"):
        parse_tle(f"{L1}\n{L2}\n{L1}\n", source="s.tle")
    with pytest.raises(InputError, match="line 3: duplicate satellite name '28057'"):
        parse_tle(f"{L1}\n{L2}\n{L1}\n{L2}\n")


def test_utc_iso_converts_any_offset_and_names_the_field():
    assert utc_iso("2026-06-01T02:30:00+02:00") == "2026-06-01T00:30:00Z"
    assert utc_iso("2026-05-31T20:00:00-04:00") == "2026-06-01T00:00:00Z"
    assert utc_iso("2026-06-01T00:00:00Z") == "2026-06-01T00:00:00Z"
    assert utc_iso("2026-06-01 00:00:00.250") == "2026-06-01T00:00:00.250Z"  # no zone: UTC
    with pytest.raises(InputError, match=r"^--start: not an ISO 8601 time: 'soon'"):
        utc_iso("soon", "--start")


def test_stale_elements_measure_the_longest_propagation():
    (sat,) = parse_tle(GOOD)
    epoch = element_epoch(sat)
    assert epoch == "2006-06-26T18:52:04.080Z"  # day 177.78615833 of 2006
    assert stale_elements([sat], epoch, 24.0) == []
    assert stale_elements([sat], epoch, 24.0 * 3.5) == [("CBERS 2", pytest.approx(3.5))]
    ((name, days),) = stale_elements([sat], "2006-06-20T18:52:04.080Z", 24.0)
    assert name == "CBERS 2" and days == pytest.approx(6.0)
    assert stale_elements([sat], "2006-06-24T18:52:04.080Z", 24.0) == []  # 2 days at most


# ----------------------------------------------------------------------------- elements


def test_from_elements_matches_published_figures():
    sats = {s.name: s for s in builtin_satellites()}
    assert list(sats) == ["JB-3A", "JB-3C", "CBERS-1", "CBERS-2"]
    assert sats["CBERS-1"].period / 60 == pytest.approx(100.26, abs=0.01)
    assert sats["JB-3A"].period / 60 == pytest.approx(94.4, abs=0.01)
    # altitudes from the propagated states: CBERS ~778 km, JB-3A 490-493 km (+- J2 terms)
    grids = ephemeris_grids(list(sats.values()), EPOCH, 0.0, 6000.0, 60.0)
    alt = {n: np.linalg.norm(g.r, axis=1) - 6371.0 for n, g in zip(sats, grids, strict=True)}
    assert 740 < alt["CBERS-1"].mean() < 800
    assert 460 < alt["JB-3A"].mean() < 520


def test_from_elements_rejects_bad_values():
    kw = dict(epoch=EPOCH, inclination=98.0, raan=0.0, arg_perigee=0.0, mean_anomaly=0.0)
    with pytest.raises(InputError, match="eccentricity"):
        from_elements("S", eccentricity=1.2, mean_motion=14.0, **kw)
    with pytest.raises(InputError, match="mean motion"):
        from_elements("S", eccentricity=0.0, mean_motion=-1.0, **kw)


def test_sun_synchronous_node_times():
    """CBERS-1's descending node is at 10:30 local mean time (the published figure)."""
    (sat,) = builtin_satellites(["CBERS-1"])
    grid = ephemeris_grids([sat], EPOCH, 0.0, 7000.0, 10.0)[0]
    z = grid.r[:, 2]
    i = np.flatnonzero((z[:-1] > 0) & (z[1:] <= 0))[0]  # descending node
    t = grid.t0 + grid.step * (i + z[i] / (z[i] - z[i + 1]))
    r, _, _ = grid.state(np.array([t]))
    lon = math.degrees(math.atan2(r[0, 1], r[0, 0]))
    local_mean_time = (t / 3600.0 + lon / 15.0) % 24.0
    assert local_mean_time == pytest.approx(10.5, abs=0.1)


# ----------------------------------------------------------------------------- frames


def test_epoch_round_trip():
    jd, fr = parse_epoch("2026-06-01T06:00:00Z")
    assert jd + fr == pytest.approx(2461192.75)
    assert format_epoch(jd, fr) == "2026-06-01T06:00:00Z"
    with pytest.raises(InputError):
        parse_epoch("yesterday")


def test_gmst_matches_skyfield():
    t = TS.utc(2026, 6, 1, 0, 0, [0.0, 3600.0, 50000.0])
    from skyfield.sgp4lib import theta_GMST1982

    ref, _ = theta_GMST1982(t.whole, t.ut1_fraction)
    jd, fr = parse_epoch(EPOCH)
    ours, _ = gmst(jd, fr + np.array([0.0, 3600.0, 50000.0]) / 86400.0)
    # UT1 - UTC (0.03 s) is the only difference: 0.03 s * 7.3e-5 rad/s
    assert np.allclose(ours, ref, atol=5e-6)


def test_earth_fixed_states_match_skyfield():
    sats = builtin_satellites()
    t = np.array([0.0, 1234.5, 43210.0, 86000.0])
    r, v = propagate(sats, EPOCH, t)
    for i, sat in enumerate(sats):
        es = skyfield_api.EarthSatellite.from_satrec(sat.satrec, TS)
        rr, vv = es.at(TS.utc(2026, 6, 1, 0, 0, t)).frame_xyz_and_velocity(itrs)
        # 0.03 s of Earth rotation is < 20 m; precession-nutation models differ by metres.
        assert np.abs(r[i] - rr.km.T).max() < 0.05
        assert np.abs(v[i] - vv.km_per_s.T).max() < 1e-4


def test_sun_direction_declination():
    jd, fr = parse_epoch("2026-06-21T08:24:00Z")  # June solstice 2026
    s = sun_direction_ecef(jd, fr)
    assert math.degrees(math.asin(s[2])) == pytest.approx(23.44, abs=0.02)
    jd, fr = parse_epoch("2026-03-20T14:46:00Z")  # March equinox
    s = sun_direction_ecef(jd, fr)
    assert abs(math.degrees(math.asin(s[2]))) < 0.02
    # At 12:00 UTC the Sun is near longitude 0 (equation of time: minutes)
    jd, fr = parse_epoch("2026-06-01T12:00:00Z")
    s = sun_direction_ecef(jd, fr)
    assert abs(math.degrees(math.atan2(s[1], s[0]))) < 1.0


# ----------------------------------------------------------------------------- revolutions


def _skyfield_ascending_nodes(sat, t_end: float) -> np.ndarray:
    es = skyfield_api.EarthSatellite.from_satrec(sat.satrec, TS)
    t = np.arange(0.0, t_end, 30.0)
    z = es.at(TS.utc(2026, 6, 1, 0, 0, t)).frame_xyz(itrs).km[2]
    out = []
    for i in np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0)):
        lo, hi = t[i], t[i + 1]
        for _ in range(40):  # bisection, independent of sosp's Newton refinement
            mid = 0.5 * (lo + hi)
            zm = es.at(TS.utc(2026, 6, 1, 0, 0, mid)).frame_xyz(itrs).km[2]
            lo, hi = (mid, hi) if zm < 0 else (lo, mid)
        out.append(0.5 * (lo + hi))
    return np.array(out)


def test_revolutions_numbered_from_ascending_nodes():
    sats = builtin_satellites()
    horizon = (0.0, 86400.0)
    grids = ephemeris_grids(sats, EPOCH, -600.0, 87000.0, 20.0)
    revs = revolutions(sats, grids, horizon)
    for s, sat in enumerate(sats):
        rows = np.flatnonzero(revs.satellite == s)
        ids = [revs.ids[j] for j in rows]
        assert ids[0] == f"{sat.name}#000"
        assert ids == [f"{sat.name}#{k:03d}" for k in range(len(ids))]
        assert np.array_equal(revs.number[rows], np.arange(len(rows)))
        starts, ends = revs.start[rows], revs.end[rows]
        assert starts[0] == 0.0 and ends[-1] == 86400.0
        assert np.array_equal(starts[1:], ends[:-1])
        # full revolutions last one nodal period (J2 makes it differ slightly from 2 pi / n)
        assert np.allclose(np.diff(starts[1:]), sat.period, rtol=2e-3)
        # ~14-15 revolutions per day plus the partial ones
        assert abs(len(rows) - 1 - 86400.0 / sat.period) < 1.0
        nodes = _skyfield_ascending_nodes(sat, 86400.0)
        assert len(nodes) == len(rows) - 1
        assert np.abs(nodes - starts[1:]).max() < 0.05


def test_horizon_starting_on_a_node_has_no_empty_revolution():
    sats = builtin_satellites(["CBERS-2"])
    grids = ephemeris_grids(sats, EPOCH, -600.0, 20000.0, 20.0)
    node = revolutions(sats, grids, (0.0, 15000.0)).start[1]
    revs = revolutions(sats, grids, (node, node + 10000.0))
    assert revs.ids[0] == "CBERS-2#001"
    assert np.all(revs.end > revs.start)


def test_revolution_wrapper_on_decayed_state_is_nan_not_crash():
    sat = from_elements(
        "LOW",
        epoch=EPOCH,
        inclination=51.6,
        raan=0.0,
        eccentricity=0.0,
        arg_perigee=0.0,
        mean_anomaly=0.0,
        mean_motion=16.4,
        bstar=0.5,
    )
    r, _ = propagate([sat], EPOCH, np.array([0.0, 30 * 86400.0]))
    assert np.isfinite(r[0, 0]).all()
    assert np.isnan(r[0, 1]).all()
