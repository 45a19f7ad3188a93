"""Incremental search state: per-orbit timelines of cluster-tasks, with an undo journal.

A cluster-task (an observation) is an immutable tuple
``(start, end, roll, lo, hi, members)``: window (10), roll (9) (or the nadir rule), common
roll range (8) and its component options sorted by start. Changing a cluster-task builds a new
tuple by (8)-(10) from its new members, so the roll and window are always recomputed whenever
its components change (section 5.1).

Each orbit keeps its cluster-tasks in a :class:`heuristics.timeline.OrbitTimeline` (the
timeline every insertion method shares: time order, totals of observation time and slew time
updated by deltas, constraints (3)-(6), (11)); a cluster-task is an entry whose payload is
``(lo, hi, members)``. A move is applied with a journal: the first time a move touches an
orbit, that orbit's short list (at most c_j + 1 entries) is saved, and every unit assignment
is logged; :meth:`State.rollback` restores both, so a rejected move costs no copy of the
schedule.
"""

from __future__ import annotations

from bisect import bisect_left, insort
from collections.abc import Callable
from functools import cached_property
from types import SimpleNamespace

import numpy as np

from heuristics.asa.problem import Problem
from heuristics.timeline import OrbitTimeline
from sosp.rules import RollRule, choose_roll, group_roll_ranges

#: Cluster tuple fields.
START, END, ROLL, LO, HI, MEMBERS = range(6)

Cluster = tuple  # (start, end, roll, lo, hi, members)

#: The options' float columns :attr:`State.arrays` holds (``Problem.opt_<name>``).
NUMERIC = ("start", "end", "lo", "hi")


class State:
    """Current solution: orbit lines, unit assignment, coverage, profit and the undo journal.

    Parameters
    ----------
    problem
        The flattened instance.
    roll_rule
        ``"midpoint"`` (9) or ``"nadir"`` for cluster-tasks of two or more components.
    nadir_singles
        Roll a single option to the point of its range closest to nadir (DTC only; otherwise
        it keeps its own roll).
    """

    def __init__(
        self, problem: Problem, roll_rule: str = "midpoint", nadir_singles: bool = False
    ) -> None:
        self.pb = problem
        self.roll_rule: RollRule = "nadir" if roll_rule == "nadir" else "midpoint"
        self.nadir_singles = nadir_singles and problem.clustering
        #: Roll of each option observed alone.
        self.single_roll = list(problem.opt_roll)
        if self.nadir_singles:
            self.single_roll = [
                min(max(0.0, lo), hi) for lo, hi in zip(problem.opt_lo, problem.opt_hi, strict=True)
            ]
        self.lines = [OrbitTimeline(p) for p in problem.orbits]
        # Units with options by weight: an unscheduled unit is held by its rank, kept sorted.
        self.rank_unit = sorted(
            (u for u in range(problem.n_units) if problem.unit_options[u]),
            key=lambda u: (-problem.unit_weight[u], u),
        )
        self.unit_rank = [-1] * problem.n_units
        for r, u in enumerate(self.rank_unit):
            self.unit_rank[u] = r
        # journal
        self._snaps: dict[int, tuple[list[Cluster], float, float]] = {}
        self._log: list[tuple[int, int]] = []
        self._profit0 = 0.0
        self._empty()

    def _empty(self) -> None:
        """Nothing scheduled: no unit assigned, no target covered, every unit unscheduled."""
        self.sched = [-1] * self.pb.n_units  # option of each unit, -1 when unscheduled
        self.cover = [0] * len(self.pb.target_weight)
        self.profit = 0.0
        self.unscheduled = list(range(len(self.rank_unit)))
        self.scheduled: set[int] = set()

    # -------------------------------------------------------------- journal
    def begin(self) -> None:
        """Start a move: later changes can be undone by :meth:`rollback`."""
        self._snaps.clear()
        self._log.clear()
        self._profit0 = self.profit

    def find(self, j: int, x: int) -> int:
        """Position on orbit j of the cluster-task holding option ``x`` (-1 if none)."""
        return next((pos for pos, c in enumerate(self.lines[j].obs) if x in c[MEMBERS]), -1)

    def touch(self, j: int) -> OrbitTimeline:
        """The line of orbit j, saved in the journal on first touch."""
        line = self.lines[j]
        if j not in self._snaps:
            self._snaps[j] = line.snapshot()
        return line

    def commit(self) -> list[int]:
        """End a move, keeping it; returns the units it removed (for the tabu list): those
        scheduled before the move and unscheduled after it, in removal order."""
        removed = list(dict.fromkeys(u for u, old in self._log if old >= 0 and self.sched[u] < 0))
        self._snaps.clear()
        self._log.clear()
        return removed

    def attempt(self, move: Callable[[], object], gain: float) -> bool:
        """Make ``move`` one journaled move and keep it when it returns true and the profit
        then exceeds the profit before by ``gain`` (negative: falls by less); else undo it.
        Returns whether it was kept."""
        before = self.profit
        self.begin()
        if move() and self.profit > before + gain:
            self.commit()
            return True
        self.rollback()
        return False

    def touched_orbits(self) -> list[int]:
        return list(self._snaps)

    def rollback(self) -> None:
        """Undo every change since :meth:`begin`."""
        for j, snap in self._snaps.items():
            self.lines[j].restore(snap)
        for u, old in reversed(self._log):
            if self.sched[u] >= 0:
                self._unset(u)
            if old >= 0:
                self._set(u, old)
        self.profit = self._profit0
        self._snaps.clear()
        self._log.clear()

    # ----------------------------------------------------- unit bookkeeping
    def _set(self, u: int, x: int) -> None:
        self.sched[u] = x
        tw, cover = self.pb.target_weight, self.cover
        for k in self.pb.unit_targets[u]:
            if cover[k] == 0:
                self.profit += tw[k]
            cover[k] += 1
        r, pool = self.unit_rank[u], self.unscheduled
        i = bisect_left(pool, r)  # the pool is sorted
        if i < len(pool) and pool[i] == r:
            pool.pop(i)
        self.scheduled.add(u)

    def _unset(self, u: int) -> None:
        self.sched[u] = -1
        tw, cover = self.pb.target_weight, self.cover
        for k in self.pb.unit_targets[u]:
            cover[k] -= 1
            if cover[k] == 0:
                self.profit -= tw[k]
        insort(self.unscheduled, self.unit_rank[u])
        self.scheduled.discard(u)

    def assign(self, u: int, x: int) -> None:
        """Schedule unit u at option x (bookkeeping only; the line is changed by the caller)."""
        self._log.append((u, self.sched[u]))
        self._set(u, x)

    def unassign(self, u: int) -> None:
        self._log.append((u, self.sched[u]))
        self._unset(u)

    def gain(self, u: int) -> float:
        """Profit a unit would add now (its targets not yet covered)."""
        tw, cover = self.pb.target_weight, self.cover
        return sum(tw[k] for k in self.pb.unit_targets[u] if cover[k] == 0)

    def loss(self, u: int) -> float:
        """Profit lost by unscheduling a scheduled unit (targets it alone covers)."""
        tw, cover = self.pb.target_weight, self.cover
        return sum(tw[k] for k in self.pb.unit_targets[u] if cover[k] == 1)

    # ------------------------------------------------------ cluster-tasks
    @cached_property
    def arrays(self) -> SimpleNamespace:
        """The options' ``start``, ``end``, ``lo``, ``hi``, ``single_roll`` and ``unit``, and
        the units' ``unit_weight``, as numpy columns (made on first use), for moves that
        build many cluster-tasks at once."""
        pb = self.pb
        cols = {k: np.asarray(getattr(pb, f"opt_{k}"), dtype=float) for k in NUMERIC}
        unit = np.asarray(pb.opt_unit, dtype=np.int64)
        weight = np.asarray(pb.unit_weight, dtype=float)
        single = np.asarray(self.single_roll, dtype=float)
        return SimpleNamespace(**cols, single_roll=single, unit=unit, unit_weight=weight)

    def group_rolls(self, ptr: np.ndarray, flat: np.ndarray) -> np.ndarray:
        """The roll :meth:`make_cluster` gives each group of options ``flat[ptr[g]:ptr[g + 1]]``
        (non-empty), for many groups at once: (9) or the nadir rule over the common range (8)
        (:func:`sosp.rules.group_roll_ranges`), a single option its own roll
        (:attr:`single_roll`)."""
        cols = self.arrays
        roll = choose_roll(*group_roll_ranges(cols.lo, cols.hi, ptr, flat), self.roll_rule)
        single = np.diff(ptr) == 1
        roll[single] = cols.single_roll[flat[ptr[:-1][single]]]
        return roll

    def make_cluster(self, members: tuple[int, ...]) -> Cluster:
        """The cluster-task of ``members`` (sorted by start) by (8)-(10) and (9) or nadir."""
        pb = self.pb
        st, en, lo_, hi_ = pb.opt_start, pb.opt_end, pb.opt_lo, pb.opt_hi
        if len(members) == 1:
            x = members[0]
            return (st[x], en[x], self.single_roll[x], lo_[x], hi_[x], members)
        s = min(st[x] for x in members)
        e = max(en[x] for x in members)
        lo = max(lo_[x] for x in members)
        hi = min(hi_[x] for x in members)
        return (s, e, choose_roll(lo, hi, self.roll_rule), lo, hi, members)

    def cluster_with(self, c: Cluster, x: int) -> Cluster:
        """``c`` with option ``x`` added (window (10), range (8), roll (9))."""
        pb = self.pb
        members = tuple(sorted(c[MEMBERS] + (x,), key=lambda y: (pb.opt_start[y], y)))
        s = min(c[START], pb.opt_start[x])
        e = max(c[END], pb.opt_end[x])
        lo = max(c[LO], pb.opt_lo[x])
        hi = min(c[HI], pb.opt_hi[x])
        return (s, e, choose_roll(lo, hi, self.roll_rule), lo, hi, members)

    def cluster_without(self, c: Cluster, x: int) -> Cluster | None:
        """``c`` without option ``x``, recomputed by (8)-(10); None if nothing is left."""
        members = tuple(y for y in c[MEMBERS] if y != x)
        return self.make_cluster(members) if members else None

    # ------------------------------------------------------------ snapshot
    def snapshot(self) -> list[list[Cluster]]:
        """The schedule as per-orbit cluster lists (cheap: tuples are immutable)."""
        return [list(line.obs) for line in self.lines]

    def load(self, snap: list[list[Cluster]]) -> None:
        """Make a snapshot (:meth:`snapshot`) the current solution, rebuilding the totals and
        the assignment from it (used to restart from the best; never inside a move)."""
        pb = self.pb
        self._empty()
        for line, obs in zip(self.lines, snap, strict=True):
            line.load(obs)
            for c in obs:
                for x in c[MEMBERS]:
                    self._set(pb.opt_unit[x], x)
        self._snaps.clear()
        self._log.clear()

    def check(self) -> bool:
        """Debug helper: every orbit feasible and the totals agree with a recount."""
        for line in self.lines:
            if not line.feasible():
                return False
            obs_t = sum(c[END] - c[START] for c in line.obs)
            slew = sum(line.turn(a, b) for a, b in zip(line.obs, line.obs[1:], strict=False))
            if abs(obs_t - line.observe) > 1e-6 or abs(slew - line.slew) > 1e-6:
                return False
        return True
