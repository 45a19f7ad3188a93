"""Scenario generator: the paper's reference scenarios B1..B10, C1..C10 and custom ones.

Section 6.1 of the paper: four satellites (JB-3A, JB-3C, CBERS-1, CBERS-2), lateral roll within
[-33, 33] degrees, a 6 degree field of view, a 24 h horizon, Table 1 resources; scenario ``Bk``
has ``100 k`` targets uniform in latitude [-30, 60] and longitude [0, 150] (degrees), ``Ck``
has ``100 k`` targets in latitude [30, 60] and longitude [90, 120]; weights are integers uniform
in [2, 10]. Opportunities come from real-orbit geometry (:mod:`sosp.visibility`), not STK, so
the counts differ from the paper's Tables 3-4 (see ``docs/scenarios.md``).

Everything is deterministic for a given name and seed: the one random generator is
``numpy.random.default_rng([seed, crc32(name)])``.
"""

from __future__ import annotations

import logging
import math
import os
import re
import time
import zlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sosp.errors import InputError
from sosp.instance import MAX_WEIGHT, OPP_KEYS, Instance, Resources
from sosp.io import Column, read_id_table
from sosp.orbits import (
    Satellite,
    builtin_satellites,
    element_epoch,
    read_tle,
    stale_elements,
    utc_iso,
)
from sosp.visibility import find_opportunities

log = logging.getLogger(__name__)

#: Default start of the horizon (and the common element epoch of the built-in satellites, so
#: no long propagation from the element epoch is involved).
DEFAULT_START = "2026-06-01T00:00:00Z"

#: Target regions (lat_min, lat_max, lon_min, lon_max) of the two scenario groups, degrees.
REGIONS: dict[str, tuple[float, float, float, float]] = {
    "B": (-30.0, 60.0, 0.0, 150.0),
    "C": (30.0, 60.0, 90.0, 120.0),
}

#: The numbers of a target CSV row, their ranges and what the error says they must be
#: (:func:`read_targets_csv`; a weight must also be an integer).
CSV_RANGES: tuple[Column, ...] = (
    ("lat", lambda x: -90.0 <= x <= 90.0, "a finite number in [-90, 90]"),
    ("lon", lambda x: -180.0 <= x <= 360.0, "a finite number in [-180, 360]"),
    (
        "weight",
        lambda x: 0 <= x <= MAX_WEIGHT and x.is_integer(),
        f"an integer in [0, {MAX_WEIGHT:.0e}]",
    ),
)

#: Target weights: integers uniform in [2, 10] (inclusive).
WEIGHT_RANGE = (2, 10)

GENERATOR = "sosp.scenarios"


def scenario_names() -> list[str]:
    """``["B1", ..., "B10", "C1", ..., "C10"]``."""
    return [f"{g}{k}" for g in "BC" for k in range(1, 11)]


def _parse_name(name: str) -> tuple[str, int]:
    if not isinstance(name, str) or not re.fullmatch(r"[BC](10|[1-9])", name):
        raise InputError(f"scenario: unknown name {name!r}; expected B1..B10 or C1..C10")
    return name[0], int(name[1:])


def _rng(name: str, seed: int) -> np.random.Generator:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
    return np.random.default_rng([int(seed), zlib.crc32(name.encode("utf-8"))])


def random_targets(
    count: int,
    region: tuple[float, float, float, float],
    rng: np.random.Generator,
) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """``count`` targets uniform in latitude and longitude (degrees) inside ``region``.

    Parameters
    ----------
    count
        Number of targets (ids ``"T0001"``, ``"T0002"``, ...; wider when count > 9999).
    region
        ``(lat_min, lat_max, lon_min, lon_max)``. A box across the antimeridian is given
        either with ``lon_max`` above 180 (``170, 190``) or, as GeoJSON bounding boxes do,
        with its west edge east of its east edge (``170, -170``); its longitudes are then
        returned in [-180, 180).
    rng
        The generator; draws latitudes, then longitudes, then weights.

    Returns
    -------
    ids, lat, lon, weight
    """
    lat0, lat1, lon0, lon1 = (float(x) for x in region)
    if not -90.0 <= lat0 <= lat1 <= 90.0:
        raise InputError(f"region: expected -90 <= lat0 <= lat1 <= 90, got {lat0}, {lat1}")
    across = lon0 > lon1 and -180.0 <= lon1 and lon0 <= 180.0
    if across:
        lon1 += 360.0  # west edge east of the east edge: the box crosses 180 degrees
    if not -180.0 <= lon0 <= lon1 <= 360.0:
        raise InputError(
            "region: expected -180 <= lon0 <= lon1 <= 360 (or lon0 > lon1 in [-180, 180] "
            f"for a box across 180 degrees), got {lon0}, {float(region[3])}"
        )
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 0:
        raise InputError(f"count: expected a non-negative integer, got {count!r}")
    width = max(4, len(str(count)))
    ids = [f"T{i:0{width}d}" for i in range(1, count + 1)]
    lat = rng.uniform(lat0, lat1, count)
    lon = rng.uniform(lon0, lon1, count)
    if across:
        lon = (lon + 180.0) % 360.0 - 180.0
    weight = rng.integers(WEIGHT_RANGE[0], WEIGHT_RANGE[1] + 1, count)
    return ids, lat, lon, weight


def generate_scenario(
    name: str,
    seed: int = 0,
    *,
    start: str | None = None,
    hours: float = 24.0,
    resources: Resources | None = None,
    max_roll: float = 33.0,
    fov: float = 6.0,
    min_sun_elevation: float | None = None,
) -> Instance:
    """The paper's reference scenario ``name`` (B1..B10, C1..C10) with real-orbit geometry.

    Parameters
    ----------
    name
        ``"Bk"`` (large area) or ``"Ck"`` (small area), ``k`` in 1..10: ``100 k`` targets.
    seed
        Seed of the target draw (with the name).
    start
        Horizon start, ISO 8601 with any offset (stored as UTC); :data:`DEFAULT_START` (the
        built-in satellites' element epoch) by default.
    hours
        Horizon length.
    resources
        Per-orbit resources; Table 1 (:class:`~sosp.instance.Resources` defaults) by default.
    max_roll, fov
        theta_max and the sensor's full field of view sigma, degrees.
    min_sun_elevation
        Optional daylight rule (degrees); off by default as in the paper.

    Returns
    -------
    Instance
        Named ``name``; ``meta`` records the provenance.
    """
    group, k = _parse_name(name)
    return custom_scenario(
        region=REGIONS[group],
        count=100 * k,
        seed=seed,
        start=DEFAULT_START if start is None else start,
        hours=hours,
        resources=resources,
        max_roll=max_roll,
        fov=fov,
        min_sun_elevation=min_sun_elevation,
        name=name,
    )


def custom_scenario(
    *,
    targets: tuple[Sequence[Any], Any, Any, Any] | None = None,
    region: tuple[float, float, float, float] | None = None,
    count: int | None = None,
    seed: int = 0,
    satellites: Sequence[Satellite] | str | os.PathLike[str] | None = None,
    start: str | None = None,
    hours: float = 24.0,
    resources: Resources | None = None,
    max_roll: float = 33.0,
    fov: float = 6.0,
    min_sun_elevation: float | None = None,
    name: str = "custom",
) -> Instance:
    """An instance for your own targets or region and satellites.

    Parameters
    ----------
    targets
        ``(ids, lat, lon, weight)`` (e.g. from :func:`read_targets_csv`); or else
    region, count
        ``(lat0, lat1, lon0, lon1)`` and the number of random targets drawn in it
        (uniform in lat/lon, weights uniform integers in [2, 10]) with ``seed``.
    seed
        Seed of the target draw (with ``name``).
    satellites
        A list of :class:`~sosp.orbits.Satellite`, the path of a two- or three-line element
        file (:func:`~sosp.orbits.parse_tle`), or None for the built-in four.
    start
        Horizon start, ISO 8601 with any offset (stored as UTC). None: the latest element
        epoch of the satellites (for the built-in ones :data:`DEFAULT_START`), so element
        sets are not silently propagated for years. A horizon reaching more than
        :data:`~sosp.orbits.STALE_DAYS` days from a satellite's element epoch is logged as a
        warning naming the satellite and the distance.
    hours, resources, max_roll, fov, min_sun_elevation
        As in :func:`generate_scenario`.
    name
        Instance name (also seeds the draw together with ``seed``).
    """
    if (targets is None) == (region is None):
        raise InputError("custom scenario: give exactly one of targets= or region=")
    rng = _rng(name, seed)
    meta: dict[str, Any] = {"scenario": name, "seed": int(seed)}
    if targets is not None:
        if count is not None:
            raise InputError("custom scenario: count= goes with region=, not targets=")
        try:
            ids, lat, lon, weight = targets
        except (TypeError, ValueError):
            raise InputError("targets: expected (ids, lat, lon, weight)") from None
        ids = [str(i) for i in ids]
        meta["targets"] = "given"
    else:
        if count is None:
            raise InputError("custom scenario: region= needs count=")
        ids, lat, lon, weight = random_targets(count, region, rng)  # type: ignore[arg-type]
        meta["region"] = [float(x) for x in region]  # type: ignore[union-attr]
    if satellites is None:
        sats = builtin_satellites()
        meta["satellite_source"] = "builtin"
    elif isinstance(satellites, str | os.PathLike):
        sats = read_tle(satellites)
        meta["satellite_source"] = f"TLE file {Path(satellites).name}"
    else:
        sats = list(satellites)
        meta["satellite_source"] = "given"
    if not sats:
        raise InputError("satellites: need at least one satellite")
    names = [s.name for s in sats]
    if len(set(names)) != len(names):
        raise InputError("satellites: names must be unique (they make the orbit ids)")
    if meta["satellite_source"] != "builtin":
        # The orbits themselves (the lines read, or the elements written as TLE lines), so
        # that exports can draw the satellites' paths (:func:`sosp.orbits.instance_satellites`).
        from sgp4.exporter import export_tle

        meta["tle"] = [[s.name, *(s.tle or export_tle(s.satrec))] for s in sats]
    if start is None:
        start = max((element_epoch(s) for s in sats), key=lambda e: utc_iso(e))
    start = utc_iso(start, "start")
    if not (isinstance(hours, int | float) and math.isfinite(hours) and hours > 0):
        raise InputError(f"hours: expected a positive number, got {hours!r}")
    for sat_name, days in stale_elements(sats, start, hours):
        log.warning(
            "satellite %s: the horizon reaches %.1f days from its element epoch %s; SGP4 "
            "errors grow with that distance (use elements near the horizon, or --start near "
            "the epoch)",
            sat_name,
            days,
            element_epoch(next(s for s in sats if s.name == sat_name)),
        )
    lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
    if not (len(ids) == lat.size == lon.size == np.size(weight)):
        raise InputError("targets: ids, lat, lon and weight differ in length")
    bad = np.flatnonzero(~np.isfinite(lat) | (np.abs(lat) > 90) | ~np.isfinite(lon))
    if bad.size:
        raise InputError(f"targets[{bad[0]}]: invalid latitude/longitude")
    t_begin = time.perf_counter()
    revs, opps = find_opportunities(
        sats,
        lat,
        lon,
        epoch=start,
        horizon=(0.0, hours * 3600.0),
        max_roll=max_roll,
        fov=fov,
        min_sun_elevation=min_sun_elevation,
    )
    opp_ids = [f"{ids[k]}@{revs.ids[j]}" for k, j in zip(opps.target, opps.orbit, strict=True)]
    full_meta = {
        "generator": GENERATOR,
        **meta,
        "satellites": [s.name for s in sats],
        "start": start,
        "hours": float(hours),
        "max_roll": float(max_roll),
        "fov": float(fov),
        "min_sun_elevation": None if min_sun_elevation is None else float(min_sun_elevation),
    }
    inst = Instance.from_arrays(
        epoch=start,
        target_ids=list(ids),
        target_lat=lat,
        target_lon=lon,
        target_weight=weight,
        orbit_ids=list(revs.ids),
        orbit_satellite=[sats[i].name for i in revs.satellite],
        orbit_start=revs.start,
        orbit_end=revs.end,
        resources=resources if resources is not None else Resources(),
        **{f"opp_{k}": getattr(opps, k) for k in OPP_KEYS},
        opp_ids=opp_ids,
        name=name,
        meta=full_meta,
    )
    log.info(
        "scenario %s: %d targets, %d orbits, %d opportunities (EN %d) in %.2f s",
        name,
        inst.n_targets,
        inst.n_orbits,
        inst.n_opps,
        inst.observable_targets,
        time.perf_counter() - t_begin,
    )
    return inst


def read_targets_csv(
    path: str | os.PathLike[str],
) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """Read targets from a CSV file with the header ``id,lat,lon,weight``.

    Latitude in [-90, 90] and longitude in [-180, 360] degrees (finite); weight a
    non-negative integer (``"4"`` or ``"4.0"``); ids unique and non-empty. Columns may come
    in any order; extra columns are ignored.

    Returns
    -------
    ids, lat, lon, weight

    Raises
    ------
    InputError
        Naming the file and the line (1-based, the header is line 1) and field at fault.
    """
    rows = read_id_table(path, CSV_RANGES, "targets")
    lat, lon, weight = (np.array([r[2][k] for r in rows]) for k, _, _ in CSV_RANGES)
    return [r[1] for r in rows], lat, lon, weight.astype(np.int64)
