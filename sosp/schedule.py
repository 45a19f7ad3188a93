"""Schedules: observations (sensor openings) on orbits, each covering one or more opportunities.

An :class:`Observation` is the paper's cluster-task t_u (section 4.1): a set of opportunities
of one orbit observed in one sensor opening with roll theta_u over the window [ts_u, te_u].
With one opportunity it is an ordinary task.

The schedule file format (``format: "sosp-schedule"``, ``version: 1``) is documented in
``docs/formats.md``. It refers to orbits and opportunities by id and carries the fingerprint
of the instance it was made for.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from sosp import rules
from sosp.downlink import Downlink
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.io import atomic_write_json, is_finite_number, read_json
from sosp.rules import RollRule, choose_roll

FORMAT_NAME = "sosp-schedule"
FORMAT_VERSION = 1


@dataclass(frozen=True, slots=True)
class Observation:
    """One sensor opening on one orbit.

    Attributes
    ----------
    orbit
        Orbit index.
    start, end
        Observation window [ts_u, te_u], seconds from the epoch.
    roll
        Roll theta_u, degrees.
    opps
        Sorted tuple of the opportunity indices it covers (its component tasks).
    """

    orbit: int
    start: float
    end: float
    roll: float
    opps: tuple[int, ...]

    @property
    def duration(self) -> float:
        return self.end - self.start


def make_observation(
    instance: Instance, opps: Iterable[int], rule: RollRule = "midpoint"
) -> Observation:
    """Build the observation of a set of opportunities of one orbit, by (8)-(10).

    A single opportunity keeps its own roll (the paper's theta_i); a cluster takes the roll of
    ``rule`` in the common range (8) and the window (10).

    Raises
    ------
    ValueError
        If the set is empty, spans several orbits or has an empty common roll range.
    """
    ids = tuple(sorted(int(i) for i in opps))
    if not ids:
        raise ValueError("an observation needs at least one opportunity")
    idx = np.asarray(ids, dtype=np.int64)
    orbits = np.unique(instance.opp_orbit[idx])
    if orbits.size != 1:
        raise ValueError("an observation's opportunities must share one orbit")
    start, end = rules.cluster_window(instance.opp_start[idx], instance.opp_end[idx])
    if len(ids) == 1:
        roll = float(instance.opp_roll[ids[0]])
    else:
        lo, hi = rules.common_roll_range(instance.opp_roll_min[idx], instance.opp_roll_max[idx])
        if rules.range_empty(lo, hi):
            raise ValueError("the opportunities have no common roll (7)")
        roll = choose_roll(lo, hi, rule)
    return Observation(int(orbits[0]), start, end, roll, ids)


@dataclass(frozen=True)
class Schedule:
    """A solution: observations plus where it came from.

    Attributes
    ----------
    observations
        Sorted by (orbit, start).
    method, params, seed
        How it was made.
    profit
        The profit the method claims (checked by the validator when given).
    fingerprint
        Fingerprint of the instance it belongs to.
    status, bound
        How the solve that made it ended (``optimal``, ``feasible``, ``time_limit``,
        ``interrupted``, ...) and the upper bound it proved, when known: a file read later
        says whether its schedule is proven, cut short or stopped.
    downlinks
        Sorted by (satellite, start): the data sent to ground stations (instances with
        stations only, :mod:`sosp.downlink`).
    """

    observations: tuple[Observation, ...] = ()
    method: str = ""
    params: Mapping[str, Any] = field(default_factory=dict)
    seed: int | None = None
    profit: float | None = None
    fingerprint: str | None = None
    status: str | None = None
    bound: float | None = None
    downlinks: tuple[Downlink, ...] = ()

    def __post_init__(self) -> None:
        obs = tuple(sorted(self.observations, key=lambda o: (o.orbit, o.start, o.end, o.opps)))
        object.__setattr__(self, "observations", obs)
        dls = tuple(sorted(self.downlinks, key=lambda d: (d.satellite, d.start, d.station)))
        object.__setattr__(self, "downlinks", dls)

    def __len__(self) -> int:
        return len(self.observations)

    def observed_opps(self) -> list[int]:
        """All opportunity indices covered, in observation order."""
        return [i for o in self.observations for i in o.opps]

    def coverage_profit(self, instance: Instance) -> tuple[float, int]:
        """``(profit, observed)``: objective (1) over the distinct targets covered (each once,
        constraint (2) read as coverage), and how many there are."""
        ks = {int(instance.opp_target[i]) for i in self.observed_opps()}
        return float(sum(int(instance.target_weight[k]) for k in ks)), len(ks)

    def to_dict(self, instance: Instance) -> dict[str, Any]:
        """JSON-ready dict; ids are taken from ``instance``.

        Each observation also carries its window as ISO 8601 UTC (``start_utc``, ``end_utc``)
        for a planner's tools; the seconds from the epoch stay the reference.
        """
        from sosp.orbits import utc_at

        return {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "instance": self.fingerprint or instance.fingerprint,
            "method": self.method,
            "params": jsonable(dict(self.params)),
            "seed": self.seed,
            "profit": self.profit,
            **{k: v for k, v in (("status", self.status), ("bound", self.bound)) if v is not None},
            "observations": [
                {
                    "orbit": instance.orbit_ids[o.orbit],
                    "start": o.start,
                    "end": o.end,
                    "start_utc": utc_at(instance.epoch, o.start),
                    "end_utc": utc_at(instance.epoch, o.end),
                    "roll": o.roll,
                    "opportunities": [instance.opp_ids[i] for i in o.opps],
                }
                for o in self.observations
            ],
            **({"downlinks": [_downlink_record(instance, d)
                              for d in self.downlinks]} if self.downlinks else {}),
        }  # fmt: skip

    @classmethod
    def from_dict(cls, data: Any, instance: Instance, source: str | None = None) -> Schedule:
        """Read a schedule dict made for ``instance``; :class:`InputError` names the row.

        ``start_utc``/``end_utc`` are optional (files written before they existed are read);
        when present they must agree with ``start``/``end`` to the millisecond.
        """
        from sosp.orbits import seconds_after, utc_at

        if not isinstance(data, dict):
            raise InputError("expected a JSON object at the top level", source=source)
        if data.get("format", FORMAT_NAME) != FORMAT_NAME:
            raise InputError(f"format: expected {FORMAT_NAME!r}", source=source)
        if data.get("version", FORMAT_VERSION) != FORMAT_VERSION:
            raise InputError(f"version: this sosp reads version {FORMAT_VERSION}", source=source)
        fp = data.get("instance")
        if fp is not None and fp != instance.fingerprint:
            raise InputError(
                "instance: the schedule was made for another instance "
                f"(fingerprint {str(fp)[:19]}..., this instance {instance.fingerprint[:19]}...)",
                source=source,
            )
        if "observations" not in data:
            raise InputError("missing key 'observations'", source=source)
        rows = data["observations"]
        if not isinstance(rows, list):
            raise InputError("observations: expected a list", source=source)
        obs = []
        for r, rec in enumerate(rows):
            where = f"observations[{r}]"
            if not isinstance(rec, dict):
                raise InputError(f"{where}: expected an object", source=source)
            for key in ("orbit", "start", "end", "roll", "opportunities"):
                if key not in rec:
                    raise InputError(f"{where}: missing key {key!r}", source=source)
            for key in ("start", "end", "roll"):
                if not is_finite_number(rec[key]):
                    raise InputError(
                        f"{where}.{key}: expected a finite number, got {rec[key]!r}", source=source
                    )
            for key in ("start", "end"):
                utc = rec.get(f"{key}_utc")
                if utc is None:
                    continue
                try:
                    off = seconds_after(instance.epoch, utc)
                except InputError:
                    raise InputError(
                        f"{where}.{key}_utc: not an ISO 8601 time: {utc!r}", source=source
                    ) from None
                if abs(off - rec[key]) > 1e-3:
                    raise InputError(
                        f"{where}.{key}_utc: {utc!r} disagrees with {key} = {rec[key]} s "
                        f"({utc_at(instance.epoch, rec[key])}); drop it or fix one of them",
                        source=source,
                    )
            orbit = instance.orbit_index.get(str(rec["orbit"]))
            if orbit is None or isinstance(rec["orbit"], bool):
                raise InputError(f"{where}.orbit: unknown orbit {rec['orbit']!r}", source=source)
            if not isinstance(rec["opportunities"], list):
                raise InputError(f"{where}.opportunities: expected a list", source=source)
            opps = []
            for oid in rec["opportunities"]:
                i = instance.opp_index.get(str(oid)) if isinstance(oid, str | int) else None
                if i is None or isinstance(oid, bool):
                    raise InputError(
                        f"{where}.opportunities: unknown opportunity {oid!r}", source=source
                    )
                opps.append(i)
            # Keep duplicates so that the validator can report them.
            start, end, roll = (float(rec[key]) for key in ("start", "end", "roll"))
            obs.append(Observation(orbit, start, end, roll, tuple(sorted(opps))))
        profit = data.get("profit")
        if profit is not None and not is_finite_number(profit):
            raise InputError("profit: expected a number or null", source=source)
        seed = data.get("seed")
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise InputError("seed: expected an integer or null", source=source)
        params = data.get("params", {})
        if not isinstance(params, dict):
            raise InputError("params: expected an object", source=source)
        method = data.get("method", "")
        if not isinstance(method, str):
            raise InputError("method: expected a string", source=source)
        status, bound = data.get("status"), data.get("bound")
        if status is not None and not isinstance(status, str):
            raise InputError("status: expected a string or null", source=source)
        if bound is not None and not is_finite_number(bound):
            raise InputError("bound: expected a number or null", source=source)
        dls = _read_downlinks(data.get("downlinks", []), instance, source)
        return cls(
            tuple(obs), method, params, seed, profit, instance.fingerprint, status, bound, dls
        )

    def save(self, path: str | os.PathLike[str], instance: Instance) -> None:
        """Write the schedule file atomically."""
        atomic_write_json(path, self.to_dict(instance))


def _downlink_record(instance: Instance, d: Downlink) -> dict[str, Any]:
    from sosp.orbits import utc_at

    return {
        "satellite": instance.satellite_names[d.satellite],
        "station": instance.stations[d.station].id,
        "start": d.start,
        "end": d.end,
        "start_utc": utc_at(instance.epoch, d.start),
        "end_utc": utc_at(instance.epoch, d.end),
        "volume": d.volume,
        "data": [{"opportunity": instance.opp_ids[i], "volume": v} for i, v in d.parts],
    }


def _read_downlinks(rows: Any, instance: Instance, source: str | None) -> tuple[Downlink, ...]:
    """The ``downlinks`` of a schedule file (``start_utc``, ``end_utc`` and ``volume`` are
    for people: the seconds and the parts are the reference)."""
    if not isinstance(rows, list):
        raise InputError("downlinks: expected a list", source=source)
    sats = {n: i for i, n in enumerate(instance.satellite_names)}
    stations = {s.id: i for i, s in enumerate(instance.stations)}
    out = []
    for r, rec in enumerate(rows):
        where = f"downlinks[{r}]"

        def bad(msg: str, where: str = where) -> InputError:
            return InputError(f"{where}{msg}", source=source)

        if not isinstance(rec, dict):
            raise bad(": expected an object")
        for key in ("satellite", "station", "start", "end", "data"):
            if key not in rec:
                raise bad(f": missing key {key!r}")
        for key in ("start", "end"):
            if not is_finite_number(rec[key]):
                raise bad(f".{key}: expected a finite number, got {rec[key]!r}")
        s, g = sats.get(rec["satellite"]), stations.get(rec["station"])
        if s is None:
            raise bad(f".satellite: unknown satellite {rec['satellite']!r}")
        if g is None:
            raise bad(f".station: unknown station {rec['station']!r}")
        if not isinstance(rec["data"], list):
            raise bad(".data: expected a list")
        parts = []
        for n, part in enumerate(rec["data"]):
            at = f"{where}.data[{n}]"
            if not isinstance(part, dict) or set(part) != {"opportunity", "volume"}:
                raise bad(": expected {opportunity, volume}", at)
            i = instance.opp_index.get(str(part["opportunity"]))
            if i is None:
                raise bad(f".opportunity: unknown opportunity {part['opportunity']!r}", at)
            if not is_finite_number(part["volume"]):
                raise bad(".volume: expected a finite number", at)
            parts.append((i, float(part["volume"])))
        out.append(Downlink(s, g, float(rec["start"]), float(rec["end"]), tuple(parts)))
    return tuple(out)


class Items(Protocol):
    """Columns of candidate observations (:class:`sosp.clustering.TaskSet`, the models' data,
    :class:`sosp.planner.OrbitData`): per item its orbit, window, roll and covered
    opportunities."""

    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: Sequence[Sequence[int]]


def items_to_schedule(instance: Instance, items: Items, chosen: Iterable[int]) -> Schedule:
    """The schedule of a chosen set of items, each target claimed once.

    Items are taken by (orbit, start); each observation keeps its item's window and roll (the
    costs the method counted) and lists the opportunities whose target is not yet claimed, so
    a target covered twice counts once (2). An item left with nothing to claim is dropped:
    removing an observation never breaks (3)-(6) (``docs/model.md``).
    """
    claimed: set[int] = set()
    obs = []
    for u in sorted(set(int(c) for c in chosen), key=lambda u: (items.orbit[u], items.start[u])):
        mine = []
        for i in items.opps[u]:
            k = int(instance.opp_target[i])
            if k not in claimed:
                claimed.add(k)
                mine.append(i)
        if mine:
            start, end, roll = float(items.start[u]), float(items.end[u]), float(items.roll[u])
            obs.append(Observation(int(items.orbit[u]), start, end, roll, tuple(mine)))
    return Schedule(tuple(obs))


def load_schedule(path: str | os.PathLike[str], instance: Instance) -> Schedule:
    """Read a schedule file made for ``instance``."""
    return Schedule.from_dict(read_json(path), instance, source=str(path))


def jsonable(value: Any) -> Any:
    """Parameters as plain JSON values (numpy scalars, tuples and enums converted)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    return str(value)
