"""Downlinks: getting the observed data to the ground (``docs/model.md``, "Downlink").

An instance with ground stations (:meth:`sosp.instance.Instance.with_stations`) carries
:class:`DownlinkParams` and its contact windows. Its schedules list, besides the
observations, the :class:`Downlink` s that carry each observation's data to a station; an
observation is worth its weight only once all its data is on the ground (D8).

This module holds the parameters, the schedule's downlink record and the rules D1-D8 that
solvers share (the validator re-derives them on its own), and the planner every method uses:

* :func:`plan_downlinks` sends each satellite's data as soon as a contact, an antenna and the
  orbit's energy allow (first in, first out), over all satellites' contacts in time order. For
  one satellite with its contacts given, sending as early as possible keeps the store at its
  least at every moment and delivers as much as any plan by every time (an exchange argument:
  any plan's cumulative sent volume is at most the greedy's), so it also maximises what is
  delivered; antennas shared between satellites are granted first come, first served.
* :func:`deliver` turns observations into a schedule that passes D1-D8: it plans the
  downlinks, drops the observations whose data overflows the store (D5) or never reaches the
  ground (D8), and plans again; removing an observation never delays another's data.
* :func:`search_instance` and :func:`relaxed_instance` are the two station-free problems the
  searches and the bounds see: per-orbit memory allowances derived from the contacts (a
  restriction: what fits them almost always flies), and per-orbit memory raised by what the
  orbit's contacts can carry away, with rows limiting what runs of orbits make between
  contacts (:func:`store_rows`; a relaxation: every bound of it bounds the problem with
  stations; the argument is in ``docs/model.md``).
"""

from __future__ import annotations

import logging
from collections import defaultdict
from dataclasses import dataclass, fields, replace
from typing import Any, Literal

import numpy as np

from sosp import rules
from sosp.errors import InputError

log = logging.getLogger(__name__)

Count = Literal["delivered", "observed"]


@dataclass(frozen=True)
class DownlinkParams:
    """How data reaches the ground (the same for every satellite and station).

    Attributes
    ----------
    rate
        r, memory units sent per second of downlink (D3).
    energy_rate
        ed, energy units per second of downlink, charged to the orbit's budget (4) (D7).
    station_setup_s
        Seconds an antenna needs between two passes (D6).
    while_observing
        Whether a satellite may downlink while it observes (D4).
    count
        ``"delivered"``: an observation earns its weight once all its data is on the ground
        (D8); ``"observed"``: when it is observed, as without stations.
    """

    rate: float = 2.0
    energy_rate: float = 0.5
    station_setup_s: float = 60.0
    while_observing: bool = True
    count: Count = "delivered"

    def __post_init__(self) -> None:
        for name, low in (("rate", 0.0), ("energy_rate", None), ("station_setup_s", None)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
                raise InputError(f"downlink.{name}: expected a finite number, got {v!r}")
            if v < 0 or (low is not None and v <= low):
                raise InputError(f"downlink.{name}: must be {'> 0' if low is not None else '>= 0'}")
        if not isinstance(self.while_observing, bool):
            raise InputError("downlink.while_observing: expected true or false")
        if self.count not in ("delivered", "observed"):
            raise InputError(f"downlink.count: expected delivered or observed, got {self.count!r}")

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: Any) -> DownlinkParams:
        if not isinstance(data, dict):
            raise InputError("downlink: expected an object")
        unknown = set(data) - {f.name for f in fields(cls)}
        if unknown:
            raise InputError(f"downlink: unknown key {sorted(unknown)[0]!r}")
        return cls(**data)


@dataclass(frozen=True, slots=True)
class Downlink:
    """One transmission from a satellite to a station.

    Attributes
    ----------
    satellite, station
        Rows of :attr:`~sosp.instance.Instance.satellite_names` and of the stations.
    start, end
        Seconds from the epoch.
    parts
        ``(opportunity, volume)`` pairs: whose data it carries, each observation named by the
        first opportunity it covers (a target is observed once, so this names it), and how
        many memory units of it.
    """

    satellite: int
    station: int
    start: float
    end: float
    parts: tuple[tuple[int, float], ...]

    @property
    def volume(self) -> float:
        return float(sum(v for _, v in self.parts))


def volume(instance: Any, ob: Any) -> float:
    """The data an observation makes, ``w_j (te - ts)`` ((5)'s memory, D2)."""
    return float(rules.memory(ob.end - ob.start, instance.memory_rate[ob.orbit]))


def satellite_of_orbit(instance: Any) -> np.ndarray:
    """Each orbit's row in :attr:`~sosp.instance.Instance.satellite_names`."""
    row = {n: i for i, n in enumerate(instance.satellite_names)}
    return np.array([row[s] for s in instance.orbit_satellite], dtype=np.int64)


# ------------------------------------------------------------------------------- planner
@dataclass
class _Sat:
    """One satellite's state in :func:`plan_downlinks`: its observations by end time, what
    of each is still on board, its orbits and their energy left."""

    ends: list[float]
    keys: list[int]
    left: list[float]
    obs_windows: list[tuple[float, float]]
    orbit_start: np.ndarray
    orbit_end: np.ndarray
    orbit_rows: np.ndarray
    next_in: int = 0  # observations [0, next_in) have ended by the clock
    head: int = 0  # first observation with data still on board
    busy_until: float = -np.inf


def plan_downlinks(instance: Any, observations: Any) -> tuple[list[Downlink], dict[int, float]]:
    """Downlinks sending each satellite's data as early as the rules allow (FIFO).

    Contacts are taken in start order; each gets the antenna of its station that frees first
    (D6) once the satellite is free of its previous downlink (D4), and sends what is on board,
    oldest first, at ``rate`` (D3), within the orbit's energy left after its observations
    (D7), and, unless ``while_observing``, between observations (D4). Downlinks are cut at
    orbit ends so that each charges one orbit.

    Returns
    -------
    downlinks, sent
        The downlinks, and per observation (by its first opportunity) the volume sent.
    """
    inst, par = instance, instance.downlink
    sat_of = satellite_of_orbit(inst)
    energy_left = np.asarray(inst.energy_capacity, dtype=float).copy()
    per_orbit: dict[int, list[Any]] = defaultdict(list)
    for ob in observations:
        per_orbit[ob.orbit].append(ob)
    for j, obs in per_orbit.items():
        obs.sort(key=lambda o: o.start)
        r = rules.orbit_rules(inst, j)
        used, _ = r.usage(np.array([o.end - o.start for o in obs]), np.array([o.roll for o in obs]))
        energy_left[j] -= used + rules.EPS
    sats: list[_Sat] = []
    for s in range(len(inst.satellite_names)):
        obs = sorted((o for j in np.flatnonzero(sat_of == s) for o in per_orbit.get(int(j), ())),
                     key=lambda o: o.end)  # fmt: skip
        rows = np.flatnonzero(sat_of == s)
        rows = rows[np.argsort(inst.orbit_start[rows], kind="stable")]
        sats.append(
            _Sat(
                [o.end for o in obs],
                [o.opps[0] for o in obs],
                [volume(inst, o) for o in obs],
                sorted((o.start, o.end) for o in obs),
                inst.orbit_start[rows],
                inst.orbit_end[rows],
                rows,
            )  # fmt: skip
        )
    contacts = inst.contacts[np.lexsort((inst.contacts["station"], inst.contacts["start_s"]))]
    antenna_free = [np.full(st.antennas, -np.inf) for st in inst.stations]
    out: list[Downlink] = []
    sent: dict[int, float] = defaultdict(float)
    for c in contacts:
        s, g = int(c["satellite"]), int(c["station"])
        sat, free = sats[s], antenna_free[g]
        a = int(np.argmin(free))
        t = max(float(c["start_s"]), float(free[a]), sat.busy_until)
        made = _send(inst, par, sat, s, g, t, float(c["end_s"]), energy_left, sent)
        if made:
            out.extend(made)
            free[a] = made[-1].end + par.station_setup_s
            sat.busy_until = made[-1].end
    return out, dict(sent)


def _send(inst, par, sat: _Sat, s: int, g: int, t: float, t_end: float, energy_left, sent):
    """The downlinks of one pass: from ``t`` to ``t_end``, send what is on board."""
    made: list[Downlink] = []
    rate = par.rate
    while t_end - t > rules.EPS:
        while sat.next_in < len(sat.ends) and sat.ends[sat.next_in] <= t:
            sat.next_in += 1
        while sat.head < sat.next_in and sat.left[sat.head] <= rules.EPS:
            sat.head += 1
        if sat.head >= sat.next_in:  # nothing on board: wait for the next observation's end
            if sat.next_in >= len(sat.ends) or sat.ends[sat.next_in] >= t_end:
                break
            t = sat.ends[sat.next_in]
            continue
        stop = t_end
        if not par.while_observing:
            # not during an observation: skip one under way, stop at the next one
            during = [w for w in sat.obs_windows if w[0] < t + rules.EPS and w[1] > t]
            if during:
                t = max(w[1] for w in during)
                continue
            stop = min([stop, *(w[0] for w in sat.obs_windows if w[0] > t)])
        k = int(np.searchsorted(sat.orbit_end, t, "right"))
        if k >= len(sat.orbit_end) or sat.orbit_start[k] > t:  # between orbits
            if k >= len(sat.orbit_end):
                break
            t = float(sat.orbit_start[k])
            continue
        j = int(sat.orbit_rows[k])
        stop = min(stop, float(sat.orbit_end[k]))
        if par.energy_rate > 0:
            stop = min(stop, t + max(0.0, energy_left[j]) / par.energy_rate)
        on_board = sum(sat.left[sat.head : sat.next_in])
        stop = min(stop, t + on_board / rate)
        if stop <= t + rules.EPS:  # no energy left in this orbit: try the next one
            t = float(sat.orbit_end[k])
            continue
        budget, parts = rate * (stop - t), []
        for i in range(sat.head, sat.next_in):
            if budget <= rules.EPS:
                break
            v = min(sat.left[i], budget)
            if v > 0:
                parts.append((sat.keys[i], v))
                sat.left[i] -= v
                sent[sat.keys[i]] += v
                budget -= v
        made.append(Downlink(s, g, t, stop, tuple(parts)))
        energy_left[j] -= par.energy_rate * (stop - t)
        t = stop
    return made


def store_overflow(instance: Any, observations: Any, downlinks: Any) -> list[Any]:
    """The observations at whose end the satellite's store exceeds its capacity (D5), in
    time order per satellite: data arrives when an observation ends; a downlink removes its
    volume evenly over its span."""
    sat_of = satellite_of_orbit(instance)
    by_sat: dict[int, list[Any]] = defaultdict(list)
    for ob in observations:
        by_sat[int(sat_of[ob.orbit])].append(ob)
    dl: dict[int, list[Any]] = defaultdict(list)
    for d in downlinks:
        dl[d.satellite].append(d)
    bad = []
    for s, obs in by_sat.items():
        obs.sort(key=lambda o: o.end)
        ends = np.array([o.end for o in obs])
        made = np.cumsum([volume(instance, o) for o in obs])
        gone = np.zeros(len(obs))
        for d in dl.get(s, ()):
            gone += d.volume * np.clip((ends - d.start) / (d.end - d.start), 0.0, 1.0)
        cap = np.asarray(instance.memory_capacity, dtype=float)[[o.orbit for o in obs]]
        bad.extend(obs[i] for i in np.flatnonzero(made - gone > cap + rules.EPS))
    return bad


def deliver(instance: Any, observations: Any) -> tuple[tuple[Any, ...], list[Downlink]]:
    """Observations and downlinks passing D1-D8.

    Plan; where a satellite's store first overflows (D5), drop the observation worth the
    least per unit of data among those made since its last contact ended (still on board,
    the ones whose removal lowers the store there), then plan again; when weights count on
    delivery, drop what is not all delivered (D8); repeat until nothing is dropped. Removing
    an observation never delays another's data, so this ends with every kept one delivered.
    Each window is first cut to (10) of what it covers (an observation that lost targets to
    another keeps a longer one): with stations it must end when its last opportunity ends.
    """
    inst = instance
    obs = [
        replace(o, start=float(inst.opp_start[list(o.opps)].min()),
                end=float(inst.opp_end[list(o.opps)].max()))
        for o in observations
    ]  # fmt: skip
    count_delivered = inst.downlink.count == "delivered"
    sat_of = satellite_of_orbit(inst)
    worth = {id(o): float(inst.target_weight[inst.opp_target[list(o.opps)]].sum()) for o in obs}
    ends = {
        s: np.sort(inst.contacts["end_s"][inst.contacts["satellite"] == s])
        for s in range(len(inst.satellite_names))
    }
    while True:
        downlinks, sent = plan_downlinks(inst, obs)
        first: dict[int, Any] = {}  # the first overflow of each satellite (stores are apart)
        for o in store_overflow(inst, obs, downlinks):
            first.setdefault(int(sat_of[o.orbit]), o)
        drop = set()
        for s, o in first.items():
            e = ends[s]
            since = e[np.searchsorted(e, o.end, "left") - 1] if e.size and e[0] < o.end else -np.inf
            pool = [u for u in obs if sat_of[u.orbit] == s and since < u.end <= o.end]
            drop.add(id(min(pool, key=lambda u: (worth[id(u)] / volume(inst, u), -u.end))))
        if count_delivered and not drop:
            drop = {id(o) for o in obs if sent.get(o.opps[0], 0.0) < volume(inst, o) - 1e-7}
        if not drop:
            return tuple(obs), downlinks
        obs = [o for o in obs if id(o) not in drop]


# --------------------------------------------------------------- station-free problems
def _contact_seconds(instance: Any) -> np.ndarray:
    """Per orbit, the seconds its satellite is in contact with any station (overlapping
    contacts of one satellite counted once: it talks to one station at a time)."""
    sat_of = satellite_of_orbit(instance)
    out = np.zeros(instance.n_orbits)
    con = instance.contacts
    for s in np.unique(con["satellite"]):
        c = con[con["satellite"] == s]
        order = np.argsort(c["start_s"])
        spans: list[list[float]] = []
        for a, b in zip(c["start_s"][order], c["end_s"][order], strict=True):
            if spans and a <= spans[-1][1]:
                spans[-1][1] = max(spans[-1][1], b)
            else:
                spans.append([a, b])
        sp = np.array(spans)
        for j in np.flatnonzero(sat_of == s):
            lo, hi = instance.orbit_start[j], instance.orbit_end[j]
            out[j] = np.clip(np.minimum(sp[:, 1], hi) - np.maximum(sp[:, 0], lo), 0, None).sum()
    return out


def deliverable(instance: Any) -> np.ndarray:
    """Which opportunities can earn their weight: all of them when weights count when
    observed; else those ending before the last contact of their satellite ends (D2: data
    leaves in a contact after the observation ends; D8)."""
    if instance.downlink.count == "observed":
        return np.ones(instance.n_opps, dtype=bool)
    last = np.full(len(instance.satellite_names), -np.inf)
    np.maximum.at(last, instance.contacts["satellite"], instance.contacts["end_s"])
    return instance.opp_end < last[satellite_of_orbit(instance)[instance.opp_orbit]] - rules.EPS


def _spans(instance: Any, s: int) -> np.ndarray:
    """Satellite ``s``'s contact time as disjoint ``(start, end)`` rows (it talks to one
    station at a time, so overlapping contacts count once)."""
    con = instance.contacts[instance.contacts["satellite"] == s]
    spans: list[list[float]] = []
    for a, b in sorted(zip(con["start_s"].tolist(), con["end_s"].tolist(), strict=True)):
        if spans and a <= spans[-1][1]:
            spans[-1][1] = max(spans[-1][1], b)
        else:
            spans.append([a, b])
    return np.array(spans, dtype=float).reshape(-1, 2)


def _seconds(spans: np.ndarray, a: float, b: float) -> float:
    """Contact seconds of ``spans`` within ``[a, b]``."""
    return float(np.clip(np.minimum(spans[:, 1], b) - np.maximum(spans[:, 0], a), 0, None).sum())


#: Key of :attr:`~sosp.instance.Instance.meta` under which :func:`relaxed_instance` records
#: its store rows: ``[[orbit, ...], rhs]`` per row (``models.colgen`` adds them to its master).
STORE_ROWS = "store_rows"


def store_rows(instance: Any) -> tuple[np.ndarray, list[tuple[list[int], float]]]:
    """The store's limits on what runs of one satellite's orbits can make (``docs/model.md``,
    "Bounds with stations"), for the :func:`deliverable` opportunities.

    For orbits k..l of one satellite (in time order, those with such opportunities), every
    observation of theirs ends in ``[a, b]``, a the earliest end of an opportunity of k and b
    the latest of l (windows shrunk to (10)). What they make is the store at b minus the
    store just before a plus what is sent in between, so at most ``S + r C[a, b]``: C the
    satellite's contact seconds in ``[a, b]`` (one station at a time), S what may be on
    board at b: ``W`` (D5, b being an observation's end), and when weights count on
    delivery, at most what can still be sent after b, ``r C[b, end)`` (D8).

    Returns
    -------
    cap, rows
        Per orbit the single-orbit limit (at most ``W_j + r c_j``), and the rows of two or
        more orbits that could bind: ``(orbits, rhs)``, rhs below what the orbits can make.
    """
    inst, par = instance, instance.downlink
    r, delivered = float(par.rate), par.count == "delivered"
    sat_of = satellite_of_orbit(inst)
    keep = deliverable(inst)
    w_cap = np.asarray(inst.memory_capacity, dtype=float)
    cap = w_cap + r * _contact_seconds(inst)
    made = np.asarray(inst.memory_rate, dtype=float)[inst.opp_orbit] * (
        inst.opp_end - inst.opp_start
    )
    most = np.bincount(inst.opp_orbit[keep], made[keep], inst.n_orbits)  # all its opportunities
    rows: list[tuple[list[int], float]] = []
    for s in range(len(inst.satellite_names)):
        spans = _spans(inst, s)
        mine = [int(j) for j in np.flatnonzero(sat_of == s) if most[j] > 0]
        mine.sort(key=lambda j: inst.orbit_start[j])
        first = [float(inst.opp_end[keep & (inst.opp_orbit == j)].min()) for j in mine]
        last = [float(inst.opp_end[keep & (inst.opp_orbit == j)].max()) for j in mine]
        for k in range(len(mine)):
            for lo in range(k, len(mine)):
                j, b = mine[lo], last[lo]
                held = w_cap[j]
                if delivered:
                    held = min(held, r * _seconds(spans, b, np.inf))
                rhs = held + r * _seconds(spans, first[k], b)
                if lo == k:
                    cap[j] = min(cap[j], rhs)
                    continue
                run = mine[k : lo + 1]
                if rhs < float(np.minimum(cap[run], most[run]).sum()) - 1e-9:
                    rows.append((run, rhs))
    return cap, rows


def relaxed_instance(instance: Any) -> Any:
    """The station-free relaxation every bound of sosp computes for an instance with stations
    (``docs/model.md``, "Bounds with stations"): the :func:`deliverable` opportunities,
    per-orbit memory at most ``W_j + r * contact seconds of orbit j`` (:func:`store_rows`),
    energy as it is, weights counted when observed, and in its ``meta`` under
    :data:`STORE_ROWS` the rows limiting what runs of orbits make together (the column
    generation's master holds them; other bounds leave them out, which is still valid)."""
    cap, rows = store_rows(instance)
    out = instance.with_opportunities(deliverable(instance)).without_stations()
    meta = dict(out.meta)
    meta[STORE_ROWS] = [[list(run), float(rhs)] for run, rhs in rows]
    return replace(out, memory_capacity=cap, meta=meta)


def _carried(load: np.ndarray, sends: np.ndarray, store: float, keep_last: bool) -> np.ndarray:
    """What each segment may make when data may wait on board for a later contact: in time
    order, a segment takes what it asks up to the room left in the store, its contact sends
    what it can (oldest first); what is still on board after the last contact (the newest
    data) is taken back from the latest segments, unless weights count when observed."""
    take = np.zeros(len(load))
    on_board = 0.0
    for i in range(len(load)):
        take[i] = max(0.0, min(load[i], store - on_board))
        on_board += take[i]
        if i < len(load) - 1:
            on_board -= min(sends[i], on_board)
    if not keep_last:
        for i in range(len(load) - 1, -1, -1):
            cut = min(take[i], on_board)
            take[i] -= cut
            on_board -= cut
    return take


def search_instance(instance: Any) -> tuple[Any, np.ndarray]:
    """The station-free restriction the searches plan observations on (``docs/model.md``,
    "How the methods plan downlinks"), and the index in ``instance`` of each of its
    opportunities (the :func:`deliverable` ones).

    Each satellite's time is cut at the ends of its contacts: data made in a segment (by an
    opportunity ending early enough for its data to be sent before the contact ends) goes
    on board and leaves, oldest first, in that contact or a later one (:func:`_carried`: a
    segment may make what the store has room for; when weights count on delivery, what no
    contact would send is taken back from the latest segments). An orbit's demand in a
    segment is the data its opportunities there could make (its memory capacity at most); a
    segment's demands are scaled down together to what it may make, and an orbit's
    memory allowance is the sum of its scaled demands. Its energy is lowered by what sending
    them costs in the orbit where the contact starts. What still does not fit is dropped by
    :func:`deliver`.
    """
    inst, par = instance, instance.downlink
    sat_of = satellite_of_orbit(inst)
    w = np.asarray(inst.memory_rate, dtype=float)
    cap_orbit = np.asarray(inst.memory_capacity, dtype=float)
    made = w[inst.opp_orbit] * (inst.opp_end - inst.opp_start)
    total = np.bincount(inst.opp_orbit, made, minlength=inst.n_orbits)
    made *= np.divide(cap_orbit, total, out=np.ones_like(total), where=total > cap_orbit)[
        inst.opp_orbit
    ]  # an orbit never makes more than its memory capacity
    allow = np.zeros(inst.n_orbits)
    reserve = np.zeros(inst.n_orbits)
    for s in range(len(inst.satellite_names)):
        rows = np.flatnonzero(sat_of == s)
        con = inst.contacts[inst.contacts["satellite"] == s]
        con = con[np.argsort(con["end_s"])]
        mine = np.isin(inst.opp_orbit, rows)
        # data can leave in a contact that ends after the observation and its sending
        seg = np.searchsorted(con["end_s"], inst.opp_end[mine] + made[mine] / par.rate, "left")
        load = np.bincount(seg, made[mine], minlength=len(con) + 1)
        sends = np.append(par.rate * (con["end_s"] - con["start_s"]), 0.0)
        carry = _carried(load, sends, float(cap_orbit[rows].min()), par.count == "observed")
        scale = np.minimum(1.0, np.divide(carry, load, out=np.ones_like(carry), where=load > 0))
        allow += np.bincount(inst.opp_orbit[mine], made[mine] * scale[seg], inst.n_orbits)
        # the downlink of segment i's data, charged to the orbit where contact i starts
        for c, vol in zip(con, (load * scale)[:-1], strict=True):
            k = rows[
                (inst.orbit_start[rows] <= c["start_s"]) & (c["start_s"] < inst.orbit_end[rows])
            ]
            if k.size:
                reserve[k[0]] += par.energy_rate * vol / par.rate
    keep = deliverable(inst)
    out = replace(
        inst.with_opportunities(keep).without_stations(),
        memory_capacity=np.minimum(allow, cap_orbit),
        energy_capacity=np.maximum(0.0, np.asarray(inst.energy_capacity, float) - reserve),
    )
    return out, np.flatnonzero(keep)
