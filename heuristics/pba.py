"""PBA-STC: the partition-based upper bound of Vasquez and Hao on static cluster-tasks.

The paper's Tables 3-4 give, as R* and F*, "the upper bounds obtained by PBA-STC": the
partition-based approach of Vasquez and Hao (Journal of Combinatorial Optimization 7, 2003)
for the SPOT5 daily photograph problem, which follows the divide and conquer principle and
uses dynamic programming and tabu search conjointly. The paper applies it to static
cluster-tasks with the energy knapsack "relaxed like the memory storage constraint".

The relaxation (``docs/baselines.md``, section PBA-STC, states every choice)
    the variables are the targets (as the SPOT5 photographs: each target is covered by one of
    its static cluster-tasks, :func:`sosp.clustering.static_cluster_tasks`, or by none, as a
    photograph is taken by one of its cameras or not). The targets are split into *parts*;
    each part is the problem restricted to its targets: choose cluster-tasks to cover the
    part's targets (a task counts only for the part's targets it covers) subject to (3)
    between the chosen tasks and (6) per orbit, with memory (5) and energy (4) relaxed (the
    paper's modification (2)). The constraints between tasks chosen for different parts are
    relaxed too.
Why the sum of the parts' optima bounds the static optimum
    let S be an optimal static schedule (a set of cluster-tasks keeping (3)-(6)). For a part
    P, the tasks of S covering P's targets keep (3) and (6) (a subset of a feasible set) and
    cover exactly the targets of P that S covers: a feasible selection of P's problem worth
    S's profit on P. The parts partition the targets, so the sum of the parts' optima is at
    least the profit of S. This holds for every partition.
The partition (dynamic programming)
    the targets are put in an order that keeps interacting targets close (reverse
    Cuthill-McKee on the graph linking two targets when tasks covering them are in (3)
    conflict or one task covers both: SPOT5's photographs come in track order, which has
    the same effect there), and the partition into consecutive intervals of at most
    ``max_part`` targets that minimises the sum of the parts' optima is found by dynamic
    programming over the cut points: ``B[j] = min over L of B[j - L] + opt(j - L, j)``.
    Interactions cut by a boundary are what the bound loses.
The parts' optima (exact search)
    each part is solved exactly by depth-first branch and bound over its targets (fewest
    tasks first): a target already covered needs no branch; otherwise each compatible task
    covering it in turn, then "not covered"; the bound is the value so far plus the weight of
    the part's undecided targets; the search stops when the value reaches the part's total
    weight. A part whose search exceeds ``node_limit`` nodes, or is not reached before the
    time limit or a stop request (:mod:`sosp.stop`), gets its total weight (always a valid
    bound): the result stays an upper bound.
The schedule (method ``pba-stc``)
    the tasks of the best partition's part optima, by decreasing weight, then every other
    task by decreasing weight, inserted when they add profit and keep (3)-(6)
    (:func:`heuristics.hpfs.insertion_decode`): the parts' solutions recombined and repaired.
    Its profit is at most the static optimum, at most the bound.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from heuristics.hpfs import insertion_decode, priority_order
from sosp.clustering import TaskSet, static_cluster_tasks, tasks_to_schedule
from sosp.conflicts import setup_conflict_pairs
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.result import Result, Status
from sosp.rules import check_roll_rule
from sosp.schedule import RollRule
from sosp.stop import Interrupted

log = logging.getLogger(__name__)

Order = Literal["rcm", "index"]


@dataclass(frozen=True)
class PBAParams:
    """Parameters of the partition-based bound (reasons in ``docs/baselines.md``).

    Parameters
    ----------
    max_part
        Most targets in one part.
    node_limit
        Search nodes per part before it falls back to its total weight.
    order
        Order of the targets: ``"rcm"`` (reverse Cuthill-McKee on the interaction graph) or
        ``"index"`` (the instance's order; for tests and comparisons).
    roll_rule
        Roll of multi-opportunity cluster-tasks, ``"midpoint"`` (9) or ``"nadir"``.
    """

    max_part: int = 10
    node_limit: int = 20000
    order: Order = "rcm"
    roll_rule: RollRule = "midpoint"

    def __post_init__(self) -> None:
        for name in ("max_part", "node_limit"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1:
                raise InputError(f"{name}: expected an integer >= 1, got {v!r}")
        if self.order not in ("rcm", "index"):
            raise InputError(f"order: expected 'rcm' or 'index', got {self.order!r}")
        check_roll_rule(self.roll_rule)


@dataclass
class PartProblem:
    """The relaxed problem the parts are cut from: usable tasks, their conflicts, targets.

    Attributes
    ----------
    tasks
        The static cluster-tasks.
    options
        Per target (instance index), the usable tasks covering it.
    conflicts
        Per usable task, the tasks in (3) conflict with it.
    openings
        Per orbit, c_j (6).
    weight
        Per target, p_k.
    targets
        The targets some usable task covers, weight > 0, in instance order.
    """

    tasks: TaskSet
    options: dict[int, tuple[int, ...]]
    conflicts: dict[int, frozenset[int]]
    openings: list[int]
    weight: list[int]
    targets: list[int]


def part_problem(instance: Instance, tasks: TaskSet) -> PartProblem:
    """The relaxed problem: (3) and (6) kept, (4)-(5) dropped (paper section 6.2)."""
    c = [int(x) for x in instance.max_openings]
    w = [int(x) for x in instance.target_weight]
    usable = [t for t in range(len(tasks)) if tasks.weight[t] > 0 and c[int(tasks.orbit[t])] > 0]
    idx = np.array(usable, dtype=np.int64)
    conf: dict[int, set[int]] = {t: set() for t in usable}
    if len(idx) > 1:
        pairs = setup_conflict_pairs(
            instance, tasks.orbit[idx], tasks.start[idx], tasks.end[idx], tasks.roll[idx]
        )
        for a, b in pairs.tolist():
            conf[usable[a]].add(usable[b])
            conf[usable[b]].add(usable[a])
    options: dict[int, list[int]] = {}
    for t in usable:
        for k in tasks.targets[t]:
            if w[k] > 0:
                options.setdefault(k, []).append(t)
    return PartProblem(
        tasks,
        {k: tuple(v) for k, v in options.items()},
        {t: frozenset(v) for t, v in conf.items()},
        c,
        w,
        sorted(options),
    )


def target_order(pp: PartProblem, order: Order = "rcm") -> list[int]:
    """The targets in the order the partition cuts (see the module docstring)."""
    if order == "index" or len(pp.targets) < 3:
        return list(pp.targets)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    pos = {k: i for i, k in enumerate(pp.targets)}
    rows: list[int] = []
    cols: list[int] = []
    tk = pp.tasks.targets
    for t, others in pp.conflicts.items():
        mine = [pos[k] for k in tk[t] if k in pos]
        near = {pos[k] for h in others for k in tk[h] if k in pos}
        near.update(mine)
        for a in mine:
            for b in near:
                if a != b:
                    rows.append(a)
                    cols.append(b)
    n = len(pp.targets)
    m = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n)).tocsr()
    m = m + m.T
    perm = reverse_cuthill_mckee(m, symmetric_mode=True)
    return [pp.targets[int(i)] for i in perm]


class _Budget(Exception):
    pass


def part_optimum(
    pp: PartProblem, part: list[int], node_limit: int = 20000
) -> tuple[int, list[int], bool]:
    """Optimum of one part: the best weight of its targets covered under (3) and (6).

    Returns
    -------
    tuple
        ``(value, tasks, exact)``: the optimum and tasks reaching it; when the search exceeds
        ``node_limit`` nodes, ``(total weight of the part, [], False)`` (a valid bound).
    """
    w = pp.weight
    order = sorted(part, key=lambda k: (len(pp.options[k]), -w[k], k))
    total = sum(w[k] for k in order)
    inpart = set(order)
    best_val = -1
    best_set: list[int] = []
    chosen: list[int] = []
    count: dict[int, int] = {}
    covered: dict[int, int] = {}
    orbit = pp.tasks.orbit
    nodes = 0

    def rest(q: int) -> int:
        return sum(w[k] for k in order[q:] if not covered.get(k))

    def dfs(q: int, value: int) -> bool:
        nonlocal best_val, best_set, nodes
        nodes += 1
        if nodes > node_limit:
            raise _Budget
        while q < len(order) and covered.get(order[q]):
            q += 1
        if q == len(order) or value + rest(q) <= best_val:
            if value > best_val:
                best_val, best_set = value, list(chosen)
            return best_val == total
        k = order[q]
        for t in pp.options[k]:
            j = int(orbit[t])
            if count.get(j, 0) >= pp.openings[j] or any(h in pp.conflicts[t] for h in chosen):
                continue
            gain = 0
            for x in pp.tasks.targets[t]:
                if x in inpart:
                    if not covered.get(x):
                        gain += w[x]
                    covered[x] = covered.get(x, 0) + 1
            chosen.append(t)
            count[j] = count.get(j, 0) + 1
            done = dfs(q + 1, value + gain)
            chosen.pop()
            count[j] -= 1
            for x in pp.tasks.targets[t]:
                if x in inpart:
                    covered[x] -= 1
            if done:
                return True
        # Target k not covered.
        if value + rest(q + 1) > best_val:
            return dfs(q + 1, value)
        return False

    try:
        dfs(0, 0)
    except _Budget:
        return total, [], False
    return best_val, best_set, True


def pba_partition(
    instance: Instance,
    params: PBAParams,
    deadline: float | None = None,
    tasks: TaskSet | None = None,
) -> dict[str, Any]:
    """The partition-based bound: the best partition by dynamic programming, and its parts.

    Returns
    -------
    dict
        ``bound`` (R*), ``targets`` (F*: the targets covered by the parts' optima), ``parts``
        (lists of target indices), ``part_tasks`` (the tasks of each part's optimum),
        ``inexact_parts`` (parts that fell back to their total weight), ``subproblems``.
    """
    if tasks is None:
        tasks = static_cluster_tasks(instance, roll_rule=params.roll_rule)
    pp = part_problem(instance, tasks)
    order = target_order(pp, params.order)
    n = len(order)
    lmax = params.max_part
    inf = float("inf")
    best = [0.0] + [inf] * n
    arg = [0] * (n + 1)
    memo: dict[tuple[int, int], tuple[int, list[int], bool]] = {}
    solved = 0
    stopped = False
    interrupted = Interrupted()
    for j in range(1, n + 1):
        stopped = stopped or interrupted()
        for length in range(1, min(lmax, j) + 1):
            i = j - length
            part = order[i:j]
            if stopped or (deadline is not None and time.perf_counter() > deadline):
                stopped = True
                res = (sum(pp.weight[k] for k in part), [], False)
            else:
                res = part_optimum(pp, part, params.node_limit)
                solved += 1
            memo[(i, j)] = res
            cand = best[i] + res[0]
            if cand < best[j]:
                best[j], arg[j] = cand, i
    parts: list[list[int]] = []
    part_tasks: list[list[int]] = []
    targets = inexact = 0
    j = n
    while j > 0:
        i = arg[j]
        value, chosen, exact = memo[(i, j)]
        parts.append(order[i:j])
        part_tasks.append(chosen)
        inexact += not exact
        covered = {k for t in chosen for k in tasks.targets[t]} & set(order[i:j])
        targets += len(covered) if exact else j - i
        j = i
    parts.reverse()
    part_tasks.reverse()
    return {
        "bound": int(best[n]),
        "targets": targets,
        "parts": parts,
        "part_tasks": part_tasks,
        "inexact_parts": inexact,
        "subproblems": solved,
        "tasks": tasks,
    }


def pba_bound(
    instance: Instance,
    *,
    time_limit: float | None = None,
    max_part: int = PBAParams.max_part,
    node_limit: int = PBAParams.node_limit,
    order: Order = "rcm",
    roll_rule: RollRule = "midpoint",
) -> dict[str, Any]:
    """``sosp bound --method pba``: PBA-STC's upper bound R* on the static problem.

    Returns
    -------
    dict
        ``bound``, ``model`` (``"static"``), ``method`` (``"pba"``), ``targets`` (F*),
        ``parts``, ``inexact_parts``, ``subproblems`` and ``runtime_s``.
    """
    t0 = time.perf_counter()
    params = PBAParams(max_part, node_limit, order, roll_rule)
    deadline = None if time_limit is None else t0 + float(time_limit)
    out = pba_partition(instance, params, deadline)
    return {
        "bound": out["bound"],
        "model": "static",
        "method": "pba",
        "targets": out["targets"],
        "parts": len(out["parts"]),
        "inexact_parts": out["inexact_parts"],
        "subproblems": out["subproblems"],
        "runtime_s": time.perf_counter() - t0,
    }


def solve_pba_stc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    max_part: int = PBAParams.max_part,
    node_limit: int = PBAParams.node_limit,
    order: Order = "rcm",
    roll_rule: RollRule = "midpoint",
) -> Result:
    """PBA-STC as a method: the bound R* and the parts' solutions recombined and repaired.

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused (the method is deterministic); accepted for the common signature.
    time_limit
        Seconds for the bound (parts not reached get their total weight).
    max_part, node_limit, order, roll_rule
        See :class:`PBAParams`.

    Returns
    -------
    Result
        Status ``feasible``, ``bound`` = R*; ``stats`` holds F* (``bound_targets``), the
        number of parts and of inexact parts.
    """
    del rng
    params = PBAParams(max_part, node_limit, order, roll_rule)
    deadline = None if time_limit is None else time.perf_counter() + float(time_limit)
    out = pba_partition(instance, params, deadline)
    tasks: TaskSet = out["tasks"]
    first = sorted({t for ts in out["part_tasks"] for t in ts}, key=lambda t: -tasks.weight[t])
    lines: dict = {}
    covered = np.zeros(instance.n_targets, dtype=bool)
    chosen, profit = insertion_decode(instance, tasks, first, lines, covered)
    more, extra = insertion_decode(instance, tasks, priority_order(tasks), lines, covered)
    chosen += more
    profit += extra
    schedule = tasks_to_schedule(instance, tasks, chosen)
    observed = sum(len(o.opps) for o in schedule.observations)
    stats = {
        "bound_targets": out["targets"],
        "parts": len(out["parts"]),
        "inexact_parts": out["inexact_parts"],
        "subproblems": out["subproblems"],
    }
    log.info("pba-stc: bound %d, schedule %d", out["bound"], profit)
    return Result(
        "pba-stc",
        Status.FEASIBLE,
        schedule,
        float(profit),
        observed,
        bound=float(out["bound"]),
        stats=stats,
    )
