"""Lagrangian upper bound without candidate observations (the window relaxation).

The bound of :func:`models.lagrangian.lagrangian_bound` with each orbit's maximum replaced by
the relaxation of :mod:`sosp.windows`: for multipliers ``mu >= 0`` on "each target counts
once" and ``lam >= 0`` on the knapsacks (4)-(5) of each orbit,

    L(mu, lam) = sum_k max(0, p_k - mu_k)
                 + sum_j [ relaxed max over plans of orbit j under (3), (6) at prices mu,
                           penalties lam_j + lam_ej + lam_wj ].

Each orbit's relaxed maximum is at least its exact maximum over the explicit candidates
(:func:`sosp.windows.relaxed_best_path`: every real observation is dominated by a relaxed
item), so L is at least the explicit-candidate Lagrangian function at the same multipliers,
which is an upper bound on the optimum: every value is a valid bound. The relaxed items are
priced per orbit at each step by a sweep over the orbit's windows, so memory stays at the
opportunities' size where the explicit candidates need tens of gigabytes (10,000 targets in
the C region). The multipliers come from column generation
(:func:`models.colgen.column_generation`): a relaxed plan's column is the targets its items
count (priced members at each item's argmax roll) and the relaxed plan's energy and memory.

Each orbit is priced per roll band of :data:`BAND` degrees (:func:`sosp.windows.window_items`):
the relaxation's slews are then at most one band short of the real ones, and the bound comes
close to the explicit candidates' at a few times the pricing's cost; the rounds can be priced
in ``workers`` processes. Column generation replaced subgradient steps here (the same
relaxation).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterable, Sequence
from contextlib import closing
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from models.lagrangian import capped_bound, check_count
from sosp.candidates import pairs_within
from sosp.instance import Instance
from sosp.parallel import parallelism
from sosp.planner import PlanPool
from sosp.rules import within_duration
from sosp.stop import Budget, Foresight, stop_requested
from sosp.windows import OrbitOpps, item_targets, orbit_opps, relaxed_best_path

if TYPE_CHECKING:
    from sosp.parallel import Workers

log = logging.getLogger(__name__)

#: Degrees of the relaxation's roll bands by default: the slew terms are under-estimated by
#: at most one band over the slew rate. The tightest width that still converged on the
#: largest scenarios within 600 s (``CHANGELOG.md``, "The window bound's roll bands").
BAND = 0.5

#: The finest band :func:`window_colgen_bound` refines to (a round's cost grows about as the
#: inverse of the band).
MIN_BAND = 0.1

#: Seconds per (first, covered) pair of opportunities (:func:`_pairs`) that one unbanded
#: pricing round is foreseen to take at least, for ``expect_rounds``, before a round has
#: been timed: below the least rate measured over drawn and paper instances, so that the
#: bound gives up early only on rounds that cannot fit.
ROUND_S_PER_PAIR = 1e-7

#: Rounds a window root is expected to take, and a round's cost when the band is halved,
#: for :func:`_first_band`: at most about 60 rounds on ``benchmarks/bench_window_bound.py``'s
#: instances, and a round at half the band about twice as long.
ROOT_ROUNDS = 60
HALVING_COST = 2.0


def window_colgen_bound(
    instance: Instance,
    *,
    time_limit: float | None = None,
    lower_bound: float | None = None,
    max_rounds: int = 10_000,
    expect_rounds: int | None = None,
    orbits: Sequence[OrbitOpps] | None = None,
    band: float | None = BAND,
    workers: Workers = 1,
    refine: bool = True,
) -> dict[str, Any]:
    """Upper bound by column generation over the window relaxation (no candidate list).

    :func:`models.colgen.column_generation` with each orbit priced by
    :func:`sosp.windows.relaxed_best_path`: a plan of the relaxation is worth at least the
    orbit's best real plan at the same multipliers (module docstring), so every round's
    value ``L(mu, lam)`` bounds the optimum, and the master (columns: the relaxed plans'
    priced targets, energy and memory) only chooses the next multipliers.

    Parameters
    ----------
    instance
        The problem.
    time_limit
        Seconds for everything (None: until the master is solved).
    lower_bound
        A known feasible profit: stop once the bound meets it.
    max_rounds
        Pricing rounds at most.
    expect_rounds
        See :func:`models.colgen.column_generation` (None: no such stop). Unbanded, with a
        time limit, the root is also given up before its first round when that many rounds
        of the least foreseen length (:data:`ROUND_S_PER_PAIR`) would not fit.
    orbits
        Every orbit's :class:`sosp.windows.OrbitOpps` in orbit order, when the caller has
        them (a window search's :attr:`sosp.ascent.WindowData.orbits`); None:
        made here.
    band
        Degrees of the roll bands the relaxation prices per (:func:`sosp.windows.window_items`;
        None: each first opportunity's whole range, the loosest and fastest).
    workers
        Processes for the orbits' pricing of each round (:class:`sosp.planner.PlanPool`).
    refine
        With a time limit and roll bands: start from the finest band expected to converge
        in time (:func:`_first_band`), and once a band's column generation has converged,
        halve the band (down to :data:`MIN_BAND`) and go on from its best multipliers until
        the limit. Every round's value bounds the optimum whatever the band, so the time
        left only lowers the bound; the figures returned (``master``, ``converged``,
        ``plans``) are the last band's.

    Returns
    -------
    dict
        ``bound`` (rounded down, capped by the weight of the targets with an opportunity no
        longer than Delta T), ``method`` ("colgen"), ``model`` ("windows"), ``runtime_s``,
        ``rounds``, ``columns``, ``master``, ``converged``, ``cap``, ``plans`` (as
        :func:`models.colgen.colgen_bound`'s, the relaxed plans' priced targets),
        ``bands`` (the band of each column generation run, in order).
    """
    from models.colgen import column_generation

    t0 = time.perf_counter()
    check_count("max_rounds", max_rounds)
    budget = Budget.of(time_limit)
    if orbits is None:
        orbits = [orbit_opps(instance, j) for j in range(instance.n_orbits)]
    seen, p = _observable(instance)
    cap = float(p.sum())

    rounds, columns, master, converged, best = 0, 0, None, cap == 0.0, cap
    plans: list[Any] = []
    bands: list[float | None] = []
    if orbits and cap > 0.0:
        busy = [g for g in range(len(orbits)) if len(orbits[g].start)]
        start = (p.copy(), np.zeros((len(orbits), 2)))  # mu = p: the orbits' own optima first
        b = band
        fits = True
        if expect_rounds is not None and budget.deadline is not None and band is None:
            # foreseen before the first round, which would otherwise run to the deadline
            # (it stops where an orbit is foreseen late: a partial round is no bound) and
            # only then show that expect_rounds such rounds do not fit; and before the
            # kernels are loaded (0.5-0.9 s the first time in a process)
            share = min(parallelism(workers), max(1, len(busy)))
            round_s = ROUND_S_PER_PAIR * sum(_pairs(orbits[g]) for g in busy) / share
            fits = budget.fits(expect_rounds * round_s)
            if not fits:
                msg = (
                    "window root given up before its first round: %d rounds of %.1f s, %.1f s left"
                )
                log.info(msg, expect_rounds, round_s, budget.left())
        if busy and fits:
            # compile the numba kernels (or load them from their cache) on the smallest
            # orbit before the first round, whose length decides ``expect_rounds``: a fresh
            # install's compilation (seconds) is not a round, and the workers then load the
            # cache
            small = min(busy, key=lambda g: len(orbits[g].start))
            _relaxed_plans(orbits, [small], p, np.zeros((len(orbits), 2)), band=band)
        if refine and band is not None and budget.deadline is not None:
            b, round_s, first = _first_band(orbits, p, band, budget, workers)
            best = min(best, first)  # the timed round is a round too (mu = p, lam = 0)
            # no round that cannot end before the deadline (a partial round is no bound):
            # the rest of the limit would be spent for the cap (G100k: 170 s a round in
            # one process, 100 s left after the timed one)
            fits = budget.fits(round_s)
            if not fits and math.isinf(round_s):
                log.info("window bound: the timed round did not end by the deadline")
            elif not fits:
                left = budget.left()
                log.info("window bound: a round takes about %.0f s, %.0f s left", round_s, left)
        seed: list[tuple[int, np.ndarray, float, float]] = []
        while fits:
            # the relaxation with roll bands of b degrees, priced in ``workers`` processes
            with closing(PlanPool(orbits, workers, partial(_relaxed_plans, band=b))) as pool:
                root = column_generation(
                    p,
                    seen,
                    [oo.rules for oo in orbits],
                    pool.best_paths,
                    start,
                    budget,
                    lower_bound,
                    max_rounds - rounds,
                    expect_rounds=None if bands else expect_rounds,
                    columns=seed,
                )
            bands.append(b)
            best, rounds = min(best, root.best), rounds + root.rounds
            if root.rounds or len(bands) == 1:  # a refinement cut before its first round
                master, converged = root.value, root.converged  # leaves the last band's
                columns, plans = len(root.master.columns), root.master.plans()
            finer = refine and converged and b is not None and b / 2 >= MIN_BAND
            # the finer band's rounds cost HALVING_COST times as much: one must fit
            fits = budget.deadline is not None and budget.fits(HALVING_COST * root.round_s)
            short = lower_bound is not None and math.floor(best + 1e-6) <= lower_bound
            if not (finer and fits and rounds < max_rounds) or short:
                break
            # the time left can only lower the bound: every round's value is one, whatever
            # the band; the next band starts from this one's best multipliers, its master
            # from this one's columns re-planned in the finer band (a master built from
            # nothing again took as many rounds as the first band: D100, no gain in 300 s)
            b, start = b / 2, (root.mu, root.lam)
            seed = _replanned(orbits, p, root.master.columns, b, budget)
    bound = capped_bound(best, cap)
    log.info("window colgen bound %g after %d rounds (bands %s)", bound, rounds, bands)
    return {
        "bound": bound,
        "method": "colgen",
        "model": "windows",
        "runtime_s": round(time.perf_counter() - t0, 6),
        "rounds": rounds,
        "columns": columns,
        "master": master,
        "converged": converged,
        "cap": cap,
        "plans": plans,
        "bands": bands,
    }


def _first_band(
    orbits: Sequence[OrbitOpps], p: np.ndarray, band: float, budget: Budget, workers: Workers
) -> tuple[float, float, float]:
    """The finest of ``band``, ``band / 2``, ... (not below :data:`MIN_BAND`) whose column
    generation is expected to converge within ``budget``: :data:`ROOT_ROUNDS` rounds, each
    :data:`HALVING_COST` times longer per halving than one round at ``band`` (timed here, in
    this process, and divided among the ``workers``); with it, the expected seconds of one
    of its rounds and the timed round's value (``L(p, 0)``, a bound like any round's). When
    the timed round does not end in time, both are infinite (no round fits).

    Why: refining a converged band (:func:`window_colgen_bound`) needs many rounds again, so
    when the time allows a finer band from the start, that is the tighter bound (D100, 600 s,
    two workers: 0.25 degrees from the start 27,004, 0.5 refined to 0.25 27,038).
    """
    t = time.perf_counter()
    zero = np.zeros((len(orbits), 2))
    plans = _relaxed_plans(orbits, range(len(orbits)), p, zero, band=band, until=budget.deadline)
    if plans is None:
        # the timed round alone passes the deadline (5,000 targets on 24 satellites: 5 s
        # a round, and a 5 s limit ran to 6.2 s): no round, and no bound from it
        return band, math.inf, math.inf
    cost = (time.perf_counter() - t) / min(parallelism(workers), max(1, len(orbits)))
    while band / 2 >= MIN_BAND and budget.fits(ROOT_ROUNDS * cost * HALVING_COST):
        band, cost = band / 2, cost * HALVING_COST
    return band, cost, float(sum(v for v, _, _ in plans))


def _replanned(
    orbits: Sequence[OrbitOpps],
    p: np.ndarray,
    columns: Sequence[tuple[Any, ...]],
    band: float | None,
    budget: Budget,
) -> list[tuple[int, np.ndarray, float, float]]:
    """Each master column ``(orbit, targets, counts, energy, memory)`` re-planned in the
    relaxation of ``band``: the orbit's best relaxed plan at the weights of the column's
    targets alone (a plan of that relaxation, covering those targets as far as it can);
    as many as ``budget`` allows."""
    out: list[tuple[int, np.ndarray, float, float]] = []
    lam = np.zeros((len(orbits), 2))
    for g, targets, *_ in columns:
        if budget.expired():
            break
        price = np.where(np.isin(np.arange(len(p)), targets), p, 0.0)  # the column's alone
        plans = _relaxed_plans(orbits, [g], price, lam, band=band)
        assert plans is not None  # no deadline given
        _, covered, used = plans[0]
        if used is not None:
            out.append((g, covered, used[0], used[1]))
    return out


#: Orbits of fewer (first, covered) pairs set no rate for :func:`_relaxed_plans`'s foresight
#: (their fixed costs dominate), as ``orbit-dp``'s plans over windows.
RELAXED_RATE_FROM_PAIRS = 100_000.0


def _pairs(oo: OrbitOpps) -> float:
    """Orbit ``oo``'s (first, covered) pairs of opportunities within one Delta T."""
    return float(pairs_within(oo.start, float(oo.rules.max_duration)))


def _relaxed_plans(
    orbits: Sequence[OrbitOpps],
    idx: Iterable[int],
    mu: np.ndarray,
    lam: np.ndarray,
    band: float | None = None,
    until: float | None = None,
) -> list[Any] | None:
    """The relaxed plans of the orbits ``idx`` at ``mu`` and their rows of ``lam``, as
    :meth:`sosp.planner.PlanPool.best_paths` gives them: per orbit the value, the targets the
    items count (with repeats) and the plan's (energy, memory), None for the empty plan. None
    when ``until`` passes first (a partial round is no bound), or, with ``until``, once a
    stop was requested (a round on 10,000 targets takes seconds: a Ctrl-C during
    ``--bound`` waited for it, 1.5 s, issue 63)."""
    plans: list[Any] = []
    # one orbit's plan reads no clock (seconds on a dense one: a 10 s bound ran to 12.7 s),
    # so an orbit foreseen past ``until`` at the most rate of those before it ends the round
    pace = Foresight(0.0, most=True, min_work=RELAXED_RATE_FROM_PAIRS)
    for g in idx:
        oo = orbits[g]
        work = _pairs(oo) if until is not None else 0.0
        if pace.late(g, work, until) or (until is not None and stop_requested()):
            return None
        t = time.perf_counter()
        v, path, ri = relaxed_best_path(oo, mu, float(lam[g, 0]), float(lam[g, 1]), band=band)
        pace.record(g, work, time.perf_counter() - t)
        if len(path) == 0:
            plans.append((v, np.zeros(0, dtype=np.int64), None))
            continue
        r = oo.rules
        used = r.usage(ri.duration[path], ri.slew_s[path] * r.slew_rate)
        plans.append((v, item_targets(oo, mu, ri, path), used))
    return plans


def _observable(instance: Instance) -> tuple[np.ndarray, np.ndarray]:
    """The targets with an opportunity no longer than Delta T (no other can be observed) and
    the weights, 0 for the others."""
    duration = instance.max_duration[instance.opp_orbit]
    fit = within_duration(instance.opp_start, instance.opp_end, duration)
    seen = np.bincount(instance.opp_target[fit], minlength=instance.n_targets) > 0
    return seen, np.where(seen, np.asarray(instance.target_weight, dtype=float), 0.0)
