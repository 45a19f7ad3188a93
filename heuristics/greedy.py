"""Highest-weight-first insertion without clustering (the simple baseline ``greedy``).

Targets are taken in decreasing weight (ties: instance order). Each is inserted, alone at its
own roll, into the first of its opportunities that keeps the schedule feasible, trying the
orbits with the most resources left first (the paper's rule in 5.1, step 6).
"""

from __future__ import annotations

import numpy as np

from heuristics.timeline import OrbitTimeline
from sosp.instance import Instance
from sosp.result import Result, Status
from sosp.schedule import Observation, Schedule


def solve_greedy(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None
) -> Result:
    """Insert targets by decreasing weight; deterministic (``rng`` is unused).

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused (the method is deterministic); accepted for the common signature.
    time_limit
        Unused: the method is one pass over the targets.
    """
    del rng, time_limit
    lines = [OrbitTimeline.of(instance, j) for j in range(instance.n_orbits)]
    order = np.lexsort((np.arange(instance.n_targets), -instance.target_weight))
    profit = 0.0
    observed = 0
    for k in order:
        opps = instance.target_opps[k]
        cand = sorted(opps.tolist(), key=lambda i: -lines[instance.opp_orbit[i]].free_share())
        for i in cand:
            line = lines[int(instance.opp_orbit[i])]
            entry = (
                float(instance.opp_start[i]),
                float(instance.opp_end[i]),
                float(instance.opp_roll[i]),
                i,
            )
            chk = line.check_insert(entry)
            if chk:
                line.insert(entry, chk)
                profit += float(instance.target_weight[k])
                observed += 1
                break
    obs = tuple(
        Observation(j, s, e, r, (int(i),))
        for j, line in enumerate(lines)
        for s, e, r, i in line.obs
    )
    return Result("greedy", Status.FEASIBLE, Schedule(obs), profit, observed)
