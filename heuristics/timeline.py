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

#: Solvers keep this much margin so the validator's own tolerance is never needed.
EPS = 1e-9


@dataclass(frozen=True, slots=True)
class InsertCheck:
    """Outcome of :meth:`OrbitTimeline.check_insert`: where, and the slew-time delta."""

    ok: bool
    pos: int
    d_slew: float
    reason: str = ""


class OrbitTimeline:
    """Observations of one orbit, sorted by start, with running totals.

    Parameters
    ----------
    instance
        The problem.
    orbit
        Orbit index j.
    """

    __slots__ = (
        "orbit",
        "a",
        "v",
        "eo",
        "es",
        "w",
        "E",
        "W",
        "c",
        "max_duration",
        "starts",
        "ends",
        "rolls",
        "items",
        "observe",
        "slew",
    )

    def __init__(self, instance: Instance, orbit: int) -> None:
        self.orbit = orbit
        self.a = float(instance.setup_time[orbit])
        self.v = float(instance.slew_rate[orbit])
        self.eo = float(instance.observe_energy_rate[orbit])
        self.es = float(instance.slew_energy_rate[orbit])
        self.w = float(instance.memory_rate[orbit])
        self.E = float(instance.energy_capacity[orbit])
        self.W = float(instance.memory_capacity[orbit])
        self.c = int(instance.max_openings[orbit])
        self.max_duration = float(instance.max_duration[orbit])
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
        return self.eo * self.observe + self.es * self.slew

    @property
    def memory(self) -> float:
        """Memory used, constraint (5)."""
        return self.w * self.observe

    def free_share(self) -> float:
        """Resources left, ``(E - ConE)/E + (W - ConW)/W`` (paper, 5.1 step 5)."""
        e = (self.E - self.energy) / self.E if self.E > 0 else 0.0
        m = (self.W - self.memory) / self.W if self.W > 0 else 0.0
        return e + m

    def turn(self, r1: float, r2: float) -> float:
        """Slew time between consecutive observations with rolls r1, r2 (through nadir)."""
        return (abs(r1) + abs(r2)) / self.v

    def check_insert(self, start: float, end: float, roll: float) -> InsertCheck:
        """Can an observation [start, end] at ``roll`` be added without breaking (3)-(6), (11)?"""
        if end - start > self.max_duration + EPS:
            return InsertCheck(False, -1, 0.0, "11")
        if len(self.starts) >= self.c:
            return InsertCheck(False, -1, 0.0, "6")
        pos = bisect_left(self.starts, start)
        d_slew = 0.0
        if pos > 0:
            t = self.turn(self.rolls[pos - 1], roll)
            if self.ends[pos - 1] + self.a + t > start + EPS:
                return InsertCheck(False, pos, 0.0, "3")
            d_slew += t
        if pos < len(self.starts):
            t = self.turn(roll, self.rolls[pos])
            if end + self.a + t > self.starts[pos] + EPS:
                return InsertCheck(False, pos, 0.0, "3")
            d_slew += t
        if 0 < pos < len(self.starts):
            d_slew -= self.turn(self.rolls[pos - 1], self.rolls[pos])
        dur = end - start
        if self.w * (self.observe + dur) > self.W + EPS:
            return InsertCheck(False, pos, d_slew, "5")
        if self.eo * (self.observe + dur) + self.es * (self.slew + d_slew) > self.E + EPS:
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
        d = 0.0
        if pos > 0:
            d -= self.turn(self.rolls[pos - 1], self.rolls[pos])
        if pos < n - 1:
            d -= self.turn(self.rolls[pos], self.rolls[pos + 1])
        if 0 < pos < n - 1:
            d += self.turn(self.rolls[pos - 1], self.rolls[pos + 1])
        self.observe -= self.ends[pos] - self.starts[pos]
        self.slew += d
        if len(self.starts) == 1:  # avoid drift on an emptied orbit
            self.observe = self.slew = 0.0
        del self.starts[pos], self.ends[pos], self.rolls[pos]
        return self.items.pop(pos)
