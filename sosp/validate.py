"""The independent validator: the referee of every schedule from every solver.

It re-derives everything from the instance's raw columns and the schedule's stated
observations (orbit, window, roll, covered opportunities), and shares no bookkeeping with any
solver. It checks, as ``docs/model.md`` states:

* structure: each observation is on a known orbit, covers at least one opportunity of that
  orbit, each covered opportunity's window lies inside the observation window, and the window
  lies inside the orbit; with ground stations, it ends when its last opportunity ends;
* (2) every target is observed at most once in the whole schedule;
* (3) on each orbit, consecutive observations u, v (by start time) satisfy
  ``ts_v - te_u >= a + (|theta_u| + |theta_v|) / v``;
* (4) energy ``eo * sum(te_u - ts_u) + es * sum_consecutive (|theta_u| + |theta_v|) / v <= E``;
* (5) memory ``w * sum(te_u - ts_u) <= W``;  (6) openings ``<= c``;
* (7) the stated roll lies inside the roll range of every covered opportunity;
* (11) ``te_u - ts_u <= Delta T``;
* the claimed profit, when the schedule states one, equals the recomputed objective (1).

With ground stations, it also checks the downlinks, D1-D8 of ``docs/model.md``: (5) per orbit
gives way to the satellite's store (D5), downlink seconds cost energy in (4) (D7), and a
target's weight counts once all the data of its observation is on the ground (D8).

Comparisons allow :data:`TOL` of slack for floating-point rounding.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from sosp.instance import Instance
from sosp.schedule import Schedule

#: Absolute slack allowed in every comparison (seconds, degrees, resource units).
TOL = 1e-6


@dataclass(frozen=True)
class Violation:
    """One broken constraint.

    Attributes
    ----------
    constraint
        ``"2"``, ``"3"``, ``"4"``, ``"5"``, ``"6"``, ``"7"``, ``"11"``, ``"structure"`` or
        ``"profit"``.
    message
        Human-readable, one line.
    amount
        By how much the constraint is exceeded (in its own unit), 0 for structural faults.
    orbit, observation, target
        Where: orbit id, observation index in the schedule, target id (when relevant).
    """

    constraint: str
    message: str
    amount: float = 0.0
    orbit: str | None = None
    observation: int | None = None
    target: str | None = None


@dataclass
class OrbitUsage:
    """Resources one orbit uses in a schedule."""

    orbit: str
    openings: int
    observe_time: float
    slew_time: float
    energy: float
    memory: float


@dataclass
class ValidationReport:
    """What the validator found: feasibility, violations and the schedule's measures."""

    feasible: bool
    violations: list[Violation]
    profit: float
    observed: int
    energy: float
    memory: float
    orbits: list[OrbitUsage] = field(default_factory=list)
    downlink: dict[str, Any] | None = None

    @property
    def profit_per_energy(self) -> float:
        return self.profit / self.energy if self.energy > 0 else 0.0

    @property
    def profit_per_memory(self) -> float:
        return self.profit / self.memory if self.memory > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "feasible": self.feasible,
            "profit": self.profit,
            "observed": self.observed,
            "energy": self.energy,
            "memory": self.memory,
            "profit_per_energy": self.profit_per_energy,
            "profit_per_memory": self.profit_per_memory,
            "violations": [asdict(v) for v in self.violations],
            "orbits": [asdict(u) for u in self.orbits if u.openings],
            **({"downlink": self.downlink} if self.downlink is not None else {}),
        }


def validate(instance: Instance, schedule: Schedule) -> ValidationReport:
    """Check a schedule against constraints (2)-(7) and (11) and compute its measures.

    Parameters
    ----------
    instance
        The problem.
    schedule
        Observations by index (as made by a solver or read by
        :func:`sosp.schedule.load_schedule`).

    Returns
    -------
    ValidationReport
        ``feasible`` is True when there is no violation; every violation is listed.
    """
    inst = instance
    out: list[Violation] = []
    by_orbit: dict[int, list[int]] = defaultdict(list)
    seen_target: dict[int, int] = {}
    profit = 0.0
    observations = schedule.observations

    def flag(constraint: str, message: str, **where: Any) -> None:
        out.append(Violation(constraint, message, **where))

    for u, ob in enumerate(observations):
        if not (0 <= ob.orbit < inst.n_orbits):
            flag("structure", f"observation {u}: unknown orbit {ob.orbit}", observation=u)
            continue
        oid = inst.orbit_ids[ob.orbit]
        at = {"orbit": oid, "observation": u}
        by_orbit[ob.orbit].append(u)
        if not ob.end > ob.start:
            flag("structure", f"observation {u}: start must be < end", **at)
        if ob.start < inst.orbit_start[ob.orbit] - TOL or ob.end > inst.orbit_end[ob.orbit] + TOL:
            flag("structure", f"observation {u}: window outside orbit {oid}", **at)
        if not ob.opps:
            flag("structure", f"observation {u}: covers no opportunity", **at)
        # (11) longest continuous observation
        excess = (ob.end - ob.start) - float(inst.max_duration[ob.orbit])
        if excess > TOL:
            flag(
                "11",
                f"observation {u} on {oid} lasts {ob.end - ob.start:.6g} s"
                f" > Delta T {inst.max_duration[ob.orbit]:g} s",
                amount=excess,
                **at,
            )
        for i in ob.opps:
            if not (0 <= i < inst.n_opps):
                flag("structure", f"observation {u}: unknown opportunity {i}", **at)
                continue
            pid = inst.opp_ids[i]
            k = int(inst.opp_target[i])
            tid = inst.target_ids[k]
            at_target = {**at, "target": tid}
            if int(inst.opp_orbit[i]) != ob.orbit:
                flag(
                    "structure",
                    f"observation {u}: opportunity {pid} is not on orbit {oid}",
                    **at_target,
                )
            ts, te = float(inst.opp_start[i]), float(inst.opp_end[i])
            if ts < ob.start - TOL or te > ob.end + TOL:
                flag(
                    "structure",
                    f"observation {u}: window [{ob.start:.6g}, "
                    f"{ob.end:.6g}] does not contain opportunity {pid} "
                    f"[{ts:.6g}, {te:.6g}]",
                    amount=max(ob.start - ts, te - ob.end),
                    **at_target,
                )
            # (7) the stated roll inside every component's roll range
            lo, hi = float(inst.opp_roll_min[i]), float(inst.opp_roll_max[i])
            miss = max(lo - ob.roll, ob.roll - hi)
            if miss > TOL:
                flag(
                    "7",
                    f"observation {u}: roll {ob.roll:.6g} outside the range "
                    f"[{lo:.6g}, {hi:.6g}] of opportunity {pid}",
                    amount=miss,
                    **at_target,
                )
            # (2) each target at most once
            if k in seen_target:
                flag(
                    "2",
                    f"target {tid} observed again in observation {u} "
                    f"(first in observation {seen_target[k]})",
                    amount=1.0,
                    **at_target,
                )
            else:
                seen_target[k] = u
        # with stations data counts as made when u ends: a later end than (10)'s would
        # postpone it at will (docs/model.md), which the bounds' proofs rule out
        known = [i for i in ob.opps if 0 <= i < inst.n_opps]
        if inst.stations and known and ob.end > float(inst.opp_end[known].max()) + TOL:
            flag(
                "structure",
                f"observation {u}: with stations its window must end when its last "
                f"opportunity ends ({float(inst.opp_end[known].max()):.6g}), not at {ob.end:.6g}",
                amount=ob.end - float(inst.opp_end[known].max()),
                **at,
            )

    down = _downlinks(inst, schedule, flag) if inst.stations else None
    worth = seen_target
    if down is not None and inst.downlink.count == "delivered":
        worth = {k: u for k, u in seen_target.items() if u in down["delivered_obs"]}
    profit = sum((float(inst.target_weight[k]) for k in sorted(worth)), 0.0)
    usage: list[OrbitUsage] = []
    for j in sorted(by_orbit):
        oid = inst.orbit_ids[j]
        seq = sorted(by_orbit[j], key=lambda u: (observations[u].start, observations[u].end))
        a, v = float(inst.setup_time[j]), float(inst.slew_rate[j])
        observe = slew = 0.0
        for n, u in enumerate(seq):
            ob = observations[u]
            observe += ob.end - ob.start
            if n == 0:
                continue
            p = observations[seq[n - 1]]
            turn = (abs(p.roll) + abs(ob.roll)) / v
            slew += turn
            # (3) setup and slew time between consecutive observations
            short = (a + turn) - (ob.start - p.end)
            if short > TOL:
                flag(
                    "3",
                    f"observations {seq[n - 1]} and {u} on {oid}: gap "
                    f"{ob.start - p.end:.6g} s < setup + slew {a + turn:.6g} s",
                    amount=short,
                    orbit=oid,
                    observation=u,
                )
        energy = (
            float(inst.observe_energy_rate[j]) * observe + float(inst.slew_energy_rate[j]) * slew
        )
        if down is not None:  # D7: downlink seconds in this orbit
            energy += inst.downlink.energy_rate * down["orbit_seconds"].get(j, 0.0)
        memory = float(inst.memory_rate[j]) * observe
        usage.append(OrbitUsage(oid, len(seq), observe, slew, energy, memory))
        for rule, what, used, cap in (
            ("4", "energy", energy, inst.energy_capacity[j]),
            *(() if down is not None else (("5", "memory", memory, inst.memory_capacity[j]),)),
        ):
            if used - float(cap) > TOL:  # (4), (5)
                msg = f"orbit {oid}: {what} {used:.6g} > capacity {cap:g}"
                flag(rule, msg, amount=used - float(cap), orbit=oid)
        if len(seq) > int(inst.max_openings[j]):  # (6)
            flag(
                "6",
                f"orbit {oid}: {len(seq)} openings > {inst.max_openings[j]}",
                amount=float(len(seq) - int(inst.max_openings[j])),
                orbit=oid,
            )

    if schedule.profit is not None and abs(float(schedule.profit) - profit) > TOL:
        flag(
            "profit",
            f"claimed profit {schedule.profit:g} differs from the recomputed profit {profit:g}",
            amount=abs(float(schedule.profit) - profit),
        )
    if down is not None:
        for j, sec in down.pop("orbit_seconds").items():  # D7 in orbits with no observation
            if (
                j not in by_orbit
                and inst.downlink.energy_rate * sec > inst.energy_capacity[j] + TOL
            ):
                e = inst.downlink.energy_rate * sec
                oid = inst.orbit_ids[j]
                flag(
                    "4",
                    f"orbit {oid}: energy {e:.6g} > capacity {inst.energy_capacity[j]:g}",
                    amount=e - float(inst.energy_capacity[j]),
                    orbit=oid,
                )
        delivered = down.pop("delivered_obs")
        down["observed_profit"] = sum(float(inst.target_weight[k]) for k in sorted(seen_target))
        down["delivered_profit"] = sum(
            float(inst.target_weight[k]) for k, u in sorted(seen_target.items()) if u in delivered
        )
    return ValidationReport(
        feasible=not out,
        violations=out,
        profit=profit,
        observed=len(seen_target),
        energy=sum((u.energy for u in usage), 0.0),  # in orbit order, as checked
        memory=sum((u.memory for u in usage), 0.0),
        orbits=usage,
        downlink=down,
    )


def _downlinks(inst: Instance, schedule: Schedule, flag: Any) -> dict[str, Any]:
    """Check the downlinks (D1-D8 of ``docs/model.md``) and measure them: which observations
    are delivered, downlink seconds per orbit (for (4)), latency, what is left on board, the
    store's peak per satellite and each station's use."""
    par, obs = inst.downlink, schedule.observations
    sat_row = {n: i for i, n in enumerate(inst.satellite_names)}
    orbit_sat = [sat_row[s] for s in inst.orbit_satellite]
    of_opp = {i: u for u, ob in enumerate(obs) for i in ob.opps}
    vol = [float(inst.memory_rate[ob.orbit]) * (ob.end - ob.start) for ob in obs]
    sent = [0.0] * len(obs)
    done_at = [0.0] * len(obs)
    orbit_seconds: dict[int, float] = defaultdict(float)
    passes: dict[tuple[int, int, int], list[float]] = {}
    by_sat: dict[int, list[int]] = defaultdict(list)
    con = inst.contacts
    for n, d in enumerate(schedule.downlinks):
        at = {"observation": None}
        if not (0 <= d.satellite < len(inst.satellite_names)) or not (
            0 <= d.station < len(inst.stations)
        ):
            flag("structure", f"downlink {n}: unknown satellite or station", **at)
            continue
        sname = inst.satellite_names[d.satellite]
        if not d.end > d.start:
            flag("structure", f"downlink {n}: start must be < end", **at)
            continue
        by_sat[d.satellite].append(n)
        # D1: inside one contact window of its satellite and station
        inside = np.flatnonzero(
            (con["satellite"] == d.satellite)
            & (con["station"] == d.station)
            & (con["start_s"] <= d.start + TOL)
            & (d.end <= con["end_s"] + TOL)
        )
        if not inside.size:
            flag(
                "D1",
                f"downlink {n}: {sname} is not in contact with station "
                f"{inst.stations[d.station].id} over [{d.start:.6g}, {d.end:.6g}]",
            )
        else:
            span = passes.setdefault((d.station, d.satellite, int(inside[0])), [d.start, d.end])
            span[0], span[1] = min(span[0], d.start), max(span[1], d.end)
        # D3: at most the rate
        if d.volume > par.rate * (d.end - d.start) + TOL:
            flag(
                "D3",
                f"downlink {n}: volume {d.volume:.6g} > rate x duration "
                f"{par.rate * (d.end - d.start):.6g}",
                amount=d.volume - par.rate * (d.end - d.start),
            )
        # D2: data of an observation of this satellite, ended before the downlink starts
        for i, v in d.parts:
            u = of_opp.get(i)
            if u is None or orbit_sat[obs[u].orbit] != d.satellite:
                flag(
                    "D2",
                    f"downlink {n}: no observation of {sname} covers opportunity "
                    f"{inst.opp_ids[i] if 0 <= i < inst.n_opps else i}",
                )
                continue
            if not v > 0:
                flag("D2", f"downlink {n}: volume {v:g} of observation {u} must be > 0")
            if obs[u].end > d.start + TOL:
                flag(
                    "D2",
                    f"downlink {n} starts at {d.start:.6g} before observation {u} ends "
                    f"({obs[u].end:.6g})",
                    amount=obs[u].end - d.start,
                    observation=u,
                )
            sent[u] += v
            done_at[u] = max(done_at[u], d.end)
        # (4) D7: its seconds in each orbit of its satellite
        for j in np.flatnonzero(np.array(orbit_sat) == d.satellite):
            lap = min(d.end, inst.orbit_end[j]) - max(d.start, inst.orbit_start[j])
            if lap > 0:
                orbit_seconds[int(j)] += float(lap)
    for u in range(len(obs)):
        if sent[u] > vol[u] + TOL:  # D2: no more than it made
            flag(
                "D2",
                f"observation {u}: {sent[u]:.6g} sent > {vol[u]:.6g} observed",
                amount=sent[u] - vol[u],
                observation=u,
            )
    # D4: one downlink at a time per satellite, and not while observing unless allowed
    for s, ns in by_sat.items():
        ds = sorted((schedule.downlinks[n] for n in ns), key=lambda d: d.start)
        for a, b in zip(ds, ds[1:], strict=False):
            if b.start < a.end - TOL:
                flag(
                    "D4",
                    f"{inst.satellite_names[s]}: downlinks overlap at {b.start:.6g}",
                    amount=a.end - b.start,
                )
        if not par.while_observing:
            mine = [(u, ob) for u, ob in enumerate(obs) if orbit_sat[ob.orbit] == s]
            for d in ds:
                for u, ob in mine:
                    if min(d.end, ob.end) - max(d.start, ob.start) > TOL:
                        flag(
                            "D4",
                            f"{inst.satellite_names[s]}: downlink at {d.start:.6g} "
                            f"while observing (observation {u})",
                            observation=u,
                        )
    # D6: each pass holds an antenna from its first downlink to its last plus the set-up
    for g, st in enumerate(inst.stations):
        spans = sorted(
            (a, b + par.station_setup_s) for (h, _, _), (a, b) in passes.items() if h == g
        )
        ends: list[float] = []
        for a, b in spans:
            ends = [e for e in ends if e > a + TOL] + [b]
            if len(ends) > st.antennas:
                flag(
                    "D6",
                    f"station {st.id}: {len(ends)} passes at {a:.6g} s on "
                    f"{st.antennas} antenna(s), set-up {par.station_setup_s:g} s included",
                    amount=float(len(ends) - st.antennas),
                )
    # D5: the store at each observation's end (data in at ends, out evenly over a downlink)
    peak: dict[str, float] = {}
    for s in range(len(inst.satellite_names)):
        mine = sorted(
            (u for u, ob in enumerate(obs) if orbit_sat[ob.orbit] == s), key=lambda u: obs[u].end
        )
        if not mine:
            continue
        ends = np.array([obs[u].end for u in mine])
        made = np.cumsum([vol[u] for u in mine])[np.searchsorted(ends, ends + TOL, "right") - 1]
        gone = np.zeros(len(mine))
        for n in by_sat.get(s, ()):
            d = schedule.downlinks[n]
            gone += d.volume * np.clip((ends - d.start) / (d.end - d.start), 0.0, 1.0)
        store = made - gone
        peak[inst.satellite_names[s]] = float(store.max())
        cap = np.asarray(inst.memory_capacity, dtype=float)[[obs[u].orbit for u in mine]]
        for i in np.flatnonzero(store > cap + TOL):
            flag(
                "D5",
                f"{inst.satellite_names[s]}: store {store[i]:.6g} > capacity {cap[i]:g} "
                f"when observation {mine[i]} ends",
                amount=float(store[i] - cap[i]),
                observation=mine[i],
            )
    # D8: delivered when all its data is on the ground
    delivered = {u for u in range(len(obs)) if sent[u] >= vol[u] - TOL}
    lat = sorted(done_at[u] - obs[u].end for u in delivered)
    use: dict[str, float] = defaultdict(float)
    for d in schedule.downlinks:
        if 0 <= d.station < len(inst.stations):
            use[inst.stations[d.station].id] += d.end - d.start
    return {
        "delivered_obs": delivered,
        "orbit_seconds": dict(orbit_seconds),
        "delivered": len(delivered),
        "downlinks": len(schedule.downlinks),
        "on_board_end": sum(vol) - sum(sent),
        "latency_s": {
            "mean": float(np.mean(lat)) if lat else None,
            "p95": float(np.percentile(lat, 95)) if lat else None,
            "max": lat[-1] if lat else None,
        },
        "store_peak": peak,
        "station_seconds": dict(use),
    }
