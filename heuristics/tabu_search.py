"""TS-STC: Vasquez and Hao's tabu search over static cluster-tasks (paper section 6.3).

The paper compares ASA-DTC with "the Tabu Search algorithm developed by Vasquez and Hao [9]
... to address the daily photograph scheduling of Spot 5", modified by (1) removing the
ternary constraints and (2) adding two knapsack constraints, energy capacity and the maximum
number of sensor openings. Vasquez and Hao (Computational Optimization and Applications 20,
2001) state the SPOT5 problem as a 0/1 knapsack with many "logical" binary and ternary
constraints and search it with a tabu search in the space of *feasible* configurations: a
move adds one photograph and removes the photographs that the addition makes infeasible, and
the search uses a dynamic tabu tenure, aspiration, intensification and diversification.

The formulation here (``docs/baselines.md``, section TS-STC, states every choice)
    one 0/1 variable per usable static cluster-task
    (:func:`sosp.clustering.static_cluster_tasks`); binary constraints: the setup-time
    conflicts (3) between tasks of one orbit (:func:`sosp.conflicts.setup_conflict_rows`,
    exact pairwise, ``docs/model.md``); knapsacks per orbit: memory (5), energy (4) with its
    consecutive slew term, openings (6), all checked by
    :class:`heuristics.timeline.OrbitTimeline`. No ternary constraints (the paper's
    modification (1)). The objective is (1) with coverage semantics: a target covered by
    several scheduled tasks counts once.
Move (add/drop)
    add a task not in the configuration; drop the scheduled tasks of its orbit in (3)
    conflict with it; while the orbit's knapsacks (4)-(6) are violated, drop the scheduled
    task of that orbit whose removal loses least profit (ties: the longest, then the first).
    The move's value is the change of objective (1). Every configuration is feasible.
Selection, tabu tenure and aspiration
    each iteration makes the best move (largest value, ties broken uniformly with ``rng``)
    among the non-tabu ones; a task dropped at iteration ``it`` may not be added back before
    ``it + tenure`` (the reverse move is tabu), with the dynamic, frequency-based tenure
    ``tenure = tenure_min + floor(tenure_freq * drops)`` where ``drops`` counts how often the
    task was dropped so far (tasks that keep oscillating stay out longer). Aspiration: a tabu
    move is allowed when it leads to a configuration better than the best found.
Intensification and diversification
    after ``restart_after`` iterations without a new best, the search restarts from the best
    configuration (intensification) and drops ``perturb`` of its tasks drawn with ``rng``,
    each made tabu (diversification); the drop counts are kept across restarts.
Incremental evaluation
    the value of every move is cached and re-evaluated only when it may have changed: moves
    on the orbit of the last move, on orbits where a scheduled task covers a target whose
    coverage changed, and moves of tasks covering such a target.
Initial configuration
    highest weight first insertion (HPFS-STC, :func:`heuristics.hpfs.insertion_decode`).
Stopping
    after ``iterations`` moves, at ``time_limit`` seconds or on a stop request
    (:mod:`sosp.stop`; the best configuration so far is returned). The rng is the only
    randomness: the same seed and iterations give the same schedule.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np

from heuristics.hpfs import insertion_decode, priority_order, task_result
from heuristics.stc import Watch, at_least
from heuristics.timeline import OrbitTimeline, fits_alone, task_entries
from sosp.clustering import TaskSet, static_cluster_tasks
from sosp.conflicts import setup_conflict_rows
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.result import Result
from sosp.schedule import RollRule

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TSParams(Params):
    """Parameters of TS-STC (defaults and their reasons in ``docs/baselines.md``).

    Parameters
    ----------
    iterations
        Moves at most.
    tenure_min
        Iterations a dropped task stays tabu at least.
    tenure_freq
        Extra tabu iterations per earlier drop of the same task (the dynamic tenure).
    restart_after
        Iterations without a new best before restarting from the best configuration.
    perturb
        Tasks of the best configuration dropped at a restart.
    roll_rule
        Roll of multi-opportunity cluster-tasks, ``"midpoint"`` (9) or ``"nadir"``.
    """

    iterations: int = param(20000, "Moves at most.")
    tenure_min: int = param(10, "Iterations a dropped task stays tabu at least.")
    tenure_freq: float = param(1.0, "Extra tabu iterations per earlier drop of a task.")
    restart_after: int = param(1000, "Idle iterations before restarting from the best.")
    perturb: int = param(3, "Tasks of the best configuration dropped at a restart.")
    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")

    def check(self) -> None:
        at_least(self, iterations=0, tenure_min=0, restart_after=1, perturb=0)
        tf = self.tenure_freq  # a number (Params.check_types); nan fails the range too
        if not 0 <= tf < 1e6:
            raise InputError(f"tenure_freq: expected a number in [0, 1e6), got {tf!r}")


def tabu_tenure(params: TSParams, drops: int) -> int:
    """Iterations a task dropped for the ``drops``-th time (counting this one) stays tabu."""
    return params.tenure_min + int(params.tenure_freq * max(drops - 1, 0))


def is_allowed(tabu_until: Any, it: int, value: int, gain: Any, best: int) -> Any:
    """The tabu rule with aspiration: allowed when not tabu or when it beats the best.

    Elementwise on numpy arrays (``tabu_until`` and ``gain`` per move).
    """
    return (tabu_until <= it) | (value + gain > best)


class TabuSearch:
    """The search state: configuration, coverage, timelines, cached move values.

    Parameters
    ----------
    instance
        The problem.
    tasks
        The static cluster-tasks.
    params
        The parameters.
    rng
        The only source of randomness.
    """

    def __init__(
        self, instance: Instance, tasks: TaskSet, params: TSParams, rng: np.random.Generator
    ) -> None:
        self.instance, self.tasks, self.params, self.rng = instance, tasks, params, rng
        alone = fits_alone(instance, tasks)
        usable = [int(t) for t in priority_order(tasks) if tasks.weight[t] > 0 and alone[t]]
        usable.sort()  # local index order = (orbit, start)
        self.usable = usable
        n = self.n = len(usable)
        self.orb = [int(tasks.orbit[t]) for t in usable]
        self.st = [float(tasks.start[t]) for t in usable]
        self.en = [float(tasks.end[t]) for t in usable]
        # timeline entries (start, end, roll, local index), built once
        self.ent = task_entries(tasks, usable)
        self.tg = [tasks.targets[t] for t in usable]
        self.tw = [int(x) for x in instance.target_weight]
        idx = np.array(usable, dtype=np.int64)
        indptr, indices = setup_conflict_rows(
            instance, tasks.orbit[idx], tasks.start[idx], tasks.end[idx], tasks.roll[idx]
        )
        self.conf = [part.tolist() for part in np.split(indices, indptr[1:-1])]
        self.orbit_tasks: dict[int, list[int]] = {}
        self.target_tasks: dict[int, list[int]] = {}
        for i in range(n):
            self.orbit_tasks.setdefault(self.orb[i], []).append(i)
            for k in self.tg[i]:
                self.target_tasks.setdefault(k, []).append(i)
        self.cover = [0] * instance.n_targets
        self.in_s = [False] * n
        self.lines = {j: OrbitTimeline.of(instance, j) for j in self.orbit_tasks}
        self.value = 0
        self.tabu_until = np.zeros(n, dtype=np.int64)
        self.drops = [0] * n
        self.gain = np.full(n, -np.inf)
        self.plan: list[tuple[int, ...] | None] = [None] * n

    # ------------------------------------------------------------------ configuration
    def add(self, i: int) -> None:
        """Put task i in (its orbit must accept it)."""
        line = self.lines[self.orb[i]]
        chk = line.check_insert(self.ent[i])
        if not chk:
            raise RuntimeError(f"ts-stc: task {i} rejected ({chk.reason}) after its repair")
        line.insert(self.ent[i], chk)
        for k in self.tg[i]:
            if self.cover[k] == 0:
                self.value += self.tw[k]
            self.cover[k] += 1
        self.in_s[i] = True

    def drop(self, i: int) -> None:
        """Take task i out."""
        self.lines[self.orb[i]].discard(self.ent[i])
        for k in self.tg[i]:
            self.cover[k] -= 1
            if self.cover[k] == 0:
                self.value -= self.tw[k]
        self.in_s[i] = False

    def load(self, chosen: list[int]) -> None:
        """Replace the configuration by ``chosen`` (a feasible set of local indices)."""
        for i in [i for i in range(self.n) if self.in_s[i]]:
            self.drop(i)
        for i in sorted(chosen, key=lambda x: self.st[x]):
            self.add(i)
        self.gain[:] = -np.inf
        self.plan = [None] * self.n
        for i in range(self.n):
            self._refresh(i)

    # ------------------------------------------------------------------ moves
    def evaluate(self, i: int) -> tuple[int, tuple[int, ...]] | None:
        """Value and dropped tasks of the move "add task i" (None if i is scheduled)."""
        if self.in_s[i]:
            return None
        j = self.orb[i]
        conflicting = {h for h in self.conf[i] if self.in_s[h]}
        keep = [o[3] for o in self.lines[j].obs if o[3] not in conflicting]
        dropped = list(conflicting)
        dec: dict[int, int] = {}
        for h in dropped:
            for k in self.tg[h]:
                dec[k] = dec.get(k, 0) + 1
        mine = set(self.tg[i])
        while True:
            line = OrbitTimeline(self.lines[j].rules)
            for h in keep:  # a subset of a feasible orbit: fits, no check needed
                line.insert(self.ent[h])
            chk = line.check_insert(self.ent[i])
            if chk:
                break
            if chk.reason == "3" or not keep:  # cannot happen: (3) conflicts are dropped
                return None
            # Knapsack repair: drop the task whose removal loses least (then the longest).
            best_h, best_key = -1, None
            for h in keep:
                loss = sum(
                    self.tw[k]
                    for k in self.tg[h]
                    if k not in mine and self.cover[k] - dec.get(k, 0) == 1
                )
                key = (loss, -(self.en[h] - self.st[h]), h)
                if best_key is None or key < best_key:
                    best_h, best_key = h, key
            keep.remove(best_h)
            dropped.append(best_h)
            for k in self.tg[best_h]:
                dec[k] = dec.get(k, 0) + 1
        gain = sum(self.tw[k] for k in mine if self.cover[k] == 0)
        gain -= sum(self.tw[k] for k, d in dec.items() if k not in mine and self.cover[k] == d)
        return gain, tuple(sorted(dropped))

    def _refresh(self, i: int) -> None:
        ev = self.evaluate(i)
        self.gain[i], self.plan[i] = (-np.inf, None) if ev is None else ev

    def apply(self, i: int, it: int) -> None:
        """Make the move "add task i" (its cached plan) and refresh the affected moves."""
        dropped = self.plan[i]
        assert dropped is not None
        changed: set[int] = set(self.tg[i])
        for h in dropped:
            self.ban(h, it, changed)
        self.add(i)
        self.invalidate({self.orb[i]}, changed)

    def ban(self, h: int, it: int, changed: set[int]) -> None:
        """Take task h out at iteration ``it``, tabu for its tenure; its targets join
        ``changed`` (for :meth:`invalidate`)."""
        self.drop(h)
        self.drops[h] += 1
        self.tabu_until[h] = it + tabu_tenure(self.params, self.drops[h])
        changed.update(self.tg[h])

    def invalidate(self, orbits: set[int], changed: set[int]) -> None:
        """Re-evaluate the moves that the last change of configuration may affect."""
        dirty_orbits = set(orbits)
        dirty: set[int] = set()
        for k in changed:
            for h in self.target_tasks.get(k, ()):
                if self.in_s[h]:
                    dirty_orbits.add(self.orb[h])
                else:
                    dirty.add(h)
        for j in dirty_orbits:
            dirty.update(self.orbit_tasks[j])
        for h in sorted(dirty):
            self._refresh(h)

    def choose(self, it: int, best: int) -> int:
        """The best allowed move (ties uniformly at random), or -1 if there is none."""
        g = self.gain
        allowed = np.isfinite(g) & is_allowed(self.tabu_until, it, self.value, g, best)
        if not allowed.any():
            return -1
        top = g[allowed].max()
        cand = np.flatnonzero(allowed & (g == top))
        return int(cand[int(self.rng.integers(len(cand)))]) if len(cand) > 1 else int(cand[0])

    def chosen(self) -> list[int]:
        return [i for i in range(self.n) if self.in_s[i]]


def run_tabu_search(
    instance: Instance,
    params: TSParams,
    rng: np.random.Generator,
    time_limit: float | None = None,
) -> tuple[TaskSet, list[int], int, dict[str, int]]:
    """Run the search; returns the tasks, the best ones chosen, their profit and counters."""
    watch = Watch(time_limit)
    tasks = static_cluster_tasks(instance, roll_rule=params.roll_rule)
    ts = TabuSearch(instance, tasks, params, rng)
    local = {t: i for i, t in enumerate(ts.usable)}
    order = priority_order(tasks)
    start, _ = insertion_decode(instance, tasks, order[np.isin(order, ts.usable)])
    ts.load([local[t] for t in start])
    best, best_set, best_iter = ts.value, ts.chosen(), 0
    it = last_best = restarts = idle = aspired = 0
    # progress reports, the limit and stop requests (Ctrl-C keeps the best so far)
    while it < params.iterations and ts.n:
        if watch(it, best, it - best_iter):
            break
        it += 1
        i = ts.choose(it, best)
        if i < 0:
            idle += 1
            if not np.isfinite(ts.gain).any():
                break  # every task is scheduled
            continue
        if ts.tabu_until[i] > it:
            aspired += 1
        ts.apply(i, it)
        if ts.value > best:
            best, best_set, best_iter, last_best = ts.value, ts.chosen(), it, it
        elif it - last_best >= params.restart_after:
            restarts += 1
            last_best = it
            ts.load(best_set)
            k = min(params.perturb, len(best_set))
            if k:
                out = rng.choice(len(best_set), size=k, replace=False)
                changed: set[int] = set()
                for q in sorted(int(x) for x in out):
                    ts.ban(best_set[q], it, changed)
                ts.invalidate({ts.orb[best_set[int(q)]] for q in out}, changed)
    stats = {
        "tasks": len(tasks),
        "usable_tasks": ts.n,
        "best_iteration": best_iter,
        "restarts": restarts,
        "idle_iterations": idle,
        "aspirations": aspired,
    }
    return tasks, [ts.usable[i] for i in best_set], best, stats | {"iterations": it}


def solve_ts_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """TS-STC: Vasquez and Hao's tabu search over static cluster-tasks.

    Parameters
    ----------
    instance
        The problem.
    rng
        The only source of randomness (ties between moves, restarts).
    time_limit
        Wall-time limit in seconds (None: stop after ``iterations``).
    **params
        Fields of :class:`TSParams`.

    Returns
    -------
    Result
        Status ``feasible``; ``stats`` holds the iteration of the best configuration, the
        restarts and the moves allowed by aspiration.
    """
    p = from_kwargs(TSParams, params, method="ts-stc")
    tasks, chosen, profit, stats = run_tabu_search(instance, p, rng, time_limit)
    it = stats.pop("iterations")
    log.info("ts-stc: profit %d, %d iterations (best at %d)", profit, it, stats["best_iteration"])
    return task_result("ts-stc", instance, tasks, chosen, profit, iterations=it, stats=stats)
