"""Ground stations and their contact windows with the satellites.

A :class:`Station` is a geodetic point (WGS84) with an elevation mask and a number of
antennas. Stations come from a CSV file (:func:`read_stations`), from the built-in list of
real stations in ``sosp/data/stations.csv`` (:func:`builtin_stations`, each row citing its
source), or from the ``--stations FILE|builtin|ID,ID,...`` text (:func:`stations_from_arg`).

Contact windows
---------------
A station sees a satellite while the satellite's elevation, the angle of the line of sight
above the plane perpendicular to the station's ellipsoid normal (no refraction), is above the
station's mask. Positions are Earth-fixed, as everywhere in sosp (:mod:`sosp.orbits`: sgp4 in
TEME rotated by GMST; :func:`sosp.visibility.geodetic_to_ecef` for the station).
:func:`contact_windows` samples the elevation on a regular grid of sgp4 states, takes every
run of samples above the mask, and every local maximum of the samples below it whose refined
maximum is above it (a short pass between two samples), then bisects each rise and set on the
Hermite interpolation of the states (:class:`sosp.orbits.EphemerisGrid`, centimetre-accurate)
to well under a millisecond. The elevation of a pass is taken to have one maximum (true of
low orbits), found by golden-section search.
"""

from __future__ import annotations

import functools
import logging
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib import resources as importlib_resources
from pathlib import Path

import numpy as np

from sosp.errors import InputError
from sosp.io import Column, read_id_table
from sosp.orbits import Satellite, ephemeris_grids
from sosp.visibility import geodetic_to_ecef, geodetic_up

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Station:
    """A ground station.

    Attributes
    ----------
    id
        Unique short name (``"SG"``), used on the command line.
    lat_deg, lon_deg
        WGS84 geodetic latitude and longitude, degrees.
    alt_m
        Height above the WGS84 ellipsoid, metres.
    min_elevation_deg
        Elevation mask: contacts need the satellite above it, degrees in ``[0, 90)``.
    antennas
        Antennas that can track a satellite each at the same time.
    description
        Free text (name, operator); no downlink rate belongs here.
    """

    id: str
    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0
    min_elevation_deg: float = 5.0
    antennas: int = 1
    description: str = ""


#: The numeric columns of a stations CSV file (named as the :class:`Station` fields), a test
#: of their values and what the error says they must be.
CSV_COLUMNS: tuple[Column, ...] = (
    ("lat_deg", lambda x: -90.0 <= x <= 90.0, "in [-90, 90]"),
    ("lon_deg", lambda x: -180.0 <= x <= 360.0, "in [-180, 360]"),
    ("alt_m", lambda x: -500.0 <= x <= 10000.0, "in [-500, 10000]"),
    ("min_elevation_deg", lambda x: 0.0 <= x < 90.0, "in [0, 90)"),
    ("antennas", lambda x: x >= 1 and x.is_integer(), "a positive integer"),
)


def read_stations(path: str | os.PathLike[str]) -> tuple[Station, ...]:
    """Read stations from a CSV file.

    The header names the columns ``id``, ``lat_deg``, ``lon_deg``, ``alt_m``,
    ``min_elevation_deg`` and ``antennas`` (any order), and optionally ``description``;
    other columns (the built-in file's ``source``) are ignored, and so are blank lines and
    lines starting with ``#``.

    Raises
    ------
    InputError
        Naming the file, the line (1-based, comments counted) and the field at fault: a
        missing column, a value that is not a number or out of its range
        (:data:`CSV_COLUMNS`), an empty or duplicate id, no station at all.
    """
    rows = read_id_table(path, CSV_COLUMNS, "stations", comments=True)
    return tuple(
        Station(
            sid,
            **{**values, "antennas": int(values["antennas"])},
            description=f.get("description", ""),
        )
        for _, sid, values, f in rows
    )


@functools.cache
def builtin_stations() -> tuple[Station, ...]:
    """The real ground stations of ``sosp/data/stations.csv`` (sources in the file)."""
    ref = importlib_resources.files("sosp").joinpath("data", "stations.csv")
    with importlib_resources.as_file(ref) as path:
        return read_stations(path)


def stations_from_arg(text: str) -> tuple[Station, ...]:
    """The stations named by ``--stations``: a CSV file, ``builtin`` (all built-in
    stations) or comma-separated built-in ids (``SG,KIR``), in the order given.

    Text that names an existing file or ends in ``.csv`` is a file.

    Raises
    ------
    InputError
        For a bad file (:func:`read_stations`), an unknown or repeated id (naming it and
        the known ids).
    """
    if text.strip() == "builtin":
        return builtin_stations()
    if Path(text).is_file() or text.lower().endswith(".csv"):
        return read_stations(text)
    known = {s.id: s for s in builtin_stations()}
    ids = [i.strip() for i in text.split(",")]
    for k, sid in enumerate(ids):
        if sid not in known or sid in ids[:k]:
            why = "repeated" if sid in known else "unknown"
            raise InputError(
                f"--stations: {why} built-in station {sid!r}; known: {', '.join(known)}"
            )
    return tuple(known[i] for i in ids)


#: One contact window per row: indices into the satellites and stations, its start and end
#: (seconds from the epoch) and the satellite's highest elevation during it.
CONTACT_DTYPE = np.dtype(
    [
        ("satellite", np.int64),
        ("station", np.int64),
        ("start_s", float),
        ("end_s", float),
        ("max_elevation_deg", float),
    ]
)


def contact_windows(
    satellites: list[Satellite],
    stations: Sequence[Station],
    epoch: str,
    start_s: float,
    end_s: float,
    step_s: float = 20.0,
) -> np.ndarray:
    """The contact windows of every satellite with every station inside a horizon.

    Parameters
    ----------
    satellites, stations
        The satellites and stations (rows refer to them by index).
    epoch
        ISO 8601 UTC origin of the times.
    start_s, end_s
        The horizon, seconds from ``epoch``; windows are clipped to it.
    step_s
        Sampling step of the elevation. A pass shorter than it is still found when its
        highest sample is a local maximum (see the module's notes).

    Returns
    -------
    numpy.ndarray
        Structured array of :data:`CONTACT_DTYPE`, sorted by satellite, station and start.
    """
    if not end_s > start_s:
        raise InputError(f"horizon: end must be after start, got {start_s}, {end_s}")
    lat, lon, alt_m, mask_deg = (
        np.array([getattr(s, k) for s in stations], dtype=float)
        for k in ("lat_deg", "lon_deg", "alt_m", "min_elevation_deg")
    )
    pos = geodetic_to_ecef(lat, lon, alt_m / 1000.0)  # (G, 3) km
    up = geodetic_up(lat, lon)
    # one sample beyond each end, so a pass across an end is found as any other
    grids = ephemeris_grids(satellites, epoch, start_s - step_s, end_s + step_s, step_s)
    parts = [np.empty(0, CONTACT_DTYPE)]
    for s, grid in enumerate(grids):
        t = grid.t0 + step_s * np.arange(grid.n)

        def height(tt: np.ndarray, g: np.ndarray, grid=grid) -> np.ndarray:
            """Elevation above the mask (degrees) at times ``tt`` from stations ``g``."""
            los = grid.state(tt)[0] - pos[g]
            sin_el = np.sum(los * up[g], axis=-1) / np.linalg.norm(los, axis=-1)
            return np.degrees(np.arcsin(np.clip(sin_el, -1.0, 1.0))) - mask_deg[g]

        h = height(t[None, :], np.arange(len(stations))[:, None])  # (G, n); NaN if sgp4 failed
        above = np.pad(h > 0.0, ((0, 0), (1, 1)))
        g_run, a = np.nonzero(above[:, 1:] & ~above[:, :-1])  # a: first sample above
        b = np.nonzero(above[:, :-1] & ~above[:, 1:])[1] - 1  # b: last sample above
        # a pass between two samples: a local maximum of the samples below the mask
        g_pk, k = np.nonzero((h[:, 1:-1] > h[:, :-2]) & (h[:, 1:-1] >= h[:, 2:]) & ~above[:, 2:-2])
        t_pk, h_pk = _golden_max(lambda tt, g=g_pk: height(tt, g), t[k], t[k + 2])
        pk = h_pk > 0.0
        g_pk, k, t_pk = g_pk[pk], k[pk] + 1, t_pk[pk]
        g = np.concatenate((g_run, g_pk))
        # a run from the first or to the last sample starts or ends outside the horizon
        lo_rise = t[np.maximum(np.concatenate((a, k)) - 1, 0)]
        hi_rise = np.concatenate((t[a], t_pk))
        hi_set = t[np.minimum(np.concatenate((b, k)) + 1, grid.n - 1)]
        lo_set = np.concatenate((t[b], t_pk))
        rise = _bisect(lambda tt, g=g: height(tt, g), lo_rise, hi_rise)
        set_ = _bisect(lambda tt, g=g: height(tt, g), lo_set, hi_set)
        rise, set_ = np.maximum(rise, start_s), np.minimum(set_, end_s)
        keep = set_ > rise
        g, rise, set_ = g[keep], rise[keep], set_[keep]
        _, h_max = _golden_max(lambda tt, g=g: height(tt, g), rise, set_)
        row = np.empty(len(g), CONTACT_DTYPE)
        row["satellite"], row["station"], row["start_s"], row["end_s"] = s, g, rise, set_
        row["max_elevation_deg"] = h_max + mask_deg[g]
        parts.append(row)
        log.debug("%s: %d contact windows", satellites[s].name, len(row))
    out = np.concatenate(parts)
    return out[np.lexsort((out["start_s"], out["station"], out["satellite"]))]


def _bisect(
    f: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray, iterations: int = 40
) -> np.ndarray:
    """Roots of ``f`` in ``[lo, hi]`` by bisection, vectorised; ``f`` changes sign in each
    interval (``f(lo) > 0`` or ``f(hi) > 0``, not both)."""
    pos_lo = f(lo) > 0.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        same = (f(mid) > 0.0) == pos_lo  # the root lies in [mid, hi]
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    return 0.5 * (lo + hi)


def _golden_max(
    f: Callable[[np.ndarray], np.ndarray], lo: np.ndarray, hi: np.ndarray, iterations: int = 50
) -> tuple[np.ndarray, np.ndarray]:
    """The maximum of a unimodal ``f`` on ``[lo, hi]`` by golden-section search, vectorised:
    its place and value."""
    r = (math.sqrt(5.0) - 1.0) / 2.0
    for _ in range(iterations):
        a, b = hi - r * (hi - lo), lo + r * (hi - lo)
        left = f(a) >= f(b)  # the maximum lies in [lo, b]
        lo, hi = np.where(left, lo, a), np.where(left, b, hi)
    mid = 0.5 * (lo + hi)
    return mid, f(mid)
