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
    paper's modification (2)). Between the parts, (3) and (6) are *priced* (below); without
    prices (``prices="none"``, the paper's reading) they are relaxed, and a part of ten
    targets has every orbit's openings and time to itself, which on the dense C scenarios
    gives nearly the total weight.
The prices (:func:`lp_prices`)
    every orbit j with more usable tasks than openings gets ``lam_j >= 0`` per opening, every
    maximal clique K of the (3) conflicts of an orbit (an interval graph,
    :func:`models.cliques.maximal_cliques`) gets ``mu_K >= 0``; a task t costs
    ``pi_t = lam_j(t) + sum_{K ni t} mu_K``, split into shares ``s_tk >= 0`` among its
    positive-weight targets with ``sum_k s_tk <= pi_t``. A part P values a choice of tasks at
    the weight of the targets of P it covers minus, per chosen task t, ``sum_{k in P} s_tk``.
    The prices are the dual of the LP relaxation (coverage rows ``z_k <= sum x_t``, the
    openings rows (6) and the clique rows of (3)), solved once by HiGHS; with them the parts
    of one target add up to the LP bound, and the partition can only lower that sum.
Why the result is an upper bound
    let S be an optimal static schedule (cluster-tasks keeping (3)-(6); wlog none of weight
    0, whose positive-weight targets all lie in parts) and S_P the
    tasks of S covering targets of part P: a subset of S, so it keeps (3) and (6), and it
    covers exactly the targets of P that S covers. Hence ``w(S) = sum_P w_P(S_P) <= sum_P
    [opt_P + charge_P(S_P)]``, and the charges add up to ``sum_{t in S} sum_k s_tk <= sum_{t
    in S} pi_t = sum_j lam_j |S_j| + sum_K mu_K |S & K| <= sum_j lam_j c_j + sum_K mu_K``,
    since S keeps (6) (``|S_j| <= c_j``) and (3) (at most one task of a clique). So ``sum_P
    opt_P + sum_j lam_j c_j + sum_K mu_K >= w(S)`` for every partition and all nonnegative
    prices and shares (zero prices: the paper's bound); the LP's only make it tight. R* is the
    least of the two partitions' bounds (with and without prices), rounded down (the optimum
    is an integer) after a 1e-6 margin far above the float error.
The partition (dynamic programming)
    the targets are put in an order that keeps interacting targets close (reverse
    Cuthill-McKee on the graph linking two targets when tasks covering them are in (3)
    conflict or one task covers both: SPOT5's photographs come in track order, which has
    the same effect there), and the partition into consecutive intervals of at most
    ``max_part`` targets that minimises the sum of the parts' optima is found by dynamic
    programming over the cut points: ``B[j] = min over L of B[j - L] + opt(j - L, j)``.
    Interactions cut by a boundary are what the bound loses (without prices, all of them).
The parts' optima (exact search)
    each part is solved exactly by depth-first branch and bound over its targets (fewest
    tasks first): a target already covered needs no branch; otherwise each compatible task
    covering it that adds more weight than its charge, in turn, then "not covered"; the bound
    is the value so far plus the *upper values* of the undecided targets (``p_k`` minus the
    least share of a task covering k, at least 0: the most covering k can add); the search
    stops when the value reaches the part's upper values. A part whose search exceeds
    ``node_limit`` nodes, or is not reached before the time limit or a stop request
    (:mod:`sosp.stop`), counts its upper values (always a valid bound): the result stays an
    upper bound.
The schedule (method ``pba-stc``)
    with the LP: every task by decreasing LP value, then decreasing weight, inserted when it
    adds profit and keeps (3)-(6) (:func:`heuristics.hpfs.insertion_decode`): the LP's
    solution rounded and repaired. Without it: the tasks of the best partition's part
    optima, by decreasing weight, then every other task by decreasing weight (the parts'
    solutions recombined and repaired). Its profit is at most the static optimum, at most the
    bound.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from heuristics.hpfs import insertion_decode, priority_order, task_result
from heuristics.stc import at_least
from sosp.candidates import as_budget
from sosp.clustering import TaskSet, static_cluster_tasks
from sosp.conflicts import setup_conflict_rows
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.result import Result
from sosp.schedule import RollRule
from sosp.stop import Budget, stop_requested

log = logging.getLogger(__name__)

Order = Literal["rcm", "index"]
PriceRule = Literal["lp", "none"]


@dataclass(frozen=True)
class PBAParams(Params):
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
    prices
        ``"lp"``: the openings (6) and the (3) cliques of each orbit priced across the parts
        with the LP dual (:func:`lp_prices`); ``"none"``: every part has every orbit to
        itself (the paper's reading; for comparisons).
    """

    max_part: int = param(10, "Most targets in one part.")
    node_limit: int = param(20000, "Search nodes per part before its total weight.")
    order: Order = param("rcm", "Order of the targets: 'rcm' or 'index'.")
    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")
    prices: PriceRule = param("lp", "'lp': orbits priced across the parts; 'none'.")

    def check(self) -> None:
        at_least(self, max_part=1, node_limit=1)


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


def part_problem(instance: Instance, tasks: TaskSet, unit: bool = False) -> PartProblem:
    """The relaxed problem: (3) and (6) kept, (4)-(5) dropped (paper section 6.2). With
    ``unit``, every target weighs 1: its optimum counts targets (F* instead of R*)."""
    c = [int(x) for x in instance.max_openings]
    w = [1] * instance.n_targets if unit else [int(x) for x in instance.target_weight]
    usable = [
        t for t in range(len(tasks)) if (unit or tasks.weight[t] > 0) and c[int(tasks.orbit[t])] > 0
    ]
    idx = np.array(usable, dtype=np.int64)
    # the compiled rows, one frozenset per task, instead of a Python set.add per pair (the
    # same sets; na5000's 6,999 static tasks: 0.06 s against 0.10 s)
    indptr, indices = setup_conflict_rows(
        instance, tasks.orbit[idx], tasks.start[idx], tasks.end[idx], tasks.roll[idx]
    )
    others = idx[indices].tolist()
    bounds = indptr.tolist()
    conf = {t: frozenset(others[bounds[i] : bounds[i + 1]]) for i, t in enumerate(usable)}
    options: dict[int, list[int]] = {}
    for t in usable:
        for k in tasks.targets[t]:
            if w[k] > 0:
                options.setdefault(k, []).append(t)
    return PartProblem(
        tasks, {k: tuple(v) for k, v in options.items()}, conf, c, w, sorted(options)
    )


#: Foreseen seconds of the ``"rcm"`` order per unit of its products' work (per usable task
#: the square of its targets, per (3) pair the product of the two tasks' targets): the most
#: measured (2-core machine, five instances of 440-10,000 targets: 5-85 ns, 0.01-13.4 s).
RCM_S_PER_WORK = 85e-9

#: With a deadline, the ``"rcm"`` order is made only when foreseen within this share of the
#: time left; else the targets keep the instance's order (``"index"``).
RCM_SHARE = 0.25


def target_order(
    pp: PartProblem, order: Order = "rcm", budget: Budget | float | None = None
) -> list[int]:
    """The targets in the order the partition cuts (see the module docstring).

    ``"rcm"``: reverse Cuthill-McKee over the targets' graph, where a target of a usable
    task t is joined to every other target of t and of the tasks in (3) conflict with t,
    that is the pattern of ``A^T (D + C) A`` (A the tasks' incidence on the targets, C the
    conflicts, D the usable tasks), made by sparse products: the loop over every such pair
    made 28.6 million pairs in Python on a 2,500-target instance (3-7 s, twice per run,
    not interruptible: ``pba-stc --time-limit 5`` ran 7-8 s). The products read no clock
    either (a polar box of 10,000 targets: 13.4 s, and a 5 s run went to 14.5 s): with a
    time-limited ``budget``, an order foreseen past :data:`RCM_SHARE` of the time left
    (:data:`RCM_S_PER_WORK`) is ``"index"`` instead.
    """
    if order == "index" or len(pp.targets) < 3:
        return list(pp.targets)
    from scipy.sparse import csr_array, diags_array
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    n, n_tasks = len(pp.targets), len(pp.tasks.targets)
    pos = np.full(len(pp.weight), -1, dtype=np.int64)  # target -> its position, or -1
    pos[np.asarray(pp.targets, dtype=np.int64)] = np.arange(n)
    counts = np.fromiter((len(ks) for ks in pp.tasks.targets), dtype=np.int64, count=n_tasks)
    flat = np.fromiter(
        (k for ks in pp.tasks.targets for k in ks), dtype=np.int64, count=int(counts.sum())
    )
    row, col = np.repeat(np.arange(n_tasks), counts), pos[flat]
    on = col >= 0
    inc = csr_array((np.ones(int(on.sum())), (row[on], col[on])), shape=(n_tasks, n))
    keys = np.fromiter(pp.conflicts, dtype=np.int64, count=len(pp.conflicts))
    sizes = np.fromiter((len(pp.conflicts[t]) for t in keys), dtype=np.int64, count=len(keys))
    others = np.fromiter(
        (h for t in keys for h in pp.conflicts[t]), dtype=np.int64, count=int(sizes.sum())
    )
    budget = as_budget(budget)
    if budget.deadline is not None:
        work = float((counts[keys] ** 2).sum())
        work += float((counts[np.repeat(keys, sizes)] * counts[others]).sum())
        if not budget.share(RCM_SHARE).fits(RCM_S_PER_WORK * work):
            log.info("pba: targets in index order (rcm foreseen at %.1f s)", RCM_S_PER_WORK * work)
            return list(pp.targets)
    usable = np.zeros(n_tasks)
    usable[keys] = 1.0
    reach = diags_array(usable) + csr_array(
        (np.ones(len(others)), (np.repeat(keys, sizes), others)), shape=(n_tasks, n_tasks)
    )
    m = inc.T @ (reach @ inc)
    m = (m + m.T).tocsr()
    m.setdiag(0)
    m.eliminate_zeros()
    perm = reverse_cuthill_mckee(m, symmetric_mode=True)
    return [pp.targets[int(i)] for i in perm]


@dataclass
class Prices:
    """Prices that couple the parts: each task's price split into shares among its targets.

    Attributes
    ----------
    share
        Per usable task, per positive-weight target it covers, the share ``s_tk >= 0`` of the
        task's price charged to a part holding that target. The shares of a task add up to at
        most ``pi_t = lam_j(t) + sum of mu_K over the cliques K holding t``.
    constant
        ``sum_j lam_j c_j + sum_K mu_K``: what the priced constraints allow.
    upper
        Per target, ``max(0, p_k - least share of a task covering k)``: no part's priced
        optimum gains more from covering k (the bound of the search, the singleton parts).
    lp_value
        The LP bound the prices come from (None: no LP, zero prices).
    lp_x
        Per usable task, its value in the LP's optimum (empty without an LP): the schedule's
        repair takes the tasks the LP takes first.
    """

    share: dict[int, dict[int, float]]
    constant: float
    upper: dict[int, float]
    lp_value: float | None = None
    lp_x: dict[int, float] = field(default_factory=dict)

    def charge(self, t: int, part_targets: tuple[int, ...]) -> float:
        """What choosing task ``t`` costs a part holding ``part_targets`` of its targets."""
        s = self.share.get(t)
        return 0.0 if s is None else sum(s[x] for x in part_targets)


def zero_prices(pp: PartProblem) -> Prices:
    """No coupling: the paper's parts, each with every orbit to itself."""
    return Prices({}, 0.0, {k: float(pp.weight[k]) for k in pp.targets})


def orbit_cliques(instance: Instance, pp: PartProblem) -> tuple[list[int], list[list[int]]]:
    """Per orbit with more usable tasks than openings, its tasks; and every maximal clique of
    the (3) conflicts of an orbit (:func:`models.cliques.maximal_cliques`), as task lists."""
    from models.cliques import maximal_cliques, orbit_intervals

    tk = pp.tasks
    by_orbit: dict[int, list[int]] = {}
    for t in sorted(pp.conflicts):
        by_orbit.setdefault(int(tk.orbit[t]), []).append(t)
    capped: list[int] = []
    cliques: list[list[int]] = []
    for j, ts in sorted(by_orbit.items()):
        if len(ts) > pp.openings[j]:
            capped.append(j)
        idx = np.array(ts, dtype=np.int64)
        left, right = orbit_intervals(
            tk.start[idx],
            tk.end[idx],
            tk.roll[idx],
            float(instance.setup_time[j]),
            float(instance.slew_rate[j]),
        )
        cliques.extend([ts[int(i)] for i in c] for c in maximal_cliques(left, right))
    return capped, cliques


def lp_prices(instance: Instance, pp: PartProblem, time_limit: float | None = None) -> Prices:
    """Prices from the dual of the LP relaxation of the relaxed static problem.

    The LP: ``max sum_k p_k z_k`` s.t. ``z_k <= sum of x_t over the tasks covering k`` (dual
    ``y_k``), per orbit ``sum x_t <= c_j`` (6) (dual ``lam_j``), per maximal clique K of the
    (3) conflicts of an orbit ``sum_{t in K} x_t <= 1`` (dual ``mu_K``), ``0 <= x, z <= 1``.
    Task t's price is ``pi_t = lam_j + sum_{K ni t} mu_K``; its shares are the ``y_k`` of its
    targets, scaled down if they add up to more than ``pi_t`` and otherwise topped up to
    ``pi_t`` in proportion to the targets' weights (a larger share only lowers the parts'
    optima). Any nonnegative prices give a valid bound (module docstring); the LP's make the
    sum over single-target parts at most the LP bound. When the LP is not solved (time limit),
    the prices are zero (the paper's bound).
    """
    from scipy.sparse import coo_matrix

    tk = pp.tasks
    usable = sorted(pp.conflicts)
    col = {t: i for i, t in enumerate(usable)}
    nt, nk = len(usable), len(pp.targets)
    if nk == 0:
        return zero_prices(pp)
    krow = {k: i for i, k in enumerate(pp.targets)}
    entries: list[tuple[int, int, float]] = []  # (row, column, value) of the constraints
    for r, k in enumerate(pp.targets):
        entries.append((r, nt + r, 1.0))
        entries += [(r, col[t], -1.0) for t in pp.options[k]]
    capped, cliques = orbit_cliques(instance, pp)
    orbit_row = {j: nk + i for i, j in enumerate(capped)}
    rhs = [0.0] * nk + [float(pp.openings[j]) for j in capped]
    task_row = {t: orbit_row.get(int(tk.orbit[t])) for t in usable}  # its orbit's (6) row
    entries += [(r, col[t], 1.0) for t, r in task_row.items() if r is not None]
    first_clique = len(rhs)
    entries += [(first_clique + q, col[t], 1.0) for q, ts in enumerate(cliques) for t in ts]
    rhs += [1.0] * len(cliques)
    rows, cols, vals = zip(*entries, strict=True)
    a = coo_matrix((vals, (rows, cols)), shape=(len(rhs), nt + nk)).tocsr()
    cost = np.zeros(nt + nk)
    cost[nt:] = [-float(pp.weight[k]) for k in pp.targets]
    solved = _solve_lp(cost, a, np.asarray(rhs, dtype=float), time_limit)
    if solved is None:
        log.warning("pba: LP not solved (time limit or stop); parts without prices")
        return zero_prices(pp)
    fun, x, marginals = solved
    # HiGHS's marginals of a minimisation's <= rows are <= 0; any nonnegative value is valid.
    dual = np.maximum(-marginals, 0.0)
    pi = {t: 0.0 if r is None else float(dual[r]) for t, r in task_row.items()}
    for q, members in enumerate(cliques):
        mu = float(dual[first_clique + q])
        if mu > 0.0:
            for t in members:
                pi[t] += mu
    constant = float(sum(dual[r] * pp.openings[j] for j, r in orbit_row.items()))
    constant += float(dual[first_clique:].sum())
    w = pp.weight
    share: dict[int, dict[int, float]] = {}
    for t in usable:
        ks = [k for k in tk.targets[t] if w[k] > 0]
        y = [float(dual[krow[k]]) for k in ks]
        sy = sum(y)
        if sy >= pi[t]:
            f = pi[t] / sy if sy > 0.0 else 0.0
            share[t] = {k: yk * f for k, yk in zip(ks, y, strict=True)}
        else:
            wt = float(sum(w[k] for k in ks))
            extra = pi[t] - sy
            share[t] = {k: yk + extra * w[k] / wt for k, yk in zip(ks, y, strict=True)}
    upper = {k: max(0.0, w[k] - min(share[t][k] for t in pp.options[k])) for k in pp.targets}
    log.info("pba: LP bound %.3f, %d capped orbits, %d cliques", -fun, len(capped), len(cliques))
    lp_x = {t: float(x[col[t]]) for t in usable}
    return Prices(share, constant, upper, float(-fun), lp_x)


class _Budget(Exception):
    pass


def _solve_lp(
    cost: np.ndarray, a: Any, rhs: np.ndarray, time_limit: float | None
) -> tuple[float, np.ndarray, np.ndarray] | None:
    """``min cost x`` s.t. ``a x <= rhs``, ``0 <= x <= 1`` by HiGHS: (objective, x, the
    rows' duals), or None unless solved to optimality.

    highspy rather than :func:`scipy.optimize.linprog`, whose HiGHS holds the GIL and takes
    no callback: on 10,000 targets its LP ran a minute after a Ctrl-C. Here a stop request
    (:func:`sosp.stop.request_stop`, also from the CLI's signal thread) interrupts it.
    """
    import highspy

    from models.highs_direct import new_highs  # no banner on the standard output

    h = new_highs()
    h.setOptionValue("output_flag", False)
    if time_limit is not None:
        h.setOptionValue("time_limit", max(float(time_limit), 0.01))
    a = a.tocsr()
    m, n = a.shape
    h.passModel(
        n, m, a.nnz, int(highspy.MatrixFormat.kRowwise), int(highspy.ObjSense.kMinimize), 0.0,
        np.asarray(cost, dtype=float), np.zeros(n), np.ones(n), np.full(m, -highspy.kHighsInf),
        rhs, a.indptr.astype(np.int32), a.indices.astype(np.int32), a.data.astype(float),
        np.zeros(n, dtype=np.int32),
    )  # fmt: skip

    def interrupt(event: Any) -> None:
        if stop_requested():
            event.interrupt()

    h.cbSimplexInterrupt += interrupt
    h.cbIpmInterrupt += interrupt
    if stop_requested():
        return None
    h.run()
    if h.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return None
    sol = h.getSolution()
    x = np.asarray(sol.col_value, dtype=float)
    return float(cost @ x), x, np.asarray(sol.row_dual, dtype=float)


def part_optimum(
    pp: PartProblem,
    part: list[int],
    node_limit: int = 20000,
    prices: Prices | None = None,
) -> tuple[float, list[int], bool]:
    """Priced optimum of one part: covered weight minus the chosen tasks' shares, (3) and (6).

    Parameters
    ----------
    pp
        The relaxed problem.
    part
        The part's targets.
    node_limit
        Search nodes before giving up.
    prices
        The shares (None: zero prices, the part's plain optimum).

    Returns
    -------
    tuple
        ``(value, tasks, exact)``: the optimum and tasks reaching it; when the search exceeds
        ``node_limit`` nodes, ``(sum of the part's upper values, [], False)`` (a valid bound).
    """
    if prices is None:
        prices = zero_prices(pp)
    w = pp.weight
    up = prices.upper
    order = sorted(part, key=lambda k: (len(pp.options[k]), -w[k], k))
    total = sum(up[k] for k in order)
    inpart = set(order)
    mine: dict[int, tuple[int, ...]] = {}
    charge: dict[int, float] = {}
    for k in order:
        for t in pp.options[k]:
            if t not in mine:
                mine[t] = tuple(x for x in pp.tasks.targets[t] if x in inpart)
                charge[t] = prices.charge(t, mine[t])
    best_val = -1.0
    best_set: list[int] = []
    chosen: list[int] = []
    count: dict[int, int] = {}
    covered: dict[int, int] = {}
    orbit = pp.tasks.orbit
    nodes = 0

    def rest(q: int) -> float:
        return sum(up[k] for k in order[q:] if not covered.get(k))

    def dfs(q: int, value: float) -> bool:
        nonlocal best_val, best_set, nodes
        nodes += 1
        if nodes > node_limit:
            raise _Budget
        while q < len(order) and covered.get(order[q]):
            q += 1
        if q == len(order) or value + rest(q) <= best_val:
            if value > best_val:
                best_val, best_set = value, list(chosen)
            return best_val >= total
        k = order[q]
        for t in pp.options[k]:
            j = int(orbit[t])
            if count.get(j, 0) >= pp.openings[j] or any(h in pp.conflicts[t] for h in chosen):
                continue
            gain = sum(w[x] for x in mine[t] if not covered.get(x)) - charge[t]
            if gain <= 0.0:
                # Some optimum with fewest tasks never takes a task that adds nothing when
                # its turn comes: dropping it loses at most this gain.
                continue
            for x in mine[t]:
                covered[x] = covered.get(x, 0) + 1
            chosen.append(t)
            count[j] = count.get(j, 0) + 1
            done = dfs(q + 1, value + gain)
            chosen.pop()
            count[j] -= 1
            for x in mine[t]:
                covered[x] -= 1
            if done:
                return True
        # Target k not covered.
        if value + rest(q + 1) > best_val:
            return dfs(q + 1, value)
        return False

    try:
        dfs(0, 0.0)
    except _Budget:
        return total, [], False
    return best_val, best_set, True


def partition_dp(
    pp: PartProblem,
    order: list[int],
    params: PBAParams,
    prices: Prices,
    deadline: Budget | float | None = None,
) -> dict[str, Any]:
    """The partition of ``order`` into intervals minimising the sum of the parts' optima.

    ``B[j] = min over L <= max_part of B[j - L] + opt(j - L, j)`` (module docstring); parts
    not reached before the budget ``deadline`` expires (or a stop request) count their upper
    values.

    Returns
    -------
    dict
        ``value`` (the least sum, without the prices' constant), ``parts``, ``part_tasks``,
        ``targets`` (the targets the parts' optima cover), ``inexact_parts``,
        ``subproblems``, ``stopped``.
    """
    n = len(order)
    lmax = params.max_part
    inf = float("inf")
    best = [0.0] + [inf] * n
    arg = [0] * (n + 1)
    memo: dict[tuple[int, int], tuple[float, list[int], bool]] = {}
    solved = 0
    stopped, budget = False, as_budget(deadline)
    for j in range(1, n + 1):
        for length in range(1, min(lmax, j) + 1):
            i = j - length
            part = order[i:j]
            if stopped or budget.expired():
                stopped = True
                res = (sum(prices.upper[k] for k in part), [], False)
            else:
                res = part_optimum(pp, part, params.node_limit, prices)
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
        covered = {k for t in chosen for k in pp.tasks.targets[t]} & set(order[i:j])
        targets += len(covered) if exact else j - i
        j = i
    parts.reverse()
    part_tasks.reverse()
    return {
        "value": best[n],
        "parts": parts,
        "part_tasks": part_tasks,
        "targets": targets,
        "inexact_parts": inexact,
        "subproblems": solved,
        "stopped": stopped,
    }


def pba_partition(
    instance: Instance,
    params: PBAParams,
    budget: Budget | float | None = None,
    tasks: TaskSet | None = None,
    unit: bool = False,
) -> dict[str, Any]:
    """The partition-based bound: the best partition by dynamic programming, and its parts.

    With ``params.prices == "lp"`` the partition is computed twice, with the LP's prices
    (:func:`lp_prices`) and, if time is left, without prices (the paper's reading), and R* is
    the lesser of the two bounds (both valid, module docstring); the parts returned are those
    of the lesser. A stop request or a ``budget`` already spent skips the LP. With ``unit``
    every target weighs 1, so the bound is one on the number of targets a static schedule
    observes (the paper's F*).

    Returns
    -------
    dict
        ``bound`` (R*), and :func:`partition_dp`'s figures of the lesser partition:
        ``targets`` (the targets covered by the parts' optima), ``parts`` (lists of target
        indices), ``part_tasks`` (the tasks of each part's optimum), ``inexact_parts`` (parts
        that fell back to their upper values), ``value``, ``stopped``; ``subproblems`` (of
        both partitions), ``unpriced_bound`` (the bound without prices; None if not
        computed), ``lp_bound`` (the LP bound the prices come from, or None), ``lp_x`` (the
        LP's task values, empty without an LP), ``tasks``.
    """
    if tasks is None:
        tasks = static_cluster_tasks(instance, roll_rule=params.roll_rule)
    pp = part_problem(instance, tasks, unit)
    budget = as_budget(budget)
    order = target_order(pp, params.order, budget)
    coverable = sum(pp.weight[k] for k in pp.targets)
    prices = zero_prices(pp)
    if params.prices == "lp" and not budget.expired():
        # The LP first: if time runs out in the partition, the parts not reached count their
        # upper values, and with the LP's prices these still add up to the LP bound.
        prices = lp_prices(instance, pp, budget.left())
    out = partition_dp(pp, order, params, prices, budget)
    solved = out["subproblems"]
    # The optimum is an integer: round down, with a margin far above the float error of these
    # sums (about 1e-12 here), and never above the weight some task covers.
    bound = min(int(math.floor(out["value"] + prices.constant + 1e-6)), coverable)
    unpriced: int | None = bound if prices.lp_value is None else None
    if prices.lp_value is not None and not out["stopped"]:
        plain = partition_dp(pp, order, params, zero_prices(pp), budget)
        solved += plain["subproblems"]
        unpriced = min(int(math.floor(plain["value"] + 1e-6)), coverable)
        if unpriced < bound:
            bound, out = unpriced, plain
    log.info("pba: bound %d (without prices %s, LP %s)", bound, unpriced, prices.lp_value)
    return {
        **out,
        "bound": bound,
        "subproblems": solved,
        "tasks": tasks,
        "unpriced_bound": unpriced,
        "lp_bound": prices.lp_value,
        "lp_x": prices.lp_x,
    }


def count_bound(
    instance: Instance, params: PBAParams, tasks: TaskSet, deadline: Budget | float | None = None
) -> int:
    """F*: PBA-STC's upper bound on the number of targets a static schedule observes, the
    bound of :func:`pba_partition` with every weight 1 (the same argument as R*'s: it holds
    for any non-negative weights). Parts not reached in the budget ``deadline`` count all
    their targets, so it stays a bound: once it is spent that is every target a usable task
    covers, counted here without the partition's set-up (its conflicts and order, seconds
    on thousands of targets)."""
    if as_budget(deadline).expired():
        opens = np.asarray(instance.max_openings) > 0
        return len({int(k) for t in np.flatnonzero(opens[tasks.orbit]) for k in tasks.targets[t]})
    return int(pba_partition(instance, params, deadline, tasks, unit=True)["bound"])


def pba_bound(
    instance: Instance, *, time_limit: float | None = None, **params: Any
) -> dict[str, Any]:
    """``sosp bound --method pba``: PBA-STC's upper bound R* on the static problem, with the
    fields of :class:`PBAParams` as ``params``.

    Returns
    -------
    dict
        ``bound``, ``model`` (``"static"``), ``method`` (``"pba"``), ``targets`` (F*,
        :func:`count_bound`), ``parts``, ``inexact_parts``, ``subproblems`` and
        ``runtime_s``.
    """
    t0 = time.perf_counter()
    params = from_kwargs(PBAParams, params, method="pba")
    budget = Budget.of(time_limit)
    out = pba_partition(instance, params, budget)
    return {
        "bound": out["bound"],
        "model": "static",
        "method": "pba",
        "targets": count_bound(instance, params, out["tasks"], budget),
        "parts": len(out["parts"]),
        **{k: out[k] for k in ("inexact_parts", "subproblems", "unpriced_bound", "lp_bound")},
        "runtime_s": time.perf_counter() - t0,
    }


def solve_pba_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """PBA-STC as a method: the bound R* and a schedule repaired from the bound's solutions.

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused (the method is deterministic); accepted for the common signature.
    time_limit
        Seconds for the bound (parts not reached get their upper values).
    **params
        Fields of :class:`PBAParams`.

    Returns
    -------
    Result
        Status ``feasible``, ``bound`` = R*; ``stats`` holds F* (``bound_targets``,
        :func:`count_bound`), the
        number of parts and of inexact parts, the LP bound and the bound without prices.
    """
    del rng
    params = from_kwargs(PBAParams, params, method="pba-stc")
    budget = Budget.of(time_limit)
    out = pba_partition(instance, params, budget)
    tasks: TaskSet = out["tasks"]
    lines: dict = {}
    covered = np.zeros(instance.n_targets, dtype=bool)
    x: dict[int, float] = out["lp_x"]
    if x:
        # The LP's solution rounded: tasks by decreasing LP value (to 1e-6, so that solver
        # noise does not reorder ties), then by decreasing weight. Better than the parts'
        # solutions first on 19 of the 20 B and C scenarios, equal on B1 (docs/baselines.md).
        first = sorted(
            range(len(tasks)), key=lambda t: (-round(x.get(t, 0.0), 6), -tasks.weight[t], t)
        )
        chosen, profit = insertion_decode(instance, tasks, first, lines, covered)
    else:
        first = sorted({t for ts in out["part_tasks"] for t in ts}, key=lambda t: -tasks.weight[t])
        chosen, profit = insertion_decode(instance, tasks, first, lines, covered)
        more, extra = insertion_decode(instance, tasks, priority_order(tasks), lines, covered)
        chosen += more
        profit += extra
    stats = {
        "bound_targets": count_bound(instance, params, tasks, budget),
        "parts": len(out["parts"]),
        **{k: out[k] for k in ("inexact_parts", "subproblems", "lp_bound", "unpriced_bound")},
    }
    log.info("pba-stc: bound %d, schedule %d", out["bound"], profit)
    bound = float(out["bound"])
    return task_result("pba-stc", instance, tasks, chosen, profit, bound=bound, stats=stats)
