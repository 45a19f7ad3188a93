"""MILP-based large neighbourhood search over the cluster model (method ``milp-lns``).

The clustering-exact model (:mod:`models.cluster`) is too large to solve whole on the big
reference scenarios (B10: 6 448 candidate observations, C10: 176 610), and on them the
heuristics of the paper stop well below its LP bound. Restricted to a few orbits, with the
targets observed on the other orbits worth nothing, the same model is small and HiGHS solves it
to optimality in about a second. Each step of this matheuristic therefore

1. draws a seed orbit uniformly (with the one ``rng``) among the orbits with candidates and adds
   the ``orbits - 1`` orbits that share the most observable targets with it (a little noise
   breaks ties and varies the neighbourhoods);
2. frees every observation of those orbits and re-plans them *exactly*: the cluster model over
   their candidates, objective (1) counting only targets not observed elsewhere (the rest of the
   schedule is fixed, so (2)-(6) hold across the whole schedule), warm-started from the
   observations it freed;
3. keeps the new observations when they are worth at least as much as the freed ones.

It starts from ``orbit-dp`` by default, whose move re-plans one orbit exactly; re-planning
several orbits jointly is what this search adds.

Because the freed observations are a feasible start of the sub-MILP, HiGHS never returns less,
so the profit never decreases; equal-profit replacements let the search drift on plateaus.
The result is a heuristic schedule (status ``feasible``): no bound is claimed. With
``orbit-dp`` it gives the "best known" values against which bounds and the other heuristics
are measured (``docs/exact.md``); in 60 s it adds little to orbit-dp alone (B10: 6103-6111
against 6107-6116; C10: equal).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, ClassVar, Literal

import numpy as np

from heuristics.orbit_search import limits
from heuristics.stc import at_least
from heuristics.timeline import OrbitTimeline
from sosp.candidates import CandidateMode, OppGroups, orbit_pairs
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.pipeline import Start, run_start
from sosp.progress import current as current_progress
from sosp.result import Result, Status
from sosp.rules import EPS, may_precede, orbit_rules
from sosp.schedule import Observation, Schedule, items_to_schedule
from sosp.stop import Budget, FirstOf, Foresight, Interrupted, SearchStatus

log = logging.getLogger(__name__)

#: Methods that cannot give the start (this one, and the whole MILP it replaces).
_EXACT = ("milp", "milp-lns")

#: Neighbourhoods of a step (see :class:`LNSParams`).
Neighbourhood = Literal["auto", "orbits", "window"]


@dataclass(frozen=True)
class LNSParams(Params):
    """Parameters of :func:`solve_milp_lns`.

    Parameters
    ----------
    orbits
        Orbits freed and re-planned per step (the neighbourhood size). Larger neighbourhoods
        find more per step but each sub-MILP takes longer (B10: 6 orbits, ~800 candidates,
        2-5 s per step; 4 orbits, the default, did best in 60 s on B10).
    sub_time_limit
        Seconds for one sub-MILP (it keeps its incumbent when stopped; the step still counts).
    start
        Method giving the initial schedule (any heuristic of :data:`sosp.solve.METHODS`), run
        with ``start_time_limit``. The default, ``orbit-dp`` (exact re-planning of one orbit at
        a time by dynamic programming, :mod:`heuristics.orbit_search`), makes the result never
        worse than orbit-dp's at that limit; it is the stronger start by far (B10, 60 s:
        about 6 100 against ASA-DTC's 5 549; C10: 3 840 against 2 819).
    start_time_limit
        Seconds for the start method (None: its own stopping rule); capped at half of the
        overall limit. The start is the pipeline's start stage (:func:`start_stage`,
        :func:`sosp.pipeline.run_start`): one that ends at this limit without a schedule
        (``orbit-dp`` when its candidates are not ready) gives way to
        :data:`sosp.pipeline.FALLBACK_START` with the same share of the time left.
    neighbourhood
        ``"orbits"``: free whole orbits (above). ``"window"``: free the observations of the
        seed orbit inside a time window of ``window`` seconds (the rest of that orbit stays:
        candidates must clear its neighbours by (3), and (4)-(6) get what the fixed
        observations leave, slews counted twice, which never under-estimates (4)).
        ``"auto"`` (default): orbits, unless they hold more than ``max_items`` useful
        candidates (the dense C scenarios), then a window.
    window
        Seconds of the time window of a window step (default 120 s, one longest observation
        Delta T of Table 1; on C10 120 s beat 60-100 s and 150-600 s in 60 s runs).
    max_items
        Largest orbit neighbourhood (useful candidates) ``"auto"`` solves whole.
    start_params
        Keyword parameters of the start method (e.g. ``{"iterations": 5000}``).
    iterations
        Stop after this many steps (None: no limit from this rule).
    no_improve
        Stop after this many steps in a row without a profit gain (None: no limit from this
        rule). With no limit at all, ``no_improve`` defaults to two sweeps' worth of steps
        (``2 * orbits with candidates / orbits``).
    threads
        HiGHS threads per sub-MILP.
    candidates
        ``"explicit"``: every candidate observation, made once (:mod:`sosp.candidates`);
        ``"windows"``: none made up front; each step makes the freed orbits' candidates at
        the step's prices, the real observations of the argmax rolls of
        :func:`sosp.windows.window_candidates` (a restricted set), plus the freed
        observations themselves (so a step never loses); ``"auto"`` (default): explicit
        unless they would take more than ``sosp.candidates.MAX_CANDIDATE_BYTES``.
    """

    #: :func:`solve_milp_lns`'s keyword beside the fields, for ``sosp methods``.
    KEYWORDS: ClassVar[dict[str, tuple[str, Any, str]]] = {
        "warm_start": (
            "Schedule | None",
            None,
            "A schedule to start from instead of running start (ignored with a warning when "
            "the validator rejects it).",
        )
    }

    orbits: int = param(4, "Orbits freed and re-planned per step (the neighbourhood size).")
    sub_time_limit: float = param(10.0, "Time limit of one sub-MILP.", "s")
    start: str = param("orbit-dp", "Heuristic method giving the initial schedule.")
    start_time_limit: float | None = param(10.0, "Time limit of the start method.", "s")
    start_params: dict[str, Any] | None = param(None, "Parameters of the start method.")
    neighbourhood: Neighbourhood = param("auto", "What a step frees: orbits or a time window.")
    window: float = param(120.0, "Time window of a window step.", "s")
    max_items: int = param(1500, "Largest orbit neighbourhood 'auto' solves whole.")
    iterations: int | None = param(None, "Stop after this many steps (None: no limit).")
    no_improve: int | None = param(None, "Stop after this many steps without a gain.")
    threads: int = param(1, "HiGHS threads per sub-MILP.")
    candidates: CandidateMode = param("auto", "Candidates: made up front or priced per window.")

    def check(self) -> None:
        at_least(self, orbits=1, iterations=1, no_improve=1, threads=1, max_items=1)
        for name in ("sub_time_limit", "start_time_limit", "window"):
            if (v := getattr(self, name)) is not None and not (math.isfinite(v) and v > 0):
                raise InputError(f"{name}: expected a number of seconds > 0, got {v!r}")
        if self.start_params is not None and not isinstance(self.start_params, dict):
            raise InputError(f"start_params: expected an object, got {self.start_params!r}")
        from sosp.registry import METHODS

        if self.start not in METHODS or self.start in _EXACT:
            raise InputError(
                f"start: expected a heuristic method name (e.g. 'hpfs-stc', 'asa-dtc'), "
                f"got {self.start!r}"
            )


def _claims_value(instance: Instance, observations: list[Observation], weight: np.ndarray) -> int:
    """Total ``weight`` of the distinct targets the observations list."""
    ks = {int(instance.opp_target[i]) for ob in observations for i in ob.opps}
    return int(weight[list(ks)].sum()) if ks else 0


def _weights_left(
    instance: Instance, fixed: list[Observation], weight: np.ndarray
) -> tuple[set[int], np.ndarray]:
    """Targets the ``fixed`` observations cover, and the weights with those set to 0."""
    covered = {int(instance.opp_target[i]) for ob in fixed for i in ob.opps}
    w_sub = weight.copy()
    w_sub[list(covered)] = 0
    return covered, w_sub


def _useful(
    instance: Instance,
    w_sub: np.ndarray,
    freed: list[Observation],
    sel: np.ndarray,
    ptr: np.ndarray,
    flat_opps: np.ndarray,
    flat_targets: np.ndarray,
) -> np.ndarray:
    """Which candidates of ``sel`` are worth solving for.

    A candidate whose targets are all worth 0 in ``w_sub`` (observed by fixed observations) is
    worth nothing and only uses resources: dropping it is exact. Candidates holding a freed
    observation's opportunities stay (the warm start maps onto them).
    """
    useful = _any_per_row(w_sub[flat_targets] > 0, ptr, sel)
    if freed:
        held = np.zeros(instance.n_opps, dtype=bool)
        held[[i for ob in freed for i in ob.opps]] = True
        useful |= _any_per_row(held[flat_opps], ptr, sel)
    return useful


def _window_plan(
    instance: Instance,
    current: list[Observation],
    j: int,
    items: np.ndarray,
    cand: tuple[np.ndarray, np.ndarray, np.ndarray],
    rng: np.random.Generator,
    length: float,
) -> tuple[list[Observation], list[Observation], np.ndarray, Instance] | None:
    """Free orbit ``j``'s observations inside a random window; the sub-problem's data.

    Returns (fixed, freed, candidates, sub-instance) or None when nothing can change. The
    window of ``length`` seconds is centred on a random candidate's start. The orbit's other
    observations stay: ``prev`` (the last one starting before the window) and ``nxt`` (the
    first one starting in or after it) are consecutive among them, and every candidate kept
    clears both by (3), so (3) holds along the orbit (pairwise exactness, ``docs/model.md``).
    The sub-instance gives orbit j what the fixed observations leave of (4)-(6). Inserted
    between prev and nxt, new observations add exactly ``2 es sum |theta| / v`` of slew energy;
    with only one of them, at most that plus its |theta| (charged up front); with neither, at
    most that. So the ``"conservative"`` energy row (slews counted twice) never lets (4) break.
    """
    c_start, c_end, c_roll = cand
    t0 = float(c_start[items[rng.integers(len(items))]]) - length / 2.0
    t1 = t0 + length
    on_j = sorted((ob for ob in current if ob.orbit == j), key=lambda ob: ob.start)
    inside = [t0 <= ob.start and ob.end <= t1 for ob in on_j]
    freed = [ob for ob, f in zip(on_j, inside, strict=True) if f]
    kept = [ob for ob, f in zip(on_j, inside, strict=True) if not f]
    prev = next((ob for ob in reversed(kept) if ob.start < t0), None)
    nxt = next((ob for ob in kept if ob.start >= t0), None)
    r = orbit_rules(instance, j)
    st, en, th = c_start[items], c_end[items], c_roll[items]
    ok = (st >= t0) & (en <= t1)
    # (3) against the kept neighbours by the interval ends of sosp.rules, with a margin so the
    # sub-MILP's plans never sit on the boundary
    if prev is not None:
        ok &= may_precede(r.right(prev.end, prev.roll), r.left(st, th), -EPS)
    if nxt is not None:
        ok &= may_precede(r.right(en, th), r.left(nxt.start, nxt.roll), -EPS)
    line = OrbitTimeline(r)
    line.load([(ob.start, ob.end, ob.roll) for ob in on_j])
    first = sum(1 for ob in on_j if ob.start < t0)  # the freed ones follow prev, if any
    energy, memory, openings = line.budget_between(first, first + len(freed) - 1, ends_paid=True)
    if not ok.any() or openings <= 0 or memory <= 0 or energy <= 0:
        return None
    # the instance with orbit j's capacities set to what is left
    left = {"energy_capacity": energy, "memory_capacity": memory, "max_openings": openings}
    columns = {name: np.array(getattr(instance, name), copy=True) for name in left}
    for name, value in left.items():
        columns[name][j] = value
    sub = replace(instance, **columns)
    fixed = [ob for ob in current if ob.orbit != j] + kept
    return fixed, freed, items[ok], sub


class _Late(Exception):
    """An orbit's window columns (its index, the one argument) are foreseen to end past the
    deadline."""


#: Foreseen seconds of an orbit's window sweep (:func:`sosp.windows.window_items`) per
#: (first, covered) pair of opportunities inside one Delta T, until one was timed: the most
#: measured (2-core machine, the densest orbits of four drawn instances of 1,200-10,000
#: targets: 0.09-0.35 us a pair, up to 6.5 s an orbit).
WINDOW_S_PER_PAIR = 3.5e-7

#: Foreseen seconds of the window candidates' members listing per opportunity it reads
#: (:func:`sosp.windows.member_scan`), until one was timed: the most measured on the same
#: orbits (7-12 ns, both passes; up to 28 s an orbit). Per pair the listing varies 200-fold.
WINDOW_S_PER_SCAN = 1.25e-8


#: Foreseen seconds of a step's model (data and arrays) per member of its candidates, until
#: one was timed: the most measured (2-core machine, windowed steps on four drawn instances
#: of 2,500-10,000 targets: 0.3-0.64 us a member, models of up to 3 million members).
BUILD_S_PER_MEMBER = 6.5e-7

#: A step's model of fewer members than this is timed for the fixed part of the foresight,
#: and only from this size on for the part per member: below it the fixed cost (about 1 ms,
#: up to 2.2 ms, over 989 models on two drawn instances of 500 and 600 targets) is most of
#: the time, and one member's model, 0.8 ms, read as 820 us a member, which foresaw a model
#: of 25,718 members at 7.6 s (it takes 11 ms) and ended a 20 s run at 14 s.
RATE_MIN_MEMBERS = 10_000


@dataclass
class BuildForesight:
    """Foreseen seconds of a step's model (data and arrays), from the models timed so far:
    ``fixed + rate * members``, ``fixed`` the most a model of fewer than
    :data:`RATE_MIN_MEMBERS` members took, ``rate`` the most seconds per member of a larger
    one (:data:`BUILD_S_PER_MEMBER` until one was timed)."""

    rate: float = 0.0
    fixed: float = 0.0

    def seconds(self, members: int) -> float:
        return self.fixed + (self.rate or BUILD_S_PER_MEMBER) * members

    def record(self, members: int, seconds: float) -> None:
        if members >= RATE_MIN_MEMBERS:
            self.rate = max(self.rate, seconds / members)
        else:
            self.fixed = max(self.fixed, seconds)


class _WindowColumns:
    """Candidate columns (orbit, start, end, roll, opportunities) of an orbit at given prices
    from :func:`sosp.windows.window_candidates`, made only when foreseen to end in time.

    The making is compiled and reads no clock: on a dense orbit (4,714 opportunities, 11.6
    million window members) it takes more than a second, and a 5 s ``milp-lns`` ran to
    12.8 s. It is foreseen twice:

    * before the sweep: orbit j's own last time, else its (first, covered) pairs times the
      most seconds per pair any orbit took in all, at least :data:`WINDOW_S_PER_PAIR` (the
      sweep's alone);
    * before the members' listing: its :func:`sosp.windows.member_scan` times the most
      seconds per opportunity read, at least :data:`WINDOW_S_PER_SCAN`. Per pair an orbit's
      whole time varied 200-fold (0.07-15.7 us), and a 5 s run on a 10,000-target polar box
      went to 8.0 s; per opportunity read, 7-12 ns.
    """

    def __init__(self, instance: Instance, budget: Budget) -> None:
        self.instance = instance
        self.budget = budget
        self.n_opps = np.diff(instance.orbit_offsets)
        self.opps_of: dict[int, Any] = {}  # each orbit's opportunity arrays, made once
        self.whole = Foresight(WINDOW_S_PER_PAIR, most=True)  # per orbit, by its pairs
        self.scan = Foresight(WINDOW_S_PER_SCAN, most=True)  # the listings, by their reads

    def foreseen(self, j: int) -> float:
        """Seconds orbit j's columns are foreseen to take before its sweep (see the class
        docstring)."""
        return self.whole(j, orbit_pairs(self.instance, j))

    def listing(self, scan: int) -> float:
        """Seconds a members' listing reading ``scan`` opportunities is foreseen to take."""
        return self.scan.rate_or_prior() * scan

    def __call__(
        self, j: int, price: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, OppGroups]:
        from sosp.windows import TooManyMembers, orbit_opps, window_candidates

        if not self.budget.fits(self.foreseen(j)):
            raise _Late(j)
        t = time.perf_counter()
        if j not in self.opps_of:
            self.opps_of[j] = orbit_opps(self.instance, j)
        scanned = [0, t]  # the listing's opportunities read, and when it started

        def ahead(scan: int) -> None:
            scanned[:] = [scan, time.perf_counter()]
            if not self.budget.fits(self.listing(scan)):
                # not made, now or later: its time so far plus the listing, for foreseen(j)
                self.whole.took[j] = scanned[1] - t + self.listing(scan)
                raise _Late(j)

        try:
            st, en, ro, groups = window_candidates(self.opps_of[j], price, ahead=ahead)
        except TooManyMembers as exc:
            # too large a model for any step: the orbit is left out as if always late
            log.warning("milp-lns: %s; the steps go on without it", exc)
            self.whole.took[j] = math.inf
            raise _Late(j) from None
        end = time.perf_counter()
        self.whole.record(j, orbit_pairs(self.instance, j), end - t)
        self.scan.record(j, scanned[0], end - scanned[1])
        return np.full(len(st), j, dtype=np.int64), st, en, ro, groups


class _Stacked:
    """Groups of opportunities of several :class:`sosp.candidates.OppGroups` one after
    another, read in place: ``ptr`` as if their members were one array, ``[u]`` the u-th
    group's tuple. A step reads only the groups it selects, so the members (70 million on
    one orbit of a 10,000-target polar box) are not copied: that copy's first touch of
    fresh memory took 1.2 s, past a 5 s limit."""

    __slots__ = ("parts", "ptr", "starts")

    def __init__(self, parts: list[OppGroups]) -> None:
        self.parts = parts
        sizes = np.concatenate([g.sizes for g in parts])
        self.ptr = np.zeros(len(sizes) + 1, dtype=np.int64)
        np.cumsum(sizes, out=self.ptr[1:])
        self.starts = np.cumsum([0] + [len(g) for g in parts])  # each part's first group

    def __len__(self) -> int:
        return len(self.ptr) - 1

    def __getitem__(self, u: int) -> tuple[int, ...]:
        u = int(u)
        if not 0 <= u < len(self):
            raise IndexError(u)
        k = int(np.searchsorted(self.starts, u, side="right")) - 1
        return self.parts[k][u - int(self.starts[k])]


def _stack_columns(
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, OppGroups]],
    freed: list[Observation],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, _Stacked]:
    """``parts`` one after another, then the ``freed`` observations (the warm start maps onto
    them, so the sub-MILP never returns less than it freed). The opportunities stay where
    they are (:class:`_Stacked`): a dense orbit has tens of thousands of candidates."""
    kinds = {"orbit": np.int64, "start": float, "end": float, "roll": float}
    mine = [np.array([getattr(ob, f) for ob in freed], dtype=d) for f, d in kinds.items()]
    parts = [*parts, (*mine, OppGroups.from_groups([ob.opps for ob in freed]))]
    cols = (np.concatenate([part[c] for part in parts]) for c in range(4))
    return (*cols, _Stacked([part[4] for part in parts]))  # type: ignore[return-value]


def _any_per_row(flags: np.ndarray, ptr: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """For each row r in ``rows``: is any of ``flags[ptr[r]:ptr[r + 1]]`` true? (rows non-empty)"""
    counts = np.add.reduceat(flags.astype(np.int64), ptr[:-1])
    return counts[rows] > 0


def _shared_targets(instance: Instance) -> np.ndarray:
    """M x M: number of targets with an opportunity on both orbits (diagonal: on the orbit)."""
    # float: numpy multiplies integer matrices without BLAS (g20, 20,000 targets x 180
    # orbits: 3.3 s, not interruptible, where the float product takes milliseconds); the
    # counts are exact in float64
    inc = np.zeros((instance.n_targets, instance.n_orbits))
    inc[instance.opp_target, instance.opp_orbit] = 1.0
    return np.rint(inc.T @ inc).astype(np.int64)


def start_stage(instance: Instance, params: Mapping[str, Any]) -> Start | None:
    """The start stage of ``milp-lns`` with ``params`` (:data:`sosp.pipeline.StartRule`):
    ``start`` with ``start_params`` in at most ``start_time_limit``; None when a
    ``warm_start`` schedule is given. Explicit candidates that would not fit are refused
    here, before the start spends half the time."""
    from sosp.candidates import candidate_mode

    if params.get("warm_start") is not None:
        return None
    kwargs = {k: v for k, v in params.items() if k != "warm_start"}
    p = from_kwargs(LNSParams, kwargs, method="milp-lns")
    if p.candidates == "explicit":
        candidate_mode(instance, p.candidates)
    return Start(p.start, p.start_time_limit, p.start_params or {})


def solve_milp_lns(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    warm_start: Schedule | None = None,
    **params: Any,
) -> Result:
    """MILP-LNS: re-plan a few related orbits at a time exactly with the cluster MILP (HiGHS).

    Parameters
    ----------
    instance
        The problem.
    rng
        The one generator: neighbourhood draws, and the start method's randomness.
    time_limit
        Wall-time limit in seconds for everything (start, steps); None: stop by ``iterations``
        or ``no_improve``.
    warm_start
        A schedule to start from instead of running ``start`` (ignored with a warning when
        the validator rejects it).
    **params
        Fields of :class:`LNSParams`.

    Returns
    -------
    Result
        Status ``feasible``; ``iterations`` the steps made; ``stats`` the start profit, steps
        that improved, sub-MILP sizes and a ``trace`` of ``[step, time_s, profit]`` rows at
        each improvement.
    """
    from models.data import TimeUp, prepare
    from models.highs_direct import build_arrays, run_highs, start_vector
    from models.solve import warm_start_values
    from sosp.candidates import candidate_mode, cluster_candidates, flatten
    from sosp.validate import validate

    t0 = time.perf_counter()
    p = from_kwargs(LNSParams, params, method="milp-lns")
    budget = Budget.until(None if time_limit is None else t0 + time_limit)
    # ---- start
    if warm_start is not None and not isinstance(warm_start, Schedule):
        raise InputError("warm_start: expected a Schedule")
    # explicit candidates for every orbit, or window candidates made per step (an explicit
    # request that would not fit was refused by start_stage, before the start ran)
    windowed = candidate_mode(instance, p.candidates, budget.deadline) == "windows"
    if warm_start is not None and not validate(instance, warm_start).feasible:
        # as for ``milp``: an unusable start is ignored, not fatal
        log.warning("warm start ignored: the schedule is infeasible; starting from %s", p.start)
        warm_start = None
    start_name = "warm_start"
    if warm_start is None:  # called directly, not by the pipeline: run the start stage here
        start = start_stage(instance, params)
        first, stage = run_start(instance, start, rng, budget)
        warm_start, start_name = first.schedule, stage.name
    current = list(warm_start.observations)
    weight = np.asarray(instance.target_weight, dtype=np.int64)
    profit = _claims_value(instance, current, weight)
    start_profit = profit
    trace: list[list[float]] = [[0, round(time.perf_counter() - t0, 4), float(profit)]]

    # ---- candidates once, shared with an orbit-dp start (cached per instance by
    # sosp.candidates; not interruptible: C10 about 2.5 s); per step only a subset is used
    candidates: Any = (np.zeros(0),) * 4 + ((),)  # none when the start used the whole limit
    if budget.fits(0.05) and not windowed:
        try:  # the limit holds while generating them too (they stop at the deadline)
            candidates = cluster_candidates(instance, max_candidates=None, deadline=budget.deadline)
        except TimeLimitReached:
            # not ready by the deadline (foreseen: at once): the steps make window candidates
            # for the orbits they free, as where the candidates do not fit in memory
            windowed = True
    c_orbit, c_start, c_end, c_roll, c_opps = candidates
    order = np.argsort(c_orbit, kind="stable")  # each orbit's candidates, in index order
    blocks = np.split(order, np.flatnonzero(np.diff(c_orbit[order])) + 1) if len(order) else []
    by_orbit: dict[int, np.ndarray] = {int(c_orbit[b[0]]): b for b in blocks}
    active = np.array(sorted(by_orbit), dtype=np.int64)
    window_columns = _WindowColumns(instance, budget)
    if windowed:
        active = np.flatnonzero(np.diff(instance.orbit_offsets) > 0).astype(np.int64)
    # candidates' opportunities and targets as flat arrays (CSR), to filter them per step
    n_opps, flat_opps = flatten(c_opps)
    ptr = np.concatenate([[0], np.cumsum(n_opps)])
    flat_targets = np.asarray(instance.opp_target, dtype=np.int64)[flat_opps]
    shared = _shared_targets(instance).astype(float)
    k = min(p.orbits, len(active))
    no_improve = p.no_improve
    if no_improve is None and p.iterations is None and budget.deadline is None:
        no_improve = max(1, 2 * math.ceil(len(active) / max(k, 1)))

    steps = improved = stale = 0
    sizes: list[int] = []
    seconds = None if time_limit is None else time_limit - 0.05  # no step in the last 50 ms
    crit = limits(seconds, t0, p.iterations, no_improve)
    stop, now = FirstOf(current_progress(), Interrupted(), *crit), SearchStatus()
    prep_s = 0.0  # the last step's time to its model (candidates, data, arrays)
    build = BuildForesight()
    while len(active):
        now.iteration, now.since_best, now.best = steps, stale, float(profit)
        if stop(now):
            break
        if not budget.fits(prep_s):
            break  # not even this step's model would be built in time (windows: seconds)
        step_t0 = time.perf_counter()
        steps += 1
        stale += 1  # until this step gains
        seed = int(active[rng.integers(len(active))])
        score = shared[seed, active] + 0.5 * rng.random(len(active))
        score[active == seed] = math.inf
        chosen = {int(j) for j in active[np.argsort(-score, kind="stable")[:k]]}

        fixed = [ob for ob in current if ob.orbit not in chosen]
        freed = [ob for ob in current if ob.orbit in chosen]
        sub_instance, slew = instance, "exact"
        use_window = p.neighbourhood == "window"
        if windowed:
            covered, w_sub = _weights_left(instance, fixed, weight)
            # the seed orbit's candidates first: where they alone pass max_items, the step
            # is a window of the seed orbit and the other orbits' are not made
            try:
                made = {seed: window_columns(seed, w_sub)}
                cols = _stack_columns([made[seed]], [ob for ob in freed if ob.orbit == seed])
                if not use_window and p.neighbourhood == "auto" and len(cols[4]) > p.max_items:
                    use_window = True
                if not use_window and len(chosen) > 1:
                    for j in sorted(chosen - {seed}):
                        made[j] = window_columns(j, w_sub)
            except _Late as late:
                # that orbit's columns would not be ready in time, now or later (the time
                # left only shrinks): the steps go on without it, over the orbits left
                active = active[active != late.args[0]]
                k = min(k, len(active))
                continue
            if len(made) > 1:
                everything = _stack_columns([made[j] for j in sorted(chosen)], freed)
                use_window = p.neighbourhood == "auto" and len(everything[4]) > p.max_items
                if not use_window:
                    cols = everything
            c_orbit, c_start, c_end, c_roll, c_opps = cols
            sel = np.arange(len(c_opps))
            useful = np.ones(len(sel), dtype=bool)
            seed_items = sel[c_orbit == seed]
        else:
            sel = np.concatenate([by_orbit[j] for j in sorted(chosen)])
            seed_items = by_orbit[seed]
            if not use_window:
                covered, w_sub = _weights_left(instance, fixed, weight)
                useful = _useful(instance, w_sub, freed, sel, ptr, flat_opps, flat_targets)
                use_window = p.neighbourhood == "auto" and int(useful.sum()) > p.max_items
        if use_window:
            plan = None
            if len(seed_items):
                cand = (c_start, c_end, c_roll)
                plan = _window_plan(instance, current, seed, seed_items, cand, rng, p.window)
            if plan is None:
                continue
            fixed, freed, sel, sub_instance = plan
            slew = "conservative"
            covered, w_sub = _weights_left(instance, fixed, weight)
            if windowed:
                useful = np.ones(len(sel), dtype=bool)
            else:
                useful = _useful(instance, w_sub, freed, sel, ptr, flat_opps, flat_targets)
        old_value = _claims_value(instance, freed, w_sub)
        sel = sel[useful]
        if not len(sel):
            continue
        # the model's data and arrays read no clock either (3 million members: 1.7 s, and a
        # 5 s run went to 7.4 s): a model foreseen past the deadline is not built
        members = int(np.diff(c_opps.ptr)[sel].sum())
        foreseen = build.seconds(members)
        if not budget.fits(foreseen):
            # this neighbourhood is skipped, not the search: the next step draws another,
            # often smaller; the time to this decision is what the next step must fit
            prep_s = time.perf_counter() - step_t0
            continue
        build_t0 = time.perf_counter()
        try:
            data = prepare(
                "cluster",
                sub_instance,
                c_orbit[sel],
                c_start[sel],
                c_end[sel],
                c_roll[sel],
                tuple(c_opps[int(u)] for u in sel),
                coverage=True,
            )
        except TimeUp:  # a stop request: the search ends with the schedule it has
            break
        data = replace(data, weight=w_sub)
        sizes.append(data.n_items)
        am = build_arrays(data, slew=slew)
        prep_s = time.perf_counter() - step_t0
        build.record(members, time.perf_counter() - build_t0)
        x0 = None
        if freed:
            vals = warm_start_values(data, Schedule(tuple(freed)))
            if vals is not None:
                x0 = start_vector(am, vals)
        out = run_highs(
            am,
            time_limit=max(budget.child(p.sub_time_limit).left(), 0.01),
            threads=p.threads,
            start=x0,
            probing=False,  # probing checks HiGHS's clock rarely: 43 s under a 4.9 s limit
        )
        if out.x is None:
            continue
        sub = items_to_schedule(instance, data, [int(u) for u in np.flatnonzero(out.x > 0.5)])
        new = []
        for ob in sub.observations:
            # a target observed on a fixed orbit is worth 0 here: never claim it twice (2)
            mine = tuple(i for i in ob.opps if int(instance.opp_target[i]) not in covered)
            if mine:
                new.append(replace(ob, opps=mine))
        new_value = _claims_value(instance, new, w_sub)
        if new_value < old_value:
            continue
        current = sorted(fixed + new, key=lambda ob: (ob.orbit, ob.start))
        if new_value > old_value:
            profit += new_value - old_value
            improved += 1
            stale = 0
            trace.append([steps, round(time.perf_counter() - t0, 4), float(profit)])
            log.debug("milp-lns step %d: profit %d (%d items)", steps, profit, data.n_items)

    schedule = Schedule(tuple(current))
    observed = len({int(instance.opp_target[i]) for i in schedule.observed_opps()})
    stats = {
        "start": start_name,
        "start_profit": float(start_profit),
        "steps_improved": improved,
        "orbits_per_step": k,
        "mean_items": round(float(np.mean(sizes)), 1) if sizes else 0.0,
        "max_items": int(max(sizes)) if sizes else 0,
        "candidates": 0 if windowed else len(c_opps),
        "candidate_mode": "windows" if windowed else "explicit",
        "trace": trace,
    }
    runtime = time.perf_counter() - t0
    return Result(
        "milp-lns", Status.FEASIBLE, schedule, float(profit), observed, runtime, None, steps, stats
    )
