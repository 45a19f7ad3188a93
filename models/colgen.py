"""Upper bound by column generation (Dantzig-Wolfe) over orbit plans, priced by the planner.

The Lagrangian dual that :func:`models.lagrangian.lagrangian_bound` approaches by subgradient
steps is the linear programme of the Dantzig-Wolfe reformulation of the cluster model: one
column per plan of one orbit under (3) and (6) (its covered targets, its energy (4) and memory
(5)), per orbit a convexity row and the two knapsack rows (4)-(5) over the plans' usages, per
target ``z_k <= sum of the plans covering k`` and ``z_k <= 1``. Its duals are the multipliers:
``mu_k`` of the coverage rows, ``lam_j`` of the knapsacks. Column generation solves it exactly
with a small restricted master (HiGHS) and the exact single-orbit planner
(:func:`sosp.planner.best_path`) as pricing, where subgradient steps only creep towards it.

Every pricing round, at any multipliers ``mu >= 0``, ``lam >= 0``, gives the valid upper bound

    L(mu, lam) = sum_k max(0, p_k - mu_k)
                 + sum_j [ max over plans of orbit j under (3), (6) of
                           sum_u (mu(targets of u) - penalties of u) + lam_ej + lam_wj ]

(the bound of ``lagrangian_bound``); the least one found is returned. The duals are smoothed
(Wentges): each round prices at a point between the duals of the best bound so far and the
master's, which damps the oscillation of plain column generation.
"""

from __future__ import annotations

import heapq
import logging
import math
import os
import time
from collections.abc import Callable, Sequence
from contextlib import closing
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from models.lagrangian import capped_bound, check_count, seen_weights
from models.subset_row import CUTS_PER_ROUND, CutPool, cut_levels
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.parallel import Child, ChildStartError, child_setup
from sosp.planner import OrbitData, PlanPool, best_path, flat_positions, orbit_data
from sosp.rules import OrbitRules
from sosp.stop import Budget, stop_requested

if TYPE_CHECKING:
    from sosp.parallel import Workers

log = logging.getLogger(__name__)

#: Weight of the best-bound duals in the pricing point (Wentges smoothing). 0 is plain column
#: generation (pricing at the master's duals); 0.3-0.7 took about a third fewer rounds to
#: converge than 0, and more than 0.7 as many as 0 again.
SMOOTHING = 0.5

#: A column enters the master when its reduced cost at the master's duals exceeds this.
_RC_TOL = 1e-7

#: Subset-row cut separation rounds (100 cuts each at most) at the branch and price's root
#: (:func:`branch_and_price`) of a run shorter than :data:`LONG_RUN_S`: each round lowers the
#: root but slows every node's pricing; 3 gave the lowest bounds at 60 s (the measurements:
#: ``CHANGELOG.md``, "Subset-row cuts in the branch and price").
CUT_ROUNDS = 3

#: Root rounds of a run of at least :data:`LONG_RUN_S` seconds, or of no time limit: on
#: 600 s runs 5 rounds gave lower bounds than 3 on most C scenarios and as low as 10.
LONG_CUT_ROUNDS = 5

#: See :data:`LONG_CUT_ROUNDS` (between the 60 s and the 600 s runs it was chosen on).
LONG_RUN_S = 300.0


def root_cut_rounds(time_limit: float | None) -> int:
    """The branch and price's default root cut rounds for a run of ``time_limit`` seconds:
    more cuts lower the root, but each round slows every node's pricing, which pays only on
    long runs (:data:`CUT_ROUNDS`, :data:`LONG_CUT_ROUNDS`)."""
    long = time_limit is None or float(time_limit) >= LONG_RUN_S
    return LONG_CUT_ROUNDS if long else CUT_ROUNDS


#: Separation rounds in each node below the root (the cuts hold for every schedule, so one
#: found in a node joins the pool every later node keeps), and the cuts each adds at most.
NODE_CUT_ROUNDS = 0
NODE_CUTS = 20

#: Branching candidates evaluated on the restricted master of each node the search branches
#: on (strong branching, :func:`_strong_pick`; 0: the heaviest fractional pair,
#: :func:`_candidates`). 5 gave lower bounds after 300 s than 0 or 10.
STRONG_CANDIDATES = 5

#: HiGHS's primal simplex (``simplex_strategy``), the restricted masters' (:class:`_Master`).
_MASTER_SIMPLEX = 4

#: Dual simplex for the strong branching's solves: a child's changed coefficients leave the
#: node's basis neither primal nor dual feasible, and from there the primal simplex took up
#: to twenty times the dual's iterations.
_STRONG_SIMPLEX = 1


def allow_seconds(h: Any, seconds: float | None) -> None:
    """Let the next ``h.run()`` take ``seconds`` (None: no limit).

    HiGHS compares its ``time_limit`` with the solver object's run clock, which adds up over
    every ``run()`` of that object: a master solved again after more than the time left
    worth of earlier solves stopped at once ("time limit reached", no iteration), and the
    column generation ended there as if out of time (G100k: the third master, after 169 s
    of solves, with 142 s left). So the limit is the clock so far plus ``seconds``.
    """
    if seconds is None:
        h.setOptionValue("time_limit", math.inf)
    else:
        h.setOptionValue("time_limit", float(h.getRunTime()) + max(float(seconds), 1e-3))


def _caps(rules: Sequence[OrbitRules]) -> np.ndarray:
    """Each orbit's energy and memory capacities (orbits x 2)."""
    caps = [(r.energy_capacity, r.memory_capacity) for r in rules]
    return np.array(caps, dtype=float).reshape(-1, 2)


class _Master:
    """A restricted master LP (minimising ``-sum p_k z_k``, so HiGHS's duals of the ``<=``
    rows are <= 0 and the multipliers are their negatives), solved again after every round
    of new columns: the root's (:func:`column_generation`) or a node's (:func:`_solve_node`,
    which adds ``forced``, ``banned`` and cut rows).

    Rows: per free target (seen and not forced) its coverage row ``z_k - sum_P n_kP y_P <=
    0`` over the plans whose orbit's cover of k counts (``n_kP``: how many of plan P's
    observations cover k, as the planner counts; not orbit g's where (k, g) is ``banned``),
    per target k forced to orbit g ``sum_{P of g} n_kP y_P + s_k >= 1``, then per orbit the
    convexity rows ``sum_P y_P <= 1`` and the knapsacks ``sum_P E_P y_P <= E_j``, ``sum_P M_P
    y_P <= W_j``, then the cut rows the caller adds. Columns: ``z_k`` in [0, 1] per free
    target, ``s_k >= 0`` per forced one (an artificial slack costing more than all weights,
    so the master is always feasible), then ``y_P >= 0`` (:attr:`columns`, from :attr:`base`).

    Primal simplex, presolve off: new columns leave the last basis primal feasible, so the
    re-solve starts from it (presolve would discard it). HiGHS's default dual simplex spends
    about three times the iterations per re-solve here. No ``threads`` option: HiGHS keeps
    one scheduler per process, and a solve asking for another count than it started with
    fails (:func:`models.highs_direct.use_threads`).
    """

    def __init__(
        self,
        p: np.ndarray,
        seen: np.ndarray,
        caps: np.ndarray,
        forced: dict[int, int] | None = None,
        banned: frozenset[tuple[int, int]] = frozenset(),
        links: Links | None = None,
    ) -> None:
        import highspy

        from models.highs_direct import new_highs

        inf = highspy.kHighsInf
        self.forced = {} if forced is None else forced
        self.free = np.flatnonzero(seen & ~np.isin(np.arange(len(p)), list(self.forced)))
        self.fk = np.array(sorted(self.forced), dtype=np.int64)
        nf, n_fk, self.n_orb = len(self.free), len(self.fk), len(caps)
        self.row_free = np.full(len(p), -1, dtype=np.int64)
        self.row_free[self.free] = np.arange(nf)
        self.row_forced = np.full(len(p), -1, dtype=np.int64)
        self.row_forced[self.fk] = nf + np.arange(n_fk)
        self.base = nf + n_fk  # the first orbit row, and the first plan's column
        self.banned_on: dict[int, list[int]] = {}
        for k, j in banned:
            self.banned_on.setdefault(j, []).append(k)
        self.h = h = new_highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("presolve", "off")
        h.setOptionValue("solver", "simplex")
        h.setOptionValue("simplex_strategy", _MASTER_SIMPLEX)
        lower = np.concatenate([np.full(nf, -inf), np.ones(n_fk), np.full(3 * self.n_orb, -inf)])
        upper = [np.zeros(nf), np.full(n_fk, inf), np.ones(self.n_orb), caps.T.ravel()]
        h.addRows(len(lower), lower, np.concatenate(upper), 0, [], [], [])
        # z_k, then s_k, each on its own row
        cost = np.concatenate([-p[self.free], np.full(n_fk, float(p.sum()) + 1.0)])
        top, at = np.concatenate([np.ones(nf), upper[1]]), np.arange(self.base, dtype=np.int32)
        h.addCols(self.base, cost, np.zeros(self.base), top, self.base, at, at, np.ones(self.base))
        # the store rows linking orbits (root only): sum over their orbits' plans of M_P y_P
        self.links = links
        self.n_links = 0 if links is None else len(links[1])
        if self.n_links:
            h.addRows(self.n_links, np.full(self.n_links, -inf), links[1], 0, [], [], [])
        self.keys: set[tuple[int, bytes, float, float]] = set()
        self.columns: list[tuple[int, np.ndarray, np.ndarray, float, float]] = []
        self.x = np.zeros(0)  # the columns' values at the last optimum

    def add(self, column: tuple[Any, ...], cut_rows: Any = (), cut_vals: Any = ()) -> None:
        """Add the plan ``column`` (orbit g, targets ``tg``, how many of its observations
        cover each, energy, memory) with its entries ``cut_vals`` in the rows ``cut_rows``."""
        g, tg, cnt, energy, memory = column
        counts = self.row_free[tg] >= 0
        if g in self.banned_on:
            counts &= ~np.isin(tg, self.banned_on[g])
        mine = np.array([self.forced.get(int(k)) == g for k in tg], dtype=bool)  # forced to g
        # its counted covers, its forced targets, its orbit's convexity and knapsack rows
        rows = [self.row_free[tg[counts]], self.row_forced[tg[mine]]]
        rows += [self.base + g + self.n_orb * np.arange(3), np.asarray(cut_rows, dtype=np.int64)]
        vals = [-cnt[counts], cnt[mine], np.array([1.0, energy, memory]), cut_vals]
        if self.n_links:
            on = np.flatnonzero(self.links[0][:, g])
            rows.append(self.base + 3 * self.n_orb + on)
            vals.append(np.full(len(on), memory))
        r, v = np.concatenate(rows).astype(np.int32), np.concatenate(vals)
        self.h.addCol(0.0, 0.0, np.inf, len(r), r, v)
        self.columns.append(column)

    def add_new(self, g: int, covered: np.ndarray, energy: float, memory: float) -> None:
        """:meth:`add` the plan of orbit ``g`` covering ``covered`` (targets with repeats)
        unless the master has it already (the root's)."""
        tg, cnt = np.unique(covered, return_counts=True)
        key = (g, tg.tobytes() + cnt.tobytes(), round(energy, 6), round(memory, 6))
        if key not in self.keys:
            self.keys.add(key)
            self.add((g, tg, cnt.astype(float), energy, memory))

    def solve(self, budget: Budget, retry: bool = False) -> bool:
        """Solve within ``budget``; False when HiGHS stops before the optimum (time limit).
        With ``retry``, a failed solve (from a basis given to HiGHS) is tried again from
        scratch."""
        import highspy

        h, optimal = self.h, highspy.HighsModelStatus.kOptimal
        allow_seconds(h, budget.left())
        h.run()
        if retry and h.getModelStatus() != optimal:
            h.clearSolver()  # not expected; then from scratch, as without a parent's basis
            allow_seconds(h, budget.left())
            h.run()
        if h.getModelStatus() != optimal:
            return False
        self.x = np.asarray(h.getSolution().col_value, dtype=float)
        return True

    def duals(self, p: np.ndarray, caps: np.ndarray) -> tuple[float, tuple[np.ndarray, ...]]:
        """At the last optimum: its value (a maximum, the forced weights included) and the
        multipliers ``(mu, beta, lam, conv, cut)``, all >= 0: per target of the instance the
        coverage duals (at most its weight) and the forcing ones, per orbit the knapsacks'
        per whole capacity (orbits x 2) and the convexity duals, per cut row its dual."""
        dual = np.asarray(self.h.getSolution().row_dual, dtype=float)
        value = -float(self.h.getInfo().objective_function_value) + float(p[self.fk].sum())
        nf, b, m = len(self.free), self.base, self.n_orb
        mu, beta = np.zeros(len(p)), np.zeros(len(p))
        mu[self.free] = np.clip(-dual[:nf], 0.0, p[self.free])
        beta[self.fk] = np.maximum(dual[nf:b], 0.0)
        out = np.maximum(-dual[b:], 0.0)
        lam = out[m : 3 * m].reshape(2, m).T * caps
        self.link_duals = out[3 * m : 3 * m + self.n_links]
        return value, (mu, beta, lam, out[:m], out[3 * m + self.n_links :])

    def plans(self) -> list[tuple[int, np.ndarray, float, float, float]]:
        """The plans positive at the last optimum: ``(orbit, covered targets, value, energy,
        memory)`` (a plan alone may exceed its orbit's (4)-(5): the knapsack rows hold for
        the mix)."""
        return [
            (g, tg, float(v), e, m)
            for (g, tg, _, e, m), v in zip(self.columns, self.x[self.base :], strict=False)
            if v > 1e-9
        ]


#: Every orbit's best plan at multipliers ``(mu, lam)`` before a deadline: per orbit ``(value,
#: covered targets with repeats, (energy, memory) or None for the empty plan)``, the value as
#: in the module docstring's bound; None when the deadline passes before all orbits are priced.
Pricer = Callable[
    [np.ndarray, np.ndarray, float | None],
    list[tuple[float, np.ndarray, tuple[float, float] | None]] | None,
]


#: Rows linking orbits' memory (:data:`sosp.downlink.STORE_ROWS`): a 0/1 matrix (rows x
#: orbit positions) and the right-hand sides, ``sum over the row's orbits of M_P y_P <= rhs``.
Links = tuple[np.ndarray, np.ndarray]


def links_of(instance: Instance, groups: Sequence[Any]) -> Links | None:
    """The store rows :func:`sosp.downlink.relaxed_instance` recorded in ``instance.meta``,
    over the positions of ``groups`` (None: none). An orbit without a position has no plan
    but the empty one, so it adds nothing to a row."""
    from sosp.downlink import STORE_ROWS

    given = instance.meta.get(STORE_ROWS) if instance.meta else None
    if not given:
        return None
    pos = {int(o.orbit): g for g, o in enumerate(groups)}
    a = np.zeros((len(given), len(groups)))
    for i, (orbits, _) in enumerate(given):
        a[i, [pos[j] for j in orbits if j in pos]] = 1.0
    return a, np.array([float(rhs) for _, rhs in given])


def _smoothed(alpha: float, best: tuple[Any, ...], master: tuple[Any, ...] | None) -> tuple:
    """The pricing point (Wentges): ``alpha`` times the best bound's multipliers ``best``
    plus ``1 - alpha`` times the master's (``best`` itself before the first master)."""
    if master is None:
        return best
    return tuple(alpha * c + (1.0 - alpha) * m for c, m in zip(best, master, strict=True))


@dataclass
class Root:
    """What :func:`column_generation` ends with: the least Lagrangian value ``best`` and its
    multipliers, the last master and its optimum (None before the first), the rounds, and
    whether the rounded bound has reached the rounded master optimum."""

    best: float
    mu: np.ndarray
    lam: np.ndarray
    master: _Master
    value: float | None
    rounds: int
    converged: bool
    round_s: float = 0.0  # the longest pricing round, seconds


def column_generation(
    p: np.ndarray,
    seen: np.ndarray,
    rules: Sequence[OrbitRules],
    price: Pricer,
    start: tuple[np.ndarray, np.ndarray],
    budget: Budget,
    lower_bound: float | None = None,
    max_rounds: int = 10_000,
    smoothing: float = SMOOTHING,
    expect_rounds: int | None = None,
    columns: Sequence[tuple[int, np.ndarray, float, float]] = (),
    links: Links | None = None,
) -> Root:
    """Column generation on the master of the module docstring with any pricing that gives,
    per orbit, a plan of largest value at least the exact one (the exact planner, or the
    window relaxation's :func:`sosp.windows.relaxed_best_path`): every round's value is then
    a valid upper bound, whatever the master. Stops when no plan prices out at the master's
    duals, when the rounded bound meets the rounded master optimum or ``lower_bound``, at
    ``max_rounds`` or when ``budget`` runs out; with ``expect_rounds``, also after the first
    round when that many rounds of its length would not fit in ``budget`` (before any master
    is solved: a caller that wants the master's plans gets none rather than an early,
    uncoordinated master's).

    ``p`` holds the target weights (0 where not ``seen``), ``seen`` the targets some plan can
    cover (the master's coverage rows), ``rules`` the orbits' :class:`sosp.rules.OrbitRules`
    (the knapsack rows), ``start`` the first multipliers ``(mu, lam)`` (``lam`` per whole
    capacity, orbits x 2), ``columns`` plans ``(orbit, covered targets, energy, memory)`` the
    master starts with (plans of the pricing's own relaxation, so that the master's optimum
    stays that relaxation's: the bounds come from the pricing alone), ``links`` store rows
    over several orbits' memory (:func:`links_of`) the master holds too: their multipliers
    ``sig`` add ``W_j sum of sig over the rows of j`` to orbit j's memory multiplier in the
    pricing and ``sig . rhs`` to the bound, which stays valid at any ``sig >= 0`` (the rows
    are relaxed like the knapsacks). ``Root.lam`` is then that effective multiplier.
    """
    caps = _caps(rules)
    e_cap, w_cap = caps.T
    master = _Master(p, seen, caps, links=links)
    n_links = master.n_links
    a_link = links[0] if n_links else np.zeros((0, len(rules)))
    rhs_link = links[1] if n_links else np.zeros(0)

    def effective(lam: np.ndarray, sig: np.ndarray) -> np.ndarray:
        if not n_links:
            return lam
        out = lam.copy()
        out[:, 1] += w_cap * (a_link.T @ sig)
        return out

    for g, covered, energy, memory in columns:
        master.add_new(g, covered, energy, memory)
    mu_c, lam_c = start
    sig_c, sig_m = np.zeros(n_links), np.zeros(n_links)
    best = math.inf
    master_value: float | None = None
    rounds = 0
    mu_m: np.ndarray | None = None
    lam_m = np.zeros((len(rules), 2))
    sigma = np.zeros(len(rules))
    alpha = 0.0  # the first round prices at the start point itself
    converged = False
    given = budget.left()
    round_s = 0.0  # the longest round so far
    while rounds < max_rounds:
        # a round foreseen to end past the deadline is not started: a partial round is no
        # bound, and a round over windows of a dense orbit prices it for seconds without
        # reading the clock (a drawn 1,200-target instance: 7.9 s for a 5 s limit)
        if not budget.fits(round_s):
            break
        mu_s, lam_s, sig_s = _smoothed(
            alpha, (mu_c, lam_c, sig_c), None if mu_m is None else (mu_m, lam_m, sig_m)
        )
        t_round = time.perf_counter()
        plans = price(mu_s, effective(lam_s, sig_s), budget.deadline)
        round_s = max(round_s, time.perf_counter() - t_round)
        if plans is None:
            break  # the deadline fell inside the round: its bound is incomplete
        rounds += 1
        # the Lagrangian bound L(mu, lam) of the round's plans (module docstring)
        value = float(np.maximum(p - mu_s, 0.0).sum()) + sum(v for v, _, _ in plans)
        value += float(lam_s.sum()) + float(sig_s @ rhs_link)
        if value < best - 1e-9:
            best, mu_c, lam_c, sig_c = value, mu_s, lam_s, sig_s
        if rounds == 1 and given is not None and (expect_rounds or 0) * round_s > given:
            # too slow a round for this budget: no master (see above)
            log.info(
                "root given up: its first round took %.1f s, %d such rounds need %.0f s, "
                "%.0f s were given", round_s, expect_rounds, expect_rounds * round_s, given,
            )  # fmt: skip
            break
        improving = 0
        lam_e = None if mu_m is None else effective(lam_m, sig_m)
        for g, (_, covered, used) in enumerate(plans):
            if used is None:
                continue
            if mu_m is not None:
                rc = float(mu_m[covered].sum()) - lam_e[g, 0] * used[0] / max(e_cap[g], 1e-12)
                rc -= lam_e[g, 1] * used[1] / max(w_cap[g], 1e-12) + sigma[g]
                improving += rc > _RC_TOL
            master.add_new(g, covered, used[0], used[1])
        if mu_m is not None and improving == 0:
            if alpha == 0.0:
                converged = True  # no plan prices out at the master's duals: solved
                break
            alpha = 0.0  # mis-pricing: the next round prices at the master's duals
            continue
        if lower_bound is not None and math.floor(best + 1e-6) <= lower_bound + 1e-9:
            break
        if not master.solve(budget):
            break  # out of time inside the master: the best bound so far stands
        master_value, (mu_m, _, lam_m, sigma, _) = master.duals(p, caps)
        if n_links:
            sig_m = master.link_duals
        alpha = smoothing
        if math.floor(best + 1e-6) <= math.floor(master_value + 1e-6):
            converged = True  # the rounded bound cannot fall below the master's optimum
            break
    return Root(best, mu_c, effective(lam_c, sig_c), master, master_value, rounds, converged,
                round_s)  # fmt: skip


def colgen_bound(
    instance: Instance,
    *,
    time_limit: float | None = None,
    lower_bound: float | None = None,
    data: OrbitData | None = None,
    workers: Workers = 1,
    max_rounds: int = 10_000,
    smoothing: float = SMOOTHING,
    start: tuple[np.ndarray, np.ndarray] | None = None,
    branch: bool = False,
    root_time_limit: float | None = None,
    report: Callable[[float], None] | None = None,
    expect_rounds: int | None = None,
    cut_rounds: int | None = None,
) -> dict[str, Any]:
    """Upper bound on the optimum (cluster model) by column generation over orbit plans.

    Solves the Dantzig-Wolfe master of the module docstring by column generation, pricing
    each orbit exactly with :func:`sosp.planner.best_path`; every round's multipliers give
    the Lagrangian bound ``L(mu, lam)`` (coverage rows of (2) relaxed with ``mu``, knapsacks
    (4)-(5) with ``lam``), and the least one found, rounded down (the optimum is an integer)
    and capped by the total weight of the targets some candidate covers, is returned. Its
    limit is the optimum of the master LP, the least value any ``lagrangian_bound`` run can
    reach.

    Parameters
    ----------
    instance
        The problem.
    time_limit
        Seconds for everything, candidates included (None: until the master is solved).
    lower_bound
        A known feasible profit: stop once the bound meets it (None: no such stop).
    data
        Prepared candidates (built here when None).
    workers
        Processes for the orbits' plans of each round (:class:`sosp.planner.PlanPool`), and
        with ``branch`` and an integer of 2 or more, for the two children of each branching
        (:func:`branch_and_price`).
    max_rounds
        Pricing rounds at most.
    smoothing
        Weight in [0, 1) of the best bound's multipliers in each pricing point.
    start
        Multipliers ``(mu, lam)`` to start from (per target of the instance, and orbits x 2
        per whole capacity as ``lagrangian_bound`` uses them), e.g. a subgradient run's;
        None: ``mu = p / 2``, ``lam = 0``.
    branch
        After convergence, spend the time left on a best-first branch and price
        (:func:`branch_and_price`), which lowers the bound below the master LP's optimum.
        Without a ``time_limit`` it runs until the tree is explored, which can take very long.
    root_time_limit
        Seconds (from the start) for the column generation before any branching (None: all
        of ``time_limit``); the branching gets the rest of ``time_limit``.
    report
        Called with the branching's bound (not rounded) after every node it branches on, so
        that a caller in another process (:class:`SideBound`) always holds a valid bound.
    expect_rounds
        See :func:`column_generation` (None: no such stop).
    cut_rounds
        Subset-row cut separation rounds at the branching's root (:func:`branch_and_price`;
        None: :func:`root_cut_rounds` of ``time_limit``, 0: none).

    Returns
    -------
    dict
        ``bound``, ``method`` ("colgen"), ``model`` ("cluster"), ``runtime_s``, ``rounds``,
        ``columns``, ``master`` (the last restricted master's optimum, a lower bound on the
        limit; None before the first), ``converged`` (the rounded bound has reached the
        rounded master optimum: no Lagrangian bound of this relaxation, nor the LP over the
        same candidates, is lower), ``candidates``, ``cap`` (the covered weight), ``plans``
        (the last restricted master's positive plans, ``(orbit, covered targets, value,
        energy, memory)``:
        the fractional schedule a primal heuristic can start from, see
        :func:`heuristics.orbit_search.lp_start`; empty before the first master); with
        ``branch``, ``nodes`` (subproblems solved) when the branching ran, and ``schedule``
        and its ``profit`` when it ended on a node with nothing fractional whose plans the
        referee accepts as a schedule (a lower bound; the optimum when it meets ``bound``).
    """
    check_count("max_rounds", max_rounds)
    if not 0.0 <= float(smoothing) < 1.0:
        raise InputError(f"smoothing: expected a number in [0, 1), got {smoothing!r}")
    if cut_rounds is None:
        cut_rounds = root_cut_rounds(time_limit)
    check_count("cut_rounds", cut_rounds, 0)
    if branch and cut_rounds:
        cut_levels()  # compiled (or loaded) before the clock starts, as the planner's kernels
    t0 = time.perf_counter()
    budget = Budget.of(time_limit)
    root_budget = budget.child(root_time_limit)
    if data is None:
        data = orbit_data(instance, root_budget.deadline, workers=workers)
    groups = data.orbits
    seen, p = seen_weights(instance, groups)
    cap = float(p.sum())

    def out(
        bound: float, rounds: int, columns: int, master: float | None, converged: bool
    ) -> dict[str, Any]:
        log.info("colgen bound %g after %d rounds, %d columns", bound, rounds, columns)
        return {
            "bound": bound,
            "method": "colgen",
            "model": "cluster",
            "runtime_s": round(time.perf_counter() - t0, 6),
            "rounds": rounds,
            "columns": columns,
            "master": master,
            "converged": converged,
            "candidates": data.n_items,
            "cap": cap,
        }

    if not groups or cap == 0.0:
        return out(cap, 0, 0, None, True)
    if start is None:
        mu_c, lam_c = 0.5 * p, np.zeros((len(groups), 2))
    else:
        mu_c = np.clip(np.asarray(start[0], dtype=float), 0.0, p)
        lam_c = np.maximum(np.asarray(start[1], dtype=float), 0.0)
        if lam_c.shape != (len(groups), 2):
            raise InputError(f"start: expected lam of shape {(len(groups), 2)}")
    with closing(PlanPool(groups, workers)) as pool:
        root = column_generation(
            p,
            seen,
            [o.rules for o in groups],
            pool.best_paths,
            (mu_c, lam_c),
            root_budget,
            lower_bound,
            max_rounds,
            smoothing,
            expect_rounds,
            links=links_of(instance, groups),
        )
    bound = capped_bound(root.best, cap)
    if report is not None:
        report(bound)
    result = out(bound, root.rounds, len(root.master.columns), root.value, root.converged)
    result["plans"] = root.master.plans()
    proven = lower_bound is not None and bound <= lower_bound + 1e-9
    if branch and root.converged and not proven:
        answer, nodes, final = branch_and_price(
            p, seen, groups, root.master.columns, (root.best, root.mu, root.lam), budget,
            lower_bound, report=report, cut_rounds=cut_rounds,
            workers=workers if isinstance(workers, int) else 1,
        )  # fmt: skip
        result["nodes"] = nodes
        result["bound"] = min(bound, float(math.floor(answer + 1e-6)))
        if final is not None:
            # the node of largest bound is integral in its covers: its plans are a schedule
            found = node_schedule(instance, data, p, final)
            if found is not None:
                result["schedule"], result["profit"] = found
        result["runtime_s"] = round(time.perf_counter() - t0, 6)
    return result


# ------------------------------------------------------------------------ branch and price
@dataclass
class _Node:
    """A subproblem of the branch and price: the cluster model with, for some targets k and
    orbits g, "orbit g's cover of k does not count" (``banned``) or "k is covered by orbit g"
    (``forced``; then no other orbit's cover of k counts and k's weight is earned).

    ``bound`` is the least Lagrangian bound of the subproblem found so far (valid whatever
    the multipliers), ``mu``, ``beta``, ``lam`` the multipliers that gave it (the children's
    start), ``cover`` the master's cover of each (target, orbit) pair at the end of its column
    generation (None when it was cut short by the time limit), ``support`` the pool's
    columns positive in its last master (the children's masters start with them).
    """

    bound: float
    banned: frozenset[tuple[int, int]]
    forced: dict[int, int]
    mu: np.ndarray
    beta: np.ndarray
    lam: np.ndarray
    cover: dict[tuple[int, int], float] | None
    support: tuple[int, ...] = ()
    sigma: np.ndarray | None = None  # subset-row cut duals (per cut of the pool), or None
    basis: _Basis | None = None  # its last master's basis (the children's masters start there)
    pick: tuple[int, int] | None = None  # the pair strong branching chose, or None


@dataclass(frozen=True, eq=False)
class _Basis:
    """A node's last master basis by what each row and column stands for, so a child's
    master (other rows, other columns) can start from it: statuses as
    ``highspy.HighsBasisStatus`` values, -1 where the master had no such row or column.

    ``target_col`` and ``target_row`` hold, per target, its ``z_k`` (or forced slack) column
    and its coverage (or forcing) row, ``orbit_row`` the convexity and knapsack rows, ``y``
    and ``y_status`` the pool's columns the master held, ``cut`` and ``cut_status`` its cut
    rows.
    """

    target_col: np.ndarray
    target_row: np.ndarray
    orbit_row: np.ndarray
    y: np.ndarray
    y_status: np.ndarray
    cut: np.ndarray
    cut_status: np.ndarray


class _Columns:
    """Every plan generated so far (orbit, targets, how many times each, energy, memory),
    with their entries also as flat arrays (grown on demand) to value them all at once."""

    def __init__(self) -> None:
        self.keys: dict[tuple[int, bytes], int] = {}
        self.items: list[tuple[int, np.ndarray, np.ndarray, float, float]] = []
        ints, floats = np.zeros(0, dtype=np.int64), np.zeros(0)
        self._flat: tuple[np.ndarray, ...] = (ints, ints, ints, floats, floats, floats)
        # per column, its cut coefficients and how many of the pool's cuts they cover
        self._coef: list[tuple[int, dict[int, int]]] = []

    def add(self, g: int, tg: np.ndarray, cnt: np.ndarray, energy: float, memory: float) -> int:
        """The column's index in the pool (added when new)."""
        # keyed by the stored dtypes, so that a plan priced here (integer counts) and the
        # same plan received from a helper (:class:`_Helper`, float counts) are one column
        tg, cnt = np.asarray(tg, dtype=np.int64), np.asarray(cnt, dtype=float)
        key = (g, tg.tobytes() + cnt.tobytes())
        if key not in self.keys:
            self.keys[key] = len(self.items)
            self.items.append((g, tg, cnt, energy, memory))
            self._coef.append((0, {}))
        return self.keys[key]

    def truncate(self, n: int) -> None:
        """Drop the columns from index ``n`` on (a helper's own, before it takes the
        parent's pool, :class:`_Helper`)."""
        if n >= len(self.items):
            return
        self.keys = {key: i for key, i in self.keys.items() if i < n}
        del self.items[n:]
        del self._coef[n:]
        col, orb, tgt, cnt, energy, memory = self._flat
        if len(energy) > n:
            cut = int(np.searchsorted(col, n))  # entries are in column order
            self._flat = (col[:cut], orb[:n], tgt[:cut], cnt[:cut], energy[:n], memory[:n])

    def coefficients(self, i: int, cuts: CutPool) -> dict[int, int]:
        """Column i's coefficient per cut of ``cuts`` it hits
        (:meth:`models.subset_row.CutPool.coefficients`), computed once per column and cut:
        every node's master holds the pool's cuts, and recomputing them for each master's
        columns was a tenth of C7's branch and price."""
        n, coef = self._coef[i]
        if n < len(cuts):
            g, tg, cnt, _, _ = self.items[i]
            coef = {**coef, **cuts.coefficients(tg, cnt, g, since=n)}
            self._coef[i] = (len(cuts), coef)
        return coef

    def values(self, price: np.ndarray, lam_per_unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each column's value, ``sum_k price[g, k] * n_kP - lam_e E_P - lam_w M_P`` with
        ``price`` orbits x targets and ``lam_per_unit`` orbits x 2 (per unit of energy and
        memory), and its orbit g."""
        n = len(self._flat[4])
        if n < len(self.items):  # the new columns' entries and orbits appended
            g, tg, cnt, energy, memory = zip(*self.items[n:], strict=True)
            at = np.repeat(np.arange(n, len(self.items)), [len(t) for t in tg])
            new = (at, np.array(g, dtype=np.int64), np.concatenate(tg), np.concatenate(cnt))
            new += (energy, memory)
            self._flat = tuple(np.concatenate([a, b]) for a, b in zip(self._flat, new, strict=True))
        col, orb, tgt, cnt, energy, memory = self._flat
        gained = np.bincount(col, weights=price[orb[col], tgt] * cnt, minlength=len(energy))
        return gained - lam_per_unit[orb, 0] * energy - lam_per_unit[orb, 1] * memory, orb


def _padded(sigma: np.ndarray | None, cuts: CutPool | None) -> np.ndarray:
    """Cut duals ``sigma`` (None: none yet) with zeros for the pool's cuts added since."""
    n = 0 if cuts is None else len(cuts)
    out = np.zeros(n)
    if sigma is not None:
        out[: len(sigma)] = sigma[:n]
    return out


def _node_prices(node_mu: np.ndarray, beta: np.ndarray, g: int, node: _Node) -> np.ndarray:
    """What covering each target is worth to orbit g in ``node``: ``mu`` for the targets whose
    cover counts, ``beta`` for those forced to g, 0 for targets banned on g or forced
    elsewhere."""
    price = node_mu.copy()
    for k, j in node.banned:
        if j == g:
            price[k] = 0.0
    for k, j in node.forced.items():
        price[k] = beta[k] if j == g else 0.0
    return price


@dataclass(frozen=True, eq=False)
class _Tree:
    """What every node of a branch and price shares: the target weights ``p`` (0 for
    unseen), ``seen`` (the targets some candidate covers), the orbits, the pool of columns,
    the smoothing weight, the cut pool (None: no cuts) and the orbits' capacities
    (:func:`_caps`)."""

    p: np.ndarray
    seen: np.ndarray
    groups: tuple[Any, ...]
    cols: _Columns
    smoothing: float
    cuts: CutPool | None
    caps: np.ndarray


def _solve_node(
    node: _Node,
    tree: _Tree,
    budget: Budget,
    separate: int = 0,
    cuts_per_round: int = CUTS_PER_ROUND,
    strong: int = 0,
    prune: float | None = None,
) -> _Node:
    """Column generation on the master of ``node``; returns it with its bound and cover.

    Master (minimising ``-sum p_k z_k`` over the free targets): per free target
    ``z_k - sum n_kP y_P <= 0`` over the plans whose orbit's cover of k counts, per forced
    (k, g) ``sum_{P of g} n_kP y_P + s_k >= 1`` (``s_k`` an artificial slack costing more
    than all weights, so the master is always feasible), per orbit convexity and knapsacks.
    For any ``mu, beta, lam >= 0``

        L = sum_free max(0, p_k - mu_k) + sum_forced (p_k - beta_k)
            + sum_j [max over plans of orbit j of (prices of the node) - penalties + lam_j]

    bounds the node's optimum (the coverage and forcing rows relaxed).

    With ``cuts``, the master also holds the pool's cuts (:class:`models.subset_row.CutPool`:
    targets S and orbits G) that the node keeps: with F = S's forced targets, ``sum_{free k
    in S} z_k - sum_P c_SP y_P <= r_S``, ``c_SP`` the plan's ``ceil(h_SP / 2)`` (``floor``
    on G's orbits) and ``r_S = floor((|S| + |G|) / 2) - |F|`` (valid: the forced z are 1,
    and the node's counted covers are at most the real ones), for ``r_S >= 0`` (a cut with
    more forced targets is dropped here, which only weakens the node). Their duals ``sigma
    >= 0`` add ``sum_S sigma_S r_S`` to L, take ``sigma_S`` from each free ``z_k`` of S and
    give each plan its earning ``sigma_S c_SP``
    (:meth:`models.subset_row.CutPool.best_path`). After the column generation has
    converged, up to ``separate`` rounds add the cuts its master violates
    (:meth:`models.subset_row.CutPool.separate`) to the pool and go on. With ``strong``,
    the converged node also gets its branching pair (``pick``, :func:`_strong_pick` over
    that many candidates). With ``prune`` (a known schedule's profit), the column generation
    stops as soon as the bound rounded down is at most ``prune``: the node then holds no
    better schedule and its cover is never needed (returned as None).
    """
    import highspy

    p, groups, cols, cuts = tree.p, tree.groups, tree.cols, tree.cuts
    master = _Master(p, tree.seen, tree.caps, node.forced, node.banned)
    h, free, fk, row_free, base = master.h, master.free, master.fk, master.row_free, master.base
    in_lp: list[int] = []  # the pool's columns the master holds, in its order
    loaded: set[int] = set()
    held: dict[int, tuple[int, float, np.ndarray]] = {}  # per held cut: row, rhs, free rows
    cut0 = base + 3 * master.n_orb  # the first cut row

    def load(i: int) -> None:
        if i in loaded:
            return
        loaded.add(i)
        at: list[tuple[int, float]] = []
        if held:
            coef = cols.coefficients(i, cuts)  # type: ignore[arg-type]
            at = sorted((held[c][0], -float(v)) for c, v in coef.items() if c in held)
        master.add(cols.items[i], [r for r, _ in at], [v for _, v in at])
        in_lp.append(i)

    def hold(new: Sequence[int]) -> None:
        """Add rows for the pool's cuts ``new`` that this node keeps."""
        assert cuts is not None
        # each cut's y entries, in the master's column order, from the columns' coefficients
        ys: dict[int, tuple[list[int], list[float]]] = {c: ([], []) for c in new}
        for x, i in enumerate(in_lp):
            for c, v in cols.coefficients(i, cuts).items():
                if c in ys:
                    ys[c][0].append(base + x)
                    ys[c][1].append(-float(v))
        for c in new:
            members = cuts.cuts[c]
            rhs = float(cuts.rhs[c] - np.count_nonzero(master.row_forced[members] >= 0))
            zs = row_free[members][row_free[members] >= 0]
            if rhs >= 0:
                held[c] = (cut0 + len(held), rhs, zs)
                idx = np.concatenate([zs, ys[c][0]]).astype(np.int32)
                vals = np.concatenate([np.ones(len(zs)), ys[c][1]])
                h.addRow(-highspy.kHighsInf, rhs, len(idx), idx, vals)

    for i in _start_columns(node, tree):
        load(int(i))
    if cuts is not None and len(cuts):
        hold(range(len(cuts)))
    pf = p[fk]
    best, mu_c, beta_c, lam_c = node.bound, node.mu, node.beta, node.lam
    sigma_c = _padded(node.sigma, cuts)
    m_duals: tuple[np.ndarray, ...] | None = None  # the last master's (mu, beta, lam, sigma)
    alpha = 0.0
    resolve = False  # cuts were just added: solve the master before pricing again
    warm = node.basis  # the parent's basis, for this master's first solve
    sep_s = 0.5  # the longest separation so far (seconds)
    while not budget.expired():
        if not resolve:
            at_master = m_duals is not None and alpha == 0.0
            mu_s, beta_s, lam_s, sigma_s = _smoothed(alpha, (mu_c, beta_c, lam_c, sigma_c), m_duals)
            z_gain = p[free] - mu_s[free]
            value = float((pf - beta_s[fk]).sum()) + float(lam_s.sum())
            if held:
                kept = np.isin(np.arange(len(sigma_s)), list(held))
                sigma_s = np.where(kept, sigma_s, 0.0)  # a parent's cut this node dropped
                for c, (_, rhs, zs) in held.items():
                    value += float(sigma_s[c]) * rhs
                    z_gain[zs] -= sigma_s[c]
            value += float(np.maximum(z_gain, 0.0).sum())
            n_loaded = len(in_lp)
            for g, o in enumerate(groups):
                if budget.expired():
                    return replace(node, cover=None)
                price = _node_prices(mu_s, beta_s, g, node)
                if held:
                    v, path, _ = cuts.best_path(g, price, lam_s[g], sigma_s)
                else:
                    v, path = best_path(o, price, float(lam_s[g, 0]), float(lam_s[g, 1]))
                value += v
                if len(path):
                    tg, cnt = np.unique(o.target_flat[flat_positions(o, path)], return_counts=True)
                    load(cols.add(g, tg, cnt, *o.usage(path)))  # new to this master, or to all
            if value < best:
                best, mu_c, beta_c, lam_c, sigma_c = value, mu_s, beta_s, lam_s, sigma_s
                node = replace(node, bound=best, mu=mu_c, beta=beta_c, lam=lam_c, sigma=sigma_c)
                if prune is not None and math.floor(best + 1e-6) <= prune + 1e-9:
                    return replace(node, cover=None)  # pruned: the search stops before it
        resolve = False
        if warm is not None:
            _start_basis(h, warm, free, fk, in_lp, list(held))
        solved = master.solve(budget, retry=warm is not None)
        warm = None
        if not solved:
            return replace(node, cover=None)
        m_value, (mu_m, beta_m, lam_m, _, held_sigma) = master.duals(p, tree.caps)
        sigma_m = _padded(None, cuts)
        sigma_m[list(held)] = held_sigma
        m_duals = (mu_m, beta_m, lam_m, sigma_m)
        sigma_c = _padded(sigma_c, cuts)
        # the weights are integers, so only the node's bound rounded down matters (the answer
        # is the largest, rounded down): once it equals the master's value rounded down, the
        # node's LP optimum (between the two) rounds to it too and the rounds that would close
        # the rest of the gap (column generation's slow tail) change nothing
        done = best - m_value <= 1e-6 * max(1.0, abs(best))
        done = done or math.floor(best + 1e-6) <= math.floor(m_value + 1e-6)
        if not done and len(in_lp) == n_loaded:
            if not at_master:
                alpha = 0.0  # no new plan at the smoothed point: price at the master's duals
                continue
            done = True  # no plan prices out at the master's duals: solved (to rounding)
        if done:
            y = master.x
            positive = [(i, float(x)) for i, x in zip(in_lp, y[base:], strict=True) if x > 1e-9]
            if separate > 0 and cuts is not None and budget.fits(2 * sep_s):
                # not started unless twice the last one's time is left (at least a second):
                # its products before the search read no clock
                separate -= 1
                t_sep = time.perf_counter()
                z = np.zeros(len(p))
                z[free] = y[: len(free)]
                z[fk] = 1.0
                plans = [(cols.items[i][1], yi) for i, yi in positive]
                orbits = [cols.items[i][0] for i, _ in positive]
                new = cuts.separate(z, plans, cuts_per_round, budget.deadline, orbits)
                sep_s = max(sep_s, time.perf_counter() - t_sep, 0.5)
                if new:
                    log.debug("node: %d cuts added (%d in the pool)", len(new), len(cuts))
                    hold(new)
                    sigma_c = _padded(sigma_c, cuts)
                    # solve the master with them, then price: "no new plan" means nothing
                    # until a pricing round has run at the new master's duals
                    alpha, resolve, n_loaded = 0.0, True, -1
                    continue
            cover: dict[tuple[int, int], float] = {}
            for i, yi in positive:
                g = cols.items[i][0]
                for k in cols.items[i][1].tolist():
                    cover[(k, g)] = cover.get((k, g), 0.0) + yi
            last = h.getBasis()
            col_status = np.array([int(x) for x in last.col_status], dtype=np.int8)
            row_status = np.array([int(x) for x in last.row_status], dtype=np.int8)
            target_col, target_row = np.full((2, len(p)), -1, dtype=np.int8)
            target_col[np.concatenate([free, fk])] = col_status[:base]
            target_row[np.concatenate([free, fk])] = row_status[:base]
            basis = _Basis(
                target_col, target_row, row_status[base:cut0].copy(),
                np.array(in_lp, dtype=np.int64), col_status[base:].copy(),
                np.array(list(held), dtype=np.int64), row_status[cut0:].copy(),
            )  # fmt: skip
            support = tuple(i for i, _ in positive)
            node = replace(node, cover=cover, support=support, basis=basis)
            if strong > 0:
                node = replace(
                    node, pick=_strong_pick(h, node, p, strong, m_value, pf, master, last, budget)
                )  # fmt: skip
            return node
        alpha = tree.smoothing
    return replace(node, cover=None)


def _start_basis(
    h: Any,
    parent: _Basis,
    free: np.ndarray,
    forced: np.ndarray,
    in_lp: Sequence[int],
    cut_ids: Sequence[int],
) -> None:
    """Give the master ``h`` (rows: free targets, forced targets, orbits, cuts ``cut_ids``;
    columns: free targets' ``z_k``, forced targets' slacks, the pool's ``in_lp``) the
    parent's basis where the two share a row or column, as an alien basis (HiGHS makes it
    square and nonsingular): a basic row or column stays basic, a nonbasic one sits at its
    finite bound, and what the parent lacked is nonbasic (a column) or basic (a cut row).

    A child's master differs from its parent's by one branching, so its first solve starts
    near the parent's optimum rather than from the slack basis: the first solve was a third
    of a C5 node's simplex time (2,500 iterations against 130 per later re-solve).
    """
    import highspy

    st = highspy.HighsBasisStatus
    lower, basic, upper = int(st.kLower), int(st.kBasic), int(st.kUpper)

    def kept(status: Any, bound: int) -> np.ndarray:
        """Basic stays basic; anything else sits at ``bound``."""
        return np.where(np.asarray(status, dtype=np.int64) == basic, basic, bound)

    z = parent.target_col[free]  # z_k in [0, 1], a forced slack in [0, inf)
    held = dict(zip(parent.y.tolist(), parent.y_status.tolist(), strict=True))
    had = dict(zip(parent.cut.tolist(), parent.cut_status.tolist(), strict=True))
    cols = [np.where(z == upper, upper, kept(z, lower)), kept(parent.target_col[forced], lower)]
    cols.append(kept([held.get(i, lower) for i in in_lp], lower))
    # coverage rows <= 0, forcing rows >= 1, orbit rows <= 1 and capacities, cut rows <= rhs
    rows = [kept(parent.target_row[free], upper), kept(parent.target_row[forced], lower)]
    rows += [kept(parent.orbit_row, upper), kept([had.get(c, basic) for c in cut_ids], upper)]
    basis = highspy.HighsBasis()
    basis.col_status = [st(int(x)) for x in np.concatenate(cols)]
    basis.row_status = [st(int(x)) for x in np.concatenate(rows)]
    basis.alien = True
    h.setBasis(basis)


#: A node's master starts with every column of the pool while it has at most this many;
#: beyond, with its parent's positive columns and each orbit's best :data:`PER_ORBIT` at the
#: node's starting multipliers (its own pricing adds back any other it needs). Loading the
#: whole pool made europe-400's nodes three times slower after 800 nodes than at the start.
POOL_ALL = 1000

#: Columns per orbit a node's master starts with once the pool is larger than
#: :data:`POOL_ALL`.
PER_ORBIT = 20


def _start_columns(node: _Node, tree: _Tree) -> np.ndarray:
    """The pool's columns a node's master starts with (see :data:`POOL_ALL`). Which columns
    the master holds changes its convergence, not the node's bound: that is the least
    Lagrangian bound of its pricing rounds, valid whatever the master."""
    n = len(tree.cols.items)
    if n <= POOL_ALL:
        return np.arange(n)
    price = np.stack([_node_prices(node.mu, node.beta, g, node) for g in range(len(tree.groups))])
    value, orbit = tree.cols.values(price, node.lam / np.maximum(tree.caps, 1e-12))
    by = np.lexsort((-value, orbit))  # by orbit, best first
    first = np.searchsorted(orbit[by], orbit[by], side="left")
    rank = np.arange(n) - first
    chosen = by[rank < PER_ORBIT]
    return np.union1d(chosen, np.asarray(node.support, dtype=np.int64))


def _candidates(node: _Node, p: np.ndarray, n: int) -> list[tuple[int, int]]:
    """The ``n`` heaviest pairs of ``node`` by ``p_k * min(x, 1 - x)`` whose counted cover x
    is strictly between 0 and 1 (ties in the cover's order)."""
    cover = (node.cover or {}).items()
    scored = [(p[k] * min(x, 1.0 - x), (k, g)) for (k, g), x in cover if k not in node.forced]
    scored = [(score, pair) for score, pair in scored if pair not in node.banned and score > 1e-6]
    scored.sort(key=lambda t: -t[0])  # stable: the first of equal scores first
    return [pair for _, pair in scored[:n]]


def _strong_pick(
    h: Any,
    node: _Node,
    p: np.ndarray,
    n: int,
    m_value: float,
    pf: np.ndarray,
    master: _Master,
    basis: Any,
    budget: Budget,
) -> tuple[int, int] | None:
    """Strong branching on the restricted master: of the ``n`` heaviest fractional pairs,
    the one whose two children's master values, with the node's columns and no pricing, fall
    most below the node's (product of the two falls, each at least 1e-4).

    A child's restricted value is at most its master optimum (fewer columns), so the falls
    over-state the children's; they rank the candidates, they bound nothing. The ban child
    drops orbit g's entries in k's coverage row, the force child fixes ``z_k = 1`` and drops
    the other orbits' entries (as HiGHS holds them, ``master``'s); each is solved from the
    node's optimal basis and undone.
    """
    import highspy

    picks = _candidates(node, p, n)
    if len(picks) <= 1:
        return picks[0] if picks else None
    best, pick = -1.0, picks[0]
    forced_value = float(pf.sum())
    # no iteration limit: at 100 the falls ranked no better than the fractionality does
    # (C7, 300 s: 2868.87 after 102 nodes against 2868.98 after 100 without strong branching)
    h.setOptionValue("simplex_strategy", _STRONG_SIMPLEX)
    for k, g in picks:
        if budget.expired():
            break
        row = int(master.row_free[k])
        _, at, vals = h.getRowEntries(row)
        # the plans' entries in k's row (z_k's is in column ``row``)
        ys = [(c, v) for c, v in zip(at.tolist(), vals.tolist(), strict=True) if c >= master.base]
        falls = []
        for force in (False, True):
            drop = [(c, v) for c, v in ys if (master.columns[c - master.base][0] != g) == force]
            for col, _ in drop:
                h.changeCoeff(row, col, 0.0)
            if force:
                h.changeColBounds(row, 1.0, 1.0)  # z_k is column ``row`` (free targets first)
            h.setBasis(basis)
            allow_seconds(h, budget.left())
            h.run()
            ok = h.getModelStatus() == highspy.HighsModelStatus.kOptimal
            value = -float(h.getInfo().objective_function_value) + forced_value
            falls.append(max(m_value - value, 1e-4) if ok else 1e-4)
            for col, v in drop:
                h.changeCoeff(row, col, v)
            if force:
                h.changeColBounds(row, 0.0, 1.0)
        score = falls[0] * falls[1]
        if score > best:
            best, pick = score, (k, g)
    h.setOptionValue("simplex_strategy", _MASTER_SIMPLEX)  # as the master had it
    return pick


#: Seconds a :class:`_Helper` may take past the deadline to return its child (a node cut
#: short by the deadline comes back at once; this is for a helper that has hung or died).
HELPER_GRACE_S = 5.0

#: Seconds that must be left at a branching for a :class:`_Helper` to start: its start and
#: first node (a spawned interpreter, imports, the pool sent) took 1.2 s on C2, where this
#: process solved the other child in 0.26 s, so with less left it cannot pay for itself.
HELPER_MIN_LEFT_S = 2.0


def _helper_child(conn: Any, tree: _Tree) -> None:
    """A :class:`_Helper`'s process: solve the nodes it is sent (:func:`_solve_node`), each
    after taking the parent's pool of columns, and send each back with the columns it
    added, until ``("stop",)`` or the parent's end."""
    child_setup()
    cols = tree.cols  # the parent's pool when it started the helper
    try:
        while True:
            msg = conn.recv()
            if msg[0] != "node":
                break
            _, keep, new, node, budget, prune = msg
            cols.truncate(keep)  # its own columns of the last node came back in ``new``
            for item in new:
                cols.add(*item)
            n0 = len(cols.items)
            out = _solve_node(node, tree, budget, 0, NODE_CUTS, prune=prune)
            conn.send(("node", out, cols.items[n0:]))
    except (EOFError, OSError):
        pass  # the parent has gone
    except Exception as exc:  # pragma: no cover - HiGHS or pickling failures
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


class _Helper:
    """A second process for :func:`branch_and_price`: it solves one of the two children of
    each branching while this process solves the other.

    Both start from the same pool of columns, the one at the branching, so the children,
    and the search, are the same whatever either process's speed (only a deadline cuts
    them). The pools stay identical up to :attr:`synced`: after a branching this process
    adds the helper's new columns after its own child's, and the helper, before its next
    child, drops its own and takes this process's (:meth:`send`). The cut pool is sent
    once, at the start (the helper is started after the root's separation and is not used
    when the nodes separate cuts, :data:`NODE_CUT_ROUNDS`). The process is started with
    ``spawn``, as :class:`SideBound`'s; a daemonic process (a side process) cannot start
    one, and then the search stays in one process.
    """

    def __init__(self, tree: _Tree) -> None:
        self._child = Child(_helper_child, (), (tree,), duplex=True)
        #: The pools of both processes are the same up to this index.
        self.synced = len(tree.cols.items)
        self._base = self.synced

    @classmethod
    def start(cls, tree: _Tree) -> _Helper | None:
        """A helper, or None, with the reason logged, where none can start."""
        import multiprocessing as mp

        if mp.current_process().daemon:
            log.debug("branch and price: one process (a daemonic process starts none)")
            return None
        try:
            return cls(tree)
        except ChildStartError as exc:
            log.warning("%s; branch and price in one process", exc)
            return None

    def send(self, cols: _Columns, node: _Node, budget: Budget, prune: float | None) -> bool:
        """Start solving ``node`` there, from this process's pool as it is now; False if
        the helper has gone (logged)."""
        msg = ("node", self.synced, cols.items[self.synced :], node, budget, prune)
        try:
            self._child.conn.send(msg)
        except (OSError, ValueError):
            log.warning("branch and price: the helper process ended")
            return False
        self._base = len(cols.items)
        return True

    def receive(self, cols: _Columns, budget: Budget) -> _Node | None:
        """The node sent, solved, its new columns added to ``cols``; None if the helper
        failed or did not answer within ``budget`` (plus :data:`HELPER_GRACE_S`)."""
        wait = budget.left()
        try:
            if not self._child.conn.poll(None if wait is None else wait + HELPER_GRACE_S):
                log.warning("branch and price: the helper process did not answer")
                return None
            msg = self._child.conn.recv()
        except (EOFError, OSError):
            log.warning("branch and price: the helper process ended")
            return None
        if msg[0] != "node":
            log.warning("branch and price: the helper process failed: %s", msg[1])
            return None
        _, node, added = msg
        index = np.arange(self._base + len(added), dtype=np.int64)
        for x, item in enumerate(added):
            index[self._base + x] = cols.add(*item)
        self.synced = self._base
        # the node's columns (its support, its basis's) renumbered as this process's pool
        basis = None if node.basis is None else replace(node.basis, y=index[node.basis.y])
        return replace(node, support=tuple(int(index[i]) for i in node.support), basis=basis)

    def close(self) -> None:
        """Stop the helper (it ends by itself when this process does)."""
        # it has nothing to save and no message to finish: ended at once, not waited for
        # (its interpreter's exit took 0.17 s on C2 after a deadline, more on a busy machine)
        self._child.stop()


def branch_and_price(
    p: np.ndarray,
    seen: np.ndarray,
    groups: tuple[Any, ...],
    columns: list[tuple[int, np.ndarray, np.ndarray, float, float]],
    start: tuple[float, np.ndarray, np.ndarray],
    budget: Budget,
    lower_bound: float | None = None,
    max_nodes: int | None = None,
    smoothing: float = SMOOTHING,
    report: Callable[[float], None] | None = None,
    cut_rounds: int = 0,
    strong: int | None = None,
    workers: int = 1,
) -> tuple[float, int, _Node | None]:
    """Best-first branch and price from a converged root; ``(bound, nodes, final)``, where
    ``final`` is the node of largest bound when it has nothing fractional left (else None).

    Branching on a (target k, orbit g) pair whose cover is fractional: either g's cover of k
    does not count, or g covers k (and no other orbit's cover of k counts). Every schedule
    falls in one of the two (if g covers k, k is earned whatever the others do; if not,
    dropping g's cover of k changes nothing), so the optimum is at most the largest bound of
    the open nodes, which is what is returned (not rounded). Each node's bound is the least
    Lagrangian bound of its column generation (:func:`_solve_node`), valid at any stage, so a
    node cut short by the deadline keeps a valid bound. The search takes the node of largest
    bound first (only that one can lower the answer) and stops at the deadline, at
    ``max_nodes``, when it meets ``lower_bound`` (a known schedule's profit), or when that
    node has no fractional pair left (its bound is then the answer). A node whose bound
    meets ``lower_bound`` during its column generation stops there (``prune`` of
    :func:`_solve_node`): it can only be at the top once the search is over.

    Parameters
    ----------
    p, seen
        Target weights (0 for unseen) and which targets some candidate covers.
    groups
        The orbits (:attr:`sosp.planner.OrbitData.orbits`).
    columns
        The root's plans (orbit, targets, counts, energy, memory).
    start
        The root's bound and its multipliers ``(bound, mu, lam)``.
    budget
        When to stop (:class:`sosp.stop.Budget`).
    lower_bound, max_nodes, smoothing, report
        See above and :func:`colgen_bound`.
    cut_rounds
        Rounds of subset-row cut separation at the root node (0: no cuts). The cuts hold
        for every schedule, so every node's master keeps them (:func:`_solve_node`).
    strong
        Strong branching's candidates (:func:`_strong_pick`; None:
        :data:`STRONG_CANDIDATES`, 0: none). A node the search is about to branch on is
        solved again (its master from its own columns and basis, a round or two) and
        branched on the pair the candidates' restricted children rank first; the nodes
        never branched on, most of them, cost nothing more.
    workers
        Processes: from 2 on, a second process (:class:`_Helper`) solves one child of each
        branching while this one solves the other; the search is the same for any number
        of two or more, and differs from one process's only by the columns each child
        starts with (a bound is valid either way). One process where a second cannot start.
    """
    if strong is None:
        strong = STRONG_CANDIDATES
    cols = _Columns()
    for g, tg, cnt, energy, memory in columns:
        cols.add(g, tg, cnt, energy, memory)
    bound0, mu0, lam0 = start
    root = _Node(bound0, frozenset(), {}, mu0, np.zeros(len(p)), lam0, None)
    pool = CutPool(groups) if cut_rounds > 0 else None
    tree = _Tree(p, seen, groups, cols, smoothing, pool, _caps([o.rules for o in groups]))
    root = _solve_node(root, tree, budget, cut_rounds, strong=strong)
    if pool is not None:
        log.info("branch and price: root %.4f with %d subset-row cuts", root.bound, len(pool))
        if report is not None:
            report(root.bound)  # the cuts may have taken a while: say what they gave
    heap: list[tuple[float, int, _Node]] = [(-root.bound, 0, root)]
    count, nodes = 1, 0
    final: _Node | None = None

    def solve_child(child: _Node) -> _Node:
        separate = NODE_CUT_ROUNDS if pool is not None else 0
        return _solve_node(child, tree, budget, separate, NODE_CUTS, prune=lower_bound)

    # a helper needs the cut pool to stay as the root left it; started at the first branching
    helped = workers >= 2 and (pool is None or NODE_CUT_ROUNDS == 0)
    helper: _Helper | None = None
    try:
        while heap:
            if budget.expired() or (max_nodes is not None and nodes >= max_nodes):
                break
            top = heap[0][2]
            if lower_bound is not None and math.floor(top.bound + 1e-6) <= lower_bound + 1e-9:
                break
            if top.cover is None:
                break  # cut short by the deadline: its bound stands
            # the heaviest fractional pair; None when every counted cover is 0 or 1
            pair = top.pick if top.pick is not None else next(iter(_candidates(top, p, 1)), None)
            if strong > 0 and top.pick is None and pair is not None:
                # strong branching only on the nodes the search branches on (most solved nodes
                # never are): the node's master again, from its own columns and basis, which
                # converges in a round or two and keeps the bound it had (or lowers it)
                heapq.heappop(heap)
                top = _solve_node(
                    replace(top, cover=None), tree, budget, 0, NODE_CUTS, strong, prune=lower_bound
                )
                heapq.heappush(heap, (-top.bound, count, top))
                count += 1
                continue
            if pair is None:
                final = top
                break  # nothing fractional to branch on: the largest bound is final
            heapq.heappop(heap)
            k, g = pair
            beta = top.beta.copy()
            beta[k] = top.mu[k]
            children = (
                replace(top, banned=top.banned | {(k, g)}, cover=None, pick=None),
                replace(top, forced={**top.forced, k: g}, beta=beta, cover=None, pick=None),
            )
            if helped and helper is None and budget.fits(HELPER_MIN_LEFT_S):
                helper = _Helper.start(tree)
                helped = helper is not None
            # the parent's bound holds for a child (a subset of its schedules) until its own
            # column generation finds a lower one
            sent = helper is not None and helper.send(cols, children[1], budget, lower_bound)
            solved = [solve_child(children[0])]
            there = helper.receive(cols, budget) if sent else None
            if helper is not None and there is None:
                helper.close()  # it failed (logged): this process goes on alone
                helper, helped = None, False
            solved.append(solve_child(children[1]) if there is None else there)
            for child in solved:
                nodes += 1
                heapq.heappush(heap, (-child.bound, count, child))
                count += 1
            if report is not None:
                report(-heap[0][0])
            if nodes % 100 < 2:  # a long run shows its progress (sosp -v)
                log.info("branch and price: %d nodes, bound %.4f", nodes, -heap[0][0])
    finally:
        if helper is not None:
            helper.close()
    answer = max((-b for b, _, _ in heap), default=-math.inf)
    log.info("branch and price: %d nodes, bound %.4f", nodes, answer)
    return answer, nodes, final


def node_schedule(
    instance: Instance, data: OrbitData, p: np.ndarray, node: _Node
) -> tuple[Any, float] | None:
    """A schedule (and its profit) from a node whose counted covers are all 0 or 1, or None.

    Per orbit, the targets the node counts it as covering get their weight and the rest 0;
    :func:`sosp.planner.best_feasible_path` plans the orbit at those prices (the node's plans
    cover them all within (3), (6), so the recursion finds such a plan; (4)-(5) are kept).
    The schedule is returned only if the referee (:func:`sosp.validate.validate`) accepts it.
    """
    from sosp.planner import best_feasible_path
    from sosp.schedule import items_to_schedule
    from sosp.validate import validate

    counted: dict[int, list[int]] = {}
    for (k, g), x in (node.cover or {}).items():
        if x > 0.5 and (k, g) not in node.banned and node.forced.get(k, g) == g:
            counted.setdefault(g, []).append(k)
    chosen: list[int] = []
    for g, ks in counted.items():
        o, price = data.orbits[g], np.where(np.isin(np.arange(len(p)), ks), p, 0.0)
        chosen.extend(o.items[best_feasible_path(o, price)].tolist())
    sched = items_to_schedule(instance, data, chosen)
    report = validate(instance, sched)
    return (sched, float(report.profit)) if report.feasible else None


# ------------------------------------------------------------ beside the MILP, one process
#: :func:`models.solve.solve_milp` starts a :class:`SideBound` only when at least this many
#: seconds are left for the MILP. A child starts in about a second, and a short run gains
#: most from a second bound (``CHANGELOG.md``, "A side process from 4 s on").
SIDE_MIN_S = 4.0


def side_cores() -> int:
    """The cores this process may run on (a side process needs a second one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def _side_child(
    conn: Any, instance: Instance, data: OrbitData, seconds: float, lower_bound: float | None
) -> None:
    """A :class:`SideBound`'s process: :func:`colgen_bound` with branching for ``seconds``,
    sending ``("bound", value)`` whenever its bound rounded down falls, then ``("done",
    bound, schedule, profit)`` (``schedule`` None when the search ended on none), or
    ``("error", text)``."""
    child_setup()
    sent = [math.inf]

    def report(value: float) -> None:
        # integers only matter (weights are integers); one message per unit also keeps the
        # pipe from filling while the parent is busy with its MILP
        if math.floor(value + 1e-6) < sent[0]:
            sent[0] = math.floor(value + 1e-6)
            conn.send(("bound", float(value)))

    try:
        out = colgen_bound(
            instance, time_limit=seconds, lower_bound=lower_bound, data=data, branch=True,
            report=report,
        )  # fmt: skip
        conn.send(("done", float(out["bound"]), out.get("schedule"), out.get("profit")))
    except Exception as exc:  # pragma: no cover - HiGHS or pickling failures
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


class SideBound:
    """Column generation and branch and price in a child process, beside a MILP.

    On dense instances the MILP's dual bound moves little once its root is solved (C5: 540 s
    of MILP left the branch and price's 60 s bound as it was), while on others (B10, the
    openings cap binding) the MILP's cuts give the better bound. Run side by side, the least
    of the two bounds is valid and needs no choice between them beforehand; while the MILP
    runs, :meth:`watch` stops it when the child's bound proves a schedule optimal, and stops
    the child when the MILP's bound is the better one (:meth:`yield_to`). The child is
    started with ``spawn`` (as HiGHS's guarded solves,
    :func:`models.highs_direct._run_guarded`) and sends its bound whenever it falls by a
    unit, so stopping it at any time leaves a valid bound with the parent.

    Parameters
    ----------
    instance, data
        The problem and the items to price (the model's, as :func:`colgen_bound` takes them).
    seconds
        The child's time limit (it stops by itself then).
    lower_bound
        A known profit: the child stops once its bound meets it.
    """

    def __init__(
        self, instance: Instance, data: OrbitData, seconds: float, lower_bound: float | None
    ) -> None:
        self._child: Child | None = None
        try:
            self._child = Child(_side_child, (), (instance, data, seconds, lower_bound))
        except ChildStartError as exc:
            log.warning("%s; no side branch and price", exc)
        self.bound: float | None = None
        self.found: tuple[Any, float] | None = None
        self.lower_bound = lower_bound
        #: :func:`time.perf_counter` when :meth:`yield_to` stopped the child (else None).
        self.yielded_at: float | None = None
        #: :func:`time.perf_counter` when :meth:`watch` first found the child's bound to
        #: prove a schedule optimal (the MILP's incumbent, its start or its own; else None).
        self.proved_at: float | None = None
        self._done = self._child is None  # it did not start: nothing to read
        self._stopped = False

    def poll(self) -> float | None:
        """Read what the child has sent so far; its bound (not rounded), None before any."""
        return self._read(0.0)

    def _read(self, wait: float) -> float | None:
        """:meth:`poll`, also waiting up to ``wait`` seconds for the child's last message."""
        budget = Budget.of(wait)
        try:
            while not self._done and self._child.conn.poll(budget.left()):
                msg = self._child.conn.recv()
                if msg[0] == "error":  # pragma: no cover - see _side_child
                    log.warning("side branch and price failed: %s", msg[1])
                else:
                    self.bound = msg[1] if self.bound is None else min(self.bound, msg[1])
                    if msg[0] == "done" and msg[2] is not None:
                        self.found = (msg[2], float(msg[3]))
                self._done = msg[0] != "bound"
        except (EOFError, OSError):
            self._done = True
        return self.bound

    def watch(self, dual_bound: float, incumbent: float) -> bool:
        """A MILP's :func:`models.highs_direct.watching_bound` listener: True (stop the
        MILP) once the child's bound, rounded down, meets the MILP's ``incumbent``, the
        child's ``lower_bound`` (the MILP's start, which the MILP returns at least) or the
        profit of the schedule the child ended on: that schedule is then proven optimal
        (on generated instances of 300-500 targets the branch and price closes in seconds
        where HiGHS takes minutes, some of them in a presolve that reports nothing);
        otherwise :meth:`yield_to` the MILP's ``dual_bound`` (inf before HiGHS has one)."""
        if not self._stopped:
            self.poll()
            # the MILP's incumbent, the start it was given (the child's lower bound), or the
            # schedule the child ended on (its bound then is that schedule's profit)
            known = [incumbent, self.lower_bound, None if self.found is None else self.found[1]]
            best = max(x for x in known if x is not None)
            if self.bound is not None and math.floor(self.bound + 1e-6) <= best + 1e-6:
                log.info("the side branch and price proves %g optimal", best)
                if self.proved_at is None:
                    self.proved_at = time.perf_counter()
                return True
        self.yield_to(dual_bound)
        return False

    def yield_to(self, dual_bound: float) -> bool:
        """Stop the child once a MILP's ``dual_bound`` is below the child's own bound (both
        rounded down); True when it is stopped.

        The two bounds go different ways with the instance: on the dense C scenarios the
        MILP's never comes below the branch and price's (C5: 540 s), on B10 it does within a
        minute and then falls further by its cuts and branching, which HiGHS spreads over its
        worker threads (one per core). From then on the child's core is worth more to HiGHS
        (B10, 600 s: 6141 / 6156 with the child running to the end, 6146 / 6155 without it).
        Strictly below, and below a bound the child has sent: HiGHS's first bound is its LP
        relaxation's, which the column generation's root bound meets (C5: 2241), and the
        branch and price only then starts lowering its own. :meth:`watch` calls this.
        """
        if self._stopped:
            return True
        self.poll()
        if self.bound is None or not math.isfinite(dual_bound):
            return False
        if math.floor(dual_bound + 1e-6) >= math.floor(self.bound + 1e-6):
            return False
        log.info(
            "side branch and price stopped: the MILP's bound %.2f is below its %.2f",
            dual_bound, self.bound,
        )  # fmt: skip
        self.yielded_at = time.perf_counter()
        self.finish(0.0)
        return True

    def finish(self, wait: float = 0.5) -> tuple[float | None, tuple[Any, float] | None]:
        """Stop the child (after ``wait`` seconds for its last message, none once a stop was
        requested: the child does not know of it, and a Ctrl-C waited the 0.5 s, issue 63)
        and return its bound (not rounded; None if it sent none) and the schedule it ended
        on with its profit (or None)."""
        if not self._stopped and self._child is not None:
            self._read(0.0 if stop_requested() else wait)
            self._child.stop()
        self._stopped = True
        return self.bound, self.found
