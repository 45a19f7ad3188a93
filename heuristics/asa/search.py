"""Algorithm 1 (ASA-DTC) and the solve functions of the three variants."""

from __future__ import annotations

import io
import logging
import os
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from heuristics.asa.accept import AdaptiveTemperature, Outcome
from heuristics.asa.neighbourhoods import (
    INSERTION,
    MIGRATION,
    initial_solution,
    insertion_move,
    migration_move,
)
from heuristics.asa.orbit import ascend, make_planner, replan_or_orbit
from heuristics.asa.params import ASAParams
from heuristics.asa.problem import Problem, build_problem
from heuristics.asa.replan import REPLAN, polish, replan_move
from heuristics.asa.select import AdaptiveRoulette
from heuristics.asa.state import END, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.stop import FirstOf, MaxIterations, MaxRuntime, NoImprovement, SearchStatus
from heuristics.asa.tabu import TabuList
from sosp.clustering import tasks_to_schedule
from sosp.instance import Instance
from sosp.io import atomic_write_text
from sosp.result import Result, Status
from sosp.schedule import Observation, Schedule

log = logging.getLogger(__name__)

#: Iteration limit used when no stopping rule at all is given.
DEFAULT_ITERATIONS = 20_000

#: Columns of the trace (``Result.stats["trace"]``), in CSV order.
TRACE_COLUMNS = (
    "iteration",
    "time_s",
    "best",
    "current",
    "temperature",
    "pro_insertion",
    "pro_migration",
    "accepted_insertion",
    "rejected_insertion",
    "accepted_migration",
    "rejected_migration",
    "pro_replan",
    "accepted_replan",
    "rejected_replan",
)

#: The neighbourhoods by index (:data:`INSERTION`, :data:`MIGRATION`, :data:`REPLAN`); the
#: third only with ``ASAParams.replan``.
NEIGHBOURHOODS: tuple[Callable[..., bool], ...] = (insertion_move, migration_move, replan_move)
NAMES = ("insertion", "migration", "replan")


def run_asa(
    instance: Instance,
    mode: str,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    params: ASAParams | None = None,
    acceptance: Any = None,
    selector: Any = None,
    stop: Callable[[SearchStatus], bool] | None = None,
) -> Result:
    """Run Algorithm 1 on ``instance``.

    Parameters
    ----------
    instance
        The problem.
    mode
        ``"dtc"`` (dynamic clustering), ``"stc"`` (static cluster-tasks) or ``"nontc"``.
    rng
        The only source of randomness.
    time_limit
        Wall-time limit in seconds (includes the initial solution).
    params
        :class:`ASAParams` (Table 2 defaults).
    acceptance, selector, stop
        Swappable acceptance rule, neighbourhood selector and stopping criterion (defaults:
        :class:`AdaptiveTemperature` (19)-(21), :class:`AdaptiveRoulette` (17)-(18), and the
        first of ``params.iterations``, ``time_limit``, ``params.no_improve``).

    Returns
    -------
    Result
        Status ``feasible``; ``stats`` holds the trace (columns :data:`TRACE_COLUMNS`) and
        counts per neighbourhood.
    """
    t0 = time.perf_counter()
    params = params or ASAParams()
    problem = build_problem(instance, mode, params.roll_rule)
    state = State(problem, params.roll_rule, params.nadir_singles)
    acceptance = acceptance or AdaptiveTemperature(
        params.lambda_min, params.rho, params.delta, params.r_update
    )
    probs = [params.pro1, params.pro2] + ([params.pro3] if params.replan else [])
    floor = max(params.min_probability, params.replan_floor) if params.replan else None
    selector = selector or AdaptiveRoulette(
        probs, params.eta, params.itr, params.min_probability if floor is None else floor
    )
    if stop is None:
        crit: list[Callable[[SearchStatus], bool]] = []
        if params.iterations is not None:
            crit.append(MaxIterations(params.iterations))
        if time_limit is not None:
            crit.append(MaxRuntime(max(0.0, time_limit - (time.perf_counter() - t0))))
        if params.no_improve is not None:
            crit.append(NoImprovement(params.no_improve))
        if not crit:
            crit.append(MaxIterations(DEFAULT_ITERATIONS))
        stop = FirstOf(*crit)
    length = params.tabu_length
    if length is None:
        length = max(1, problem.n_observable // 50)
    tabu = TabuList(length)

    moves = list(NEIGHBOURHOODS)
    deadline = None if time_limit is None else t0 + 0.5 * time_limit
    planner = make_planner(instance, state, params, deadline)
    if planner is not None:
        moves[REPLAN] = partial(replan_or_orbit, planner=planner)
    t_planner = time.perf_counter() - t0

    initial_solution(state, params)
    t_init = time.perf_counter() - t0
    best = state.profit
    best_snap = state.snapshot()
    status = SearchStatus(0, 0, best)
    counts = {o.name.lower(): [0, 0, 0] for o in Outcome}
    accepted = [0, 0, 0]
    rejected = [0, 0, 0]
    trace: list[list[float]] = []

    def record(g: int) -> None:
        pr = selector.probabilities
        trace.append(
            [
                g,
                round(time.perf_counter() - t0, 6),
                best,
                state.profit,
                acceptance.temperature,
                pr[INSERTION],
                pr[MIGRATION],
                accepted[0],
                rejected[0],
                accepted[1],
                rejected[1],
                pr[REPLAN] if len(pr) > REPLAN else 0.0,
                accepted[2],
                rejected[2],
            ]
        )

    record(0)
    g = 0
    restart = params.restart
    restarts = 0
    every = params.trace_every
    log.debug("asa-%s: initial profit %g in %.3f s", mode, best, t_init)
    while not stop(status):
        g += 1
        i = selector.choose(rng)
        before = state.profit
        state.begin()
        made = moves[i](state, rng, params, tabu)
        delta = state.profit - before if made else 0.0
        if made and acceptance(delta, rng):
            removed = state.commit()
            tabu.add(removed)
            accepted[i] += 1
            if state.profit > best + 1e-9:
                best = state.profit
                best_snap = state.snapshot()
                outcome = Outcome.BEST
            elif delta > 0:
                outcome = Outcome.BETTER
            else:
                outcome = Outcome.ACCEPTED
            acceptance.update(delta, True)
        else:
            state.rollback()
            rejected[i] += 1
            outcome = Outcome.REJECTED
            acceptance.update(delta, False)
        selector.record(i, outcome)
        counts[outcome.name.lower()][i] += 1
        status.iteration = g
        if restart and outcome is not Outcome.BEST and (status.since_best + 1) % restart == 0:
            # Intensify around the best (sosp's, not the paper's): restart from it, polish it.
            state.load(best_snap)
            restarts += 1
            if planner is not None:
                polished = ascend(state, rng, planner) > 0
            else:
                polished = params.polish > 0 and polish(state, rng, params, tabu) > 0
            if polished and state.profit > best + 1e-9:
                best = state.profit
                best_snap = state.snapshot()
                outcome = Outcome.BEST
        if outcome is Outcome.BEST:
            status.since_best = 0
            status.best = best
            record(g)
        else:
            status.since_best += 1
            if g % every == 0:
                record(g)
    if not trace or trace[-1][0] != g:
        record(g)
    runtime = time.perf_counter() - t0
    schedule = build_schedule(instance, problem, best_snap)
    observed = sum(len(o.opps) for o in schedule.observations)
    names = NAMES[: len(probs)]
    stats = {
        "mode": mode,
        "params": params.as_dict(),
        "initial_profit": trace[0][2],
        "initial_time_s": round(t_init, 6),
        "orbit_candidates": 0 if planner is None else planner.data.n_items,
        "orbit_candidates_s": round(t_planner, 6) if planner is not None else 0.0,
        "iterations_per_s": round(g / max(runtime - t_init, 1e-9), 1),
        "tabu_length": length,
        "restarts": restarts,
        "accepted": dict(zip(names, accepted, strict=False)),
        "rejected": dict(zip(names, rejected, strict=False)),
        "outcomes": {k: dict(zip(names, v, strict=False)) for k, v in counts.items()},
        "trace_columns": list(TRACE_COLUMNS),
        "trace": trace,
    }
    log.info("asa-%s: best %g after %d iterations, %.2f s", mode, best, g, runtime)
    return Result(
        f"asa-{mode}",
        Status.FEASIBLE,
        schedule,
        float(best),
        observed,
        runtime_s=runtime,
        iterations=g,
        stats=stats,
    )


def build_schedule(instance: Instance, problem: Problem, snap: list[list[Cluster]]) -> Schedule:
    """The :class:`~sosp.schedule.Schedule` of a per-orbit snapshot of cluster-tasks."""
    if problem.mode == "stc":
        chosen = [c[MEMBERS][0] for obs in snap for c in obs]
        return tasks_to_schedule(instance, problem.tasks, chosen)
    out = []
    for j, obs in enumerate(snap):
        for c in obs:
            out.append(Observation(j, c[START], c[END], c[ROLL], tuple(sorted(c[MEMBERS]))))
    return Schedule(tuple(out))


def trace_csv(result: Result) -> str:
    """The trace of a result as CSV text (header :data:`TRACE_COLUMNS`)."""
    cols = result.stats.get("trace_columns", list(TRACE_COLUMNS))
    buf = io.StringIO()
    buf.write(",".join(cols) + "\n")
    for row in result.stats.get("trace", []):
        buf.write(",".join(repr(float(v)) if isinstance(v, float) else str(v) for v in row))
        buf.write("\n")
    return buf.getvalue()


def write_trace_csv(result: Result, path: str | os.PathLike[str]) -> None:
    """Write the trace of a result to ``path`` as CSV, atomically."""
    atomic_write_text(path, trace_csv(result))


def _solve(
    instance: Instance, mode: str, rng: np.random.Generator, time_limit: float | None, **kw: Any
) -> Result:
    params = ASAParams.from_kwargs(**kw)
    return run_asa(instance, mode, rng=rng, time_limit=time_limit, params=params)


def solve_asa_dtc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-DTC: adaptive simulated annealing with dynamic task clustering (Algorithm 1).

    Parameters
    ----------
    instance
        The problem.
    rng
        The only randomness (seeded by :func:`sosp.solve.solve`).
    time_limit
        Wall-time limit, seconds.
    **params
        Any field of :class:`~heuristics.asa.params.ASAParams` (``iterations``, ``lambda_min``,
        ``roll_rule``, ...), and ``preset`` (a name of
        :data:`~heuristics.asa.params.PRESETS`, applied first); CLI strings are converted.
        Bad values raise :class:`~sosp.errors.InputError`.
    """
    return _solve(instance, "dtc", rng, time_limit, **params)


def solve_asa_stc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-STC: the same search over static cluster-tasks built once (no dynamic clustering).

    Parameters are those of :func:`solve_asa_dtc`; ``roll_rule`` sets the static tasks' roll.
    """
    return _solve(instance, "stc", rng, time_limit, **params)


def solve_asa_nontc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-NONTC: the same search over single opportunities, never clustered.

    Parameters are those of :func:`solve_asa_dtc`.
    """
    return _solve(instance, "nontc", rng, time_limit, **params)
