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
