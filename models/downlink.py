"""The integer program (1)-(6) with ground stations and downlinks (``docs/exact.md``,
"Downlinks in the integer program").

:func:`downlink_block` is a :data:`models.formulation.Block`: it adds to the model of
:func:`models.formulation.build_model` one store per satellite across its orbits and a fluid
downlink, each contact's use time a continuous variable per *segment* (the contact cut at
every time where something changes), and returns the downlink term of each orbit's energy
row (4). :func:`models.solve.solve_milp` solves that model on an instance with stations, lays the
downlinks of the chosen observations with :func:`sosp.downlink.deliver` and reports the
model's value as the bound.

The model is exact except for the antennas (D6), which it relaxes: at no time do a
station's contacts send for more than its antennas' seconds, set-up times and the
one-pass-per-contact rule left out. Its optimum is therefore an upper bound of the problem;
when the delivered schedule reaches it (always on instances whose stations are never asked
for more antennas than they have), it is the optimum.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pyomo.environ as pyo

from models.data import ModelData
from sosp.downlink import satellite_of_orbit
from sosp.instance import Instance


@dataclass(frozen=True)
class Segments:
    """The contacts cut into segments, and each satellite's chain of times.

    A satellite's *points* are the ends of its items (and their starts when it may not
    downlink while observing), its orbits' bounds and every contact's bounds, in time order;
    a segment is one contact between two consecutive points of its satellite, so within a
    segment no item ends, no orbit changes and no contact starts or ends.

    Attributes
    ----------
    points
        Per satellite, its times.
    sat, contact, k, start, end, orbit
        Per segment: its satellite, its row in the contacts, the index of its first point in
        its satellite's points, its span, and the orbit it lies in (-1: none).
    """

    points: list[np.ndarray]
    sat: np.ndarray
    contact: np.ndarray
    k: np.ndarray
    start: np.ndarray
    end: np.ndarray
    orbit: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return self.end - self.start


def segments(data: ModelData) -> Segments:
    """The :class:`Segments` of ``data``'s instance and items."""
    inst = data.instance
    con, sat_of = inst.contacts, satellite_of_orbit(inst)
    bounds = np.concatenate([con["start_s"], con["end_s"]])
    cols: dict[str, list[Any]] = defaultdict(list)
    points = []
    for s in range(len(inst.satellite_names)):
        rows = np.flatnonzero(sat_of == s)
        mine = np.isin(data.orbit, rows)
        times = [data.end[mine], inst.orbit_start[rows], inst.orbit_end[rows], bounds]
        if not inst.downlink.while_observing:
            times.append(data.start[mine])
        p = np.unique(np.concatenate(times))
        points.append(p)
        for c in np.flatnonzero(con["satellite"] == s):
            lo, hi = np.searchsorted(p, [con["start_s"][c], con["end_s"][c]])
            for k in range(lo, hi):
                a, b = p[k], p[k + 1]
                inside = rows[(inst.orbit_start[rows] <= a) & (b <= inst.orbit_end[rows])]
                for name, v in (("sat", s), ("contact", c), ("k", k), ("start", a), ("end", b)):
                    cols[name].append(v)
                cols["orbit"].append(int(inside[0]) if inside.size else -1)
    arr = {n: np.array(cols[n], dtype=float if n in ("start", "end") else np.int64) for n in
           ("sat", "contact", "k", "start", "end", "orbit")}  # fmt: skip
    return Segments(points, **arr)


def downlink_block(m: pyo.ConcreteModel, data: ModelData) -> dict[int, Any]:
    """Add the downlinks to the model of ``data`` (a :data:`models.formulation.Block`).

    Variables: ``dl_y[g]`` in [0, length of g], the seconds segment g sends; ``dl_store[s, k]``
    >= 0, what satellite s has on board at its point k, after the data of the items ending
    there arrived and what the segments ending there sent left. Rows (numbered as in
    ``docs/exact.md``):

    * (D-a) ``store[s,k] = store[s,k-1] - r sum_{g at k-1} y_g + sum_{u ends at k} vol_u x_u``;
    * (D-b) ``r sum_{g at k} y_g <= store[s,k]``: a segment sends only data made by its start;
    * (D-c) ``store[s,k(u)] <= W_o(u) + M_u (1 - x_u)`` at each item's end, with
      ``M_u = max_o W_o - W_o(u)`` over the satellite's orbits (0 when they are equal);
    * (D-d) ``store[s, last] = 0`` when weights count on delivery;
    * (D-e) ``sum_{g at (s,k)} y_g <= length``: one station at a time;
    * (D-f) ``y_g <= length (1 - sum_{u spans g} x_u)`` when downlinking while observing is
      forbidden;
    * (D-g) per station and span between two of its contacts' bounds, the segments of its
      contacts send at most ``antennas x span`` seconds (D6 relaxed);

    and ``ed sum_{g in orbit j} y_g`` joins orbit j's energy row (4) (the returned terms).
    """
    inst, par = data.instance, data.instance.downlink
    seg = segments(data)
    sat_of = satellite_of_orbit(inst)
    item_sat = sat_of[data.orbit] if data.n_items else np.zeros(0, dtype=np.int64)
    vol = np.asarray(inst.memory_rate, float)[data.orbit] * data.duration
    cap = np.asarray(inst.memory_capacity, dtype=float)
    r, n_seg = float(par.rate), len(seg.sat)
    at: dict[tuple[int, int], list[int]] = defaultdict(list)  # (s, k) -> its segments
    for g in range(n_seg):
        at[int(seg.sat[g]), int(seg.k[g])].append(g)
    ends: dict[tuple[int, int], list[int]] = defaultdict(list)  # (s, k) -> items ending there
    k_end = np.zeros(data.n_items, dtype=np.int64)
    for u in range(data.n_items):
        s = int(item_sat[u])
        k_end[u] = np.searchsorted(seg.points[s], data.end[u])
        ends[s, int(k_end[u])].append(u)
    chain = [(s, k) for s, p in enumerate(seg.points) for k in range(len(p))]
    length = seg.length

    m.DL = pyo.Set(initialize=range(n_seg), doc="downlink segments")
    m.dl_y = pyo.Var(m.DL, bounds=lambda m, g: (0.0, float(length[g])), doc="seconds sent")
    m.dl_store = pyo.Var(chain, domain=pyo.NonNegativeReals, doc="on board")

    def sent(s: int, k: int) -> Any:
        return r * sum(m.dl_y[g] for g in at.get((s, k), ()))

    def made(s: int, k: int) -> Any:
        return sum(float(vol[u]) * m.x[u] for u in ends.get((s, k), ()))

    @m.Constraint(chain)
    def dl_balance(m, s, k):  # (D-a)
        before = 0 if k == 0 else m.dl_store[s, k - 1] - sent(s, k - 1)
        return m.dl_store[s, k] == before + made(s, k)

    @m.Constraint(sorted(at))
    def dl_on_board(m, s, k):  # (D-b)
        return sent(s, k) <= m.dl_store[s, k]

    @m.Constraint(range(data.n_items))
    def dl_capacity(m, u):  # (D-c)
        s = int(item_sat[u])
        big = float(cap[sat_of == s].max() - cap[data.orbit[u]])
        return m.dl_store[s, int(k_end[u])] <= float(cap[data.orbit[u]]) + big * (1 - m.x[u])

    if par.count == "delivered":

        @m.Constraint(range(len(seg.points)))
        def dl_delivered(m, s):  # (D-d)
            return m.dl_store[s, len(seg.points[s]) - 1] == 0

    @m.Constraint([key for key, gs in at.items() if len(gs) > 1])
    def dl_one_station(m, s, k):  # (D-e)
        g0 = at[s, k][0]
        return sum(m.dl_y[g] for g in at[s, k]) <= float(length[g0])

    if not par.while_observing:

        def spans(g: int) -> list[int]:
            mine = np.flatnonzero(
                (item_sat == seg.sat[g]) & (data.start <= seg.start[g]) & (seg.end[g] <= data.end)
            )
            return [int(u) for u in mine]

        @m.Constraint(m.DL)
        def dl_not_observing(m, g):  # (D-f)
            us = spans(g)
            if not us:
                return pyo.Constraint.Skip
            return m.dl_y[g] <= float(length[g]) * (1 - sum(m.x[u] for u in us))

    rows = _antenna_rows(inst, seg)
    m.dl_antennas = pyo.Constraint(
        range(len(rows)),
        rule=lambda m, n: sum(m.dl_y[g] for g in rows[n][0]) <= rows[n][1],  # (D-g)
    )
    energy: dict[int, Any] = defaultdict(int)
    for g in np.flatnonzero(seg.orbit >= 0):
        energy[int(seg.orbit[g])] += float(par.energy_rate) * m.dl_y[int(g)]
    return dict(energy)


def _antenna_rows(inst: Instance, seg: Segments) -> list[tuple[list[int], float]]:
    """(D-g): per station, per span between consecutive bounds of its contacts where more
    contacts are open than it has antennas, the segments in it and ``antennas x span``."""
    con, out = inst.contacts, []
    station = con["station"][seg.contact] if len(seg.contact) else np.zeros(0, np.int64)
    for h, st in enumerate(inst.stations):
        mine = con["station"] == h
        q = np.unique(np.concatenate([con["start_s"][mine], con["end_s"][mine]]))
        for a, b in zip(q[:-1], q[1:], strict=True):
            n_open = int(np.sum(mine & (con["start_s"] <= a) & (b <= con["end_s"])))
            if n_open <= st.antennas:
                continue
            gs = np.flatnonzero((station == h) & (a <= seg.start) & (seg.end <= b))
            out.append(([int(g) for g in gs], float(st.antennas * (b - a))))
    return out


def downlink_data(data: ModelData) -> ModelData:
    """``data`` for the model with downlinks: the per-orbit memory row (5) gives way to the
    store (D-c), and every orbit with items gets its energy row (4) with the exact slew term
    (a downlink may make it bind)."""
    return replace(
        data,
        memory_orbits=(),
        energy_orbits=tuple(sorted(set(data.energy_orbits) | set(data.orbit_items))),
    )
