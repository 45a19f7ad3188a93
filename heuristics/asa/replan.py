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
   unscheduled (and not tabu, unless this move freed them): every run of options that starts
   at some option, shares a roll r (0 or an end of a roll range, (7)) and ends within Delta T
   (11); members are the options whose window lies inside and whose range holds r, and the
   cluster-task is made by (8)-(10) with the search's roll rule. STC and NONTC use their units
   alone (no clustering);
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

from bisect import bisect_left

import numpy as np

from heuristics.asa.neighbourhoods import remove_member, repair
from heuristics.asa.params import ASAParams
from heuristics.asa.state import END, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.tabu import TabuList
from sosp.planner import plan_sequence
from sosp.rules import EPS

#: Index of this neighbourhood in the selector's probabilities (after insertion, migration).
REPLAN = 2

#: Levels of the ejection chain of a stretch move with ``replan_pull``: the orbits that lost a
#: task to the stretch are re-planned once, with unscheduled tasks only. (A parameter before;
#: an unbounded chain measured no better on B10, ``docs/asa.md``.)
EJECTION_DEPTH = 2

#: Subgradient rounds of the two-orbit re-planning (:func:`replan_pair`).
PAIR_ROUNDS = 6


def candidates(state: State, opts: list[int], dT: float) -> list[Cluster]:
    """Candidate cluster-tasks over ``opts`` (options of one orbit, sorted by start).

    DTC: for each first option i and each roll r in {0, ends of the ranges} inside i's range,
    every prefix (by end) of the options starting at or after i, ending by ``start_i + dT``
    (11) and holding r in their range (7). Duplicates (same members) are dropped. STC and
    NONTC: each option alone.
    """
    pb = state.pb
    if not pb.clustering:
        return [state.make_cluster((x,)) for x in opts]
    nadir = state.nadir
    # per position in ``opts``
    st = [pb.opt_start[x] for x in opts]
    en = [pb.opt_end[x] for x in opts]
    lo = [pb.opt_lo[x] for x in opts]
    hi = [pb.opt_hi[x] for x in opts]
    seen: set[int] = set()  # member sets as bit masks over positions in ``opts``
    out: list[Cluster] = []
    n = len(opts)
    for a, i in enumerate(opts):
        out.append(state.make_cluster((i,)))
        limit = st[a] + dT + EPS
        lo_i, hi_i = lo[a], hi[a]
        win = []  # positions b > a (same or later start: ``opts`` is sorted by start)
        for b in range(a + 1, n):
            if st[b] > limit:
                break
            if en[b] <= limit and lo[b] <= hi_i and hi[b] >= lo_i:
                win.append(b)
        if not win:
            continue
        rolls = {min(max(0.0, lo_i), hi_i), lo_i, hi_i}
        for b in win:
            if lo_i <= lo[b] <= hi_i:
                rolls.add(lo[b])
            if lo_i <= hi[b] <= hi_i:
                rolls.add(hi[b])
        win.sort(key=lambda b: (en[b], b))  # prefixes by end
        s0, e0 = st[a], en[a]
        for r in rolls:
            key = 1 << a
            cur = [a]
            e, lo_c, hi_c = e0, lo_i, hi_i
            for b in win:
                if not lo[b] <= r <= hi[b]:
                    continue
                key |= 1 << b
                cur.append(b)
                if en[b] > e:
                    e = en[b]
                if lo[b] > lo_c:
                    lo_c = lo[b]
                if hi[b] < hi_c:
                    hi_c = hi[b]
                if key in seen:
                    continue
                seen.add(key)
                roll = min(max(0.0, lo_c), hi_c) if nadir else 0.5 * (lo_c + hi_c)
                members = tuple(opts[c] for c in sorted(cur))
                out.append((s0, e, roll, lo_c, hi_c, members))
    return out


def best_chain(
    state: State,
    j: int,
    cands: list[Cluster],
    gains: list[float],
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
    # candidates worth nothing never help (plan_sequence drops them): not even converted
    use = [v for v, g in enumerate(gains) if g > 0.0]
    if not use:
        return 0.0, []
    cols = np.array([(*cands[v][:3], gains[v]) for v in use], dtype=float).T
    gain, chain = plan_sequence(
        cols[0],
        cols[1],
        cols[2],
        cols[3],
        state.lines[j].rules,
        left=None if left is None else (left[END], left[ROLL]),
        right=None if right is None else (right[START], right[ROLL]),
        energy=energy,
        memory=memory,
        openings=openings,
    )
    return gain, [use[v] for v in chain.tolist()]


def _around(opts: list[int], at: int, m: int) -> list[int]:
    """At most ``m`` consecutive options of ``opts`` centred on position ``at``."""
    lo = max(0, min(at - m // 2, len(opts) - m))
    return opts[lo : lo + m]


def replan_move(
    state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None
) -> bool:
    """Orbit re-planning (steps 1-5 of the module docstring). False: no move.

    The stretch is, with probability ``params.replan_target``, the ``replan_opps`` options
    around an option of an unscheduled task drawn as in step 1 of the insertion neighbourhood
    (roulette by weight among the ``pool`` heaviest non-tabu ones); otherwise a random stretch
    of a random orbit.

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
    depth = EJECTION_DEPTH
    holes = replan_stretch(state, j, window, tabu, pull if depth > 1 else 0.0)
    if holes is None:
        return False
    for level in range(2, depth + 1):
        nxt: list[tuple[int, int]] = []
        for i, x in holes:
            opts = pb.orbit_options[i]
            more = replan_stretch(
                state, i, _around(opts, opts.index(x), m), tabu, pull if level < depth else 0.0
            )
            nxt.extend(more or ())
        holes = nxt
    return all(repair(state, i) for i in state.touched_orbits())


class _Stretch:
    """A stretch of orbit j about to be re-planned: the freed cluster-tasks, the fixed
    neighbours, the budgets of (4)-(6) they leave, and the options that may be used."""

    __slots__ = ("j", "first", "freed", "left", "right", "energy", "memory", "openings")

    def __init__(self, state: State, j: int, window: list[int]) -> None:
        pb = state.pb
        st, en = pb.opt_start, pb.opt_end
        t0 = min(st[x] for x in window)
        t1 = max(en[x] for x in window)
        line = state.lines[j]
        obs = line.obs
        first = last = -1
        for pos, c in enumerate(obs):
            if c[END] >= t0 and c[START] <= t1:
                if first < 0:
                    first = pos
                last = pos
        if first >= 0:
            freed = obs[first : last + 1]
        else:
            first = sum(1 for c in obs if c[END] < t0)
            last = first - 1
            freed = []
        self.j, self.first, self.freed = j, first, freed
        self.left = obs[first - 1] if first > 0 else None
        self.right = obs[last + 1] if last + 1 < len(obs) else None
        # Budgets left by the fixed cluster-tasks (the pair left-right is the chain's to pay).
        p = line.rules
        rest_obs = line.observe - sum(c[END] - c[START] for c in freed)
        seq = [c for c in (self.left, *freed, self.right) if c is not None]
        rest_slew = line.slew - sum(line.turn(x, y) for x, y in zip(seq, seq[1:], strict=False))
        self.energy = p.energy_capacity - p.energy(rest_obs, rest_slew)
        self.memory = p.memory_capacity - p.memory(rest_obs)
        self.openings = p.max_openings - (len(obs) - len(freed))

    def units(self, state: State) -> set[int]:
        unit = state.pb.opt_unit
        return {unit[x] for c in self.freed for x in c[MEMBERS]}

    def options(self, state: State, t0: float, t1: float) -> list[int]:
        """Options of the orbit strictly between the fixed neighbours whose window lies in
        ``[t0, t1]`` (by start, as ``orbit_options``)."""
        pb = state.pb
        st, en = pb.opt_start, pb.opt_end
        lo_t = self.left[END] if self.left is not None else -np.inf
        hi_t = self.right[START] if self.right is not None else np.inf
        opts = pb.orbit_options[self.j]
        out = []
        for a in range(bisect_left(opts, t0, key=st.__getitem__), len(opts)):
            x = opts[a]
            if st[x] > t1:
                break
            if lo_t < st[x] and en[x] < hi_t and en[x] <= t1:
                out.append(x)
        return out

    def best(self, state: State, cands: list[Cluster], gains: list[float]):
        return best_chain(
            state,
            self.j,
            cands,
            gains,
            self.left,
            self.right,
            self.energy,
            self.memory,
            self.openings,
        )

    def free(self, state: State) -> None:
        line = state.touch(self.j)
        unit = state.pb.opt_unit
        for _ in self.freed:
            c = line.remove(self.first)
            for x in c[MEMBERS]:
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
                if sched[u] >= 0:
                    y = sched[u]
                    i = orbit[y]
                    if i == j:
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
    st, en = pb.opt_start, pb.opt_end
    t0 = min([st[x] for x in window] + [c[START] for c in stretch.freed])
    t1 = max([en[x] for x in window] + [c[END] for c in stretch.freed])
    avail = []
    value = {}
    for x in stretch.options(state, t0, t1):
        u = unit[x]
        if u in freed_units:
            value[x] = pb.unit_weight[u]
        elif tabu is not None and u in tabu:
            continue
        elif sched[u] < 0:
            value[x] = pb.unit_weight[u]
        elif pull > 0 and orbit[sched[u]] != j:
            value[x] = pull * pb.unit_weight[u]
        else:
            continue
        avail.append(x)
    if pb.mode == "stc":  # coverage semantics: a static task is worth its targets left
        tw, cover, targets = pb.target_weight, state.cover, pb.unit_targets
        held: dict[int, int] = {}
        for u in freed_units:
            for k in targets[u]:
                held[k] = held.get(k, 0) + 1
        # a target covered now is worth its weight only when freed tasks alone cover it
        back = {k: tw[k] for k, n in held.items() if cover[k] == n}
        freed_profit = sum(back.values())
        get = back.get
        # the candidates are the options alone (:func:`candidates`); only those worth
        # something can be in a best chain, so only they are made
        cands, gains = [], []
        for x in avail:
            w = sum([get(k, 0.0) if cover[k] else tw[k] for k in targets[unit[x]]])
            if w > 0:
                cands.append(state.make_cluster((x,)))
                gains.append(w)
        if len(cands) == len(stretch.freed) and set(cands) == set(stretch.freed):
            # Nothing but the freed tasks is worth anything here, each of them is, and they
            # keep (3)-(6) where they stand: they are the best chain, and the stretch is
            # already it (see below).
            return []
    else:
        cands = candidates(state, avail, state.lines[j].rules.max_duration)
        gains = [sum(value[x] for x in c[MEMBERS]) for c in cands]
        freed_profit = sum(pb.unit_weight[u] for u in freed_units)
    gain, chain = stretch.best(state, cands, gains)
    if gain < freed_profit - 1e-9:
        return None
    chosen = [cands[v] for v in chain]
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
    count: dict[int, int] = {}
    for x in window:
        for y in pb.alternatives[x]:
            if orbit[y] != j:
                count[orbit[y]] = count.get(orbit[y], 0) + 1
    if not count or (partner >= 0 and partner not in count):
        return None
    if partner >= 0:
        i = partner
    else:  # roulette by the number of shared options
        partners = sorted(count)
        z = rng.random() * sum(count.values())
        for i in partners:
            z -= count[i]
            if z < 0:
                break
    opts_i = pb.orbit_options[i]
    shared = sorted(opts_i.index(y) for x in window for y in pb.alternatives[x] if orbit[y] == i)
    window_i = _around(opts_i, shared[len(shared) // 2], m)
    sa, sb = _Stretch(state, j, window), _Stretch(state, i, window_i)
    freed = sa.units(state) | sb.units(state)
    sched = state.sched
    weight = pb.unit_weight

    def usable(stretch: _Stretch, win: list[int]) -> list[int]:
        st, en = pb.opt_start, pb.opt_end
        t0 = min([st[x] for x in win] + [c[START] for c in stretch.freed])
        t1 = max([en[x] for x in win] + [c[END] for c in stretch.freed])
        out = []
        for x in stretch.options(state, t0, t1):
            u = unit[x]
            if u in freed or (sched[u] < 0 and (tabu is None or u not in tabu)):
                out.append(x)
        return out

    ca = candidates(state, usable(sa, window), state.lines[j].rules.max_duration)
    cb = candidates(state, usable(sb, window_i), state.lines[i].rules.max_duration)
    units_a = [{unit[x] for x in c[MEMBERS]} for c in ca]
    units_b = [{unit[x] for x in c[MEMBERS]} for c in cb]
    both = set().union(*units_a) & set().union(*units_b) if ca and cb else set()
    mu = dict.fromkeys(both, 0.0)

    def gains(units: list[set[int]], skip: set[int] | None = None) -> list[float]:
        if skip is not None:
            return [sum(weight[u] for u in us if u not in skip) for us in units]
        return [sum(weight[u] - mu.get(u, 0.0) for u in us) for us in units]

    def taken(units: list[set[int]], chain: list[int]) -> set[int]:
        return set().union(*(units[v] for v in chain)) if chain else set()

    best = (-1.0, [], [])
    for r in range(PAIR_ROUNDS if both else 1):
        _, ch_a = sa.best(state, ca, gains(units_a))
        _, ch_b = sb.best(state, cb, gains(units_b))
        ta, tb = taken(units_a, ch_a), taken(units_b, ch_b)
        for first_a in (True, False):
            if first_a:
                g2, ch2 = sb.best(state, cb, gains(units_b, ta))
                value = sum(weight[u] for u in ta) + g2
                item = (value, [ca[v] for v in ch_a], [cb[v] for v in ch2])
            else:
                g2, ch2 = sa.best(state, ca, gains(units_a, tb))
                value = sum(weight[u] for u in tb) + g2
                item = (value, [ca[v] for v in ch2], [cb[v] for v in ch_b])
            if item[0] > best[0] + 1e-9:
                best = item
        step = 0.5 / (1 + r)
        for u in both:
            if u in ta and u in tb:
                mu[u] = min(weight[u], mu[u] + step * weight[u])
            elif u not in ta and u not in tb:
                mu[u] = max(0.0, mu[u] - step * weight[u])
    if best[0] < sum(weight[u] for u in freed) - 1e-9:
        return False
    sa.free(state)
    sb.free(state)
    sa.build(state, best[1])
    sb.build(state, best[2])
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
        before = state.profit
        state.begin()
        made = replan_pair(state, rng, j, window, m, tabu, partner=i)
        if (
            made
            and all(repair(state, h) for h in state.touched_orbits())
            and (state.profit >= before - 1e-9)
        ):
            state.commit()
            kept += 1
        else:
            state.rollback()
    return kept
