"""Ant colony optimisation over static cluster-tasks: ACO-STC and ACO-LS-STC (paper, 6.3).

The paper compares ASA-DTC with the ant colony optimisation of its ref. [10] (Wu, Liu, Ma and
Qiu, "A two-phase scheduling method with the consideration of task clustering for earth
observing satellites", Computers & Operations Research 2013) over static cluster-tasks, with
its local search (ACO-LS-STC, Tables 3-4) and without it (ACO-STC, Fig. 2). Ref. [10] builds
an acyclic directed graph over the cluster-tasks and lets ants find paths in it with a
MAX-MIN Ant System (Stutzle and Hoos, 2000). ``docs/baselines.md`` says what is taken from the
references and what sosp had to choose; in short:

Construction graph
    one acyclic directed graph per orbit: a source node, then the orbit's usable cluster-tasks
    (:class:`heuristics.stc.StcData`) in start order; an arc u -> v when v starts after u and
    may follow it by (3) (:func:`sosp.rules.may_precede` on their interval ends). An ant walks
    the orbits in a random order; on each it starts at the source and repeatedly moves to a
    successor of its current node, i.e. schedules it; a successor is a candidate when it
    still earns something (some target not covered yet); the drawn candidate must also fit
    the orbit's knapsacks, energy (4), memory (5) and openings (6)
    (:class:`heuristics.timeline.OrbitTimeline`). Only the first ``candidates`` earning
    successors in start order are considered (a candidate list); the walk ends when none
    is left.
Choice
    pseudo-random proportional rule: with probability ``q0`` the candidate maximising
    ``tau(u, v)^alpha * eta(u, v)^beta``, else one drawn with probability proportional to it.
    The heuristic information is what v earns over what taking it loses,
    ``eta(u, v) = g_v / loss(u, v)`` (:func:`loss_eta`): g_v the weight of v's uncovered
    targets, loss(u, v) the gain of every earning successor of u that can no longer follow
    once v is taken, v's own included (the GWMIN2 ratio of greedy maximum-weight independent
    set). On a path everything skipped or blocked is lost for good, and on the paper's
    scenarios (3) is what binds (``docs/baselines.md``), so the lost gain prices a choice.
    ``heuristic = "resource"`` keeps the former ``g_v / (cost_v + gap_weight * gap / H)``.
Pheromone (MAX-MIN Ant System)
    one value per arc, initialised to tau_max. After each iteration every trail evaporates,
    ``tau <- (1 - rho) tau``, then the iteration-best ant (every ``gb_every``-th iteration the
    best so far) deposits ``f(s) / f(s_best)`` on the arcs of its paths, and every trail is
    clamped to [tau_min, tau_max] with ``tau_max = 1 / rho`` (the limit of a trail reinforced
    by the best schedule each time) and ``tau_min = tau_max (1 - p_dec) / ((avg - 1) p_dec)``,
    ``p_dec = p_best^(1/n)``, n the arcs of the best schedule and avg = candidates / 2. After
    ``restart`` iterations without a new best the trails are reset to tau_max.
Local search (ACO-LS-STC)
    applied to the iteration-best ant before the update (Lamarckian: its improved paths
    deposit): first-improvement exchange moves, :func:`local_search`.
Stopping
    after ``iterations`` colony iterations (default: none with a time limit, else
    :data:`DEFAULT_ITERATIONS`), at ``time_limit``, or on a stop request
    (:mod:`sosp.stop`, checked after each ant, which also reports progress); the rng passed
    in is the only randomness, so the same seed and iterations give the same schedule.
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np

from heuristics.hpfs import task_result
from heuristics.stc import Selection, StcData, Watch, at_least, check_float, stc_data
from sosp import rules
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.result import Result
from sosp.rules import RollRule
from sosp.stop import Budget

log = logging.getLogger(__name__)


#: Colony iterations when neither ``iterations`` nor a time limit is given.
DEFAULT_ITERATIONS = 200

#: Orbits with at most this many usable tasks keep their successor matrix ((m + 1) x m
#: booleans, 4 MB at the limit); larger ones compute the rows an ant asks for.
DENSE_TASKS = 2048


@dataclass(frozen=True)
class ACOParams(Params):
    """Parameters of ACO-STC (MAX-MIN Ant System defaults without local search).

    Parameters
    ----------
    ants
        Ants per iteration (MMAS uses one per city on the TSP, 10 with local search; here 10
        so that short runs do enough iterations for the trails to learn,
        ``docs/baselines.md``).
    alpha
        Weight of the pheromone in the choice rule (MMAS: 1).
    beta
        Weight of the heuristic information in the choice rule (MMAS: 2).
    rho
        Evaporation rate (MMAS: 0.02 for long runs without local search, 0.2 with it; 0.2
        here, as the colony gets tens of iterations at the paper's time limits).
    p_best
        Probability that an ant at convergence builds the best schedule, which sets tau_min
        (MMAS: 0.05).
    gb_every
        Every this many iterations the best schedule so far deposits instead of the
        iteration's best (MMAS alternates the two; 0: never).
    restart
        Reset every trail to tau_max after this many iterations without a new best (MMAS's
        re-initialisation; 0: never).
    candidates
        Successors an ant considers at each step (candidate list), the first that fit.
    q0
        Pseudo-random proportional rule (Dorigo and Gambardella's ACS, 0.9 there): with this
        probability an ant takes the best-rated candidate instead of drawing (0: MMAS's
        random proportional rule alone).
    heuristic
        Heuristic information: ``"loss"``, a candidate's gain over the gain of the earning
        successors it makes unreachable (:func:`loss_eta`), or ``"resource"``, the former
        gain over resource share plus weighted idle time (:func:`resource_eta`).
    gap_weight
        Weight of the idle time skipped in the ``"resource"`` heuristic information
        (``docs/baselines.md``: 1, 3, 10, 30 measured); unused by ``"loss"``.
    iterations
        Colony iterations (each: ``ants`` constructions, then the update); None: until the
        time limit, or :data:`DEFAULT_ITERATIONS` when there is none.
    local_search
        Apply :func:`local_search` to the iteration-best ant (ACO-LS-STC).
    ls_passes
        Most passes of the local search over the unscheduled tasks.
    roll_rule
        Roll of multi-opportunity cluster-tasks: ``"midpoint"`` (9) or ``"nadir"``.
    """

    ants: int = param(10, "Ants per iteration (docs/baselines.md).")
    alpha: float = param(1.0, "Weight of the pheromone in the choice rule (MMAS: 1).")
    beta: float = param(2.0, "Weight of the heuristic information in the choice rule (MMAS: 2).")
    rho: float = param(0.2, "Evaporation rate (MMAS: 0.02, 0.2 with local search).")
    p_best: float = param(0.05, "Probability of building the best at convergence (tau_min).")
    gb_every: int = param(10, "Iterations between deposits of the best so far (0: never).")
    restart: int = param(250, "Reset the trails after this many idle iterations (0: never).")
    candidates: int = param(20, "Successors an ant considers at each step.")
    q0: float = param(0.9, "Probability of taking the best-rated candidate (ACS).")
    heuristic: Literal["loss", "resource"] = param("loss", "Heuristic information.")
    gap_weight: float = param(10.0, "Weight of idle time in the 'resource' heuristic.")
    iterations: int | None = param(None, "Colony iterations (None: to the time limit).")
    local_search: bool = param(False, "Apply local_search to the iteration-best ant (ACO-LS-STC).")
    ls_passes: int = param(10, "Most passes of the local search over the unscheduled tasks.")
    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")

    def check(self) -> None:
        at_least(self, ants=1, gb_every=0, restart=0, candidates=1, ls_passes=1, iterations=0)
        floats = {"alpha": (0, 100), "beta": (0, 100), "q0": (0, 1), "gap_weight": (0, 1e6)}
        for name, (lo, hi) in floats.items():
            check_float(name, getattr(self, name), lo, hi)
        for name in ("rho", "p_best"):
            check_float(name, getattr(self, name), 0.0, 1.0, lo_open=True)
        if self.p_best >= 1.0:
            raise InputError(f"p_best: must lie in (0, 1), got {self.p_best!r}")


@dataclass(frozen=True)
class ACOLSParams(ACOParams):
    """Parameters of ACO-LS-STC: MAX-MIN Ant System with local search (:class:`ACOParams`
    with these defaults)."""

    ants: int = param(10, "Ants per iteration (MMAS with local search: 10).")
    rho: float = param(0.2, "Evaporation rate (MMAS with local search: 0.2).")
    q0: float = param(0.0, "Probability of taking the best-rated candidate.")
    local_search: bool = param(True, "Apply local_search to the iteration-best ant.")


# ----------------------------------------------------------------------------- the graph
class Graph:
    """The per-orbit construction graphs: node indices and their pheromone matrices.

    For orbit j with m usable tasks, ``tau[j]`` has shape (m + 1, m): row 0 is the source,
    row i + 1 the task of local index i; column v the arc's head (local index v).
    """

    def __init__(self, data: StcData) -> None:
        self.data = data
        self.orbits = sorted(data.orbit_tasks)
        inst, tasks_of = data.instance, data.orbit_tasks
        self.local = np.full(len(data.tasks), -1, dtype=np.int64)
        for j in self.orbits:
            self.local[tasks_of[j]] = np.arange(len(tasks_of[j]))
        span = {j: float(inst.orbit_end[j] - inst.orbit_start[j]) for j in self.orbits}
        self.horizon = {j: max(s, 1e-9) for j, s in span.items()}
        self.origin = {j: float(inst.orbit_start[j]) for j in self.orbits}
        self.tau = {j: np.ones((len(tasks_of[j]) + 1, len(tasks_of[j]))) for j in self.orbits}
        self.left = {j: data.left[tasks_of[j]] for j in self.orbits}
        self.right = {j: data.right[tasks_of[j]] for j in self.orbits}
        # per orbit, the successor matrix of its graph (row 0 the source, row v + 1 task v),
        # kept when small enough (:data:`DENSE_TASKS`), else rows are computed when asked
        self._succ = {
            j: self._rows(j, np.arange(len(t))) if len(t) - 1 <= DENSE_TASKS else None
            for j, t in self.tau.items()
        }
        #: per task, its weight (its gain while no target is covered), as floats
        self.weight = np.asarray(data.tasks.weight, dtype=np.float64)
        covering = data.target_tasks
        #: per target, the tasks covering it (whose gain drops when it gets covered)
        self.covering = [
            np.asarray(covering.get(k, ()), dtype=np.int64) for k in range(data.instance.n_targets)
        ]

    def _rows(self, j: int, rows: np.ndarray) -> np.ndarray:
        """Rows of orbit ``j``'s successor matrix, computed: v follows u when it comes later
        in start order and (3) allows it (:func:`sosp.rules.may_precede` on ``R_u``, ``L_v``)."""
        lft, rgt = self.left[j], self.right[j]
        m = len(lft)
        col = np.arange(m)
        tail = rows[:, None] - 1  # task index of each row (-1: the source)
        ends = np.where(rows > 0, rgt[np.maximum(rows - 1, 0)], -np.inf)
        return (col[None, :] > tail) & rules.may_precede(ends[:, None], lft[None, :])

    def successors(self, j: int, rows: int | np.ndarray) -> np.ndarray:
        """Which tasks of orbit ``j`` may follow the node(s) ``rows`` (0: the source, every
        task; v + 1: local task v), as a boolean row (or one row per entry of ``rows``)."""
        mat = self._succ[j]
        if mat is not None:
            return mat[rows]
        out = self._rows(j, np.atleast_1d(np.asarray(rows, dtype=np.int64)))
        return out[0] if np.ndim(rows) == 0 else out

    def reset(self, value: float) -> None:
        """Set every trail to ``value``."""
        for mat in self.tau.values():
            mat.fill(value)

    def arcs(self, sol: Selection) -> list[tuple[int, int, int]]:
        """The arcs (orbit, row, column) of a selection's paths: source, then time order."""
        out = []
        for j in self.orbits:
            row = 0
            for t in sol.path(j):
                col = int(self.local[t])
                out.append((j, row, col))
                row = col + 1
        return out


def update_pheromone(
    tau: dict[int, np.ndarray],
    arcs: list[tuple[int, int, int]],
    amount: float,
    rho: float,
    tau_min: float,
    tau_max: float,
) -> None:
    """MMAS update: evaporate every trail by ``rho``, deposit ``amount`` on ``arcs``, clamp.

    ``tau <- (1 - rho) tau`` everywhere, ``+ amount`` on each arc of the depositing schedule,
    then every trail is clamped to ``[tau_min, tau_max]``.
    """
    for mat in tau.values():
        mat *= 1.0 - rho
    for j, row, col in arcs:
        tau[j][row, col] += amount
    for mat in tau.values():
        np.clip(mat, tau_min, tau_max, out=mat)


def tau_bounds(rho: float, p_best: float, n_arcs: int, candidates: int) -> tuple[float, float]:
    """MMAS trail limits for deposits normalised to at most 1: ``(tau_min, tau_max)``.

    ``tau_max = 1 / rho``; ``tau_min = tau_max (1 - p_dec) / ((avg - 1) p_dec)`` with
    ``p_dec = p_best^(1/n)``, n = ``n_arcs`` decisions and avg = ``candidates / 2`` choices
    per decision (at least 2); never above tau_max.
    """
    tau_max = 1.0 / rho
    n = max(1, n_arcs)
    avg = max(2.0, candidates / 2.0)
    p_dec = p_best ** (1.0 / n)
    tau_min = tau_max * (1.0 - p_dec) / ((avg - 1.0) * p_dec)
    return min(tau_min, tau_max), tau_max


# ---------------------------------------------------------------------------- construction
def loss_eta(gains: np.ndarray, cand: np.ndarray, follows: np.ndarray) -> np.ndarray:
    """Heuristic information ``eta(u, v) = g_v / loss(u, v)`` of the candidates v.

    Taking v ends the path's chance at every earning successor of the current node u that
    cannot follow v by (3): ``loss(u, v)`` is their gain, v's own included (v does not follow
    itself), so ``eta`` lies in (0, 1] and is 1 when v blocks nothing that earns. This is
    the ratio of the GWMIN2 greedy for the maximum-weight independent set (a vertex's weight
    over that of its closed neighbourhood; Sakai, Togasaki and Yamazaki 2003), with the
    neighbourhood taken as what the path loses: the time a task occupies, the idle time
    skipped before it and the setup and slew (3) it needs are all priced by the earning tasks
    they exclude.

    Parameters
    ----------
    gains
        Per local index of the orbit, the gain g (weight of the uncovered targets, (1)) of
        u's successors, 0 for every task that is not one or earns nothing.
    cand
        Local indices of the candidates (each with a positive gain).
    follows
        Boolean, one row per candidate v: which local indices may follow v
        (:meth:`Graph.successors`).

    Returns
    -------
    numpy.ndarray
        ``eta`` of ``cand``.
    """
    loss = float(gains.sum()) - follows @ gains
    return gains[cand] / loss


def resource_eta(
    gains: np.ndarray, cost: np.ndarray, gap: np.ndarray, gap_weight: float
) -> np.ndarray:
    """The former heuristic information ``g_v / (cost_v + gap_weight * gap(u, v) / H)``.

    ``cost`` the candidates' :func:`heuristics.stc.resource_cost`, ``gap`` the idle time
    between u's and v's (3) intervals over the orbit length H (``heuristic = "resource"``).
    """
    return gains / (cost + gap_weight * gap)


def construct(graph: Graph, p: ACOParams, rng: np.random.Generator) -> Selection:
    """One ant's schedule: a path per orbit (random orbit order), see the module docstring.

    The successors of the current node that earn something are found on the whole orbit at
    once ((3) by :func:`sosp.rules.may_precede`, gains kept per task and lowered as targets
    get covered); the first ``candidates`` of them are rated (:func:`loss_eta`). The drawn
    one is then checked against the knapsacks (4)-(6) by the orbit's timeline, and a
    candidate that does not fit is removed and the choice made again among the others (the
    same distribution as drawing among the fitting candidates only, with one timeline check
    per step instead of one per candidate).
    """
    data = graph.data
    sol = Selection(data)
    weight, targets, cover, covering = data.weight, data.targets, sol.cover, graph.covering
    gain = graph.weight.copy()  # per task: weight of its targets not covered yet
    loss_rule = p.heuristic == "loss"
    alpha, beta = p.alpha, p.beta
    for oi in rng.permutation(len(graph.orbits)):
        j = graph.orbits[int(oi)]
        idx, lft, rgt = data.orbit_tasks[j], graph.left[j], graph.right[j]
        mat = graph.tau[j]
        line = sol.lines[j]
        openings = line.rules.max_openings
        u = -1
        r_u = graph.origin[j]
        while len(line) < openings:
            # gains of u's successors (0 for the others): the earning ones are the choices
            gs = gain[idx] * graph.successors(j, u + 1)
            cand = gs.nonzero()[0][: p.candidates]
            if not len(cand):
                break
            if loss_rule:
                eta = loss_eta(gs, cand, graph.successors(j, cand + 1))
            else:
                gap = np.maximum(0.0, lft[cand] - r_u) / graph.horizon[j]
                eta = resource_eta(gs[cand], data.cost[idx[cand]], gap, p.gap_weight)
            w = mat[u + 1, cand] ** alpha * eta**beta
            cand_list = cand.tolist()
            chk = None
            while cand_list:
                if p.q0 > 0 and rng.random() < p.q0:
                    i = int(w.argmax())
                else:
                    cum = np.cumsum(w)
                    i = int(np.searchsorted(cum, rng.random() * cum[-1], side="right"))
                    i = min(i, len(cand_list) - 1)
                chk = sol.check(int(idx[cand_list[i]]))
                if chk.ok:
                    break
                del cand_list[i]
                w = np.delete(w, i)
            if not cand_list or chk is None or not chk.ok:
                break
            v = cand_list[i]
            t = int(idx[v])
            for k in targets[t]:
                if cover[k] == 0:  # k becomes covered: no task earns its weight any more
                    gain[covering[k]] -= weight[k]
            sol.add(t, chk)
            u, r_u = v, float(rgt[v])
    sol.commit()
    return sol


# ---------------------------------------------------------------------------- local search
def exchange(sol: Selection, x: int, rank: np.ndarray) -> bool:
    """Try to schedule the unscheduled task ``x`` by taking out what blocks it.

    The chosen tasks of x's orbit in (3) conflict with x are removed; while x still breaks
    (4)-(6), the chosen task of the orbit that loses least is removed too (while the loss is
    below x's weight). If x then fits it is added and the freed room is refilled with
    unscheduled tasks (of the orbit, and any covering a target the move uncovered) by
    decreasing utility. The move is kept only when the profit rises; else it is undone.

    Returns
    -------
    bool
        Whether the move was kept.
    """
    data = sol.data
    j = int(data.tasks.orbit[x])
    line = sol.lines[j]
    before = sol.profit
    mark = sol.mark()
    lx, rx = float(data.left[x]), float(data.right[x])
    removed = [
        t
        for t in sol.path(j)
        if not (rules.may_precede(data.right[t], lx) or rules.may_precede(rx, data.left[t]))
    ]
    for t in removed:
        sol.remove(t)
    chk = sol.check(x)
    limit = int(data.tasks.weight[x])
    while not chk.ok and chk.reason in ("4", "5", "6") and line.obs:
        if before - sol.profit >= limit:
            break
        y = min(sol.path(j), key=lambda t: (sol.loss(t), data.utility[t]))
        sol.remove(y)
        removed.append(y)
        chk = sol.check(x)
    if chk.ok and sol.gain(x) > 0:
        sol.add(x, chk)
        refill = set(int(t) for t in data.orbit_tasks[j])
        for t in removed:
            for k in data.targets[t]:
                if sol.cover[k] == 0:
                    refill.update(u for u in data.target_tasks[k] if data.position[u] >= 0)
        sol.fill(sorted(refill, key=lambda t: rank[t]))
    if sol.profit > before:
        return True
    sol.undo(mark)
    return False


def local_search(sol: Selection, max_passes: int, budget: Budget | None = None) -> int:
    """First-improvement local search with :func:`exchange` moves; returns moves kept.

    Each pass first adds every task that fits (by decreasing utility), then tries an exchange
    for each unscheduled task that would earn something, by decreasing utility, keeping every
    improving move. Stops after a pass with no improvement, ``max_passes`` passes, or once
    ``budget`` expires (None: no limit).
    """
    data = sol.data
    rank = np.empty(len(data.tasks), dtype=np.int64)
    rank[data.by_utility] = np.arange(len(data.by_utility))
    kept = 0
    for _ in range(max_passes):
        sol.fill(data.by_utility)
        sol.commit()
        improved = False
        for x in data.by_utility:
            x = int(x)
            if x in sol.chosen or sol.gain(x) <= 0:
                continue
            if exchange(sol, x, rank):
                kept += 1
                improved = True
                sol.commit()
            if budget is not None and budget.expired():
                return kept
        if not improved:
            break
    return kept


# ----------------------------------------------------------------------------------- solve
def run_aco(
    instance: Instance,
    p: ACOParams,
    rng: np.random.Generator,
    time_limit: float | None,
    method: str,
) -> Result:
    """The MAX-MIN ant colony over static cluster-tasks (module docstring)."""
    watch = Watch(time_limit)
    data = stc_data(instance, p.roll_rule)
    graph = Graph(data)
    tau_min, tau_max = tau_bounds(p.rho, p.p_best, 1, p.candidates)
    graph.reset(tau_max)
    best: Selection | None = None
    best_profit, best_iter, since, restarts, ls_moves = -1, 0, 0, 0, 0
    it = 0
    stop = False
    max_iterations = watch.limit(p.iterations, DEFAULT_ITERATIONS)
    while it < max_iterations and graph.orbits and not stop:
        it += 1
        iter_best: Selection | None = None
        for _ in range(p.ants):
            ant = construct(graph, p, rng)
            if iter_best is None or ant.profit > iter_best.profit:
                iter_best = ant
            if watch(it, float(max(best_profit, iter_best.profit)), since):
                stop = True
                break
        assert iter_best is not None
        if p.local_search and not stop:
            ls_moves += local_search(iter_best, p.ls_passes, watch.budget)
        if iter_best.profit > best_profit:
            best, best_profit, best_iter, since = iter_best, iter_best.profit, it, 0
            tau_min, tau_max = tau_bounds(p.rho, p.p_best, len(best.chosen), p.candidates)
        else:
            since += 1
        if stop:
            break
        if p.restart and since >= p.restart:
            graph.reset(tau_max)
            restarts += 1
            since = 0
            continue
        depositor = best if (p.gb_every and it % p.gb_every == 0) else iter_best
        assert depositor is not None and best is not None
        amount = depositor.profit / best_profit if best_profit > 0 else 1.0
        update_pheromone(graph.tau, graph.arcs(depositor), amount, p.rho, tau_min, tau_max)
    chosen = sorted(best.chosen) if best is not None else []
    profit = max(best_profit, 0)
    stats = {
        "tasks": len(data.tasks),
        "usable_tasks": len(data.usable),
        "best_iteration": best_iter,
        "restarts": restarts,
        "tau_min": tau_min,
        "tau_max": tau_max,
        "params": asdict(p),
    }
    if p.local_search:
        stats["ls_moves"] = ls_moves
    log.info("%s: profit %d after %d iterations (best at %d)", method, profit, it, best_iter)
    return task_result(method, instance, data.tasks, chosen, profit, iterations=it, stats=stats)


def solve_aco_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """ACO-STC: MAX-MIN ant colony over static cluster-tasks, no local search.

    Parameters
    ----------
    instance
        The problem.
    rng
        The only source of randomness.
    time_limit
        Wall-time limit in seconds (None: stop after ``iterations``).
    **params
        Fields of :class:`ACOParams`.

    Returns
    -------
    Result
        Status ``feasible``; ``iterations`` colony iterations done; ``stats`` holds the
        iteration of the best schedule, restarts and the trail limits.
    """
    p = from_kwargs(ACOParams, params, method="aco-stc")
    return run_aco(instance, p, rng, time_limit, "aco-stc")


def solve_aco_ls_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """ACO-LS-STC: MAX-MIN ant colony with local search over static cluster-tasks.

    Parameters
    ----------
    instance
        The problem.
    rng
        The only source of randomness.
    time_limit
        Wall-time limit in seconds (None: stop after ``iterations``).
    **params
        Fields of :class:`ACOLSParams`.

    Returns
    -------
    Result
        As :func:`solve_aco_stc`, with ``stats["ls_moves"]``, the improving moves kept.
    """
    p = from_kwargs(ACOLSParams, params, method="aco-ls-stc")
    return run_aco(instance, p, rng, time_limit, "aco-ls-stc")
