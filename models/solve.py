"""Solve the exact models with HiGHS: :func:`solve_milp` and :func:`bound`.

Two backends build the same model: Pyomo (:mod:`models.formulation`, the reference builder,
solved through APPSI) and arrays passed to highspy directly (:mod:`models.highs_direct`, for
large models, where Pyomo's build and load dominate). ``backend="auto"`` picks by size
(:func:`choose_backend`).

Traps handled here (each has a test):

* a time-limited solve must not raise: solutions are loaded only when HiGHS has one
  (``load_solution=False``, then load if there is an incumbent);
* a solver object keeps its options between solves, so a fresh one is made per solve (no stale
  time limit or gap);
* HiGHS writes to the console by default: its log goes to this module's logger at DEBUG and
  is switched off entirely unless that level is enabled;
* the time limit covers model building too: HiGHS gets what is left of it;
* the bound reported is never below the incumbent and, the weights being integers, is rounded
  down to an integer (the optimum is an integer).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from models.data import ModelData
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.result import Result, Status
from sosp.schedule import Schedule, items_to_schedule
from sosp.solve import check_time_limit

if TYPE_CHECKING:
    import pyomo.environ as pyo

log = logging.getLogger(__name__)

#: Model name -> function preparing its data.
MODELS: dict[str, str] = {
    "task": "models.task:task_data",
    "cluster": "models.cluster:cluster_data",
    "static": "models.static:static_data",
}

#: Slack for reading binaries and comparing objective values.
INT_TOL = 1e-6


def model_data(instance: Instance, model: str = "cluster") -> ModelData:
    """Prepare the data of ``model`` (``"task"``, ``"cluster"`` or ``"static"``)."""
    import importlib

    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"model: expected one of {', '.join(MODELS)}, got {model!r}")
    module, func = MODELS[model].split(":")
    prep: Callable[[Instance], ModelData] = getattr(importlib.import_module(module), func)
    return prep(instance)


def _check_params(mip_gap: Any, threads: Any) -> None:
    if mip_gap is not None and (
        isinstance(mip_gap, bool)
        or not isinstance(mip_gap, int | float)
        or not math.isfinite(mip_gap)
        or not 0 <= mip_gap < 1
    ):
        raise InputError(f"mip_gap: expected a number in [0, 1), got {mip_gap!r}")
    if threads is not None and (
        isinstance(threads, bool) or not isinstance(threads, int | np.integer) or threads < 1
    ):
        raise InputError(f"threads: expected a positive integer, got {threads!r}")


def _solver(time_limit: float | None, mip_gap: float | None, threads: int | None) -> Any:
    """A fresh HiGHS solver (APPSI interface: it takes MIP starts) with only these options."""
    from pyomo.contrib.appsi.solvers import Highs

    opt = Highs()
    opt.config.load_solution = False
    opt.config.stream_solver = False
    opt.config.log_level = logging.DEBUG
    opt.config.solver_output_logger = log
    options: dict[str, Any] = {"output_flag": log.isEnabledFor(logging.DEBUG)}
    if time_limit is not None:
        opt.config.time_limit = float(time_limit)
    if mip_gap is not None:
        opt.config.mip_gap = float(mip_gap)
    if threads is not None:
        options["threads"] = int(threads)
    opt.highs_options = options
    return opt


def _model_size(opt: Any, m: pyo.ConcreteModel) -> dict[str, int]:
    h = getattr(opt, "_solver_model", None)
    if h is not None:
        try:
            return {
                "variables": int(h.getNumCol()),
                "constraints": int(h.getNumRow()),
                "nonzeros": int(h.getNumNz()),
            }
        except AttributeError:  # pragma: no cover - older highspy
            pass
    return {"variables": m.nvariables(), "constraints": m.nconstraints(), "nonzeros": -1}


def warm_start_values(data: ModelData, schedule: Schedule) -> dict[str, dict[int, float]] | None:
    """Values of x (and z, f, l, s, r) reproducing ``schedule`` with the model's items.

    Each observation is mapped to an item on its orbit that covers all its opportunities with a
    window inside the observation's and a roll no farther from nadir (such an item is feasible
    wherever the observation is). Returns None (with a warning) when some observation has no
    such item or the mapped schedule is infeasible.
    """
    from sosp.validate import validate

    inst = data.instance
    by_opp: dict[int, list[int]] = {}
    for u, ops in enumerate(data.opps):
        for i in ops:
            by_opp.setdefault(i, []).append(u)
    chosen: list[int] = []
    for n, ob in enumerate(schedule.observations):
        if not ob.opps or not all(0 <= i < inst.n_opps for i in ob.opps):
            log.warning("warm start ignored: observation %d covers no valid opportunity", n)
            return None
        need = set(ob.opps)
        best, best_cost = None, math.inf
        for u in by_opp.get(ob.opps[0], []):
            if (
                data.orbit[u] == ob.orbit
                and need.issubset(data.opps[u])
                and data.start[u] >= ob.start - INT_TOL
                and data.end[u] <= ob.end + INT_TOL
                and abs(data.roll[u]) <= abs(ob.roll) + INT_TOL
            ):
                cost = (data.end[u] - data.start[u]) + abs(data.roll[u])
                if cost < best_cost:
                    best, best_cost = u, cost
        if best is None:
            log.warning(
                "warm start ignored: observation %d (orbit %s, %d opportunities) is no item "
                "of the %s model",
                n,
                inst.orbit_ids[ob.orbit] if 0 <= ob.orbit < inst.n_orbits else ob.orbit,
                len(ob.opps),
                data.name,
            )
            return None
        chosen.append(best)
    if len(set(chosen)) < len(chosen):
        log.warning("warm start ignored: two observations map to the same item")
        return None
    mapped = items_to_schedule(data.instance, data, chosen)
    if not validate(inst, mapped).feasible:
        log.warning("warm start ignored: the schedule is infeasible")
        return None
    x = dict.fromkeys(range(data.n_items), 0.0)
    for u in chosen:
        x[u] = 1.0
    vals: dict[str, dict[int, float]] = {"x": x}
    if data.coverage:
        vals["z"] = {k: float(any(x[u] for u in us)) for k, us in data.target_items.items()}
    f, l_, s, r = {}, {}, {}, {}
    for j in data.energy_orbits:
        seq = [int(u) for u in data.orbit_items[j]]
        taken = [u for u in seq if x[u]]
        seen = 0.0
        for u in seq:
            seen = max(seen, x[u])
            s[u] = seen
        seen = 0.0
        for u in reversed(seq):
            seen = max(seen, x[u])
            r[u] = seen
        for u in seq:
            f[u] = 1.0 if taken and u == taken[0] else 0.0
            l_[u] = 1.0 if taken and u == taken[-1] else 0.0
    vals.update({"f": f, "l": l_, "s": s, "r": r})
    return vals


def _int_bound(raw: float | None) -> float | None:
    """An upper bound rounded down to an integer (weights are integers), None if unknown."""
    if raw is None or not math.isfinite(float(raw)):
        return None
    return float(math.floor(float(raw) + INT_TOL))


#: Backends of :func:`solve_milp` and :func:`bound`.
BACKENDS = ("auto", "pyomo", "highs")

#: ``backend="auto"`` uses the direct HiGHS backend from this many items on (Pyomo below).
AUTO_HIGHS_ITEMS = 1000


def _check_backend(backend: Any, conflicts: Any) -> None:
    from models.highs_direct import CONFLICT_FORMS

    if backend not in BACKENDS:
        raise InputError(f"backend: expected one of {', '.join(BACKENDS)}, got {backend!r}")
    if conflicts not in CONFLICT_FORMS:
        raise InputError(
            f"conflicts: expected one of {', '.join(CONFLICT_FORMS)}, got {conflicts!r}"
        )


def _check_lp_solver(lp_solver: Any) -> None:
    from models.highs_direct import LP_SOLVERS

    if lp_solver not in LP_SOLVERS:
        raise InputError(f"lp_solver: expected one of {', '.join(LP_SOLVERS)}, got {lp_solver!r}")


def choose_backend(data: ModelData, backend: str = "auto") -> str:
    """``"pyomo"`` or ``"highs"``: ``"auto"`` picks the direct backend for large models.

    Pyomo is the reference builder; below :data:`AUTO_HIGHS_ITEMS` items its build and load
    take well under a second and it stays the default there (the tests' path). From that size
    on, building and loading through Pyomo dominates (C5: 44 s before HiGHS starts), and the
    direct backend, which gives the same optima and LP values, is used.
    """
    if backend != "auto":
        return backend
    return "highs" if data.n_items >= AUTO_HIGHS_ITEMS else "pyomo"


def solve_milp(
    instance: Instance,
    *,
    rng: np.random.Generator | None = None,
    time_limit: float | None = None,
    model: str = "cluster",
    mip_gap: float | None = None,
    threads: int | None = None,
    warm_start: Schedule | None = None,
    relax: bool = False,
    backend: str = "auto",
    conflicts: str = "network",
    lp_solver: str = "choose",
    slew: str = "exact",
    probing: str = "auto",
) -> Result:
    """Solve an exact model of (1)-(6) with HiGHS.

    Parameters
    ----------
    instance
        The problem.
    rng
        Unused (HiGHS is deterministic for fixed options); accepted for the common signature.
    time_limit
        Wall-time limit in seconds for building and solving (None: until optimal).
    model
        ``"cluster"`` (default: clustering-exact, the optimum of the problem), ``"task"``
        (the paper's IP (1)-(6), no clustering) or ``"static"`` (static cluster-tasks).
    mip_gap
        Relative gap at which HiGHS stops (None: HiGHS default, 1e-4, which with integer weights
        below 10^4 total proves optimality).
    threads
        HiGHS threads.
    warm_start
        A schedule mapped to the model's variables as a MIP start (ignored with a warning
        when it does not fit the model or is infeasible).
    relax
        Solve the LP relaxation instead: the result has no schedule, only ``bound``.
    backend
        ``"pyomo"`` (the reference builder, :mod:`models.formulation`, through APPSI),
        ``"highs"`` (the same model as arrays, :mod:`models.highs_direct`) or ``"auto"``
        (default: see :func:`choose_backend`).
    conflicts
        Form of (3) in the direct backend: ``"network"`` (default) or ``"clique"``; the Pyomo
        builder always uses clique rows. Both give the same LP and MILP optima.
    lp_solver
        HiGHS's algorithm for the LP relaxation (``relax=True`` only): ``"choose"`` (HiGHS
        decides), ``"simplex"``, ``"ipm"`` (interior point with crossover; B10's cluster LP:
        17 s against 94 s by dual simplex) or ``"pdlp"``.
    slew
        The slew term of (4): ``"exact"`` or, with ``relax=True`` only, ``"relaxed"`` (one
        row per orbit that over-estimates nothing, see :func:`models.highs_direct.build_arrays`;
        a weaker but much smaller LP; direct backend) or ``"auto"`` (relaxed for an LP that
        ``backend="auto"`` gives the direct backend, else exact). On B10 the relaxed cluster LP
        has the exact LP's value (6188.36) in 1.2 s instead of 15 s; on C10 it is solved in
        52 s where the exact LP is not solved in 400 s.
    probing
        HiGHS's probing in MIP presolve: ``"on"``, ``"off"`` or ``"auto"`` (default: off when
        a time limit is given). Probing checks the clock rarely: on C2's cluster model it ran
        32 s under a 20 s limit (73 s under 60 s) and left no bound; without it the limit holds
        (20.0 s, bound 1207). It does prove some models sooner (B6: 41 s instead of not within
        60 s), so it stays on when there is no limit.

    Returns
    -------
    Result
        ``status`` optimal / time_limit (incumbent) / feasible (stopped at ``mip_gap``) /
        no_solution; ``bound`` the best bound (never below the profit); ``stats`` the model
        size, the number of items (``candidates``), the backend and the solver's own figures.
    """
    del rng
    t0 = time.perf_counter()
    time_limit = check_time_limit(time_limit)
    _check_params(mip_gap, threads)
    _check_backend(backend, conflicts)
    _check_lp_solver(lp_solver)
    if probing not in ("auto", "on", "off"):
        raise InputError(f"probing: expected one of auto, on, off, got {probing!r}")
    use_probing = probing == "on" or (probing == "auto" and time_limit is None)
    if slew not in ("exact", "relaxed", "auto"):  # "conservative" is for milp-lns only
        raise InputError(f"slew: expected one of exact, relaxed, auto, got {slew!r}")
    if slew == "relaxed" and not relax:
        raise InputError("slew: 'relaxed' gives bounds only (the LP relaxation), not schedules")
    if slew == "relaxed" and backend == "pyomo":
        raise InputError("slew: 'relaxed' is built by the direct backend (backend highs or auto)")
    if warm_start is not None and not isinstance(warm_start, Schedule):
        raise InputError("warm_start: expected a Schedule")
    data = model_data(instance, model)
    if slew == "auto":  # the small relaxed LP where the direct backend is chosen anyway
        slew = "relaxed" if relax and choose_backend(data, backend) == "highs" else "exact"
    backend = "highs" if slew == "relaxed" else choose_backend(data, backend)
    stats: dict[str, Any] = {
        "model": model,
        "relax": bool(relax),
        "backend": backend,
        "candidates": data.n_items,
        "cliques": data.n_events,
    }
    if backend == "highs":
        stats["conflicts"] = conflicts
    if not relax:
        stats["probing"] = use_probing
    method = "milp"
    empty = Schedule(())
    if data.n_items == 0:
        stats.update({"build_s": round(time.perf_counter() - t0, 6)})
        stats.update({"variables": 0, "constraints": 0, "nonzeros": 0})
        return Result(
            method, Status.OPTIMAL, empty, 0.0, 0, time.perf_counter() - t0, 0.0, None, stats
        )
    if backend == "highs":
        kind, incumbent, raw_bound, chosen = _run_direct(
            data,
            t0,
            time_limit,
            mip_gap,
            threads,
            warm_start,
            relax,
            conflicts,
            lp_solver,
            slew,
            use_probing,
            stats,
        )
    else:
        kind, incumbent, raw_bound, chosen = _run_pyomo(
            data, t0, time_limit, mip_gap, threads, warm_start, relax, lp_solver, use_probing, stats
        )
    runtime = time.perf_counter() - t0

    if relax:
        bound = None
        if kind == "optimal" and incumbent is not None:
            stats["lp_bound"] = float(incumbent)
            bound = _int_bound(incumbent)
        return Result(method, Status.NO_SOLUTION, empty, 0.0, 0, runtime, bound, None, stats)

    if kind == "infeasible":  # cannot happen (the empty schedule is feasible) but map it
        return Result(method, Status.INFEASIBLE, empty, 0.0, 0, runtime, None, None, stats)
    if incumbent is None or chosen is None or kind not in ("optimal", "time_limit"):
        if kind != "time_limit":
            log.warning("HiGHS stopped with %s and no solution", stats.get("termination"))
        bound = _int_bound(raw_bound)
        return Result(method, Status.NO_SOLUTION, empty, 0.0, 0, runtime, bound, None, stats)

    schedule = items_to_schedule(data.instance, data, chosen)
    profit, observed = schedule.coverage_profit(instance)
    if abs(profit - float(incumbent)) > 1e-4:
        log.warning("schedule profit %g differs from the model's objective %g", profit, incumbent)
    ib = _int_bound(raw_bound)
    bound: float | None = max(ib, profit) if ib is not None else None
    if kind == "optimal" and (bound is None or bound <= profit + INT_TOL):
        status = Status.OPTIMAL
        bound = profit
    elif kind == "optimal":
        status = Status.FEASIBLE  # stopped at the requested gap
        stats["stopped_at"] = "mip_gap"
    else:
        # stopped before HiGHS had a finite bound (e.g. during the root LP): no bound, not
        # the incumbent (which would claim a zero gap)
        status = Status.TIME_LIMIT
    stats["objective"] = float(incumbent)
    stats["raw_bound"] = None if raw_bound is None else float(raw_bound)
    return Result(method, status, schedule, profit, observed, runtime, bound, None, stats)


_Outcome = tuple[str, float | None, float | None, list[int] | None]


def _run_direct(
    data: ModelData,
    t0: float,
    time_limit: float | None,
    mip_gap: float | None,
    threads: int | None,
    warm_start: Schedule | None,
    relax: bool,
    conflicts: str,
    lp_solver: str,
    slew: str,
    probing: bool,
    stats: dict[str, Any],
) -> _Outcome:
    """Build ``data`` as arrays and solve it with highspy (:mod:`models.highs_direct`)."""
    from models.highs_direct import build_arrays, run_highs, start_vector

    t1 = time.perf_counter()
    am = build_arrays(data, relax=bool(relax), conflicts=conflicts, slew=slew)
    stats["slew"] = slew
    stats["build_s"] = round(time.perf_counter() - t0, 6)  # items + arrays, as for Pyomo
    stats["arrays_s"] = round(time.perf_counter() - t1, 6)
    stats.update({"variables": am.n_cols, "constraints": am.n_rows, "nonzeros": int(am.matrix.nnz)})
    start = None
    if warm_start is not None and not relax:
        vals = warm_start_values(data, warm_start)
        stats["warm_start"] = vals is not None
        if vals is not None:
            start = start_vector(am, vals)
    deadline = None if time_limit is None else t0 + time_limit
    out = run_highs(
        am,
        deadline=deadline,
        mip_gap=mip_gap,
        threads=threads,
        start=start,
        lp_solver=None if lp_solver == "choose" else lp_solver,
        probing=probing,
    )
    stats["load_s"] = round(out.load_s, 6)
    stats["solve_s"] = round(out.solve_s, 6)
    stats["termination"] = out.model_status
    stats.update(out.info)
    chosen = None if out.x is None else [int(u) for u in np.flatnonzero(out.x > 0.5)]
    return out.status, out.objective, out.bound, chosen


def _run_pyomo(
    data: ModelData,
    t0: float,
    time_limit: float | None,
    mip_gap: float | None,
    threads: int | None,
    warm_start: Schedule | None,
    relax: bool,
    lp_solver: str,
    probing: bool,
    stats: dict[str, Any],
) -> _Outcome:
    """Build ``data`` with the reference Pyomo builder and solve it through APPSI."""
    from models.formulation import build_model

    m = build_model(data, relax=bool(relax))
    build_s = time.perf_counter() - t0
    stats["build_s"] = round(build_s, 6)
    opt = _solver(None, mip_gap, threads)
    if relax and lp_solver != "choose":
        opt.highs_options = {**opt.highs_options, "solver": lp_solver}
    if not relax and not probing:
        from models.highs_direct import PROBING_OFF

        opt.highs_options = {**opt.highs_options, "presolve_rule_off": PROBING_OFF}
    # Loading the model into HiGHS takes seconds on large models: do it first, then give
    # HiGHS only what is left of the limit, and skip APPSI's change detection at solve time.
    opt.set_instance(m)
    for flag in (
        "check_for_new_or_removed_constraints",
        "check_for_new_or_removed_vars",
        "check_for_new_or_removed_params",
        "check_for_new_objective",
        "update_constraints",
        "update_vars",
        "update_params",
        "update_named_expressions",
        "update_objective",
    ):
        if hasattr(opt.update_config, flag):
            setattr(opt.update_config, flag, False)
    stats["load_s"] = round(time.perf_counter() - t0 - build_s, 6)
    if time_limit is not None:
        opt.config.time_limit = max(time_limit - (time.perf_counter() - t0), 0.01)
    if warm_start is not None and not relax:
        vals = warm_start_values(data, warm_start)
        if vals is not None:
            for name, values in vals.items():
                var = getattr(m, name)
                for key, val in values.items():
                    var[key].set_value(val)
            opt.config.warmstart = True
            stats["warm_start"] = True
        else:
            stats["warm_start"] = False
    from pyomo.contrib.appsi.base import TerminationCondition as TC

    from models.highs_direct import use_threads

    use_threads(threads)
    res = opt.solve(m)
    stats.update(_model_size(opt, m))
    tc = res.termination_condition
    stats["termination"] = tc.name
    stats["solve_s"] = round(time.perf_counter() - t0 - build_s - stats["load_s"], 6)
    if tc == TC.optimal:
        kind = "optimal"
    elif tc in (TC.maxTimeLimit, TC.maxIterations, TC.interrupted):
        kind = "time_limit"
    elif tc == TC.infeasible:
        kind = "infeasible"
    else:
        kind = "other"
    incumbent = res.best_feasible_objective
    chosen = None
    if incumbent is not None and not relax and kind in ("optimal", "time_limit"):
        res.solution_loader.load_vars()
        chosen = [int(u) for u in m.U if (m.x[u].value or 0.0) > 0.5]
    return kind, incumbent, res.best_objective_bound, chosen


def bound(
    instance: Instance,
    model: str = "cluster",
    method: str = "lp",
    time_limit: float | None = None,
    threads: int | None = None,
    backend: str = "auto",
    conflicts: str = "network",
    lp_solver: str = "ipm",
    slew: str = "auto",
) -> dict[str, Any]:
    """An upper bound on the optimum of ``model``.

    Parameters
    ----------
    instance
        The problem.
    model
        ``"cluster"`` (bounds the problem and so every heuristic), ``"task"`` or ``"static"``.
    method
        ``"lp"``: the clique-strengthened LP relaxation (cliques of (3), exact slew term of
        (4)); ``"milp"``: HiGHS's best bound after a (time-limited) MILP solve.
    time_limit
        Seconds (None: no limit).
    threads
        HiGHS threads.
    backend, conflicts
        As for :func:`solve_milp`.
    lp_solver
        HiGHS's LP algorithm for ``method="lp"`` (default ``"ipm"``: interior point with
        crossover, several times faster than simplex on the large cluster LPs).
    slew
        ``"auto"`` (default), ``"exact"`` or ``"relaxed"`` (``method="lp"``; the MILP
        bound always uses the exact term): see :func:`solve_milp`.

    Returns
    -------
    dict
        ``bound``, ``method``, ``model``, ``runtime_s``, the model size, and for ``"milp"``
        the incumbent ``profit``, ``status`` and ``gap``.
    """
    if method not in ("lp", "milp"):
        raise InputError(f"method: expected 'lp' or 'milp', got {method!r}")
    res = solve_milp(
        instance,
        time_limit=time_limit,
        model=model,
        threads=threads,
        relax=(method == "lp"),
        backend=backend,
        conflicts=conflicts,
        lp_solver=lp_solver,
        slew=slew if method == "lp" else "exact",
    )
    out: dict[str, Any] = {
        "bound": res.bound,
        "method": method,
        "model": model,
        "runtime_s": round(res.runtime_s, 6),
    }
    keys = ("candidates", "cliques", "variables", "constraints", "nonzeros", "termination")
    for key in (*keys, "backend", "build_s", "load_s", "solve_s"):
        if key in res.stats:
            out[key] = res.stats[key]
    if method == "lp":
        out["lp_value"] = res.stats.get("lp_bound")
        out["lp_solver"] = lp_solver
        out["slew"] = res.stats.get("slew", "exact")
    else:
        out.update({"profit": res.profit, "status": res.status.value, "gap": res.gap})
    return out
