"""Conventional simulated annealing over static cluster-tasks (SA-STC, paper section 6.3).

The paper's SA baseline is "the simulated annealing algorithm incorporating the mutation
operator called temperature-dependent swap, which performed best in Globus's tests" (Globus,
Crawford, Lohn and Pryor, "A comparison of techniques for scheduling Earth observing
satellites", AAAI/IAAI 2004), combined with static task clustering (STC).

Representation and decoder
    A solution is a permutation of the static cluster-tasks
    (:func:`sosp.clustering.static_cluster_tasks`). It is decoded greedily, as in Globus et
    al.: the tasks are taken in permutation order and each is inserted into its orbit's
    timeline when it still adds profit (some target not yet covered: coverage semantics,
    ``docs/model.md``) and (3)-(6), (11) stay satisfied
    (:class:`heuristics.timeline.OrbitTimeline`). The fitness is objective (1) of the decoded
    schedule. Tasks that can never be scheduled (zero weight, infeasible alone) are left out
    of the permutation. The initial permutation is the HPFS order (decreasing weight), so
    SA-STC starts from the HPFS-STC schedule.
Temperature-dependent swap
    two tasks are swapped whose distance in the permutation is drawn uniformly from
    ``1..d(T)`` with ``d(T) = max(1, round((n - 1) * T / T0))``: at high temperature any two
    tasks may swap (large jumps), as T falls the swaps become local (fine tuning).
Acceptance and cooling
    Metropolis: a move changing the profit by ``delta`` is accepted with probability
    ``min(1, exp(delta / T))``. Geometric cooling ``T = T0 * (T_final / T0)^f`` where the
    progress f is ``k / iterations`` (so T reaches ``T_final`` at the last iteration) or, with
    a ``time_limit``, the larger of that and the elapsed share of the time limit (so a run cut
    by time still cools fully; such a run depends on the clock, as any time-limited run).
    Defaults: ``T0`` = the mean weight of a usable task (losing an average task is
    accepted with probability 1/e at the start), ``T_final = T0 / 100``.
Incremental decode (what a move costs)
    swapping positions i < j leaves the decode of positions < i unchanged. The search keeps
    the decoder state (timelines and coverage) at a "cursor" position and moves it to i by
    removing or re-inserting only the tasks accepted in between (no feasibility checks), then
    decodes from i. After position j both permutations have decoded the same set of tasks,
    and as soon as the same subset is accepted (the state depends only on that subset) the
    rest of the decode is the same as before, so it stops there. A local swap (low
    temperature) costs O(j - i) checks plus the cursor move, instead of a full O(n) decode.
    A rejected move is undone the same way. The returned schedule is re-decoded from scratch.
Stopping
    after ``iterations`` moves or at ``time_limit`` seconds, whichever comes first. The rng is
    the only randomness: the same seed and iterations give the same schedule.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from heuristics.hpfs import insertion_decode, priority_order, task_result
from heuristics.stc import Watch, at_least
from heuristics.timeline import OrbitTimeline, fits_alone, task_entries
from sosp.clustering import static_cluster_tasks
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import Params, param
from sosp.result import Result
from sosp.schedule import RollRule

log = logging.getLogger(__name__)


def swap_distance(n: int, temperature: float, t0: float) -> int:
    """Largest swap distance at ``temperature``: ``max(1, round((n - 1) * T / T0))``."""
    if n < 2:
        return 0
    return max(1, min(n - 1, int(round((n - 1) * temperature / t0))))


@dataclass(frozen=True)
class SAParams(Params):
    """Parameters of :func:`solve_sa_stc`."""

    iterations: int = param(20000, "Number of swap moves.")
    t0: float | None = param(None, "Initial temperature (None: mean task weight).", "weight")
    t_final: float | None = param(None, "Final temperature (None: t0 / 100).", "weight")
    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")

    def check(self) -> None:
        at_least(self, iterations=0)


def solve_sa_stc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    iterations: int = SAParams.iterations,
    t0: float | None = SAParams.t0,
    t_final: float | None = SAParams.t_final,
    roll_rule: RollRule = SAParams.roll_rule,
) -> Result:
    """SA-STC: simulated annealing with temperature-dependent swaps over cluster-task orders.

    Parameters
    ----------
    instance
        The problem.
    rng
        The only source of randomness (picks swaps and Metropolis draws).
    time_limit
        Wall-time limit in seconds (None: stop after ``iterations``).
    iterations
        Number of swap moves.
    t0, t_final
        Initial and final temperatures (defaults in the module docstring).
    roll_rule
        Roll of multi-opportunity cluster-tasks, ``"midpoint"`` (9) or ``"nadir"``.

    Returns
    -------
    Result
        Status ``feasible``; ``iterations`` moves done; ``stats`` holds temperatures, accepted
        and improving moves and the iteration of the best schedule.
    """
    watch = Watch(time_limit)
    tasks = static_cluster_tasks(instance, roll_rule=roll_rule)
    tw = instance.target_weight

    alone = fits_alone(instance, tasks)
    usable = [int(t) for t in priority_order(tasks) if tasks.weight[t] > 0 and alone[t]]
    n = len(usable)
    if t0 is None:
        t0 = float(np.mean(tasks.weight[usable])) if n else 1.0
    if t_final is None:
        t_final = t0 / 100.0
    if not (t0 > 0 and 0 < t_final <= t0):
        raise InputError(f"t0, t_final: need 0 < t_final <= t0, got {t0!r}, {t_final!r}")
    log_ratio = math.log(t_final / t0)

    # Per-task data as Python lists (the inner loops are scalar).
    orb = tasks.orbit.tolist()
    # timeline entries (start, end, roll, task), built once
    ent = task_entries(tasks)
    tg = [tuple(int(k) for k in ks) for ks in tasks.targets]
    twl = tw.tolist()
    lines = {j: OrbitTimeline.of(instance, j) for j in set(orb[t] for t in usable)}
    cover = [0] * instance.n_targets

    perm = list(usable)
    acc = [False] * len(tasks)  # accepted in the decode of ``perm``
    gain = [0] * len(tasks)  # its profit contribution there

    def put(t: int) -> None:
        lines[orb[t]].insert(ent[t])  # replays an accepted insertion: it fits
        for k in tg[t]:
            cover[k] += 1

    def take(t: int) -> None:
        lines[orb[t]].discard(ent[t])
        for k in tg[t]:
            cover[k] -= 1

    def fit(t: int) -> int:
        # the decoder's step: insert t if it earns and fits; what it earns (0: not inserted)
        g = 0
        for k in tg[t]:
            if cover[k] == 0:
                g += twl[k]
        chk = lines[orb[t]].check_insert(ent[t]) if g > 0 else None
        if not chk:
            return 0
        lines[orb[t]].insert(ent[t], chk)
        for k in tg[t]:
            cover[k] += 1
        return g

    # Initial decode (HPFS order) leaves the cursor at n.
    total = 0
    for t in perm:
        g = fit(t)
        if g:
            acc[t], gain[t] = True, g
            total += g
    cursor = n
    best_total, best_perm, best_iter = total, list(perm), 0
    temperature = t0
    accepted = improved = 0
    it = 0
    new_acc: list[bool] = []
    new_gain: list[int] = []

    # the limits (iterations, time) set the cooling schedule; progress, the time limit and
    # stop requests are checked every 16 moves
    while it < iterations and n >= 2:
        if (it & 15) == 0 and watch(it, best_total):
            break
        if time_limit is not None and (it & 15) == 0:
            # the share of the limit passed, counted as the limit is: fully cooled at its end
            share = 1.0 - (watch.budget.left() or 0.0) / time_limit
            temperature = t0 * math.exp(log_ratio * max(it / max(iterations, 1), share))
        elif time_limit is None:
            temperature = t0 * math.exp(log_ratio * it / max(iterations, 1))
        it += 1
        dist = int(rng.integers(1, swap_distance(n, temperature, t0) + 1))
        i = int(rng.integers(0, n - dist))
        j = i + dist
        # Move the cursor to i (state = accepted tasks of positions < i).
        if cursor > i:
            for p in range(cursor - 1, i - 1, -1):
                if acc[perm[p]]:
                    take(perm[p])
        else:
            for p in range(cursor, i):
                if acc[perm[p]]:
                    put(perm[p])
        perm[i], perm[j] = perm[j], perm[i]
        # Decode from i until the accepted subset matches the old one again after j.
        diff = 0
        delta = 0
        new_acc.clear()
        new_gain.clear()
        p = i
        while p < n:
            t = perm[p]
            g = fit(t)
            ok = g > 0
            new_acc.append(ok)
            new_gain.append(g)
            if ok != acc[t]:
                diff += 1
            delta += g - gain[t]
            p += 1
            if p > j and diff == 0:
                break
        end = p
        if delta >= 0 or rng.random() < math.exp(delta / temperature):
            accepted += 1
            for q in range(i, end):
                t = perm[q]
                acc[t], gain[t] = new_acc[q - i], new_gain[q - i]
            cursor = end
            total += delta
            if total > best_total:
                improved += 1
                best_total, best_perm, best_iter = total, list(perm), it
        else:
            for q in range(end - 1, i - 1, -1):
                if new_acc[q - i]:
                    take(perm[q])
            perm[i], perm[j] = perm[j], perm[i]
            cursor = i

    chosen, profit = insertion_decode(instance, tasks, best_perm)
    if profit != best_total:
        log.warning("sa-stc: re-decoded profit %d differs from tracked %d", profit, best_total)
    stats = {
        "tasks": len(tasks),
        "usable_tasks": n,
        "t0": t0,
        "t_final": t_final,
        "temperature_end": temperature,
        "accepted_moves": accepted,
        "improving_moves": improved,
        "best_iteration": best_iter,
    }
    log.info("sa-stc: profit %d after %d iterations (best at %d)", profit, it, best_iter)
    return task_result("sa-stc", instance, tasks, chosen, profit, iterations=it, stats=stats)
