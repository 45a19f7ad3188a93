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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import numpy as np

from models.data import ModelData, TimeUp, fits
from sosp.candidates import OppGroups
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.parallel import check_workers
from sosp.params import Params, param
from sosp.registry import BOUNDS, PROBLEM_MODEL, load
from sosp.result import Result, Status
from sosp.rules import orbit_rules
from sosp.schedule import Schedule, items_to_schedule
from sosp.solve import check_time_limit
from sosp.stop import Budget, stop_requested

if TYPE_CHECKING:
    from models.colgen import SideBound
    from models.formulation import Block
    from sosp.parallel import Workers
    from sosp.planner import OrbitData

log = logging.getLogger(__name__)

#: Model name -> function preparing its data.
MODELS: dict[str, str] = {
    "task": "models.task:task_data",
    "cluster": "models.cluster:cluster_data",
    "static": "models.static:static_data",
}

#: Slack for reading binaries and comparing objective values.
INT_TOL = 1e-6


def model_data(
    instance: Instance,
    model: str = "cluster",
    deadline: float | None = None,
    generate_by: float | None = None,
) -> ModelData:
    """Prepare the data of ``model`` (``"task"``, ``"cluster"`` or ``"static"``).

    With a ``deadline`` (a :func:`time.perf_counter` value) the cluster model's candidate
    generation stops when it passes (or ``generate_by``, when given and earlier), raising
    :class:`TimeUp`.
    """
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"model: expected one of {', '.join(MODELS)}, got {model!r}")
    prep: Callable[..., ModelData] = load(MODELS[model])
    if model != "cluster" or deadline is None:
        return prep(instance)
    try:
        return prep(instance, deadline=deadline, generate_by=generate_by)
    except TimeLimitReached:
        raise TimeUp("candidate generation") from None


def start_items(data: ModelData, schedule: Schedule) -> list[int] | None:
    """The model's items reproducing ``schedule`` (None, with a warning, when it cannot).

    Each observation is mapped to an item on its orbit that covers all its opportunities with a
    window inside the observation's and a roll no farther from nadir (such an item is feasible
    wherever the observation is). None when some observation has no such item, two map to the
    same item, or the mapped schedule is infeasible.
    """
    from sosp.validate import validate

    inst = data.instance
    # the items covering each observation's first opportunity, in item order (by arrays: a
    # loop over every item's opportunities took 0.3 s on C10, uninterruptible)
    groups = OppGroups.from_groups(data.opps)
    firsts = [ob.opps[0] for ob in schedule.observations if ob.opps]
    at = np.flatnonzero(np.isin(groups.flat, firsts))
    items = np.searchsorted(groups.ptr, at, side="right") - 1
    by_opp: dict[int, list[int]] = {}
    for i, u in zip(groups.flat[at].tolist(), items.tolist(), strict=True):
        by_opp.setdefault(i, []).append(u)
    chosen: list[int] = []
    for n, ob in enumerate(schedule.observations):
        if not ob.opps or not all(0 <= i < inst.n_opps for i in ob.opps):
            log.warning("warm start ignored: observation %d covers no valid opportunity", n)
            return None
        need = set(ob.opps)
        fit = [
            u
            for u in by_opp.get(ob.opps[0], [])
            if data.orbit[u] == ob.orbit
            and need.issubset(data.opps[u])
            and data.start[u] >= ob.start - INT_TOL
            and data.end[u] <= ob.end + INT_TOL
            and abs(data.roll[u]) <= abs(ob.roll) + INT_TOL
        ]
        # the first of the least cost: the shortest window, the roll nearest nadir
        best = min(fit, key=lambda u: data.end[u] - data.start[u] + abs(data.roll[u]), default=None)
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
    return chosen


def warm_start_values(data: ModelData, schedule: Schedule) -> dict[str, dict[int, float]] | None:
    """Values of x (and z, f, l, s, r) reproducing ``schedule`` with the model's items.

    See :func:`start_items` (None, with a warning, when the schedule does not map).
    """
    chosen = start_items(data, schedule)
    return None if chosen is None else item_values(data, chosen)


def item_values(data: ModelData, chosen: list[int]) -> dict[str, dict[int, float]]:
    """Values of x, z and the slew-order variables f, l, s, r when ``chosen`` are scheduled."""
    taken = set(chosen)
    x = {u: 1.0 if u in taken else 0.0 for u in range(data.n_items)}
    vals: dict[str, dict[int, float]] = {"x": x}
    if data.coverage:
        vals["z"] = {k: float(any(x[u] for u in us)) for k, us in data.target_items.items()}
    f, l_, s, r = {}, {}, {}, {}
    for j in data.energy_orbits:
        seq = [int(u) for u in data.orbit_items[j]]
        xs = np.array([x[u] for u in seq])
        pre, suf = np.maximum.accumulate(xs), np.maximum.accumulate(xs[::-1])[::-1]
        # the first taken item is where the prefix turns 1, the last where the suffix ends
        firsts, lasts = pre - np.r_[0.0, pre[:-1]], suf - np.r_[suf[1:], 0.0]
        for out, col in ((s, pre), (r, suf), (f, firsts), (l_, lasts)):
            out.update(zip(seq, col.tolist(), strict=True))
    vals.update({"f": f, "l": l_, "s": s, "r": r})
    return vals


#: From this many items on, the MILP rarely proves the optimum in minutes and its answer is
#: its start or a few units above.
LARGE_MODEL_ITEMS = 20_000

#: On models of :data:`LARGE_MODEL_ITEMS` or more, HiGHS gives way when, after this share of
#: the MILP's time, its incumbent is still its start and its bound has not passed below the
#: side branch and price's (which then has not yielded): the search goes on from the start
#: for the rest of the time, beside the side process (:func:`_search_on`).
GIVE_WAY_SHARE = 0.2

#: Share of ``time_limit`` for the bound :func:`solve_milp` computes before the MILP (it
#: stops sooner when it meets the warm start: then no MILP is needed).
EXTRA_BOUND_SHARE = 0.1

#: What :func:`solve_milp` computes besides HiGHS's dual bound (``extra_bound``).
ExtraBound = Literal["colgen", "lagrangian", "lp", "none"]


@dataclass(frozen=True)
class MILPParams(Params):
    """Parameters of :func:`solve_milp` (the steps they steer are in its docstring); built by
    :func:`solve_milp` and :func:`bound` to check their arguments."""

    model: str = param("cluster", "'cluster' (the problem), 'task' or 'static'.")
    mip_gap: float | None = param(None, "Relative gap at which HiGHS stops (None: 1e-4).")
    threads: int | None = param(None, "HiGHS threads (None: HiGHS's default).")
    warm_start: Schedule | str | None = param(
        "auto", "'auto' (the start stage orbit-dp, at most half the time), 'none' or a schedule."
    )
    extra_bound: ExtraBound = param("colgen", "Bound computed before the MILP.")
    relax: bool = param(False, "Solve the LP relaxation instead (no schedule).")
    backend: Literal["auto", "pyomo", "highs"] = param("auto", "'pyomo', 'highs' or 'auto'.")
    conflicts: Literal["network", "clique"] = param("network", "Form of (3) in the direct backend.")
    lp_solver: Literal["choose", "simplex", "ipm", "pdlp"] = param("choose", "HiGHS LP algorithm.")
    slew: Literal["exact", "lazy", "relaxed", "auto"] | None = param(
        None, "Slew term of (4): 'exact', 'lazy', 'auto' or 'relaxed'."
    )
    probing: Literal["auto", "on", "off"] = param("auto", "HiGHS probing in presolve.")

    def check(self) -> None:
        gap, threads, start = self.mip_gap, self.threads, self.warm_start
        if gap is not None and not (math.isfinite(gap) and 0 <= gap < 1):
            raise InputError(f"mip_gap: expected a number in [0, 1), got {gap!r}")
        if threads is not None and threads < 1:
            raise InputError(f"threads: expected a positive integer, got {threads!r}")
        if start not in ("auto", "none", None) and not isinstance(start, Schedule):
            raise InputError(f"warm_start: expected 'auto', 'none' or a schedule, got {start!r}")
        if self.slew == "lazy" and self.relax:
            raise InputError("slew: 'lazy' is for MILP solves (an LP takes relaxed or exact)")
        if self.slew == "relaxed" and not self.relax:
            raise InputError("slew: 'relaxed' gives bounds only (the LP relaxation), not schedules")
        if self.slew == "relaxed" and self.backend == "pyomo":
            raise InputError(
                "slew: 'relaxed' is built by the direct backend (backend highs or auto)"
            )


def start_stage(instance: Instance, params: Mapping[str, Any]) -> Any:
    """The start stage of ``milp`` with ``params`` (:data:`sosp.pipeline.StartRule`):
    ``orbit-dp`` for ``warm_start="auto"`` (the default) on the problem's model, until 200
    steps in a row bring nothing (where the MILP proves the optimum in seconds, the start
    should not take half the time); None for a given schedule, ``"none"``, the LP
    relaxation, a restricted model (whose bound can lie below a start's profit, so that
    start could not be kept beside it) or an instance with stations
    (:func:`_solve_with_stations` takes its own)."""
    from sosp.pipeline import Start

    if getattr(instance, "stations", ()):  # its own start, planned with the stations
        # (None: the method's start in general, as `sosp methods` asks)
        return None
    auto = params.get("warm_start", MILPParams.warm_start) == "auto"
    cluster = params.get("model", MILPParams.model) == "cluster"
    if not auto or not cluster or params.get("relax"):
        return None
    return Start("orbit-dp", params={"no_improve": 200})


def _int_bound(raw: float | None) -> float | None:
    """An upper bound rounded down to an integer (weights are integers), None if unknown."""
    if raw is None or not math.isfinite(float(raw)):
        return None
    return float(math.floor(float(raw) + INT_TOL))


#: ``backend="auto"`` uses the direct HiGHS backend from this many items on (Pyomo below).
AUTO_HIGHS_ITEMS = 1000


def choose_backend(data: ModelData, backend: str = "auto") -> str:
    """``"pyomo"`` or ``"highs"``: ``"auto"`` picks the direct backend for large models.

    Pyomo is the reference builder; below :data:`AUTO_HIGHS_ITEMS` items its build and load
    take well under a second and it stays the default there (the tests' path). From that size
    on, building and loading through Pyomo dominates the time, and the direct backend, which
    gives the same optima and LP values, is used.
    """
    if backend != "auto":
        return backend
    return "highs" if data.n_items >= AUTO_HIGHS_ITEMS else "pyomo"


def solve_milp(
    instance: Instance,
    *,
    rng: np.random.Generator | None = None,
    time_limit: float | None = None,
    model: str = MILPParams.model,
    mip_gap: float | None = MILPParams.mip_gap,
    threads: int | None = MILPParams.threads,
    warm_start: Schedule | str | None = MILPParams.warm_start,
    extra_bound: ExtraBound = MILPParams.extra_bound,
    relax: bool = MILPParams.relax,
    backend: str = MILPParams.backend,
    conflicts: str = MILPParams.conflicts,
    lp_solver: str = MILPParams.lp_solver,
    slew: str | None = MILPParams.slew,
    probing: str = MILPParams.probing,
) -> Result:
    """Solve an exact model of (1)-(6) with HiGHS.

    Steps (each within ``time_limit``, model building included: the deadline is checked
    between the steps and while the cluster model's candidates are generated, and HiGHS gets
    only what is left):

    0. with ``warm_start="auto"`` on the cluster model, the start stage (:func:`start_stage`:
       ``orbit-dp`` in at most half the limit) runs first, through
       :func:`sosp.pipeline.improve` as under :func:`sosp.solve.solve`, and its schedule is
       the warm start of the steps below;
    1. the model's items (:func:`model_data`);
    2. the warm start mapped to the model's items (:func:`start_items`);
    3. an upper bound besides HiGHS's own (``extra_bound``: column generation then branch
       and price over the model's items, at most :data:`EXTRA_BOUND_SHARE` of the limit);
       when it meets the warm start, the start is optimal and no MILP is built;
    4. the MILP, started from the warm start; with ``extra_bound="colgen"`` and a second
       core, the branch and price goes on beside it in a child process
       (:class:`models.colgen.SideBound`); it stops the MILP when its bound proves the MILP's
       incumbent, and leaves its core to HiGHS's threads once the MILP's dual bound is below
       its own. The bound before the MILP is then the column generation's root alone: the
       branching is the side's.

    The schedule returned is never worse than the warm start, and the bound is the least of
    HiGHS's dual bound, the extra bound and the total weight of the targets the model's items
    cover (never below the profit). When the model's items are not ready by the deadline,
    the schedule is the warm start (when the validator accepts it) and the bound the
    observable weight.

    Parameters
    ----------
    instance
        The problem.
    rng
        The generator of the start stage and the search (HiGHS itself is deterministic for
        fixed options); None: ``default_rng(0)``.
    time_limit
        Wall-time limit in seconds for everything (None: until optimal).
    model
        ``"cluster"`` (default: clustering-exact, the optimum of the problem), ``"task"``
        (the paper's IP (1)-(6), no clustering) or ``"static"`` (static cluster-tasks).
    mip_gap
        Relative gap at which HiGHS stops (None: HiGHS default, 1e-4, which with integer weights
        below 10^4 total proves optimality).
    threads
        HiGHS threads (None: HiGHS's default; HiGHS 1.16 then runs one MIP search worker per
        core).
    warm_start
        ``"auto"`` (default): the start stage of :func:`start_stage` (none on a restricted
        model or the LP relaxation); ``"none"`` (or None): no start; or a schedule (searched
        on from when HiGHS cannot run), mapped to the model's variables (ignored with a
        warning when it does not fit the model or is infeasible).
    extra_bound
        ``"colgen"`` (default: :func:`models.colgen.colgen_bound` over the model's items,
        then its branch and price for the rest of the share; a schedule it ends on replaces
        the warm start when better), ``"lagrangian"``
        (:func:`models.lagrangian.lagrangian_bound`, subgradient steps), ``"lp"`` (the LP
        relaxation with the relaxed slew row, direct backend) or ``"none"``. Each bounds the
        MILP's optimum, also when HiGHS stops before its root LP.
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
        decides), ``"simplex"``, ``"ipm"`` (interior point with crossover) or ``"pdlp"``.
    slew
        The slew term of (4): ``"exact"``; ``"lazy"`` (MILP, direct backend; the exact term
        added only on the orbits where a solution breaks (4), see :func:`_run_lazy`; exact
        with the Pyomo backend); ``"auto"`` (lazy for a MILP; for an LP, relaxed where the
        direct backend is chosen, else exact); None (default): lazy for a MILP, exact for an
        LP; or, with ``relax=True`` only, ``"relaxed"`` (one row per orbit that
        over-estimates nothing, see :func:`models.highs_direct.build_arrays`; a weaker but
        much smaller LP; direct backend).
    probing
        HiGHS's probing in MIP presolve: ``"on"``, ``"off"`` or ``"auto"`` (default: off when
        a time limit is given; it checks the clock rarely and can run far past the limit).

    Returns
    -------
    Result
        ``status`` optimal (the bound meets the profit) / time_limit / feasible (stopped at
        ``mip_gap``) / no_solution (LP relaxation: no schedule); ``bound`` the best bound
        (never below the profit); ``stats`` the model size, the number of items
        (``candidates``), the backend, the warm start's and the extra bound's figures;
        with a start stage, ``stages`` and ``stats["start"]`` (:func:`sosp.pipeline.improve`).
    """
    t0 = time.perf_counter()
    time_limit = check_time_limit(time_limit)
    params = {
        "model": model, "mip_gap": mip_gap, "threads": threads, "warm_start": warm_start,
        "extra_bound": extra_bound, "relax": relax, "backend": backend, "conflicts": conflicts,
        "lp_solver": lp_solver, "slew": slew, "probing": probing,
    }  # fmt: skip
    MILPParams(**params)
    use_probing = probing == "on" or (probing == "auto" and time_limit is None)
    warm_start = "none" if warm_start is None else warm_start
    rng = np.random.default_rng(0) if rng is None else rng
    if instance.stations and relax:  # a bound: of the relaxation without them (docs/model.md)
        from sosp.downlink import relaxed_instance

        instance = relaxed_instance(instance)
    elif instance.stations:  # the model with downlinks (docs/exact.md)
        params["warm_start"] = warm_start
        return _solve_with_stations(instance, rng=rng, time_limit=time_limit, params=params)
    if start_stage(instance, params) is not None:  # called directly: the pipeline's start
        from sosp.pipeline import improve

        return improve(instance, "milp", solve_milp, params, rng, Budget.of(time_limit))
    budget = Budget.until(None if time_limit is None else t0 + time_limit)
    deadline = budget.deadline
    method = "milp"
    empty = Schedule(())
    stats: dict[str, Any] = {"model": model, "relax": bool(relax)}
    # candidates not ready by half the limit leave the warm start as the answer (a large
    # instance could spend the whole limit generating them); ready by then, the model goes
    # on with the whole limit
    generate_by = None if deadline is None else t0 + MODEL_SHARE * time_limit
    try:
        data = model_data(instance, model, deadline, generate_by=generate_by)
    except TimeUp:
        return _no_model(instance, warm_start, relax, stats, t0)
    cap = data.covered_weight()
    if slew in (None, "auto") and not relax:
        slew = "lazy"  # proves more (docs/exact.md, "The lazy slew term")
    elif slew in (None, "auto"):  # auto: the small relaxed LP where the direct backend is chosen
        slew = "relaxed" if slew and choose_backend(data, backend) == "highs" else "exact"
    backend = "highs" if slew == "relaxed" else choose_backend(data, backend)
    if slew == "lazy" and backend == "pyomo":
        slew = "exact"  # the reference builder has the exact term only
    stats.update(backend=backend, candidates=data.n_items, cliques=data.n_events, cap=cap)
    if backend == "highs":
        stats["conflicts"] = conflicts
    if not relax:
        stats["probing"] = use_probing
    if data.n_items == 0:
        stats["build_s"] = round(time.perf_counter() - t0, 6)
        stats.update({"variables": 0, "constraints": 0, "nonzeros": 0})
        status = Status.NO_SOLUTION if relax else Status.OPTIMAL
        return Result(method, status, empty, 0.0, 0, time.perf_counter() - t0, 0.0, None, stats)

    # (the LP ignores the MIP's options: its gap and probing)
    run = _Run(data, t0, mip_gap, threads, conflicts, lp_solver, slew, use_probing, backend, stats)
    if relax:
        kind, incumbent, _, _ = _solve(run, deadline, None, True)
        bound = None
        if kind == "optimal" and incumbent is not None:
            stats["lp_bound"] = float(incumbent)
            bound = min(_int_bound(incumbent) or 0.0, cap)
        runtime = time.perf_counter() - t0
        return Result(method, Status.NO_SOLUTION, empty, 0.0, 0, runtime, bound, None, stats)

    # ---- warm start (never worse than it) and a bound besides HiGHS's
    start: list[int] | None = None
    arranged = None  # the items arranged per orbit for the planner (warm start, Lagrangian)
    if (warm_start != "none" or extra_bound in ("colgen", "lagrangian")) and fits(
        "arrange", data.n_items, deadline
    ):
        from sosp.planner import with_rolls

        arranged = with_rolls(data, data.roll)
    if stop_requested():  # during the arranging: the MILP will not run
        return _no_model(instance, warm_start, relax, stats, t0)
    if isinstance(warm_start, Schedule):
        start = start_items(data, warm_start)
        stats["warm_start"] = start is not None
    start_profit = 0.0
    if start is not None:
        start_profit = items_to_schedule(instance, data, start).coverage_profit(instance)[0]
        stats.update(start_profit=float(start_profit), start_s=round(time.perf_counter() - t0, 6))
    upper = cap
    if extra_bound != "none" and start_profit < cap and (arranged or extra_bound == "lp"):
        # the branching is left to the side process when one will run: it starts its own
        # column generation anyway, and the share is worth more to the MILP
        share = budget.child(None if time_limit is None else EXTRA_BOUND_SHARE * time_limit)
        side_next = _side_possible(extra_bound, arranged, budget, share.left() or 0.0)
        extra, found = _extra_bound(
            data, extra_bound, start_profit, share, threads, arranged, branch=not side_next
        )
        if extra is not None:
            stats["extra_bound"] = extra
            upper = min(upper, extra)
        start, start_profit = _adopt(data, found, start, start_profit, stats)
        stats["extra_bound_s"] = round(time.perf_counter() - t0, 6)

    kind, incumbent, raw_bound, chosen = "not_run", None, None, None
    if start_profit >= upper - INT_TOL:
        stats["proven_by"] = "extra_bound" if upper < cap else "cap"
    elif budget.expired():
        stats["timed_out"] = "before the MILP"
    else:
        # when the last stage must end: HiGHS overruns its limit a little and the solution is
        # read back after it, so a reserve is kept (5 % of the limit, at most 0.5 s)
        solve_by = None if deadline is None else deadline - min(0.5, 0.05 * time_limit)
        by = Budget.until(solve_by)
        from models.highs_direct import watching_bound

        # a models.colgen.SideBound beside the MILP until solve_by (where _side_possible); it
        # yields its core to the MILP once the MILP's bound is below its own
        side: SideBound | None = None
        if _side_possible(extra_bound, arranged, by):
            from models.colgen import SideBound

            lower = start_profit if start_profit > 0 else None
            side = SideBound(data.instance, arranged, by.left(), lower)
        watch = None if side is None else side.watch
        give: _GiveWay | None = None
        if side is not None and warm_start != "none" and data.n_items >= LARGE_MODEL_ITEMS:
            watch = give = _GiveWay(side, start_profit, by)
        try:
            with watching_bound(watch):
                kind, incumbent, raw_bound, chosen = _solve(run, solve_by, start, False)
            gave_way = give is not None and give.gave_at is not None
            if gave_way:
                stats["gave_way_s"] = round(give.gave_at - t0, 3)
            # HiGHS did not run (its model would not be built, or presolved, in time), or it
            # gave way to the search
            idle = stats.get("timed_out") == "building" or stats.get("termination") == "not started"
            idle = (idle and raw_bound is None) or gave_way
            if idle and warm_start != "none" and arranged is not None:
                start, start_profit = _search_on(
                    data, rng, arranged, start, start_profit, by, stats, side
                )
        finally:
            if side is not None:
                side_bound, found = side.finish()
                stats["side_bound"] = _int_bound(side_bound)
                if side.yielded_at is not None:
                    stats["side_yielded_s"] = round(side.yielded_at - t0, 3)
                if side.proved_at is not None:
                    stats["side_proved_s"] = round(side.proved_at - t0, 3)
                if stats["side_bound"] is not None:
                    upper = min(upper, stats["side_bound"])
                start, start_profit = _adopt(data, found, start, start_profit, stats)
        if start is not None and chosen is not None and incumbent is not None:
            value = items_to_schedule(instance, data, chosen).coverage_profit(instance)[0]
            if value < float(incumbent) - 1e-4 and not budget.expired():
                # HiGHS can read back the start's solution with the optimum's objective when
                # presolve alone finishes a model given a MIP start, on both backends: solve
                # again without the start (the model was small)
                log.debug("HiGHS returned the start (%g) for objective %g", value, incumbent)
                stats["resolved_without_start"] = True
                kind, incumbent, raw_bound, chosen = _solve(run, solve_by, None, False)
    runtime = time.perf_counter() - t0
    if kind == "infeasible":  # cannot happen (the empty schedule is feasible) but map it
        return Result(method, Status.INFEASIBLE, empty, 0.0, 0, runtime, None, None, stats)
    if kind not in ("optimal", "time_limit", "not_run"):
        log.warning("HiGHS stopped with %s", stats.get("termination"))

    profit, schedule = 0.0, empty
    if chosen is not None:
        schedule = items_to_schedule(data.instance, data, chosen)
        profit = schedule.coverage_profit(instance)[0]
        if incumbent is not None and profit < float(incumbent) - 1e-4:
            log.warning("schedule profit %g below the model's objective %g", profit, incumbent)
        stats["objective"] = None if incumbent is None else float(incumbent)
    if start is not None and start_profit > profit:
        # HiGHS did not reach its start (stopped while loading, or refused it): keep the start
        schedule, profit = items_to_schedule(data.instance, data, start), start_profit
        stats["returned"] = "warm_start"
    observed = schedule.coverage_profit(instance)[1]
    ib = _int_bound(raw_bound)
    stats["raw_bound"] = None if raw_bound is None else float(raw_bound)
    bound = max(upper if ib is None else min(ib, upper), profit)
    if bound <= profit + INT_TOL:
        status, bound = Status.OPTIMAL, profit
    elif kind == "optimal":
        status = Status.FEASIBLE  # stopped at the requested gap
        stats["stopped_at"] = "mip_gap"
    else:
        status = Status.TIME_LIMIT
    return Result(method, status, schedule, profit, observed, runtime, bound, None, stats)


def _no_model(
    instance: Instance, warm_start: Any, relax: bool, stats: dict[str, Any], t0: float
) -> Result:
    """:func:`solve_milp`'s answer when its model was not ready in time, or a stop was
    requested while it was prepared: no MILP and no warm start over its items, so the free
    bound, and a schedule all the same (the warm start when the validator accepts it: never
    worse than a heuristic; else the empty schedule)."""
    from sosp.validate import validate

    stats["timed_out"] = "stopped" if stop_requested() else "candidates"
    upper = instance.observable_weight
    schedule, profit, observed, status = Schedule(()), 0.0, 0, Status.NO_SOLUTION
    if not relax:
        if isinstance(warm_start, Schedule) and validate(instance, warm_start).feasible:
            schedule, stats["returned"] = warm_start, "warm_start"
        elif isinstance(warm_start, Schedule):
            log.warning("warm start ignored: the schedule is infeasible")
        profit, observed = schedule.coverage_profit(instance)
        status = Status.OPTIMAL if profit >= upper - INT_TOL else Status.TIME_LIMIT
    runtime = time.perf_counter() - t0
    return Result("milp", status, schedule, profit, observed, runtime, upper, None, stats)


class _GiveWay:
    """A :func:`models.highs_direct.watching_bound` listener: ``side.watch``, and also True
    (stop HiGHS) once :data:`GIVE_WAY_SHARE` of the time to ``solve_by`` has passed with
    HiGHS's incumbent at most ``start_profit`` and the side not yielded to HiGHS's bound.
    ``gave_at``: :func:`time.perf_counter` when it first did (else None)."""

    def __init__(self, side: Any, start_profit: float, solve_by: Budget) -> None:
        self.side, self.start_profit = side, start_profit
        self.at = solve_by.share(GIVE_WAY_SHARE).deadline
        self.gave_at: float | None = None

    def __call__(self, dual_bound: float, incumbent: float) -> bool:
        if self.side.watch(dual_bound, incumbent):
            return True
        if self.at is None or time.perf_counter() < self.at or self.side.yielded_at is not None:
            return False
        if incumbent > self.start_profit + INT_TOL:
            return False  # HiGHS finds better schedules: it keeps its time
        if self.gave_at is None:
            log.info("HiGHS gives way to the search: no better schedule than its start")
            self.gave_at = time.perf_counter()
        return True


#: Least time (seconds) :func:`_search_on` needs to be worth starting.
SEARCH_ON_MIN_S = 1.0


def _search_on(
    data: ModelData,
    rng: np.random.Generator,
    arranged: OrbitData,
    start: list[int] | None,
    start_profit: float,
    budget: Budget,
    stats: dict[str, Any],
    side: SideBound | None = None,
) -> tuple[list[int] | None, float]:
    """The start and its profit after the time the MILP did not use: when HiGHS was not run
    (its model would not be built, or presolved, in the time left) or gave way
    (:data:`GIVE_WAY_SHARE`), orbit-dp's search (:func:`sosp.ascent.iterate`, each orbit
    re-planned over the model's own items) goes on from the start until
    ``budget`` ends, or until the ``side`` branch and price's bound proves its best schedule
    optimal (:meth:`models.colgen.SideBound.watch`), and its schedule replaces the start when
    better (a start given or found: the MILP's time is not lost when HiGHS cannot use it)."""
    if budget.deadline is None or not budget.fits(SEARCH_ON_MIN_S):
        return start, start_profit
    t1 = time.perf_counter()

    from sosp.ascent import OrbitSearch, OrbitSearchParams, iterate

    def until(now: Any) -> bool:
        # HiGHS no longer runs: with no dual bound (inf) the side only checks for a proof
        if budget.expired():
            return True
        return side is not None and side.watch(math.inf, max(now.best, start_profit))

    search = OrbitSearch(arranged, rng)
    if start:
        search.set_chosen(start)
    run = iterate(search, OrbitSearchParams(), until, budget.deadline, 0.0, report=False)
    search.paths = run.best_paths
    more = search.chosen()
    if side is not None and side.proved_at is not None:
        stats["search_on_stopped"] = "proven"
    profit = items_to_schedule(data.instance, data, more).coverage_profit(data.instance)[0]
    stats.update(search_on_s=round(time.perf_counter() - t1, 6), search_on_profit=float(profit))
    if profit > start_profit:
        stats.update(start_profit=float(profit), start_from="search_on")
        return more, profit
    return start, start_profit


#: Share of ``milp``'s time limit within which the cluster model's candidates must be
#: generated; past it, the warm start is the answer (when the validator accepts it).
MODEL_SHARE = 0.5


def _extra_bound(
    data: ModelData,
    how: str,
    lower: float,
    budget: Budget,
    threads: int | None,
    arranged: OrbitData | None,
    branch: bool = True,
) -> tuple[float | None, tuple[Schedule, float] | None]:
    """The bound ``how`` of ``data``'s model within ``budget`` (its share of the limit), and
    the schedule (with its profit) the branch and price ended on, if any (``colgen``: the
    branching only with ``branch``)."""
    if budget.expired():
        return None, None
    limit = budget.left()
    common = {"time_limit": limit, "lower_bound": lower if lower > 0 else None, "data": arranged}
    if how == "colgen":
        from models.colgen import colgen_bound

        # without a limit the branching could run for very long: the MILP decides then
        out = colgen_bound(data.instance, branch=branch and limit is not None, **common)
        found = (out["schedule"], float(out["profit"])) if "schedule" in out else None
        return float(out["bound"]), found
    if how == "lagrangian":
        from models.lagrangian import lagrangian_bound

        return float(lagrangian_bound(data.instance, **common)["bound"]), None
    # the LP relaxation with the relaxed slew row (direct backend), rounded down
    from models.highs_direct import build_arrays, run_highs

    if not fits("build", data.n_items, budget.deadline):
        return None, None
    am = build_arrays(data, relax=True, slew="relaxed")
    if budget.expired():
        return None, None
    lp = run_highs(am, deadline=budget.deadline, threads=threads, lp_solver="ipm")
    return (_int_bound(lp.bound) if lp.status == "optimal" else None), None


def _adopt(
    data: ModelData,
    found: tuple[Schedule, float] | None,
    start: list[int] | None,
    start_profit: float,
    stats: dict[str, Any],
) -> tuple[list[int] | None, float]:
    """The start and its profit: the branch and price's schedule ``found`` (with its profit)
    when it is better and maps onto the model's items, else ``start`` as it was."""
    if found is not None and found[1] > start_profit:
        better = start_items(data, found[0])
        if better is not None:
            stats.update(start_profit=float(found[1]), start_from="branch_and_price")
            return better, found[1]
    return start, start_profit


#: Share of the time limit the start stage of :func:`_solve_with_stations` (orbit-dp planned
#: with the stations) may take.
STATIONS_START_SHARE = 0.2


def _solve_with_stations(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None,
    params: dict[str, Any],
) -> Result:
    """:func:`solve_milp` on an instance with ground stations.

    Steps: with ``warm_start="auto"``, orbit-dp planned with the stations
    (:func:`sosp.solve.solve`, at most :data:`STATIONS_START_SHARE` of the limit) gives a
    start schedule; the model of :func:`models.downlink.downlink_block` over the items of
    ``model`` is solved by HiGHS (Pyomo backend); the chosen items' downlinks are laid by
    :func:`sosp.downlink.deliver`. The bound is the least of HiGHS's bound, the weight the
    items cover and ``extra_bound`` of the station-free relaxation (at most
    :data:`EXTRA_BOUND_SHARE` of the limit, before the MILP; when it meets the start, no MILP
    runs); the status is ``optimal`` only when the delivered schedule reaches the bound.
    The schedule returned is never worse than the start.
    """
    from models.downlink import downlink_block, downlink_data
    from sosp.downlink import deliver
    from sosp.solve import solve
    from sosp.validate import validate

    t0 = time.perf_counter()
    budget = Budget.until(None if time_limit is None else t0 + time_limit)
    model, start = params["model"], params["warm_start"]
    stats: dict[str, Any] = {"model": model, "relax": False, "backend": "pyomo", "stations": True}
    if params["backend"] == "highs":
        log.warning("backend highs: the model with downlinks is built with Pyomo")
    best = Schedule(())
    if start == "auto":
        share = budget.child(None if time_limit is None else STATIONS_START_SHARE * time_limit)
        first = solve(
            instance, "orbit-dp", seed=int(rng.integers(2**31)), time_limit=share.left(),
            no_improve=200,
        )  # fmt: skip
        best, stats["start_profit"] = first.schedule, first.profit
    elif isinstance(start, Schedule) and validate(instance, start).feasible:
        best = start
    best_profit = best.coverage_profit(instance)[0]
    upper = instance.observable_weight
    kind, raw = "not_run", None
    if params["extra_bound"] != "none" and best_profit < upper:
        # the bound of the station-free relaxation (docs/model.md, "Bounds with stations"):
        # on C2 and C3 with three stations it is tighter than HiGHS's bound at 300 s
        from sosp.registry import compute_bound

        share = budget.child(None if time_limit is None else EXTRA_BOUND_SHARE * time_limit)
        extra = compute_bound(
            params["extra_bound"], instance, time_limit=share.left(), lower_bound=best_profit
        )["bound"]
        if extra is not None:
            stats["extra_bound"] = float(extra)
            upper = min(upper, float(extra))
    try:
        data = downlink_data(model_data(instance, model, budget.deadline))
    except TimeUp:
        stats["timed_out"] = "candidates"
        data = None
    probing = params["probing"] == "on" or (params["probing"] == "auto" and time_limit is None)
    if data is not None:  # no items: nothing can be observed
        upper = min(upper, data.covered_weight())
    if best_profit >= upper - INT_TOL:
        stats["proven_by"] = "extra_bound" if "extra_bound" in stats else "cap"
    elif data is not None and data.n_items and not budget.expired():
        run = _Run(data, t0, params["mip_gap"], params["threads"], "clique", "choose", "exact",
                   probing, "pyomo", stats, downlink_block)  # fmt: skip
        solve_by = (
            None if budget.deadline is None else budget.deadline - min(0.5, 0.05 * time_limit)
        )
        kind, objective, raw, chosen = _solve(run, solve_by, None, False)
        stats["objective"] = objective
        if chosen is not None:
            obs, downlinks = deliver(
                instance, items_to_schedule(instance, data, chosen).observations
            )
            got = Schedule(obs, downlinks=tuple(downlinks))
            profit = got.coverage_profit(instance)[0]
            if objective is not None and profit < float(objective) - INT_TOL:
                # the fluid antennas (D-g) promised more than one antenna per pass delivers
                log.info("delivered %g of the model's %g: the model's value is a bound",
                         profit, objective)  # fmt: skip
                stats["delivered_below_model"] = True
            if profit > best_profit:
                best, best_profit = got, profit
            else:
                stats["returned"] = "warm_start"
    ib = _int_bound(raw)
    bound = max(upper if ib is None else min(ib, upper), best_profit)
    if bound <= best_profit + INT_TOL:
        status, bound = Status.OPTIMAL, best_profit
    elif kind == "optimal":
        status = Status.FEASIBLE
    else:
        status = Status.TIME_LIMIT
    observed = best.coverage_profit(instance)[1]
    runtime = time.perf_counter() - t0
    return Result("milp", status, best, best_profit, observed, runtime, bound, None, stats)


def _side_possible(
    how: str, arranged: OrbitData | None, budget: Budget, reserve_s: float = 0.0
) -> bool:
    """Whether a side process runs beside the MILP (:func:`solve_milp`'s side): only with
    ``extra_bound="colgen"``, a ``budget`` with at least :data:`models.colgen.SIDE_MIN_S`
    left after ``reserve_s`` seconds more (asked before the bound before the MILP, which then
    leaves the branching to the side) and a second core."""
    from models.colgen import SIDE_MIN_S, side_cores

    if how != "colgen" or arranged is None or budget.deadline is None:
        return False
    return budget.fits(reserve_s + SIDE_MIN_S) and side_cores() >= 2


@dataclass(frozen=True)
class _Run:
    """What every HiGHS solve of one :func:`solve_milp` call shares: the model's data, the
    call's start, the options and the ``stats`` the solves write to."""

    data: ModelData
    t0: float
    mip_gap: float | None
    threads: int | None
    conflicts: str
    lp_solver: str
    slew: str
    probing: bool
    backend: str
    stats: dict[str, Any]
    block: Block | None = None  # an extra constraint family (Pyomo backend)


def _solve(run: _Run, deadline: float | None, start: list[int] | None, relax: bool) -> _Outcome:
    """``run`` until ``deadline`` from the items ``start`` (the LP relaxation with ``relax``)
    on its backend: lazy, direct or Pyomo."""
    if run.backend == "highs" and run.slew == "lazy":
        return _run_lazy(run, deadline, start)
    if run.backend == "highs":
        return _run_direct(run, deadline, start, relax)
    return _run_pyomo(run, deadline, start, relax)


def energy_violations(data: ModelData, chosen: list[int]) -> set[int]:
    """Orbits where the chosen items break (4) with its exact slew term (consecutive pairs).

    Only orbits whose energy can bind (``data.energy_orbits``) are checked; a 1e-9 margin
    keeps clear of the validator's tolerance.
    """
    inst = data.instance
    taken = np.asarray(sorted(chosen), dtype=np.int64)
    bad: set[int] = set()
    for j in data.energy_orbits:
        u = taken[data.orbit[taken] == j]
        if not len(u):
            continue
        u = u[np.argsort(data.start[u], kind="stable")]
        rj = orbit_rules(inst, j)
        energy, _ = rj.usage(data.duration[u], data.roll[u])  # (4), exact slew
        if not rj.usage_ok(energy, 0.0):  # (5) is exact in every form of the model
            bad.add(int(j))
    return bad


def _run_lazy(run: _Run, deadline: float | None, start: list[int] | None) -> _Outcome:
    """The MILP with the exact slew term of (4) added only where a solution needs it.

    Round 1 gives every energy-binding orbit the relaxed row of
    :func:`models.highs_direct.build_arrays` (one row, no slew columns: a relaxation, so its
    dual bound bounds the problem). When the solution keeps (4) on every orbit it is feasible,
    and optimal when the round was. Otherwise the orbits it breaks get the exact term and the
    model is solved again, started from the best feasible schedule so far (the solution
    without the observations of the broken orbits, or the warm start). Every round's dual
    bound is valid; the least is returned.
    """
    data, stats = run.data, run.stats
    each = replace(run, lp_solver="choose", slew="exact")
    exact: set[int] = set()
    best = list(start) if start is not None else None
    best_value = _items_value(data, best)
    dual: float | None = None
    rounds = 0
    while True:
        rounds += 1
        kind, incumbent, raw, chosen = _run_direct(each, deadline, best, False, exact)
        if raw is not None:
            dual = raw if dual is None else min(dual, raw)
        stats.update({"lazy_rounds": rounds, "lazy_exact_orbits": len(exact)})
        if chosen is None:
            return kind, (best_value if best else None), dual, best
        bad = energy_violations(data, chosen)
        if not bad and _items_value(data, chosen) + INT_TOL >= best_value:
            return kind, incumbent, dual, chosen
        if not bad:  # stopped early below a schedule of an earlier round
            return kind, best_value, dual, best
        kept = [u for u in chosen if int(data.orbit[u]) not in bad]  # feasible: (4) elsewhere
        if _items_value(data, kept) > best_value:
            best, best_value = kept, _items_value(data, kept)
        exact |= bad
        if deadline is not None and time.perf_counter() >= deadline:
            return "time_limit", (best_value if best else None), dual, best


def _items_value(data: ModelData, chosen: list[int] | None) -> float:
    if not chosen:
        return 0.0
    return items_to_schedule(data.instance, data, chosen).coverage_profit(data.instance)[0]


_Outcome = tuple[str, float | None, float | None, list[int] | None]


def _run_direct(
    run: _Run,
    deadline: float | None,
    start_items_: list[int] | None,
    relax: bool,
    exact_orbits: set[int] | None = None,
) -> _Outcome:
    """Build ``data`` as arrays and solve it with highspy (:mod:`models.highs_direct`).

    The deadline is checked after building (HiGHS is not started when it has passed, or
    once a stop was requested) and HiGHS gets what is left of it after loading.
    """
    from models.highs_direct import build_arrays, run_highs, start_vector

    data, stats, slew, lp_solver = run.data, run.stats, run.slew, run.lp_solver
    if not fits("build", data.n_items, deadline):
        stats["timed_out"] = "building"
        return "time_limit", None, None, None
    t1 = time.perf_counter()
    am = build_arrays(
        data, relax=bool(relax), conflicts=run.conflicts, slew=slew, exact_orbits=exact_orbits
    )
    now = time.perf_counter()  # build_s: everything before the arrays too
    stats.update(slew=slew, build_s=round(now - run.t0, 6), arrays_s=round(now - t1, 6))
    stats.update(variables=am.n_cols, constraints=am.matrix.shape[0], nonzeros=int(am.matrix.nnz))
    if stop_requested() or (deadline is not None and time.perf_counter() >= deadline):
        # (stopped: the start's values and HiGHS's start took 0.3 s on 2,000 targets)
        stats["timed_out"] = "building"
        return "time_limit", None, None, None
    start = None
    if start_items_ is not None and not relax:
        start = start_vector(am, item_values(data, start_items_))
    out = run_highs(
        am,
        deadline=deadline,
        mip_gap=run.mip_gap,
        threads=run.threads,
        start=start,
        lp_solver=None if lp_solver == "choose" else lp_solver,
        probing=run.probing,
    )
    stats.update(load_s=round(out.load_s, 6), solve_s=round(out.solve_s, 6))
    stats.update(termination=out.model_status, **out.info)
    chosen = None if out.x is None else [int(u) for u in np.flatnonzero(out.x > 0.5)]
    return out.status, out.objective, out.bound, chosen


def _run_pyomo(
    run: _Run, deadline: float | None, start_items_: list[int] | None, relax: bool
) -> _Outcome:
    """Build ``data`` with the reference Pyomo builder and solve it with :func:`run_appsi`."""
    from models.formulation import build_model
    from models.highs_direct import PROBING_OFF

    data, t0, stats, lp_solver = run.data, run.t0, run.stats, run.lp_solver
    m = build_model(data, relax=bool(relax), block=run.block)
    stats["build_s"] = round(time.perf_counter() - t0, 6)
    warm = start_items_ is not None and not relax
    if warm:
        for name, values in item_values(data, start_items_).items():
            for key, val in values.items():
                getattr(m, name)[key].set_value(val)
    options = {
        "solver": lp_solver if relax and lp_solver != "choose" else None,
        "presolve_rule_off": None if relax or run.probing else PROBING_OFF,
    }
    kind, incumbent, raw_bound, opt = run_appsi(
        m, deadline, mip_gap=run.mip_gap, threads=run.threads, options=options, warm=warm,
        stats=stats,
    )  # fmt: skip
    chosen = None
    if incumbent is not None and not relax and kind in ("optimal", "time_limit"):
        units = list(m.U)
        values = appsi_values(opt, [m.x[u] for u in units])
        chosen = [int(u) for u, v in zip(units, values, strict=True) if v > 0.5]
    return kind, incumbent, raw_bound, chosen


def run_appsi(
    m: Any,
    deadline: float | None,
    *,
    mip_gap: float | None = None,
    threads: int | None = None,
    options: Mapping[str, Any] | None = None,
    warm: bool = False,
    stats: dict[str, Any],
) -> tuple[str, float | None, float | None, Any]:
    """Solve the Pyomo model ``m`` with APPSI's HiGHS (it takes MIP starts) until ``deadline``.

    A fresh solver object with only this run's options, its log to this module's logger, and
    no solution loaded (read it with :func:`appsi_values`). ``warm``: start from the values
    the model's variables hold. Writes ``load_s``, ``solve_s``, the model's size and the
    termination to ``stats``.

    Returns
    -------
    tuple
        ``(kind, incumbent, bound, solver)``: kind optimal / infeasible / time_limit / other.
    """
    from pyomo.contrib.appsi.base import TerminationCondition as TC
    from pyomo.contrib.appsi.solvers import Highs

    from models.highs_direct import use_threads

    t1 = time.perf_counter()
    opt = Highs()  # its time limit is set after the load
    opt.config.load_solution = opt.config.stream_solver = False
    opt.config.log_level, opt.config.solver_output_logger = logging.DEBUG, log
    if mip_gap is not None:
        opt.config.mip_gap = float(mip_gap)
    every = {"output_flag": log.isEnabledFor(logging.DEBUG), "threads": threads, **(options or {})}
    opt.highs_options = {k: v for k, v in every.items() if v is not None}
    # Loading the model into HiGHS takes seconds on large models: do it first, then give
    # HiGHS only what is left of the limit, and skip APPSI's change detection at solve time.
    opt.set_instance(m)
    for flag in opt.update_config:
        if flag.startswith(("check_for_new", "update_")):
            setattr(opt.update_config, flag, False)
    stats["load_s"] = round(time.perf_counter() - t1, 6)
    if deadline is not None:
        if time.perf_counter() >= deadline:
            stats["timed_out"] = "building"
            return "time_limit", None, None, opt
        opt.config.time_limit = max(deadline - time.perf_counter(), 0.01)
    opt.config.warmstart = warm
    use_threads(threads)
    t2 = time.perf_counter()
    res = opt.solve(m)
    h = opt._solver_model
    stats.update(variables=h.getNumCol(), constraints=h.getNumRow(), nonzeros=h.getNumNz())
    tc = res.termination_condition
    stats["termination"] = tc.name
    stats["solve_s"] = round(time.perf_counter() - t2, 6)
    kind = {TC.optimal: "optimal", TC.infeasible: "infeasible"}.get(tc, "other")
    if tc in (TC.maxTimeLimit, TC.maxIterations, TC.interrupted):
        kind = "time_limit"
    return kind, res.best_feasible_objective, res.best_objective_bound, opt


def appsi_values(opt: Any, variables: list[Any]) -> list[float]:
    """The values of ``variables`` in the solution HiGHS holds after :func:`run_appsi`."""
    col, index = opt._solver_model.getSolution().col_value, opt._pyomo_var_to_solver_var_map
    return [col[index[id(v)]] for v in variables]


#: Methods of :func:`bound`: the registered bounds of the problem (every model's bound here).
BOUND_METHODS = tuple(name for name, b in BOUNDS.items() if b.model == PROBLEM_MODEL)

#: Share of ``time_limit`` :func:`bound` with ``method="auto"`` gives the column-generation
#: bound before the LP gets the rest.
AUTO_LAGRANGIAN_SHARE = 0.4


def bound(
    instance: Instance,
    model: str = "cluster",
    method: str = "auto",
    time_limit: float | None = None,
    threads: int | None = None,
    backend: str = "auto",
    conflicts: str = "network",
    lp_solver: str = "ipm",
    slew: str = "auto",
    iterations: int = 300,
    lower_bound: float | None = None,
    workers: Workers = 1,
) -> dict[str, Any]:
    """An upper bound on the optimum of ``model``, within ``time_limit``.

    Every bound returned is at most the total weight of the targets the model's items cover
    (a target no schedule can observe adds nothing), so at most the total observable weight.

    Parameters
    ----------
    instance
        The problem.
    model
        ``"cluster"`` (bounds the problem and so every heuristic), ``"task"`` or ``"static"``.
    method
        ``"auto"`` (default): the column-generation bound (its root at most
        :data:`AUTO_LAGRANGIAN_SHARE` of the limit), then, unless it converged, the LP
        relaxation with what is left; the least of the two that finished (a converged
        column generation has the optimum of a master LP at least as tight as this LP, see
        :mod:`models.colgen`; on the cluster model its branch and price then gets the rest
        of the limit). ``"lp"``: the clique-strengthened LP relaxation (cliques of
        (3), slew term of (4) as ``slew``); ``"milp"``: the bound of a time-limited
        :func:`solve_milp` (its dual bound, the Lagrangian bound, the cap);
        ``"lagrangian"``: :func:`models.lagrangian.lagrangian_bound` over the model's items;
        ``"colgen"``: :func:`models.colgen.colgen_bound` over the planner's candidates
        (cluster model; other models: over their items), with a ``time_limit`` followed by
        branch and price until it ends. ``"windows"``:
        :func:`models.window_bound.window_colgen_bound` (cluster model, no candidate
        list: what ``"auto"`` falls back to when the planner's candidates would not fit in
        memory).
    time_limit
        Seconds for everything from the call, the kernels' load and building included (None:
        no limit).
    threads
        HiGHS threads.
    backend, conflicts
        As for :func:`solve_milp`.
    lp_solver
        HiGHS's LP algorithm for the LP (default ``"ipm"``: interior point with crossover,
        several times faster than simplex on the large cluster LPs).
    slew
        ``"auto"`` (default), ``"exact"`` or ``"relaxed"`` (LP; the MILP bound always uses
        the exact term): see :func:`solve_milp`.
    iterations
        Subgradient steps of the Lagrangian bound; pricing rounds of ``"windows"``.
    lower_bound
        A known schedule's profit: the Lagrangian bound's target (None: one quick ascent).
    workers
        Processes planning the orbits of each pricing round of ``colgen`` and
        ``lagrangian`` (and of the column generation of ``auto``); 1 (default): in this
        process. They pay where cores are idle and orbits many (``docs/scenarios.md``).

    Returns
    -------
    dict
        ``bound``, ``method``, ``source`` (what gave the bound: ``"lp"``, ``"lagrangian"``,
        ``"colgen"``, ``"milp"`` or ``"cap"`` when nothing finished below it), ``model``,
        ``runtime_s``,
        ``cap`` (the covered weight), the model size; ``"auto"``: ``parts`` (each method's
        bound, None when it did not finish); ``"milp"``: the incumbent ``profit``,
        ``status`` and ``gap``.

    Notes
    -----
    An instance with ground stations is bounded through its station-free relaxation
    (:func:`sosp.downlink.relaxed_instance`, ``docs/model.md``, "Bounds with stations").
    """
    from models.colgen import colgen_bound
    from models.lagrangian import check_count, lagrangian_bound
    from models.subset_row import cut_levels
    from sosp.planner import kernels_within, with_rolls

    t0 = time.perf_counter()
    if instance.stations:
        from sosp.downlink import relaxed_instance

        instance = relaxed_instance(instance)
    if method not in BOUND_METHODS:
        raise InputError(f"method: expected one of {', '.join(BOUND_METHODS)}, got {method!r}")
    time_limit = check_time_limit(time_limit)
    check_count("iterations", iterations)
    check_workers(workers)
    deadline = kernels_within(t0, time_limit)  # the kernels' load counts in the limit
    cut_levels()  # the branch and price's cut pricing (colgen, auto)
    if deadline is not None:
        time_limit = deadline - t0  # the limit, or more when the load took most of it
    highs = {"threads": threads, "backend": backend, "conflicts": conflicts}
    if method == "milp":
        left = None if deadline is None else deadline - time.perf_counter()
        res = solve_milp(instance, time_limit=left, model=model, **highs)
        return _bound_out(res.bound, method, model, t0, res.stats, profit=res.profit,
                          status=res.status.value, gap=res.gap, source="milp")  # fmt: skip
    lp = {"relax": True, "lp_solver": lp_solver, "slew": slew, **highs}
    MILPParams(**lp)  # the LP's options checked before anything is computed
    ask = _Ask(instance, t0, deadline, lower_bound or None, iterations, workers)
    if method == "colgen" and model == "cluster":
        return _over_candidates(ask, "colgen")
    if method == "windows":
        return _window_bound(ask, model)
    generate_by = None
    if method in ("auto", "lagrangian") and model == "cluster" and time_limit is not None:
        # candidates not ready by then leave the window relaxation its share: a dense orbit
        # begun just before the foresight could stop it can take the rest, and the answer
        # would be the cap
        generate_by = t0 + (1.0 - WINDOWS_AFTER_SHARE) * time_limit
    try:
        data = model_data(instance, model, deadline, generate_by)
    except TimeUp:
        if method in ("auto", "lagrangian") and model == "cluster":
            return _cap_or_windows(ask, method)
        return _bound_out(instance.observable_weight, method, model, t0, TIMED_OUT, source="cap")
    except InputError:
        if method == "lagrangian" and model == "cluster":
            # more candidates than the MILPs take (D30): the Lagrangian bound prices the
            # planner's candidates, which have no such cap
            return _over_candidates(ask, "lagrangian")
        if method != "auto" or model != "cluster":
            raise
        # more candidates than the MILPs take (D30): no LP, but the column generation's own
        # candidates have no such cap, so auto is its bound alone, with all the time left
        log.info("bound: the cluster model is too large for the LP; column generation alone")
        try:
            out = _over_candidates(ask, "colgen")
        except InputError:  # the planner's candidates would not fit in memory either
            return _windows_instead(ask, "auto", parts=True)
        if out.get("timed_out") == "candidates":  # the planner's were not ready either
            return _cap_or_windows(ask, "auto")
        out.update({"method": "auto", "parts": {"colgen": out["bound"]}})
        return out
    cap = data.covered_weight()
    parts: dict[str, float | None] = {}
    stats: dict[str, Any] = {"candidates": data.n_items, "cliques": data.n_events, "cap": cap}
    converged = False
    if (
        method in ("auto", "colgen")
        and data.n_items > 0
        and fits("arrange", data.n_items, deadline)
    ):
        limit = root = None
        if deadline is not None:
            share = AUTO_LAGRANGIAN_SHARE if method == "auto" else 1.0
            root = max(min(share * time_limit, deadline - time.perf_counter()), 1e-3)
            # a converged root leaves the LP nothing to add (cluster model): the rest of the
            # limit goes to branch and price instead
            limit = max(deadline - time.perf_counter(), root) if model == "cluster" else root
        cg = colgen_bound(
            instance,
            time_limit=limit,
            lower_bound=ask.lower_bound,
            data=with_rolls(data, data.roll),
            branch=deadline is not None and model == "cluster",
            root_time_limit=root,
            workers=workers,
        )
        parts["colgen"] = cg["bound"]
        stats.update({k: cg[k] for k in ("rounds", "nodes") if k in cg})
        stats["converged"] = bool(cg["converged"])
        # the argument that the LP cannot be tighter is made for the cluster model's rows
        converged = stats["converged"] and model == "cluster"
        if ask.lower_bound:
            stats["lower_bound"] = float(ask.lower_bound)
    lagrangian = method == "lagrangian" and data.n_items > 0
    if lagrangian and fits("arrange", data.n_items, deadline):
        lag = lagrangian_bound(
            instance,
            iterations=iterations,
            time_limit=ask.left(),  # all the limit: the method is lagrangian, never auto
            lower_bound=ask.lower_bound,
            data=with_rolls(data, data.roll),
            workers=workers,
        )
        parts["lagrangian"] = lag["bound"]
        stats.update({k: lag[k] for k in ("iterations", "lower_bound")})
    first = parts.get("lagrangian", parts.get("colgen"))
    proven = first is not None and first <= stats.get("lower_bound", -math.inf) + INT_TOL
    if method == "lp" or (method == "auto" and data.n_items and not proven and not converged):
        # (auto: no LP when the first bound already meets a schedule's profit, or when the
        # column generation converged: its master LP is at least as tight as this LP)
        left = None if deadline is None else deadline - time.perf_counter()
        if left is None or left > 0.05:
            res = solve_milp(instance, time_limit=left, model=model, **lp)
            parts["lp"] = res.bound
            keys = ("variables", "constraints", "nonzeros", "termination", "backend")
            stats.update({k: res.stats[k] for k in (*keys, "build_s", "load_s", "solve_s")
                          if k in res.stats})  # fmt: skip
            stats.update(lp_value=res.stats.get("lp_bound"), lp_solver=lp_solver)
            stats["slew"] = res.stats.get("slew", "exact")
        else:
            parts["lp"] = None
    upper = min([cap, *(v for v in parts.values() if v is not None)])
    # which computation gave the bound: a method, or the cap when none finished below it
    best = min((k for k, v in parts.items() if v is not None), key=lambda k: parts[k], default=None)
    source = best if best is not None and parts[best] <= cap else "cap"
    out = _bound_out(upper, method, model, t0, stats, source=source)
    if method == "auto":
        out["parts"] = parts
    return out


class _Ask(NamedTuple):
    """What :func:`bound`'s helpers are asked: the instance, the call's start, its deadline, a
    known schedule's profit (None: none), the rounds and the pricing workers."""

    instance: Instance
    t0: float
    deadline: float | None
    lower_bound: float | None
    iterations: int
    workers: Workers

    def left(self) -> float | None:
        """The seconds left (at least a millisecond), None without a deadline."""
        return None if self.deadline is None else max(self.deadline - time.perf_counter(), 1e-3)


def _window_bound(ask: _Ask, model: str) -> dict[str, Any]:
    """``bound(method="windows")``: :func:`models.window_bound.window_colgen_bound` with
    the time left, at most ``iterations`` pricing rounds and ``workers`` pricing processes
    (cluster model only: it bounds the problem itself)."""
    from models.window_bound import window_colgen_bound

    if model != "cluster":
        raise InputError(f"method windows: bounds the cluster model only, got model {model!r}")
    wb = window_colgen_bound(
        ask.instance,
        time_limit=ask.left(),
        lower_bound=ask.lower_bound,
        max_rounds=ask.iterations,
        workers=ask.workers,
    )
    keys = ("rounds", "converged", "cap")
    return _bound_out(wb["bound"], "windows", "cluster", ask.t0, {k: wb[k] for k in keys},
                      source="windows")  # fmt: skip


def _windows_instead(ask: _Ask, method: str, parts: bool = False) -> dict[str, Any]:
    """``method``'s bound when the planner's candidates would not fit in memory: the window
    relaxation's, which needs no candidate list (``parts``: with it as the only part)."""
    log.info("bound: too dense for the candidates; the window relaxation's bound")
    out = _window_bound(ask, "cluster")
    out["method"] = method
    if parts:
        out["parts"] = {"windows": out["bound"]}
    return out


#: ``bound`` with ``auto`` or ``lagrangian`` answers with the window relaxation's bound when
#: the candidates are not ready in time and at least this share of the limit is left (a
#: bound below the cap, the observable weight); else with the cap.
WINDOWS_AFTER_SHARE = 0.25

#: ... the share of the limit that must be left for the window relaxation's bound: less than
#: the :data:`WINDOWS_AFTER_SHARE` the generation leaves, which it passes by milliseconds
#: when it stops at its time.
WINDOWS_MIN_SHARE = 0.2


def _cap_or_windows(ask: _Ask, method: str) -> dict[str, Any]:
    """The bound of ``method`` when the candidates were not ready by the deadline: the window
    relaxation's (:func:`_window_bound`, never above the cap) with the time left when it is
    at least :data:`WINDOWS_MIN_SHARE` of the limit, else the cap (observable weight)."""
    upper = ask.instance.observable_weight
    now, deadline = time.perf_counter(), ask.deadline
    if deadline is not None and deadline - now >= WINDOWS_MIN_SHARE * (deadline - ask.t0):
        log.info("bound: the candidates are not ready in time; the window relaxation's bound")
        out = _window_bound(ask, "cluster")
        out.update({"method": method, "timed_out": "candidates"})
        out["parts"] = {"windows": out["bound"]}
        if upper <= out["bound"]:
            out.update({"bound": float(upper), "source": "cap"})
        return out
    return _bound_out(upper, method, "cluster", ask.t0, TIMED_OUT, source="cap")


def _over_candidates(ask: _Ask, method: str) -> dict[str, Any]:
    """``bound(method=method)`` (``"colgen"`` or ``"lagrangian"``) of the cluster model over
    the planner's candidates: the cluster model's, without the cap on their number that
    :func:`model_data` keeps for the MILPs (D30's 3.4 million are priced in seconds a round).
    Lagrangian: where the candidates are not ready in time or would not fit in memory either,
    the window relaxation's bound, which is a Lagrangian bound too
    (:mod:`models.window_bound`)."""
    from models.colgen import colgen_bound
    from models.lagrangian import lagrangian_bound
    from sosp.planner import orbit_data

    lagrangian = method == "lagrangian"
    try:
        data = orbit_data(ask.instance, ask.deadline, workers=ask.workers)
    except TimeLimitReached:
        if lagrangian:
            return _cap_or_windows(ask, method)
        # the candidates' own "time limit reached": nothing but the observable weight holds
        return _bound_out(ask.instance.observable_weight, method, "cluster", ask.t0, {},
                          source="cap", timed_out="candidates")  # fmt: skip
    except InputError:
        if lagrangian:
            return _windows_instead(ask, method)
        raise
    given = {"time_limit": ask.left(), "lower_bound": ask.lower_bound, "workers": ask.workers}
    if lagrangian:
        lag = lagrangian_bound(ask.instance, iterations=ask.iterations, data=data, **given)
        stats = {"candidates": data.n_items, "iterations": lag["iterations"]}
        stats["lower_bound"] = lag["lower_bound"]
        return _bound_out(lag["bound"], method, "cluster", ask.t0, stats, source=method)
    # the time left after convergence: branch and price
    cg = colgen_bound(ask.instance, data=data, branch=ask.deadline is not None, **given)
    keys = ("candidates", "cap", "rounds", "converged", "nodes")
    out = _bound_out(cg["bound"], method, "cluster", ask.t0, {k: cg[k] for k in keys if k in cg},
                     source="colgen" if cg["bound"] < cg["cap"] else "cap")  # fmt: skip
    if "profit" in cg:
        out["profit"] = cg["profit"]  # a validated schedule the branch and price ended on
    return out


#: The statistics of a bound that is the cap, the candidates not ready in time.
TIMED_OUT = {"timed_out": "candidates"}

#: The keys of a bound's statistics its answer carries, in this order.
_BOUND_KEYS = (
    *("candidates", "cliques", "variables", "constraints", "nonzeros", "termination"),
    *("backend", "build_s", "load_s", "solve_s", "cap", "iterations", "lower_bound"),
    *("rounds", "converged", "nodes", "lp_value", "lp_solver", "slew", "timed_out"),
)


def _bound_out(
    value: float | None, method: str, model: str, t0: float, stats: dict[str, Any], **more: Any
) -> dict[str, Any]:
    """A bound's answer: ``value``, ``method``, ``model``, the runtime from ``t0``, the
    :data:`_BOUND_KEYS` of ``stats``, then ``more`` in its order."""
    runtime = round(time.perf_counter() - t0, 6)
    out = {"bound": value, "method": method, "model": model, "runtime_s": runtime}
    return out | {k: stats[k] for k in _BOUND_KEYS if k in stats} | more
