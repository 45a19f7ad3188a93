"""The one entry point: :func:`solve` runs any registered method on an instance.

Methods are registered by name in :data:`METHODS` as ``"module:function"`` and imported
lazily, so the CLI stays fast and heavy dependencies (Pyomo, HiGHS) load only when used.
A method function has the signature::

    def solve_xxx(instance: Instance, *, rng: numpy.random.Generator,
                  time_limit: float | None, **params) -> Result
"""

from __future__ import annotations

import importlib
import importlib.util
import logging
import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from sosp.errors import InputError, SospError
from sosp.instance import Instance
from sosp.parallel import Workers, check_workers
from sosp.progress import Progress, reporting
from sosp.result import Result, Status
from sosp.schedule import Schedule
from sosp.stop import stop_requested
from sosp.validate import validate

log = logging.getLogger(__name__)

#: Method name -> "module:function". The module is imported on first use.
METHODS: dict[str, str] = {
    "greedy": "heuristics.greedy:solve_greedy",
    "hpfs-stc": "heuristics.hpfs:solve_hpfs_stc",
    "asa-dtc": "heuristics.asa:solve_asa_dtc",
    "asa-stc": "heuristics.asa:solve_asa_stc",
    "asa-nontc": "heuristics.asa:solve_asa_nontc",
    "rds": "heuristics.rds:solve_rds",
    "rds-stc": "heuristics.rds:solve_rds_stc",
    "sa-stc": "heuristics.sa:solve_sa_stc",
    "aco-stc": "heuristics.aco:solve_aco_stc",
    "aco-ls-stc": "heuristics.aco:solve_aco_ls_stc",
    "ga-stc": "heuristics.ga:solve_ga_stc",
    "ts-stc": "heuristics.tabu_search:solve_ts_stc",
    "pba-stc": "heuristics.pba:solve_pba_stc",
    "milp": "models.solve:solve_milp",
    "milp-lns": "heuristics.lns:solve_milp_lns",
    "orbit-dp": "heuristics.orbit_search:solve_orbit_dp",
}

#: Method name -> "module:Class" of the parameter dataclass a method taking ``**params`` builds
#: (with its ``from_kwargs``): ``sosp methods`` lists its fields and
#: :func:`sosp.methods.check_params` validates a parameter set with it before any run starts.
#: Methods with explicit keyword parameters need no entry: their signature says it all.
PARAM_CLASSES: dict[str, str] = {
    "asa-dtc": "heuristics.asa.params:ASAParams",
    "asa-stc": "heuristics.asa.params:ASAParams",
    "asa-nontc": "heuristics.asa.params:ASAParams",
    "milp-lns": "heuristics.lns:LNSParams",
    "orbit-dp": "heuristics.orbit_search:OrbitSearchParams",
    "aco-stc": "heuristics.aco:ACOParams",
    "aco-ls-stc": "heuristics.aco:ACOLSParams",
    "ga-stc": "heuristics.ga:GAParams",
}

#: The method of :func:`solve` and of ``sosp solve`` when none is named.
DEFAULT_METHOD = "asa-dtc"

#: Bound name -> "module:function" (each returns a dict with at least ``bound``), so the core
#: and its CLI reach the models only through this table.
BOUNDS: dict[str, str] = {
    "auto": "models.solve:auto_bound",
    "lp": "models.solve:lp_bound",
    "milp": "models.solve:milp_bound",
    "lagrangian": "models.lagrangian:lagrangian_bound",
    "colgen": "models.solve:colgen_bound",
    "pba": "heuristics.pba:pba_bound",
}


class SolverError(SospError):
    """A solver returned a schedule the validator rejects (a bug, never bad input)."""


def available_methods() -> list[str]:
    """The registered methods whose module is installed."""
    out = []
    for name, target in METHODS.items():
        module = target.split(":")[0]
        try:
            if importlib.util.find_spec(module) is not None:
                out.append(name)
        except ModuleNotFoundError:
            pass
    return out


def method_function(method: str) -> Callable[..., Result]:
    """The function registered for ``method``; :class:`InputError` if unknown."""
    if method not in METHODS:
        raise InputError(
            f"method: unknown method {method!r} (choose from {', '.join(available_methods())})"
        )
    module, func = METHODS[method].split(":")
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            raise InputError(f"method: {method!r} is not available in this build") from None
        raise
    return getattr(mod, func)


def bound_function(name: str) -> Callable[..., dict[str, Any]]:
    """The function registered for bound ``name`` in :data:`BOUNDS`."""
    if name not in BOUNDS:
        raise InputError(f"bound: unknown method {name!r} (choose from {', '.join(BOUNDS)})")
    module, func = BOUNDS[name].split(":")
    return getattr(importlib.import_module(module), func)


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
        A name from :data:`METHODS` (e.g. ``"asa-dtc"``, ``"milp"``, ``"hpfs-stc"``);
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
        Certify the schedule: one of :data:`CERTIFYING_BOUNDS` (bounds of the problem itself,
        the cluster model) computed after the solve, with a time limit of its own equal to
        ``time_limit``; the result's ``bound`` is then the least of the method's and this one,
        ``gap`` how far the schedule may be from optimal, and the status ``optimal`` when the
        bound meets the profit. None (default): the method's own bound only.
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
    rng = np.random.default_rng(int(seed))
    from sosp.planner import kernels_within

    t0 = time.perf_counter()
    if instance.n_opps == 0:
        # nothing can be observed: the empty schedule is optimal, with no search to run (an
        # iterative method would spend its whole limit finding that out) and no kernels to
        # load for one (about a second in a fresh process)
        result = Result(method, Status.OPTIMAL, Schedule(()), 0.0, 0, bound=0.0)
        result.stats["proven_by"] = "cap"
    else:
        deadline = kernels_within(t0, time_limit)  # the kernels' load counts in the limit
        left = None if deadline is None else deadline - time.perf_counter()
        with reporting(progress) as prog:
            prog.start(method)
            result = func(instance, rng=rng, time_limit=left, **params)
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
    if stop_requested() and status in (Status.FEASIBLE, Status.TIME_LIMIT):
        status = Status.INTERRUPTED  # stopped on request: its limits were not reached
    cap = instance.observable_weight
    if status is not Status.OPTIMAL and result.profit >= cap - 1e-6:
        # every target that has an opportunity is observed: no schedule does better,
        # whichever method found this one (and however it was stopped)
        status, upper = Status.OPTIMAL, cap
        stats = {**stats, "proven_by": "cap"}
    result = replace(
        result, method=method, schedule=schedule, runtime_s=runtime, status=status,
        bound=upper, stats=stats,
    )  # fmt: skip
    if check:
        report = validate(instance, schedule)
        if not report.feasible:
            first = report.violations[0]
            raise SolverError(
                f"{method} returned an infeasible schedule ({len(report.violations)} "
                f"violations; first: ({first.constraint}) {first.message})"
            )
    if bound is not None:
        result = certify(instance, result, bound, time_limit, bound_workers)
    log.info("%s: profit %g, %d observed, %.3f s", method, result.profit, result.observed, runtime)
    return result


#: Bounds of :data:`BOUNDS` that bound the problem itself (the cluster model's optimum), so
#: every method's schedule: what :func:`solve`'s ``bound`` accepts.
CERTIFYING_BOUNDS = ("auto", "lp", "lagrangian", "colgen", "milp")


def certify(
    instance: Instance,
    result: Result,
    bound: str = "auto",
    time_limit: float | None = None,
    workers: Workers = 1,
) -> Result:
    """``result`` with the least of its own bound and bound ``bound`` (within ``time_limit``,
    its pricing rounds on ``workers``).

    The status becomes ``optimal`` when the bound meets the profit (nothing better exists).
    """
    out = bound_function(bound)(
        instance, time_limit=time_limit, lower_bound=result.profit, workers=workers
    )
    value = out.get("bound")
    if value is None:
        return result
    best = float(value) if result.bound is None else min(float(value), result.bound)
    best = max(best, float(result.profit))
    status = Status.OPTIMAL if best <= result.profit + 1e-6 else result.status
    stats = {**result.stats, "certified_by": bound, "certify_s": out.get("runtime_s")}
    return replace(result, bound=best, status=status, stats=stats)
