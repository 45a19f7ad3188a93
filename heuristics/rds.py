"""Russian Doll Search (RDS): the paper's exact baseline (RDS and RDS-STC, section 6.2).

Russian Doll Search (Verfaillie, Lemaitre and Schiex, AAAI-96; used on SPOT5 by Bensana et al.,
1999) is a depth-first branch and bound over 0/1 variables x_1..x_n (here: "item i is
scheduled") that solves n nested subproblems in turn: P_n on the last variable, then P_{n-1}
on the last two, ..., P_1 on all of them. The optimum ``opt[i]`` of P_i is kept, and while
solving P_i the bound at a node that has decided x_i..x_{d-1} is

    value so far + opt[d],

since what the undecided variables x_d..x_n can add is at most the optimum of P_d. Two classic
RDS refinements are used: a solution of P_i better than ``opt[i+1]`` must schedule item i, so
P_i only searches the branch x_i = 1 (its incumbent starts at ``opt[i+1]``); and the search of
P_i stops as soon as it reaches ``weight_i + opt[i+1]``, an upper bound of P_i.

Items
    ``rds``: single opportunities at their own roll (:func:`sosp.clustering.single_tasks`);
    ``rds-stc``: static cluster-tasks (:func:`sosp.clustering.static_cluster_tasks`), the
    paper's RDS-STC.
Variables (``variables``)
    ``"targets"`` (default, :func:`rds_targets_component`): one variable per target, valued by
    a task covering it or "none", the SPOT5 formulation; ``"tasks"``
    (:func:`rds_component`): one 0/1 variable per task. The rest of this note is about the
    default; ``"tasks"`` is the plain RDS above.
Objective (1) with coverage semantics
    the value of scheduling an item is the weight of its targets not yet covered. For single
    opportunities this is exactly (2): an opportunity of a covered target is worth 0 and is
    never scheduled (scheduling it would break (2)); for cluster-tasks a target shared by tasks
    on several orbits counts once (``docs/model.md``).
Why the RDS bounds stay valid under coverage
    the value that items d..n can add given the covered set C is ``w(targets(S) minus C)`` for
    the chosen set S, at most ``w(targets(S))``, the value of S in P_d alone; and S is
    feasible in P_d because removing observations never breaks (3)-(6) (``docs/model.md``).
    So the best completion is at most ``opt[d]`` (coverage is submodular).
Constraints
    (3)-(6) and (11) are checked incrementally with one
    :class:`heuristics.timeline.OrbitTimeline` per orbit (insert on the way down, remove on
    backtrack), including the consecutive slew term of (4).
Nesting order (``order``)
    the order of the variables, which fixes the nested subproblems: ``"orbit"`` (default) by
    orbit, then start time (for targets: of their earliest task), so subproblems are local;
    ``"weight"``: decreasing weight (ties by orbit and time).
Open tasks and coverable targets (targets search)
    at a node, a task is *open* unless it is excluded below the node: banned by an earlier
    branch (below), in (3) conflict with a scheduled task (:func:`pairwise_conflicts`: such
    a pair is never in one schedule), or, on an orbit whose resources can bind, rejected by
    the orbit's timeline (a set that breaks (4)-(6) keeps breaking them when observations are
    added, since removing observations never breaks them and the slew sum of a sequence
    only grows with insertions, by the triangle inequality). A target is *coverable* while
    some open task covers it (a scheduled task is open). Every selection in the node's
    subtree keeps the scheduled tasks and adds open tasks only, so it covers coverable
    targets only.
The bound of a node of P_i (targets search)
    ``min over r in (i, n] of  w(coverable targets among i..r-1) + opt[r]``: for any
    selection F of the subtree, the targets i..r-1 it covers are coverable, and the targets
    r..n it covers are the value in P_r of F's tasks that cover them, a feasible selection of
    P_r, so at most ``opt[r]`` (``opt[n] = 0``). With the targets before r decided, this is
    the classic RDS bound "value so far + opt[r]"; r = n gives the sum of the coverable
    weights. The term only decreases from r to r + 1 when target r is not coverable (as
    ``opt[r] - opt[r+1] <= w_r``), so it is evaluated at r = i + 1, r = n and just after
    each target that is not coverable.
Search of P_i (targets search)
    the branch "target i covered" only (a better solution than ``opt[i+1]`` needs it), then
    repeatedly a target to branch on: each open task covering it in turn, the tasks already
    tried being banned in the later branches (their solutions were searched), and last
    "none", with all its tasks banned. Two branching orders are used: *static*, the first
    uncovered coverable target in the nesting order (classic RDS); and *fail first*, the one
    with the fewest open tasks. Each is exponentially slower than the other on some
    instances (static on dense regions such as C1, fail first where resources bind, such as
    B2 without clustering), so runs alternate between them with a doubling node budget
    (restarts; the order that finished the last long run gets the full budget, the other a
    quarter) until one finishes: exact either way, at most a constant factor slower than the
    better order.
Repair (targets search)
    before searching P_i, the last optimum (of P_{i+1}) is repaired: a task of target i put
    in, the tasks in (3) conflict with it taken out and their lost targets covered again by
    insertion (fewest options first). If that reaches ``w_i + opt[i+1]``, an upper bound of
    P_i, it is P_i's optimum and no search is needed.
Descending target (targets search)
    P_i is first searched for a selection worth more than ``upper - 1`` with ``upper = w_i +
    opt[i+1]`` (a pruning bound at its strongest); a pass that finds none proves ``opt[i] <=
    upper - 1``, which becomes ``upper``, and the next pass asks for more than ``upper - 2``,
    then ``- 4``, ..., down to ``opt[i+1]``. A pass that finds a selection searches on with it
    as incumbent, so it ends with the optimum. Most subproblems are solved by the first pass
    in a few nodes.
Fixed tasks (``reduce``)
    before the search, tasks that some optimal selection contains are fixed and their
    targets count as covered (:func:`fix_free_tasks`: conflict-free tasks on orbits whose
    resources cannot bind); tasks left with covered targets only are dropped.
Decomposition
    items interact only through (3) (same orbit, close in time), the per-orbit knapsacks
    (4)-(6) (same orbit) and shared targets. The connected components of that "interaction"
    graph are independent problems whose optima add up, and each is solved by its own RDS.
    The edges are those of :func:`sosp.conflicts.conflict_graph` (setup and target edges),
    plus, on an orbit whose resources can bind (:func:`orbit_resources_can_bind`), a chain
    linking all its items. Branch and bound is exponential in the component size, so
    splitting one problem of n items into k parts of n/k items is a very large gain.
Time limit
    on timeout the incumbent of each unfinished component is the better of its RDS incumbent
    and a highest-weight-first insertion (:func:`heuristics.hpfs.insertion_decode`); the
    status is ``time_limit`` and ``bound`` a proven upper bound (solved components give
    their optimum, an interrupted one ``sum of weights before i + upper`` with ``upper`` the
    proven bound of the interrupted P_i, an unstarted one the weight of its targets). When
    every component finishes, the status is ``optimal`` and ``bound`` equals the profit.
"""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from heuristics.hpfs import insertion_decode, task_result
from heuristics.timeline import OrbitTimeline, fits_alone, task_entries
from sosp import rules
from sosp.clustering import TaskSet, single_tasks, static_cluster_tasks
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.progress import current as current_progress
from sosp.result import Result, Status
from sosp.rules import EPS, orbit_rules
from sosp.schedule import RollRule
from sosp.stop import Budget

log = logging.getLogger(__name__)

Order = Literal["orbit", "weight"]
Variables = Literal["targets", "tasks"]

#: The budget of a call without a time limit.
UNLIMITED = Budget()

#: Node budget of the first run of a search pass (then doubled, see ``search_pass``).
_FIRST_BUDGET = 1000

#: Nodes between two clock reads: a node of the targets search can cost ~50 us (an insertion
#: check), so 2048 nodes overran a 4 s limit by more than a second on C5.
_CLOCK_EVERY = 64


class _Timeout(Exception):
    """Raised when the budget is spent or a stop is requested: inside the search, or while
    a component's search is being prepared (:func:`pairwise_conflicts`)."""


def _halt(budget: Budget, nodes: int) -> bool:
    """The search's periodic check: report ``nodes`` to the solve's progress; True when the
    budget is spent or a stop was requested (:func:`sosp.stop.request_stop`)."""
    current_progress().update(nodes, None)
    return budget.expired()


class _Budget(Exception):
    """Raised inside a search run when its node budget is spent (it is then restarted)."""


class _Done(Exception):
    """Raised inside a subproblem's search when its upper bound is reached."""


@dataclass
class ComponentOutcome:
    """What the search found on one independent component.

    Attributes
    ----------
    items
        The component's task indices in search order.
    chosen
        The best selection found (task indices).
    value
        Its value (objective (1) restricted to the component).
    proven
        True when ``value`` is the component's optimum.
    bound
        An upper bound on the component's optimum.
    nodes
        Search nodes visited.
    """

    items: list[int]
    chosen: list[int]
    value: int
    proven: bool
    bound: int
    nodes: int = 0


@dataclass
class RdsOutcome:
    """Result of :func:`russian_doll` over all components."""

    chosen: list[int]
    value: int
    proven: bool
    bound: int
    components: list[ComponentOutcome] = field(default_factory=list)


# ----------------------------------------------------------------------------- structure
def orbit_resources_can_bind(instance: Instance, tasks: TaskSet, idx: np.ndarray) -> bool:
    """Can (4), (5) or (6) cut a (3)-feasible subset of these tasks of one orbit?

    False only when provably not. Item u occupies the interval ``[ts_u - |theta_u|/v, te_u + a
    + |theta_u|/v)`` and (3) between consecutive observations u, v says exactly that u's
    interval ends before v's starts, so the (3)-feasible sets are the chains of pairwise
    disjoint intervals (an interval graph). Over those chains a dynamic program by interval
    end (weighted interval scheduling) gives the largest number of members, the largest
    observing time and the largest ``eo dur + es 2|theta|/v`` (every slew of a sequence
    bounded by ``(|theta_u| + |theta_v|)/v``, summed as ``2 sum |theta| / v``). The orbit
    cannot bind when these fit c (6), W (5) and E (4). Intervals compare with a tolerance
    that can only admit more chains, and intervals shorter than that tolerance make the
    answer True, which keeps it conservative.
    """
    if idx.size == 0:
        return False
    j = int(tasks.orbit[idx[0]])
    dur = tasks.end[idx] - tasks.start[idx]
    absr = np.abs(tasks.roll[idx])
    r = orbit_rules(instance, j)
    lo = r.left(tasks.start[idx], absr)
    hi = r.right(tasks.end[idx], absr)
    tol = 4 * EPS
    if np.any(hi - lo <= tol):
        return True
    energy = r.energy(dur, rules.slew_upper(absr, r.slew_rate))
    order = np.argsort(hi, kind="stable")
    lo, hi, dur, energy = lo[order], hi[order], dur[order], energy[order]
    # prev[k]: how many intervals (in end order) end before interval k starts.
    prev = np.minimum(np.searchsorted(hi, lo + tol, side="right"), np.arange(idx.size))
    # best[k]: the most members, observing time and energy of a chain of the first k
    gain = np.stack([np.ones(idx.size), dur, energy], axis=1)
    best = np.zeros((idx.size + 1, 3))
    for k in range(idx.size):
        best[k + 1] = np.maximum(best[k], best[prev[k]] + gain[k])
    card, obs, eng = best[-1].tolist()
    if card > r.max_openings:
        return True
    # conservative: a total within EPS below a capacity counts as binding
    return r.memory(obs) > r.memory_capacity - EPS or eng > r.energy_capacity - EPS


def interaction_components(
    instance: Instance, tasks: TaskSet, usable: np.ndarray
) -> list[list[int]]:
    """Independent groups of tasks (connected components of the interaction graph).

    Parameters
    ----------
    instance
        The problem.
    tasks
        All tasks.
    usable
        Indices of the tasks that may be scheduled at all.

    Returns
    -------
    list of list of int
        Components as lists of task indices, smallest first.

    Notes
    -----
    The graph's edges are those of :func:`sosp.conflicts.conflict_graph` (setup conflicts,
    shared targets) plus a path over each orbit whose resources can bind; only its
    connectivity is used, so the tasks sharing a target are linked by a path instead of all
    their pairs, and the components are found by ``scipy.sparse.csgraph``: those of the
    setup conflicts over their compiled rows (:func:`sosp.conflicts.setup_conflict_rows`),
    then those that the other edges join. The networkx graph of all pairs took 27 s on a
    5,000-target instance of 24 satellites (12.6 million setup pairs), under the time limit's
    clock; the sorted pairs and one scipy graph of all edges, 4.8 s; this, about 1 s.
    """
    from scipy.sparse import coo_array, csr_array
    from scipy.sparse.csgraph import connected_components

    from sosp.conflicts import setup_conflict_rows

    idx = np.asarray(usable, dtype=np.int64)
    if len(idx) == 0:
        return []
    orbit = tasks.orbit[idx]
    # the setup conflicts as the compiled sweep's rows (12.6 million pairs: 0.3 s, where the
    # sorted pairs took 3.6 s)
    indptr, indices = setup_conflict_rows(
        instance, orbit, tasks.start[idx], tasks.end[idx], tasks.roll[idx]
    )
    setup = csr_array((np.ones(len(indices)), indices, indptr), shape=(len(idx), len(idx)))
    # the rows are symmetric, so the strong components are the components; scipy finds them
    # without the transpose that ``directed=False`` makes (1.8 s against 0.16 s)
    n_setup, setup_label = connected_components(setup, directed=True, connection="strong")
    edges = [np.empty((0, 2), dtype=np.int64)]
    # tasks sharing a target: one path per target, over the tasks covering it
    n_of = np.fromiter((len(tasks.targets[t]) for t in idx), dtype=np.int64, count=len(idx))
    if n_of.sum():
        target = np.fromiter(
            (k for t in idx for k in tasks.targets[t]), dtype=np.int64, count=int(n_of.sum())
        )
        holder = np.repeat(np.arange(len(idx)), n_of)
        order = np.lexsort((holder, target))
        target, holder = target[order], holder[order]
        same = target[1:] == target[:-1]
        edges.append(np.stack([holder[:-1][same], holder[1:][same]], axis=1))
    for j in np.unique(orbit):
        on = np.flatnonzero(orbit == j)
        if orbit_resources_can_bind(instance, tasks, idx[on]):
            edges.append(np.stack([on[:-1], on[1:]], axis=1))
    # the other edges join the setup components: components of the graph over them
    e = setup_label[np.concatenate([a.reshape(-1, 2) for a in edges]).astype(np.int64)]
    joined = coo_array((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n_setup, n_setup))
    _, label = connected_components(joined, directed=False)
    label = label[setup_label]
    members = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.diff(label[members])) + 1
    comps = [sorted(idx[part].tolist()) for part in np.split(members, cuts)]
    comps.sort(key=lambda c: (len(c), c[0]))
    return comps


#: Pairs between two readings of the clock in the loops over (3) conflict pairs.
PAIRS_PER_CHECK = 1 << 18

#: Most (3) pairs the search's conflict lists hold (Python lists, about 80 bytes a pair): as
#: ASA-DTC's :data:`heuristics.asa.problem.MAX_CONFLICTS`. Beyond it the search is not
#: run and the answer is the fall-back decode (a polar box of 10,000 targets has 167
#: million pairs).
MAX_PAIRS = 25_000_000


def pairwise_conflicts(
    instance: Instance,
    tasks: TaskSet,
    items: list[int],
    budget: Budget = UNLIMITED,
) -> list[list[int]]:
    """For each item (by position in ``items``), the positions of the items it excludes by (3).

    Once ``budget`` is spent (read before the adjacency and every :data:`PAIRS_PER_CHECK` of
    its entries: a dense instance has millions) it raises :class:`_Timeout`.

    Two tasks u, v of one orbit with ``ts_u <= ts_v`` and ``te_u + a + (|theta_u| +
    |theta_v|)/v > ts_v + EPS`` (:func:`sosp.conflicts.setup_conflict_pairs`) are never both
    in a schedule that :class:`heuristics.timeline.OrbitTimeline` accepts: next to each other
    they break (3) directly, and with w_1..w_r between them the r + 1 consecutive (3)
    inequalities add up to ``te_u + a + (|theta_u| + |theta_v|)/v <= ts_v + (r + 1) EPS -
    sum_i (te_w - ts_w + a + 2|theta_w|/v)``, which contradicts the conflict as soon as every
    ``te_w - ts_w + a >= EPS``. Orbits where some item is shorter than that (never in real
    data) get no pairs, which only weakens the bounds that use them.
    """
    if len(items) < 2:
        return [[] for _ in items]
    from sosp.conflicts import TooManyConflicts, setup_conflict_rows

    # the sweep reads no clock: foreseen past the deadline it is not started (a polar box of
    # 10,000 targets, 167 million pairs: 5.7 s, and a 5 s run went to 7.1 s)
    foreseen = 0.0 if budget.deadline is None else _prep_seconds(instance, tasks, items)
    if not budget.fits(foreseen):
        raise _Timeout
    idx = np.asarray(items, dtype=np.int64)
    orbit = tasks.orbit[idx]
    start, end, roll = tasks.start[idx], tasks.end[idx], tasks.roll[idx]
    foot = end - start + instance.setup_time[orbit]
    thin = np.unique(orbit[foot < 4 * EPS])
    # one compiled sweep (12.6 million pairs: 0.4 s, where the sorted pairs took 3.9 s
    # before the first clock reading); the lists are made a block of rows at a time
    try:
        indptr, indices = setup_conflict_rows(
            instance, orbit, start, end, roll, keep=~np.isin(orbit, thin), max_pairs=MAX_PAIRS
        )
    except TooManyConflicts as exc:
        # the lists would take tens of GB (about 80 bytes a pair): no search
        log.warning("rds: %s; no search, the schedule is the fall-back's", exc)
        raise _Timeout from None
    conf: list[list[int]] = []
    row = 0
    while row < len(idx):
        if budget.expired():
            raise _Timeout
        # rows up to about PAIRS_PER_CHECK entries (at least one row)
        last = int(np.searchsorted(indptr, indptr[row] + PAIRS_PER_CHECK, side="right")) - 1
        last = min(max(last, row + 1), len(idx))
        block = indices[indptr[row] : indptr[last]]
        conf.extend(part.tolist() for part in np.split(block, indptr[row + 1 : last] - indptr[row]))
        row = last
    return conf


def fix_free_tasks(
    instance: Instance,
    tasks: TaskSet,
    usable: list[int],
    budget: Budget = UNLIMITED,
) -> tuple[list[int], list[int]]:
    """Exact reduction: tasks that some optimal selection contains, and the tasks still useful.

    On an orbit whose resources cannot bind (:func:`orbit_resources_can_bind` over its usable
    tasks), a task in (3) conflict with no other remaining task of its orbit
    (:func:`sosp.conflicts.setup_conflict_pairs`) can be added to any feasible selection of
    the remaining tasks: (3) only involves consecutive pairs, none of which can break, and
    (4)-(6) hold for every (3)-feasible set of the orbit's tasks. Adding it never lowers (1),
    so some optimal selection contains it: it is fixed and its targets count as covered. A
    task whose targets are all covered then adds nothing and is dropped, which can free other
    tasks; repeated until nothing changes.

    Once ``budget`` is spent (a dense instance has millions of conflict pairs) it stops with the
    tasks fixed so far, each an exact reduction on its own.

    Returns
    -------
    tuple of (list of int, list of int)
        The fixed tasks and the remaining ones (task indices), both sorted.
    """
    from sosp.conflicts import setup_conflict_rows

    if not usable:
        return [], []
    idx = np.asarray(usable, dtype=np.int64)
    loose = {
        int(j): not orbit_resources_can_bind(instance, tasks, idx[tasks.orbit[idx] == j])
        for j in np.unique(tasks.orbit[idx])
    }
    if budget.expired():
        return [], sorted(int(t) for t in idx)
    # the (3) adjacency by one compiled sweep (positions in ``idx``): a 5,000-target instance
    # of 24 satellites has 12.6 million pairs, which as sorted pairs and Python sets took
    # 4 s before the first clock reading (a 3 s limit ran to 5.8 s)
    indptr, indices = setup_conflict_rows(
        instance, tasks.orbit[idx], tasks.start[idx], tasks.end[idx], tasks.roll[idx]
    )
    degree = np.diff(indptr)  # alive neighbours of each position
    alive = np.ones(len(idx), dtype=bool)
    is_loose = np.array([loose[int(tasks.orbit[t])] for t in idx], dtype=bool)
    covered: set[int] = set()
    fixed: list[int] = []

    def discard(x: int) -> None:
        alive[x] = False
        degree[indices[indptr[x] : indptr[x + 1]]] -= 1

    changed = True
    while changed and not budget.expired():
        changed = False
        for seen, x in enumerate(np.flatnonzero(alive).tolist()):
            if seen % 4096 == 4095 and budget.expired():
                break  # the fixes so far stand
            t = int(idx[x])
            if all(int(k) in covered for k in tasks.targets[t]):
                discard(x)  # adds nothing any more (and may free a neighbour)
                changed = True
            elif is_loose[x] and degree[x] == 0:
                alive[x] = False  # no alive neighbour: no degree to lower
                fixed.append(t)
                covered.update(int(k) for k in tasks.targets[t])
                changed = True
    return sorted(fixed), sorted(int(t) for t in idx[alive])


def _restrict(instance: Instance, tasks: TaskSet, keep: list[int], fixed: list[int]) -> TaskSet:
    """The tasks ``keep`` with the targets of the ``fixed`` tasks taken out (already covered)."""
    covered = {int(k) for t in fixed for k in tasks.targets[t]}
    tw = instance.target_weight
    targets = tuple(tuple(k for k in tasks.targets[t] if int(k) not in covered) for t in keep)
    sel = np.asarray(keep, dtype=np.int64)
    weight = np.asarray([sum(int(tw[k]) for k in ks) for ks in targets], dtype=np.int64)
    times = (tasks.orbit[sel], tasks.start[sel], tasks.end[sel], tasks.roll[sel])
    return TaskSet(*times, weight, tuple(tasks.opps[t] for t in keep), targets)


def search_order(tasks: TaskSet, items: list[int], order: Order) -> list[int]:
    """The component's items in RDS variable order (see the module docstring)."""
    if order == "weight":
        return sorted(items, key=lambda t: (-tasks.weight[t], tasks.orbit[t], tasks.start[t], t))
    return sorted(items, key=lambda t: (tasks.orbit[t], tasks.start[t], tasks.end[t], t))


# ------------------------------------------------------------------------------- search
def _entries(
    instance: Instance, tasks: TaskSet, items: list[int]
) -> tuple[list[int], list[tuple], dict[int, OrbitTimeline], list[OrbitTimeline]]:
    """Per item (by position): its orbit, timeline entry ``(start, end, roll, position)``
    (:func:`heuristics.timeline.task_entries`) and its orbit's empty timeline (also given per
    orbit)."""
    orb = tasks.orbit[items].tolist()
    ent = task_entries(tasks, items)
    lines = {j: OrbitTimeline.of(instance, j) for j in set(orb)}
    return orb, ent, lines, [lines[j] for j in orb]


def rds_component(
    instance: Instance,
    tasks: TaskSet,
    items: list[int],
    budget: Budget = UNLIMITED,
) -> ComponentOutcome:
    """Russian Doll Search on one component, items already in variable order.

    Parameters
    ----------
    instance
        The problem.
    tasks
        All tasks (``items`` index into it).
    items
        The component's tasks in search order x_1..x_m.
    budget
        The time the search may take.

    Returns
    -------
    ComponentOutcome
        ``proven`` is False when the budget interrupted the search.
    """
    m = len(items)
    tw = instance.target_weight
    orb, ent, _, line_of = _entries(instance, tasks, items)
    tg = [tuple(int(k) for k in tasks.targets[t]) for t in items]
    wt = [int(sum(int(tw[k]) for k in ks)) for ks in tg]
    cover: dict[int, int] = {k: 0 for ks in tg for k in ks}
    opt = [0] * (m + 1)
    stack: list[int] = []  # positions currently scheduled
    state: dict[str, Any] = {"best": 0, "sel": [], "ub": 0, "nodes": 0}
    incumbent: list[int] = []  # positions of the best selection of the last solved P_i

    wts = [[int(tw[k]) for k in ks] for ks in tg]

    def add(p: int, chk: Any) -> None:
        line_of[p].insert(ent[p], chk)
        for k in tg[p]:
            cover[k] += 1
        stack.append(p)

    def undo(p: int) -> None:
        line_of[p].discard(ent[p])
        for k in tg[p]:
            cover[k] -= 1
        stack.pop()

    def dfs(p: int, value: int) -> None:
        # Decide x_p..x_m given the scheduled prefix; value is the profit so far.
        while p < m:
            if value + opt[p] <= state["best"]:
                return  # the RDS bound: the rest adds at most opt[p]
            state["nodes"] += 1
            if state["nodes"] % _CLOCK_EVERY == 0 and _halt(budget, state["nodes"]):
                raise _Timeout
            gain = sum(w for k, w in zip(tg[p], wts[p], strict=True) if cover[k] == 0)
            if gain > 0:
                chk = line_of[p].check_insert(ent[p])
                if chk:
                    add(p, chk)
                    nv = value + gain
                    if nv > state["best"]:
                        state["best"] = nv
                        state["sel"] = list(stack)
                        if nv >= state["ub"]:
                            undo(p)
                            raise _Done
                    try:
                        dfs(p + 1, nv)
                    finally:
                        undo(p)
            p += 1  # x_p = 0: continue with the next variable (no recursion needed)

    proven = True
    interrupted_at = -1
    try:
        for i in range(m - 1, -1, -1):
            # Subproblem P_i on positions i..m-1: improving on opt[i+1] needs x_i = 1.
            state["best"] = opt[i + 1]
            state["sel"] = None
            state["ub"] = wt[i] + opt[i + 1]
            chk = line_of[i].check_insert(ent[i])
            if chk and wt[i] > 0:
                add(i, chk)
                try:
                    if wt[i] > state["best"]:
                        state["best"] = wt[i]
                        state["sel"] = [i]
                    if state["best"] < state["ub"]:
                        dfs(i + 1, wt[i])
                except _Done:
                    pass
                except _Timeout:
                    interrupted_at = i
                    raise
                finally:
                    undo(i)
            opt[i] = state["best"]
            if state["sel"] is not None:
                incumbent = state["sel"]
    except _Timeout:
        proven = False
        # The best of the interrupted P_i is a feasible selection too.
        if state["sel"] is not None:
            incumbent = state["sel"]
    i = interrupted_at
    bound = min(sum(int(tw[k]) for k in cover), sum(wt[: i + 1]) + opt[i + 1])
    return _outcome(instance, tasks, items, incumbent, proven, opt[0], bound, state["nodes"])


def _outcome(
    instance: Instance,
    tasks: TaskSet,
    items: list[int],
    incumbent: list[int],
    proven: bool,
    optimum: int,
    bound: int,
    nodes: int,
) -> ComponentOutcome:
    """A component's outcome: the ``incumbent`` (positions in ``items``), with ``optimum`` as
    its bound when ``proven`` (the incumbent is then the selection that reached it), else
    ``bound``."""
    chosen = [items[p] for p in incumbent]
    value = _coverage_value(instance, tasks, chosen)
    if proven and value != optimum:
        raise AssertionError(f"RDS bookkeeping: incumbent {value} != optimum {optimum}")
    return ComponentOutcome(
        list(items), chosen, value, proven, int(optimum if proven else bound), nodes
    )


def rds_targets_component(
    instance: Instance,
    tasks: TaskSet,
    items: list[int],
    order: Order,
    budget: Budget = UNLIMITED,
) -> ComponentOutcome:
    """Russian Doll Search on one component with one variable per target (SPOT5 style).

    Variable x_k of target k takes as value a task covering k (its "domain", heaviest task
    first) or "none"; a task is scheduled while some target is assigned to it. This is the
    formulation of Bensana et al. on SPOT5 (photographs with their possible cameras) and the
    default here: the suffix bound ``opt[q]`` is the optimum over targets q..n, which never
    counts a target twice, so it stays tight when targets are seen from many orbits. A
    target covered by a scheduled task needs no branch; in the branches of a target, tasks
    already tried are banned below (their solutions were searched), and in its "none"
    branch all its tasks. The bound, the two branching orders with restarts and the passes
    with a descending target are described in the module docstring. The domain is tried
    with the tasks of the last subproblem's optimum first (the classic RDS value order).

    Parameters
    ----------
    instance, tasks, items, budget
        As :func:`rds_component`; ``items`` are the component's tasks.
    order
        Target order: ``"orbit"`` by (orbit, start) of the target's earliest task in the
        component, ``"weight"`` by decreasing weight.

    Returns
    -------
    ComponentOutcome
        ``proven`` is False when the budget interrupted the search.
    """
    tw = instance.target_weight
    by_target: dict[int, list[int]] = {}
    for t in items:
        for k in tasks.targets[t]:
            by_target.setdefault(int(k), []).append(t)
    first = {
        k: min((int(tasks.orbit[t]), float(tasks.start[t]), t) for t in ts)
        for k, ts in by_target.items()
    }
    if order == "weight":
        tkeys = sorted(by_target, key=lambda k: (-int(tw[k]), first[k], k))
    else:
        tkeys = sorted(by_target, key=lambda k: (first[k], k))
    n = len(tkeys)
    wq = [int(tw[k]) for k in tkeys]
    # Tasks become local ids 0..m-1; domains hold local ids, heaviest task first.
    local = {t: i for i, t in enumerate(items)}
    orb, ent, lines, line_of = _entries(instance, tasks, items)

    def heaviest(t: int) -> tuple:
        return (-int(tasks.weight[t]), tasks.orbit[t], tasks.start[t])

    dom = [[local[t] for t in sorted(by_target[k], key=heaviest)] for k in tkeys]
    m = len(items)
    on = [False] * m  # task scheduled
    opt = [0] * (n + 1)
    stack: list[int] = []
    state: dict[str, Any] = {"best": 0, "sel": None, "ub": 0, "nodes": 0, "prefer_ff": False}
    incumbent: list[int] = []
    # A task is "open" while no branch above banned it and no scheduled task excludes it by
    # (3) (:func:`pairwise_conflicts`); ``shut[t]`` counts what closes it (a ban always ends
    # after the schedules below it). ``cnt[p]`` counts the open tasks covering target p (a
    # scheduled task is open: scheduled tasks never conflict) and ``covc[p]`` the scheduled
    # ones. A target with ``cnt[p] == 0`` can no longer be covered below the node.
    pos_of = {k: p for p, k in enumerate(tkeys)}
    tpos = [[pos_of[int(k)] for k in tasks.targets[t]] for t in items]
    conf = pairwise_conflicts(instance, tasks, items, budget)
    shut = [0] * m
    cnt = [len(d) for d in dom]
    covc = [0] * n
    # On an orbit whose resources can bind, a task that no longer fits (4)-(6) next to the
    # scheduled ones never will below the node (feasibility is kept by subsets): it is
    # closed as well, and reopened on backtrack (``killed``, one list per scheduled task).
    on_orbit: dict[int, list[int]] = {}
    for t in range(m):
        on_orbit.setdefault(orb[t], []).append(t)
    tight = {
        j: orbit_resources_can_bind(instance, tasks, np.asarray([items[t] for t in ts]))
        for j, ts in on_orbit.items()
    }
    killed: list[list[int]] = []
    cur = {"i": n, "value": 0}  # the subproblem P_i being solved and the value of the node

    def close(t: int) -> None:
        shut[t] += 1
        if shut[t] == 1:
            for p in tpos[t]:
                cnt[p] -= 1

    def reopen(t: int) -> None:
        shut[t] -= 1
        if shut[t] == 0:
            for p in tpos[t]:
                cnt[p] += 1

    def schedule(t: int, chk: Any) -> None:
        line_of[t].insert(ent[t], chk)
        on[t] = True
        stack.append(t)
        i = cur["i"]
        for p in tpos[t]:
            covc[p] += 1
            if covc[p] == 1 and p >= i:
                cur["value"] += wq[p]
        for u in conf[t]:
            close(u)
        gone: list[int] = []
        if tight[orb[t]]:
            line = line_of[t]
            for u in on_orbit[orb[t]]:
                if not shut[u] and not on[u] and not line.check_insert(ent[u]):
                    close(u)
                    gone.append(u)
        killed.append(gone)

    def unschedule(t: int) -> None:
        for u in killed.pop():
            reopen(u)
        for u in conf[t]:
            reopen(u)
        i = cur["i"]
        for p in tpos[t]:
            covc[p] -= 1
            if covc[p] == 0 and p >= i:
                cur["value"] -= wq[p]
        stack.pop()
        on[t] = False
        line_of[t].discard(ent[t])

    def record(value: int) -> None:
        if value > state["best"]:
            state["best"] = value
            state["sel"] = list(stack)
            if value >= state["ub"]:
                raise _Done

    def dfs(i: int) -> None:
        # One node of P_i. The bound (module docstring): for every r in (i, n], targets
        # i..r-1 add at most the weight of those still coverable, and targets r.. at most
        # opt[r]. The branching target is the uncovered coverable one with the fewest open
        # tasks (fail first), ties by weight then position.
        state["nodes"] += 1
        if state["nodes"] > state["limit"]:
            raise _Budget
        if state["nodes"] % _CLOCK_EVERY == 0 and _halt(budget, state["nodes"]):
            raise _Timeout
        best = state["best"]
        bound = opt[i + 1] + (wq[i] if cnt[i] else 0)
        s = 0
        pick, pick_cnt = -1, 1 << 30
        # pick_cnt = 0 makes the first uncovered coverable target the pick (static order).
        fail_first = state["fail_first"]
        for p in range(i, n):
            c = cnt[p]
            if c:
                s += wq[p]
                if not covc[p] and c < pick_cnt:
                    pick, pick_cnt = p, (c if fail_first else 0)
            else:
                b = s + opt[p + 1]
                if b < bound:
                    bound = b
        if s < bound:
            bound = s
        if bound <= best:
            return
        if pick >= 0:  # else every coverable target is covered: a leaf (already recorded)
            branch(i, pick, True)

    def branch(i: int, k: int, none: bool) -> None:
        # The branches of target k at a node of P_i: each open task covering it in turn, then
        # with ``none`` the branch "k not covered". Later branches exclude a task tried (its
        # solutions were just searched), so in "none" all of k's tasks are banned.
        banned: list[int] = []
        try:
            for t in dom[k]:
                if shut[t]:
                    continue
                chk = line_of[t].check_insert(ent[t])
                if chk:
                    schedule(t, chk)
                    try:
                        record(cur["value"])
                        dfs(i)
                    finally:
                        unschedule(t)
                close(t)
                banned.append(t)
            if none:
                dfs(i)
        finally:
            for t in banned:
                reopen(t)

    def search_pass(i: int, low: int, upper: int) -> bool:
        # Search P_i (target i covered) for a selection worth more than ``low``, with
        # ``upper`` a proven upper bound. Restarts alternate the static order (first
        # uncovered target) and fail first, doubling a node budget, until one run finishes:
        # either order alone is exponentially slow on some instances (module docstring).
        budget, fail_first = _FIRST_BUDGET, state["prefer_ff"]
        state["sel"] = None
        state["best"] = low
        while True:
            state["ub"] = upper
            state["fail_first"] = fail_first
            # The order that finished the last long pass gets the full budget, the other a
            # quarter (the order that suits an instance tends to suit all its subproblems).
            own = budget if fail_first == state["prefer_ff"] else max(_FIRST_BUDGET, budget // 4)
            state["limit"] = state["nodes"] + own
            try:
                branch(i, i, False)  # target i covered (no task of it is closed up here)
            except _Done:
                pass
            except _Budget:
                # Keep what was found (state["best"], state["sel"]) and restart.
                if fail_first != state["prefer_ff"]:
                    budget *= 2
                fail_first = not fail_first
                continue
            if budget > _FIRST_BUDGET:
                state["prefer_ff"] = fail_first
            log.debug(
                "P_%d > %d: %s order, budget %d", i, low, "ff" if fail_first else "static", own
            )
            return state["sel"] is not None

    def repair(i: int, base: list[int], goal: int) -> list[int] | None:
        # A selection of P_i worth ``goal``, if one is found by putting a task of target i
        # into ``base`` (the last optimum), dropping the tasks in (3) conflict with it and
        # covering their lost targets again, fewest options first. Heuristic; any selection
        # it returns is feasible (built through the timelines) and worth ``goal``.
        def put(tl: dict[int, OrbitTimeline], t: int) -> bool:
            line = tl.setdefault(orb[t], OrbitTimeline(lines[orb[t]].rules))
            chk = line.check_insert(ent[t])
            if chk:
                line.insert(ent[t], chk)
            return bool(chk)

        for t0 in dom[i]:
            bad = set(conf[t0])
            sel = sorted((t for t in base if t not in bad), key=lambda t: ent[t][0]) + [t0]
            tl: dict[int, OrbitTimeline] = {}
            if not all(put(tl, t) for t in sel):
                continue
            have = {p for t in sel for p in tpos[t] if p >= i}
            lost = sorted(
                {p for t in base if t in bad for p in tpos[t] if p > i} - have,
                key=lambda p: (len(dom[p]), p),
            )
            for p in lost:
                if p in have:
                    continue
                for u in dom[p]:
                    if put(tl, u):
                        sel.append(u)
                        have.update(p2 for p2 in tpos[u] if p2 >= i)
                        break
            if sum(wq[p] for p in have) >= goal:
                return sel
        return None

    proven = True
    interrupted_at = -1
    try:
        for i in range(n - 1, -1, -1):
            # P_i on targets i..n-1: improving on opt[i+1] needs target i covered, so
            # opt[i+1] <= opt[i] <= upper = w_i + opt[i+1].
            interrupted_at = i
            upper = wq[i] + opt[i + 1]
            # The clock is read here too: when the repair solves every subproblem, no node
            # of the search reads it (2,212 targets over a polar box: 1,860 repairs of a
            # 1,300-task selection, 6.8 s past a 5 s limit). Only the clock: a stop request
            # is read by the nodes, so a tiny instance solved by repairs keeps its proof.
            if budget.left() == 0:
                raise _Timeout
            if incumbent:
                # Value order: the task that covers a target in the last optimum first.
                prev = set(incumbent)
                for p in range(i + 1, n):
                    dom[p].sort(key=lambda t: t not in prev)
            fix = repair(i, incumbent, upper) if incumbent else None
            if fix is not None:
                # The last optimum repaired to cover target i too reaches the upper bound.
                opt[i] = upper
                incumbent = fix
                continue
            # Passes with a descending target: each searches for a selection worth more
            # than ``low``; a pass that finds none proves opt[i] <= low (module docstring).
            step = 1
            low = max(opt[i + 1], upper - step)
            cur["i"] = i
            while True:
                found = search_pass(i, low, upper)
                log.debug("P_%d pass > %d: %s, %d nodes", i, low, found, state["nodes"])
                if found or low <= opt[i + 1]:
                    break
                upper = low
                step *= 2
                low = max(opt[i + 1], upper - step)
            if state["sel"] is not None:
                opt[i] = state["best"]
                incumbent = state["sel"]
            else:
                opt[i] = opt[i + 1]
            log.debug("P_%d: opt %d (w %d), %d nodes", i, opt[i], wq[i], state["nodes"])
    except _Timeout:
        proven = False
        if state["sel"] is not None:
            incumbent = state["sel"]
    bound = sum(wq[:interrupted_at]) + upper
    return _outcome(instance, tasks, items, incumbent, proven, opt[0], bound, state["nodes"])


def _coverage_value(instance: Instance, tasks: TaskSet, chosen: list[int]) -> int:
    """Objective (1) of a selection, each target counted once."""
    ks = {int(k) for t in chosen for k in tasks.targets[t]}
    return int(sum(int(instance.target_weight[k]) for k in ks))


#: Seconds per usable task kept back from the time limit for the work after the search
#: (measured on the 2-core machine, 209,103 tasks: the search's last step 0.4 s past its
#: deadline, then two decodes of 0.6-0.7 s each; 5e-6 kept back too little, 10.8 s for a
#: 10 s limit), at most half the limit.
FALLBACK_S_PER_TASK = 1e-5


#: Foreseen seconds of :func:`fix_free_tasks` and of :func:`interaction_components`, each,
#: per usable task and per pair the (3) sweep tests
#: (:func:`sosp.conflicts.setup_pair_candidates`). Measured on the 2-core machine, a
#: 5,000-target instance of 24 satellites (106,331 tasks, 15.3 million such pairs): 0.9-1.9 s
#: and 1.8-2.7 s (foreseen: 2.4 s), where a 3 s limit had run to 5.8 s.
PREP_S_PER_TASK = 5e-6
PREP_S_PER_PAIR = 1.2e-7


def _prep_seconds(instance: Instance, tasks: TaskSet, usable: list[int]) -> float:
    """The foreseen seconds of the reduction, or of the decomposition (:data:`PREP_S_PER_PAIR`)."""
    from sosp.conflicts import setup_pair_candidates

    idx = np.asarray(usable, dtype=np.int64)
    pairs = setup_pair_candidates(
        instance, tasks.orbit[idx], tasks.start[idx], tasks.end[idx], tasks.roll[idx]
    )
    return PREP_S_PER_TASK * len(idx) + PREP_S_PER_PAIR * pairs


def russian_doll(
    instance: Instance,
    tasks: TaskSet,
    *,
    time_limit: float | None = None,
    order: Order = "orbit",
    decompose: bool = True,
    variables: Variables = "targets",
    reduce: bool = True,
) -> RdsOutcome:
    """Solve the static problem over ``tasks`` exactly by Russian Doll Search.

    Parameters
    ----------
    instance
        The problem.
    tasks
        The atomic tasks (single opportunities or static cluster-tasks).
    time_limit
        Wall-time limit in seconds for the whole search (None: until proven).
    order
        Variable order, ``"orbit"`` or ``"weight"`` (module docstring).
    decompose
        Split into independent components of the interaction graph first.
    variables
        ``"targets"`` (default): one variable per target, valued by a task covering it or
        none (:func:`rds_targets_component`); ``"tasks"``: one 0/1 variable per task
        (:func:`rds_component`).
    reduce
        Fix the tasks that some optimal selection contains first (:func:`fix_free_tasks`).

    Returns
    -------
    RdsOutcome
        The best selection, its value, whether it is proven optimal, and an upper bound.
    """
    budget = Budget.of(time_limit)
    # Tasks that can never be scheduled: no weight, or infeasible alone ((4)-(6), (11)).
    alone = fits_alone(instance, tasks)
    usable = [t for t in range(len(tasks)) if tasks.weight[t] > 0 and alone[t]]
    if time_limit is not None:
        # what follows the search when it is not proven (the fall-back decode of every
        # task, the restriction to the tasks left) reads no clock: its time is kept back
        # (20,000 targets, 209,103 tasks: about 1 s, and a 3 s limit ran to 4.04 s)
        keep = min(0.5 * float(time_limit), FALLBACK_S_PER_TASK * len(usable))
        budget = Budget.until(budget.deadline - keep)
    fixed: list[int] = []
    # the reduction and the decomposition are optional and read no clock in their compiled
    # and scipy parts: each is skipped when foreseen to end past the deadline
    prep_s = _prep_seconds(instance, tasks, usable)
    if reduce and not budget.fits(prep_s):
        log.debug("no reduction: foreseen %.2f s, %s s left", prep_s, budget.left())
        reduce = False
    if reduce:
        fixed, back = fix_free_tasks(instance, tasks, usable, budget)
        usable = list(range(len(back)))
        log.debug("fixed %d tasks, %d left", len(fixed), len(back))
    else:
        back = list(range(len(tasks)))
    fixed_value = _coverage_value(instance, tasks, fixed)
    # From here on ``tasks`` are the remaining ones (``back`` maps them to the originals).
    tasks = _restrict(instance, tasks, back, fixed)
    usable_arr = np.asarray(usable, dtype=np.int64)
    if decompose and budget.fits(prep_s):
        comps = interaction_components(instance, tasks, usable_arr)
    else:
        comps = [usable] if usable else []
    need = max((len(c) for c in comps), default=0) + 1000
    sys.setrecursionlimit(max(sys.getrecursionlimit(), need))
    outcomes: list[ComponentOutcome] = []
    # the preparation above reads the clock only between its steps (and in its loops over
    # conflict pairs): past the deadline, no search starts
    timed_out = budget.expired()
    for comp in comps:
        items = search_order(tasks, comp, order)
        out = None
        if not timed_out:
            try:
                if variables == "targets":
                    out = rds_targets_component(instance, tasks, items, order, budget)
                else:
                    out = rds_component(instance, tasks, items, budget)
                timed_out = not out.proven
            except _Timeout:
                timed_out = True
        if out is None:  # not searched: no selection yet, the coverage of all as its bound
            out = ComponentOutcome(items, [], 0, False, _coverage_value(instance, tasks, items))
        if not out.proven:
            # Fall-back incumbents: the search's best (often a subproblem's, over the last
            # targets only) completed highest weight first, and highest weight first alone.
            by_weight = sorted(items, key=lambda t: (-tasks.weight[t], t))
            lines: dict[int, OrbitTimeline] = {}
            covered = np.zeros(instance.n_targets, dtype=bool)
            cands = [insertion_decode(instance, tasks, by_weight)[0]]
            if out.chosen:  # (without a selection the completion is the same decode)
                insertion_decode(instance, tasks, sorted(out.chosen), lines, covered)
                more, _ = insertion_decode(instance, tasks, by_weight, lines, covered)
                cands.insert(0, sorted(set(out.chosen) | set(more)))
            for cand in cands:
                cval = _coverage_value(instance, tasks, cand)
                if cval > out.value:
                    out.chosen, out.value = cand, cval
        outcomes.append(out)
        done = fixed_value + sum(o.value for o in outcomes)
        current_progress().update(sum(o.nodes for o in outcomes), done)
    chosen = sorted(fixed + [back[t] for o in outcomes for t in o.chosen])
    value = fixed_value + sum(o.value for o in outcomes)
    proven = all(o.proven for o in outcomes)
    bound = value if proven else fixed_value + sum(o.bound for o in outcomes)
    return RdsOutcome(chosen, value, proven, bound, outcomes)


# ------------------------------------------------------------------------------ methods
def _result(
    method: str, instance: Instance, tasks: TaskSet, time_limit: float | None, p: RDSParams
) -> Result:
    """:func:`russian_doll` over ``tasks`` with the parameters ``p``, as the method's result."""
    opts = {"order": p.order, "decompose": p.decompose, "variables": p.variables}
    out = russian_doll(instance, tasks, time_limit=time_limit, **opts)
    sizes = [len(c.items) for c in out.components]
    stats = {
        "tasks": len(tasks),
        "components": len(out.components),
        "largest_component": max(sizes, default=0),
        "proven_components": sum(c.proven for c in out.components),
        "nodes": sum(c.nodes for c in out.components),
    }
    status = Status.OPTIMAL if out.proven else Status.TIME_LIMIT
    log.info("%s: %s, profit %d, bound %d, %s", method, status.value, out.value, out.bound, stats)
    chosen, bound = out.chosen, float(out.bound)
    return task_result(method, instance, tasks, chosen, out.value, status, bound=bound, stats=stats)


@dataclass(frozen=True)
class RDSParams(Params):
    """Parameters of :func:`solve_rds`."""

    order: Order = param("orbit", 'Variable order: "orbit" (by orbit, then time) or "weight".')
    decompose: bool = param(True, "Solve independent components separately.")
    variables: Variables = param("targets", "One variable per target or per task.")


@dataclass(frozen=True)
class RDSSTCParams(RDSParams):
    """Parameters of :func:`solve_rds_stc`."""

    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")


def solve_rds(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """RDS over single opportunities at their own roll (no clustering): exact for (1)-(6).

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused: the search is deterministic.
    time_limit
        Seconds; on timeout the status is ``time_limit`` with the incumbent and a bound.
    **params
        Fields of :class:`RDSParams`: ``order``, the variable order, ``"orbit"`` (by orbit,
        then time) or ``"weight"``; ``decompose``, solve independent components of the
        interaction graph separately; ``variables``, ``"targets"`` (one variable per target,
        default) or ``"tasks"`` (0/1 per task).

    Returns
    -------
    Result
        Status ``optimal`` (``bound`` = profit) or ``time_limit``; ``stats`` has the number of
        components, the largest one and the search nodes.
    """
    del rng
    p = from_kwargs(RDSParams, params, method="rds")
    return _result("rds", instance, single_tasks(instance), time_limit, p)


def solve_rds_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """RDS-STC: RDS over the static cluster-tasks (the paper's exact baseline, Tables 3-4).

    Parameters
    ----------
    instance, rng, time_limit
        As :func:`solve_rds`.
    **params
        Fields of :class:`RDSSTCParams`: those of :func:`solve_rds`, and ``roll_rule``, the
        roll of multi-opportunity cluster-tasks, ``"midpoint"`` (9) or ``"nadir"``.

    Returns
    -------
    Result
        As :func:`solve_rds`; optimal means optimal over these fixed cluster-tasks.
    """
    del rng
    p = from_kwargs(RDSSTCParams, params, method="rds-stc")
    tasks = static_cluster_tasks(instance, roll_rule=p.roll_rule)
    return _result("rds-stc", instance, tasks, time_limit, p)
