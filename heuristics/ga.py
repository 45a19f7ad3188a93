"""Genetic algorithm over static cluster-tasks (GA-STC, paper section 6.3).

The paper compares ASA-DTC with the GA of its ref. [7] over static cluster-tasks, keeping of
ref. [7]'s five-criteria fitness (priority, deadline, profit, area, emergency) only the
priority criterion: the fitness is objective (1), the total weight of the targets covered.
The paper casts SOSP as a multidimensional knapsack problem (section 1 and its ref. [1]);
sosp follows the GA with repair of Chu and Beasley for that problem ("A genetic algorithm for
the multidimensional knapsack problem", Journal of Heuristics 1998), whose operators and
parameters are published; ``docs/baselines.md`` says what was taken from where.

Encoding
    one bit per usable static cluster-task (:class:`heuristics.stc.StcData`): 1 = scheduled.
Repair (DROP then ADD, Lamarckian)
    the child's scheduled tasks are taken by decreasing pseudo-utility (weight over resource
    share, :func:`heuristics.stc.resource_cost`) and kept when they still earn something and
    fit their orbit ((3)-(6), (11) through :class:`heuristics.timeline.OrbitTimeline`); the
    others are dropped (so the least useful go first). Then every unscheduled task, by
    decreasing utility, is added when it earns and fits. The repaired bits replace the
    child's. Every individual is a feasible schedule.
Selection
    binary tournament, once per parent.
Crossover
    uniform: each bit from either parent with probability 1/2.
Mutation
    ``mutation_bits`` random bits flipped (Chu and Beasley: 2).
Replacement
    steady state: a child identical to a member of the population is discarded; otherwise it
    replaces a least fit member.
Initial population
    each member adds the tasks in a random order, each when it earns and fits (no duplicates).
Stopping
    after ``iterations`` children (default: none with a time limit, else
    :data:`DEFAULT_ITERATIONS`), at ``time_limit``, or on a stop request (:mod:`sosp.stop`,
    which also reports progress); the rng passed in is the only randomness, so the same seed
    and iterations give the same schedule.
"""

from __future__ import annotations

import logging
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from heuristics.hpfs import task_result
from heuristics.stc import Selection, StcData, Watch, at_least, stc_data
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.result import Result
from sosp.rules import RollRule

log = logging.getLogger(__name__)


#: Children generated when neither ``iterations`` nor a time limit is given.
DEFAULT_ITERATIONS = 20000


@dataclass(frozen=True)
class GAParams(Params):
    """Parameters of GA-STC (Chu and Beasley's published values as defaults).

    Parameters
    ----------
    population
        Individuals in the population (Chu and Beasley: 100).
    tournament
        Tournament size of the parent selection (binary tournament: 2).
    mutation_bits
        Bits flipped in each child (Chu and Beasley: 2).
    iterations
        Children generated (Chu and Beasley stop after 10^6 non-duplicate children); None:
        until the time limit, or :data:`DEFAULT_ITERATIONS` when there is none.
    roll_rule
        Roll of multi-opportunity cluster-tasks: ``"midpoint"`` (9) or ``"nadir"``.
    """

    population: int = param(100, "Individuals in the population (Chu and Beasley: 100).")
    tournament: int = param(2, "Tournament size of the parent selection (binary tournament: 2).")
    mutation_bits: int = param(2, "Bits flipped in each child (Chu and Beasley: 2).")
    iterations: int | None = param(None, "Children generated (None: to the time limit).")
    roll_rule: RollRule = param("midpoint", "Roll of cluster-tasks: 'midpoint' (9) or 'nadir'.")

    def check(self) -> None:
        at_least(self, population=2, tournament=1, mutation_bits=0, iterations=0)
        if self.tournament > self.population:
            raise InputError(
                f"tournament: must not exceed population ({self.population}), "
                f"got {self.tournament!r}"
            )


def repair(data: StcData, bits: np.ndarray) -> tuple[np.ndarray, int]:
    """DROP then ADD (module docstring): a feasible, maximal chromosome and its fitness.

    Parameters
    ----------
    data
        The usable tasks.
    bits
        One bool per usable task (index into ``data.usable``); not modified.

    Returns
    -------
    tuple of (numpy.ndarray, int)
        The repaired bits and the profit (objective (1)) of the schedule they encode.
    """
    pos = data.position
    sol = Selection(data)
    on = set(int(t) for t in data.usable[bits])
    out = np.zeros(len(data.usable), dtype=bool)
    # DROP: keep the selected tasks by decreasing utility while they earn and fit; ADD: then
    # every other task by decreasing utility (a task kept earns nothing more)
    for only in (on, None):
        for t in data.by_utility.tolist():
            if (only is None or t in only) and sol.gain(t) > 0 and sol.try_add(t):
                out[pos[t]] = True
    return out, sol.profit


def random_member(data: StcData, rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """An initial chromosome: the tasks in a random order, each added when it earns and fits."""
    pos = data.position
    sol = Selection(data)
    out = np.zeros(len(data.usable), dtype=bool)
    for i in rng.permutation(len(data.usable)):
        t = int(data.usable[i])
        if sol.gain(t) > 0 and sol.try_add(t):
            out[pos[t]] = True
    return out, sol.profit


def uniform_crossover(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Each bit from ``a`` or ``b`` with probability 1/2."""
    return np.where(rng.random(len(a)) < 0.5, a, b)


def mutate(bits: np.ndarray, n_bits: int, rng: np.random.Generator) -> np.ndarray:
    """Flip ``n_bits`` distinct random bits (a copy)."""
    out = bits.copy()
    if len(out) and n_bits:
        flip = rng.choice(len(out), size=min(n_bits, len(out)), replace=False)
        out[flip] = ~out[flip]
    return out


def tournament(fitness: np.ndarray, size: int, rng: np.random.Generator) -> int:
    """Index of the fittest of ``size`` members drawn with replacement (first on ties)."""
    drawn = rng.integers(0, len(fitness), size=size)
    return int(drawn[np.argmax(fitness[drawn])])


def solve_ga_stc(
    instance: Instance, *, rng: np.random.Generator, time_limit: float | None = None, **params: Any
) -> Result:
    """GA-STC: steady-state genetic algorithm over static cluster-tasks, each child repaired.

    Parameters
    ----------
    instance
        The problem.
    rng
        The only source of randomness.
    time_limit
        Wall-time limit in seconds (None: stop after ``iterations`` children).
    **params
        Fields of :class:`GAParams`.

    Returns
    -------
    Result
        Status ``feasible``; ``iterations`` children generated; ``stats`` holds the duplicates
        discarded and the child that found the best schedule.
    """
    p = from_kwargs(GAParams, params, method="ga-stc")
    watch = Watch(time_limit)
    data = stc_data(instance, p.roll_rule)
    pop: list[np.ndarray] = []
    fit: list[int] = []
    seen: set[bytes] = set()
    tries = 0
    # Initial population without duplicates (a few tries: tiny instances have few schedules).
    while len(pop) < p.population and tries < 10 * p.population:
        tries += 1
        bits, f = random_member(data, rng)
        key = np.packbits(bits).tobytes()
        if key in seen:
            continue
        seen.add(key)
        pop.append(bits)
        fit.append(f)
        if watch.budget.expired():
            break
    fitness = np.array(fit, dtype=np.int64)
    best_i = int(np.argmax(fitness))
    best_bits, best_fit, best_child = pop[best_i], int(fitness[best_i]), 0
    children = duplicates = 0
    max_children = watch.limit(p.iterations, DEFAULT_ITERATIONS)
    while children < max_children and len(pop) >= 2:
        if watch(children, best_fit, children - best_child):
            break
        children += 1
        a = tournament(fitness, p.tournament, rng)
        b = tournament(fitness, p.tournament, rng)
        child = mutate(uniform_crossover(pop[a], pop[b], rng), p.mutation_bits, rng)
        child, f = repair(data, child)
        key = np.packbits(child).tobytes()
        if key in seen:
            duplicates += 1
            continue
        worst = int(np.argmin(fitness))
        seen.discard(np.packbits(pop[worst]).tobytes())
        seen.add(key)
        pop[worst], fitness[worst] = child, f
        if f > best_fit:
            best_bits, best_fit, best_child = child, f, children
    chosen = [int(t) for t in data.usable[best_bits]]
    stats = {
        "tasks": len(data.tasks),
        "usable_tasks": len(data.usable),
        "population": len(pop),
        "duplicates": duplicates,
        "best_child": best_child,
        "params": asdict(p),
    }
    log.info("ga-stc: profit %d after %d children (best at %d)", best_fit, children, best_child)
    return task_result(
        "ga-stc", instance, data.tasks, chosen, best_fit, iterations=children, stats=stats
    )
