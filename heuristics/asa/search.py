"""Algorithm 1 (ASA-DTC) and the solve functions of the three variants."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import asdict, replace
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
from heuristics.asa.orbit import ascend, make_planner, orbit_search_start, replan_or_orbit
from heuristics.asa.params import ASAParams
from heuristics.asa.problem import Problem, TooLargeForASA, build_problem
from heuristics.asa.replan import REPLAN, polish, replan_move
from heuristics.asa.select import AdaptiveRoulette
from heuristics.asa.state import END, MEMBERS, ROLL, START, Cluster, State
from heuristics.asa.tabu import TabuList
from sosp.clustering import tasks_to_schedule
from sosp.instance import Instance
from sosp.io import atomic_write_text
from sosp.progress import current as current_progress
from sosp.result import Result, Status
from sosp.schedule import Observation, Schedule
from sosp.stop import (
    Budget,
    FirstOf,
    Interrupted,
    MaxIterations,
    MaxRuntime,
    NoImprovement,
    SearchStatus,
)

log = logging.getLogger(__name__)

#: Iteration limit used when no stopping rule at all is given.
DEFAULT_ITERATIONS = 20_000

#: Columns of the trace (``Result.stats["trace"]``), in CSV order.
TRACE_COLUMNS = tuple(
    "iteration time_s best current temperature pro_insertion pro_migration accepted_insertion"
    " rejected_insertion accepted_migration rejected_migration pro_replan accepted_replan"
    " rejected_replan".split()
)

#: The neighbourhoods by index (:data:`INSERTION`, :data:`MIGRATION`, :data:`REPLAN`); the
#: third only with ``ASAParams.replan``.
NEIGHBOURHOODS: tuple[Callable[..., bool], ...] = (insertion_move, migration_move, replan_move)
NAMES = ("insertion", "migration", "replan")


class Search:
    """Algorithm 1 as a resumable object: build, :meth:`run` until a stop, :meth:`result`.

    :func:`run_asa` runs it once (the parallel search, :mod:`heuristics.asa.parallel`, once
    per chain); the temperature, the neighbourhood probabilities, the tabu list and the
    counters carry over from one :meth:`run` to the next.

    Parameters
    ----------
    instance, mode, rng, params, acceptance, selector
        As :func:`run_asa`.
    time_limit
        Wall time of the whole search, seconds: the candidates of whole-orbit re-planning
        must be complete within half of what is left of it (else the move plans over windows,
        :func:`~heuristics.asa.orbit.make_planner`).
    t0
        :func:`time.perf_counter` value the run's times count from (default: now).
    """

    def __init__(
        self,
        instance: Instance,
        mode: str,
        *,
        rng: np.random.Generator,
        time_limit: float | None = None,
        params: ASAParams | None = None,
        acceptance: Any = None,
        selector: Any = None,
        t0: float | None = None,
    ) -> None:
        self.t0 = t0 = time.perf_counter() if t0 is None else t0
        self.instance = instance
        self.mode = mode
        self.rng = rng
        self.params = params = params or ASAParams()
        self.problem = build_problem(instance, mode, params.roll_rule)
        self.state = state = State(self.problem, params.roll_rule, params.nadir_singles)
        self.acceptance = acceptance or AdaptiveTemperature(
            params.lambda_min, params.rho, params.delta, params.r_update
        )
        self.probs = [params.pro1, params.pro2] + ([params.pro3] if params.replan else [])
        floor = params.replan_floor if params.replan else 0.0
        self.selector = selector or AdaptiveRoulette(self.probs, params.eta, params.itr, floor)
        length = params.tabu_length
        self.tabu = TabuList(max(1, self.problem.n_observable // 50) if length is None else length)

        self.moves = list(NEIGHBOURHOODS)
        run = Budget.until(None if time_limit is None else t0 + time_limit)
        self.planner = make_planner(instance, state, params, run)
        if self.planner is not None:
            self.moves[REPLAN] = partial(replan_or_orbit, planner=self.planner)
        self.t_planner = time.perf_counter() - t0

        self.init_stats: dict[str, float] = {}
        if params.init in ("orbit-dp", "lp") and self.planner is not None:
            self.init_stats = orbit_search_start(state, rng, params, self.planner, run, t0)
        # section 5.4's insertion ends at the limit, or after an orbit start at its share
        # (``init_share``) of the time left: the start leaves it the targets it could not
        # place, and trying them all could take most of the run
        insertion = run.share(params.init_share) if self.init_stats else run
        initial_solution(state, params, insertion)
        self.t_init = time.perf_counter() - t0
        self.best = state.profit
        self.best_snap = state.snapshot()
        self.status = SearchStatus(0, 0, self.best)
        self.counts = {o.name.lower(): [0, 0, 0] for o in Outcome}
        self.accepted = [0, 0, 0]
        self.rejected = [0, 0, 0]
        self.restarts = 0
        self.trace: list[list[float]] = []
        self.record()
        log.debug("asa-%s: initial profit %g in %.3f s", mode, self.best, self.t_init)

    def record(self) -> None:
        """Append a trace row (columns :data:`TRACE_COLUMNS`)."""
        pr, acc, rej = self.selector.probabilities, self.accepted, self.rejected
        replan = [pr[REPLAN] if len(pr) > REPLAN else 0.0, acc[2], rej[2]]
        row = [self.status.iteration, round(time.perf_counter() - self.t0, 6), self.best]
        row += [self.state.profit, self.acceptance.temperature, pr[INSERTION], pr[MIGRATION]]
        self.trace.append([*row, acc[0], rej[0], acc[1], rej[1], *replan])

    def run(self, stop: Callable[[SearchStatus], bool]) -> None:
        """Iterate Algorithm 1 (with sosp's restarts) until ``stop`` says so or a stop is
        requested (:class:`~sosp.stop.Interrupted`); each check also reports to the solve's
        :func:`~sosp.progress.current` progress."""
        stop = FirstOf(current_progress(), Interrupted(), stop)
        state, rng, params, tabu = self.state, self.rng, self.params, self.tabu
        selector, acceptance, status = self.selector, self.acceptance, self.status
        accepted, rejected, counts, moves = self.accepted, self.rejected, self.counts, self.moves
        restart, every = params.restart, params.trace_every
        g = status.iteration
        while not stop(status):
            g += 1
            i = selector.choose(rng)
            before = state.profit
            state.begin()
            made = moves[i](state, rng, params, tabu)
            delta = state.profit - before if made else 0.0
            if made and acceptance(delta, rng):
                tabu.add(state.commit())
                accepted[i] += 1
                outcome = Outcome.BETTER if delta > 0 else Outcome.ACCEPTED
                if state.profit > self.best + 1e-9:
                    self.best, self.best_snap = state.profit, state.snapshot()
                    outcome = Outcome.BEST
            else:
                state.rollback()
                rejected[i] += 1
                outcome = Outcome.REJECTED
            acceptance.update(delta, outcome is not Outcome.REJECTED)
            selector.record(i, outcome)
            counts[outcome.name.lower()][i] += 1
            status.iteration = g
            if restart and outcome is not Outcome.BEST and (status.since_best + 1) % restart == 0:
                # Intensify around the best (sosp's, not the paper's): restart from it, polish.
                state.load(self.best_snap)
                self.restarts += 1
                if self.planner is not None:
                    polished = ascend(state, rng, self.planner) > 0
                else:
                    polished = params.polish > 0 and polish(state, rng, params, tabu) > 0
                if polished and state.profit > self.best + 1e-9:
                    self.best, self.best_snap = state.profit, state.snapshot()
                    outcome = Outcome.BEST
            if outcome is Outcome.BEST:
                status.since_best = 0
                status.best = self.best
                self.record()
            else:
                status.since_best += 1
                if g % every == 0:
                    self.record()

    def result(self) -> Result:
        """The best schedule found so far as a :class:`~sosp.result.Result`."""
        g = self.status.iteration
        if not self.trace or self.trace[-1][0] != g:
            self.record()
        runtime = time.perf_counter() - self.t0
        schedule = build_schedule(self.instance, self.problem, self.best_snap)
        observed = sum(len(o.opps) for o in schedule.observations)
        names = NAMES[: len(self.probs)]
        planner = self.planner
        stats = {
            "mode": self.mode,
            "params": asdict(self.params),
            "initial_profit": self.trace[0][2],
            "initial_time_s": round(self.t_init, 6),
            **self.init_stats,
            "orbit_candidates": 0 if planner is None else planner.n_candidates,
            "orbit_candidates_s": round(self.t_planner, 6) if planner is not None else 0.0,
            "iterations_per_s": round(g / max(runtime - self.t_init, 1e-9), 1),
            "tabu_length": self.tabu.length,
            "restarts": self.restarts,
            "accepted": dict(zip(names, self.accepted, strict=False)),
            "rejected": dict(zip(names, self.rejected, strict=False)),
            "outcomes": {k: dict(zip(names, v, strict=False)) for k, v in self.counts.items()},
            "trace_columns": list(TRACE_COLUMNS),
            "trace": self.trace,
        }
        log.info("asa-%s: best %g after %d iterations, %.2f s", self.mode, self.best, g, runtime)
        return Result(
            f"asa-{self.mode}",
            Status.FEASIBLE,
            schedule,
            float(self.best),
            observed,
            runtime_s=runtime,
            iterations=g,
            stats=stats,
        )


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
    run = Budget.until(None if time_limit is None else t0 + time_limit)
    try:
        search = Search(
            instance,
            mode,
            rng=rng,
            time_limit=time_limit,
            params=params,
            acceptance=acceptance,
            selector=selector,
            t0=t0,
        )
    except TooLargeForASA as exc:
        if mode != "dtc":
            raise  # a variant stands for itself in a comparison: refused, not replaced
        # ASA-DTC on an instance whose conflict lists it refuses (MAX_CONFLICTS): the search
        # its default start runs (orbit-dp's iterated local search; init="lp" or "orbit-dp")
        # for the whole time, reported under the name of what ran (method orbit-dp,
        # stats["fallback"]) with a warning. ASA-DTC is the default method and milp's
        # schedule when its model cannot be built, so it answers on every instance; a
        # 2,500-target box near a pole under 8 satellites (35 million (3) pairs) was refused
        # with exit 2 by both.
        from heuristics.orbit_search import solve_orbit_dp

        log.warning("asa-dtc: %s; the schedule is orbit-dp's search, ASA-DTC's start", exc)
        res = solve_orbit_dp(instance, rng=rng, time_limit=run.left())
        stats = {"mode": "dtc", "fallback": "orbit-dp", "fallback_reason": str(exc), **res.stats}
        return replace(res, runtime_s=time.perf_counter() - t0, stats=stats)  # method: orbit-dp
    if stop is None:  # the first of iterations, no_improve and the time left (None: none)
        limits = (MaxIterations, params.iterations), (NoImprovement, params.no_improve)
        crit: list[Callable[[SearchStatus], bool]] = [f(n) for f, n in limits if n is not None]
        if run.deadline is not None:  # an orbit move can take seconds: foreseen
            crit.append(MaxRuntime(run.left() or 0.0, foresee=True))
        stop = FirstOf(*crit or [MaxIterations(DEFAULT_ITERATIONS)])
    search.run(stop)
    return search.result()


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
    lines = [",".join(result.stats.get("trace_columns", TRACE_COLUMNS))] + [
        ",".join(repr(float(v)) if isinstance(v, float) else str(v) for v in row)
        for row in result.stats.get("trace", [])
    ]
    return "".join(f"{line}\n" for line in lines)


def write_trace_csv(result: Result, path: str | os.PathLike[str]) -> None:
    """Write the trace of a result to ``path`` as CSV, atomically."""
    atomic_write_text(path, trace_csv(result))
