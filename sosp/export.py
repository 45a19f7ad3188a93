"""``sosp export``: a schedule as CSV, KML (Google Earth) or CZML (Cesium).

* **CSV**: one row per covered target, in time order: the observation's satellite, orbit, UTC
  window and roll, and the target's id, position and weight.
* **KML** (:mod:`xml.etree.ElementTree`): targets observed and not (two folders, two styles),
  one placemark per observation with its UTC time span, and the satellites' ground tracks.
* **CZML** (:mod:`json`): targets as points, each observation as an entity available over its
  window (lines of sight from the satellite to its targets when the orbit is known), and the
  satellites as time-tagged positions with their paths, so Cesium's clock replays the plan.

Instances with ground stations (issue 60) add the stations, their contact windows and the
schedule's downlinks to each format: CSV rows of kind ``downlink`` (:data:`STATION_CSV_COLUMNS`),
KML folders of stations, contacts and downlinks with time spans, CZML station entities and a
link from satellite to station while each contact and each downlink is on. Without stations
the files are what they were before.

Satellite paths need the orbits: instances of the built-in satellites name them in
``meta["satellites"]``, and custom ones (TLE files, Walker constellations) carry their
element lines in ``meta["tle"]`` (:func:`sosp.orbits.instance_satellites`). Other instances
are exported without paths. Positions are geocentric latitude and longitude with a
spherical altitude, enough to draw. The formats are described in ``docs/formats.md``.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import logging
import math
import sys
import xml.etree.ElementTree as ET
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from collections.abc import Iterator

    import numpy as np

    from sosp.downlink import Downlink
    from sosp.instance import Instance
    from sosp.orbits import Satellite
    from sosp.schedule import Schedule

log = logging.getLogger(__name__)

#: Export formats, chosen with ``--format`` or by the file's extension.
FORMATS = ("csv", "kml", "czml")

#: Columns of the CSV export.
CSV_COLUMNS = tuple(
    "observation satellite orbit start_utc end_utc roll_deg target lat lon weight".split()
)

#: Columns the CSV export adds for an instance with ground stations: ``kind`` (``observation``
#: or ``downlink``), and for a downlink its station, the volume it sends and whose data
#: (``target=volume`` pairs joined by ``;``).
STATION_CSV_COLUMNS = ("kind", "station", "volume", "data")

#: Seconds between points of a satellite path.
PATH_STEP = 60.0

#: Equatorial radius used for the altitude of the drawn paths (km, WGS72 as in SGP4).
EARTH_RADIUS_KM = 6378.135

KML_NS = "http://www.opengis.net/kml/2.2"


# --------------------------------------------------------------------------- shared
def _lon180(lon: float) -> float:
    """Longitude in [-180, 180) (instances accept [-180, 360])."""
    return round((float(lon) + 180.0) % 360.0 - 180.0, 6)  # 1e-6 deg: the data's precision


def covered(instance: Instance, schedule: Schedule) -> list[tuple[int, int]]:
    """``(observation index, target index)`` per covered target, in time order.

    A target covered by several observations (which the validator refuses) is listed at its
    first.
    """
    obs = schedule.observations
    first: dict[int, int] = {}  # target: its first observation, in order of discovery
    for u in sorted(range(len(obs)), key=lambda u: (obs[u].start, obs[u].orbit)):
        for i in obs[u].opps:
            first.setdefault(int(instance.opp_target[i]), u)
    return [(u, k) for k, u in first.items()]


def _observations(
    instance: Instance, schedule: Schedule, cov: list[tuple[int, int]]
) -> Iterator[tuple[int, Any, list[int], str, str]]:
    """Per observation: its index, the observation, the targets it covers (:func:`covered`),
    its satellite and the description both KML and CZML show."""
    ks_of: dict[int, list[int]] = {}
    for u, k in cov:
        ks_of.setdefault(u, []).append(k)
    for u, ob in enumerate(schedule.observations):
        ks = ks_of.get(u, [])
        desc = (
            f"{instance.orbit_ids[ob.orbit]}: {len(ks)} target(s) "
            f"({', '.join(str(instance.target_ids[k]) for k in ks)}), roll {ob.roll:.2f} deg, "
            f"{ob.end - ob.start:.1f} s"
        )
        yield u, ob, ks, instance.orbit_satellite[ob.orbit], desc


def satellite_paths(
    instance: Instance, step: float = PATH_STEP
) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
    """Sub-satellite tracks over the horizon: times and ``(n, 3)`` lat, lon, altitude (km).

    None when the instance does not record its orbits (:func:`sosp.orbits.instance_satellites`).
    """
    import numpy as np

    from sosp.orbits import instance_satellites

    sats = instance_satellites(instance)
    if not sats or not instance.n_orbits:
        return None
    t0 = float(instance.orbit_start.min())
    t1 = float(instance.orbit_end.max())
    t = np.append(np.arange(t0, t1, step), t1)
    return t, subsatellite_points(sats, instance.epoch, t)


def subsatellite_points(sats: list[Satellite], epoch: str, t: np.ndarray) -> dict[str, np.ndarray]:
    """Per satellite, its ``(n, 3)`` geocentric lat, lon (degrees) and spherical altitude (km)
    at the times ``t`` (seconds from ``epoch``)."""
    import numpy as np

    from sosp.orbits import propagate

    out = {}
    for s, pos in zip(sats, propagate(sats, epoch, t)[0], strict=True):
        norm = np.linalg.norm(pos, axis=1)
        lat = np.degrees(np.arcsin(np.clip(pos[:, 2] / norm, -1.0, 1.0)))
        lon = np.degrees(np.arctan2(pos[:, 1], pos[:, 0]))
        out[s.name] = np.column_stack([lat, lon, norm - EARTH_RADIUS_KM])
    return out


def _position_at(
    paths: tuple[np.ndarray, dict[str, np.ndarray]] | None, name: str, t: float
) -> tuple[float, float, float] | None:
    """A satellite's (lat, lon, alt km) at ``t``, interpolated on its path (None: unknown)."""
    import numpy as np

    if paths is None or name not in paths[1]:
        return None
    times, track = paths
    pts = track[name]
    if not (times[0] <= t <= times[-1]) or not np.isfinite(pts).all():
        return None
    lat = float(np.interp(t, times, pts[:, 0]))
    lon = float(np.degrees(np.angle(np.interp(t, times, np.exp(1j * np.radians(pts[:, 1]))))))
    return lat, lon, float(np.interp(t, times, pts[:, 2]))


# --------------------------------------------------------------------------- CSV
def export_csv(instance: Instance, schedule: Schedule) -> str:
    """One row per covered target (:data:`CSV_COLUMNS`), in time order; with ground stations,
    the columns :data:`STATION_CSV_COLUMNS` too and then one row per downlink, in time order
    (its satellite, the orbit it starts in, UTC window, the station's position, volume and
    whose data)."""
    from sosp.orbits import utc_at

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    extra = STATION_CSV_COLUMNS if instance.stations else ()
    w.writerow(CSV_COLUMNS + extra)
    for u, k in covered(instance, schedule):
        ob = schedule.observations[u]
        w.writerow(
            [
                u,
                instance.orbit_satellite[ob.orbit],
                instance.orbit_ids[ob.orbit],
                utc_at(instance.epoch, ob.start),
                utc_at(instance.epoch, ob.end),
                f"{ob.roll:.6g}",
                instance.target_ids[k],
                f"{float(instance.target_lat[k]):.6f}",
                f"{float(instance.target_lon[k]):.6f}",
                int(instance.target_weight[k]),
            ]
            + (["observation", "", "", ""] if extra else [])
        )
    for d in sorted(schedule.downlinks, key=lambda d: (d.start, d.satellite)) if extra else ():
        sat, st = instance.satellite_names[d.satellite], instance.stations[d.station]
        j = _orbit_at(instance, sat, d.start)
        w.writerow(
            [
                "",
                sat,
                "" if j is None else instance.orbit_ids[j],
                utc_at(instance.epoch, d.start),
                utc_at(instance.epoch, d.end),
                "",
                "",
                f"{st.lat_deg:.6f}",
                f"{_lon180(st.lon_deg):.6f}",
                "",
                "downlink",
                st.id,
                f"{d.volume:.6g}",
                _whose(instance, d),
            ]
        )
    return buf.getvalue()


def _orbit_at(instance: Instance, satellite: str, t: float) -> int | None:
    """The orbit of ``satellite`` that holds time ``t`` (None: outside its orbits)."""
    for j in range(instance.n_orbits):
        if (
            instance.orbit_satellite[j] == satellite
            and instance.orbit_start[j] <= t < instance.orbit_end[j]
        ):
            return j
    return None


def _whose(instance: Instance, d: Downlink) -> str:
    """Whose data a downlink carries: ``target=volume`` pairs joined by ``;``."""
    return ";".join(
        f"{instance.target_ids[int(instance.opp_target[i])]}={v:.6g}" for i, v in d.parts
    )


def _links(instance: Instance, schedule: Schedule) -> Iterator[tuple[str, int, Any, str, str]]:
    """The contact windows, then the downlinks, of an instance with stations: per link its kind
    (``contact`` or ``downlink``), index, ``(satellite row, station row, start, end)``, name
    and the description KML and CZML show."""
    for n, c in enumerate(instance.contacts):
        sat, st = instance.satellite_names[c["satellite"]], instance.stations[c["station"]].id
        span = (int(c["satellite"]), int(c["station"]), float(c["start_s"]), float(c["end_s"]))
        desc = f"contact, max elevation {float(c['max_elevation_deg']):.1f} deg"
        yield "contact", n, span, f"{sat} -> {st}", desc
    for n, d in enumerate(schedule.downlinks):
        sat, st = instance.satellite_names[d.satellite], instance.stations[d.station].id
        desc = f"downlink of {d.volume:.6g} memory units: {_whose(instance, d)}"
        yield "downlink", n, (d.satellite, d.station, d.start, d.end), f"{sat} -> {st}", desc


# --------------------------------------------------------------------------- KML
def _sub(parent: ET.Element, tag: str, text: str | None = None, **children: str) -> ET.Element:
    """Add element ``tag`` with ``text`` and, in order, a child element per keyword (its
    text the value)."""
    el = ET.SubElement(parent, tag)
    if text is not None:
        el.text = text
    for child, value in children.items():
        _sub(el, child, value)
    return el


def _style(doc: ET.Element, sid: str, color: str, scale: float, line: bool = False) -> None:
    size = {"width" if line else "scale": f"{scale:g}"}
    style = ET.SubElement(doc, "Style", id=sid)
    style = _sub(style, "LineStyle" if line else "IconStyle", color=color, **size)
    if not line:
        href = "http://maps.google.com/mapfiles/kml/shapes/placemark_circle.png"
        _sub(style, "Icon", href=href)


def _split_antimeridian(points: list[tuple[float, float, float]]) -> list[list[tuple]]:
    """Cut a track where it crosses the antimeridian (else the line wraps round the globe)."""
    parts: list[list[tuple]] = [[]]
    for p in points:
        if parts[-1] and abs(p[1] - parts[-1][-1][1]) > 180.0:
            parts.append([])
        parts[-1].append(p)
    return [q for q in parts if len(q) > 1]


def _coords(points: list[tuple[float, float, float]]) -> str:
    return " ".join(f"{lon:.5f},{lat:.5f},{alt:.0f}" for lat, lon, alt in points)


def export_kml(instance: Instance, schedule: Schedule) -> str:
    """A KML document: targets observed and not, observations with time spans, paths."""
    from sosp.orbits import utc_at

    ET.register_namespace("", KML_NS)
    root = ET.Element("kml", xmlns=KML_NS)
    doc = _sub(
        root,
        "Document",
        name=f"{instance.name or 'instance'}: {schedule.method or 'schedule'}",
        description=f"epoch {instance.epoch}; {len(schedule)} observations; made by sosp",
    )
    _style(doc, "observed", "ff00c000", 0.9)  # KML colours are aabbggrr
    _style(doc, "unobserved", "ff0000ff", 0.6)
    _style(doc, "path", "9fffffff", 1.5, line=True)
    _style(doc, "sight", "ff00ffff", 2.0, line=True)
    if instance.stations:
        _style(doc, "station", "ffff8000", 1.2)
        _style(doc, "contact", "80c0c0c0", 1.0, line=True)
        _style(doc, "downlink", "ffff00ff", 3.0, line=True)
    cov = covered(instance, schedule)
    by_target = {k: u for u, k in cov}
    paths = satellite_paths(instance)

    def target_mark(folder: ET.Element, k: int, style: str, desc: str) -> None:
        pm = _sub(folder, "Placemark", name=str(instance.target_ids[k]), description=desc)
        _sub(pm, "styleUrl", f"#{style}")
        lon, lat = _lon180(instance.target_lon[k]), float(instance.target_lat[k])
        _sub(pm, "Point", coordinates=f"{lon:.6f},{lat:.6f},0")

    f_obs = _sub(doc, "Folder", name=f"targets observed ({len(cov)})")
    for u, k in cov:
        ob = schedule.observations[u]
        target_mark(
            f_obs,
            k,
            "observed",
            f"weight {int(instance.target_weight[k])}; observed by "
            f"{instance.orbit_satellite[ob.orbit]} ({instance.orbit_ids[ob.orbit]}) "
            f"{utc_at(instance.epoch, ob.start)} to {utc_at(instance.epoch, ob.end)}, "
            f"roll {ob.roll:.2f} deg",
        )
    missed = [k for k in range(instance.n_targets) if k not in by_target]
    f_not = _sub(doc, "Folder", name=f"targets not observed ({len(missed)})", visibility="1")
    for k in missed:
        target_mark(f_not, k, "unobserved", f"weight {int(instance.target_weight[k])}")

    f_win = _sub(doc, "Folder", name=f"observations ({len(schedule)})")
    for _u, ob, ks, sat, desc in _observations(instance, schedule, cov):
        begin, end = utc_at(instance.epoch, ob.start), utc_at(instance.epoch, ob.end)
        pm = _sub(f_win, "Placemark", name=f"{sat} {begin}", description=desc)
        _sub(pm, "TimeSpan", begin=begin, end=end)
        _sub(pm, "styleUrl", "#sight")
        geo = _sub(pm, "MultiGeometry")
        at = _position_at(paths, sat, 0.5 * (ob.start + ob.end))
        for k in ks:
            tgt = (float(instance.target_lat[k]), _lon180(instance.target_lon[k]), 0.0)
            if at is not None:  # line of sight from the satellite to the target
                sight = _coords([(at[0], at[1], at[2] * 1000.0), tgt])
                _sub(geo, "LineString", altitudeMode="absolute", coordinates=sight)
            else:
                _sub(geo, "Point", coordinates=_coords([tgt]))

    if instance.stations:
        _kml_stations(doc, instance, schedule, paths)

    if paths is not None:
        f_path = _sub(doc, "Folder", name="satellite paths")
        for name, pts in paths[1].items():
            geo = _sub(_sub(f_path, "Placemark", name=name, styleUrl="#path"), "MultiGeometry")
            finite = [(float(a), float(b), 0.0) for a, b, _ in pts if math.isfinite(a + b)]
            for part in _split_antimeridian(finite):
                _sub(geo, "LineString", tessellate="1", coordinates=_coords(part))
    ET.indent(root, space=" ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _kml_stations(
    doc: ET.Element,
    instance: Instance,
    schedule: Schedule,
    paths: tuple[np.ndarray, dict[str, np.ndarray]] | None,
) -> None:
    """Folders of ground stations (points), contact windows and downlinks (each a placemark
    with its UTC time span, a line from the satellite at mid-window to the station when the
    orbit is known, else the station's point)."""
    from sosp.orbits import utc_at

    f_st = _sub(doc, "Folder", name=f"ground stations ({len(instance.stations)})")
    for st in instance.stations:
        desc = f"{st.description}; " if st.description else ""
        desc += f"{st.antennas} antenna(s), elevation mask {st.min_elevation_deg:g} deg"
        pm = _sub(f_st, "Placemark", name=st.id, description=desc)
        _sub(pm, "styleUrl", "#station")
        _sub(pm, "Point", coordinates=f"{_lon180(st.lon_deg):.6f},{st.lat_deg:.6f},{st.alt_m:.0f}")
    folders = {
        "contact": _sub(doc, "Folder", name=f"contact windows ({len(instance.contacts)})"),
        "downlink": _sub(doc, "Folder", name=f"downlinks ({len(schedule.downlinks)})"),
    }
    for kind, _n, (sat, g, t0, t1), name, desc in _links(instance, schedule):
        begin, end = utc_at(instance.epoch, t0), utc_at(instance.epoch, t1)
        pm = _sub(folders[kind], "Placemark", name=f"{name} {begin}", description=desc)
        _sub(pm, "TimeSpan", begin=begin, end=end)
        _sub(pm, "styleUrl", f"#{kind}")
        st = instance.stations[g]
        ground = (st.lat_deg, _lon180(st.lon_deg), st.alt_m)
        at = _position_at(paths, instance.satellite_names[sat], 0.5 * (t0 + t1))
        if at is not None:
            line = _coords([(at[0], at[1], at[2] * 1000.0), ground])
            _sub(pm, "LineString", altitudeMode="absolute", coordinates=line)
        else:
            _sub(pm, "Point", coordinates=_coords([ground]))


# --------------------------------------------------------------------------- CZML
def _rgba(r: int, g: int, b: int, a: int = 255) -> dict[str, Any]:
    return {"rgba": [r, g, b, a]}


def export_czml(instance: Instance, schedule: Schedule) -> str:
    """A CZML document (a JSON list of packets) replaying the schedule in Cesium."""
    from sosp.orbits import utc_at

    utc = partial(utc_at, instance.epoch)
    cov = covered(instance, schedule)
    by_target = {k: u for u, k in cov}
    paths = satellite_paths(instance)
    t0 = float(instance.orbit_start.min()) if instance.n_orbits else 0.0
    t1 = float(instance.orbit_end.max()) if instance.n_orbits else 0.0
    horizon = f"{utc(t0)}/{utc(t1)}"
    packets: list[dict[str, Any]] = [
        {
            "id": "document",
            "name": f"{instance.name or 'instance'}: {schedule.method or 'schedule'}",
            "version": "1.0",
            "clock": {
                "interval": horizon,
                "currentTime": utc(t0),
                "multiplier": 60,
                "range": "LOOP_STOP",
                "step": "SYSTEM_CLOCK_MULTIPLIER",
            },
        }
    ]
    for k in range(instance.n_targets):
        u = by_target.get(k)
        lat, lon = round(float(instance.target_lat[k]), 6), _lon180(instance.target_lon[k])
        pkt: dict[str, Any] = {
            "id": f"target/{instance.target_ids[k]}",
            "name": str(instance.target_ids[k]),
            "position": {"cartographicDegrees": [lon, lat, 0.0]},
            "properties": {"weight": int(instance.target_weight[k]), "observed": u is not None},
        }
        if u is None:
            pkt["description"] = f"weight {int(instance.target_weight[k])}; not observed"
            pkt["point"] = {"pixelSize": 6, "color": _rgba(220, 40, 40)}
        else:
            ob = schedule.observations[u]
            t_end = utc(ob.end)
            pkt["description"] = (
                f"weight {int(instance.target_weight[k])}; observed by "
                f"{instance.orbit_satellite[ob.orbit]} {utc(ob.start)} to {t_end}, "
                f"roll {ob.roll:.2f} deg"
            )
            # Yellow until its observation ends, then green.
            pkt["point"] = {
                "pixelSize": 8,
                "color": [
                    {"interval": f"{utc(t0)}/{t_end}", **_rgba(240, 200, 0)},
                    {"interval": f"{t_end}/{utc(max(t1, ob.end))}", **_rgba(0, 190, 0)},
                ],
            }
        packets.append(pkt)
    for u, ob, ks, sat, desc in _observations(instance, schedule, cov):
        pkt = {
            "id": f"observation/{u}",
            "name": f"{sat} {utc(ob.start)}",
            "availability": f"{utc(ob.start)}/{utc(ob.end)}",
            "description": desc,
            "properties": {
                "satellite": sat,
                "orbit": instance.orbit_ids[ob.orbit],
                "roll": round(ob.roll, 6),
                "targets": [str(instance.target_ids[k]) for k in ks],
            },
        }
        at = _position_at(paths, sat, 0.5 * (ob.start + ob.end))
        if at is not None and ks:
            coords: list[float] = []
            for k in ks:  # a fan of lines of sight from the satellite
                coords += [_lon180(at[1]), round(at[0], 6), round(at[2] * 1000.0, 1)]
                coords += [
                    _lon180(instance.target_lon[k]),
                    round(float(instance.target_lat[k]), 6),
                    0.0,
                ]
            pkt["polyline"] = {
                "positions": {"cartographicDegrees": coords},
                "width": 2,
                "arcType": "NONE",
                "material": {"solidColor": {"color": _rgba(255, 220, 0)}},
            }
        packets.append(pkt)
    if paths is not None:
        times, tracks = paths
        for name, pts in tracks.items():
            samples: list[float] = []
            for t, (lat, lon, alt) in zip(times, pts, strict=True):
                if math.isfinite(lat + lon + alt):
                    samples += [round(float(t), 3), _lon180(lon), round(float(lat), 6)]
                    samples.append(round(float(alt) * 1000.0, 1))  # metres to 0.1, seconds to 1e-3
            packets.append(
                {
                    "id": f"satellite/{name}",
                    "name": name,
                    "availability": horizon,
                    "position": {
                        "epoch": instance.epoch,
                        "interpolationAlgorithm": "LAGRANGE",
                        "interpolationDegree": 5,
                        "cartographicDegrees": samples,
                    },
                    "point": {"pixelSize": 7, "color": _rgba(255, 255, 255)},
                    "label": {
                        "text": name,
                        "font": "11pt sans-serif",
                        "pixelOffset": {"cartesian2": [10, 0]},
                    },
                    "path": {
                        "width": 1,
                        "leadTime": 0,
                        "trailTime": 6000,
                        "resolution": 60,
                        "material": {"solidColor": {"color": _rgba(255, 255, 255, 140)}},
                    },
                }
            )
    if instance.stations:
        packets += _czml_stations(instance, schedule, set(paths[1]) if paths else set())
    return json.dumps(packets, indent=1, allow_nan=False) + "\n"


def _czml_stations(instance: Instance, schedule: Schedule, drawn: set[str]) -> list[dict[str, Any]]:
    """Packets of the ground stations (points), and per contact window and per downlink one
    entity available over its window; when the satellite's path is drawn (in ``drawn``), a
    polyline between the satellite and the station that follows both (references to their
    positions), thin grey for a contact, thick magenta while data flows."""
    from sosp.orbits import utc_at

    utc = partial(utc_at, instance.epoch)
    out: list[dict[str, Any]] = []
    for st in instance.stations:
        out.append(
            {
                "id": f"station/{st.id}",
                "name": st.id,
                "description": st.description,
                "position": {
                    "cartographicDegrees": [
                        _lon180(st.lon_deg),
                        round(st.lat_deg, 6),
                        round(st.alt_m, 1),
                    ]
                },
                "point": {"pixelSize": 9, "color": _rgba(0, 128, 255)},
                "label": {
                    "text": st.id,
                    "font": "11pt sans-serif",
                    "pixelOffset": {"cartesian2": [10, 0]},
                },
                "properties": {
                    "antennas": st.antennas,
                    "min_elevation_deg": st.min_elevation_deg,
                },
            }
        )
    look = {"contact": (1, _rgba(200, 200, 200, 120)), "downlink": (3, _rgba(255, 0, 255))}
    for kind, n, (sat, g, t0, t1), name, desc in _links(instance, schedule):
        sname, sid = instance.satellite_names[sat], instance.stations[g].id
        pkt: dict[str, Any] = {
            "id": f"{kind}/{n}",
            "name": f"{name} {utc(t0)}",
            "availability": f"{utc(t0)}/{utc(t1)}",
            "description": desc,
            "properties": {"satellite": sname, "station": sid},
        }
        if kind == "downlink":
            d = schedule.downlinks[n]
            pkt["properties"]["volume"] = round(d.volume, 6)
            pkt["properties"]["data"] = [
                {"target": str(instance.target_ids[k]), "volume": round(v, 6)}
                for k, v in ((int(instance.opp_target[i]), v) for i, v in d.parts)
            ]
        if sname in drawn:
            width, colour = look[kind]
            ends = [f"satellite/{sname}#position", f"station/{sid}#position"]
            pkt["polyline"] = {
                "positions": {"references": ends},
                "width": width,
                "arcType": "NONE",
                "material": {"solidColor": {"color": colour}},
            }
        out.append(pkt)
    return out


# --------------------------------------------------------------------------- CLI
def add_export_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``export`` to the ``sosp`` subcommands."""
    p = subparsers.add_parser(
        "export",
        help="write a schedule as CSV (a row per observed target), KML or CZML",
        description="Write a schedule for a planner's tools: CSV (one row per covered target "
        "with satellite, orbit, UTC window, roll, target and weight), KML for Google Earth or "
        "CZML for Cesium (targets observed and not, observation intervals, and the satellites' "
        "paths when the instance records its orbits). See docs/formats.md.",
    )
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument("schedule", help="schedule file (.json)")
    p.add_argument(
        "--format", choices=FORMATS, default=None, help="csv, kml or czml (default: by extension)"
    )
    p.add_argument("-o", "--output", required=True, help="file to write")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_export)
    return p


def cmd_export(args: argparse.Namespace) -> int:
    """Handler of ``sosp export``."""
    from sosp.errors import InputError
    from sosp.instance import load_instance
    from sosp.io import atomic_write_text, check_output
    from sosp.orbits import instance_satellites
    from sosp.schedule import load_schedule

    check_output(args.output)
    fmt = args.format or Path(args.output).suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise InputError(
            f"-o: cannot tell the format from {Path(args.output).name!r}; give --format "
            f"({', '.join(FORMATS)}) or a .csv, .kml or .czml file"
        )
    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    exporter = {"csv": export_csv, "kml": export_kml, "czml": export_czml}[fmt]
    atomic_write_text(args.output, exporter(inst, sched))
    n = len(covered(inst, sched))
    info = {
        "output": args.output,
        "format": fmt,
        "observations": len(sched),
        "targets_observed": n,
        "targets": inst.n_targets,
        "paths": fmt != "csv" and instance_satellites(inst) is not None,
    }
    text = (
        f"wrote {args.output} ({fmt}): {len(sched)} observations, {n} of "
        f"{inst.n_targets} targets observed"
    )
    if inst.stations:
        info["stations"], info["downlinks"] = len(inst.stations), len(sched.downlinks)
        text += f", {len(sched.downlinks)} downlinks to {len(inst.stations)} stations"
    if fmt != "csv" and not info["paths"]:
        text += "; no satellite paths (the instance does not record its orbits)"
    sys.stdout.write((json.dumps(info) if args.json else text) + "\n")
    return 0
