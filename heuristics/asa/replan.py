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
4. choose a chain of candidates by a longest-path dynamic program in time order: consecutive
   cluster-tasks, and the fixed neighbours on both sides, meet (3); the openings left (6) are a
   count dimension; energy (4) and memory (5) are priced by a Lagrange multiplier found by
   bisection (the best chain within both budgets is kept), so the chain is optimal for the
   candidates when (4), (5) do not bind and near-optimal otherwise;
5. put the chain in place of the freed cluster-tasks (a task with two options in the stretch
   is scheduled once) and repair the orbit as in step 7 (a safety net; the chain is feasible).

The move is judged by the annealing rule and feeds the adaptive selection (17)-(18) like the
others. A chain worth less than what was freed is not proposed (no move).
"""

from __future__ import annotations

import numpy as np

from heuristics.asa.neighbourhoods import remove_member, repair
from heuristics.asa.params import ASAParams
from heuristics.asa.problem import EPS
from heuristics.asa.state import END, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.tabu import TabuList

#: Index of this neighbourhood in the selector's probabilities (after insertion, migration).
REPLAN = 2

#: Bisection rounds on the Lagrange multiplier of (4), (5).
LAGRANGE_ROUNDS = 10


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
    st, en, lo, hi = pb.opt_start, pb.opt_end, pb.opt_lo, pb.opt_hi
    seen: set[tuple[int, ...]] = set()
    out: list[Cluster] = []
    n = len(opts)
    for a, i in enumerate(opts):
        limit = st[i] + dT + EPS
        lo_i, hi_i = lo[i], hi[i]
        win = []
        for b in range(n):
            x = opts[b]
            if b == a or st[x] < st[i] or (st[x] == st[i] and b < a):
                continue
            if st[x] > limit:
                break
            if en[x] <= limit and lo[x] <= hi_i and hi[x] >= lo_i:
                win.append(x)
        single = (i,)
        if single not in seen:
            seen.add(single)
            out.append(state.make_cluster(single))
        if not win:
            continue
        rolls = {min(max(0.0, lo_i), hi_i), lo_i, hi_i}
        for x in win:
            if lo_i <= lo[x] <= hi_i:
                rolls.add(lo[x])
            if lo_i <= hi[x] <= hi_i:
                rolls.add(hi[x])
        for r in rolls:
            mem = [x for x in win if lo[x] <= r <= hi[x]]
            if not mem:
                continue
            mem.sort(key=lambda y: (en[y], y))
            cur = [i]
            for x in mem:
                cur.append(x)
                key = tuple(sorted(cur, key=lambda y: (st[y], y)))
                if key not in seen:
                    seen.add(key)
                    out.append(state.make_cluster(key))
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
    r"""The best chain of candidates between the fixed neighbours ``left`` and ``right``.

    Maximises the sum of ``gains`` over a chain in time order meeting (3) between consecutive
    cluster-tasks (including ``left`` before the first and ``right`` after the last), with at
    most ``openings`` cluster-tasks (6) and within the budgets of (4) and (5):

    .. math::
        eo \sum_u d_u + es \sum_{(u, v)} (|\theta_u| + |\theta_v|)/v \le energy,\qquad
        w \sum_u d_u \le memory

    where the slew sum runs over the consecutive pairs of ``left``, the chain, ``right``.
    Energy and memory are priced by one multiplier ``t`` (per share of budget) and ``t`` is
    bisected; the best chain within both budgets is returned as (gain, candidate indices).
    """
    p = state.lines[j].p
    a, iv = p.a, 1.0 / p.v
    if openings <= 0 or energy < -EPS or memory < -EPS:
        return 0.0, []
    n = len(cands)
    # Events: node v is computed at s_v - a - |r_v|/v (the latest a predecessor may reach) and
    # offered to successors at e_v + |r_v|/v; (3) holds for u -> v iff offer_u <= compute_v.
    events = []
    for v, c in enumerate(cands):
        ar = abs(c[ROLL]) * iv
        events.append((c[START] - a - ar + EPS, 1, v))
        events.append((c[END] + ar, 0, v))
    if left is not None:
        events.append((left[END] + abs(left[ROLL]) * iv, 0, -1))
    events.sort()
    dur = [c[END] - c[START] for c in cands]
    turn = [abs(c[ROLL]) * iv for c in cands]
    lt = abs(left[ROLL]) * iv if left is not None else 0.0
    left_offer = left[END] + lt if left is not None else -np.inf
    rt = right_at = 0.0
    if right is not None:
        rt = abs(right[ROLL]) * iv
        right_at = right[START] - a - rt + EPS
    e_share = p.eo / energy if energy > EPS else np.inf
    w_share = p.w / memory if memory > EPS else np.inf
    s_share = p.es / energy if energy > EPS else np.inf

    def measure(chain: list[int]) -> tuple[float, float, float]:
        d = sum(dur[v] for v in chain)
        rolls = ([lt] if left is not None else []) + [turn[v] for v in chain]
        if right is not None:
            rolls.append(rt)
        slew = sum(x + y for x, y in zip(rolls, rolls[1:], strict=False))
        return sum(gains[v] for v in chain), d, slew

    def fits(d: float, slew: float) -> bool:
        return p.w * d <= memory + EPS and p.eo * d + p.es * slew <= energy + EPS

    def run(t: float, cap: int) -> list[int]:
        """Longest path with penalty t per share of the budgets, at most ``cap`` nodes."""
        node_pen = [t * dur[v] * (e_share + w_share) for v in range(n)] if t > 0 else [0.0] * n
        slew_pen = t * s_share if t > 0 else 0.0
        neg = -np.inf
        # best[k]: (value - slew_pen * turn, node) over the nodes offered so far with k in the
        # chain; node -1 is the start (``left`` once offered, or the orbit's start)
        best: list[tuple[float, int]] = [(neg, -2)] * (cap + 1)
        if left is None:
            best[0] = (0.0, -1)
        val = [[neg] * (cap + 1) for _ in range(n)]
        pred = [[-2] * (cap + 1) for _ in range(n)]
        for _, kind, v in events:
            if v < 0:  # ``left`` is offered
                best[0] = (-slew_pen * lt, -1)
                continue
            if kind == 0:
                tv = slew_pen * turn[v]
                row = val[v]
                for k in range(1, cap + 1):
                    x = row[k] - tv
                    if x > best[k][0]:
                        best[k] = (x, v)
                continue
            base = gains[v] - node_pen[v]
            tv = slew_pen * turn[v]
            row, prow = val[v], pred[v]
            for k in range(1, cap + 1):
                b, u = best[k - 1]
                if b == neg:
                    continue
                row[k] = base + b - (tv if u >= 0 or left is not None else 0.0)
                prow[k] = u
        # the end: ``right`` (with the slew from the last) or the end of the orbit
        end_val, end_node, end_k = neg, -2, 0
        if right is None:
            end_val, end_node, end_k = 0.0, -1, 0
            for v in range(n):
                row = val[v]
                for k in range(1, cap + 1):
                    if row[k] > end_val:
                        end_val, end_node, end_k = row[k], v, k
        else:
            rpen = slew_pen * rt
            if left is None:
                end_val, end_node, end_k = 0.0, -1, 0
            elif left_offer <= right_at:
                end_val, end_node, end_k = -slew_pen * lt - rpen, -1, 0
            for v in range(n):
                if cands[v][END] + turn[v] > right_at:
                    continue
                row = val[v]
                tv = slew_pen * turn[v] + rpen
                for k in range(1, cap + 1):
                    if row[k] - tv > end_val:
                        end_val, end_node, end_k = row[k] - tv, v, k
        chain = []
        v, k = end_node, end_k
        while v >= 0:
            chain.append(v)
            v, k = pred[v][k], k - 1
        chain.reverse()
        return chain

    cap = min(openings, n)
    if cap <= 0:
        return 0.0, []
    best_gain, best_ch = 0.0, []
    ch = run(0.0, cap)
    g, d, s = measure(ch)
    if fits(d, s):
        return g, ch
    lo_t, hi_t = 0.0, max(sum(gains), 1.0)
    for _ in range(LAGRANGE_ROUNDS):
        t = 0.5 * (lo_t + hi_t)
        ch = run(t, cap)
        g, d, s = measure(ch)
        if fits(d, s):
            if g > best_gain:
                best_gain, best_ch = g, ch
            hi_t = t
        else:
            lo_t = t
    return best_gain, best_ch


def replan_move(
    state: State, rng: np.random.Generator, params: ASAParams, tabu: TabuList | None
) -> bool:
    """Orbit re-planning (steps 1-5 of the module docstring). False: no move.

    With ``params.replan_pull > 0`` (DTC and NONTC) the stretch may also take tasks observed
    on other orbits, each worth ``replan_pull`` times its weight; they leave their orbit, and
    the stretch of each orbit they left (``replan_opps`` options around the hole) is then
    re-planned with the unscheduled tasks: an ejection chain of depth two.
    """
    pb = state.pb
    orbits = pb.replan_orbits
    if not orbits:
        return False
    j = orbits[int(rng.integers(len(orbits)))]
    opts = pb.orbit_options[j]
    m = params.replan_opps
    if len(opts) > m:
        s = int(rng.integers(len(opts) - m + 1))
        window = opts[s : s + m]
    else:
        window = opts
    pull = params.replan_pull if pb.mode != "stc" else 0.0
    holes = replan_stretch(state, j, window, tabu, pull)
    if holes is None:
        return False
    for i, x in holes:
        opts = pb.orbit_options[i]
        at = opts.index(x)
        lo = max(0, min(at - m // 2, len(opts) - m))
        replan_stretch(state, i, opts[lo : lo + m], tabu, 0.0)
    return all(repair(state, i) for i in state.touched_orbits())


def replan_stretch(
    state: State, j: int, window: list[int], tabu: TabuList | None, pull: float = 0.0
) -> list[tuple[int, int]] | None:
    """Free and rebuild the stretch of orbit j spanned by the options ``window``.

    Returns the options pulled from other orbits (orbit, option), or None when the best chain
    is worth less than what it would replace (nothing is changed then).
    """
    pb = state.pb
    st, en = pb.opt_start, pb.opt_end
    opts = pb.orbit_options[j]
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
        t0 = min(t0, obs[first][START])
        t1 = max(t1, obs[last][END])
        freed = obs[first : last + 1]
    else:
        first = sum(1 for c in obs if c[END] < t0)
        last = first - 1
        freed = []
    left = obs[first - 1] if first > 0 else None
    right = obs[last + 1] if last + 1 < len(obs) else None
    # Budgets left by the fixed cluster-tasks (the pair left-right is the chain's to pay).
    p = line.p
    rest_obs = line.observe - sum(c[END] - c[START] for c in freed)
    rest_slew = line.slew
    seq = ([left] if left is not None else []) + freed + ([right] if right is not None else [])
    rest_slew -= sum(line.turn(x, y) for x, y in zip(seq, seq[1:], strict=False))
    energy = p.E - p.eo * rest_obs - p.es * rest_slew
    memory = p.W - p.w * rest_obs
    openings = p.c - (len(obs) - len(freed))
    freed_units = {pb.opt_unit[x] for c in freed for x in c[MEMBERS]}
    lo_t = left[END] if left is not None else -np.inf
    hi_t = right[START] if right is not None else np.inf
    sched, unit, orbit = state.sched, pb.opt_unit, pb.opt_orbit
    avail = []
    value = {}
    for x in opts:
        if not (t0 <= st[x] and en[x] <= t1 and lo_t < st[x] and en[x] < hi_t):
            continue
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
    cands = candidates(state, avail, p.dT)
    if pb.mode == "stc":  # coverage semantics: a static task is worth its targets left
        tw, cover = pb.target_weight, state.cover
        held: dict[int, int] = {}
        for u in freed_units:
            for k in pb.unit_targets[u]:
                held[k] = held.get(k, 0) + 1
        freed_profit = sum(tw[k] for k, n in held.items() if cover[k] == n)
        gains = [
            sum(tw[k] for k in pb.unit_targets[unit[c[MEMBERS][0]]] if cover[k] == held.get(k, 0))
            for c in cands
        ]
    else:
        gains = [sum(value[x] for x in c[MEMBERS]) for c in cands]
        freed_profit = sum(pb.unit_weight[u] for u in freed_units)
    gain, chain = best_chain(state, j, cands, gains, left, right, energy, memory, openings)
    if gain < freed_profit - 1e-9:
        return None
    # Free the stretch, then put the chain in its place.
    line = state.touch(j)
    for _ in freed:
        c = line.remove(first)
        for x in c[MEMBERS]:
            state.unassign(unit[x])
    holes = []
    for v in chain:
        units: set[int] = set()
        members = []
        for x in cands[v][MEMBERS]:
            u = unit[x]
            if u in units:
                continue  # a task twice in one cluster-task: once
            if sched[u] >= 0:
                y = sched[u]
                i = orbit[y]
                if i == j:
                    continue  # a task twice in the stretch: once
                remove_member(state, i, state.lines[i].find(y), y)
                holes.append((i, y))
            units.add(u)
            members.append(x)
        if not members:
            continue
        line.insert(state.make_cluster(tuple(members)))
        for x in members:
            state.assign(unit[x], x)
    # The chain is feasible by construction; a task dropped as a duplicate can move a
    # midpoint roll, and a pulled task can move its old cluster's: repair both (step 7).
    for i in {j} | {i for i, _ in holes}:
        repair(state, i)
    return holes
