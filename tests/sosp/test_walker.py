"""Walker-delta constellations from elements (``sosp scenario --walker``)."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from sosp.errors import InputError
from sosp.orbits import DAY, sun_synchronous_inclination, walker_delta
from sosp.scenarios import DEFAULT_START, custom_scenario


def test_planes_are_evenly_spaced_and_phased() -> None:
    sats = walker_delta(12, 4, 1, 500.0, epoch=DEFAULT_START, inclination=53.0)
    assert len(sats) == 12 and len({s.name for s in sats}) == 12
    raan = [math.degrees(s.satrec.nodeo) for s in sats]
    anomaly = [math.degrees(s.satrec.mo) for s in sats]
    for p in range(4):
        plane = range(3 * p, 3 * p + 3)
        assert all(raan[k] == pytest.approx(90.0 * p) for k in plane)
        # three slots 120 deg apart, the plane shifted by 360 F / T = 30 deg per plane
        for s, k in enumerate(plane):
            assert anomaly[k] == pytest.approx((120.0 * s + 30.0 * p) % 360.0)
    assert all(math.degrees(s.satrec.inclo) == pytest.approx(53.0) for s in sats)


def test_sun_synchronous_by_default() -> None:
    """97.4 deg at 500 km, and SGP4's own secular node rate is the Sun's (one turn a year)."""
    assert sun_synchronous_inclination(500.0) == pytest.approx(97.4, abs=0.05)
    assert sun_synchronous_inclination(800.0) > sun_synchronous_inclination(500.0)
    sat = walker_delta(2, 1, 0, 500.0, epoch=DEFAULT_START)[0]
    assert math.degrees(sat.satrec.inclo) == pytest.approx(sun_synchronous_inclination(500.0))
    node_deg_per_day = math.degrees(sat.satrec.nodedot) * 1440.0  # rad/min -> deg/day
    assert node_deg_per_day == pytest.approx(360.0 / 365.2422, rel=0.01)
    assert sat.period == pytest.approx(2 * math.pi * math.sqrt(6878.135**3 / 398600.8), rel=2e-3)
    assert DAY / sat.period == pytest.approx(15.2, abs=0.1)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((12, 5, 1, 500.0), "5 planes must divide 12"),
        ((12, 4, 4, 500.0), "phasing must be an integer in 0..3"),
        ((0, 1, 0, 500.0), "satellites must be a positive integer"),
        ((4, 2, 1, 50.0), "altitude must be in"),
    ],
)
def test_bad_patterns_are_one_line_errors(args, message) -> None:
    with pytest.raises(InputError, match=message):
        walker_delta(*args, epoch=DEFAULT_START)


def test_a_walker_scenario_sees_targets() -> None:
    sats = walker_delta(4, 2, 1, 500.0, epoch=DEFAULT_START)
    inst = custom_scenario(region=(30, 40, 100, 110), count=20, satellites=sats, hours=12)
    assert set(inst.orbit_satellite) <= {s.name for s in sats}
    assert inst.n_opps > 0


def test_cli_walker_and_its_errors(tmp_path) -> None:
    out = tmp_path / "w.json"
    base = [sys.executable, "-m", "sosp", "scenario", "w", "-o", str(out), "--hours", "3"]
    region = ["--region", "30", "40", "100", "110", "--targets", "10"]
    ok = subprocess.run(
        [*base, *region, "--walker", "4/2/1", "--altitude", "600"], capture_output=True, text=True
    )
    assert ok.returncode == 0, ok.stderr
    assert "on 4 satellite(s)" in ok.stdout or "4 satellite" in ok.stdout
    for extra, message in (
        (["--walker", "4/2"], "expected SATS/PLANES/PHASING"),
        (["--walker", "4/2/1"], "give the altitude"),
        (["--altitude", "500"], "give them with --walker"),
        (["--walker", "4/2/1", "--altitude", "500", "--tle", "x.tle"], "not both"),
    ):
        bad = subprocess.run([*base, *region, *extra], capture_output=True, text=True)
        assert bad.returncode == 2 and message in bad.stderr and "Traceback" not in bad.stderr
