"""Solvers of the SPOT5 problem (:mod:`sosp.spot5`) besides the MILP: Russian Doll Search
(exact) and a tabu search (scales to the multi-orbit instances).

Russian Doll Search (Verfaillie, Lemaître and Schiex, AAAI 1996), on its original problem
    the variables are put in an order x_0..x_{n-1} and the n nested subproblems P_{n-1} (the
    last variable), P_{n-2} (the last two), ..., P_0 (all) are solved in turn by depth-first
    branch and bound assigning the variables in that order, each with the value "unselected"
    besides its domain. The optimum ``opt[d]`` of P_d is kept; at a node of P_i that has
    assigned x_i..x_{d-1} with profit g, what x_d..x_{n-1} can add is at most ``opt[d]``
    (any completion is a solution of P_d: dropping variables breaks no constraint, nor the
    capacity), so the node is cut when ``g + opt[d] <= best``. As in
    :mod:`heuristics.rds` (the satellite problem's RDS): a solution of P_i better than
    ``opt[i+1]`` must select x_i, so only those branches are searched from the incumbent
    ``opt[i+1]``, and the search stops on reaching ``w_i + opt[i+1]``, an upper bound of P_i.
    Values are tried from the one the last optimum gave the variable (the 1996 paper's value
    ordering). The search is a numba kernel over an explicit stack, resumable, so that
    Python checks the time limit between chunks of nodes. The satellite RDS of
    :mod:`heuristics.rds` is specific to its tasks and timelines (coverage, orbit
    resources); what the two share is the scheme above, not code.

Tabu search (:func:`solve_spot5_tabu`)
    a local search over complete assignments, for the multi-orbit instances where the MILP
    needs a good start: a move gives an unselected image one of its values and drops the
    images in conflict with it (binary or ternary) and, if the recorder overflows, the least
    valuable images per unit until it fits; the best non-tabu move is taken (ties at random)
    even if it loses, and the dropped images are tabu for a random tenure. An aspiration
    criterion allows a tabu move that beats the best solution. One seeded
    ``numpy.random.Generator`` drives it.
"""

from __future__ import annotations

import logging
import time
from typing import Literal

import numba as nb
import numpy as np

from sosp.spot5 import Spot5, Spot5Result

log = logging.getLogger(__name__)

Order = Literal["file", "reverse"]


def _check_tables(
    problem: Spot5, rank: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Constraint checks per variable in the search order ``rank`` (rank[v] = position).

    Every constraint is checked when the last of its variables (in the order) is assigned:
    binary entries ``(u, forbidden[a_d, a_u])`` and ternary ones ``(u, w, forbidden[a_d,
    a_u, a_w])``, u and w earlier than d, constraints on the same variables merged.
    """
    n, K = problem.n, problem.values.shape[1]
    two: dict[tuple[int, int], np.ndarray] = {}
    for c, (x, y) in enumerate(rank[problem.pairs].tolist()):
        fb = problem.pair_forbid[problem.pair_ptr[c] : problem.pair_ptr[c + 1]]
        if x < y:
            x, y, fb = y, x, fb[:, ::-1]
        t = two.setdefault((x, y), np.zeros((K, K), dtype=np.bool_))
        t[fb[:, 0], fb[:, 1]] = True
    three: dict[tuple[int, int, int], np.ndarray] = {}
    for c, trio in enumerate(rank[problem.triples].tolist()):
        fb = problem.triple_forbid[problem.triple_ptr[c] : problem.triple_ptr[c + 1]]
        perm = np.argsort(trio)[::-1]  # latest first
        key = tuple(int(trio[p]) for p in perm)
        t = three.setdefault(key, np.zeros((K, K, K), dtype=np.bool_))  # type: ignore[arg-type]
        f = fb[:, perm]
        t[f[:, 0], f[:, 1], f[:, 2]] = True
    keys2 = sorted(two)
    keys3 = sorted(three)
    ptr2 = np.searchsorted([k[0] for k in keys2], np.arange(n + 1)).astype(np.int64)
    ptr3 = np.searchsorted([k[0] for k in keys3], np.arange(n + 1)).astype(np.int64)
    u2 = np.asarray([k[1] for k in keys2], dtype=np.int64)
    tab2 = np.asarray([two[k] for k in keys2], dtype=np.bool_).reshape(-1, K, K)
    uw3 = np.asarray([k[1:] for k in keys3], dtype=np.int64).reshape(-1, 2)
    tab3 = np.asarray([three[k] for k in keys3], dtype=np.bool_).reshape(-1, K, K, K)
    return ptr2, u2, tab2, ptr3, uw3, tab3, np.asarray(keys2, dtype=np.int64).reshape(-1, 2)


@nb.njit(cache=True)
def _rds_chunk(  # noqa: PLR0913
    i, size, weight, cons, cap, ptr2, u2, tab2, ptr3, uw3, tab3, opt, pref, val, ch, best_sol,
    state, max_nodes,
):  # fmt: skip
    """Search P_i from ``state`` = [d, g, used, best, ub, nodes] for at most ``max_nodes``
    nodes; returns 0 when P_i is solved (``state[3]`` its optimum, ``best_sol`` its
    assignment when it beat the start) and 1 when the node budget ran out (resume by
    calling again with the same arrays)."""
    n = len(size)
    d, g, used, best, ub = state[0], state[1], state[2], state[3], state[4]
    budget = state[5] + max_nodes
    nodes = state[5]
    while True:
        nodes += 1
        if nodes >= budget:
            state[0], state[1], state[2], state[3], state[5] = d, g, used, best, nodes
            return 1
        if d == n:
            if g > best:
                best = g
                best_sol[:] = val
                if best >= ub:
                    break
            d -= 1
            continue
        if ch[d] == 0:
            if g + opt[d] <= best:
                d -= 1
                if d < i:
                    break
                continue
        elif val[d] >= 0:
            g -= weight[d]
            used -= cons[d, val[d]]
            val[d] = -1
        t = ch[d]
        lim = size[d] - 1 if d == i else size[d]
        if t > lim:
            ch[d] = 0
            d -= 1
            if d < i:
                break
            continue
        ch[d] = t + 1
        if t == size[d]:  # unselected
            if g + opt[d + 1] > best:
                d += 1
                ch[d] = 0
            continue
        a = (pref[d] + t) % size[d]
        if cap >= 0 and used + cons[d, a] > cap:
            continue
        ok = True
        for e in range(ptr2[d], ptr2[d + 1]):
            b = val[u2[e]]
            if b >= 0 and tab2[e, a, b]:
                ok = False
                break
        if ok:
            for e in range(ptr3[d], ptr3[d + 1]):
                b = val[uw3[e, 0]]
                c = val[uw3[e, 1]]
                if b >= 0 and c >= 0 and tab3[e, a, b, c]:
                    ok = False
                    break
        if not ok:
            continue
        val[d] = a
        g += weight[d]
        used += cons[d, a]
        d += 1
        ch[d] = 0
    state[3], state[5] = best, nodes
    return 0


def rds_order(problem: Spot5, order: Order = "file") -> np.ndarray:
    """The variables in the nesting order: file order (default) or its reverse."""
    idx = np.arange(problem.n)
    return idx if order == "file" else idx[::-1].copy()


def solve_spot5_rds(
    problem: Spot5,
    time_limit: float | None = None,
    *,
    order: Order = "file",
    chunk: int = 1_000_000,
) -> Spot5Result:
    """Russian Doll Search (module docstring) within ``time_limit`` wall seconds.

    Parameters
    ----------
    problem
        The instance (the capacity, if any, is checked too).
    time_limit
        Wall seconds (None: until proven); checked every ``chunk`` nodes.
    order
        Nesting order of the variables (:func:`rds_order`).

    Returns
    -------
    Spot5Result
        ``status`` optimal when every subproblem was solved; otherwise the best solution of
        the last solved subproblem and the bound ``sum of the weights before it + its
        optimum`` (``w_i + opt[i+1]`` for the unsolved P_i).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    seq = rds_order(problem, order)
    rank = np.empty(problem.n, dtype=np.int64)
    rank[seq] = np.arange(problem.n)
    ptr2, u2, tab2, ptr3, uw3, tab3, _ = _check_tables(problem, rank)
    size, weight = problem.size[seq].copy(), problem.weight[seq].copy()
    cons = problem.consumption[seq].copy()
    cap = -1 if problem.capacity is None else int(problem.capacity)
    n = problem.n
    opt = np.zeros(n + 1, dtype=np.int64)
    sol = np.full(n, -1, dtype=np.int64)  # optimum of the last solved subproblem
    val = np.full(n, -1, dtype=np.int64)
    ch = np.zeros(n + 1, dtype=np.int64)
    nodes = 0
    status = "optimal"
    solved = n  # P_solved..: solved
    for i in range(n - 1, -1, -1):
        pref = np.where(sol >= 0, sol, 0)
        best_sol = sol.copy()
        val[:] = -1
        ch[:] = 0
        ub = int(weight[i] + opt[i + 1])
        opt[i] = ub  # P_i's own bound, so that its root is not cut
        state = np.array([i, 0, 0, opt[i + 1], ub, 0], dtype=np.int64)
        while _rds_chunk(
            i, size, weight, cons, cap, ptr2, u2, tab2, ptr3, uw3, tab3, opt, pref, val, ch,
            best_sol, state, chunk,
        ):  # fmt: skip
            if time_limit is not None and time.perf_counter() - t0 > time_limit:
                status = "time_limit"
                break
        nodes += int(state[5])
        if status != "optimal":
            break
        opt[i] = state[3]
        sol = best_sol
        solved = i
    assign = np.full(n, -1, dtype=np.int64)
    assign[seq] = sol
    value = problem.profit(assign)
    if status == "optimal":
        bound = value
    else:  # P_{solved-1} unsolved: its bound w + opt[solved], plus every weight before it
        bound = int(weight[: solved - 1].sum() + weight[solved - 1] + opt[solved])
    stats = {"nodes": nodes, "solved_from": solved, "order": order}
    return Spot5Result(
        "rds", assign, value, bound, status, time.perf_counter() - t0,
        time.process_time() - c0, stats,
    )  # fmt: skip


def conflict_lists(problem: Spot5) -> tuple[np.ndarray, ...]:
    """Per node (see :func:`models.spot5.node_offsets`): its conflict-graph neighbours (CSR
    ``nbr_ptr, nbr``) and the node pairs completing a forbidden triple with it (CSR
    ``tri_ptr, tri``, rows of two nodes)."""
    from models.spot5 import conflict_edges, node_offsets

    off = node_offsets(problem)
    nn = int(off[-1])
    e = conflict_edges(problem)
    both = np.concatenate([e, e[:, ::-1]])
    both = both[np.lexsort((both[:, 1], both[:, 0]))]
    nbr_ptr = np.searchsorted(both[:, 0], np.arange(nn + 1)).astype(np.int64)
    c3 = np.repeat(np.arange(len(problem.triples)), np.diff(problem.triple_ptr))
    t = off[problem.triples[c3]] + problem.triple_forbid
    rows = np.concatenate([t[:, [0, 1, 2]], t[:, [1, 0, 2]], t[:, [2, 0, 1]]])
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    tri_ptr = np.searchsorted(rows[:, 0], np.arange(nn + 1)).astype(np.int64)
    return nbr_ptr, both[:, 1].copy(), tri_ptr, rows[:, 1:].copy()


@nb.njit(cache=True)
def _move(j, node_var, node_w, node_c, cap, nbr_ptr, nbr, tri_ptr, tri, sel, used, mark,
          stamp, order, apply_to):  # fmt: skip
    """Gain of selecting node ``j``: the nodes in conflict with it (and, if the recorder
    overflows, the least valuable per unit in ``order``) are dropped; with ``apply_to`` >= 0
    the dropped nodes are written to ``apply_to``-marked ``mark`` too (mark = -2)."""
    gain = node_w[j]
    freed = 0
    v = node_var[j]
    for q in range(nbr_ptr[j], nbr_ptr[j + 1]):
        k = nbr[q]
        if sel[node_var[k]] == k and mark[k] != stamp:
            mark[k] = stamp
            gain -= node_w[k]
            freed += node_c[k]
    for q in range(tri_ptr[j], tri_ptr[j + 1]):
        a, b = tri[q, 0], tri[q, 1]
        if sel[node_var[a]] == a and sel[node_var[b]] == b:
            if mark[a] == stamp or mark[b] == stamp:
                continue
            k = a if node_w[a] <= node_w[b] else b
            mark[k] = stamp
            gain -= node_w[k]
            freed += node_c[k]
    if cap >= 0:
        need = used + node_c[j] - freed - cap
        for k in order:
            if need <= 0:
                break
            if mark[k] == stamp or node_var[k] == v:
                continue
            mark[k] = stamp
            gain -= node_w[k]
            need -= node_c[k]
    return gain


@nb.njit(cache=True)
def _tabu_chunk(node_var, node_w, node_c, cap, nbr_ptr, nbr, tri_ptr, tri, sel, tabu, best_sel,
                st, iters, tmin, tmax, gen):  # fmt: skip
    """``iters`` tabu iterations from ``st`` = [it, value, used, best, it of best]; see the
    module docstring; ``gen``: the run's generator (numba draws from it in place)."""
    nn = len(node_var)
    mark = np.full(nn, -1, dtype=np.int64)
    it, value, used, best, found = st[0], st[1], st[2], st[3], st[4]
    stamp = 0
    for _ in range(iters):
        it += 1
        on = np.empty(0, dtype=np.int64)
        if cap >= 0:
            cand = np.array([sel[v] for v in range(len(sel)) if sel[v] >= 0 and node_c[sel[v]] > 0])
            if len(cand):
                ratio = np.array([node_w[k] / node_c[k] for k in cand])
                on = cand[np.argsort(ratio)]
        best_j, best_gain, ties = -1, -(1 << 60), 0
        for j in range(nn):
            v = node_var[j]
            if sel[v] == j:
                continue
            stamp += 1
            gain = _move(j, node_var, node_w, node_c, cap, nbr_ptr, nbr, tri_ptr, tri, sel,
                         used, mark, stamp, on, -1)  # fmt: skip
            if tabu[v] > it and value + gain <= best:
                continue
            if gain > best_gain:
                best_j, best_gain, ties = j, gain, 1
            elif gain == best_gain:
                ties += 1
                if gen.integers(0, ties) == 0:
                    best_j = j
        if best_j < 0:
            continue
        stamp += 1
        _move(best_j, node_var, node_w, node_c, cap, nbr_ptr, nbr, tri_ptr, tri, sel, used, mark,
              stamp, on, 1)  # fmt: skip
        for k in range(nn):
            if mark[k] == stamp:
                u = node_var[k]
                sel[u] = -1
                tabu[u] = it + tmin + gen.integers(0, tmax - tmin + 1)
                value -= node_w[k]
                used -= node_c[k]
        sel[node_var[best_j]] = best_j
        value += node_w[best_j]
        used += node_c[best_j]
        if value > best:
            best, found = value, it
            best_sel[:] = sel
    st[0], st[1], st[2], st[3], st[4] = it, value, used, best, found


def solve_spot5_tabu(
    problem: Spot5,
    time_limit: float = 10.0,
    *,
    rng: np.random.Generator | None = None,
    start: np.ndarray | None = None,
    tenure: tuple[int, int] = (5, 20),
    chunk: int = 200,
    stall: int | None = None,
) -> Spot5Result:
    """Tabu search (module docstring) for ``time_limit`` wall seconds.

    Parameters
    ----------
    problem
        The instance.
    time_limit
        Wall seconds, checked every ``chunk`` iterations.
    rng
        The run's seeded generator (default: seed 0).
    start
        A feasible assignment to start from (default: empty).
    tenure
        Tabu tenure drawn uniformly in this range (iterations).
    stall
        Stop sooner, after this many iterations without a new best (None: never).
    """
    from models.spot5 import node_offsets

    t0, c0 = time.perf_counter(), time.process_time()
    rng = np.random.default_rng(0) if rng is None else rng
    off = node_offsets(problem)
    node_var = np.repeat(np.arange(problem.n), problem.size)
    node_pos = np.arange(int(off[-1])) - off[node_var]
    node_w = problem.weight[node_var].astype(np.int64)
    node_c = problem.consumption[node_var, node_pos].astype(np.int64)
    cap = -1 if problem.capacity is None else int(problem.capacity)
    nbr_ptr, nbr, tri_ptr, tri = conflict_lists(problem)
    sel = np.full(problem.n, -1, dtype=np.int64)
    if start is not None:
        on = np.flatnonzero(np.asarray(start) >= 0)
        sel[on] = off[on] + np.asarray(start)[on]
    value = int(node_w[sel[sel >= 0]].sum())
    st = np.array([0, value, int(node_c[sel[sel >= 0]].sum()), value, 0], dtype=np.int64)
    tabu = np.zeros(problem.n, dtype=np.int64)
    best_sel = sel.copy()
    while True:
        _tabu_chunk(node_var, node_w, node_c, cap, nbr_ptr, nbr, tri_ptr, tri, sel, tabu,
                    best_sel, st, chunk, tenure[0], tenure[1], rng)  # fmt: skip
        if time.perf_counter() - t0 >= time_limit or (stall and st[0] - st[4] >= stall):
            break
    assign = np.where(best_sel >= 0, best_sel - off[np.arange(problem.n)], -1)
    return Spot5Result(
        "tabu", assign, problem.profit(assign), None, "heuristic", time.perf_counter() - t0,
        time.process_time() - c0, {"iterations": int(st[0]), "last_improvement": int(st[4])},
    )  # fmt: skip
