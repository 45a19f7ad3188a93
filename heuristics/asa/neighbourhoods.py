"""The two neighbourhood structures of section 5.1 and the initial solution of 5.4.

Every function changes the :class:`~heuristics.asa.state.State` in place inside a journal
(``state.begin()`` was called by the caller), so the caller can evaluate the profit change and
either commit or roll back.
"""

from __future__ import annotations

import heapq
import logging
from itertools import islice

import numpy as np

from heuristics.asa.params import ASAParams
from heuristics.asa.select import roulette
from heuristics.asa.state import END, HI, LO, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.tabu import TabuList
from heuristics.timeline import OrbitTimeline
from sosp.ascent import UNLIMITED
from sosp.rules import range_empty
from sosp.stop import Budget

log = logging.getLogger(__name__)

#: Step 1 of the migration neighbourhood draws among this many scheduled tasks with the most
#: (3) conflicts (``docs/asa.md``, decision 7; 1 is the paper's deterministic rule). A
#: parameter before; on the tuning set no pool size was better on every instance
#: (``docs/asa.md``, "Readings measured").
MIGRATION_POOL = 8

#: Which neighbourhood: index into the selector's probabilities.
INSERTION, MIGRATION = 0, 1


# --------------------------------------------------------------------------- clustering test
def clustering_gain(
    state: State, line: OrbitTimeline, c: Cluster, x: int, params: ASAParams
) -> tuple[float, Cluster] | None:
    r"""Can option ``x`` join cluster-task ``c`` by (7), (11) and (16)? Returns (saving, new).

    (7): the common roll range (8) of ``c`` and ``x`` is not empty. (11): the new window (10)
    is at most Delta T. (16), with u the new cluster-task and h = c:

    .. math::
        \alpha\, ec + \beta\, wc < \alpha\, en + \beta\, wn,\qquad
        en = eo(d_c + d_x) + es(|\theta_c| + |\theta_x|)/v,\; wn = w(d_c + d_x),
        ec = eo(te_u - ts_u) + es|\theta_u|/v,\; wc = w(te_u - ts_u)      \quad (12)-(16)

    with :math:`\alpha = ConE/E`, :math:`\beta = ConW/W` of the orbit. As section 4.2 says,
    (16) only judges tasks that could also be observed one after the other: when ``x`` and
    ``c`` are exclusive by (3), clustering is always worth it and (16) is not applied.
    When both are 0 the test is degenerate (``0 < 0``) and sosp reads it with
    ``alpha = 1/E, beta = 1/W`` (``docs/asa.md``, decision 2). The saving is the right side
    minus the left side (capacity-normalised, ``alpha = 1/E, beta = 1/W``, when (16) is
    switched off); larger is better. With
    ``params.rule16_openings`` the openings (6) count as a third resource and every term is a
    share of its capacity: ``alpha (en - ec)/E + beta (wn - wc)/W + gamma (2 - 1)/c``, with
    ``gamma = openings used / c`` (``1/c`` on an orbit with none).
    """
    pb = state.pb
    lo = max(c[LO], pb.opt_lo[x])
    hi = min(c[HI], pb.opt_hi[x])
    if range_empty(lo, hi):
        return None  # (7)
    s = min(c[START], pb.opt_start[x])
    e = max(c[END], pb.opt_end[x])
    p = line.rules
    if not p.duration_ok(s, e):
        return None  # (11)
    new = state.cluster_with(c, x)
    span = e - s
    d_sep = (c[END] - c[START]) + (pb.opt_end[x] - pb.opt_start[x])
    en = p.energy(d_sep, p.turn(c[ROLL], state.single_roll[x]))  # apart: one slew between
    wn = p.memory(d_sep)
    ec = p.energy(span, p.slew(new[ROLL]))  # together: one window, one roll
    wc = p.memory(span)
    alpha = line.energy / p.energy_capacity if p.energy_capacity > 0 else 0.0
    beta = line.memory / p.memory_capacity if p.memory_capacity > 0 else 0.0
    openings = params.rule16_openings and p.max_openings > 0
    openings = openings and p.energy_capacity > 0 and p.memory_capacity > 0
    gamma = max(len(line.obs), 1) / p.max_openings if openings else 0.0

    def saving_of(capacity: bool) -> float:
        """Right side minus left side of (16); ``capacity``: the reading alpha = 1/E, beta = 1/W."""
        if openings:
            # three resources, each saving as a share of its capacity, weighted by the share
            # consumed (1 each in the capacity reading): one opening saved is worth 1/c
            wa, wb = (1.0, 1.0) if capacity else (alpha, beta)
            return (
                wa * (en - ec) / p.energy_capacity
                + wb * (wn - wc) / p.memory_capacity
                + gamma / p.max_openings
            )
        if capacity:
            wa = 1.0 / p.energy_capacity if p.energy_capacity > 0 else 0.0
            wb = 1.0 / p.memory_capacity if p.memory_capacity > 0 else 0.0
            return wa * (en - ec) + wb * (wn - wc)
        return alpha * (en - ec) + beta * (wn - wc)

    # (16) only judges tasks that could also be done one after the other (section 4.2):
    # tasks exclusive by (3) are always worth clustering.
    if pb.opt_start[x] >= c[START]:
        separable = not p.clash(c[END], c[ROLL], pb.opt_start[x], state.single_roll[x])
    else:
        separable = not p.clash(pb.opt_end[x], state.single_roll[x], c[START], c[ROLL])
    # an orbit that has consumed nothing is read with capacities (decision 2), as are the
    # tasks (16) does not judge when it is off
    degenerate = alpha == 0.0 and beta == 0.0
    saving = saving_of(capacity=degenerate or (separable and not params.rule16))
    return None if separable and params.rule16 and not saving > 0 else (saving, new)


# ------------------------------------------------------------------------------ insertion
def _best_join(
    state: State, line: OrbitTimeline, x: int, params: ASAParams, check: bool
) -> tuple[bool, float, int, Cluster] | None:
    """The cluster-task of ``line`` that option ``x`` joins best by (7), (11), (16) (DTC):
    ``(fits, saving, position, new cluster-task)``, where with ``check`` those that keep
    (3)-(6) (``fits``) rank first; None when it joins none."""
    found = None
    if state.pb.clustering:
        for pos, c in enumerate(line.obs):
            g = clustering_gain(state, line, c, x, params)
            if g is not None:
                cand = (check and line.check_replace(pos, g[1]), g[0], pos, g[1])
                if found is None or cand[:2] > found[:2]:
                    found = cand
    return found


def insert_options(
    state: State, options: list[int], params: ASAParams, protect: bool = True
) -> int:
    """Steps 2-7 of the insertion neighbourhood for one task, over the given options.

    Step 2-5: among the clustering-insertion opportunities (an option that can join a
    scheduled cluster-task by (7), (11), (16)) take the one on the orbit with most resources
    left, ``(E - ConE)/E + (W - ConW)/W``; on that orbit join the cluster-task with the
    largest saving in (16). Step 6: otherwise insert the option of the orbit with most
    resources left alone. Step 7: :func:`repair` the orbit, keeping the inserted option.

    Returns the option inserted, or -1 when the repair could not restore feasibility (the
    caller rolls back).
    """
    pb = state.pb
    lines = state.lines
    feasible_first = params.option_rule == "feasible-first"
    best = None  # (key, x, pos or -1, new cluster or None)
    for idx, x in enumerate(options):
        line = lines[pb.opt_orbit[x]]
        share = line.free_share()
        found = _best_join(state, line, x, params, feasible_first)
        if found is None:  # isolated insertion (step 6) ranks after clustering (steps 3-5)
            fits = feasible_first and line.check_insert(state.make_cluster((x,))).ok
            found = (fits, None, -1, None)
        item = ((found[0], found[1] is not None, share, -idx), x, found[2], found[3])
        if best is None or item[0] > best[0]:
            best = item
    if best is None:
        return -1
    _, x, pos, new = best
    place(state, x, new if new is not None else state.make_cluster((x,)), pos)
    if not repair(state, pb.opt_orbit[x], x if protect else -1):
        return -1
    return x


def place(state: State, x: int, new: Cluster, pos: int = -1, check=None) -> None:
    """Schedule option x as cluster-task ``new``: in place of the one at ``pos`` of its orbit,
    or inserted (``pos`` -1; ``check``: its :meth:`~OrbitTimeline.check_insert`)."""
    line = state.touch(state.pb.opt_orbit[x])
    if pos >= 0:
        line.replace(pos, new)
    else:
        line.insert(new, check)
    state.assign(state.pb.opt_unit[x], x)


def _last(c: Cluster, pb) -> int:
    """The component of a cluster-task that ends last (ties: the latest start, then index)."""
    return max(c[MEMBERS], key=lambda y: (pb.opt_end[y], pb.opt_start[y], y))


def _ends(c: Cluster, pb) -> tuple[int, ...]:
    """End components of a cluster-task: earliest start and latest end (5.1, step 7)."""
    if len(c[MEMBERS]) == 1:
        return c[MEMBERS]
    first, last = c[MEMBERS][0], _last(c, pb)
    return (first,) if last == first else (first, last)


def remove_member(state: State, j: int, pos: int, x: int) -> None:
    """Remove option x from the cluster-task at ``pos`` of orbit j, recomputing it (8)-(10)."""
    line = state.touch(j)
    line.replace(pos, state.cluster_without(line.obs[pos], x))
    state.unassign(state.pb.opt_unit[x])


def _removal_score(
    state: State, line: OrbitTimeline, pos: int, x: int, cap: int = 0
) -> tuple[float, float, int]:
    """(resource use freed per profit lost (inf: none lost), resource use freed, openings
    freed) if x leaves the cluster at pos; with ``cap`` > 0 the use counts an opening freed
    as ``1 / cap``."""
    c = line.obs[pos]
    new = state.cluster_without(c, x)
    if new is not None and not (
        (pos == 0 or line.obs[pos - 1][START] <= new[START])
        and (pos + 1 == len(line.obs) or new[START] <= line.obs[pos + 1][START])
    ):
        # Shrinking reorders the line (only in a transient conflict): estimate by the window.
        d_obs, d_slew = -((c[END] - c[START]) - (new[END] - new[START])), 0.0
    else:
        d_obs, d_slew = line.delta_replace(pos, new)
    p = line.rules
    # resources freed, as a share of capacity (the free-share measure of 5.1 step 5)
    e_cap, m_cap = p.energy_capacity, p.memory_capacity
    d_e, d_w = -p.energy(d_obs, d_slew), -p.memory(d_obs)
    use = (d_e / e_cap if e_cap > 0 else 0.0) + (d_w / m_cap if m_cap > 0 else 0.0)
    lost, opened = state.loss(state.pb.opt_unit[x]), 1 if new is None else 0
    if cap > 0:
        use += opened / cap
    return use / lost if lost > 0 else float("inf"), use, opened


def repair(state: State, j: int, protect: int = -1) -> bool:
    """Step 7: restore (3), then (4)-(6), on orbit j, never removing option ``protect``.

    (3): while two consecutive cluster-tasks clash, trim the one not holding ``protect`` at the
    facing end (the left one loses its latest-ending component, the right one its earliest);
    if neither holds it, trim the one with the larger resource use per unit of profit.
    (4)-(6): while a capacity is exceeded, remove one end component (earliest or latest window
    of a cluster-task; the whole task when it is alone) with the largest resource use per
    profit lost, ``((dE)/E + (dW)/W [+ 1/c when (6) binds]) / loss``, among those freeing a
    resource that is exceeded. Each removal recomputes the cluster-task by (8)-(10).

    Returns False when nothing removable is left and the orbit is still infeasible.
    """
    pb = state.pb
    line = state.lines[j]
    while True:
        p = line.first_conflict()
        if p >= 0:
            left, right = line.obs[p], line.obs[p + 1]
            lx, rx = _last(left, pb), right[MEMBERS][0]
            if protect in left[MEMBERS]:
                choice = (p + 1, rx)
            elif protect in right[MEMBERS]:
                choice = (p, lx)
            else:
                kl = _removal_score(state, line, p, lx)[0]
                kr = _removal_score(state, line, p + 1, rx)[0]
                choice = (p, lx) if kl >= kr else (p + 1, rx)
            if choice[1] == protect:
                return False
            remove_member(state, j, choice[0], choice[1])
            continue
        over_e, over_w, over_c = line.over()
        if not (over_e or over_w or over_c):
            return True
        best = fallback = None
        cap = line.rules.max_openings if over_c else 0
        for pos, c in enumerate(line.obs):
            for x in _ends(c, pb):
                if x == protect:
                    continue
                key, use, opened = _removal_score(state, line, pos, x, cap)
                frees = (over_e or over_w) and use > 0 or (over_c and opened)
                item = (key, -pos, -x, pos, x)
                if frees and (best is None or item > best):
                    best = item
                if fallback is None or item > fallback:
                    fallback = item
        pick = best if best is not None else fallback
        if pick is None:
            return False
        remove_member(state, j, pick[3], pick[4])


# --------------------------------------------------------------------- task choice (step 1)
def choose_unscheduled(
    state: State, rng: np.random.Generator, pool: int, tabu: TabuList | None
) -> int:
    """Step 1 of the insertion neighbourhood: the heaviest unscheduled non-tabu task.

    The paper's rule is deterministic; to avoid retrying one rejected move forever we draw by
    roulette, with probability proportional to weight, among the ``pool`` heaviest
    unscheduled non-tabu tasks (``pool = 1`` is the literal rule). For STC a task whose
    targets are all covered already adds nothing and is skipped. Returns -1 if none.
    """
    pb = state.pb
    weight = state.gain if pb.mode == "stc" else pb.unit_weight.__getitem__
    units = (state.rank_unit[r] for r in state.unscheduled)
    free = ((u, weight(u)) for u in units if tabu is None or u not in tabu)
    top = list(islice(((u, w) for u, w in free if w > 0), pool))
    if len(top) <= 1:
        return top[0][0] if top else -1
    wts = [w for _, w in top]
    return top[roulette(wts, rng.random() * sum(wts))][0]


def insertion_move(
    state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None
) -> bool:
    """The insertion and removal neighbourhood (5.1 (1), steps 1-7). False: no move."""
    u = choose_unscheduled(state, rng, params.pool, tabu)
    if u < 0:
        return False
    return insert_options(state, state.pb.unit_options[u], params) >= 0


# -------------------------------------------------------------------------------- migration
def choose_migrating(state: State, rng: np.random.Generator, pool: int) -> int:
    """Step 1 of migration: a scheduled task with many setup-time conflicting tasks.

    Candidates are scheduled units with somewhere to go (another option); the score of a unit
    is the number of its option's neighbours in the (3) conflict graph. Roulette by score
    among the ``pool`` highest (``pool = 1``: the literal rule). Returns -1 if none.
    """
    sched = state.sched
    score = state.pb.migration_score
    items = [(score[sched[u]], -u) for u in state.scheduled if score[sched[u]] >= 0]
    if not items:
        return -1
    top = heapq.nlargest(pool, items)
    if len(top) == 1:
        return -top[0][1]
    total = sum(s for s, _ in top)
    if total <= 0:
        return -top[int(rng.integers(len(top)))][1]
    return -top[roulette([s for s, _ in top], rng.random() * total)][1]


def try_insert_feasible(state: State, x: int, params: ASAParams) -> bool:
    """Insert option x only if (3)-(6) stay met (clustering first, by (7), (11), (16))."""
    line = state.lines[state.pb.opt_orbit[x]]
    found = _best_join(state, line, x, params, True)
    if found is not None and found[0]:
        place(state, x, found[3], found[2])
        return True
    single = state.make_cluster((x,))
    if chk := line.check_insert(single):
        place(state, x, single, check=chk)
    return bool(chk)


def migration_move(
    state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None
) -> bool:
    """The task migration neighbourhood (5.1 (2), steps 1-4). False: no move.

    1. choose a scheduled task with many setup-time conflicting tasks (:func:`choose_migrating`);
    2. remove it from its opportunity and insert it (DTC, NONTC) — or, for STC, the static
       task of another orbit sharing its targets — at another opportunity by clustering or
       isolated insertion, then repair that orbit (steps 2 and 4);
    3. on the freed orbit, insert its unscheduled, non-tabu setup-time conflicting tasks by
       decreasing weight while they fit, stopping at the first that does not (step 3);
    4. repair the freed orbit (step 4).
    """
    pb = state.pb
    u = choose_migrating(state, rng, MIGRATION_POOL)
    if u < 0:
        return False
    x_old = state.sched[u]
    j_old = pb.opt_orbit[x_old]
    remove_member(state, j_old, state.find(j_old, x_old), x_old)
    # Removing a component can move a cluster's midpoint roll: re-check the freed orbit.
    if not repair(state, j_old):
        return False
    if pb.mode == "stc":
        targets = [y for y in pb.alternatives[x_old] if state.sched[pb.opt_unit[y]] < 0]
        targets = [y for y in targets if tabu is None or pb.opt_unit[y] not in tabu]
    else:
        targets = pb.alternatives[x_old]
    if not targets or insert_options(state, targets, params) < 0:
        return False
    # Step 3: the freed resources go to u's unscheduled setup-time conflicting tasks.
    sched, unit = state.sched, pb.opt_unit
    # a DTC or NONTC unit is one target: its gain is its weight while unscheduled
    gain = state.gain if pb.mode == "stc" else pb.unit_weight.__getitem__
    gains = {y: gain(unit[y]) for y in pb.conflicts[x_old] if sched[unit[y]] < 0}
    cands = [y for y, g in gains.items() if g > 0 and (tabu is None or unit[y] not in tabu)]
    cands.sort(key=lambda y: (-gains[y], y))
    for y in cands:
        if state.sched[pb.opt_unit[y]] >= 0:
            continue  # another option of this unit went in meanwhile
        if not try_insert_feasible(state, y, params):
            break
    return repair(state, j_old)


# --------------------------------------------------------------------------- initial (5.4)
def initial_solution(state: State, params: ASAParams, budget: Budget = UNLIMITED) -> None:
    """Section 5.4: every task in decreasing weight goes through the insertion neighbourhood;
    the partial solution is kept only when it improves.

    Once ``budget`` expires (or a stop is requested) the tasks left are not tried: the
    solution so far is feasible, and on 20,000 targets the pass takes seconds."""
    pb = state.pb
    for u in list(state.rank_unit):
        if state.sched[u] >= 0 or state.gain(u) <= 0:
            continue
        if budget.expired():
            log.info("asa: initial solution stopped at the time limit")
            break
        state.attempt(lambda u=u: insert_options(state, pb.unit_options[u], params) >= 0, 1e-12)
