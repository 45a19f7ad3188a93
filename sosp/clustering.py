"""Tasks to schedule atomically: single opportunities or static cluster-tasks (STC).

A :class:`TaskSet` is what the static methods schedule (the paper's *-STC comparisons and the
no-clustering variants): each task is one sensor opening with a fixed window and roll covering
one or more opportunities of one orbit.

Static task clustering (the paper's ref. [10]; ``docs/model.md``, "Static cluster-tasks") builds the
cluster-tasks once, before scheduling, by partitioning each orbit's opportunities into groups
that satisfy (7) (a common roll) and (11) (span <= Delta T); afterwards they are atomic. The
partition is a greedy clique partition of the "can cluster" graph: opportunities are taken in
start order and each joins the open group whose span grows least (best fit), or opens a new
group. Its window is (10) and its roll (9) (midpoint, default) or the point of the common range
closest to nadir.

A target may belong to cluster-tasks on several orbits. Scheduling two such tasks is feasible
(the target is simply photographed twice) but it counts once: every static method uses this
coverage semantics, and :func:`tasks_to_schedule` claims each target in the first scheduled
task covering it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from sosp.instance import Instance
from sosp.rules import RollRule, range_empty, within_duration
from sosp.schedule import Schedule, items_to_schedule, make_observation


@dataclass(frozen=True, eq=False)
class TaskSet:
    """Atomic tasks: one sensor opening each, with a fixed window and roll.

    Attributes
    ----------
    orbit, start, end, roll
        Per task: orbit index, window [ts_u, te_u] (10), roll theta_u.
    weight
        Sum of the weights of the distinct targets covered.
    opps
        Per task, the sorted opportunity indices it covers (its component tasks).
    targets
        Per task, the sorted distinct target indices it covers.
    """

    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    weight: np.ndarray
    opps: tuple[tuple[int, ...], ...]
    targets: tuple[tuple[int, ...], ...]

    def __len__(self) -> int:
        return len(self.opps)

    @property
    def duration(self) -> np.ndarray:
        return self.end - self.start

    @cached_property
    def target_tasks(self) -> dict[int, tuple[int, ...]]:
        """For each covered target index, the tasks that cover it."""
        out: dict[int, list[int]] = {}
        for t, ks in enumerate(self.targets):
            for k in ks:
                out.setdefault(k, []).append(t)
        return {k: tuple(v) for k, v in out.items()}


def single_tasks(instance: Instance) -> TaskSet:
    """One task per opportunity, at the opportunity's own roll (no clustering)."""
    n = instance.n_opps
    return TaskSet(
        orbit=instance.opp_orbit.copy(),
        start=instance.opp_start.copy(),
        end=instance.opp_end.copy(),
        roll=instance.opp_roll.copy(),
        weight=instance.opp_weight.copy(),
        opps=tuple((i,) for i in range(n)),
        targets=tuple((int(k),) for k in instance.opp_target),
    )


def static_cluster_tasks(instance: Instance, roll_rule: RollRule = "midpoint") -> TaskSet:
    """Static cluster-tasks: a per-orbit partition of the opportunities satisfying (7), (11).

    Parameters
    ----------
    instance
        The problem.
    roll_rule
        ``"midpoint"`` (9) or ``"nadir"`` for groups of two or more; a single opportunity
        keeps its own roll.

    Returns
    -------
    TaskSet
        Tasks sorted by (orbit, start); every opportunity is in exactly one task.
    """
    groups: list[list[int]] = []
    # plain Python floats and inlined min/max: the loop is sequential (each opportunity joins
    # the open group it grows least), and numpy scalars and builtin calls were most of its time
    starts, ends = instance.opp_start.tolist(), instance.opp_end.tolist()
    los, his = instance.opp_roll_min.tolist(), instance.opp_roll_max.tolist()
    inf = float("inf")
    for j in range(instance.n_orbits):
        sl = instance.orbit_opps(j)
        limit = float(instance.max_duration[j])
        # open groups: [first start, max end, lo, hi, members]
        open_: list[list] = []
        for i in range(sl.start, sl.stop):
            s, e, lo, hi = starts[i], ends[i], los[i], his[i]
            # Opportunities come in start order (and end after they start): a group that this
            # start already outruns can take no later opportunity, so it is closed.
            if open_ and not within_duration(open_[0][0], s, limit):
                still_open = []
                for g in open_:
                    if not within_duration(g[0], s, limit):
                        groups.append(g[4])
                    else:
                        still_open.append(g)
                open_ = still_open
            best, best_growth = None, inf
            for g in open_:
                g1 = g[1]
                end = e if e > g1 else g1
                if not within_duration(g[0], end, limit):
                    continue  # (11)
                glo, ghi = g[2], g[3]
                if range_empty(glo if glo > lo else lo, ghi if ghi < hi else hi):
                    continue  # (7)
                growth = end - g1
                if growth < best_growth:
                    best, best_growth = g, growth
            if best is None:
                open_.append([s, e, lo, hi, [i]])
            else:
                if e > best[1]:
                    best[1] = e
                if lo > best[2]:
                    best[2] = lo
                if hi < best[3]:
                    best[3] = hi
                best[4].append(i)
        groups.extend(g[4] for g in open_)
    return _taskset(instance, groups, roll_rule)


def _taskset(instance: Instance, groups: list[list[int]], roll_rule: RollRule) -> TaskSet:
    """The tasks of ``groups``, each the observation of its members, (8)-(10)."""
    obs = sorted(
        (make_observation(instance, g, roll_rule) for g in groups),
        key=lambda o: (o.orbit, o.start, o.end, o.opps),
    )
    targets = tuple(tuple(sorted({int(k) for k in instance.opp_target[list(o.opps)]})) for o in obs)
    w = instance.target_weight
    return TaskSet(
        orbit=np.array([o.orbit for o in obs], dtype=np.int64),
        start=np.array([o.start for o in obs], dtype=float),
        end=np.array([o.end for o in obs], dtype=float),
        roll=np.array([o.roll for o in obs], dtype=float),
        weight=np.array([int(w[list(ks)].sum()) for ks in targets], dtype=np.int64),
        opps=tuple(o.opps for o in obs),
        targets=targets,
    )


def tasks_to_schedule(instance: Instance, tasks: TaskSet, chosen: Iterable[int]) -> Schedule:
    """The schedule of a chosen set of tasks (:func:`sosp.schedule.items_to_schedule`)."""
    return items_to_schedule(instance, tasks, chosen)
