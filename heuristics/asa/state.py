"""Incremental search state: per-orbit timelines of cluster-tasks, with an undo journal.

A cluster-task (an observation) is an immutable tuple
``(start, end, roll, lo, hi, members)``: window (10), roll (9) (or the nadir rule), common
roll range (8) and its component options sorted by start. Changing a cluster-task builds a new
tuple by (8)-(10) from its new members, so the roll and window are always recomputed whenever
its components change (section 5.1).

Each orbit keeps its cluster-tasks in time order with the totals of observation time and slew
time, updated by deltas (constraints (4)-(6)). A move is applied with a journal: the first
time a move touches an orbit, that orbit's short list (at most c_j + 1 entries) is saved, and
every unit assignment is logged; :meth:`State.rollback` restores both, so a rejected move
costs no copy of the schedule.
"""

from __future__ import annotations

from bisect import insort

from heuristics.asa.problem import Problem
from sosp.rules import OrbitRules

#: Cluster tuple fields.
START, END, ROLL, LO, HI, MEMBERS = range(6)

Cluster = tuple  # (start, end, roll, lo, hi, members)


class OrbitLine:
    """Cluster-tasks of one orbit, sorted by (start, end), with running totals.

    Attributes
    ----------
    obs
        The cluster-tasks in time order.
    observe
        Total observation time, sum of te_u - ts_u (terms of (4), (5)).
    slew
        Total slew time over consecutive pairs, sum of (|theta_u| + |theta_v|)/v (4).
    """

    __slots__ = ("rules", "obs", "observe", "slew")

    def __init__(self, rules: OrbitRules) -> None:
        self.rules = rules
        self.obs: list[Cluster] = []
        self.observe = 0.0
        self.slew = 0.0

    # ------------------------------------------------------------ measures
    @property
    def energy(self) -> float:
        """ConE_j, the left side of (4)."""
        return self.rules.energy(self.observe, self.slew)

    @property
    def memory(self) -> float:
        """ConW_j, the left side of (5)."""
        return self.rules.memory(self.observe)

    def free_share(self) -> float:
        """Resources left, ``(E - ConE)/E + (W - ConW)/W`` (5.1, step 5)."""
        return self.rules.free_share(self.energy, self.memory)

    def turn(self, c1: Cluster, c2: Cluster) -> float:
        """Slew time between consecutive cluster-tasks (through nadir), as in (3)-(4)."""
        return self.rules.turn(c1[ROLL], c2[ROLL])

    def clash(self, c1: Cluster, c2: Cluster) -> bool:
        """True if c1 then c2 breaks (3)."""
        return self.rules.clash(c1[END], c1[ROLL], c2[START], c2[ROLL])

    def first_conflict(self) -> int:
        """Position p of the first consecutive pair (p, p+1) breaking (3), or -1."""
        obs = self.obs
        clash = self.rules.clash
        for p in range(len(obs) - 1):
            u, w = obs[p], obs[p + 1]
            if clash(u[END], u[ROLL], w[START], w[ROLL]):
                return p
        return -1

    def over(self) -> tuple[bool, bool, bool]:
        """Which of (4) energy, (5) memory, (6) openings is exceeded."""
        p = self.rules
        return (
            not p.energy_ok(self.observe, self.slew),
            not p.memory_ok(self.observe),
            len(self.obs) > p.max_openings,
        )

    def feasible(self) -> bool:
        e, m, c = self.over()
        return not (e or m or c) and self.first_conflict() < 0

    # -------------------------------------------------------------- deltas
    def _slew_around(self, pos: int, c: Cluster | None, skip: int) -> float:
        """Slew of the pairs touching position ``pos`` if it held ``c`` (None: removed).

        ``skip`` is 1 when the current entry at ``pos`` is replaced or removed, 0 when ``c`` is
        inserted before it.
        """
        obs = self.obs
        left = obs[pos - 1] if pos > 0 else None
        right = obs[pos + skip] if pos + skip < len(obs) else None
        if c is None:
            return self.turn(left, right) if left is not None and right is not None else 0.0
        s = 0.0
        if left is not None:
            s += self.turn(left, c)
        if right is not None:
            s += self.turn(c, right)
        return s

    def delta_replace(self, pos: int, c: Cluster | None) -> tuple[float, float]:
        """(d observe, d slew) of replacing the entry at ``pos`` by ``c`` (None: removing it).

        Valid when ``c`` keeps the time order (the caller checks).
        """
        old = self.obs[pos]
        d_obs = -(old[END] - old[START])
        if c is not None:
            d_obs += c[END] - c[START]
        d_slew = self._slew_around(pos, c, 1) - self._slew_around(pos, old, 1)
        return d_obs, d_slew

    def insert_pos(self, c: Cluster) -> int:
        key = (c[START], c[END])
        obs = self.obs
        pos = 0
        while pos < len(obs) and (obs[pos][START], obs[pos][END]) <= key:
            pos += 1
        return pos

    def delta_insert(self, pos: int, c: Cluster) -> float:
        """d slew of inserting ``c`` at ``pos``."""
        return self._slew_around(pos, c, 0) - self._slew_around(pos, None, 0)

    def check_insert(self, c: Cluster) -> bool:
        """Would inserting ``c`` keep (3)-(6) (on a currently feasible orbit)?"""
        p = self.rules
        if len(self.obs) >= p.max_openings:
            return False
        pos = self.insert_pos(c)
        obs = self.obs
        if pos > 0 and self.clash(obs[pos - 1], c):
            return False
        if pos < len(obs) and self.clash(c, obs[pos]):
            return False
        obs_t = self.observe + c[END] - c[START]
        slew = self.slew + self.delta_insert(pos, c)
        return p.fits(obs_t, slew)

    def check_replace(self, pos: int, c: Cluster) -> bool:
        """Would replacing the entry at ``pos`` by ``c`` keep (3)-(6)?"""
        obs = self.obs
        if pos > 0 and (
            (obs[pos - 1][START], obs[pos - 1][END]) > (c[START], c[END])
            or self.clash(obs[pos - 1], c)
        ):
            return False
        if pos + 1 < len(obs) and (
            (c[START], c[END]) > (obs[pos + 1][START], obs[pos + 1][END])
            or self.clash(c, obs[pos + 1])
        ):
            return False
        d_obs, d_slew = self.delta_replace(pos, c)
        p = self.rules
        obs_t = self.observe + d_obs
        return p.fits(obs_t, self.slew + d_slew)

    # ------------------------------------------------------------- updates
    def insert(self, c: Cluster) -> int:
        pos = self.insert_pos(c)
        self.slew += self.delta_insert(pos, c)
        self.observe += c[END] - c[START]
        self.obs.insert(pos, c)
        return pos

    def remove(self, pos: int) -> Cluster:
        d_obs, d_slew = self.delta_replace(pos, None)
        self.observe += d_obs
        self.slew += d_slew
        c = self.obs.pop(pos)
        if not self.obs:  # no drift on an emptied orbit
            self.observe = self.slew = 0.0
        return c

    def replace(self, pos: int, c: Cluster | None) -> None:
        """Replace (or with None remove) the entry at ``pos``, keeping the time order."""
        if c is None:
            self.remove(pos)
            return
        obs = self.obs
        key = (c[START], c[END])
        if (pos == 0 or (obs[pos - 1][START], obs[pos - 1][END]) <= key) and (
            pos + 1 == len(obs) or key <= (obs[pos + 1][START], obs[pos + 1][END])
        ):
            d_obs, d_slew = self.delta_replace(pos, c)
            self.observe += d_obs
            self.slew += d_slew
            obs[pos] = c
        else:
            self.remove(pos)
            self.insert(c)

    def find(self, x: int) -> int:
        """Position of the cluster-task holding option ``x`` (-1 if none)."""
        for pos, c in enumerate(self.obs):
            if x in c[MEMBERS]:
                return pos
        return -1

    def snapshot(self) -> tuple[list[Cluster], float, float]:
        return (list(self.obs), self.observe, self.slew)

    def restore(self, snap: tuple[list[Cluster], float, float]) -> None:
        self.obs, self.observe, self.slew = snap[0], snap[1], snap[2]


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
        self.nadir = roll_rule == "nadir"
        self.nadir_singles = nadir_singles and problem.clustering
        #: Roll of each option observed alone.
        self.single_roll = list(problem.opt_roll)
        if self.nadir_singles:
            self.single_roll = [
                min(max(0.0, lo), hi) for lo, hi in zip(problem.opt_lo, problem.opt_hi, strict=True)
            ]
        self.lines = [OrbitLine(p) for p in problem.orbits]
        self.sched = [-1] * problem.n_units  # option of each unit, -1 when unscheduled
        self.cover = [0] * len(problem.target_weight)
        self.profit = 0.0
        # Unscheduled units with options, as ranks (weight order) kept sorted.
        order = sorted(
            (u for u in range(problem.n_units) if problem.unit_options[u]),
            key=lambda u: (-problem.unit_weight[u], u),
        )
        self.rank_unit = order
        self.unit_rank = [-1] * problem.n_units
        for r, u in enumerate(order):
            self.unit_rank[u] = r
        self.unscheduled = list(range(len(order)))
        self.scheduled: set[int] = set()
        # journal
        self._snaps: dict[int, tuple[list[Cluster], float, float]] = {}
        self._log: list[tuple[int, int]] = []
        self._profit0 = 0.0

    # -------------------------------------------------------------- journal
    def begin(self) -> None:
        """Start a move: later changes can be undone by :meth:`rollback`."""
        self._snaps.clear()
        self._log.clear()
        self._profit0 = self.profit

    def touch(self, j: int) -> OrbitLine:
        """The line of orbit j, saved in the journal on first touch."""
        line = self.lines[j]
        if j not in self._snaps:
            self._snaps[j] = line.snapshot()
        return line

    def commit(self) -> list[int]:
        """End a move, keeping it; returns the units it removed (for the tabu list)."""
        removed = self.removed_units()
        self._snaps.clear()
        self._log.clear()
        return removed

    def removed_units(self) -> list[int]:
        """Units scheduled before the move and unscheduled after it, in removal order."""
        seen: set[int] = set()
        out = []
        for u, old in self._log:
            if old >= 0 and self.sched[u] < 0 and u not in seen:
                seen.add(u)
                out.append(u)
        return out

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
        self._pool_remove(u)
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

    def _pool_remove(self, u: int) -> None:
        r = self.unit_rank[u]
        pool = self.unscheduled
        # binary search: the pool is sorted
        lo, hi = 0, len(pool)
        while lo < hi:
            mid = (lo + hi) // 2
            if pool[mid] < r:
                lo = mid + 1
            else:
                hi = mid
        if lo < len(pool) and pool[lo] == r:
            pool.pop(lo)

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
    def make_cluster(self, members: tuple[int, ...]) -> Cluster:
        """The cluster-task of ``members`` (sorted by start) by (8)-(10) and (9) or nadir."""
        pb = self.pb
        if len(members) == 1:
            x = members[0]
            return (
                pb.opt_start[x],
                pb.opt_end[x],
                self.single_roll[x],
                pb.opt_lo[x],
                pb.opt_hi[x],
                members,
            )
        st, en, lo_, hi_ = pb.opt_start, pb.opt_end, pb.opt_lo, pb.opt_hi
        s = min(st[x] for x in members)
        e = max(en[x] for x in members)
        lo = max(lo_[x] for x in members)
        hi = min(hi_[x] for x in members)
        roll = min(max(0.0, lo), hi) if self.nadir else 0.5 * (lo + hi)
        return (s, e, roll, lo, hi, members)

    def cluster_with(self, c: Cluster, x: int) -> Cluster:
        """``c`` with option ``x`` added (window (10), range (8), roll (9))."""
        pb = self.pb
        members = tuple(sorted(c[MEMBERS] + (x,), key=lambda y: (pb.opt_start[y], y)))
        s = min(c[START], pb.opt_start[x])
        e = max(c[END], pb.opt_end[x])
        lo = max(c[LO], pb.opt_lo[x])
        hi = min(c[HI], pb.opt_hi[x])
        roll = min(max(0.0, lo), hi) if self.nadir else 0.5 * (lo + hi)
        return (s, e, roll, lo, hi, members)

    def cluster_without(self, c: Cluster, x: int) -> Cluster | None:
        """``c`` without option ``x``, recomputed by (8)-(10); None if nothing is left."""
        members = tuple(y for y in c[MEMBERS] if y != x)
        if not members:
            return None
        return self.make_cluster(members)

    # ------------------------------------------------------------ snapshot
    def snapshot(self) -> list[list[Cluster]]:
        """The schedule as per-orbit cluster lists (cheap: tuples are immutable)."""
        return [list(line.obs) for line in self.lines]

    def load(self, snap: list[list[Cluster]]) -> None:
        """Make a snapshot (:meth:`snapshot`) the current solution, rebuilding the totals and
        the assignment from it (used to restart from the best; never inside a move)."""
        pb = self.pb
        self.sched = [-1] * pb.n_units
        self.cover = [0] * len(pb.target_weight)
        self.profit = 0.0
        self.unscheduled = list(range(len(self.rank_unit)))
        self.scheduled = set()
        for line, obs in zip(self.lines, snap, strict=True):
            line.obs = list(obs)
            line.observe = sum(c[END] - c[START] for c in obs)
            line.slew = sum(line.turn(a, b) for a, b in zip(obs, obs[1:], strict=False))
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
