"""Static cluster-task data and an incremental selection, shared by ACO-STC and GA-STC.

The paper (section 6) casts SOSP as a multidimensional knapsack problem over the static
cluster-tasks (:func:`sosp.clustering.static_cluster_tasks`): each task is an item, its weight
the sum of its targets' weights, and each orbit a set of knapsacks, energy (4), memory (5) and
openings (6), plus the sequencing constraint (3). This module holds what both population
methods need:

* :class:`StcData`: the usable tasks per orbit in start order, their (3) interval ends from
  :mod:`sosp.rules`, and a pseudo-utility ``weight / cost`` (the classic knapsack heuristic:
  profit over the share of each capacity an item uses, :func:`resource_cost`);
* :class:`Selection`: a set of chosen tasks with one :class:`heuristics.timeline.OrbitTimeline`
  per orbit (the rules (3)-(6), (11) are checked there and nowhere else), coverage counts per
  target (a target in tasks of several orbits counts once, ``docs/model.md``) and the profit,
  all updated by deltas.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from heuristics.timeline import InsertCheck, OrbitTimeline, fits_alone, task_entries
from sosp import rules
from sosp.clustering import TaskSet, static_cluster_tasks
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.progress import current as current_progress
from sosp.schedule import RollRule
from sosp.stop import Budget, SearchStatus, reached_cap

log = logging.getLogger(__name__)


# ------------------------------------------------------------------------------- parameters
def at_least(params: Any, **minimum: int) -> None:
    """Each named field of ``params`` (an integer or None, as
    :func:`sosp.params.check_types` made it) is None or at least its ``minimum``."""
    for name, lo in minimum.items():
        if (value := getattr(params, name)) is not None and value < lo:
            raise InputError(f"{name}: expected an integer >= {lo}, got {value!r}")


def check_float(name: str, value: Any, lo: float, hi: float, lo_open: bool = False) -> None:
    """``value`` (a number, as :func:`sosp.params.check_types` made it) lies in [lo, hi]
    (``(lo, hi]`` with ``lo_open``); NaN and infinities never do."""
    if not (lo < value <= hi if lo_open else lo <= value <= hi):
        left = "(" if lo_open else "["
        raise InputError(f"{name}: must lie in {left}{lo:g}, {hi:g}], got {value!r}")


# -------------------------------------------------------------------------------- the loop
class Watch:
    """A search loop's check: the :class:`~sosp.stop.Budget` of its time limit, stop requests
    (:func:`sosp.stop.request_stop`) and the solve's progress, reported at each check."""

    def __init__(self, time_limit: float | None) -> None:
        self.budget = Budget.of(time_limit)
        self.progress = current_progress()
        self.status = SearchStatus()

    def __call__(self, iteration: int, best: float, since_best: int = 0) -> bool:
        """Report the search's state; True when it must stop (its budget spent, or a stop
        requested, or ``best`` reached the solve's cap: optimal)."""
        self.status.iteration, self.status.since_best = iteration, since_best
        self.status.best = best
        self.progress(self.status)
        return self.budget.expired() or reached_cap(best)

    def limit(self, iterations: int | None, default: int) -> int:
        """``iterations``; when None, ``default`` without a time limit, else no limit."""
        if iterations is not None:
            return iterations
        return default if self.budget.deadline is None else sys.maxsize


# ------------------------------------------------------------------------------------- data
def resource_cost(instance: Instance, tasks: TaskSet) -> np.ndarray:
    """Share of its orbit's capacities one task uses: the denominator of the pseudo-utility.

    ``cost_u = w d_u / W + (eo d_u + es 2|theta_u| / v) / E + 1 / c + (R_u - L_u) / H``, with
    d_u = te_u - ts_u, the memory (5), energy (4) (the slew bounded by
    :func:`sosp.rules.slew_upper`, to and from nadir) and opening (6) it takes, and the share
    of the orbit's length H its (3) interval ``[L_u, R_u)`` blocks. A capacity that is zero
    counts its use as a full share. Floored at 1e-12.
    """
    j = tasks.orbit
    d = np.asarray(tasks.duration, dtype=float)
    slew = rules.slew_upper(np.abs(tasks.roll), instance.slew_rate[j])
    mem = rules.memory(d, instance.memory_rate[j])
    eng = rules.energy(d, slew, instance.observe_energy_rate[j], instance.slew_energy_rate[j])
    left = rules.left_end(tasks.start, tasks.roll, instance.slew_rate[j])
    right = rules.right_end(tasks.end, tasks.roll, instance.setup_time[j], instance.slew_rate[j])
    horizon = np.maximum(instance.orbit_end[j] - instance.orbit_start[j], 1e-9)

    def share(use: np.ndarray, cap: np.ndarray) -> np.ndarray:
        cap = np.asarray(cap, dtype=float)
        return np.where(cap > 0, use / np.where(cap > 0, cap, 1.0), 1.0)

    cost = (
        share(mem, instance.memory_capacity[j])
        + share(eng, instance.energy_capacity[j])
        + share(np.ones_like(d), instance.max_openings[j].astype(float))
        + (right - left) / horizon
    )
    return np.maximum(cost, 1e-12)


@dataclass(frozen=True, eq=False)
class StcData:
    """The static cluster-tasks as the population methods use them.

    Attributes
    ----------
    instance, tasks
        The problem and its static cluster-tasks.
    usable
        Tasks that can ever be scheduled (weight > 0 and feasible alone on an empty orbit),
        in task order (orbit, start).
    orbit_tasks
        Per orbit with usable tasks, its usable tasks in start order.
    left, right
        Per task, the ends of its (3) interval (:func:`sosp.rules.left_end`, ``right_end``).
    cost, utility
        Per task, :func:`resource_cost` and ``weight / cost``.
    by_utility
        The usable tasks by decreasing utility (ties by task index).
    position
        Per task, its index in ``usable`` (-1 when not usable).
    targets, weight
        Per task its targets; per target its weight (Python lists for the scalar loops).
    entries
        Per task its timeline entry ``(start, end, roll, task)``
        (:class:`heuristics.timeline.OrbitTimeline`).
    """

    instance: Instance
    tasks: TaskSet
    usable: np.ndarray
    orbit_tasks: dict[int, np.ndarray]
    left: np.ndarray
    right: np.ndarray
    cost: np.ndarray
    utility: np.ndarray
    by_utility: np.ndarray
    position: np.ndarray
    targets: tuple[tuple[int, ...], ...]
    weight: list[int]
    entries: list[tuple[float, float, float, int]]

    @property
    def target_tasks(self) -> dict[int, tuple[int, ...]]:
        """Per target, the tasks covering it."""
        return self.tasks.target_tasks


def stc_data(instance: Instance, roll_rule: RollRule = "midpoint") -> StcData:
    """Build :class:`StcData` from the static cluster-tasks of ``instance``."""
    tasks = static_cluster_tasks(instance, roll_rule=roll_rule)
    alone = fits_alone(instance, tasks)
    usable = [t for t in range(len(tasks)) if tasks.weight[t] > 0 and alone[t]]
    usable_arr = np.array(usable, dtype=np.int64)
    on = tasks.orbit[usable_arr]
    orbit_tasks = {int(j): usable_arr[on == j] for j in np.unique(on)}
    j = tasks.orbit
    cost = resource_cost(instance, tasks) if len(tasks) else np.zeros(0)
    utility = np.asarray(tasks.weight, dtype=float) / cost if len(tasks) else np.zeros(0)
    order = np.lexsort((usable_arr, -utility[usable_arr])) if len(usable_arr) else usable_arr
    position = np.full(len(tasks), -1, dtype=np.int64)
    position[usable_arr] = np.arange(len(usable_arr))
    return StcData(
        instance=instance,
        tasks=tasks,
        usable=usable_arr,
        orbit_tasks=orbit_tasks,
        left=rules.left_end(tasks.start, tasks.roll, instance.slew_rate[j]),
        right=rules.right_end(tasks.end, tasks.roll, instance.setup_time[j], instance.slew_rate[j]),
        cost=cost,
        utility=utility,
        by_utility=usable_arr[order],
        position=position,
        targets=tuple(tuple(int(k) for k in ks) for ks in tasks.targets),
        weight=[int(x) for x in instance.target_weight],
        entries=task_entries(tasks),
    )


# -------------------------------------------------------------------------------- selection
class Selection:
    """Chosen tasks with their orbits' timelines, target coverage counts and the profit.

    Every change goes through :meth:`add` (after :meth:`check`) and :meth:`remove`, which
    update the timelines, the counts and the profit (objective (1), each target once) by
    deltas. :meth:`mark` and :meth:`undo` give a journal: the changes since a mark can be
    undone exactly.
    """

    __slots__ = ("data", "lines", "cover", "chosen", "profit", "journal")

    def __init__(self, data: StcData) -> None:
        self.data = data
        self.lines: dict[int, OrbitTimeline] = {
            j: OrbitTimeline.of(data.instance, j) for j in data.orbit_tasks
        }
        self.cover = [0] * data.instance.n_targets
        self.chosen: set[int] = set()
        self.profit = 0
        self.journal: list[tuple[bool, int]] = []

    def gain(self, t: int) -> int:
        """Weight of the targets of ``t`` no chosen task covers (what adding it earns)."""
        cover, w = self.cover, self.data.weight
        return sum(w[k] for k in self.data.targets[t] if cover[k] == 0)

    def loss(self, t: int) -> int:
        """Weight of the targets only ``t`` covers (what removing the chosen ``t`` costs)."""
        cover, w = self.cover, self.data.weight
        return sum(w[k] for k in self.data.targets[t] if cover[k] == 1)

    def check(self, t: int) -> InsertCheck:
        """:meth:`OrbitTimeline.check_insert` of task ``t`` on its orbit ((3)-(6), (11))."""
        return self.lines[int(self.data.tasks.orbit[t])].check_insert(self.data.entries[t])

    def add(self, t: int, chk: InsertCheck) -> None:
        """Add task ``t`` where ``chk`` (a successful :meth:`check`) says."""
        self.lines[int(self.data.tasks.orbit[t])].insert(self.data.entries[t], chk)
        cover, w = self.cover, self.data.weight
        for k in self.data.targets[t]:
            if cover[k] == 0:
                self.profit += w[k]
            cover[k] += 1
        self.chosen.add(t)
        self.journal.append((True, t))

    def try_add(self, t: int) -> bool:
        """Add ``t`` if it fits its orbit; returns whether it was added."""
        chk = self.check(t)
        if chk.ok:
            self.add(t, chk)
        return chk.ok

    def remove(self, t: int) -> None:
        """Remove the chosen task ``t`` (never breaks (3)-(6): ``docs/model.md``)."""
        self.lines[int(self.data.tasks.orbit[t])].discard(self.data.entries[t])
        cover, w = self.cover, self.data.weight
        for k in self.data.targets[t]:
            cover[k] -= 1
            if cover[k] == 0:
                self.profit -= w[k]
        self.chosen.discard(t)
        self.journal.append((False, t))

    def mark(self) -> int:
        """A point of the journal to :meth:`undo` back to."""
        return len(self.journal)

    def undo(self, mark: int) -> None:
        """Undo every change since ``mark`` (a subset of a feasible set is feasible, so each
        task removed since then fits back)."""
        while len(self.journal) > mark:
            added, t = self.journal.pop()
            if added:
                self.remove(t)
            else:
                chk = self.check(t)
                if not chk.ok:  # pragma: no cover - would be a bug in the timelines
                    raise RuntimeError(f"undo: task {t} no longer fits ({chk.reason})")
                self.add(t, chk)
            self.journal.pop()  # the remove/add just logged

    def commit(self) -> None:
        """Forget the journal (the current state is kept)."""
        self.journal.clear()

    def fill(self, order: Iterable[int] | np.ndarray) -> None:
        """Add, in ``order``, every task that earns something and fits."""
        for t in order:
            t = int(t)
            if t not in self.chosen and self.gain(t) > 0:
                self.try_add(t)

    def path(self, j: int) -> list[int]:
        """The chosen tasks of orbit ``j`` in time order."""
        return [o[3] for o in self.lines[j].obs]
