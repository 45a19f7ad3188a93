"""``orbit-dp``: iterated local search whose move is the exact re-planning of one orbit.

Given the plans of the other orbits, the best plan of orbit j is the optimum of a single-orbit
problem: targets observed elsewhere are worth nothing, the others their weight p_k, and (3)-(6)
hold on j alone. :func:`sosp.planner.best_feasible_path` solves it by dynamic programming
over the cluster model's candidate observations (exactly while (4)-(5) do not bind), in
milliseconds even on an orbit with 30 000 candidates. The search is

1. **ascent**: re-plan orbits, in random order, until no re-plan gains (a plan is replaced only
   when it is worth strictly more, so this ends). Only orbits whose prices changed against
   their plans since their last re-plan (a target they see became free, or a target of their
   plan was taken by another orbit: :meth:`OrbitSearch._set`) are re-planned again;
2. **perturbation**: re-plan one to ``perturb_orbits`` random orbits with noisy prices
   (``p_k * U(1 - noise, 1 + noise)``) under which each target observed elsewhere keeps its
   weight with probability ``steal`` (so the orbit may take it over and free the other orbit),
   then ascend again;
3. **acceptance**: keep the result when it is worth at least the current schedule (plateaus
   are walked), else undo the step from its journal (the orbits' previous plans).

The search state is one plan (array of positions) per orbit and, per target, the number of
orbits whose plan covers it; a step journals the plans it replaces, so undoing costs what the
step changed and nothing is copied per step. The best plans are copied only when they improve.
The result is a heuristic schedule (status ``feasible``); no bound is claimed (``sosp bound
--method lagrangian`` gives one from the same recursion).

Where the candidates would not fit in memory (10,000 targets in the C region: tens of GB),
``candidates="auto"`` switches to :class:`WindowSearch`: the same search, whose re-plan prices
the orbit's windows at the re-plan's prices (:mod:`sosp.windows`) and plans over the real
observations of the argmax rolls, a restricted candidate set made for those prices (feasible
plans, not the optimum over every candidate).
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from sosp import candidates as sc
from sosp.ascent import OrbitSearch, OrbitSearchParams, WindowData, WindowSearch, iterate
from sosp.errors import TimeLimitReached
from sosp.instance import Instance
from sosp.parallel import workers_for
from sosp.planner import orbit_data
from sosp.result import Result, Status
from sosp.stop import Budget, FirstOf, MaxIterations, MaxRuntime, NoImprovement

if TYPE_CHECKING:
    from sosp.parallel import Workers

log = logging.getLogger(__name__)

#: Steps without a gain after which the search stops when no other limit is given.
DEFAULT_NO_IMPROVE = 500

#: Seconds per opportunity foreseen for :func:`hpfs_start` (static clustering and the
#: insertion, pure Python, one pass each, then the plans set): about twice the most measured.
HPFS_S_PER_OPP = 1.5e-5

#: Share of the time left that :func:`hpfs_start` may be foreseen to take; past it the
#: search starts as ``"lp"`` would. Most of it: on the densest instances the search over
#: windows from any other start stays far below HPFS-STC's schedule.
HPFS_START_SHARE = 0.8

#: Share of the time limit that :func:`lp_start`'s column generation may take; when it has
#: not converged by then, its last restricted master's plans are used as they are.
LP_START_SHARE = 0.3

#: The root is given up after its first pricing round when this many rounds of that length
#: would not fit in its share: a root stopped early gives uncoordinated plans, and the time
#: is the search's. G100k (771 orbits over windows, 35-80 s a round): the start from an
#: unconverged root (3 rounds in 180 s) ended at 581,975 against 585,448 from nothing in
#: 600 s. The measured roots converged in 45-65 rounds.
LP_START_ROUNDS = 20


def limits(
    seconds: float | None, start: float, iterations: int | None, no_improve: int | None
) -> list[Any]:
    """The stopping criteria of the limits given (None: not that one): ``seconds`` of wall
    time from ``start`` (a :func:`time.perf_counter` value), ``iterations`` steps and
    ``no_improve`` steps in a row without a gain."""
    crit: list[Any] = [] if seconds is None else [MaxRuntime(seconds, start=start)]
    crit += [] if iterations is None else [MaxIterations(iterations)]
    return crit + ([] if no_improve is None else [NoImprovement(no_improve)])


def lp_start(
    search: OrbitSearch,
    budget: Budget | float | None,
    workers: Workers = 1,
    keep: bool = False,
    plan_budget: Budget | float | None = None,
) -> dict[str, Any]:
    """Set each orbit's plan from the fractional schedule of the column-generation root.

    The root of :func:`models.colgen.colgen_bound` (the Dantzig-Wolfe master of the cluster
    model over orbit plans, priced by the same planner; for a :class:`WindowSearch`, the
    window relaxation's, :func:`models.window_bound.window_colgen_bound`) is solved until
    it converges or ``budget`` expires (or, when its first round shows that
    :data:`LP_START_ROUNDS` rounds would not fit, not at all: the search then keeps the start
    it had, empty or HPFS-STC's; over windows that is foreseen before the first round,
    :data:`models.window_bound.ROUND_S_PER_PAIR`).
    Each orbit then takes the plan of largest value in
    the last master's solution, re-planned by the search's own planner at the weights of
    that plan's targets (the master keeps a plan's targets, not its observations, and a
    relaxed or knapsack-breaking plan is no schedule). A target two orbits' plans cover
    counts once, and the ascent that follows re-plans the orbits against one another.

    Why: from the empty schedule the ascent settles in a local optimum where no one orbit
    can gain alone; on dense instances the master's plans are coordinated across orbits and
    the search from them ends much higher (D30, 300 s: 9,037 against 8,946; ``docs/exact.md``,
    "Start from the column-generation root").

    With ``keep`` (a start already set, e.g. :func:`hpfs_start`'s), the root's plans stay
    only when together they do not lower the profit, else the plans set before come back.
    The plans are kept or undone together, not orbit by orbit: they are coordinated, and
    one alone often loses against the other start's plans (over windows, from HPFS-STC's
    schedule: C1 490 to 552 with all of them, 520 orbit by orbit; C3 1,098 to 1,429 and
    1,216).

    An orbit's re-plan foreseen not to fit in ``plan_budget`` (the run's own; ``budget`` is
    only the root's share; None: no limit) is not made, and the orbit keeps its plan: over
    windows one re-plan of a dense orbit takes seconds.

    Returns the start's figures (rounds, seconds, the master's value, the profit set, and
    ``lp_kept``: whether the root's plans went in and stayed).
    """
    t0 = time.perf_counter()
    instance = search.data.instance
    left = sc.as_budget(budget).left()
    left = None if left is None else max(left, 1e-3)
    if isinstance(search, WindowSearch):
        from models.window_bound import window_colgen_bound as bound

        # unbanded: a banded round is 3-4 times longer (D100: 16 s against 5 s), and
        # LP_START_ROUNDS of them do not fit in the start's share; the start's plans are
        # re-planned by the search anyway, only their coordination counts
        data: dict[str, Any] = {"orbits": search.data.orbits, "band": None}
    else:
        from models.colgen import colgen_bound as bound  # type: ignore[assignment]

        data = {"data": search.data}
    root = bound(instance, time_limit=left, expect_rounds=LP_START_ROUNDS, workers=workers, **data)
    best: dict[int, tuple[float, np.ndarray]] = {}
    mark, before = len(search.journal), search.profit
    for g, targets, value, _, _ in root.get("plans", []):
        if g not in best or value > best[g][0]:
            best[g] = (value, targets)
    for g, (_, targets) in sorted(best.items()):
        price = np.zeros(len(search.weight))
        if search._late(g, sc.as_budget(plan_budget)):
            continue
        price[targets] = search.weight[targets]
        search._set(g, search._timed_plan(g, price))
    kept = len(search.journal) > mark
    if keep and search.profit < before - 1e-9:
        search.undo(mark)
        kept = False
    search.journal.clear()
    # each root plan was re-planned at its own targets' weights only, no optimum at the
    # search's prices: the ascent re-plans every orbit (as after HPFS-STC's schedule)
    search.dirty[:] = True
    return {
        "lp_rounds": root["rounds"],
        "lp_s": round(time.perf_counter() - t0, 4),
        "lp_master": root["master"],
        "lp_profit": search.profit,
        "lp_kept": kept,
    }


def hpfs_start(search: WindowSearch, budget: Budget | float | None) -> dict[str, Any]:
    """Set each orbit's plan from HPFS-STC's schedule (:func:`heuristics.hpfs.solve_hpfs_stc`:
    static cluster-tasks by decreasing weight, each inserted when feasible), unless it is
    foreseen (:data:`HPFS_S_PER_OPP`) to take more than :data:`HPFS_START_SHARE` of what
    is left of ``budget`` (the run's).

    Why: over windows one plan of a dense orbit takes seconds, so at short limits the ascent
    from nothing plans a few orbits and leaves the rest empty, while HPFS-STC fills every
    orbit in under half a second. The ascent then re-plans orbits against that schedule,
    each only where it gains.

    Returns the start's figures (seconds, the profit set; none when foreseen late).
    """
    t0 = time.perf_counter()
    instance = search.data.instance
    if not sc.as_budget(budget).share(HPFS_START_SHARE).fits(HPFS_S_PER_OPP * instance.n_opps):
        return {"hpfs_s": 0.0, "hpfs_profit": None}
    from heuristics.hpfs import solve_hpfs_stc

    search.set_schedule(solve_hpfs_stc(instance, rng=search.rng).schedule)
    return {"hpfs_s": round(time.perf_counter() - t0, 4), "hpfs_profit": search.profit}


#: After the ascent from HPFS-STC's schedule (:func:`hpfs_start`), a second ascent from nothing
#: is made when one pass over every orbit, each at its own last plan's time, is foreseen
#: within this share of the time left (an ascent takes one full pass and then shorter ones;
#: :func:`ascend_from_both`).
SECOND_ASCENT_SHARE = 0.25


def ascend_from_both(
    search: OrbitSearch, budget: Budget | float | None, started: dict[str, Any] | None = None
) -> tuple[OrbitSearch, dict[str, Any]]:
    """Ascend from the start already set (HPFS-STC's schedule), then, when it is foreseen to
    fit in :data:`SECOND_ASCENT_SHARE` of the time left, from nothing in a second search over
    the same data; return the search that ends higher, and the figures.

    With ``started`` (the start's figures, :func:`hpfs_start`'s and :func:`lp_start`'s),
    nothing is done (``search`` and no figures are returned) unless HPFS-STC's schedule is
    the start: where the root's plans went in (``lp_kept``), that coordinated start stays
    alone; where the root made no round, or its plans were undone because they lowered the
    profit, HPFS-STC's schedule is the start as much as without a root. ``orbit-dp`` and
    ASA-DTC's start both call it so.

    Why: each ascent ends in a local optimum where no single orbit's re-plan gains, and which
    one is higher depends on the instance and the seed. From HPFS-STC's schedule (static
    cluster-tasks, inserted by weight) the orbits keep its assignment of targets to orbits;
    from nothing the first orbits re-planned take whole dense strips. Where a pass does not
    fit (one plan of a dense orbit over windows takes seconds) the ascent from nothing ends
    far below the other, so only HPFS-STC's is made.

    Both searches draw from the one generator in turn, so a seed gives one result. The
    second search takes the first's foresight (its measured planning times).
    """
    if started is not None and (started.get("hpfs_profit") is None or started.get("lp_kept")):
        return search, {}
    budget = sc.as_budget(budget)
    search.ascent(budget)
    first = search.profit
    now = time.perf_counter()
    pass_s = sum(search.foreseen(g) for g in range(len(search.paths)))
    figures: dict[str, Any] = {"hpfs_ascent": first, "empty_ascent": None}
    if not budget.share(SECOND_ASCENT_SHARE).fits(pass_s):
        return search, figures
    other = type(search)(search.data, search.rng)
    other.plans = search.plans
    other.ascent(budget)
    figures["empty_ascent"] = other.profit
    figures["empty_ascent_s"] = round(time.perf_counter() - now, 4)
    if other.profit > first + 1e-9:
        other.replans += search.replans
        return other, figures
    search.replans += other.replans
    return search, figures


#: With ``candidates="auto"`` and a time limit, the explicit candidates must be generated and
#: arranged within this share of it, else the search plans over windows in the rest: where
#: they take longer the windows win (``docs/scenarios.md``); where they are quick (B10,
#: C10) explicit is better.
EXPLICIT_SHARE = 0.75

#: ... and generated within this share of it (arranging them takes about as long again), so
#: that the generation's foresight gives up early, with most of the limit left for the
#: windows.
GENERATE_SHARE = 0.4


def solve_orbit_dp(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """Iterated local search with exact orbit re-planning (method ``orbit-dp``).

    Parameters
    ----------
    instance
        The problem.
    rng
        The one generator.
    time_limit
        Wall-time limit in seconds, candidate generation included (None: stop by
        ``iterations`` / ``no_improve``). With ``candidates="auto"`` (default), the search
        plans over windows where the candidates would not fit in the solve's memory
        (:func:`sosp.candidates.candidate_cap`, estimated before any is generated) or are
        not generated within :data:`GENERATE_SHARE` and arranged within
        :data:`EXPLICIT_SHARE` of the limit (foreseen early:
        :func:`sosp.candidates.cluster_candidates`); with ``candidates="explicit"`` both
        are :class:`InputError`.
    **params
        Fields of :class:`OrbitSearchParams`.

    Returns
    -------
    Result
        Status ``feasible`` (``optimal`` when the instance has no opportunity: the empty
        schedule is then the only one, and every schedule is one); ``iterations`` the
        perturbation steps; ``stats``: candidates, ascent profit, re-plans, accepted steps,
        seconds of candidate generation, trace of (step, seconds, best).
    """

    t0 = time.perf_counter()
    p = OrbitSearchParams.from_kwargs(**params)
    budget = Budget.of(time_limit, sc.MAX_MEMORY)
    # the shares of the whole limit, counted from the start
    lp_budget, explicit, generate = (
        budget.share(s) for s in (LP_START_SHARE, EXPLICIT_SHARE, GENERATE_SHARE)
    )
    iterations, no_improve = p.iterations, p.no_improve
    if iterations is None and no_improve is None and time_limit is None:
        no_improve = DEFAULT_NO_IMPROVE
    mode = sc.candidate_mode(instance, p.candidates, budget)
    search: OrbitSearch
    data: Any = None
    if mode == "explicit":
        if p.candidates != "auto":
            explicit = generate = budget
        try:
            data = orbit_data(instance, explicit, workers=p.workers, generate_by=generate)
            search = OrbitSearch(data, rng)
        except TimeLimitReached as exc:
            if p.candidates != "auto":
                raise
            # not ready within their share (foreseen early: sosp.candidates): plan over
            # windows in the rest, as where the candidates do not fit in memory
            log.info("orbit-dp: planning over windows (%s)", str(exc).split(";")[0])
            mode = "windows"
    if mode == "windows":
        data = WindowData.build(instance)
        search = WindowSearch(data, rng)
    t_data = time.perf_counter() - t0
    started: dict[str, Any] = {}
    start = p.start
    if start == "hpfs" and mode != "windows":
        log.warning("orbit-dp: start hpfs needs window candidates; starting from lp")
        start = "lp"
    if start in ("hpfs", "auto") and mode == "windows" and data.orbits:
        started = hpfs_start(search, budget)  # type: ignore[arg-type]
        if started["hpfs_profit"] is None:
            start = "lp"
    if start == "auto":
        # then the root's plans where its share leaves time for them (they replace HPFS's
        # on their orbits when together they gain: coordinated plans, D100 at 600 s 26,040
        # against 25,716 from nothing); HPFS's stay on the others
        # (explicit candidates: the root, as before)
        start = "hpfs" if mode == "windows" and lp_budget.expired() else "lp"
    if start == "lp" and data.orbits:
        # after HPFS-STC's schedule the root's plans stay only where together they do not
        # lower the profit: the start is never below HPFS-STC's
        keep = started.get("hpfs_profit") is not None
        local = p.workers if p.workers > 1 else None
        with workers_for(p.workers, p.dask, local) as workers:
            started.update(lp_start(search, lp_budget, workers, keep, budget))
    seconds = None if time_limit is None else float(time_limit)
    crit = limits(seconds, t0, iterations, no_improve)
    # where HPFS-STC's schedule is the start, from nothing as well when that fits
    search, ascents = ascend_from_both(search, budget, started)
    started.update(ascents)
    run = iterate(search, p, FirstOf(*crit), budget, t0)
    search.paths = run.best_paths
    schedule = search.schedule()
    profit, observed = schedule.coverage_profit(instance)
    # without candidates (none in time) the empty schedule is still a schedule: feasible
    status = Status.FEASIBLE if instance.n_opps else Status.OPTIMAL
    stats = {
        "candidates": data.n_items,
        "candidate_mode": mode,
        "candidates_s": round(t_data, 4),
        **started,
        "ascent_profit": run.ascent_profit,
        "replans": search.replans,
        "accepted": run.accepted,
        "trace": run.trace,
    }
    runtime = time.perf_counter() - t0
    return Result("orbit-dp", status, schedule, profit, observed, runtime, None, run.steps, stats)
