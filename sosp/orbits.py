"""Satellites, vectorised sgp4 propagation to the Earth-fixed frame, and revolutions.

A :class:`Satellite` wraps an ``sgp4`` :class:`~sgp4.api.Satrec` built from a two-line element
set (:func:`parse_tle`, :func:`read_tle`), from mean orbital elements (:func:`from_elements`,
``Satrec.sgp4init`` with the WGS72 constants that SGP4 is defined with), or taken from the
built-in data file (:func:`builtin_satellites`, the paper's four satellites, see
``docs/scenarios.md``).

Frames
------
sgp4 returns positions in TEME (true equator, mean equinox of date). The Earth-fixed frame used
throughout sosp is the pseudo-Earth-fixed frame obtained by rotating TEME about its z axis by the
Greenwich mean sidereal time (IAU 1982 model, as in Vallado's SGP4 code and skyfield's
``TEME_to_ITRF``). Two simplifications, both documented in ``docs/scenarios.md``:

* polar motion is ignored (its effect is below 15 m on the ground);
* UT1 is taken equal to UTC (|UT1 - UTC| < 0.9 s, i.e. < 0.42 km of Earth rotation at the
  equator; in 2026 it is about 0.03 s, about 15 m).

Times are float seconds from a scenario epoch (an ISO 8601 UTC string); distances are km,
velocities km/s.

Revolutions
-----------
A revolution starts at an ascending-node crossing (the satellite's z coordinate changes from
negative to positive; z is the same in TEME and in the Earth-fixed frame because they differ by a
rotation about z). Revolution ``k`` of a horizon ``[0, H]`` starts at the ``k``-th crossing inside
the horizon; revolution 0 is the partial revolution before the first crossing and the last one
is clipped at ``H``. Its id is ``"<satellite>#<k:03d>"``.
"""

from __future__ import annotations

import json
import logging
import math
import os
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from importlib import resources as importlib_resources
from pathlib import Path
from typing import Any

import numpy as np
from sgp4.api import SGP4_ERRORS, WGS72, Satrec, SatrecArray, jday

from sosp.errors import InputError
from sosp.io import read_text

log = logging.getLogger(__name__)

#: Seconds per day.
DAY = 86400.0
#: Julian date of the sgp4init epoch origin (1949-12-31 00:00 UTC).
_JD_1949 = 2433281.5
#: Julian date of J2000.0.
_JD_J2000 = 2451545.0
#: TLE line length (columns 1-69).
TLE_LINE_LENGTH = 69


# --------------------------------------------------------------------------- time
#: Days of propagation from an element epoch past which a scenario warns
#: (:func:`stale_elements`).
STALE_DAYS = 3.0


def _datetime(text: Any, where: str = "") -> datetime:
    """An ISO 8601 time as an aware datetime (a time without a zone is UTC); ``where``
    prefixes the error messages."""
    if not isinstance(text, str):
        raise InputError(f"{where}expected an ISO 8601 string, got {text!r}")
    try:
        dt = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise InputError(f"{where}not an ISO 8601 time: {text!r}") from None
    return dt if dt.tzinfo is not None else dt.replace(tzinfo=UTC)


def parse_epoch(epoch: str) -> tuple[float, float]:
    """Split an ISO 8601 UTC time into a Julian date pair ``(jd, fr)`` as sgp4 expects.

    Parameters
    ----------
    epoch
        E.g. ``"2026-06-01T00:00:00Z"``. A time without a zone is read as UTC; any other
        offset is converted to UTC.

    Returns
    -------
    jd, fr
        Julian date of the preceding midnight (``x.5``) and the fraction of the day.
    """
    dt = _datetime(epoch, "epoch: ").astimezone(UTC)
    jd, fr = jday(dt.year, dt.month, dt.day, dt.hour, dt.minute, 0.0)
    fr += (dt.second + dt.microsecond * 1e-6) / DAY
    return jd, fr


def utc_iso(time: str, field: str = "start") -> str:
    """An ISO 8601 time with any offset as the UTC string ``YYYY-MM-DDTHH:MM:SS[.mmm]Z``.

    Raises
    ------
    InputError
        Naming ``field`` (``"--start"`` on the command line) when ``time`` is not ISO 8601.
    """
    try:
        return format_epoch(*parse_epoch(time))
    except InputError:
        raise InputError(
            f"{field}: not an ISO 8601 time: {time!r} (e.g. 2026-06-01T00:00:00Z or "
            "2026-06-01T02:00:00+02:00)"
        ) from None


def element_epoch(sat: Satellite) -> str:
    """The epoch of a satellite's element set, ISO 8601 UTC."""
    return format_epoch(*sat.epoch)


def stale_elements(
    satellites: list[Satellite], start: str, hours: float, max_days: float = STALE_DAYS
) -> list[tuple[str, float]]:
    """Satellites whose element epoch lies more than ``max_days`` from some time of the horizon.

    SGP4's error grows with the time propagated from the element epoch (of the order of a
    kilometre a day for low orbits), so a horizon far from it gives wrong opportunities.

    Returns
    -------
    list of (name, days)
        The satellite and the longest propagation its elements need over
        ``[start, start + hours]``, in days.
    """
    offsets = [(s.name, seconds_after(element_epoch(s), start)) for s in satellites]
    far = [(name, max(abs(t0), abs(t0 + hours * 3600.0)) / DAY) for name, t0 in offsets]
    return [(name, days) for name, days in far if days > max_days]


def utc_at(epoch: str, seconds: float) -> str:
    """The ISO 8601 UTC time (``...Z``, millisecond precision) ``seconds`` after ``epoch``.

    Plain calendar arithmetic (no leap seconds, as everywhere in sosp): schedule files and
    exports print observation windows with it. A time outside the calendar (years 1-9999),
    which only a damaged file gives, is written as ``epoch +seconds s`` rather than raising
    inside an error message about that file.
    """
    dt = _datetime(epoch)
    try:
        ms = round((dt.astimezone(UTC).timestamp() + float(seconds)) * 1000.0)
        at = datetime(1970, 1, 1, tzinfo=UTC) + timedelta(seconds=ms // 1000)
    except (OverflowError, ValueError):
        return f"{epoch} {float(seconds):+g} s"
    text = f"{at.year:04d}-{at:%m-%dT%H:%M:%S}"  # %Y does not pad years before 1000
    return text + (f".{ms % 1000:03d}Z" if ms % 1000 else "Z")


def seconds_after(epoch: str, time: str) -> float:
    """Seconds from ISO 8601 ``epoch`` to ``time`` (calendar arithmetic, microseconds kept).

    Raises
    ------
    InputError
        When ``time`` is not an ISO 8601 string.
    """
    return (_datetime(time) - _datetime(epoch)).total_seconds()


def format_epoch(jd: float, fr: float) -> str:
    """The ISO 8601 UTC string (``...Z``, millisecond precision) of a Julian date pair."""
    days = (jd - 2440587.5) + fr  # Unix epoch
    dt = datetime.fromtimestamp(round(days * DAY, 3), tz=UTC)
    text = dt.strftime("%Y-%m-%dT%H:%M:%S")
    ms = dt.microsecond // 1000
    return text + (f".{ms:03d}Z" if ms else "Z")


def gmst(jd: Any, fr: Any) -> tuple[np.ndarray, float]:
    """Greenwich mean sidereal time (IAU 1982, UT1 taken as UTC), vectorised.

    Parameters
    ----------
    jd, fr
        Julian date pair(s), broadcastable.

    Returns
    -------
    theta, theta_dot
        GMST in radians in ``[0, 2 pi)`` and its rate in rad/s (Earth's rotation rate
        including precession of the equinox in the 1982 model).
    """
    t = ((np.asarray(jd, dtype=float) - _JD_J2000) + np.asarray(fr, dtype=float)) / 36525.0
    # Seconds of sidereal time; the same polynomial as sgp4's gstime() and skyfield.
    sec = 67310.54841 + t * ((876600.0 * 3600.0 + 8640184.812866) + t * (0.093104 - 6.2e-6 * t))
    theta = np.mod(sec * (2.0 * np.pi / DAY), 2.0 * np.pi)
    t_mid = float(np.mean(t)) if np.size(t) else 0.0
    rate_days = (
        (876600.0 * 3600.0 + 8640184.812866) + 2.0 * 0.093104 * t_mid - 3 * 6.2e-6 * t_mid**2
    ) / 36525.0  # sidereal seconds per day
    theta_dot = rate_days * (2.0 * np.pi / DAY) / DAY
    return theta, theta_dot


def teme_to_ecef(r: np.ndarray, v: np.ndarray, jd: Any, fr: Any) -> tuple[np.ndarray, np.ndarray]:
    """Rotate TEME position/velocity to the Earth-fixed frame (polar motion ignored).

    ``r_ecef = R3(gmst) r``; ``v_ecef = R3(gmst) v - omega x r_ecef``, so the velocity is
    relative to the rotating Earth (ground-relative), as skyfield's ``TEME_to_ITRF`` does.

    Parameters
    ----------
    r, v
        Arrays ``(..., n, 3)`` in km and km/s.
    jd, fr
        Julian date pairs of shape ``(n,)`` (broadcast against the time axis).
    """
    theta, omega = gmst(jd, fr)
    c, s = np.cos(theta), np.sin(theta)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    xe = c * x + s * y
    ye = -s * x + c * y
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    vxe = c * vx + s * vy + omega * ye
    vye = -s * vx + c * vy - omega * xe
    return np.stack([xe, ye, z], axis=-1), np.stack([vxe, vye, vz], axis=-1)


def sun_direction_ecef(jd: Any, fr: Any) -> np.ndarray:
    """Unit vector to the Sun in the Earth-fixed frame, low precision (about 0.01 deg).

    The Astronomical Almanac's low-precision formulae (mean longitude, mean anomaly, ecliptic
    longitude, obliquity) give the Sun's right ascension and declination of date; the GMST
    rotation then takes the direction to the Earth-fixed frame. Parallax is ignored (8.8").
    """
    n = (np.asarray(jd, dtype=float) - _JD_J2000) + np.asarray(fr, dtype=float)
    mean_lon = np.radians(np.mod(280.460 + 0.9856474 * n, 360.0))
    g = np.radians(np.mod(357.528 + 0.9856003 * n, 360.0))
    ecl_lon = mean_lon + np.radians(1.915) * np.sin(g) + np.radians(0.020) * np.sin(2 * g)
    eps = np.radians(23.439 - 4.0e-7 * n)
    x = np.cos(ecl_lon)
    y = np.cos(eps) * np.sin(ecl_lon)
    z = np.sin(eps) * np.sin(ecl_lon)
    theta, _ = gmst(jd, fr)
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * x + s * y, -s * x + c * y, z], axis=-1)


# --------------------------------------------------------------------------- satellites


@dataclass(frozen=True, eq=False)
class Satellite:
    """One satellite: a name and its sgp4 record.

    Attributes
    ----------
    name
        Display name, used in orbit ids (``"CBERS-2#003"``).
    satrec
        The initialised :class:`sgp4.api.Satrec` (WGS72).
    norad
        Catalogue number (99999 when unknown).
    note
        Provenance (a source, or "approximation: ...").
    tle
        The two element lines it was read from (None for elements given otherwise), so that an
        instance can record its orbits.
    """

    name: str
    satrec: Satrec
    norad: int = 99999
    note: str = ""
    tle: tuple[str, str] | None = None

    @property
    def epoch(self) -> tuple[float, float]:
        """The element set's epoch as a Julian date pair ``(jd, fr)``."""
        return float(self.satrec.jdsatepoch), float(self.satrec.jdsatepochF)

    @property
    def period(self) -> float:
        """Period 2 pi / n from the Kozai mean motion, in seconds (the nodal period differs by
        J2 terms, ~0.1 %)."""
        return 2.0 * math.pi / self.satrec.no_kozai * 60.0

    def __repr__(self) -> str:
        return f"Satellite({self.name!r}, norad={self.norad}, period={self.period / 60:.2f} min)"


def tle_checksum(line: str) -> int:
    """The TLE checksum of a line: digits summed, each ``-`` counts 1, modulo 10 (cols 1-68)."""
    return sum(int(ch) if ch.isdigit() else ch == "-" for ch in line[:68]) % 10


def _check_tle_line(line: str, number: str, lineno: int, source: str) -> None:
    if len(line) != TLE_LINE_LENGTH:
        raise InputError(
            f"line {lineno}: TLE line {number} must be {TLE_LINE_LENGTH} characters, "
            f"got {len(line)}",
            source=source,
        )
    if not line.startswith(number + " "):
        raise InputError(f"line {lineno}: expected TLE line {number}", source=source)
    if not line[68].isdigit():
        raise InputError(f"line {lineno}: checksum column is not a digit", source=source)
    if tle_checksum(line) != int(line[68]):
        raise InputError(
            f"line {lineno}: bad checksum (computed {tle_checksum(line)}, stated {line[68]})",
            source=source,
        )


def parse_tle(text: str, source: str = "<tle>") -> list[Satellite]:
    """Parse element sets: three-line (a name line, then TLE lines 1 and 2) or two-line.

    Satellite catalogues serve both: with a name line (which may start with ``"0 "``) or just
    the two element lines, in which case the satellite is named by its catalogue number
    (``"28057"``). Both kinds may be mixed in one file. Blank lines and lines starting with
    ``#`` are ignored. Each element line must be exactly 69 characters (trailing white space
    is stripped) with a valid checksum, and both lines must carry the same satellite number.

    Parameters
    ----------
    text
        The file's content.
    source
        Name used in error messages (usually the file path).

    Raises
    ------
    InputError
        Naming ``source`` and the 1-based line number at fault.
    """
    lines = [
        (i + 1, raw.rstrip())
        for i, raw in enumerate(text.splitlines())
        if raw.strip() and not raw.lstrip().startswith("#")
    ]
    sats: list[Satellite] = []
    names: set[str] = set()
    k = 0
    while k < len(lines):
        lineno, name = lines[k]
        # a two-line set (no name line) starts with line 1: "1 NNNNN..." of 69 characters
        two = name.startswith("1 ") and len(name) == TLE_LINE_LENGTH and name[68].isdigit()
        step = 2 if two else 3
        if k + step > len(lines):
            who = "TLE line 1" if two else f"satellite {name.strip()!r}"
            lacks = "its line 2" if two else "its two element lines"
            raise InputError(f"line {lineno}: {who} lacks {lacks}", source=source)
        (n1, l1), (n2, l2) = lines[k + step - 2 : k + step]
        _check_tle_line(l1, "1", n1, source)
        _check_tle_line(l2, "2", n2, source)
        if l1[2:7] != l2[2:7]:
            raise InputError(
                f"line {n2}: satellite number {l2[2:7].strip()!r} does not match line 1's "
                f"{l1[2:7].strip()!r}",
                source=source,
            )
        # a two-line set is named by its catalogue number
        display = l1[2:7].strip() if two else name.strip().removeprefix("0 ").strip()
        if not display:
            raise InputError(f"line {lineno}: empty satellite name", source=source)
        if display in names:
            raise InputError(f"line {lineno}: duplicate satellite name {display!r}", source=source)
        try:
            sat = Satrec.twoline2rv(l1, l2, WGS72)
        except (ValueError, IndexError) as exc:
            raise InputError(f"line {n1}: malformed element set ({exc})", source=source) from None
        if sat.error:
            raise InputError(
                f"line {n1}: sgp4 rejects the elements (error {sat.error})", source=source
            )
        try:
            norad = int(l1[2:7])
        except ValueError:  # alpha-5 catalogue numbers
            norad = int(sat.satnum)
        names.add(display)
        sats.append(
            Satellite(display, sat, norad, note=f"TLE from {Path(source).name}", tle=(l1, l2))
        )
        k += step
    if not sats:
        raise InputError("no satellites found", source=source)
    return sats


def read_tle(path: str | os.PathLike[str]) -> list[Satellite]:
    """Read satellites from a two- or three-line element file (see :func:`parse_tle`)."""
    return parse_tle(read_text(path), source=str(Path(path)))


def from_elements(
    name: str,
    *,
    epoch: str,
    inclination: float,
    raan: float,
    eccentricity: float,
    arg_perigee: float,
    mean_anomaly: float,
    mean_motion: float,
    bstar: float = 0.0,
    norad: int = 99999,
    note: str = "",
) -> Satellite:
    """Build a satellite from SGP4 mean elements with ``Satrec.sgp4init`` (WGS72).

    Parameters
    ----------
    name
        Display name.
    epoch
        Element epoch, ISO 8601 UTC.
    inclination, raan, arg_perigee, mean_anomaly
        Degrees (TEME of epoch).
    eccentricity
        In ``[0, 1)``.
    mean_motion
        Kozai mean motion in revolutions per day (as in a TLE).
    bstar
        Drag term (1/earth radii); 0 for no drag.
    norad
        Catalogue number (1..99999).
    note
        Provenance.
    """
    if not (0.0 <= eccentricity < 1.0):
        raise InputError(f"{name}: eccentricity must be in [0, 1), got {eccentricity}")
    if not (0.0 < mean_motion < 20.0):
        raise InputError(f"{name}: mean motion must be in (0, 20) rev/day, got {mean_motion}")
    if not (0.0 <= inclination <= 180.0):
        raise InputError(f"{name}: inclination must be in [0, 180] deg, got {inclination}")
    jd, fr = parse_epoch(epoch)
    sat = Satrec()
    no_kozai = mean_motion * 2.0 * math.pi / 1440.0  # radians per minute
    angles = map(math.radians, (arg_perigee, inclination, mean_anomaly))
    elements = (float(eccentricity), *angles, no_kozai, math.radians(raan % 360.0))
    sat.sgp4init(WGS72, "i", int(norad), (jd - _JD_1949) + fr, float(bstar), 0.0, 0.0, *elements)
    if sat.error:
        raise InputError(f"{name}: sgp4init rejects the elements (error {sat.error})")
    return Satellite(name, sat, int(norad), note)


def builtin_satellites(names: list[str] | tuple[str, ...] | None = None) -> list[Satellite]:
    """The paper's four satellites (JB-3A, JB-3C, CBERS-1, CBERS-2) from ``sosp/data``.

    They are approximations built from published figures (see the data file's ``sources``
    and ``docs/scenarios.md``); all share one element epoch.

    Parameters
    ----------
    names
        A subset, by name, in the order wanted; all four by default.
    """
    text = importlib_resources.files("sosp").joinpath("data", "satellites.json").read_text("utf-8")
    data = json.loads(text)
    by_name = {
        rec["name"]: from_elements(
            rec["name"],
            epoch=data["epoch"],
            norad=rec["norad"],
            note=rec["note"],
            **rec["elements"],
        )
        for rec in data["satellites"]
    }
    for n in names or ():
        if n not in by_name:
            raise InputError(f"unknown built-in satellite {n!r}; known: {', '.join(by_name)}")
    return list(by_name.values()) if names is None else [by_name[n] for n in names]


# --------------------------------------------------------------------------- propagation


def propagate(satellites: list[Satellite], epoch: str, t: Any) -> tuple[np.ndarray, np.ndarray]:
    """Earth-fixed positions and ground-relative velocities at times ``t`` (vectorised).

    Parameters
    ----------
    satellites
        The satellites.
    epoch
        ISO 8601 UTC origin of ``t``.
    t
        Seconds from ``epoch``, shape ``(n,)``.

    Returns
    -------
    r, v
        Arrays ``(len(satellites), n, 3)``, km and km/s; rows where sgp4 fails (e.g. decay)
        are NaN and logged.
    """
    jd0, fr0 = parse_epoch(epoch)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    fr = fr0 + t / DAY
    whole = np.floor(fr)
    jd = np.full(t.shape, jd0) + whole
    fr = fr - whole
    arr = SatrecArray([s.satrec for s in satellites])
    err, r, v = arr.sgp4(jd, fr)
    bad = err != 0
    for i in np.flatnonzero(bad.any(axis=1)):
        k, sat = int(np.argmax(bad[i])), satellites[i].satrec
        code, hi = int(err[i, k]), float(t[k])
        # bisect to the second from a time sgp4 works at: the sample before, or (the first
        # sample failing) the elements' own epoch, so the time said is the failure's own
        lo = t[k - 1] if k else (sat.jdsatepoch - jd0 + sat.jdsatepochF - fr0) * DAY
        while lo < hi - 1.0:
            f = fr0 + (mid := 0.5 * (lo + hi)) / DAY
            lo, hi = (lo, mid) if sat.sgp4(jd0 + math.floor(f), f % 1.0)[0] else (mid, hi)
        log.warning(
            "sgp4 failed for %s from %s (error %d: %s): no opportunity at %d of %d times",
            satellites[i].name,
            utc_at(epoch, hi),
            code,
            SGP4_ERRORS.get(code, "unknown"),
            int(bad[i].sum()),
            t.size,
        )
    r[bad] = np.nan
    v[bad] = np.nan
    return teme_to_ecef(r, v, jd, fr)


class EphemerisGrid:
    """Earth-fixed states of one satellite on a regular time grid, with cubic Hermite
    interpolation of position (using the exact sgp4 velocities as derivatives).

    With a 20 s grid the interpolation error is below a centimetre for these orbits (the error
    of cubic Hermite interpolation scales as ``h**4 |r''''| / 384``), far below the
    accuracy of SGP4 itself, so refinements need no further sgp4 calls.

    Parameters
    ----------
    t0
        Time of the first grid point (seconds from the epoch).
    step
        Grid spacing in seconds.
    r, v
        States ``(n, 3)`` from :func:`propagate`.
    """

    def __init__(self, t0: float, step: float, r: np.ndarray, v: np.ndarray) -> None:
        self.t0, self.step, self.n = float(t0), float(step), len(r)
        self.r, self.v = np.ascontiguousarray(r), np.ascontiguousarray(v)

    def state(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Interpolated position, velocity and acceleration at times ``t`` (any shape).

        Times outside the grid are extrapolated from the end cells (avoid it).
        """
        t = np.asarray(t, dtype=float)
        x = (t - self.t0) / self.step
        j = np.clip(np.floor(x).astype(np.int64), 0, self.n - 2)
        u = (x - j)[..., None]
        h = self.step
        p0, p1 = self.r[j], self.r[j + 1]
        m0, m1 = self.v[j] * h, self.v[j + 1] * h
        u2 = u * u
        u3 = u2 * u
        pos = (
            (2 * u3 - 3 * u2 + 1) * p0
            + (u3 - 2 * u2 + u) * m0
            + (-2 * u3 + 3 * u2) * p1
            + (u3 - u2) * m1
        )
        vel = (
            (6 * u2 - 6 * u) * p0
            + (3 * u2 - 4 * u + 1) * m0
            + (-6 * u2 + 6 * u) * p1
            + (3 * u2 - 2 * u) * m1
        ) / h
        acc = ((12 * u - 6) * p0 + (6 * u - 4) * m0 + (-12 * u + 6) * p1 + (6 * u - 2) * m1) / (
            h * h
        )
        return pos, vel, acc


def ephemeris_grids(
    satellites: list[Satellite], epoch: str, t_start: float, t_end: float, step: float = 20.0
) -> list[EphemerisGrid]:
    """One :class:`EphemerisGrid` per satellite covering ``[t_start, t_end]`` (one sgp4 call).

    The grid starts at ``t_start`` and ends at the first grid point at or after ``t_end``.
    """
    n = int(math.ceil((t_end - t_start) / step)) + 1
    t = t_start + step * np.arange(max(n, 2))
    r, v = propagate(satellites, epoch, t)
    return [EphemerisGrid(t_start, step, r[i], v[i]) for i in range(len(satellites))]


# --------------------------------------------------------------------------- revolutions


@dataclass(frozen=True)
class Revolutions:
    """The revolutions (orbits, in the paper's sense) of some satellites inside a horizon.

    All arrays have one row per revolution, grouped by satellite and ordered by start time.

    Attributes
    ----------
    ids
        ``"<satellite>#<k:03d>"``; ``k`` counts ascending-node crossings inside the horizon.
    satellite
        Index into the satellite list.
    number
        ``k``.
    start, end
        Seconds from the epoch; consecutive revolutions of a satellite share their boundary.
    """

    ids: tuple[str, ...]
    satellite: np.ndarray
    number: np.ndarray
    start: np.ndarray
    end: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)


def ascending_nodes(grid: EphemerisGrid, t_start: float, t_end: float) -> np.ndarray:
    """Times of the ascending-node crossings in ``[t_start, t_end)``, refined to ~1e-6 s.

    Coarse detection of ``z < 0 <= z_next`` on the grid, then safeguarded Newton iterations on
    the interpolated ``z(t)`` inside each bracketing cell (vectorised over crossings).
    """
    z, vz = grid.r[:, 2], grid.v[:, 2]
    cell = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    if cell.size == 0:
        return np.empty(0)
    lo = grid.t0 + grid.step * cell
    hi = lo + grid.step
    t = lo - z[cell] / vz[cell]  # Newton from the left end
    t = np.clip(t, lo, hi)
    for _ in range(6):
        pos, vel, _ = grid.state(t)
        t = np.clip(t - pos[:, 2] / vel[:, 2], lo, hi)
    return t[(t >= t_start) & (t < t_end)]


def revolutions(
    satellites: list[Satellite],
    grids: list[EphemerisGrid],
    horizon: tuple[float, float],
) -> Revolutions:
    """Split each satellite's horizon into revolutions at its ascending-node crossings.

    Parameters
    ----------
    satellites
        For the names.
    grids
        Their :class:`EphemerisGrid` (covering the horizon).
    horizon
        ``(t_start, t_end)`` in seconds from the epoch.

    Returns
    -------
    Revolutions
        Revolution 0 runs from ``t_start`` to the first crossing (omitted when that is
        shorter than 1 ms, i.e. the horizon starts on a node); the last ends at ``t_end``.
    """
    t0, t1 = horizon
    rows = []  # (satellite, k, start, end)
    for i, (sat, grid) in enumerate(zip(satellites, grids, strict=True)):
        nodes = ascending_nodes(grid, t0, t1)
        bounds = np.concatenate(([t0], nodes, [t1]))
        rows += [
            (i, k, *bounds[k : k + 2])
            for k in range(len(nodes) + 1)
            if not bounds[k + 1] - bounds[k] < 1e-3
        ]
        log.debug("%s: %d ascending nodes in the horizon", sat.name, len(nodes))
    sat_idx, number, starts, ends = zip(*rows, strict=True) if rows else [()] * 4
    return Revolutions(
        ids=tuple(f"{satellites[i].name}#{k:03d}" for i, k in zip(sat_idx, number, strict=True)),
        satellite=np.asarray(sat_idx, dtype=np.int64),
        number=np.asarray(number, dtype=np.int64),
        start=np.asarray(starts, dtype=float),
        end=np.asarray(ends, dtype=float),
    )


# ------------------------------------------------------------ constellations from elements
#: WGS72 constants SGP4 is defined with: gravitational parameter (km^3/s^2), equatorial
#: radius (km) and J2.
_MU_KM3_S2 = 398600.8
_EARTH_RADIUS_KM = 6378.135
_J2 = 0.001082616
#: Rate of the mean Sun in right ascension (rad/s): one turn per tropical year.
_SUN_RATE = 2.0 * math.pi / (365.2421897 * DAY)


def sun_synchronous_inclination(altitude_km: float) -> float:
    """Inclination (deg) of the circular sun-synchronous orbit at ``altitude_km``.

    The J2 nodal regression ``dOmega/dt = -3/2 n J2 (R/a)^2 cos i`` equals the Sun's mean
    motion in right ascension (one turn per tropical year), so
    ``cos i = -2 a^2 dOmega/dt / (3 n J2 R^2)`` (about 97.4 deg at 500 km).
    """
    a = _EARTH_RADIUS_KM + altitude_km
    n = math.sqrt(_MU_KM3_S2 / a**3)
    c = -2.0 * _SUN_RATE * a**2 / (3.0 * n * _J2 * _EARTH_RADIUS_KM**2)
    if not -1.0 <= c <= 1.0:
        raise InputError(f"altitude {altitude_km} km: no sun-synchronous inclination")
    return math.degrees(math.acos(c))


def walker_delta(
    total: int,
    planes: int,
    phasing: int,
    altitude_km: float,
    *,
    epoch: str,
    inclination: float | None = None,
    prefix: str = "W",
) -> list[Satellite]:
    """A Walker-delta constellation ``total/planes/phasing`` of circular orbits.

    Plane p (0..P-1) has right ascension ``360 p / P``; satellite s (0..S-1, S = T/P) of
    plane p has mean anomaly (argument of latitude, the orbit being circular)
    ``360 s / S + 360 F p / T`` at ``epoch``. Elements become SGP4 satellites through
    :func:`from_elements` (no drag), so no TLE file is needed.

    Parameters
    ----------
    total, planes, phasing
        T satellites in P equal planes (P divides T), phasing F in ``0..P-1``.
    altitude_km
        Altitude above the WGS72 equatorial radius (km, 150..40000).
    epoch
        Element epoch, ISO 8601 UTC (the horizon start, so every satellite is where the
        pattern puts it at the start).
    inclination
        Degrees; None: the sun-synchronous inclination of the altitude
        (:func:`sun_synchronous_inclination`).
    prefix
        Names are ``{prefix}{plane:02d}-{slot:02d}`` (they make the orbit ids).
    """
    for name, value in (("satellites", total), ("planes", planes)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InputError(f"walker: {name} must be a positive integer, got {value!r}")
    if total > 9999:
        raise InputError(f"walker: at most 9999 satellites, got {total}")
    if total % planes:
        raise InputError(f"walker: {planes} planes must divide {total} satellites")
    if isinstance(phasing, bool) or not isinstance(phasing, int) or not 0 <= phasing < planes:
        raise InputError(f"walker: phasing must be an integer in 0..{planes - 1}, got {phasing!r}")
    if not (math.isfinite(altitude_km) and 150.0 <= altitude_km <= 40000.0):
        raise InputError(f"walker: altitude must be in [150, 40000] km, got {altitude_km}")
    incl = sun_synchronous_inclination(altitude_km) if inclination is None else inclination
    per_plane = total // planes
    n = math.sqrt(_MU_KM3_S2 / (_EARTH_RADIUS_KM + altitude_km) ** 3) * DAY / (2.0 * math.pi)
    return [
        from_elements(
            f"{prefix}{p:02d}-{s:02d}",
            epoch=epoch,
            inclination=incl,
            raan=360.0 * p / planes,
            eccentricity=0.0,
            arg_perigee=0.0,
            mean_anomaly=(360.0 * s / per_plane + 360.0 * phasing * p / total) % 360.0,
            mean_motion=n,
            norad=90000 + p * per_plane + s,
            note=f"Walker-delta {total}/{planes}/{phasing} at {altitude_km:g} km",
        )
        for p in range(planes)
        for s in range(per_plane)
    ]


def instance_satellites(instance: Any) -> list[Satellite] | None:
    """The satellites whose orbits the instance records, or None.

    Built-in satellites are named in ``meta["satellites"]`` (with ``satellite_source``
    ``"builtin"``); others carry their element lines in ``meta["tle"]`` as
    ``[name, line1, line2]`` records.
    """

    meta = dict(instance.meta)
    try:
        if meta.get("tle"):
            text = "".join(f"0 {n}\n{a}\n{b}\n" for n, a, b in meta["tle"])
            return parse_tle(text, source="instance meta.tle")
        if meta.get("satellite_source") == "builtin" and meta.get("satellites"):
            return builtin_satellites(list(meta["satellites"]))
    except (InputError, TypeError, ValueError, KeyError) as exc:
        log.warning("the instance's recorded orbits cannot be read (%s): no paths", exc)
    return None
