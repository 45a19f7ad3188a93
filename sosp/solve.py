"""The one entry point: :func:`solve` runs any registered method on an instance.

Methods and bounds are registered in :mod:`sosp.registry` and imported lazily, so the CLI
stays fast and heavy dependencies (Pyomo, HiGHS) load only when used. The stages of a run
(a start, the method, a certifying bound) and their shares of the time are
:mod:`sosp.pipeline`'s. A method function has
the signature::

    def solve_xxx(instance: Instance, *, rng: numpy.random.Generator,
                  time_limit: float | None, **params) -> Result
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import replace
from typing import Any

import numpy as np

from sosp.errors import InputError, SospError
from sosp.instance import Instance
from sosp.parallel import Workers, check_workers
from sosp.pipeline import BOUND_SHARE, certify, improve
from sosp.progress import Progress, reporting
from sosp.registry import (
    CERTIFYING_BOUNDS,
    DEFAULT_METHOD,
    PROBLEM_MODEL,
    REFILL,
    bounded_model,
    load,
    method_function,
    plans_downlinks,
    uses_kernels,
)
from sosp.result import Result, Status
from sosp.schedule import Schedule
from sosp.stop import Budget, capped, stop_requested
from sosp.validate import validate

log = logging.getLogger(__name__)

#: Share of a run with stations kept from the method for :data:`~sosp.registry.REFILL`
#: (a fraction of a second on the paper's scenarios; it stops at the limit on larger ones).
REFILL_SHARE = 0.05


class SolverError(SospError):
    """A solver returned a schedule the validator rejects (a bug, never bad input)."""


def check_time_limit(time_limit: Any) -> float | None:
    """Validate a time limit (None, or a finite number of seconds > 0)."""
    if time_limit is None:
        return None
    if isinstance(time_limit, bool) or not isinstance(time_limit, int | float):
        raise InputError(f"time_limit: expected a number of seconds, got {time_limit!r}")
    if not math.isfinite(time_limit) or time_limit <= 0:
        raise InputError(f"time_limit: must be a finite number of seconds > 0, got {time_limit}")
    return float(time_limit)


def solve(
    instance: Instance,
    method: str = DEFAULT_METHOD,
    *,
    seed: int = 0,
    time_limit: float | None = None,
    check: bool = True,
    progress: Progress | None = None,
    bound: str | None = None,
    bound_workers: Workers = 1,
    **params: Any,
) -> Result:
    """Solve ``instance`` with ``method``.

    Parameters
    ----------
    instance
        The problem.
    method
        A name from :data:`sosp.registry.METHODS` (e.g. ``"asa-dtc"``, ``"milp"``, ``"hpfs-stc"``);
        :data:`DEFAULT_METHOD` by default, as on the command line.
    seed
        Seeds the one :class:`numpy.random.Generator` passed down to the method.
    time_limit
        Wall-time limit in seconds from the call, the load of the numba kernels included
        (None: the method's own stopping rule).
    check
        Run the validator on the returned schedule and raise :class:`SolverError` if it
        fails (cheap next to any solve; the validator is the referee).
    progress
        Receives the search's state from its stopping checks (:mod:`sosp.progress`; the
        caller's callback draws it). The searches stop early, with their best schedule so
        far, once :func:`sosp.stop.request_stop` is called (e.g. by a signal handler): the
        status is then ``interrupted`` (unless optimality or infeasibility was proven).
    bound
        Certify the schedule: one of :data:`sosp.registry.CERTIFYING_BOUNDS` (bounds of the
        problem itself, the cluster model) computed after the solve in what is left of
        ``time_limit`` (the start and the method keep :data:`sosp.pipeline.BOUND_SHARE` of it
        free: :mod:`sosp.pipeline`); the result's ``bound`` is then the least of the method's
        and this one, ``gap`` how far the schedule may be from optimal, and the status
        ``optimal`` when the bound meets the profit. None (default): the method's own bound
        only.
    bound_workers
        Processes (or a ``distributed.Client``) for the pricing rounds of that bound
        (``auto``, ``colgen``, ``lagrangian``; :func:`models.solve.bound`'s ``workers``): the
        method has finished, so the machine's cores are free. 1 (default): this process.
    **params
        Method parameters (``sosp methods`` lists them; :func:`sosp.methods.check_params`
        refuses an unknown key with the list of valid ones).

    Returns
    -------
    Result
        With the schedule stamped with method, parameters, seed, profit and the instance's
        fingerprint.
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(f"seed: expected a non-negative integer, got {seed!r}")
    time_limit = check_time_limit(time_limit)
    func = method_function(method)
    if bound is not None and bound not in CERTIFYING_BOUNDS:
        raise InputError(
            f"bound: expected one of {', '.join(CERTIFYING_BOUNDS)} (bounds of the problem), "
            f"got {bound!r}"
        )
    check_workers(bound_workers, "bound_workers")
    from sosp.methods import check_params

    check_params(method, params)
    if instance.stations and not plans_downlinks(method):
        return _with_stations(
            instance, method, seed=seed, time_limit=time_limit, check=check, progress=progress,
            bound=bound, bound_workers=bound_workers, **params,
        )  # fmt: skip
    rng = np.random.default_rng(int(seed))
    from sosp.planner import kernels_within

    t0 = time.perf_counter()
    if instance.n_opps == 0:
        # nothing can be observed: the empty schedule is optimal, with no search to run (an
        # iterative method would spend its whole limit finding that out) and no kernels to
        # load for one (about a second in a fresh process)
        result = Result(method, Status.OPTIMAL, Schedule(()), 0.0, 0, bound=0.0)
        result.stats["proven_by"] = "cap"
        budget = Budget()
    else:
        # the searches stop once every observable target is observed: nothing is left
        with reporting(progress) as prog, capped(instance.observable_weight):
            prog.start(method)
            if uses_kernels(method):  # the kernels' load counts in the limit
                budget = Budget.until(kernels_within(t0, time_limit))
            else:
                budget = Budget.of(time_limit)
            kernels_s = time.perf_counter() - t0
            result = improve(instance, method, func, params, rng, budget, bound is not None)
        # the numba kernels' load (seconds the first time on a machine: their compilation,
        # cached on disk after) is billed to the run's time; the result says how much
        result.stats = {**result.stats, "kernels_s": round(kernels_s, 4)}
    runtime = time.perf_counter() - t0
    schedule = replace(
        result.schedule,
        method=method,
        params=dict(params),
        seed=int(seed),
        profit=float(result.profit),
        fingerprint=instance.fingerprint,
    )
    status, upper, stats = result.status, result.bound, result.stats
    # the method's own bound and optimality may be of a restriction (static, task model),
    # whose optimum can lie below the problem's: the result says which model they are of
    model = bounded_model(method, params)
    restriction = None if model in (None, PROBLEM_MODEL) else model
    cap = instance.observable_weight
    if result.profit >= cap - 1e-6 and (status is not Status.OPTIMAL or restriction):
        # every target that has an opportunity is observed: no schedule does better,
        # whichever method found this one (and however it was stopped)
        status, upper, restriction = Status.OPTIMAL, cap, None
        stats = {**stats, "proven_by": "cap"}
    # a result names the method stage that ran (ASA-DTC's fallback: orbit-dp); the schedule
    # keeps what was asked, which reproduces it
    ran = next((st.name for st in reversed(result.stages) if st.kind == "method"), method)
    result = replace(
        result, method=ran, schedule=schedule, runtime_s=runtime, status=status,
        bound=upper, stats=stats, restriction=restriction,
    )  # fmt: skip
    if check or instance.stations:
        report = validate(instance, schedule)
        if instance.stations:  # a method planning its own downlinks: their measures
            result.stats["downlink"] = report.downlink
        if check and not report.feasible:
            first = report.violations[0]
            raise SolverError(
                f"{method} returned an infeasible schedule ({len(report.violations)} "
                f"violations; first: ({first.constraint}) {first.message})"
            )
    if bound is not None and stop_requested():
        # stopped: the user wants the schedule now, not a bound computed after it (with
        # --bound the bound stage then ran to its own limit, 60 s after a Ctrl-C)
        log.info("stopped: no %s bound computed", bound)
    elif bound is not None:
        if result.restriction is not None:
            # a restriction's bound and optimum may lie below the problem's optimum: they
            # certify nothing, the bound stage alone speaks for the problem
            result = replace(result, bound=None, restriction=None, status=_unproven(result))
        result = certify(instance, result, bound, budget.left(), bound_workers)
    if stop_requested() and result.status in (Status.FEASIBLE, Status.TIME_LIMIT):
        # stopped on request (the method or its bound): its limits were not reached
        result = replace(result, status=Status.INTERRUPTED)
    log.info("%s: profit %g, %d observed, %.3f s", method, result.profit, result.observed, runtime)
    # the file written from the schedule says how the solve ended, and what it proved of the
    # problem (a restriction's optimum or bound is no claim about it)
    if result.restriction is None:
        status_text, upper = result.status.value, result.bound
    else:
        status_text, upper = _unproven(result).value, None
    return replace(result, schedule=replace(result.schedule, status=status_text, bound=upper))


def _unproven(result: Result) -> Status:
    """``result``'s status with a restriction's optimality not taken as the problem's."""
    return Status.FEASIBLE if result.status is Status.OPTIMAL else result.status


def _with_stations(
    instance: Instance,
    method: str,
    *,
    time_limit: float | None,
    check: bool,
    bound: str | None,
    bound_workers: Workers,
    **kwargs: Any,
) -> Result:
    """:func:`solve` on an instance with ground stations (``docs/model.md``, "How the
    methods plan downlinks"): ``method`` plans the observations within the memory
    allowances of :func:`sosp.downlink.search_instance`, :func:`sosp.downlink.deliver` plans
    their downlinks and drops what cannot fly, :data:`~sosp.registry.REFILL` puts back what
    the store, contacts and energy still take, and ``bound`` is computed on
    :func:`sosp.downlink.relaxed_instance`, a relaxation of the problem with stations."""
    from sosp.downlink import deliver, search_instance

    t0 = time.perf_counter()
    budget = Budget.until(None if time_limit is None else t0 + time_limit)
    own = budget.share(1.0 - BOUND_SHARE) if bound is not None else budget
    search, index = search_instance(instance)
    if isinstance(start := kwargs.get("warm_start"), Schedule):  # into the search's indices
        at = {int(i): n for n, i in enumerate(index)}
        obs = [
            replace(o, opps=tuple(at[i] for i in o.opps))
            for o in start.observations
            if all(i in at for i in o.opps)
        ]
        kwargs["warm_start"] = Schedule(tuple(obs))
    inner = solve(
        search, method, time_limit=own.share(1.0 - REFILL_SHARE).left(), check=check, **kwargs
    )
    found = [
        replace(o, opps=tuple(int(index[i]) for i in o.opps)) for o in inner.schedule.observations
    ]
    obs, downlinks = load(REFILL)(instance, found, own, kwargs.get("roll_rule", "nadir"))
    schedule = replace(inner.schedule, observations=obs, downlinks=tuple(downlinks))
    profit, observed = schedule.coverage_profit(instance)
    if isinstance(start, Schedule):  # a start the allowances cut is still never lost
        obs, downlinks = deliver(instance, start.observations)
        kept = replace(schedule, observations=obs, downlinks=tuple(downlinks))
        if (got := kept.coverage_profit(instance))[0] > profit:
            schedule, (profit, observed) = kept, got
    status = _unproven(inner)  # optimal for the allowances, a restriction
    if profit >= instance.observable_weight - 1e-6:
        status = Status.OPTIMAL
    result = replace(
        inner, schedule=replace(schedule, profit=profit, fingerprint=instance.fingerprint),
        profit=profit, observed=observed, status=status, restriction=None,
        bound=instance.observable_weight if status is Status.OPTIMAL else None,
        stats={**inner.stats, "search_profit": inner.profit},
    )  # fmt: skip
    report = validate(instance, result.schedule)  # also the downlinks' measures
    result.stats["downlink"] = report.downlink
    if check:
        if not report.feasible:
            first = report.violations[0]
            raise SolverError(
                f"{method} with stations: infeasible schedule ({len(report.violations)} "
                f"violations; first: ({first.constraint}) {first.message})"
            )
    if bound is not None and not stop_requested():
        left = budget.left()  # the search may overrun its share a little: the bound still runs
        left = None if left is None else max(left, 0.05)
        result = certify(instance, result, bound, left, bound_workers)  # of the relaxation
    if stop_requested() and result.status in (Status.FEASIBLE, Status.TIME_LIMIT):
        result = replace(result, status=Status.INTERRUPTED)
    result = replace(result, runtime_s=time.perf_counter() - t0)
    return replace(
        result,
        schedule=replace(result.schedule, status=result.status.value, bound=result.bound),
    )
