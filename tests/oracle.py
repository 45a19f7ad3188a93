"""Brute-force optimum of tiny instances, independent of the exact models in ``models/``.

Every candidate schedule is built directly from the instance and judged by the validator
(:func:`sosp.validate.validate`), the referee; nothing here shares code with ``models/``.

* ``task``: every subset of opportunities, each observed alone at its own roll over its own
  window (the paper's IP (1)-(6)).
* ``static``: every subset of the static cluster-tasks of
  :func:`sosp.clustering.static_cluster_tasks`, each target claimed once
  (:func:`sosp.clustering.tasks_to_schedule`).
* ``cluster``: on each orbit, every way of picking opportunities and splitting them into
  observations. Two observations of one orbit need disjoint windows in time order (3), so in
  start order each opportunity is skipped, joins the current observation or opens the next one
  (3 choices each). An observation's window is [min ts, max te] of its members and its roll the
  point of their common range closest to nadir (both never cost more than any other choice,
  ``docs/model.md``, "What makes the exact models exact"). Orbits are then combined, each
  target counted once.

* :func:`brute_force_stations`: with ground stations, every subset of opportunities (as in
  ``task``), its downlinks laid by :func:`sosp.downlink.deliver` (which drops what cannot
  fly), the best delivered profit the validator accepts.

Keep instances tiny: ``task`` and ``static`` are 2^n, ``cluster`` 3^n per orbit.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from sosp.clustering import static_cluster_tasks, tasks_to_schedule
from sosp.instance import Instance
from sosp.rules import RollRule
from sosp.schedule import Observation, Schedule
from sosp.validate import validate

MAX_OPPS = 14


@dataclass(frozen=True)
class OracleResult:
    """The optimum and one schedule reaching it (validated)."""

    profit: float
    schedule: Schedule


def brute_force(instance: Instance, model: str, roll_rule: RollRule = "midpoint") -> OracleResult:
    """The exhaustive optimum of ``model`` (``"task"``, ``"cluster"`` or ``"static"``; the
    static cluster-tasks' rolls by ``roll_rule``, as :func:`static_cluster_tasks`)."""
    if instance.n_opps > MAX_OPPS:
        raise ValueError(f"brute force needs at most {MAX_OPPS} opportunities")
    if model == "task":
        return _task(instance)
    if model == "static":
        return _static(instance, roll_rule)
    if model == "cluster":
        return _cluster(instance)
    raise ValueError(model)


def brute_force_stations(instance: Instance) -> OracleResult:
    """The best delivered profit over every subset of opportunities, each observed alone over
    its own window, the downlinks laid by the planner (:func:`sosp.downlink.deliver`).

    For one satellite, or stations never asked for more antennas than they have, the planner
    sends each satellite's data as early as possible, which no plan beats
    (``docs/model.md``), so this is the optimum of the paper's task model with downlinks."""
    from sosp.downlink import deliver

    if instance.n_opps > MAX_OPPS:
        raise ValueError(f"brute force needs at most {MAX_OPPS} opportunities")
    n = instance.n_opps

    def schedules():
        for mask in range(1 << n):
            chosen = [_single(instance, i) for i in range(n) if mask >> i & 1]
            obs, downlinks = deliver(instance, chosen)
            yield Schedule(obs, downlinks=tuple(downlinks))

    return _best(instance, schedules())


def _best(instance: Instance, schedules) -> OracleResult:
    best = OracleResult(0.0, Schedule(()))
    for sched in schedules:
        rep = validate(instance, sched)
        if rep.feasible and rep.profit > best.profit:
            best = OracleResult(rep.profit, sched)
    return best


def _single(instance: Instance, i: int) -> Observation:
    return Observation(
        int(instance.opp_orbit[i]),
        float(instance.opp_start[i]),
        float(instance.opp_end[i]),
        float(instance.opp_roll[i]),
        (i,),
    )


def _task(instance: Instance) -> OracleResult:
    n = instance.n_opps
    return _best(
        instance,
        (
            Schedule(tuple(_single(instance, i) for i in range(n) if mask >> i & 1))
            for mask in range(1 << n)
        ),
    )


def _static(instance: Instance, roll_rule: RollRule) -> OracleResult:
    tasks = static_cluster_tasks(instance, roll_rule)
    n = len(tasks)
    return _best(
        instance,
        (
            tasks_to_schedule(instance, tasks, [t for t in range(n) if mask >> t & 1])
            for mask in range(1 << n)
        ),
    )


def _group_observation(instance: Instance, members: list[int]) -> Observation | None:
    """The observation of a group: window (10), roll nadir-closest in the common range (8)."""
    idx = np.array(members)
    lo = float(instance.opp_roll_min[idx].max())
    hi = float(instance.opp_roll_max[idx].min())
    if lo > hi:
        return None
    roll = min(max(0.0, lo), hi)
    return Observation(
        int(instance.opp_orbit[idx[0]]),
        float(instance.opp_start[idx].min()),
        float(instance.opp_end[idx].max()),
        roll,
        tuple(sorted(members)),
    )


def _orbit_options(instance: Instance, j: int) -> dict[frozenset[int], tuple[Observation, ...]]:
    """Feasible observation sequences of orbit j, one witness per covered target set."""
    sl = instance.orbit_opps(j)
    opps = list(range(sl.start, sl.stop))
    out: dict[frozenset[int], tuple[Observation, ...]] = {frozenset(): ()}
    # choice 0: skip, 1: join the current observation, 2: open a new observation
    for choice in itertools.product((0, 1, 2), repeat=len(opps)):
        groups: list[list[int]] = []
        ok = True
        for i, c in zip(opps, choice, strict=True):
            if c == 1:
                if not groups:
                    ok = False
                    break
                groups[-1].append(i)
            elif c == 2:
                groups.append([i])
        if not ok or not groups:
            continue
        obs = [_group_observation(instance, g) for g in groups]
        if any(o is None for o in obs):
            continue
        covered = frozenset(int(instance.opp_target[i]) for g in groups for i in g)
        if covered in out:
            continue
        sched = Schedule(tuple(obs))  # type: ignore[arg-type]
        if validate(instance, sched).feasible:  # the referee, orbit by orbit
            out[covered] = sched.observations
    return out


def _cluster(instance: Instance) -> OracleResult:
    per_orbit = [_orbit_options(instance, j) for j in range(instance.n_orbits)]
    w = instance.target_weight
    best_profit, best_pick = 0.0, None
    for pick in itertools.product(*(list(o.items()) for o in per_orbit)):
        covered = frozenset().union(*(c for c, _ in pick))
        profit = float(sum(int(w[k]) for k in covered))
        if profit > best_profit:
            best_profit, best_pick = profit, pick
    if best_pick is None:
        return OracleResult(0.0, Schedule(()))
    # Witness: claim each target once; drop opportunities already claimed, then empty groups
    # (shrinking a group keeps its window and roll valid; removing one never breaks (3)-(6)).
    claimed: set[int] = set()
    obs = []
    for _, seq in best_pick:
        for ob in seq:
            mine = tuple(i for i in ob.opps if int(instance.opp_target[i]) not in claimed)
            claimed.update(int(instance.opp_target[i]) for i in mine)
            if mine:
                obs.append(Observation(ob.orbit, ob.start, ob.end, ob.roll, mine))
    sched = Schedule(tuple(obs))
    rep = validate(instance, sched)
    assert rep.feasible and rep.profit == best_profit, rep.violations
    return OracleResult(best_profit, sched)
