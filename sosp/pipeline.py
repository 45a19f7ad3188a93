"""A solve as stages of one pipeline: a start, the improving method, a certifying bound.

:func:`sosp.solve.solve` runs them in order, each within a share of one
:class:`~sosp.stop.Budget` (the run's time limit), so the limit covers the whole run:

1. **start** (:func:`run_start`): a registered method whose schedule the improving method
   starts from. A method takes one when its registry entry names a ``start`` function
   (:attr:`sosp.registry.Method.start`) that returns a :class:`Start` for its parameters
   (``milp``: ``warm_start="auto"``; ``milp-lns``: ``start``). It gets :data:`START_SHARE`
   of the method's time (and at most :attr:`Start.seconds`); a start that gives no schedule
   in its share gives way to :data:`FALLBACK_START`.
2. **method**: the registered method, given the start's schedule as ``warm_start`` and the
   time left; the result is the better of its schedule and the start's, so a method never
   returns less than its start stage alone.
3. **bound** (:func:`certify`, with ``bound=``): a bound of the problem after the method,
   in the time left; the method keeps :data:`BOUND_SHARE` of the limit free for it.

Each stage that ran is one :class:`~sosp.result.Stage` of ``Result.stages`` (``--json``
prints them). Starts and methods share one generator, drawn in stage order, so a seed gives
the same schedule for iteration-limited runs.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sosp.errors import TimeLimitReached
from sosp.parallel import Workers
from sosp.registry import compute_bound, method_function, method_start
from sosp.result import Result, Stage, Status
from sosp.stop import Budget, stop_requested

log = logging.getLogger(__name__)

#: Share of the method's time its start stage may take; the method gets the rest (at least
#: as much), warm-started from the start's schedule.
START_SHARE = 0.5

#: Share of the run's time kept for the certifying bound when one is asked for: the start
#: and the method end by the rest, so the bound cannot push the run past its limit.
BOUND_SHARE = 0.25

#: The start taken when a start method gives no schedule in its share (``orbit-dp`` when its
#: candidates are not ready in time); it answers at any limit.
FALLBACK_START = "asa-dtc"


@dataclass(frozen=True)
class Start:
    """A start stage: ``method`` (registered) run with ``params`` for at most ``seconds``
    (None: :data:`START_SHARE` of the time alone)."""

    method: str = "orbit-dp"
    seconds: float | None = None
    params: Mapping[str, Any] = field(default_factory=dict)


def run_start(
    instance: Any, start: Start, rng: np.random.Generator, budget: Budget
) -> tuple[Result, Stage]:
    """Run ``start`` within :data:`START_SHARE` of ``budget`` (and ``start.seconds``); on
    :class:`~sosp.errors.TimeLimitReached` run :data:`FALLBACK_START` in the same share of
    what is left instead. Returns its result and its stage."""

    def share() -> float | None:
        return budget.child(start.seconds, fraction=START_SHARE).left()

    t0, name = time.perf_counter(), start.method
    try:
        res = method_function(name)(instance, rng=rng, time_limit=share(), **start.params)
    except TimeLimitReached as exc:
        if name == FALLBACK_START:  # pragma: no cover - ASA-DTC answers at any limit
            raise
        log.warning(
            "no %s start in its share (%s); starting from %s",
            name, str(exc).split(";")[0], FALLBACK_START,
        )  # fmt: skip
        name = FALLBACK_START
        res = method_function(name)(instance, rng=rng, time_limit=share())
    return res, Stage("start", name, time.perf_counter() - t0, float(res.profit))


def improve(
    instance: Any,
    method: str,
    func: Callable[..., Result],
    params: Mapping[str, Any],
    rng: np.random.Generator,
    budget: Budget,
    bound: bool = False,
) -> Result:
    """The start stage (when ``method`` takes one with ``params``) and the method itself
    (its function ``func``), within ``budget`` less :data:`BOUND_SHARE` when a ``bound``
    follows."""
    own = budget.share(1.0 - BOUND_SHARE) if bound else budget
    start = method_start(method, instance, params)
    first: Result | None = None
    stages: list[Stage] = []
    params = dict(params)
    if start is not None:
        first, stage = run_start(instance, start, rng, own)
        stages.append(stage)
        params["warm_start"] = first.schedule  # also empty: the start stage ran, once
    t0 = time.perf_counter()
    result = func(instance, rng=rng, time_limit=own.left(), **params)
    ran = result.stages or (
        Stage("method", method, time.perf_counter() - t0, float(result.profit), result.bound),
    )
    result = replace(result, stages=(*stages, *ran))
    if first is not None:
        result.stats = {**result.stats, "start": stages[0].name}  # what ran, not "warm_start"
        if first.profit > result.profit:
            result = _keep_start(result, first)
    if stop_requested() and result.profit <= 0 and method != STOPPED_START:
        result = _stopped_start(instance, result, rng)
    return result


#: The method run when a stop came before the method had any schedule (during its
#: preparation: candidates, its start): one pass, a fraction of a second on 10,000 targets.
STOPPED_START = "greedy"


def _stopped_start(instance: Any, result: Result, rng: np.random.Generator) -> Result:
    """``result``, or :data:`STOPPED_START`'s schedule when it is better: a run stopped
    before its method found a schedule writes one all the same (orbit-dp wrote an empty
    schedule when Ctrl-C came during its preparation)."""
    t0 = time.perf_counter()
    quick = method_function(STOPPED_START)(instance, rng=rng, time_limit=None)
    stage = Stage("start", STOPPED_START, time.perf_counter() - t0, float(quick.profit))
    log.info("stopped before a schedule: %s's, profit %g", STOPPED_START, quick.profit)
    if quick.profit <= result.profit:
        return result
    status = Status.FEASIBLE if result.status is not Status.OPTIMAL else result.status
    stats = {**result.stats, "returned": STOPPED_START}
    return replace(
        result, schedule=quick.schedule, profit=quick.profit, observed=quick.observed,
        status=status, stats=stats, stages=(*result.stages, stage),
    )  # fmt: skip


def _keep_start(result: Result, first: Result) -> Result:
    """``result`` with the start's better schedule (the method lost it or never reached it)."""
    upper = None if result.bound is None else max(result.bound, first.profit)
    status = result.status
    if upper is not None and upper <= first.profit + 1e-6:
        status = Status.OPTIMAL
    elif status in (Status.OPTIMAL, Status.NO_SOLUTION, Status.INFEASIBLE):
        status = Status.FEASIBLE
    stats = {**result.stats, "returned": "start"}
    return replace(
        result, schedule=first.schedule, profit=first.profit, observed=first.observed,
        bound=upper, status=status, stats=stats,
    )  # fmt: skip


def certify(
    instance: Any,
    result: Result,
    bound: str = "auto",
    time_limit: float | None = None,
    workers: Workers = 1,
) -> Result:
    """``result`` with the least of its own bound and bound ``bound`` (within ``time_limit``,
    its pricing rounds on ``workers``): the bound stage.

    The status becomes ``optimal`` when the bound meets the profit (nothing better exists).
    """
    t0 = time.perf_counter()
    out = compute_bound(
        bound, instance, time_limit=time_limit, lower_bound=result.profit, workers=workers
    )
    value = out.get("bound")
    stage = Stage("bound", bound, time.perf_counter() - t0, None, value)
    result = replace(result, stages=(*result.stages, stage))
    if value is None:
        return result
    best = float(value) if result.bound is None else min(float(value), result.bound)
    best = max(best, float(result.profit))
    status = Status.OPTIMAL if best <= result.profit + 1e-6 else result.status
    stats = {**result.stats, "certified_by": bound, "certify_s": out.get("runtime_s")}
    return replace(result, bound=best, status=status, stats=stats)


#: A method's start rule: (the instance, its parameters) -> its :class:`Start`, or None (no
#: start stage). It may refuse the parameters (:class:`~sosp.errors.InputError`) before the
#: start spends any time.
StartRule = Callable[[Any, Mapping[str, Any]], Start | None]
