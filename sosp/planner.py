"""Exact single-orbit planning by dynamic programming over candidate observations.

On one orbit j, with each target given a price (what covering it is worth), the best plan is
a sequence of candidate observations (:func:`sosp.candidates.cluster_candidates`; every
feasible observation is dominated by one of them) that

* respects (3) between consecutive observations: with the conflict intervals of
  :mod:`models.cliques`, u may precede w iff ``R_u <= L_w``, where
  ``R_u = te_u + a + |theta_u| / v`` and ``L_w = ts_w - |theta_w| / v``. The condition splits
  into one number per item on each side, so "the best plan ending before w" is a prefix
  maximum over the items sorted by ``R``;
* opens the sensor at most c_j times (6). One sweep over the items sorted by ``R`` first
  gives the best plan of any length; when it has at most c_j observations it is the answer
  (on the tuning set's searches, every call). Otherwise the plan is built level by level,
  level n holding the best plan of at most n observations ending at each item (at most c_j
  levels, fewer when a level adds nothing);
* keeps (4) and (5). Their observation terms are sums over the plan; the slew term of (4) is
  ``es / v * (2 sum |theta| - |theta_first| - |theta_last|)`` over consecutive pairs, exact in
  the recursion (the first and the last observation each get ``es |theta| / v`` back). The
  knapsacks enter as Lagrangian penalties ``lam_e * energy / E + lam_w * memory / W``: with
  zero penalties the recursion maximises over (3) and (6) only, and the plan it finds is the
  exact optimum whenever it also fits (4)-(5) (:func:`best_feasible_path`).

Prices of the covered targets are summed per observation: a target seen twice on one orbit
(two passes) could be counted twice, which only over-estimates (harmless in a bound, and the
heuristic counts real coverage).

Dense orbits (thousands of opportunities, hundreds inside one Delta T) have hundreds of
thousands of candidates. They are held as numpy columns (:class:`sosp.candidates.OppGroups`,
no cap on their number), and on orbits of at least :data:`PRUNE_FROM` positions each pricing
first keeps only the positions that can be in a best plan at these prices (:func:`_useful`:
no gain, a worthless opportunity alone at an end of the window, or a same-window position of
no larger |theta| worth as much are dominated); the recursion then runs on those, with the
same optimum. :class:`PlanPool` plans every orbit at one price vector in worker processes.

:func:`plan_sequence` runs the same recursion on a stretch of an orbit given as plain
columns: between fixed neighbours (the observations before and after the stretch, which
stay), within what the orbit's other observations leave of (4)-(6); ASA-DTC's stretch moves
(:mod:`heuristics.asa.replan`) use it.

Built on the recursion: :func:`models.lagrangian.lagrangian_bound` (an upper bound with no LP
solver), ``orbit-dp`` (:mod:`heuristics.orbit_search`, an iterated local search whose move is
the exact re-planning of one orbit), ASA-DTC's whole-orbit move (:mod:`heuristics.asa.orbit`)
and the MILP LNS (:mod:`heuristics.lns`).
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from sosp.candidates import (
    OppGroups,
    Pace,
    as_budget,
    cluster_candidates,
    compile_within,
    flatten,
    offsets,
    ragged_positions,
)
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.parallel import Workers, cluster_size, fork_pool, inherited, is_client, local_processes
from sosp.recursion import least_penalty_plan, levels, recursion, release_order, restrict
from sosp.rules import EPS, OrbitRules, may_precede, orbit_rules, sequence_slew_time
from sosp.stop import Budget, stop_requested

log = logging.getLogger(__name__)


#: From this many (position, target) pairs on, an orbit's gains are one ``scipy.sparse`` CSR
#: product instead of ``np.bincount`` over ``price[target_flat]``: the product's fixed cost is
#: about 4 us, the gather and bincount's 2.7 us per 1000 pairs (C10's largest orbit, 310 000
#: pairs: 0.1 against 0.28 ms per orbit on average, a fifth of a plan).
_SPARSE_GAINS = 2000

#: From this many (position, target) pairs on, gains are ``np.add.reduceat`` over
#: ``price[target_flat]`` instead: no 0/1 matrix to hold (12 bytes a pair) on dense orbits
#: with millions of candidates.
_REDUCE_GAINS = 2_000_000

#: From this many positions on, :func:`best_path` first drops the positions that cannot be
#: in a best plan at the given prices (:func:`_useful`); below it the recursion runs on all
#: of them (the paper's scenarios: C10's largest orbit has about 30 000).
PRUNE_FROM = 100_000


@dataclass(frozen=True, eq=False)
class OrbitItems:
    """The candidate observations of one orbit, arranged for the recursion.

    Attributes
    ----------
    orbit
        Orbit index j.
    items
        Global candidate indices, in (start, end) order; positions below index into it.
    duration, roll, slew_s
        Per position: te - ts (seconds observed, (4)-(5)), the roll theta and |theta| / v
        (seconds of slew to or from nadir, (3)-(4)).
    by_release
        Positions sorted by ``R`` (the end of the conflict interval).
    n_before
        Per position w: how many positions of ``by_release`` may precede w by (3).
    target_ptr, target_flat, target_seg
        Covered targets per position (CSR: ``target_flat[target_ptr[u]:target_ptr[u+1]]``),
        and the position of each flat entry.
    targets
        The distinct targets any candidate of the orbit covers.
    rules
        The orbit's rules and parameters (:class:`sosp.rules.OrbitRules`).
    start, end, first_target, last_target
        Per position: the window (10) and the targets of the opportunities at its two ends
        (None when built without them; used by the pruning of :func:`best_path` on orbits of
        at least :data:`PRUNE_FROM` positions).
    """

    orbit: int
    items: np.ndarray
    duration: np.ndarray
    roll: np.ndarray
    slew_s: np.ndarray
    by_release: np.ndarray
    n_before: np.ndarray
    target_ptr: np.ndarray
    target_flat: np.ndarray
    targets: np.ndarray
    rules: OrbitRules
    start: np.ndarray | None = None
    end: np.ndarray | None = None
    first_target: np.ndarray | None = None
    last_target: np.ndarray | None = None

    @property
    def size(self) -> int:
        return len(self.items)

    @cached_property
    def target_seg(self) -> np.ndarray:
        """The position of each entry of ``target_flat`` (made on first use: only the small
        orbits' gains need it)."""
        return np.repeat(np.arange(self.size, dtype=np.int32), np.diff(self.target_ptr))

    @cached_property
    def incidence(self) -> Any:
        """Positions x targets 0/1 matrix (``scipy.sparse`` CSR over ``target_ptr`` and
        ``target_flat``), as many columns as the largest target covered plus one."""
        from scipy.sparse import csr_array

        cols = int(self.target_flat.max()) + 1 if len(self.target_flat) else 0
        data = np.ones(len(self.target_flat))
        return csr_array((data, self.target_flat, self.target_ptr), shape=(self.size, cols))

    def gains(self, price: np.ndarray) -> np.ndarray:
        """Sum of ``price`` over the targets each position covers."""
        nnz = len(self.target_flat)
        if nnz < _SPARSE_GAINS:
            return np.bincount(
                self.target_seg, weights=price[self.target_flat], minlength=self.size
            )
        if nnz >= _REDUCE_GAINS:
            # every candidate covers at least one target: no empty segment for reduceat
            return np.add.reduceat(
                np.asarray(price, dtype=float)[self.target_flat], self.target_ptr[:-1]
            )
        a = self.incidence
        return a @ np.ascontiguousarray(price[: a.shape[1]], dtype=float)

    @cached_property
    def windows(self) -> tuple[np.ndarray, np.ndarray]:
        """``(order, rank)``: positions by (start, end, |theta|, position), and each one's
        rank within its window (0 for the least |theta| of a window)."""
        if self.start is None or self.end is None:
            raise ValueError("windows: this OrbitItems was built without start and end")
        n = self.size
        order = np.lexsort((np.arange(n), self.slew_s, self.end, self.start))
        s, e = self.start[order], self.end[order]
        new = np.ones(n, dtype=bool)
        new[1:] = (s[1:] != s[:-1]) | (e[1:] != e[:-1])
        first = np.maximum.accumulate(np.where(new, np.arange(n), 0))
        return order, np.arange(n) - first

    def usage(self, path: np.ndarray) -> tuple[float, float]:
        """Energy (4) and memory (5) of a plan (positions in time order), slew term exact."""
        if len(path) == 0:
            return 0.0, 0.0
        return self.rules.usage(self.duration[path], self.roll[path])

    def fits(self, path: np.ndarray) -> bool:
        """Whether a plan keeps (4) and (5) ((3), (6) hold by construction)."""
        return self.rules.usage_ok(*self.usage(path))

    def covered(self, path: np.ndarray) -> np.ndarray:
        """The distinct targets a plan covers."""
        return np.unique(self.target_flat[flat_positions(self, path)])


@dataclass(frozen=True, eq=False)
class OrbitData:
    """Candidate observations of every orbit (the cluster model's items) for the recursion.

    ``orbit, start, end, roll, opps`` are the candidate columns (the attribute names of
    :class:`models.data.ModelData` that :func:`sosp.schedule.items_to_schedule` reads).
    """

    instance: Instance
    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: Sequence[tuple[int, ...]]
    orbits: tuple[OrbitItems, ...]
    target_orbits_ptr: np.ndarray
    target_orbits: np.ndarray

    @property
    def n_items(self) -> int:
        return len(self.opps)

    def orbits_seeing(self, targets: np.ndarray) -> np.ndarray:
        """Positions in :attr:`orbits` of the orbits with a candidate covering any target."""
        if len(targets) == 0:
            return np.zeros(0, dtype=np.int64)
        ptr = self.target_orbits_ptr
        parts = [self.target_orbits[ptr[k] : ptr[k + 1]] for k in targets]
        return np.unique(np.concatenate(parts))


def orbit_data(
    instance: Instance,
    deadline: Budget | float | None = None,
    workers: Workers = 1,
    roll: Callable[[OppGroups], np.ndarray] | None = None,
    generate_by: Budget | float | None = None,
) -> OrbitData:
    """Build :class:`OrbitData` from the cluster model's candidates.

    The candidates are generated orbit by orbit (:func:`sosp.candidates.orbit_candidates`)
    and held as numpy columns; there is no cap on their number (a dense orbit of C-region
    instances with 3 000 targets has about 600 000, some 50 MB).

    Parameters
    ----------
    instance
        The problem.
    deadline
        A :class:`~sosp.stop.Budget` (or a :func:`time.perf_counter` value) in which the
        candidates must be complete and fit (else :class:`~sosp.errors.InputError`, see
        :func:`sosp.candidates.cluster_candidates`).
    workers
        Processes generating the orbits' candidates side by side (1: in this process).
    roll
        A rule giving each candidate another roll from its covered opportunities (as
        :func:`with_rolls`, without arranging the candidates twice); None: the nadir-closest
        point of their common range.
    generate_by
        A smaller budget for the candidates' generation alone (the arranging keeps
        ``deadline``); None: ``deadline``.
    """
    by = deadline if generate_by is None else generate_by
    if local_processes(workers) > 1:
        from sosp.candidates import generate_in_processes

        generate_in_processes(instance, local_processes(workers), as_budget(by).deadline)
    orbit, start, end, nadir, opps = cluster_candidates(instance, max_candidates=None, deadline=by)
    rolls = nadir if roll is None else np.asarray(roll(opps), dtype=float)
    return _arrange(instance, orbit, start, end, rolls, opps, as_budget(deadline).deadline)


def with_rolls(data: OrbitData, roll: np.ndarray) -> OrbitData:
    """The same candidate observations at other rolls (one per candidate, in degrees).

    For searches whose observations follow another roll rule than the nadir-closest point
    (ASA-DTC's midpoint (9)): each roll must lie in the range of every covered opportunity
    (7), and then the recursion is exact for observations at these rolls.
    """
    return _arrange(
        data.instance, data.orbit, data.start, data.end, np.asarray(roll, dtype=float), data.opps
    )


def _arrange(
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    opps: Sequence[Sequence[int]],
    deadline: float | None = None,
) -> OrbitData:
    """Group candidate columns per orbit for the recursion (:class:`OrbitData`).

    With a ``deadline`` (a :func:`time.perf_counter` value), past it, the same one-line error
    as a candidate generation that ran out of time: millions of candidates take seconds to
    arrange, and one dense orbit alone more than a second, so the clock is read after each
    orbit and, before each orbit but the first, its time is foreseen at the rate of the
    orbits arranged so far; an orbit foreseen to end past the deadline is not started, and
    neither is the rest when it is foreseen to need more than
    ``sosp.candidates.FORESIGHT_MARGIN`` times the time left.
    ``roll`` must hold one value per candidate (else ValueError)."""
    if roll.shape != start.shape:
        raise ValueError(f"roll: expected {start.shape[0]} values, got {roll.shape}")
    opps = OppGroups.from_groups(opps)
    tgt = instance.opp_target
    groups: list[OrbitItems] = []
    seen_t: list[np.ndarray] = [np.zeros(0, dtype=np.int64)]
    seen_g: list[np.ndarray] = [np.zeros(0, dtype=np.int64)]
    if len(opps):
        order = np.lexsort((end, start, orbit))
        cuts = np.flatnonzero(np.diff(orbit[order])) + 1
        pace = Pace(deadline, time.perf_counter)  # this module's clock (tests replace it)
        for block in np.split(order, cuts):
            j = int(orbit[block[0]])
            now = pace.begin()
            if deadline is not None and pace.done:
                # this orbit foreseen to end past the deadline, or (as candidate generation
                # foresees it) the whole rest: given up at once
                if now + pace.need(len(block)) > deadline or pace.late(len(orbit) - pace.done, now):
                    raise _arrange_time_up(instance, j, len(orbit))
            rj = orbit_rules(instance, j)
            slew_s = rj.slew(roll[block])
            by_release, n_before = release_order(
                rj.left(start[block], roll[block]), rj.right(end[block], roll[block])
            )
            members = opps.take(block)
            flat, seg = _covered_targets(tgt, members)
            first_t, last_t = _end_targets(instance, members, start[block], end[block])
            ptr = offsets(np.bincount(seg, minlength=len(block)))
            targets = np.unique(flat)
            seen_t.append(targets.astype(np.int64))
            seen_g.append(np.full(len(targets), len(groups), dtype=np.int64))
            groups.append(
                OrbitItems(
                    orbit=j,
                    items=block,
                    duration=end[block] - start[block],
                    roll=roll[block],
                    slew_s=slew_s,
                    by_release=by_release,
                    n_before=n_before,
                    target_ptr=ptr,
                    target_flat=flat,
                    targets=targets,
                    rules=rj,
                    start=start[block],
                    end=end[block],
                    first_target=first_t,
                    last_target=last_t,
                )
            )
            pace.end(len(block))
            if deadline is not None and time.perf_counter() > deadline:
                raise _arrange_time_up(instance, j, len(orbit))
    # per target, the orbits (positions in ``groups``, increasing) with a candidate seeing it
    t_all, g_all = np.concatenate(seen_t), np.concatenate(seen_g)
    by_target = np.lexsort((g_all, t_all))
    tptr = offsets(np.bincount(t_all, minlength=instance.n_targets))
    return OrbitData(instance, orbit, start, end, roll, opps, tuple(groups), tptr, g_all[by_target])


def _arrange_time_up(instance: Instance, j: int, n_items: int) -> TimeLimitReached:
    return TimeLimitReached(
        f"orbit {instance.orbit_ids[j]!r}: time limit reached while arranging the candidate "
        f"observations ({n_items}); give more time or use asa-dtc"
    )


def _end_targets(
    instance: Instance, members: OppGroups, start: np.ndarray, end: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per group of opportunities: the target of the one member whose window starts at
    ``start``, and of the one whose window ends at ``end`` (the group's window (10)); -1
    where there is no such member or more than one (dropping that member would not shrink
    the window), which the pruning then leaves alone. int32."""
    ptr, flat = members.ptr, members.flat
    if len(ptr) == 1:
        return np.zeros(0, dtype=np.int32), np.zeros(0, dtype=np.int32)
    tgt = np.asarray(instance.opp_target)
    sizes = np.diff(ptr)
    out = []
    for times, bound, pick in (
        (instance.opp_start, start, np.minimum),
        (instance.opp_end, end, np.maximum),
    ):
        hit = times[flat] == np.repeat(bound, sizes)
        none = len(flat) if pick is np.minimum else -1
        where = pick.reduceat(np.where(hit, np.arange(len(flat)), none), ptr[:-1])
        once = np.add.reduceat(hit.astype(np.int64), ptr[:-1]) == 1
        found = once & (where >= 0) & (where < len(flat))
        t = np.full(len(sizes), -1, dtype=np.int32)
        t[found] = tgt[flat[where[found]]]
        out.append(t)
    return out[0], out[1]


def _covered_targets(opp_target: np.ndarray, opps: OppGroups) -> tuple[np.ndarray, np.ndarray]:
    """The distinct targets of each group of opportunities, sorted within the group, flat, and
    the group of each entry (both in group order; int32)."""
    sizes, flat_opps = flatten(opps)
    seg = np.repeat(np.arange(len(opps), dtype=np.int32), sizes)
    tg = opp_target[flat_opps].astype(np.int32)
    order = np.lexsort((tg, seg))
    tg, seg = tg[order], seg[order]
    keep = np.ones(len(tg), dtype=bool)
    keep[1:] = (tg[1:] != tg[:-1]) | (seg[1:] != seg[:-1])
    return tg[keep], seg[keep]


def best_path(
    o: OrbitItems,
    price: np.ndarray,
    lam_energy: float = 0.0,
    lam_memory: float = 0.0,
    prepared: Priced | None = None,
) -> tuple[float, np.ndarray]:
    """The best plan of one orbit under (3) and (6), knapsacks (4)-(5) as penalties.

    Maximises ``sum over the plan of (gain_u - lam_energy * energy_u / E - lam_memory *
    memory_u / W)``, with the slew term of (4) exact over consecutive observations (see the
    module docstring), over sequences of at most c_j observations pairwise compatible by (3).

    Parameters
    ----------
    o
        The orbit.
    price
        Per target of the instance, what covering it is worth (>= 0).
    lam_energy, lam_memory
        Penalties per whole capacity E_j, W_j (>= 0).
    prepared
        :func:`priced` of ``o`` at ``price``, when the caller has it (several penalties at
        one price vector).

    Returns
    -------
    tuple
        ``(value, path)``: the penalised value (0 for the empty plan, never below) and the
        plan's positions in time order.
    """
    if o.size == 0:
        return 0.0, np.zeros(0, dtype=np.int64)
    r = o.rules
    pe, pw = r.per_unit(lam_energy, lam_memory)
    sub = priced(o, price) if prepared is None else prepared
    if sub.keep is None:
        return recursion(o.slew_s, o.duration, sub.gain, o.by_release, o.n_before, r, pe, pw)
    keep = sub.keep
    rate = pe * r.observe_energy_rate + pw * r.memory_rate
    if rate > 0 and len(keep):
        # Under penalties a position worth no more than its observing penalty never helps a
        # plan: its gain net of penalties plus the slew it gives back at either end,
        # gain - rate * duration, is <= 0, so dropping it from any plan loses nothing.
        worth = sub.gain > rate * o.duration[keep]
        if np.count_nonzero(worth) < 0.8 * len(keep):
            keep = keep[worth]
            by_release, n_before = restrict(o.by_release, o.n_before, keep)
            sub = Priced(keep, sub.gain[worth], by_release, n_before)
    if len(keep) == 0:
        return 0.0, np.zeros(0, dtype=np.int64)
    value, path = recursion(
        o.slew_s[keep], o.duration[keep], sub.gain, sub.by_release, sub.n_before, r, pe, pw
    )
    return value, keep[path]


@dataclass(frozen=True, eq=False)
class Priced:
    """An orbit's positions at given prices, as :func:`best_path` uses them: the gains and,
    on orbits of at least :data:`PRUNE_FROM` positions, only the positions that can be in a
    best plan (:func:`_useful`) with their (3) order. The same for any penalties, so
    :func:`best_feasible_path` prepares it once per price vector.

    Attributes
    ----------
    keep
        Kept positions (sorted), or None for all.
    gain
        Gain per kept position.
    by_release, n_before
        As :class:`OrbitItems`' over the kept positions (None with ``keep`` None).
    """

    keep: np.ndarray | None
    gain: np.ndarray
    by_release: np.ndarray | None
    n_before: np.ndarray | None


def priced(o: OrbitItems, price: np.ndarray) -> Priced:
    """The :class:`Priced` positions of orbit ``o`` at ``price``."""
    gain = o.gains(price)
    if o.size >= PRUNE_FROM and o.start is not None:
        keep = _useful(o, gain, price)
        by_release, n_before = restrict(o.by_release, o.n_before, keep)
        return Priced(keep, gain[keep], by_release, n_before)
    return Priced(None, gain, None, None)


def _useful(o: OrbitItems, gain: np.ndarray, price: np.ndarray) -> np.ndarray:
    """Positions that may be in a best plan at these prices (sorted).

    Dropped, as each is dominated by a kept position (the recursion's optimum is unchanged;
    a tie may pick another plan of the same value):

    * a position covering nothing worth anything: removing an observation from a plan keeps
      (3)-(6) and never adds energy (``docs/model.md``);
    * one whose first or last opportunity (the only one at that end of its window) is worth
      nothing: the other members' nadir-closest common roll has no larger |theta| and their
      window (10) lies strictly inside, so a candidate with that window and roll covering
      them all exists (the candidates are all such observations up to domination) and is
      worth as much with a (3) interval inside this one's and no larger penalties;
    * one whose window holds a position of no larger |theta| (ties: the earlier) covering at
      least as much: the same window, so its (3) interval ``[ts - |theta| / v, te + a +
      |theta| / v)`` lies inside the dropped one's, its gain is no lower and its penalties
      no higher.

    Each domination moves to a strictly smaller window or, within a window, to an earlier
    position, so every dropped position has a kept one dominating it.
    """
    order, rank = o.windows
    g = gain[order]
    # inclusive running maximum of g within each window (Hillis-Steele scan, log2 passes)
    run = g.copy()
    shift = 1
    while shift < len(g) and (rank >= shift).any():
        cand = np.full(len(g), -np.inf)
        cand[shift:] = run[:-shift]
        run = np.where(rank >= shift, np.maximum(run, cand), run)
        shift *= 2
    before = np.full(len(g), -np.inf)
    before[1:] = run[:-1]
    before[rank == 0] = -np.inf
    ok = (g > 0.0) & (g > before)
    for ends in (o.first_target, o.last_target):
        if ends is not None:
            known = ends[order] >= 0
            ok &= ~known | (price[np.maximum(ends[order], 0)] > 0.0)
    return np.sort(order[ok])


def compile_kernels() -> None:
    """Compile (or load) the suite's numba kernels now (the planner's recursion, the
    candidates' cut to a stretch, :meth:`sosp.candidates.OrbitCandidates.within`, the
    window sweep, :func:`sosp.windows.compile_window_kernels`, and the (3) adjacency,
    :func:`sosp.conflicts.setup_conflict_rows`), so that no solver pays for them in the
    middle of a search: :func:`sosp.solve.solve` and :func:`models.solve.bound` call it
    through :func:`kernels_within`, inside their time limits."""
    from sosp.conflicts import compile_conflict_kernel
    from sosp.windows import compile_window_kernels  # sosp.windows imports this module

    # a stop requested meanwhile (Ctrl-C during a first compilation, seconds each) skips
    # the rest: a kernel still needed then compiles on its first use
    for compile_one in (levels, compile_within, compile_window_kernels, compile_conflict_kernel):
        if stop_requested():
            return
        compile_one()


#: The least share of a time limit a run keeps when loading the kernels took more than the
#: rest (the first run on a machine compiles them, seconds).
KERNEL_SHARE_LEFT = 0.25


def kernels_within(t0: float, time_limit: float | None) -> float | None:
    """Load the kernels (:func:`compile_kernels`) and return the deadline of a run started
    at ``t0`` (a :func:`time.perf_counter` reading) with ``time_limit`` seconds, or None.

    The load is part of the run's time: numba's import and its load from the disk cache
    take about 1.5 s in a fresh process, which a user timing ``sosp solve --time-limit 8``
    sees (it ended at 10.5 s when the load came before the clock). The run keeps at least
    :data:`KERNEL_SHARE_LEFT` of its limit after the load, so a first compilation does not
    leave it no time at all.
    """
    compile_kernels()
    if time_limit is None:
        return None
    return max(t0 + time_limit, time.perf_counter() + KERNEL_SHARE_LEFT * time_limit)


#: Bisection steps of :func:`plan_sequence` on its multiplier of (4)-(5).
LAGRANGE_ROUNDS = 10


def plan_sequence(
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    gain: np.ndarray,
    rules: OrbitRules,
    *,
    left: tuple[float, float] | None = None,
    right: tuple[float, float] | None = None,
    energy: float | None = None,
    memory: float | None = None,
    openings: int | None = None,
    rounds: int = LAGRANGE_ROUNDS,
) -> tuple[float, np.ndarray]:
    r"""The best sequence of candidate observations between fixed neighbours, within budgets.

    The recursion of :func:`best_path` over plain columns, for a stretch of an orbit whose
    other observations stay: it maximises the sum of ``gain`` over sequences in time order
    that keep (3) between consecutive observations, including the fixed neighbour ``left``
    before the first and ``right`` after the last; have at most ``openings`` observations
    (6); and keep the budgets of (4) and (5):

    .. math::
        eo \sum_u d_u + es \sum_{(u, w)} (|	heta_u| + |	heta_w|) / v \le energy, \qquad
        w \sum_u d_u \le memory,

    the slew sum over the consecutive pairs of ``left``, the sequence, ``right`` (so the turn
    between the two neighbours is the sequence's to pay, as when it is empty). The optimum
    under (3) and (6) is returned when it keeps the budgets (it is then exact); otherwise the
    budgets are priced by one multiplier ``t`` (``t / budget`` per unit, the energy budget
    net of the neighbours' own turn), bisected ``rounds`` times from ``t`` = the sum of the
    gains (where no sequence over the budgets can beat the empty one), and the best sequence
    within both budgets met is returned: a Lagrangian heuristic.

    Parameters
    ----------
    start, end, roll
        Per candidate: window (10) and roll (7), degrees.
    gain
        Per candidate, what observing it is worth (candidates of gain <= 0 are never used).
    rules
        The orbit's rules (:class:`sosp.rules.OrbitRules`).
    left, right
        ``(end, roll)`` of the fixed observation before the stretch and ``(start, roll)`` of
        the one after it, or None (the stretch reaches that end of the orbit).
    energy, memory
        Budgets of (4) and (5) (None: the orbit's capacities E_j, W_j).
    openings
        Most observations (None: c_j).
    rounds
        Bisection steps on the multiplier.

    Returns
    -------
    tuple
        ``(gain, positions)``: the sequence's summed gain and its candidates' indices in time
        order ((0.0, empty) when no sequence is worth anything).
    """
    nothing = (0.0, np.zeros(0, dtype=np.int64))
    e_budget = rules.energy_capacity if energy is None else float(energy)
    w_budget = rules.memory_capacity if memory is None else float(memory)
    cap = rules.max_openings if openings is None else int(openings)
    if cap <= 0 or e_budget < -EPS or w_budget < -EPS:
        return nothing
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    roll, gain = np.asarray(roll, dtype=float), np.asarray(gain, dtype=float)
    # (3) as interval ends (sosp.rules.may_precede): u may precede w iff R_u <= L_w + EPS
    lo, hi_end = rules.left(start, roll), rules.right(end, roll)
    ok = gain > 0.0
    left_slew = right_slew = None
    if left is not None:
        ok &= may_precede(rules.right(left[0], left[1]), lo)  # (3) after ``left``
        left_slew = float(rules.slew(left[1]))
    if right is not None:
        ok &= may_precede(hi_end, rules.left(right[0], right[1]))  # (3) before ``right``
        right_slew = float(rules.slew(right[1]))
    # the usable candidates in R order, so that the recursion's prefix maxima need no gather
    idx = np.flatnonzero(ok)
    if len(idx) == 0:
        return nothing
    idx = idx[np.argsort(hi_end[idx], kind="stable")]
    duration = (end - start)[idx]
    lo, hi_end, roll, gain = lo[idx], hi_end[idx], roll[idx], gain[idx]
    n_before = np.searchsorted(hi_end, lo + EPS, side="right")
    # rolls of the fixed neighbours, around the sequence in the exact slew of (4)
    lead = [float(left[1])] if left is not None else []
    trail = [float(right[1])] if right is not None else []
    # the turn between both neighbours is paid by every sequence, the empty one included
    base_slew = left_slew + right_slew if left_slew is not None and right_slew is not None else 0
    e_net = e_budget - rules.slew_energy_rate * base_slew
    if e_net < -EPS:
        return nothing  # the neighbours' turn alone is over the budget

    def plan(t: float) -> np.ndarray:
        pe, pw = t / max(e_net, EPS), t / max(w_budget, EPS)
        _, path = recursion(
            rules.slew(roll),
            duration,
            gain,
            None,
            n_before,
            rules,
            pe,
            pw,
            openings=cap,
            left_slew=left_slew,
            right_slew=right_slew,
        )
        return path

    def fits(path: np.ndarray) -> bool:
        rolls = np.concatenate((lead, roll[path], trail))
        observed = float(duration[path].sum())
        slew = sequence_slew_time(rolls, rules.slew_rate)
        return (
            rules.memory(observed) <= w_budget + EPS
            and rules.energy(observed, slew) <= e_budget + EPS
        )

    path = plan(0.0)
    if fits(path):
        return float(gain[path].sum()), idx[path]
    best_gain, best = nothing
    lo_t, hi_t = 0.0, float(gain.sum())
    for _ in range(rounds):
        t = 0.5 * (lo_t + hi_t)
        path = plan(t)
        if fits(path):
            hi_t = t
            value = float(gain[path].sum())
            if value > best_gain:
                best_gain, best = value, idx[path]
        else:
            lo_t = t
    return best_gain, best


def best_feasible_path(o: OrbitItems, price: np.ndarray) -> np.ndarray:
    """A plan of one orbit that keeps (3)-(6), exact when the knapsacks do not bind.

    The recursion without penalties gives the optimum over (3) and (6); when that plan also
    fits (4) and (5) it is optimal. Otherwise a common penalty on energy and memory (per unit
    of capacity) is doubled until the plan fits, then bisected 12 times towards the smallest
    penalty that fits: a Lagrangian heuristic, feasible but not proven optimal.
    """
    sub = priced(o, price)
    return least_penalty_plan(lambda t: best_path(o, price, t, t, sub)[1], o.fits)


def flat_positions(o: OrbitItems, path: np.ndarray) -> np.ndarray:
    """Indices into ``o.target_flat`` of the targets of the positions in ``path``."""
    return ragged_positions(o.target_ptr[path], np.diff(o.target_ptr)[path])


def _plans_of(
    orbits: tuple[OrbitItems, ...],
    idx: list[int],
    price: np.ndarray,
    lam: np.ndarray,
    until: float | None = None,
) -> list[tuple[float, np.ndarray, tuple[float, float] | None]] | None:
    """:func:`best_path` of the orbits ``idx`` at ``price`` and their rows of ``lam``: per orbit
    the value, the covered targets (with repeats) and the plan's (energy, memory) (None for the
    empty plan). None when ``until`` (a :func:`time.perf_counter` value, checked between
    orbits) passes first: a partial round is no bound."""
    out = []
    for g in idx:
        if until is not None and time.perf_counter() > until:
            return None
        o = orbits[g]
        v, path = best_path(o, price, float(lam[g, 0]), float(lam[g, 1]))
        if len(path):
            out.append((v, o.target_flat[flat_positions(o, path)], o.usage(path)))
        else:
            out.append((v, np.zeros(0, dtype=np.int32), None))
    return out


def _cluster_task(
    plans_of: Callable[..., list[Any]], part: tuple[Any, ...], price: np.ndarray, lam: np.ndarray
) -> list[Any]:
    """One group's plans on a Dask worker (``lam``: the group's rows)."""
    return plans_of(part, list(range(len(part))), price, lam)


#: Groups of orbits per worker thread of a Dask cluster (:class:`PlanPool`).
DASK_GROUPS_PER_THREAD = 4


def _balanced(orbits: Sequence[Any], k: int) -> list[list[int]]:
    """The orbits' indices in at most ``k`` groups of about equal size (positions; largest
    first, each to the lightest group), each sorted, none empty."""
    loads = np.zeros(max(1, min(k, len(orbits))))
    groups: list[list[int]] = [[] for _ in loads]
    for g in sorted(range(len(orbits)), key=lambda g: -orbits[g].size):
        i = int(np.argmin(loads))
        groups[i].append(g)
        loads[i] += orbits[g].size + 1
    return [sorted(x) for x in groups if x]


def _pool_task(
    task: tuple[list[int], np.ndarray, np.ndarray],
) -> list[tuple[float, np.ndarray, tuple[float, float] | None]]:
    idx, price, lam = task
    orbits, plans_of = inherited()  # the PlanPool's, forked with the worker
    return plans_of(orbits, idx, price, lam)


class PlanPool:
    """The best plans of every orbit at one price vector, in ``workers`` processes or on a
    Dask cluster.

    The orbits are shared with forked workers once (copy-on-write, nothing is pickled but
    the prices and the penalties of each call), split into ``workers`` groups of about equal
    size (positions), largest first. The results are those of one process, in orbit order,
    whatever ``workers`` is. With ``workers`` 1, or where processes cannot be forked, the
    plans are made here.

    With a Dask client as ``workers`` (:func:`sosp.parallel.dask_client`), the orbits are split
    into :data:`DASK_GROUPS_PER_THREAD` groups per worker thread (so that the scheduler
    balances uneven orbits and workers) and sent to the cluster once; each call then sends
    the prices once and one small task per group. The workers need sosp installed (the
    numba kernels compile once per machine, then load from their cache).

    Parameters
    ----------
    orbits
        The orbits (:attr:`OrbitData.orbits`, or any sized items ``plans_of`` takes).
    workers
        Processes, or a ``distributed.Client``.
    plans_of
        ``plans_of(orbits, idx, price, lam, until=None)``: the plans of the orbits ``idx`` as
        :meth:`best_paths` returns them, None when ``until`` passes first (default:
        :func:`best_path` over the candidates). Sent to a cluster by pickling: a module-level
        function or a :func:`functools.partial` of one.
    """

    def __init__(
        self,
        orbits: Sequence[Any],
        workers: Workers = 1,
        plans_of: Callable[..., list[Any]] | None = None,
    ) -> None:
        self.orbits = tuple(orbits)
        self.plans_of = _plans_of if plans_of is None else plans_of
        self.pool: Any = None
        self.client: Any = None
        self.parts: list[Any] = []  # on a cluster: each group's orbits, sent once
        self.groups: list[list[int]] = []
        if is_client(workers):
            if self.orbits:
                self.client = workers
                k = DASK_GROUPS_PER_THREAD * cluster_size(workers)
                self.groups = _balanced(self.orbits, k)
                # one future per group, so that a task finds its orbits on its worker
                self.parts = [
                    self.client.scatter([tuple(self.orbits[g] for g in idx)], hash=False)[0]
                    for idx in self.groups
                ]
        else:
            n = min(workers, len(self.orbits))
            self.pool = fork_pool(n, (self.orbits, self.plans_of))
            if self.pool is not None:
                self.groups = _balanced(self.orbits, n)

    def best_paths(
        self, price: np.ndarray, lam: np.ndarray, until: float | None = None
    ) -> list[tuple[float, np.ndarray, tuple[float, float] | None]] | None:
        """Per orbit (in order): :func:`best_path` value at ``price`` and penalties
        ``lam[g]`` (energy, memory), the targets its plan covers (with repeats) and the plan's
        (energy, memory), None for the empty plan. None when ``until`` (a
        :func:`time.perf_counter` value) passes before every orbit is planned: in this
        process it is checked between orbits; the workers are waited for until then (the
        pool is then closed)."""
        if self.client is not None:
            parts = self._on_cluster(price, lam, until)
        elif self.pool is None:
            idx = list(range(len(self.orbits)))
            return self.plans_of(self.orbits, idx, price, lam, until=until)
        else:
            job = self.pool.map_async(_pool_task, [(idx, price, lam) for idx in self.groups])
            try:
                parts = job.get(None if until is None else max(0.0, until - time.perf_counter()))
            except mp.TimeoutError:
                parts = None
        if parts is None:
            self.close()
            return None
        out: list[Any] = [None] * len(self.orbits)
        for idx, part in zip(self.groups, parts, strict=True):
            for g, res in zip(idx, part, strict=True):
                out[g] = res
        return out

    def _on_cluster(
        self, price: np.ndarray, lam: np.ndarray, until: float | None
    ) -> list[Any] | None:
        """The groups' plans from the cluster, None when ``until`` passes first (a worker's
        clock is not this one's: the deadline is kept here)."""
        from distributed import wait

        mu = self.client.scatter(price, broadcast=True, hash=False)
        jobs = [
            self.client.submit(_cluster_task, self.plans_of, part, mu, lam[idx], pure=False)
            for part, idx in zip(self.parts, self.groups, strict=True)
        ]
        timeout = None if until is None else max(0.0, until - time.perf_counter())
        try:
            wait(jobs, timeout=timeout)
        except TimeoutError:
            # the prices too: left to the garbage collector, the scheduler held them past
            # a 10 s wait in one CI run
            self.client.cancel([*jobs, mu])
            return None
        try:
            return self.client.gather(jobs)
        except Exception as exc:  # a worker without sosp, a lost worker: one line, no trace
            self.close()
            raise InputError(f"--dask: the cluster failed a pricing round: {exc!r}") from None

    def close(self) -> None:
        if self.pool is not None:
            self.pool.terminate()
            self.pool = None
        if self.client is not None:
            self.client.cancel(self.parts)  # the client is the caller's: only our data goes
            self.parts, self.client = [], None

    def __enter__(self) -> PlanPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
