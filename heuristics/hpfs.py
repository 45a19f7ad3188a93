"""Highest priority first schedule over static cluster-tasks (HPFS-STC, paper section 6.3).

The paper's HPFS baseline: "rank observation tasks in descending order with respect to their
priorities and each time try to insert the task with the highest priority into the schedule".
Here the tasks are the static cluster-tasks of :func:`sosp.clustering.static_cluster_tasks`
(the "-STC" of the paper's comparison), the priority of a cluster-task is its weight (the sum
of its targets' weights p_k, section 4.1), and "insert" means: add the task to its orbit's
timeline if (3)-(6) and (11) stay satisfied (:class:`heuristics.timeline.OrbitTimeline`).

Coverage semantics (``docs/model.md``): a target in cluster-tasks on several orbits counts
once, so a task is skipped when every target it covers is already covered (it would spend
resources for no profit); a task with some uncovered target is inserted when feasible and
gains the weight of its uncovered targets.

The simpler ``greedy`` method (:mod:`heuristics.greedy`) is the no-clustering variant: it
inserts single targets by weight at their own roll.

:func:`insertion_decode` is shared with :mod:`heuristics.sa` (the SA-STC decoder) and
:mod:`heuristics.rds` (its fall-back incumbent on a timeout).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from heuristics.timeline import OrbitTimeline
from sosp.clustering import TaskSet, static_cluster_tasks, tasks_to_schedule
from sosp.instance import Instance
from sosp.params import Params, param
from sosp.result import Result, Status
from sosp.schedule import RollRule

log = logging.getLogger(__name__)


def insertion_decode(
    instance: Instance,
    tasks: TaskSet,
    order: Iterable[int],
    lines: dict[int, OrbitTimeline] | None = None,
    covered: np.ndarray | None = None,
) -> tuple[list[int], int]:
    """Insert tasks in the given order, each if it adds profit and stays feasible.

    Parameters
    ----------
    instance
        The problem.
    tasks
        The atomic tasks.
    order
        Task indices in insertion order (a priority list or a permutation).
    lines
        Per-orbit timelines to insert into (new empty ones when None); updated in place.
    covered
        Boolean per target, True when already covered; updated in place (new when None).

    Returns
    -------
    tuple of (list of int, int)
        The inserted tasks in insertion order and the profit they add (objective (1) with
        each target counted once).
    """
    if lines is None:
        lines = {}
    if covered is None:
        covered = np.zeros(instance.n_targets, dtype=bool)
    tw = instance.target_weight
    chosen: list[int] = []
    profit = 0
    for t in order:
        t = int(t)
        gain = sum(int(tw[k]) for k in tasks.targets[t] if not covered[k])
        if gain <= 0:
            continue
        j = int(tasks.orbit[t])
        line = lines.get(j)
        if line is None:
            line = lines[j] = OrbitTimeline.of(instance, j)
        entry = (float(tasks.start[t]), float(tasks.end[t]), float(tasks.roll[t]), t)
        chk = line.check_insert(entry)  # (3)-(6), (11) incrementally
        if not chk:
            continue
        line.insert(entry, chk)
        covered[list(tasks.targets[t])] = True
        chosen.append(t)
        profit += gain
    return chosen, profit


def task_result(
    method: str,
    instance: Instance,
    tasks: TaskSet,
    chosen: list[int],
    profit: float,
    status: Status = Status.FEASIBLE,
    **fields: Any,
) -> Result:
    """The tasks ``chosen`` (indices into ``tasks``), worth ``profit``, as ``method``'s result;
    ``fields`` are the other :class:`sosp.result.Result` fields (``iterations``, ``stats``)."""
    schedule = tasks_to_schedule(instance, tasks, chosen)
    observed = sum(len(o.opps) for o in schedule.observations)
    return Result(method, status, schedule, float(profit), observed, **fields)


def priority_order(tasks: TaskSet) -> np.ndarray:
    """Tasks by decreasing weight; ties by task index (that is by orbit, then start)."""
    return np.lexsort((np.arange(len(tasks)), -np.asarray(tasks.weight, dtype=np.int64)))


@dataclass(frozen=True)
class HPFSParams(Params):
    """Parameters of :func:`solve_hpfs_stc`."""

    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")


def solve_hpfs_stc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    roll_rule: RollRule = HPFSParams.roll_rule,
) -> Result:
    """HPFS-STC: static cluster-tasks by decreasing weight, each inserted when feasible.

    Deterministic: one pass over the tasks (``rng`` and ``time_limit`` are unused).

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused; accepted for the common solver signature.
    time_limit
        Unused: the method is a single pass.
    roll_rule
        Roll of multi-opportunity cluster-tasks: ``"midpoint"`` (9) or ``"nadir"``.

    Returns
    -------
    Result
        Status ``feasible``; ``stats`` holds the number of cluster-tasks.
    """
    del rng, time_limit
    tasks = static_cluster_tasks(instance, roll_rule=roll_rule)
    chosen, profit = insertion_decode(instance, tasks, priority_order(tasks))
    log.debug("hpfs-stc: %d of %d cluster-tasks inserted", len(chosen), len(tasks))
    stats = {"tasks": len(tasks), "inserted": len(chosen)}
    return task_result("hpfs-stc", instance, tasks, chosen, profit, stats=stats)
