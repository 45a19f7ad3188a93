"""Incremental per-orbit state: observations in time order with resource totals.

Every method that builds schedules by insertion, ASA-DTC and the baselines alike, keeps one
:class:`OrbitTimeline` per orbit. An entry is a tuple whose first three fields are the window
and the roll, ``(start, end, roll, *payload)``: ASA's cluster-tasks
``(start, end, roll, lo, hi, members)`` (:mod:`heuristics.asa.state`) and the baselines'
``(start, end, roll, task)`` alike. A move is evaluated first (:meth:`OrbitTimeline.check_insert`,
:meth:`OrbitTimeline.check_replace`) and applied only if chosen; totals are updated by deltas,
never recomputed.

The constraints are those of ``docs/model.md``, taken from the kernel
:class:`sosp.rules.OrbitRules`: (3) setup and slew time between consecutive observations, (4)
energy with the slew term over consecutive pairs, (5) memory, (6) openings and (11) the longest
observation.
"""

from __future__ import annotations

from bisect import bisect_right
from typing import Any, NamedTuple

from sosp.instance import Instance
from sosp.rules import EPS, OrbitRules, alone_ok_mask, orbit_rules

__all__ = ["EPS", "Entry", "InsertCheck", "OrbitTimeline", "fits_alone", "task_entries"]

#: ``(start, end, roll, *payload)``: an observation's window [ts, te], its roll, then anything.
Entry = tuple

_INF = float("inf")


class InsertCheck(NamedTuple):
    """Outcome of :meth:`OrbitTimeline.check_insert`: truthy iff the insertion keeps the rules.

    Attributes
    ----------
    ok
        Whether (3)-(6) and (11) stay met.
    pos
        Where the entry goes (-1 when refused).
    d_slew
        Change of the orbit's slew seconds, the slew term of (4) (0 when refused).
    reason
        The constraint refused, ``"3"``, ``"4"``, ``"5"``, ``"6"`` or ``"11"`` (``""`` when ok).
    """

    ok: bool
    pos: int
    d_slew: float
    reason: str = ""

    def __bool__(self) -> bool:
        return self.ok


# Refusals carry no position: shared constants, so a refused check allocates nothing.
_NO3, _NO4, _NO5, _NO6, _NO11 = (InsertCheck(False, -1, 0.0, r) for r in ("3", "4", "5", "6", "11"))


class OrbitTimeline:
    """Entries of one orbit, sorted by (start, end), with running totals.

    Parameters
    ----------
    rules
        The orbit's rules (:func:`sosp.rules.orbit_rules`); :meth:`of` builds them from an
        instance.

    Attributes
    ----------
    rules
        The kernel's :class:`~sosp.rules.OrbitRules` of the orbit.
    obs
        The entries in time order: by (start, end), an entry inserted after those with the same
        key.
    observe
        Total observation time, sum of te - ts (the terms of (4), (5)).
    slew
        Total slew time over consecutive pairs, sum of (|theta_u| + |theta_w|)/v (4).
    """

    __slots__ = ("rules", "obs", "observe", "slew")

    def __init__(self, rules: OrbitRules) -> None:
        self.rules = rules
        self.obs: list[Entry] = []
        self.observe = 0.0
        self.slew = 0.0

    @classmethod
    def of(cls, instance: Instance, orbit: int) -> OrbitTimeline:
        """An empty timeline of orbit ``orbit`` of ``instance``."""
        return cls(orbit_rules(instance, orbit))

    def __len__(self) -> int:
        return len(self.obs)

    # ------------------------------------------------------------------------ measures
    @property
    def energy(self) -> float:
        """ConE_j, the left side of (4)."""
        return self.rules.energy(self.observe, self.slew)

    @property
    def memory(self) -> float:
        """ConW_j, the left side of (5)."""
        return self.rules.memory(self.observe)

    def free_share(self) -> float:
        """Resources left, ``(E - ConE)/E + (W - ConW)/W`` (the paper's 5.1, step 5)."""
        return self.rules.free_share(self.energy, self.memory)

    def turn(self, u: Entry, w: Entry) -> float:
        """Slew seconds between consecutive entries u then w (through nadir), (3)-(4)."""
        return self.rules.turn(u[2], w[2])

    def first_conflict(self) -> int:
        """Position p of the first consecutive pair (p, p+1) breaking (3), or -1."""
        obs = self.obs
        clash = self.rules.clash
        for p in range(len(obs) - 1):
            u, w = obs[p], obs[p + 1]
            if clash(u[1], u[2], w[0], w[2]):
                return p
        return -1

    def over(self) -> tuple[bool, bool, bool]:
        """Which of (4) energy, (5) memory, (6) openings is exceeded."""
        r = self.rules
        return (
            not r.energy_ok(self.observe, self.slew),
            not r.memory_ok(self.observe),
            len(self.obs) > r.max_openings,
        )

    def feasible(self) -> bool:
        """(3)-(6) hold on the orbit ((11) is checked per entry when it comes in)."""
        e, m, c = self.over()
        return not (e or m or c) and self.first_conflict() < 0

    # -------------------------------------------------------------------------- deltas
    def _slew_around(self, pos: int, entry: Entry | None, skip: int) -> float:
        """Slew of the pairs touching position ``pos`` if it held ``entry`` (None: nothing).

        ``skip`` is 1 when the current entry at ``pos`` is replaced or removed, 0 when
        ``entry`` goes in before it.
        """
        obs = self.obs
        turn = self.rules.turn
        right = pos + skip
        if entry is None:
            if pos > 0 and right < len(obs):
                return turn(obs[pos - 1][2], obs[right][2])
            return 0.0
        s = 0.0
        roll = entry[2]
        if pos > 0:
            s += turn(obs[pos - 1][2], roll)
        if right < len(obs):
            s += turn(roll, obs[right][2])
        return s

    def delta_replace(self, pos: int, entry: Entry | None) -> tuple[float, float]:
        """(d observe, d slew) of replacing the entry at ``pos`` by ``entry`` (None: removing
        it). Valid when ``entry`` keeps the time order (the caller checks)."""
        old = self.obs[pos]
        d_obs = -(old[1] - old[0])
        if entry is not None:
            d_obs += entry[1] - entry[0]
        d_slew = self._slew_around(pos, entry, 1) - self._slew_around(pos, old, 1)
        return d_obs, d_slew

    def check_insert(self, entry: Entry) -> InsertCheck:
        """Would inserting ``entry`` keep (11), (6), (3), (5), (4) (checked in this order, on
        a feasible orbit)? The result is truthy iff so, and says where and the slew delta, or
        which rule refused."""
        r = self.rules
        start, end, roll = entry[0], entry[1], entry[2]
        if not r.duration_ok(start, end):
            return _NO11
        obs = self.obs
        n = len(obs)
        if n >= r.max_openings:
            return _NO6
        # after every entry with (start, end) at most its own: the probe's third field (inf)
        # is above every roll, so tuple order never reaches the payloads
        pos = bisect_right(obs, (start, end, _INF))
        clash, turn = r.clash, r.turn
        # the same additions, in the same order, as an unchecked insert: equal totals to the bit
        d_slew = 0.0
        if pos > 0:
            u = obs[pos - 1]
            if clash(u[1], u[2], start, roll):
                return _NO3
            d_slew += turn(u[2], roll)
        if pos < n:
            w = obs[pos]
            if clash(end, roll, w[0], w[2]):
                return _NO3
            d_slew += turn(roll, w[2])
            if pos > 0:
                d_slew -= turn(u[2], w[2])
        observe = self.observe + (end - start)
        if not r.memory_ok(observe):
            return _NO5
        if not r.energy_ok(observe, self.slew + d_slew):
            return _NO4
        return InsertCheck(True, pos, d_slew)

    def check_replace(self, pos: int, entry: Entry) -> bool:
        """Would replacing the entry at ``pos`` by ``entry`` keep (11), (3)-(5) and the time
        order ((6) does not change)?"""
        r = self.rules
        start, end, roll = entry[0], entry[1], entry[2]
        if not r.duration_ok(start, end):
            return False
        obs = self.obs
        clash, turn = r.clash, r.turn
        old = obs[pos]
        # the slew of the pairs around pos with the new and the old entry, added as in
        # delta_replace (equal totals to the bit)
        s_new = s_old = 0.0
        if pos > 0:
            u = obs[pos - 1]
            if (u[0], u[1]) > (start, end) or clash(u[1], u[2], start, roll):
                return False
            s_new += turn(u[2], roll)
            s_old += turn(u[2], old[2])
        if pos + 1 < len(obs):
            w = obs[pos + 1]
            if (start, end) > (w[0], w[1]) or clash(end, roll, w[0], w[2]):
                return False
            s_new += turn(roll, w[2])
            s_old += turn(old[2], w[2])
        d_obs = -(old[1] - old[0]) + (end - start)
        return r.fits(self.observe + d_obs, self.slew + (s_new - s_old))

    # ------------------------------------------------------------------------- updates
    def insert(self, entry: Entry, check: InsertCheck | None = None) -> int:
        """Insert ``entry`` in time order; returns its position.

        With ``check`` (a successful :meth:`check_insert` of this entry on the unchanged
        timeline) its position and slew delta are used as they are. Without it nothing is
        checked: the orbit may become infeasible (ASA repairs it afterwards).
        """
        if check is None:
            pos = bisect_right(self.obs, (entry[0], entry[1], _INF))
            d_slew = self._slew_around(pos, entry, 0) - self._slew_around(pos, None, 0)
        elif check.ok:
            pos, d_slew = check.pos, check.d_slew
        else:
            raise ValueError(f"insert: the check refused the entry (rule {check.reason})")
        self.obs.insert(pos, entry)
        self.observe += entry[1] - entry[0]
        self.slew += d_slew
        return pos

    def remove(self, pos: int) -> Entry:
        """Remove the entry at ``pos`` and return it."""
        d_obs, d_slew = self.delta_replace(pos, None)
        self.observe += d_obs
        self.slew += d_slew
        entry = self.obs.pop(pos)
        if not self.obs:  # no drift on an emptied orbit
            self.observe = self.slew = 0.0
        return entry

    def discard(self, entry: Entry) -> None:
        """Remove ``entry`` (equal to an entry of the timeline)."""
        self.remove(self.obs.index(entry))

    def replace(self, pos: int, entry: Entry | None) -> None:
        """Replace (or with None remove) the entry at ``pos``, keeping the time order."""
        if entry is None:
            self.remove(pos)
            return
        obs = self.obs
        key = (entry[0], entry[1])
        if (pos == 0 or (obs[pos - 1][0], obs[pos - 1][1]) <= key) and (
            pos + 1 == len(obs) or key <= (obs[pos + 1][0], obs[pos + 1][1])
        ):
            d_obs, d_slew = self.delta_replace(pos, entry)
            self.observe += d_obs
            self.slew += d_slew
            obs[pos] = entry
        else:
            self.remove(pos)
            self.insert(entry)

    def load(self, entries: list[Entry]) -> None:
        """Make ``entries`` (in time order) the content, the totals recounted from scratch."""
        self.obs = list(entries)
        self.observe = sum(e[1] - e[0] for e in self.obs)
        self.slew = sum(self.turn(a, b) for a, b in zip(self.obs, self.obs[1:], strict=False))

    def budget_between(
        self, first: int, last: int, *, ends_paid: bool = False
    ) -> tuple[float, float, int]:
        """What the entries outside positions ``first..last`` (a stretch to re-plan between
        its fixed neighbours, the entries at ``first - 1`` and ``last + 1`` when there are;
        ``last = first - 1`` for an empty stretch) leave of (4)-(6): ``(energy, memory,
        openings)``.

        The turn between the two neighbours is not charged: every plan of the stretch pays
        it, the empty one included (:func:`sosp.planner.plan_sequence`). With ``ends_paid``
        each neighbour's turn to nadir is charged instead (``|theta| / v`` each, the turn
        between them when both are there): a plan may then count every new observation's
        slew twice, ``2 |theta| / v``, and never exceed (4) (:mod:`heuristics.lns`).
        """
        obs, r = self.obs, self.rules
        freed = obs[first : last + 1]
        left = obs[first - 1] if first > 0 else None
        right = obs[last + 1] if last + 1 < len(obs) else None
        rest_obs = self.observe - sum(c[1] - c[0] for c in freed)
        seq = [c for c in (left, *freed, right) if c is not None]
        rest_slew = self.slew - sum(self.turn(x, y) for x, y in zip(seq, seq[1:], strict=False))
        if ends_paid:
            rest_slew += sum(r.slew(c[2]) for c in (left, right) if c is not None)
        return (
            r.energy_capacity - r.energy(rest_obs, rest_slew),
            r.memory_capacity - r.memory(rest_obs),
            r.max_openings - (len(obs) - len(freed)),
        )

    def snapshot(self) -> tuple[list[Entry], float, float]:
        """The content and totals, for :meth:`restore` (a copy of the short list only)."""
        return (list(self.obs), self.observe, self.slew)

    def restore(self, snap: tuple[list[Entry], float, float]) -> None:
        """Go back to a :meth:`snapshot` (which is taken over, not copied)."""
        self.obs, self.observe, self.slew = snap[0], snap[1], snap[2]


def task_entries(tasks: Any, items: Any = slice(None)) -> list[Entry]:
    """Timeline entries ``(start, end, roll, position)`` of the tasks ``items`` (all by
    default) of ``tasks`` (a :class:`sosp.clustering.TaskSet`), positions counted in ``items``."""
    cols = (tasks.start[items].tolist(), tasks.end[items].tolist(), tasks.roll[items].tolist())
    return list(zip(*cols, range(len(cols[0])), strict=True))


def fits_alone(instance: Instance, tasks: Any) -> list[bool]:
    """Per task of ``tasks`` (a :class:`sosp.clustering.TaskSet`), whether it fits its empty
    orbit: what :meth:`OrbitTimeline.check_insert` answers there, (6) c >= 1, (11), (4), (5)
    (:meth:`sosp.rules.OrbitRules.alone_ok`, by :func:`sosp.rules.alone_ok_mask`)."""
    return alone_ok_mask(instance, tasks.orbit, tasks.start, tasks.end).tolist()
