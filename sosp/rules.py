"""The per-orbit rules of ``docs/model.md``, written once for every solver and bound.

Every search, model, bound and the conflict graph take the rules (3)-(6), (7)-(11) from here;
the validator (:mod:`sosp.validate`) alone is written independently from ``docs/model.md``, and a
property test checks that the two agree on random sequences.

Parameter names are those of :class:`sosp.instance.Resources` (and the instance's per-orbit
columns): ``setup_time`` a, ``slew_rate`` v (deg/s), ``observe_energy_rate`` eo,
``slew_energy_rate`` es, ``memory_rate`` w, ``energy_capacity`` E, ``memory_capacity`` W,
``max_openings`` c, ``max_duration`` Delta T.

The functions broadcast: they take Python floats (the incremental timelines' hot path) or numpy
arrays (the sweeps over all items of an instance) alike.

Rule (3) as two ends
--------------------
Give each observation u the interval ``[L_u, R_u)`` with ``L_u = ts_u - |theta_u| / v`` and
``R_u = te_u + a + |theta_u| / v``. For u before w on one orbit, (3) reads
``ts_w - te_u >= a + (|theta_u| + |theta_w|) / v``, i.e. ``R_u <= L_w``: u may precede w iff its
right end is not after w's left end. Gaps and slews add up along an orbit, so (3) between
consecutive observations holds iff it holds between every pair, and (3) on one orbit is exactly
the interval graph of these intervals (what the conflict sweep, the clique rows of the MILP and
the single-orbit planner's prefix maxima rely on).

Energy (4)
----------
``eo * sum (te - ts) + es * sum over consecutive pairs (|theta_u| + |theta_w|) / v``. Over a
sequence the slew sum is ``(2 sum |theta| - |theta_first| - |theta_last|) / v``: every
observation slews out of and back to nadir except before the first and after the last. The
conservative slew estimate the models use is derived here, once, with its validity argument:
:func:`slew_upper` (``2 sum |theta| / v``) is never below the exact slew of any sequence of the
same observations, so a row with it is conservative (a schedule keeping it keeps (4)).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Literal

import numpy as np

from sosp.errors import InputError

#: The margin every solver keeps in its feasibility tests (seconds, energy, memory, degrees),
#: so that a schedule never relies on the validator's own tolerance (``sosp.validate.TOL``,
#: 1e-6). One value for every solver, bound and the conflict graph.
EPS = 1e-9

RollRule = Literal["midpoint", "nadir"]


# ----------------------------------------------------------------------------- (3) slew time
def slew_time(roll: Any, slew_rate: Any) -> Any:
    """Seconds to slew between nadir and ``roll`` (deg) at ``slew_rate`` (deg/s)."""
    return abs(roll) / slew_rate


def left_end(start: Any, roll: Any, slew_rate: Any) -> Any:
    """``L = ts - |theta| / v``: the left end of an observation's (3) interval."""
    return start - abs(roll) / slew_rate


def right_end(end: Any, roll: Any, setup_time: Any, slew_rate: Any) -> Any:
    """``R = te + a + |theta| / v``: the right end of an observation's (3) interval."""
    return end + setup_time + abs(roll) / slew_rate


def may_precede(right_u: Any, left_w: Any, margin: float = EPS) -> Any:
    """(3) for u before w from their ends: ``R_u <= L_w`` (with the solvers' margin; a
    negative ``margin`` asks for that much room, elementwise)."""
    return right_u <= left_w + margin


# --------------------------------------------------------------------------- (4)-(6) usage
def within_duration(start: Any, end: Any, max_duration: Any) -> Any:
    """(11): a window [start, end] lasts at most Delta T (elementwise on arrays)."""
    return end - start <= max_duration + EPS


def starts_within(start: np.ndarray, max_duration: Any, at: Any = None) -> np.ndarray:
    """(11) over starts sorted in time: per start (or per time of ``at``), one past the last
    start within Delta T of it (with the margin), i.e. the run of opportunities one
    observation opening there may still cover."""
    return np.searchsorted(start, (start if at is None else at) + max_duration + EPS, "right")


def sequence_slew_time(rolls: np.ndarray, slew_rate: float) -> float:
    """Exact slew seconds of (4) over a sequence (consecutive pairs only)."""
    if len(rolls) < 2:
        return 0.0
    s = np.abs(np.asarray(rolls, dtype=float))
    return float(2.0 * s.sum() - s[0] - s[-1]) / slew_rate


def slew_upper(abs_roll_sum: Any, slew_rate: Any) -> Any:
    """``2 sum |theta| / v``: at least the exact slew of (4) of any order of the observations
    (conservative; see the module docstring)."""
    return 2.0 * abs_roll_sum / slew_rate


def energy(observe_s: Any, slew_s: Any, observe_energy_rate: Any, slew_energy_rate: Any) -> Any:
    """Energy of (4): ``eo * observed seconds + es * slew seconds``."""
    return observe_energy_rate * observe_s + slew_energy_rate * slew_s


def memory(observe_s: Any, memory_rate: Any) -> Any:
    """Memory of (5): ``w * observed seconds``."""
    return memory_rate * observe_s


# ------------------------------------------------------------------- (7)-(11) cluster-tasks
def common_roll_range(roll_min: np.ndarray, roll_max: np.ndarray) -> tuple[float, float]:
    """(8): the rolls every covered opportunity accepts, ``[max theta_lo, min theta_hi]``
    (empty when the first exceeds the second, :func:`range_empty`)."""
    return float(np.max(roll_min)), float(np.min(roll_max))


ROLL_RULES: tuple[str, ...] = ("midpoint", "nadir")


def check_roll_rule(rule: Any, name: str = "roll_rule") -> None:
    """Raise :class:`InputError` naming ``name`` unless ``rule`` is a :data:`RollRule`."""
    if rule not in ROLL_RULES:
        raise InputError(f"{name}: expected one of {', '.join(ROLL_RULES)}, got {rule!r}")


def range_empty(lo: Any, hi: Any) -> Any:
    """(7)-(8): whether no roll lies in the common range ``[lo, hi]`` (elementwise)."""
    return lo > hi


def roll_in_range(roll: Any, lo: Any, hi: Any) -> Any:
    """(7): whether ``roll`` lies in the range ``[lo, hi]``, with the margin (elementwise)."""
    return (lo <= roll + EPS) & (roll <= hi + EPS)


def group_roll_ranges(
    lo: np.ndarray, hi: np.ndarray, ptr: np.ndarray, flat: np.ndarray, block: int = 1 << 18
) -> tuple[np.ndarray, np.ndarray]:
    """(8) of many groups at once: the common range ``[max lo, min hi]`` of each non-empty
    group of members ``flat[ptr[g]:ptr[g + 1]]`` (indices into ``lo``, ``hi``). Reduced by
    blocks of ``block`` groups, so that millions of them need no gather of every member at
    once."""
    n = len(ptr) - 1
    glo, ghi = np.empty(n), np.empty(n)
    for a in range(0, n, block):
        b = min(n, a + block)
        f0, f1 = int(ptr[a]), int(ptr[b])
        part = flat[f0:f1]
        glo[a:b] = np.maximum.reduceat(lo[part], ptr[a:b] - f0)
        ghi[a:b] = np.minimum.reduceat(hi[part], ptr[a:b] - f0)
    return glo, ghi


def choose_roll(lo: Any, hi: Any, rule: RollRule = "midpoint") -> Any:
    """A roll in the common range ``[lo, hi]`` (7): the midpoint (9), or the point closest to
    nadir (never more slew time or energy than any other roll in the range). Elementwise on
    arrays; a float for floats."""
    if rule == "midpoint":
        return 0.5 * (lo + hi)
    if rule == "nadir":
        if isinstance(lo, np.ndarray) or isinstance(hi, np.ndarray):
            return np.minimum(np.maximum(0.0, lo), hi)
        return float(min(max(0.0, lo), hi))
    raise InputError(f"roll rule: expected 'midpoint' or 'nadir', got {rule!r}")


def cluster_window(starts: np.ndarray, ends: np.ndarray) -> tuple[float, float]:
    """(10): the window of a cluster-task, ``[min ts, max te]`` of its components."""
    return float(np.min(starts)), float(np.max(ends))


# ---------------------------------------------------------------------------- one orbit
@dataclass(frozen=True, slots=True)
class OrbitRules:
    """The rules of one orbit, its parameters under the :class:`~sosp.instance.Resources`
    names (Table 1 of the paper).

    Use :func:`orbit_rules` to get them from an instance.
    """

    memory_capacity: float
    memory_rate: float
    energy_capacity: float
    observe_energy_rate: float
    slew_energy_rate: float
    slew_rate: float
    setup_time: float
    max_openings: int
    max_duration: float

    def slew(self, roll: Any) -> Any:
        """Seconds between nadir and ``roll``."""
        return slew_time(roll, self.slew_rate)

    def turn(self, roll_u: Any, roll_w: Any) -> Any:
        """Slew seconds between consecutive observations ((3), (4))."""
        return (abs(roll_u) + abs(roll_w)) / self.slew_rate

    def left(self, start: Any, roll: Any) -> Any:
        """Left end of the (3) interval."""
        return left_end(start, roll, self.slew_rate)

    def right(self, end: Any, roll: Any) -> Any:
        """Right end of the (3) interval."""
        return right_end(end, roll, self.setup_time, self.slew_rate)

    def clash(self, end_u: float, roll_u: float, start_w: float, roll_w: float) -> bool:
        """Whether u (ending at ``end_u``) may NOT precede w (starting at ``start_w``) by (3)."""
        return (
            end_u + self.setup_time + (abs(roll_u) + abs(roll_w)) / self.slew_rate > start_w + EPS
        )

    def energy(self, observe_s: Any, slew_s: Any) -> Any:
        """Energy of (4) for these observed and slew seconds."""
        return self.observe_energy_rate * observe_s + self.slew_energy_rate * slew_s

    def memory(self, observe_s: Any) -> Any:
        """Memory of (5) for these observed seconds."""
        return self.memory_rate * observe_s

    def per_unit(self, lam_energy: float, lam_memory: float) -> tuple[float, float]:
        """Multipliers of (4) and (5) per whole capacity as multipliers per unit of energy and
        of memory (0 where a capacity is 0: nothing fits there anyway)."""
        pe = lam_energy / self.energy_capacity if self.energy_capacity > 0 else 0.0
        pw = lam_memory / self.memory_capacity if self.memory_capacity > 0 else 0.0
        return pe, pw

    def energy_ok(self, observe_s: float, slew_s: float) -> bool:
        """(4) with the margin."""
        return self.energy(observe_s, slew_s) <= self.energy_capacity + EPS

    def memory_ok(self, observe_s: float) -> bool:
        """(5) with the margin."""
        return self.memory_rate * observe_s <= self.memory_capacity + EPS

    def fits(self, observe_s: float, slew_s: float) -> bool:
        """(4) and (5) for an orbit's totals."""
        return self.memory_ok(observe_s) and self.energy_ok(observe_s, slew_s)

    def usage_ok(self, energy: float, memory: float) -> bool:
        """(4) and (5) for a plan's energy and memory (:meth:`usage`), with the margin."""
        return energy <= self.energy_capacity + EPS and memory <= self.memory_capacity + EPS

    def duration_ok(self, start: Any, end: Any) -> Any:
        """(11): the window is at most Delta T (elementwise on arrays)."""
        return within_duration(start, end, self.max_duration)

    def usage(self, durations: np.ndarray, rolls: np.ndarray) -> tuple[float, float]:
        """``(energy, memory)`` of a sequence in time order, slew over consecutive pairs."""
        observed = float(np.sum(durations))
        slew_s = sequence_slew_time(rolls, self.slew_rate)
        return self.energy(observed, slew_s), self.memory(observed)

    def free_share(self, energy_used: float, memory_used: float) -> float:
        """Resources left, ``(E - ConE)/E + (W - ConW)/W`` (the paper's 5.1, step 5)."""
        e_cap, m_cap = self.energy_capacity, self.memory_capacity
        e = (e_cap - energy_used) / e_cap if e_cap > 0 else 0.0
        m = (m_cap - memory_used) / m_cap if m_cap > 0 else 0.0
        return e + m

    def alone_ok(self, start: Any, end: Any) -> Any:
        """Whether one observation [start, end] fits an empty orbit: c >= 1, (11), (4), (5)
        (no slew: a lone observation has no consecutive pair). Elementwise on arrays, the
        rules' fields included (:func:`alone_ok_mask`)."""
        d = end - start
        return (
            (self.max_openings >= 1)
            & self.duration_ok(start, end)
            & self.memory_ok(d)
            & self.energy_ok(d, 0.0)
        )


_RULE_FIELDS = tuple(f.name for f in fields(OrbitRules))


def orbit_rules(instance: Any, orbit: int) -> OrbitRules:
    """The :class:`OrbitRules` of orbit ``orbit`` of ``instance`` (its per-orbit columns)."""
    values = {name: float(getattr(instance, name)[orbit]) for name in _RULE_FIELDS}
    values["max_openings"] = int(values["max_openings"])
    return OrbitRules(**values)


def alone_ok_mask(instance: Any, orbit: Any, start: Any, end: Any) -> np.ndarray:
    """:meth:`OrbitRules.alone_ok` of many observations at once: whether each window
    ``[start, end]`` fits its empty orbit ``orbit``, by the method itself over rules whose
    fields are the observations' orbits' columns (so the same float arithmetic)."""
    o = np.asarray(orbit, dtype=np.int64)
    rules = OrbitRules(**{name: np.asarray(getattr(instance, name))[o] for name in _RULE_FIELDS})
    return np.asarray(
        rules.alone_ok(np.asarray(start, dtype=float), np.asarray(end, dtype=float)), dtype=bool
    )


def all_orbit_rules(instance: Any) -> tuple[OrbitRules, ...]:
    """:func:`orbit_rules` of every orbit, in orbit order."""
    return tuple(orbit_rules(instance, j) for j in range(instance.n_orbits))
