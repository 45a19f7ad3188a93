"""Incremental per-orbit state: observations in time order with resource totals.

Every method that builds schedules by insertion keeps one :class:`OrbitTimeline` per orbit.
A move is evaluated first (:meth:`OrbitTimeline.check_insert`) and applied only if chosen
(:meth:`OrbitTimeline.insert`); totals are updated by deltas, never recomputed.

The constraints are those of ``docs/model.md``: (3) setup and slew time between consecutive
observations, (4) energy with the slew term over consecutive pairs, (5) memory, (6) openings
and (11) the longest observation.
"""

from __future__ import annotations

from bisect import bisect_left
from dataclasses import dataclass
from typing import Any

from sosp.instance import Instance
from sosp.rules import EPS, orbit_rules

__all__ = ["EPS", "InsertCheck", "OrbitTimeline"]


@dataclass(frozen=True, slots=True)
class InsertCheck:
    """Outcome of :meth:`OrbitTimeline.check_insert`: where, and the slew-time delta."""

    ok: bool
    pos: int
    d_slew: float
    reason: str = ""


class OrbitTimeline:
    """Observations of one orbit, sorted by start, with running totals.

    The rules come from :class:`sosp.rules.OrbitRules` (``self.rules``); this class only keeps
    the sequence and its totals (observed and slew seconds) by deltas.

    Parameters
    ----------
    instance
        The problem.
    orbit
        Orbit index j.
    """

    __slots__ = ("orbit", "rules", "starts", "ends", "rolls", "items", "observe", "slew")

    def __init__(self, instance: Instance, orbit: int) -> None:
        self.orbit = orbit
        self.rules = orbit_rules(instance, orbit)
        self.starts: list[float] = []
        self.ends: list[float] = []
        self.rolls: list[float] = []
        self.items: list[Any] = []
        self.observe = 0.0  # total observation time, seconds
        self.slew = 0.0  # total slew time over consecutive pairs, seconds

    def __len__(self) -> int:
        return len(self.starts)

    @property
    def energy(self) -> float:
        """Energy used, constraint (4)."""
        return self.rules.energy(self.observe, self.slew)

    @property
    def memory(self) -> float:
        """Memory used, constraint (5)."""
        return self.rules.memory(self.observe)

    def free_share(self) -> float:
        """Resources left, ``(E - ConE)/E + (W - ConW)/W`` (paper, 5.1 step 5)."""
        return self.rules.free_share(self.energy, self.memory)

    def check_insert(self, start: float, end: float, roll: float) -> InsertCheck:
        """Can an observation [start, end] at ``roll`` be added without breaking (3)-(6), (11)?"""
        r = self.rules
        if not r.duration_ok(start, end):
            return InsertCheck(False, -1, 0.0, "11")
        if len(self.starts) >= r.max_openings:
            return InsertCheck(False, -1, 0.0, "6")
        pos = bisect_left(self.starts, start)
        d_slew = 0.0
        if pos > 0:
            if r.clash(self.ends[pos - 1], self.rolls[pos - 1], start, roll):
                return InsertCheck(False, pos, 0.0, "3")
            d_slew += r.turn(self.rolls[pos - 1], roll)
        if pos < len(self.starts):
            if r.clash(end, roll, self.starts[pos], self.rolls[pos]):
                return InsertCheck(False, pos, 0.0, "3")
            d_slew += r.turn(roll, self.rolls[pos])
        if 0 < pos < len(self.starts):
            d_slew -= r.turn(self.rolls[pos - 1], self.rolls[pos])
        observe = self.observe + (end - start)
        if not r.memory_ok(observe):
            return InsertCheck(False, pos, d_slew, "5")
        if not r.energy_ok(observe, self.slew + d_slew):
            return InsertCheck(False, pos, d_slew, "4")
        return InsertCheck(True, pos, d_slew)

    def insert(self, check: InsertCheck, start: float, end: float, roll: float, item: Any) -> None:
        """Apply an insertion evaluated by :meth:`check_insert`."""
        pos = check.pos
        self.starts.insert(pos, start)
        self.ends.insert(pos, end)
        self.rolls.insert(pos, roll)
        self.items.insert(pos, item)
        self.observe += end - start
        self.slew += check.d_slew

    def remove(self, pos: int) -> Any:
        """Remove the observation at ``pos``; returns its item."""
        n = len(self.starts)
        turn = self.rules.turn
        d = 0.0
        if pos > 0:
            d -= turn(self.rolls[pos - 1], self.rolls[pos])
        if pos < n - 1:
            d -= turn(self.rolls[pos], self.rolls[pos + 1])
        if 0 < pos < n - 1:
            d += turn(self.rolls[pos - 1], self.rolls[pos + 1])
        self.observe -= self.ends[pos] - self.starts[pos]
        self.slew += d
        if len(self.starts) == 1:  # avoid drift on an emptied orbit
            self.observe = self.slew = 0.0
        del self.starts[pos], self.ends[pos], self.rolls[pos]
        return self.items.pop(pos)
