"""The independent validator: the referee of every schedule from every solver.

It re-derives everything from the instance's raw columns and the schedule's stated
observations (orbit, window, roll, covered opportunities), and shares no bookkeeping with any
solver. It checks, as ``docs/model.md`` states:

* structure: each observation is on a known orbit, covers at least one opportunity of that
  orbit, each covered opportunity's window lies inside the observation window, and the window
  lies inside the orbit;
* (2) every target is observed at most once in the whole schedule;
* (3) on each orbit, consecutive observations u, v (by start time) satisfy
  ``ts_v - te_u >= a + (|theta_u| + |theta_v|) / v``;
* (4) energy ``eo * sum(te_u - ts_u) + es * sum_consecutive (|theta_u| + |theta_v|) / v <= E``;
* (5) memory ``w * sum(te_u - ts_u) <= W``;  (6) openings ``<= c``;
* (7) the stated roll lies inside the roll range of every covered opportunity;
* (11) ``te_u - ts_u <= Delta T``;
* the claimed profit, when the schedule states one, equals the recomputed objective (1).

Comparisons allow :data:`TOL` of slack for floating-point rounding.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import asdict, dataclass, field
from typing import Any

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
                profit += float(inst.target_weight[k])

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
        memory = float(inst.memory_rate[j]) * observe
        usage.append(OrbitUsage(oid, len(seq), observe, slew, energy, memory))
        for rule, what, used, cap in (
            ("4", "energy", energy, inst.energy_capacity[j]),
            ("5", "memory", memory, inst.memory_capacity[j]),
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
    return ValidationReport(
        feasible=not out,
        violations=out,
        profit=profit,
        observed=len(seen_target),
        energy=sum((u.energy for u in usage), 0.0),  # in orbit order, as checked
        memory=sum((u.memory for u in usage), 0.0),
        orbits=usage,
    )
