"""Scenario generator: determinism, the paper's recipe, provenance, custom inputs, CSV errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sosp.errors import InputError
from sosp.instance import Resources
from sosp.scenarios import (
    DEFAULT_START,
    REGIONS,
    custom_scenario,
    generate_scenario,
    random_targets,
    read_targets_csv,
    scenario_names,
)

L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"


@pytest.fixture(scope="module")
def c2():
    return generate_scenario("C2")


def test_names():
    names = scenario_names()
    assert names[0] == "B1" and names[-1] == "C10" and len(names) == 20
    for bad in ("A1", "B0", "B11", "C01", "B", "", "c1"):
        with pytest.raises(InputError, match="unknown name"):
            generate_scenario(bad)


def test_paper_recipe(c2):
    assert c2.name == "C2" and c2.epoch == DEFAULT_START
    assert c2.n_targets == 200
    assert c2.target_ids[0] == "T0001" and c2.target_ids[-1] == "T0200"
    lat0, lat1, lon0, lon1 = REGIONS["C"]
    assert np.all((c2.target_lat >= lat0) & (c2.target_lat <= lat1))
    assert np.all((c2.target_lon >= lon0) & (c2.target_lon <= lon1))
    assert c2.target_weight.min() >= 2 and c2.target_weight.max() <= 10
    assert set(np.unique(c2.target_weight)) == set(range(2, 11))  # inclusive ends, 200 draws
    # four satellites, ~14-15 revolutions each in 24 h (+ partial ones at the edges)
    assert set(c2.orbit_satellite) == {"JB-3A", "JB-3C", "CBERS-1", "CBERS-2"}
    assert 58 <= c2.n_orbits <= 68
    assert c2.orbit_start.min() == 0.0 and c2.orbit_end.max() == 86400.0
    # Table 1
    assert np.all(c2.energy_capacity == 1500.0) and np.all(c2.max_openings == 10)
    assert np.all(c2.max_duration == 120.0)
    # opportunities: roll ranges within +-33, widths <= 6, windows of a few seconds
    assert c2.n_opps > c2.n_targets
    assert np.all(c2.opp_roll_min >= -33.0) and np.all(c2.opp_roll_max <= 33.0)
    assert np.all(c2.opp_roll_max - c2.opp_roll_min <= 6.0 + 1e-9)
    assert np.all(c2.opp_end - c2.opp_start < 17.0)


def test_meta_records_provenance(c2):
    m = c2.meta
    assert m["generator"] == "sosp.scenarios"
    assert m["scenario"] == "C2" and m["seed"] == 0
    assert m["satellites"] == ["JB-3A", "JB-3C", "CBERS-1", "CBERS-2"]
    assert m["max_roll"] == 33.0 and m["fov"] == 6.0 and m["min_sun_elevation"] is None


def test_opportunity_ids_name_target_and_orbit(c2):
    for i in range(0, c2.n_opps, 50):
        tid, oid = c2.opp_ids[i].split("@")
        assert tid == c2.target_ids[c2.opp_target[i]]
        assert oid == c2.orbit_ids[c2.opp_orbit[i]]


def test_save_load_round_trip_and_a_validated_schedule(c2, tmp_path):
    from sosp import load_instance, solve, validate

    p = tmp_path / "c2.json"
    c2.save(p)
    back = load_instance(p)
    assert back == c2 and back.meta["scenario"] == "C2"
    result = solve(c2, method="greedy", seed=0)
    report = validate(c2, result.schedule)
    assert report.feasible and report.profit > 0


def test_deterministic_and_seed_dependent(c2):
    again = generate_scenario("C2")
    assert again == c2 and again.fingerprint == c2.fingerprint
    other = generate_scenario("C2", seed=1)
    assert not np.array_equal(other.target_lat, c2.target_lat)
    # a different name with the same seed draws other targets too
    b2 = generate_scenario("B2")
    assert not np.allclose(b2.target_weight, c2.target_weight)


def test_options_change_the_instance():
    base = generate_scenario("C1")
    wide = generate_scenario("C1", max_roll=45.0)
    assert wide.n_opps > base.n_opps
    day = generate_scenario("C1", min_sun_elevation=10.0)
    assert 0 < day.n_opps < base.n_opps
    assert day.meta["min_sun_elevation"] == 10.0
    short = generate_scenario("C1", hours=6.0, start="2026-07-01T00:00:00Z")
    assert short.orbit_end.max() == 6 * 3600.0 and short.epoch == "2026-07-01T00:00:00Z"
    res = generate_scenario("C1", resources=Resources(energy_capacity=700.0))
    assert np.all(res.energy_capacity == 700.0)
    with pytest.raises(InputError):
        generate_scenario("C1", hours=0.0)
    with pytest.raises(InputError):
        generate_scenario("C1", seed=-1)
    with pytest.raises(InputError):
        generate_scenario("C1", start="not a time")


def test_custom_region_and_tle_file(tmp_path):
    tle = tmp_path / "one.tle"
    tle.write_text(f"CBERS 2\n{L1}\n{L2}\n")
    inst = custom_scenario(
        region=(40.0, 45.0, 10.0, 20.0),
        count=50,
        seed=3,
        satellites=tle,
        hours=12.0,
        start="2006-06-27T00:00:00Z",
    )
    assert inst.n_targets == 50 and set(inst.orbit_satellite) == {"CBERS 2"}
    assert inst.meta["satellite_source"] == "TLE file one.tle"
    assert inst.n_opps > 0
    again = custom_scenario(
        region=(40.0, 45.0, 10.0, 20.0),
        count=50,
        seed=3,
        satellites=tle,
        hours=12.0,
        start="2006-06-27T00:00:00Z",
    )
    assert again == inst


def test_custom_targets_from_csv(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("id,lat,lon,weight\nrome,41.9,12.5,5\nbeijing,39.9,116.4,7\nquito,-0.2,-78.5,1\n")
    targets = read_targets_csv(p)
    inst = custom_scenario(targets=targets, name="cities")
    assert inst.target_ids == ("rome", "beijing", "quito")
    assert list(inst.target_weight) == [5, 7, 1]
    assert inst.observable_targets >= 2
    with pytest.raises(InputError, match="exactly one of"):
        custom_scenario(targets=targets, region=(0, 1, 0, 1), count=3)
    with pytest.raises(InputError, match="needs count"):
        custom_scenario(region=(0, 1, 0, 1))


def test_read_targets_csv_accepts_column_order_and_float_weights(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("weight,lon,lat,id\n4.0,100,30,a\n\n2,-10,-5,b\n")
    ids, lat, lon, w = read_targets_csv(p)
    assert ids == ["a", "b"] and list(lat) == [30.0, -5.0] and list(lon) == [100.0, -10.0]
    assert w.dtype == np.int64 and list(w) == [4, 2]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty file"),
        ("id,lat,lon\n", "header lacks weight"),
        ("id,lat,lon,weight\n", "no targets"),
        ("id,lat,lon,weight\na,1,2,3\nb,1,2\n", "line 3: expected 4 fields"),
        ("id,lat,lon,weight\na,nan,2,3\n", "line 2: lat must be a finite number"),
        ("id,lat,lon,weight\na,91,2,3\n", "line 2: lat must be"),
        ("id,lat,lon,weight\na,1,400,3\n", "line 2: lon must be"),
        ("id,lat,lon,weight\na,1,x,3\n", "line 2: lon is not a number"),
        ("id,lat,lon,weight\na,1,2,-3\n", r"line 2: weight must be an integer in \[0, 1e\+09\]"),
        ("id,lat,lon,weight\na,1,2,2.5\n", "line 2: weight must be an integer in"),
        # 1e20 once raised OverflowError (a traceback) when the weights became int64
        ("id,lat,lon,weight\na,1,2,1e20\n", "line 2: weight must be an integer in"),
        ("id,lat,lon,weight\na,1,2,1000000001\n", "line 2: weight must be an integer in"),
        ("id,lat,lon,weight\na,1,2,3\na,1,2,3\n", "line 3: duplicate id 'a'"),
        ("id,lat,lon,weight\n,1,2,3\n", "line 2: empty id"),
    ],
)
def test_read_targets_csv_errors(tmp_path, text, message):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        read_targets_csv(p)
    assert str(err.value).startswith(str(p)) and "\n" not in str(err.value)


def test_read_targets_csv_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_targets_csv(tmp_path / "none.csv")


def test_counts_grow_with_scenario_size():
    """EN and TN grow with the number of targets; every C target is seen in 24 h (the small
    area at 30-60 deg latitude is inside the swaths of some pass of the four satellites)."""
    prev = 0
    for k in (1, 5, 10):
        inst = generate_scenario(f"C{k}")
        assert inst.n_opps > prev
        prev = inst.n_opps
        assert inst.observable_targets >= 0.97 * inst.n_targets


# --------------------------------------------------------------------------- custom orbits
def test_tle_horizon_starts_at_the_latest_element_epoch(tmp_path, caplog):
    tle = tmp_path / "two_line.tle"
    tle.write_text(f"{L1}\n{L2}\n")  # two-line set, as catalogues serve them
    with caplog.at_level("WARNING", logger="sosp.scenarios"):
        inst = custom_scenario(region=(40.0, 45.0, 10.0, 20.0), count=20, satellites=tle, hours=6)
    assert inst.epoch == "2006-06-26T18:52:04.080Z" == inst.meta["start"]
    assert set(inst.orbit_satellite) == {"28057"}
    assert inst.meta["tle"] == [["28057", L1, L2]]
    assert not caplog.records  # no propagation far from the epoch: no warning


def test_horizon_far_from_the_elements_warns_with_satellite_and_distance(tmp_path, caplog):
    tle = tmp_path / "one.tle"
    tle.write_text(f"CBERS 2\n{L1}\n{L2}\n")
    with caplog.at_level("WARNING", logger="sosp.scenarios"):
        custom_scenario(
            region=(40.0, 45.0, 10.0, 20.0),
            count=5,
            satellites=tle,
            hours=1,
            start="2006-07-01T18:52:04.080Z",
        )
    (rec,) = caplog.records
    assert "CBERS 2" in rec.getMessage() and "5.0 days" in rec.getMessage()


def test_start_with_an_offset_is_stored_as_utc_and_errors_name_start():
    a = generate_scenario("C1", start="2026-06-01T02:00:00+02:00", hours=2)
    b = generate_scenario("C1", start="2026-06-01T00:00:00Z", hours=2)
    assert a.epoch == "2026-06-01T00:00:00Z" and a == b
    assert generate_scenario("C1", hours=2).epoch == DEFAULT_START
    with pytest.raises(InputError, match=r"^start: not an ISO 8601 time: 'June 1st'"):
        generate_scenario("C1", start="June 1st")


@settings(max_examples=60, deadline=None)
@given(
    west=st.floats(-180.0, 180.0),
    width=st.floats(0.5, 120.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_a_box_across_the_antimeridian_is_the_box_over_180_wrapped(west, width, seed):
    """West edge east of the east edge (GeoJSON's convention) draws the same targets as the
    same box given with its east edge above 180, with longitudes wrapped to [-180, 180)."""
    east = west + width
    if east <= 180.0:
        return  # not across the antimeridian
    wrapped_east = east - 360.0
    ids, lat, lon, weight = random_targets(
        40, (10.0, 20.0, west, wrapped_east), np.random.default_rng(seed)
    )
    ids2, lat2, lon2, weight2 = random_targets(
        40, (10.0, 20.0, west, east), np.random.default_rng(seed)
    )
    assert ids == ids2 and np.array_equal(lat, lat2) and np.array_equal(weight, weight2)
    assert np.all((lon >= -180.0) & (lon < 180.0))
    assert np.allclose((lon2 + 180.0) % 360.0 - 180.0, lon)
    inside = (lon >= west) | (lon <= wrapped_east + 1e-9)
    assert inside.all()


def test_a_region_that_is_not_a_box_names_its_edge():
    rng = np.random.default_rng(0)
    with pytest.raises(InputError, match="lat0 <= lat1"):
        random_targets(3, (40.0, 30.0, 0.0, 10.0), rng)
    with pytest.raises(InputError, match="lon0 <= lon1"):
        random_targets(3, (30.0, 40.0, -200.0, 10.0), rng)
    with pytest.raises(InputError, match="lon0 <= lon1"):
        random_targets(3, (30.0, 40.0, 190.0, 100.0), rng)


def test_the_cli_draws_a_box_across_the_antimeridian(tmp_path):
    from sosp.cli import main

    out = tmp_path / "fiji.json"
    argv = ["scenario", "fiji", "-o", str(out), "--region", "-20", "-15", "175", "-178"]
    assert main([*argv, "--targets", "30", "--hours", "6"]) == 0
    from sosp.instance import load_instance

    inst = load_instance(out)
    lon = np.asarray(inst.target_lon)
    assert inst.n_targets == 30 and np.all((lon >= 175.0) | (lon <= -178.0))
