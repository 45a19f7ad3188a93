"""Events for re-planning: new and cancelled targets, weight changes, outages, cloud.

The file format (``format: "sosp-events"``, ``version: 1``) is documented in
``docs/formats.md``. It is read against the instance the plan was made for
(:func:`load_events`, :func:`parse_events`): every reference (target, satellite) and every time
is checked there, and a bad event raises :class:`~sosp.errors.InputError` with one line naming
the event's index and field, so ``sosp replan`` exits with code 2 and writes nothing.

Times are ISO 8601 UTC strings or seconds from the horizon start (the first orbit's start);
:class:`Events` holds them as seconds from the instance epoch, as every other time in sosp.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from sosp.errors import InputError
from sosp.instance import MAX_WEIGHT, Instance
from sosp.io import is_finite_number, read_json

FORMAT_NAME = "sosp-events"
FORMAT_VERSION = 1

#: The event types and the keys each takes (required, optional).
KINDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "new_target": (("id", "lat", "lon", "weight"), ("deadline",)),
    "cancel": (("target",), ()),
    "weight": (("target", "weight"), ()),
    "outage": (("satellite", "from", "to"), ()),
    "cloud": (("from", "to", "probability"), ("targets", "area")),
}


@dataclass(frozen=True)
class NewTarget:
    """A target to add: id, position (degrees), weight and an optional deadline (seconds
    from the epoch; its observation must end by then)."""

    id: str
    lat: float
    lon: float
    weight: int
    deadline: float | None = None


@dataclass(frozen=True)
class Outage:
    """Satellite ``satellite`` (a name of :attr:`Instance.satellite_names`) cannot observe
    over ``[start, end]`` (seconds from the epoch)."""

    satellite: str
    start: float
    end: float


@dataclass(frozen=True)
class Cloud:
    """Cloud over ``targets`` (target ids, new ones included) or over the box ``area``
    ``(lat0, lat1, lon0, lon1)`` during ``[start, end]``, covering with ``probability``."""

    start: float
    end: float
    probability: float
    targets: tuple[str, ...] = ()
    area: tuple[float, float, float, float] | None = None


@dataclass(frozen=True)
class Events:
    """What changed since the plan was made (all checked against its instance)."""

    new_targets: tuple[NewTarget, ...] = ()
    cancelled: tuple[str, ...] = ()
    weights: Mapping[str, int] | None = None
    outages: tuple[Outage, ...] = ()
    clouds: tuple[Cloud, ...] = ()

    @property
    def empty(self) -> bool:
        return not (
            self.new_targets or self.cancelled or self.weights or self.outages or self.clouds
        )

    def __len__(self) -> int:
        n = len(self.weights or {})
        return (
            n + len(self.new_targets) + len(self.cancelled) + len(self.outages) + len(self.clouds)
        )


def horizon(instance: Instance) -> tuple[float, float]:
    """The instance's horizon: from its first orbit's start to its last orbit's end."""
    if not instance.n_orbits:
        return 0.0, 0.0
    return float(instance.orbit_start.min()), float(instance.orbit_end.max())


def parse_time(value: Any, instance: Instance, where: str, source: str | None = None) -> float:
    """A time as seconds from the epoch: an ISO 8601 UTC string, or seconds from the horizon
    start; :class:`InputError` naming ``where`` when it is neither or lies outside the
    horizon."""
    from sosp.orbits import seconds_after

    h0, h1 = horizon(instance)
    if isinstance(value, str):  # a command line's seconds come as text
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, str):
        try:
            t = seconds_after(instance.epoch, value)
        except InputError:
            raise InputError(f"{where}: not an ISO 8601 time: {value!r}", source=source) from None
    elif is_finite_number(value):
        t = h0 + float(value)
    else:
        raise InputError(
            f"{where}: expected an ISO 8601 time or seconds, got {value!r}", source=source
        )
    if not h0 - 1e-6 <= t <= h1 + 1e-6:
        raise InputError(
            f"{where}: {value!r} is outside the horizon [{h0:g}, {h1:g}] s", source=source
        )
    return t


def parse_events(data: Any, instance: Instance, source: str | None = None) -> Events:
    """Read an events document (a dict with ``events``, or the list itself) for ``instance``.

    Raises
    ------
    InputError
        One line naming ``events[i].field``: an unknown type, target or satellite, a time
        that is not one or lies outside the horizon, ``from`` not before ``to``, a
        probability outside [0, 1], a weight that is not an integer in [0, 1e9], a new
        target whose id is taken.
    """
    if isinstance(data, dict):
        if data.get("format", FORMAT_NAME) != FORMAT_NAME:
            raise InputError(f"format: expected {FORMAT_NAME!r}", source=source)
        if data.get("version", FORMAT_VERSION) != FORMAT_VERSION:
            raise InputError(f"version: this sosp reads version {FORMAT_VERSION}", source=source)
        if "events" not in data:
            raise InputError("missing key 'events'", source=source)
        data = data["events"]
    if not isinstance(data, list):
        raise InputError("events: expected a list", source=source)
    known = instance.target_index
    sats = set(instance.satellite_names)
    new: list[NewTarget] = []
    cancelled: list[str] = []
    weights: dict[str, int] = {}
    outages: list[Outage] = []
    clouds: list[Cloud] = []
    new_ids: set[str] = set()

    for i, ev in enumerate(data):
        at = f"events[{i}]"

        def bad(msg: str, key: str = "", at: str = at) -> InputError:
            return InputError(f"{at}{'.' + key if key else ''}: {msg}", source=source)

        if not isinstance(ev, dict):
            raise bad("expected an object")
        kind = ev.get("type")
        if kind not in KINDS:
            raise bad(f"unknown type {kind!r} (expected one of {', '.join(KINDS)})", "type")
        need, optional = KINDS[kind]
        for key in need:
            if key not in ev:
                raise bad(f"missing key {key!r}")
        extra = sorted(set(ev) - {"type", *need, *optional})
        if extra:
            raise bad(f"unexpected key for a {kind} event", extra[0])

        def target(key: str = "target", value: Any = None, ev: dict = ev) -> str:
            tid = ev[key] if value is None else value
            if isinstance(tid, bool) or not isinstance(tid, str | int):
                raise bad(f"expected a target id, got {tid!r}", key)
            if str(tid) not in known and str(tid) not in new_ids:
                raise bad(f"unknown target {tid!r}", key)
            return str(tid)

        def weight(ev: dict = ev) -> int:
            w = ev["weight"]
            if not is_finite_number(w) or w < 0 or w > MAX_WEIGHT or float(w) != round(w):
                raise bad(f"expected an integer in [0, {MAX_WEIGHT:.0e}], got {w!r}", "weight")
            return int(w)

        def span(ev: dict = ev, at: str = at) -> tuple[float, float]:
            t0 = parse_time(ev["from"], instance, f"{at}.from", source)
            t1 = parse_time(ev["to"], instance, f"{at}.to", source)
            if not t0 < t1:
                raise bad(f"must be after from ({ev['from']!r}), got {ev['to']!r}", "to")
            return t0, t1

        if kind == "new_target":
            tid = ev["id"]
            if isinstance(tid, bool) or not isinstance(tid, str | int) or not str(tid):
                raise bad(f"expected a non-empty id, got {tid!r}", "id")
            if str(tid) in known or str(tid) in new_ids:
                raise bad(f"target {tid!r} exists already", "id")
            for key, lo, hi in (("lat", -90.0, 90.0), ("lon", -180.0, 360.0)):
                if not is_finite_number(ev[key]) or not lo <= ev[key] <= hi:
                    raise bad(f"expected a number in [{lo:g}, {hi:g}], got {ev[key]!r}", key)
            deadline = ev.get("deadline")
            if deadline is not None:
                deadline = parse_time(deadline, instance, f"{at}.deadline", source)
            new_ids.add(str(tid))
            new.append(NewTarget(str(tid), float(ev["lat"]), float(ev["lon"]), weight(), deadline))
        elif kind == "cancel":
            cancelled.append(target())
        elif kind == "weight":
            weights[target()] = weight()
        elif kind == "outage":
            name = ev["satellite"]
            if not isinstance(name, str) or name not in sats:
                raise bad(f"unknown satellite {name!r}", "satellite")
            outages.append(Outage(name, *span()))
        else:
            p = ev["probability"]
            if not is_finite_number(p) or not 0.0 <= p <= 1.0:
                raise bad(f"expected a number in [0, 1], got {p!r}", "probability")
            if ("targets" in ev) == ("area" in ev):
                raise bad("give exactly one of 'targets' and 'area'")
            ids: tuple[str, ...] = ()
            area = None
            if "targets" in ev:
                if not isinstance(ev["targets"], list):
                    raise bad("expected a list of target ids", "targets")
                ids = tuple(target("targets", t) for t in ev["targets"])
            else:
                box = ev["area"]
                ok = isinstance(box, list) and len(box) == 4 and all(map(is_finite_number, box))
                if not ok or not (-90 <= box[0] <= box[1] <= 90):
                    raise bad("expected [lat0, lat1, lon0, lon1] with lat0 <= lat1", "area")
                area = tuple(float(x) for x in box)
            clouds.append(Cloud(*span(), float(p), ids, area))  # type: ignore[arg-type]
    return Events(tuple(new), tuple(cancelled), weights or None, tuple(outages), tuple(clouds))


def load_events(path: str | os.PathLike[str], instance: Instance) -> Events:
    """Read an events file for ``instance`` (:func:`parse_events`)."""
    return parse_events(read_json(path), instance, source=str(path))


def in_area(
    lat: np.ndarray, lon: np.ndarray, area: tuple[float, float, float, float]
) -> np.ndarray:
    """Whether each point lies in the box ``(lat0, lat1, lon0, lon1)``; a box whose west edge
    lies east of its east edge crosses 180 degrees (as :func:`sosp.scenarios.random_targets`)."""
    lat0, lat1, lon0, lon1 = area
    lon = (np.asarray(lon, dtype=float) + 180.0) % 360.0 - 180.0
    w, e = (lon0 + 180.0) % 360.0 - 180.0, (lon1 + 180.0) % 360.0 - 180.0
    if lon1 - lon0 >= 360.0:
        inside_lon = np.ones(lon.shape, dtype=bool)
    elif w <= e:
        inside_lon = (lon >= w) & (lon <= e)
    else:
        inside_lon = (lon >= w) | (lon <= e)
    return (np.asarray(lat) >= lat0) & (np.asarray(lat) <= lat1) & inside_lon
