"""The 0-1 integer program of the SPOT5 problem (:mod:`sosp.spot5`), solved with HiGHS.

One binary ``x[j]`` per node j = (variable v, value position a) of the conflict graph
(``x[j] = 1``: image v is taken with camera value a). With ``w_v`` the weight, ``c_j`` the
recorder units and ``C`` the capacity:

    max   sum_j w_{v(j)} x_j                                                  (objective)
    s.t.  sum_{j in K} x_j <= 1          every clique K of the conflict graph    (cliques)
          x_i + x_j + x_k <= 2           every forbidden triple (i, j, k)        (ternary)
          sum_j c_j x_j <= C             multi-orbit instances: one knapsack row (capacity)

The conflict graph joins two nodes of the same variable (at most one value per image) and the
two nodes of every forbidden pair of a binary constraint. Its cliques
(:func:`models.cliques.graph_cliques`) cover every edge, so they imply "at most one value per
variable" and every forbidden pair as a linear cut, and their LP relaxation (the *clique LP*,
:func:`spot5_bound`) is stronger than the LP of the pairwise rows (``cliques=False``).

The model is built with Pyomo and solved through :func:`models.solve.run_appsi`, the
project's APPSI/HiGHS plumbing (time limit covering the build, MIP start, dual bound). When
HiGHS has not proven the optimum within its share of the limit, a large neighbourhood search
(:func:`_lns`) improves its incumbent on the same loaded model for the rest of the time.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import numpy as np
import pyomo.environ as pyo
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order

from models.cliques import graph_cliques
from models.solve import appsi_values, run_appsi
from sosp.spot5 import Spot5, Spot5Result
from sosp.stop import stop_requested

log = logging.getLogger(__name__)

#: Most maximal cliques the clique LP enumerates before a greedy cover (1506 has 167,256 of
#: them, 2.5 M nonzeros: minutes of Pyomo build; 414 has 27,259).
MAX_CLIQUES = 30_000


def node_offsets(problem: Spot5) -> np.ndarray:
    """(n+1,) first node of each variable: node ``offset[v] + a`` is (v, position a)."""
    return np.concatenate([[0], np.cumsum(problem.size)]).astype(np.int64)


def conflict_edges(problem: Spot5) -> np.ndarray:
    """(m, 2) distinct edges of the conflict graph (same variable, forbidden pairs)."""
    off = node_offsets(problem)
    same = [
        (off[v] + a, off[v] + b)
        for v in range(problem.n)
        for a in range(problem.size[v])
        for b in range(a + 1, problem.size[v])
    ]
    c = np.repeat(np.arange(len(problem.pairs)), np.diff(problem.pair_ptr))
    pair = np.stack(
        [
            off[problem.pairs[c, 0]] + problem.pair_forbid[:, 0],
            off[problem.pairs[c, 1]] + problem.pair_forbid[:, 1],
        ],
        axis=1,
    )
    e = np.concatenate([np.asarray(same, dtype=np.int64).reshape(-1, 2), pair])
    return np.unique(np.sort(e, axis=1), axis=0)


def build_spot5_model(
    problem: Spot5, *, cliques: bool = True, relax: bool = False, cover: bool = True
) -> Any:
    """The integer program of the module docstring as a Pyomo ``ConcreteModel`` (not solved).

    Parameters
    ----------
    problem
        The instance.
    cliques
        Clique rows of the conflict graph (default); False: one row per variable and one per
        forbidden pair (the plain formulation).
    relax
        Continuous ``0 <= x <= 1`` (the LP relaxation).
    cover
        With ``cliques``: a greedy clique cover of the edges (default, the MILP's rows: every
        maximal clique makes a model whose presolve alone takes minutes on 414) rather than
        every maximal clique (the strongest clique LP, :func:`spot5_bound`).
    """
    off = node_offsets(problem)
    nodes = int(off[-1])
    var = np.repeat(np.arange(problem.n), problem.size)
    pos = np.arange(nodes) - off[var]
    weight = problem.weight[var]
    units = problem.consumption[var, pos]
    if cliques:
        rows = graph_cliques(nodes, conflict_edges(problem), MAX_CLIQUES, cover=cover)
    else:
        rows = [np.arange(off[v], off[v + 1]) for v in range(problem.n) if problem.size[v] > 1]
        rows += list(conflict_edges(problem)[np.diff(conflict_edges(problem), axis=1)[:, 0] > 0])
        rows = [r for r in rows if len(r) >= 2]
    c3 = np.repeat(np.arange(len(problem.triples)), np.diff(problem.triple_ptr))
    triples = off[problem.triples[c3]] + problem.triple_forbid

    m = pyo.ConcreteModel(name=f"spot5-{problem.name}")
    m.J = pyo.RangeSet(0, nodes - 1)
    m.x = pyo.Var(m.J, domain=pyo.UnitInterval if relax else pyo.Binary)
    m.K = pyo.RangeSet(0, len(rows) - 1)
    m.T = pyo.RangeSet(0, len(triples) - 1)

    @m.Constraint(m.K)
    def clique(m: Any, k: int) -> Any:
        return pyo.quicksum(m.x[int(j)] for j in rows[k]) <= 1

    @m.Constraint(m.T)
    def ternary(m: Any, t: int) -> Any:
        i, j, k = (int(u) for u in triples[t])
        return m.x[i] + m.x[j] + m.x[k] <= 2

    if problem.capacity is not None and units.any():

        @m.Constraint()
        def capacity(m: Any) -> Any:
            used = np.flatnonzero(units)
            return pyo.quicksum(int(units[j]) * m.x[int(j)] for j in used) <= problem.capacity

    m.profit = pyo.Objective(
        expr=pyo.quicksum(int(weight[j]) * m.x[j] for j in range(nodes)), sense=pyo.maximize
    )
    m.cliques_count = len(rows)  # for the stats
    return m


def weight_split(problem: Spot5) -> int | None:
    """The largest weight ``T`` whose lighter weights sum to less than the gcd ``g`` of the
    weights from ``T`` up (None if no weight does).

    Two selections' *heavy* weights (of images weighing ``T`` or more) then differ by 0 or by
    at least ``g``, more than all light images together, so every optimum has the largest
    heavy weight: ``max w(x) = max { w(x) : heavy(x) = H* }`` with ``H* = max heavy(x)``.
    The multi-orbit instances weigh 1, 2, 5, 1000 and 2000 (``T = 1000``: the lights sum to
    at most 868).
    """
    w = np.asarray(problem.weight, dtype=np.int64)
    for t in np.unique(w[w > 0])[:0:-1]:
        if w[w < t].sum() < np.gcd.reduce(w[w >= t]):
            return int(t)
    return None


def _milp_stage(
    problem: Spot5, m: Any, deadline: float | None, start: np.ndarray | None, stats: dict,
    threads: int | None, mip_gap: float, rng: np.random.Generator | None,
) -> tuple[str, np.ndarray, float | None]:  # fmt: skip
    """Solve the built model ``m`` from ``start``: (termination, best assignment found, never
    worse than ``start``, HiGHS's raw dual bound). With ``rng``, HiGHS gets
    :data:`HIGHS_SHARE` of the time left and, unless it proves the optimum, :func:`_lns`
    the rest."""
    off = node_offsets(problem)
    if start is not None:
        for v in range(problem.n):
            for a in range(problem.size[v]):
                m.x[int(off[v] + a)].set_value(1.0 if start[v] == a else 0.0)
    now = time.perf_counter()
    lns_from = None if rng is None or deadline is None else now + HIGHS_SHARE * (deadline - now)
    kind, incumbent, raw, opt = run_appsi(
        m, lns_from or deadline, mip_gap=mip_gap, threads=threads, warm=start is not None,
        stats=stats,
    )  # fmt: skip
    best = np.full(problem.n, -1, dtype=np.int64) if start is None else np.asarray(start).copy()
    if incumbent is not None and kind in ("optimal", "time_limit"):
        x = np.asarray(appsi_values(opt, [m.x[j] for j in m.J])) > 0.5
        got = np.full(problem.n, -1, dtype=np.int64)
        on = np.flatnonzero(x)
        var = np.searchsorted(off, on, side="right") - 1
        got[var] = on - off[var]
        if problem.profit(got) >= problem.profit(best):
            best = got
    if kind == "infeasible":  # cannot happen (all unselected is feasible): say so
        log.warning("HiGHS reports the SPOT5 model of %s infeasible", problem.name)
    if lns_from is not None and kind == "time_limit":
        cols = [opt._pyomo_var_to_solver_var_map[id(m.x[j])] for j in m.J]
        best = _lns(problem, opt._solver_model, np.asarray(cols), best, deadline, rng, stats)
    return kind, best, None if raw is None or not math.isfinite(raw) else raw


#: Share of the time left that HiGHS gets before :func:`_lns` (its bound is the result's).
HIGHS_SHARE = 0.25
#: Seconds one sub-MIP of :func:`_lns` may take, and the number of images it frees first.
LNS_SUB_S, LNS_FREE = 3.0, 100


def _lns(
    problem: Spot5, h: Any, cols: np.ndarray, best: np.ndarray, deadline: float,
    rng: np.random.Generator, stats: dict,
) -> np.ndarray:  # fmt: skip
    """Large neighbourhood search on the model HiGHS holds (``h``, node j in column
    ``cols[j]``, every row of the stage kept): from the assignment ``best``, free the images
    that a breadth-first search of the constraint graph reaches first from a random image
    (others at random when its component has fewer),
    fix every other node to its value, and solve that sub-MIP with ``best`` as its start.

    Its objective is ``w_j - e c_j`` with ``e = 1 / (2C)`` (``c_j`` the recorder units, C
    the capacity): every selection's penalty is below 1/2, so the sub-MIP's optimum (to an
    absolute gap of ``e / 2``) weighs the most and, among those, uses the fewest units. A
    sub-MIP's result replaces ``best`` when it weighs more, or as much with no more units:
    on the multi-orbit instances the recorder is full and the light images gain only from
    the units a cheaper way of taking the same weight frees, a plateau move. The number of
    images freed grows by 5 % after a sub-MIP proven in half its :data:`LNS_SUB_S` seconds
    and shrinks by 10 % after one that is not. The sub-MIPs' time limits make the result
    depend on the clock, as for ``milp-lns``.
    """
    import highspy

    off = node_offsets(problem)
    var = np.repeat(np.arange(problem.n), problem.size)
    weight = problem.weight[var].astype(float)
    units = problem.consumption[var, np.arange(len(var)) - off[var]].astype(float)
    e = 0.5 / max(problem.capacity or 1, 1)
    edges = np.concatenate([problem.pairs, problem.triples[:, :2], problem.triples[:, 1:]])
    graph = sp.coo_matrix((np.ones(len(edges)), edges.T), shape=(problem.n,) * 2).tocsr()
    x = np.zeros(len(var), dtype=bool)
    x[off[:-1][best >= 0] + best[best >= 0]] = True
    for name, value in {"output_flag": False, "mip_rel_gap": 0.0, "mip_abs_gap": e / 2}.items():
        h.setOptionValue(name, value)
    h.cbMipInterrupt += lambda event: stop_requested() and event.interrupt()
    c32 = cols.astype(np.int32)
    free, tries, gains = float(LNS_FREE), 0, 0
    while (left := deadline - time.perf_counter()) > 0.05 and not stop_requested():
        tries += 1
        open_ = np.zeros(problem.n, dtype=bool)
        near = breadth_first_order(graph, rng.integers(problem.n), False, False)[: int(free)]
        open_[near] = True  # and others at random if its component is smaller
        open_[rng.permutation(np.flatnonzero(~open_))[: int(free) - len(near)]] = True
        fixed = np.where(open_[var], -1.0, x)
        h.changeColsBounds(len(c32), c32, np.maximum(fixed, 0.0), np.where(fixed < 0, 1.0, fixed))
        noise = rng.random(len(var)) * 1e-4 / len(var)  # ties broken at random: a walk
        h.changeColsCost(len(c32), c32, weight - e * units + noise)
        sol, value = highspy.HighsSolution(), np.zeros(h.getNumCol())
        value[cols] = x
        sol.col_value, sol.value_valid = value.tolist(), True
        h.setSolution(sol)
        h.setOptionValue("time_limit", float(min(LNS_SUB_S, left)))
        t = time.perf_counter()
        h.run()
        proven = h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        if not proven:
            free = max(free * 0.9, 10.0)
        elif time.perf_counter() - t < LNS_SUB_S / 2:
            free = min(free * 1.05, problem.n)
        if int(h.getInfo().primal_solution_status) != 2:  # kSolutionStatusFeasible
            continue
        y = np.asarray(h.getSolution().col_value)[cols] > 0.5
        more = weight[y].sum() - weight[x].sum()
        if more > 0 or (more == 0 and units[y].sum() <= units[x].sum()):
            gains += int(more > 0)
            x = y
    stats.update(lns_tries=tries, lns_gains=gains)
    out = np.full(problem.n, -1, dtype=np.int64)
    on = np.flatnonzero(x)
    out[var[on]] = on - off[var[on]]
    return out


#: Share of the time limit the heavy images' stage of the lexicographic solve may take.
HEAVY_SHARE = 0.5


def solve_spot5_milp(
    problem: Spot5,
    time_limit: float | None = 60.0,
    *,
    start: np.ndarray | None = None,
    cliques: bool = True,
    threads: int | None = None,
    mip_gap: float = 0.0,
    lexicographic: bool = True,
    lns: bool = True,
    rng: np.random.Generator | None = None,
) -> Spot5Result:
    """Solve the integer program with HiGHS within ``time_limit`` (build included).

    With a weight split ``T`` (:func:`weight_split`) and ``lexicographic``, in two stages:
    first the heavy images alone (their subproblem, until proven or :data:`HEAVY_SHARE` of
    the limit), value ``H``, bound ``H̄`` (a multiple of ``g``); then every image with the
    row ``H <= heavy(x) <= H̄`` (valid on both sides; once the heavy stage is proven it fixes
    the heavy weight, which tightens the LP). With ``L`` the lights' total and ``B`` the
    second stage's bound, the optimum is at most ``min(H̄ + L, max(B, H - g + L))``: a
    selection either satisfies the row or weighs at most ``H - g + L``. Once ``H̄ = H`` that
    is ``B``. On the multi-orbit instances HiGHS finds the heavy part much sooner alone
    (1407: 176,000 in 120 s against 174,000 in 300 s for the whole model).

    Parameters
    ----------
    problem
        The instance.
    time_limit
        Wall seconds for building and solving (None: no limit).
    start
        A feasible assignment (positions, -1 unselected) given to HiGHS as a MIP start; the
        result is never worse than it.
    cliques
        Clique rows (default) or the plain pairwise formulation.
    threads, mip_gap
        HiGHS options.
    lexicographic
        The two stages when the weights split (default).
    lns
        The last HiGHS run gets :data:`HIGHS_SHARE` of the time left and, unless it proves
        the optimum, :func:`_lns` the rest (default); False: HiGHS all of it.
    rng
        The large neighbourhood search's generator (None: seeded 0).

    Returns
    -------
    Spot5Result
        ``status`` optimal when the bound is proven equal to the value, ``bound`` rounded
        down (weights are integers), never below the value.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    deadline = None if time_limit is None else t0 + time_limit
    split = weight_split(problem) if lexicographic else None
    if lns and rng is None:
        rng = np.random.default_rng(0)
    rng = rng if lns else None
    m = build_spot5_model(problem, cliques=cliques)
    stats: dict[str, Any] = {"build_s": round(time.perf_counter() - t0, 3)}
    stats["cliques"] = m.cliques_count
    if split is None:
        kind, best, raw = _milp_stage(problem, m, deadline, start, stats, threads, mip_gap, rng)
        bound = None if raw is None else math.floor(raw + 1e-6)
    else:
        heavy = problem.weight >= split
        g = int(np.gcd.reduce(problem.weight[heavy]))
        light = int(problem.weight[~heavy].sum())
        share = None if time_limit is None else HEAVY_SHARE * time_limit - stats["build_s"]
        r1 = solve_spot5_milp(
            problem.subproblem(np.flatnonzero(heavy)), share,
            start=None if start is None else start[heavy], cliques=cliques, threads=threads,
            mip_gap=mip_gap, lexicographic=False, lns=False,
        )  # fmt: skip
        best1 = np.full(problem.n, -1, dtype=np.int64)
        best1[heavy] = r1.assignment
        h = r1.value
        h_bound = int(problem.weight[heavy].sum()) if r1.bound is None else r1.bound // g * g
        stats.update(heavy_value=h, heavy_bound=h_bound, heavy_s=round(r1.time_s, 3))
        var = np.repeat(np.arange(problem.n), problem.size)
        w = problem.weight[var]
        heavy_weight = pyo.quicksum(int(w[j]) * m.x[int(j)] for j in np.flatnonzero(heavy[var]))
        m.heavy = pyo.Constraint(expr=pyo.inequality(h, heavy_weight, h_bound))
        keep = start is not None and problem.profit(np.where(heavy, start, -1)) >= h
        second = start if keep and problem.profit(start) > h else best1
        kind, best, raw = _milp_stage(problem, m, deadline, second, stats, threads, mip_gap, rng)
        b2 = h_bound + light if raw is None else math.floor(raw + 1e-6)
        bound = min(h_bound + light, max(b2, h - g + light))
    value = problem.profit(best)
    bound = None if bound is None else max(bound, value)
    status = "optimal" if bound is not None and bound <= value else kind
    return Spot5Result(
        "milp", best, value, bound, status, time.perf_counter() - t0,
        time.process_time() - c0, stats,
    )  # fmt: skip


def spot5_bound(
    problem: Spot5, time_limit: float | None = 60.0, *, cliques: bool = True
) -> dict[str, Any]:
    """The LP relaxation's bound: the clique LP (default) or the plain LP (``cliques=False``).

    Returns
    -------
    dict
        ``bound`` (rounded down, weights are integers), ``lp`` (the LP's optimum), ``time_s``,
        ``rows`` and ``cliques``.
    """
    t0 = time.perf_counter()
    m = build_spot5_model(problem, cliques=cliques, relax=True, cover=False)
    stats: dict[str, Any] = {}
    deadline = None if time_limit is None else t0 + time_limit
    kind, value, raw, _ = run_appsi(m, deadline, stats=stats)
    lp = value if kind == "optimal" else raw
    return {
        "bound": None if lp is None else math.floor(lp + 1e-6),
        "lp": lp,
        "status": kind,
        "time_s": time.perf_counter() - t0,
        "rows": stats.get("constraints"),
        "cliques": m.cliques_count if cliques else 0,
    }
