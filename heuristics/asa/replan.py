"""Orbit re-planning: a third neighbourhood for ASA-DTC (sosp's, not the paper's).

The two moves of Algorithm 1 insert one task and repair, or migrate one task and fill its
slot. Neither can re-cluster a whole stretch of an orbit at once, and on the reference
scenarios the search is flat after the first second well below the best known schedules
(``docs/asa.md``). This move frees a stretch of one orbit and rebuilds it by dynamic
programming:

1. choose an orbit uniformly among those with usable options, and on it a stretch of at most
   ``replan_opps`` consecutive options (the whole orbit when it has fewer);
2. free every cluster-task whose window meets the stretch (the stretch grows to hold them);
3. build candidate cluster-tasks over the options of the stretch whose tasks are now
   unscheduled (and not tabu, unless this move freed them): the clustering-exact model's
   candidate observations (:mod:`sosp.candidates`) cut to these options (:func:`candidates`),
   each made a cluster-task by (8)-(10) with the search's roll rule. STC and NONTC use their
   units alone (no clustering);
4. choose a chain of candidates by the single-orbit planner's recursion
   (:func:`sosp.planner.plan_sequence`, the one :func:`sosp.planner.best_path` runs on whole
   orbits): consecutive cluster-tasks, and the fixed neighbours on both sides, meet (3); at
   most the openings left (6); energy (4) (the turns to and from the neighbours included)
   and memory (5) within what the other cluster-tasks leave, priced by a Lagrange multiplier
   found by bisection when they bind (the best chain within both budgets is kept), so the
   chain is optimal for the candidates when (4), (5) do not bind and near-optimal otherwise;
5. put the chain in place of the freed cluster-tasks (a task with two options in the stretch
   is scheduled once) and repair the orbit as in step 7 (a safety net; the chain is feasible).

The move is judged by the annealing rule and feeds the adaptive selection (17)-(18) like the
others. A chain worth less than what was freed is not proposed (no move). Two variants widen
it: with ``replan_pull`` the stretch may take tasks observed on other orbits, whose stretches
are re-planned next (an ejection chain, :func:`replan_move`); with ``replan_pair`` two orbits
sharing tasks are re-planned together, the shared tasks split by Lagrangian relaxation of (2)
(:func:`replan_pair`). :func:`polish` applies the two-orbit move to every pair of orbits
when the search restarts from its best solution (``ASAParams.restart``).
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections import Counter

import numpy as np

from heuristics.asa.neighbourhoods import remove_member, repair
from heuristics.asa.params import ASAParams
from heuristics.asa.select import roulette
from heuristics.asa.state import END, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.tabu import TabuList
from sosp.candidates import (
    cached_orbit_candidates,
    generate,
    offsets,
    orbit_candidates,
    orbit_pairs,
)
from sosp.planner import plan_sequence

#: Index of this neighbourhood in the selector's probabilities (after insertion, migration).
REPLAN = 2

#: Levels of the ejection chain of a stretch move with ``replan_pull``: the orbits that lost a
#: task to the stretch are re-planned once, with unscheduled tasks only. (A parameter before;
#: an unbounded chain measured no better on B10, ``docs/asa.md``.)
EJECTION_DEPTH = 2

#: Subgradient rounds of the two-orbit re-planning (:func:`replan_pair`).
PAIR_ROUNDS = 6


#: Orbits with fewer (first, covered) pairs of options within Delta T than this
#: (:func:`sosp.candidates.orbit_pairs`) have their candidate observations generated on a
#: stretch's first visit (C10's densest orbit: 65,112 pairs, 33,081 candidates in 0.2 s). A
#: denser orbit's are used when the whole-orbit move has generated them; otherwise each
#: stretch generates its own over the options it may use.
LAZY_PAIRS = 100_000


class Cands:
    """Candidate cluster-tasks of a stretch as columns: windows (10), rolls and members.

    Attributes
    ----------
    start, end, roll
        Per candidate, as the cluster-task :meth:`State.make_cluster` makes of its members.
    ptr, flat
        Members (option indices, each group sorted by start) in CSR form.
    """

    __slots__ = ("start", "end", "roll", "ptr", "flat")

    def __init__(self, state: State, ptr: np.ndarray, flat: np.ndarray) -> None:
        self.ptr, self.flat = ptr, flat
        if len(ptr) == 1:
            self.start = self.end = self.roll = np.zeros(0)
            return
        cols = state.arrays
        self.start = np.minimum.reduceat(cols.start[flat], ptr[:-1])
        self.end = np.maximum.reduceat(cols.end[flat], ptr[:-1])
        self.roll = state.group_rolls(ptr, flat)

    def __len__(self) -> int:
        return len(self.ptr) - 1

    def members(self, v: int) -> tuple[int, ...]:
        return tuple(self.flat[self.ptr[v] : self.ptr[v + 1]].tolist())

    def sums(self, per_member: np.ndarray) -> np.ndarray:
        """Per candidate, the sum of ``per_member`` (one value per entry of ``flat``)."""
        if len(self) == 0:
            return np.zeros(0)
        return np.add.reduceat(per_member, self.ptr[:-1])


def candidates(state: State, j: int, opts: list[int]) -> Cands:
    """Candidate cluster-tasks over ``opts`` (options of orbit j, sorted by start).

    DTC: the clustering-exact model's candidate observations (:mod:`sosp.candidates`) over
    these options alone, each made a cluster-task by (8)-(10) and the search's roll rule.
    They are the orbit's candidates (generated once, :data:`LAZY_PAIRS`) that start and end
    within the options' span, each cut to the members among ``opts``: the candidate that
    dominates a cluster-task S of the orbit (the same window, a superset of S, a roll no
    farther from nadir) still does after the cut, since the members left include S and
    their common range (8) only widens. Cut to the same members, two are one. When the
    orbit's candidates are not at hand (a dense orbit), the generator runs over ``opts``
    (:func:`sosp.candidates.generate`). With the midpoint rule (9) the roll moves inside the
    same common range, so each candidate is still a feasible cluster-task (7). STC and NONTC:
    each option alone.
    """
    pb = state.pb
    flat = np.asarray(opts, dtype=np.int64)
    if not pb.clustering or len(opts) < 2:
        return Cands(state, np.arange(len(opts) + 1, dtype=np.int64), flat)
    # orbit j's candidate observations when at hand or cheap to make (LAZY_PAIRS)
    inst = pb.instance
    source = None if inst is None else cached_orbit_candidates(inst, j)
    if inst is not None and source is None and orbit_pairs(inst, j) < LAZY_PAIRS:
        source = orbit_candidates(inst, j)
    if source is None:
        cols = state.arrays
        args = [col[flat] for col in (cols.start, cols.end, cols.lo, cols.hi)]
        got = [(size, pos) for _, size, pos in generate(*args, pb.orbits[j].max_duration)]
        if not got:
            return Cands(state, np.zeros(1, dtype=np.int64), flat[:0])
        sizes, pos = zip(*got, strict=True)
        return Cands(state, offsets(np.concatenate(sizes)), flat[np.concatenate(pos)])
    t0, t1 = pb.opt_start[opts[0]], max(pb.opt_end[x] for x in opts)
    ptr, cut = source.within(flat, len(pb.opt_start), t0, t1)
    return Cands(state, ptr, cut)


def best_chain(
    state: State,
    j: int,
    cands: Cands,
    gains: np.ndarray,
    left: Cluster | None,
    right: Cluster | None,
    energy: float,
    memory: float,
    openings: int,
) -> tuple[float, list[int]]:
    """The best chain of candidates between the fixed neighbours ``left`` and ``right``.

    :func:`sosp.planner.plan_sequence` (the single-orbit planner's recursion) on the
    candidates' columns: (3) between consecutive cluster-tasks and the neighbours, at most
    ``openings`` of them (6), within the budgets ``energy`` (4) and ``memory`` (5) left by
    the orbit's other cluster-tasks (the turns to and from the neighbours included).

    Returns
    -------
    tuple
        ``(gain, chain)``: the summed gain and the candidates' indices in time order.
    """
    # candidates worth nothing never help (plan_sequence drops them): not even passed
    use = np.flatnonzero(gains > 0.0)
    if not len(use):
        return 0.0, []
    cols = (cands.start[use], cands.end[use], cands.roll[use], gains[use], state.lines[j].rules)
    fixed_l = None if left is None else (left[END], left[ROLL])
    fixed_r = None if right is None else (right[START], right[ROLL])
    budgets = {"energy": energy, "memory": memory, "openings": openings}
    gain, chain = plan_sequence(*cols, left=fixed_l, right=fixed_r, **budgets)
    return gain, use[chain].tolist()


def _around(opts: list[int], at: int, m: int) -> list[int]:
    """At most ``m`` consecutive options of ``opts`` centred on position ``at``."""
    lo = max(0, min(at - m // 2, len(opts) - m))
    return opts[lo : lo + m]


def replan_move(
    state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None
) -> bool:
    """Orbit re-planning (steps 1-5 of the module docstring). False: no move.

    The stretch is the ``replan_opps`` options around a random option of a random orbit; with
    probability ``params.replan_pair`` (DTC and NONTC) it is re-planned together with a
    stretch of another orbit (:func:`replan_pair`).

    With ``params.replan_pull > 0`` (DTC and NONTC) the stretch may also take tasks observed
    on other orbits, each worth ``replan_pull`` times its weight; they leave their orbit, and
    the stretch of each orbit they left (``replan_opps`` options around the hole) is then
    re-planned in turn: an ejection chain of :data:`EJECTION_DEPTH` levels, the last of which
    takes unscheduled tasks only.
    """
    pb = state.pb
    orbits = pb.replan_orbits
    if not orbits:
        return False
    m = params.replan_opps
    j = orbits[int(rng.integers(len(orbits)))]
    opts = pb.orbit_options[j]
    window = _around(opts, int(rng.integers(len(opts))), m)
    if pb.mode != "stc" and params.replan_pair > 0 and rng.random() < params.replan_pair:
        made = replan_pair(state, rng, j, window, m, tabu)
        if made is not None:
            return made and all(repair(state, i) for i in state.touched_orbits())
    pull = params.replan_pull if pb.mode != "stc" else 0.0
    holes = replan_stretch(state, j, window, tabu, pull)
    if holes is None:
        return False
    for level in range(2, EJECTION_DEPTH + 1):  # the last level pulls nothing
        pull, nxt = (pull if level < EJECTION_DEPTH else 0.0), []
        for i, x in holes:
            opts = pb.orbit_options[i]
            nxt += replan_stretch(state, i, _around(opts, opts.index(x), m), tabu, pull) or []
        holes = nxt
    return all(repair(state, i) for i in state.touched_orbits())


class _Stretch:
    """A stretch of orbit j about to be re-planned: the freed cluster-tasks, the fixed
    neighbours, the budgets of (4)-(6) they leave, and the options that may be used."""

    __slots__ = ("j", "first", "freed", "around")

    def __init__(self, state: State, j: int, window: list[int]) -> None:
        pb = state.pb
        st, en = pb.opt_start, pb.opt_end
        t0 = min(st[x] for x in window)
        t1 = max(en[x] for x in window)
        line = state.lines[j]
        obs = line.obs
        meets = [pos for pos, c in enumerate(obs) if c[END] >= t0 and c[START] <= t1]
        if meets:
            first, last = meets[0], meets[-1]
        else:  # nothing to free: the chain goes between the last before and the first after
            first = sum(1 for c in obs if c[END] < t0)
            last = first - 1
        self.j, self.first, self.freed = j, first, obs[first : last + 1]
        left = obs[first - 1] if first > 0 else None
        right = obs[last + 1] if last + 1 < len(obs) else None
        # The fixed neighbours and the budgets (4)-(6) the other cluster-tasks leave (the pair
        # left-right is the chain's to pay): :func:`best_chain`'s arguments after the gains.
        self.around = (left, right, *line.budget_between(first, last))

    def units(self, state: State) -> set[int]:
        unit = state.pb.opt_unit
        return {unit[x] for c in self.freed for x in c[MEMBERS]}

    def options(self, state: State, window: list[int]) -> list[int]:
        """Options of the orbit strictly between the fixed neighbours whose window lies in
        the span of ``window`` and the freed cluster-tasks (by start, as ``orbit_options``)."""
        pb = state.pb
        st, en = pb.opt_start, pb.opt_end
        t0 = min([st[x] for x in window] + [c[START] for c in self.freed])
        t1 = max([en[x] for x in window] + [c[END] for c in self.freed])
        left, right = self.around[:2]
        lo_t = left[END] if left is not None else -np.inf
        hi_t = right[START] if right is not None else np.inf
        opts = pb.orbit_options[self.j]
        a = bisect_left(opts, t0, key=st.__getitem__)
        b = bisect_right(opts, t1, key=st.__getitem__)  # by start, as ``orbit_options``
        return [x for x in opts[a:b] if lo_t < st[x] and en[x] < hi_t and en[x] <= t1]

    def best(self, state: State, cands: Cands, gains: np.ndarray) -> tuple[float, list[int]]:
        return best_chain(state, self.j, cands, gains, *self.around)

    def free(self, state: State) -> None:
        line = state.touch(self.j)
        unit = state.pb.opt_unit
        for _ in self.freed:
            for x in line.remove(self.first)[MEMBERS]:
                state.unassign(unit[x])

    def build(self, state: State, chain: list[Cluster]) -> list[tuple[int, int]]:
        """Insert the chain's cluster-tasks (tasks already scheduled on this orbit dropped,
        tasks scheduled on other orbits pulled from them); returns the holes it left."""
        pb = state.pb
        sched, unit, orbit = state.sched, pb.opt_unit, pb.opt_orbit
        j = self.j
        line = state.touch(j)
        holes = []
        for cand in chain:
            units: set[int] = set()
            members = []
            for x in cand[MEMBERS]:
                u = unit[x]
                if u in units:
                    continue  # a task twice in one cluster-task: once
                if (y := sched[u]) >= 0:
                    if (i := orbit[y]) == j:
                        continue  # a task twice in the stretch: once
                    remove_member(state, i, state.find(i, y), y)
                    holes.append((i, y))
                units.add(u)
                members.append(x)
            if not members:
                continue
            line.insert(state.make_cluster(tuple(members)))
            for x in members:
                state.assign(unit[x], x)
        # The chain is feasible by construction; a task dropped as a duplicate can move a
        # midpoint roll, and a pulled task can move its old cluster's: repair (step 7).
        for i in {j} | {i for i, _ in holes}:
            repair(state, i)
        return holes


def replan_stretch(
    state: State, j: int, window: list[int], tabu: TabuList | None, pull: float = 0.0
) -> list[tuple[int, int]] | None:
    """Free and rebuild the stretch of orbit j spanned by the options ``window``.

    Returns the options pulled from other orbits (orbit, option), or None when the best chain
    is worth less than what it would replace (nothing is changed then).
    """
    pb = state.pb
    stretch = _Stretch(state, j, window)
    freed_units = stretch.units(state)
    sched, unit, orbit = state.sched, pb.opt_unit, pb.opt_orbit
    value = {}  # each usable option's worth
    for x in stretch.options(state, window):
        u = unit[x]
        if u in freed_units:
            value[x] = pb.unit_weight[u]
        elif tabu is None or u not in tabu:
            if sched[u] < 0 or (pull > 0 and orbit[sched[u]] != j):
                value[x] = (1.0 if sched[u] < 0 else pull) * pb.unit_weight[u]
    avail = list(value)
    if pb.mode == "stc":  # coverage semantics: a static task is worth its targets left
        tw, cover, targets = pb.target_weight, state.cover, pb.unit_targets
        held = Counter(k for u in freed_units for k in targets[u])
        # a target covered now is worth its weight only when freed tasks alone cover it
        back = {k: tw[k] for k, n in held.items() if cover[k] == n}
        freed_profit = sum(back.values())
        get = back.get
        # the candidates are the options alone (:func:`candidates`); only those worth
        # something can be in a best chain, so only they are made
        worth_of = {
            x: sum([get(k, 0.0) if cover[k] else tw[k] for k in targets[unit[x]]]) for x in avail
        }
        worth = [x for x in avail if worth_of[x] > 0]
        if sorted(worth) == sorted(c[MEMBERS][0] for c in stretch.freed):
            # Nothing but the freed tasks is worth anything here, each of them is, and they
            # keep (3)-(6) where they stand: they are the best chain, and the stretch is
            # already it (see below).
            return []
        cands = candidates(state, j, worth)
        gains = np.asarray([worth_of[x] for x in worth], dtype=float)
    else:
        cands = candidates(state, j, avail)
        gains = cands.sums(np.array([value[x] for x in cands.flat.tolist()], dtype=float))
        freed_profit = sum(pb.unit_weight[u] for u in freed_units)
    gain, chain = stretch.best(state, cands, gains)
    if gain < freed_profit - 1e-9:
        return None
    chosen = [state.make_cluster(cands.members(v)) for v in chain]
    if chosen == stretch.freed:
        # The best chain is the stretch as it stands (the same cluster-tasks, tasks all of
        # this orbit): freeing and rebuilding it would give back the same state. A move that
        # changes nothing, as before, at no cost (the common case once the search settles).
        return []
    stretch.free(state)
    return stretch.build(state, chosen)


def replan_pair(
    state: State,
    rng: np.random.Generator,
    j: int,
    window: list[int],
    m: int,
    tabu: TabuList | None,
    partner: int = -1,
) -> bool | None:
    """Re-plan a stretch of orbit j together with a stretch of another orbit sharing its tasks
    (DTC and NONTC), drawn by roulette on the number of shared options. None: no partner.

    Which orbit takes a shared task is decided by Lagrangian relaxation of (2): each orbit is
    re-planned by :func:`best_chain` with a shared task worth ``w - mu``; ``mu`` rises when
    both take it and falls when neither does (:data:`PAIR_ROUNDS` rounds). Every round gives
    two schedules (one orbit's chain, then the other's best chain without its tasks, and the
    reverse); the best of them replaces the two stretches when it is worth at least what they
    held.
    """
    pb = state.pb
    unit, orbit = pb.opt_unit, pb.opt_orbit
    count = Counter(orbit[y] for x in window for y in pb.alternatives[x] if orbit[y] != j)
    if not count or (partner >= 0 and partner not in count):
        return None
    if partner >= 0:
        i = partner
    else:  # roulette by the number of shared options
        partners = sorted(count)
        weights = [count[i] for i in partners]
        i = partners[roulette(weights, rng.random() * sum(weights))]
    opts_i = pb.orbit_options[i]
    shared = sorted(opts_i.index(y) for x in window for y in pb.alternatives[x] if orbit[y] == i)
    window_i = _around(opts_i, shared[len(shared) // 2], m)
    sa, sb = _Stretch(state, j, window), _Stretch(state, i, window_i)
    freed = sa.units(state) | sb.units(state)
    sched = state.sched
    weight = pb.unit_weight

    def usable(stretch: _Stretch, win: list[int]) -> list[int]:
        return [
            x
            for x in stretch.options(state, win)
            if (u := unit[x]) in freed or (sched[u] < 0 and (tabu is None or u not in tabu))
        ]

    ca = candidates(state, j, usable(sa, window))
    cb = candidates(state, i, usable(sb, window_i))
    unit_of, w_unit = state.arrays.unit, state.arrays.unit_weight
    ua, ub = unit_of[ca.flat], unit_of[cb.flat]
    both = set(ua.tolist()) & set(ub.tolist())
    mu = np.zeros(len(weight))

    def gains(c: Cands, units: np.ndarray, skip: set[int] | None = None) -> np.ndarray:
        if skip is None:
            return c.sums(w_unit[units] - mu[units])
        values = w_unit.copy()
        values[list(skip)] = 0.0
        return c.sums(values[units])

    def taken(c: Cands, units: np.ndarray, chain: list[int]) -> set[int]:
        return {u for v in chain for u in units[c.ptr[v] : c.ptr[v + 1]].tolist()}

    best: tuple[float, list[int], list[int]] = (-1.0, [], [])
    for r in range(PAIR_ROUNDS if both else 1):
        _, ch_a = sa.best(state, ca, gains(ca, ua))
        _, ch_b = sb.best(state, cb, gains(cb, ub))
        ta, tb = taken(ca, ua, ch_a), taken(cb, ub, ch_b)
        # one orbit's chain, then the other's best without its tasks; and the reverse
        g_b, after_a = sb.best(state, cb, gains(cb, ub, ta))
        g_a, after_b = sa.best(state, ca, gains(ca, ua, tb))
        for item in (
            (sum(weight[u] for u in ta) + g_b, ch_a, after_a),
            (sum(weight[u] for u in tb) + g_a, after_b, ch_b),
        ):
            if item[0] > best[0] + 1e-9:
                best = item
        step = 0.5 / (1 + r)
        up = [u for u in both if u in ta and u in tb]
        down = [u for u in both if u not in ta and u not in tb]
        mu[up] = np.minimum(w_unit[up], mu[up] + step * w_unit[up])
        mu[down] = np.maximum(0.0, mu[down] - step * w_unit[down])
    if best[0] < sum(weight[u] for u in freed) - 1e-9:
        return False
    sa.free(state)
    sb.free(state)
    sa.build(state, [state.make_cluster(ca.members(v)) for v in best[1]])
    sb.build(state, [state.make_cluster(cb.members(v)) for v in best[2]])
    return True


def polish(state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None) -> int:
    """Two-orbit re-planning of every pair of orbits sharing options, once each in random
    order, keeping a move when it loses nothing (at most ``params.polish`` moves).

    Used when the search restarts from the best solution (``params.restart``): the annealing
    current solution rarely sits at the best long enough for the one two-orbit step that
    improves it. Returns the number of moves kept.
    """
    pb = state.pb
    if pb.mode == "stc":
        return 0
    orbit = pb.opt_orbit
    pairs: set[tuple[int, int]] = set()
    for j in pb.replan_orbits:
        for x in pb.orbit_options[j]:
            for y in pb.alternatives[x]:
                if orbit[y] != j:
                    pairs.add((j, orbit[y]))
    order = sorted(pairs)
    rng.shuffle(order)
    kept = 0
    m = params.replan_opps
    for j, i in order[: params.polish]:
        opts = pb.orbit_options[j]
        on_i = [a for a, x in enumerate(opts) if any(orbit[y] == i for y in pb.alternatives[x])]
        window = _around(opts, on_i[int(rng.integers(len(on_i)))], m)

        def pair(j: int = j, i: int = i, window: list[int] = window) -> bool:
            made = replan_pair(state, rng, j, window, m, tabu, partner=i)
            return bool(made) and all(repair(state, h) for h in state.touched_orbits())

        if state.attempt(pair, -1e-9):
            kept += 1
    return kept
