"""Refill a delivered schedule (``docs/model.md``, "How the methods plan downlinks", step 4).

The searches plan observations within per-orbit memory allowances (:func:`sosp.downlink.
search_instance`), one number per orbit, and :func:`sosp.downlink.deliver` then drops what
cannot fly: the satellites' stores often keep room the allowances did not give out. This
module puts unobserved targets back where the real store, contacts and energy take them.
"""

from __future__ import annotations

import logging
import math
from bisect import bisect_right
from dataclasses import replace
from typing import Any

import numpy as np

from heuristics.timeline import OrbitTimeline
from sosp.downlink import deliver, deliverable
from sosp.instance import Instance
from sosp.rules import RollRule, orbit_rules
from sosp.schedule import Observation, Schedule, make_observation
from sosp.stop import Budget

log = logging.getLogger(__name__)


def refill(
    instance: Instance,
    observations: Any,
    budget: Budget | None = None,
    roll_rule: RollRule = "nadir",
) -> tuple[tuple[Observation, ...], list[Any]]:
    """Greedily add unobserved deliverable opportunities to a schedule with stations.

    Opportunities of unobserved targets are tried by weight per unit of data, then weight
    (the store is what the allowances ration): alone, merged into an observation of their
    orbit (a cluster at ``roll_rule``), or alone in place of an observation worth less (the
    one before or after it in time, or the orbit's least). A move must keep (3), (4), (6) and
    (11) on its orbit (:meth:`~heuristics.timeline.OrbitTimeline.check_insert`, with (5) left
    to the store, D5); it is kept when :func:`deliver` of the new observations delivers
    strictly more profit (it may drop others to do so), so the profit never falls and the
    result passes D1-D8 as :func:`deliver`'s does.

    Parameters
    ----------
    instance
        An instance with stations.
    observations
        A schedule's observations, delivered or not (:func:`deliver` runs on them first).
    budget
        The time to try in (it stops, with what it has, once expired or a stop is requested;
        None: no limit).
    roll_rule
        The roll of a merged cluster (:func:`sosp.rules.choose_roll`).

    Returns
    -------
    observations, downlinks
        As :func:`deliver` returns them.
    """
    inst, budget = instance, budget or Budget()
    obs, downlinks = deliver(inst, observations)
    profit = first = Schedule(obs).coverage_profit(inst)[0]
    lines: dict[int, OrbitTimeline] = {}

    def line(j: int) -> OrbitTimeline:
        if j not in lines:  # (5) gives way to the satellite's store (D5): deliver checks it
            lines[j] = OrbitTimeline(replace(orbit_rules(inst, j), memory_capacity=math.inf))
            mine = sorted((o for o in obs if o.orbit == j), key=lambda o: (o.start, o.end))
            lines[j].load([(o.start, o.end, o.roll, o) for o in mine])
        return lines[j]

    def value(o: Observation) -> float:
        return float(inst.target_weight[inst.opp_target[list(o.opps)]].sum())

    made = np.asarray(inst.memory_rate, float)[inst.opp_orbit] * (inst.opp_end - inst.opp_start)
    worth = np.asarray(inst.target_weight, float)[inst.opp_target]
    cand = np.flatnonzero(deliverable(inst))
    dense = worth[cand] / np.maximum(made[cand], 1e-12)  # data-free opportunities first
    cand = cand[np.lexsort((cand, -worth[cand], -dense))]
    taken = {int(t) for o in obs for t in inst.opp_target[list(o.opps)]}
    tried = 0
    for i in cand.tolist():
        if budget.expired():
            break
        if int(inst.opp_target[i]) in taken:
            continue
        tl, alone = line(int(inst.opp_orbit[i])), make_observation(inst, [i], roll_rule)
        entry = (alone.start, alone.end, alone.roll, alone)
        moves = [(None, alone)] if tl.check_insert(entry) else []
        reach = tl.rules.max_duration
        for p, e in enumerate(tl.obs):  # into a cluster whose window it may join (11)
            if e[0] - reach > alone.end or alone.start > e[1] + reach:
                continue
            try:
                both = make_observation(inst, (*e[3].opps, i), roll_rule)
            except ValueError:  # no common roll (7)
                continue
            if tl.check_replace(p, (both.start, both.end, both.roll, both)):
                moves.append((e[3], both))
        # in place of a neighbour in time (3) or of the orbit's least worth (6), worth less
        at = bisect_right(tl.obs, (alone.start, alone.end, math.inf))
        least = min(range(len(tl)), key=lambda p: value(tl.obs[p][3]), default=-1)
        for p in sorted({at - 1, at, least} & set(range(len(tl)))):
            if value(tl.obs[p][3]) < worth[i]:
                snap = tl.snapshot()
                tl.remove(p)
                if tl.check_insert(entry):
                    moves.append((snap[0][p][3], alone))
                tl.restore(snap)
        for old, ob in moves:
            tried += 1
            got, dls = deliver(inst, [o for o in obs if o is not old] + [ob])
            if (p := Schedule(got).coverage_profit(inst)[0]) > profit:
                obs, downlinks, profit = got, dls, p
                lines.clear()  # deliver may have dropped observations of any orbit
                taken = {int(t) for o in obs for t in inst.opp_target[list(o.opps)]}
                break
    log.info("refill: delivered profit %g -> %g (%d moves tried)", first, profit, tried)
    return obs, downlinks
