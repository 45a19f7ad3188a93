"""The single-orbit ascent: the search state of ``orbit-dp`` whose move is the exact re-planning
of one orbit, shared by the method (:mod:`heuristics.orbit_search`), its starts and the exact
models' heuristic start and bounds (:mod:`models.solve`, :mod:`models.lagrangian`).

Given the plans of the other orbits, the best plan of orbit j is the optimum of a single-orbit
problem: targets observed elsewhere are worth nothing, the others their weight p_k, and (3)-(6)
hold on j alone. :func:`sosp.planner.best_feasible_path` solves it by dynamic programming
over the cluster model's candidate observations (exactly while (4)-(5) do not bind).
:meth:`OrbitSearch.ascent` re-plans orbits, in random order, until no re-plan gains;
:meth:`OrbitSearch.perturb` re-plans a few orbits at noisy prices; a step is journalled so
that :meth:`OrbitSearch.undo` costs what the step changed.

Where the candidates would not fit in memory, :class:`WindowSearch` is the same search, whose
re-plan prices the orbit's windows at the re-plan's prices (:mod:`sosp.windows`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from sosp.candidates import CandidateMode, as_budget, offsets, orbit_pairs
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import Params, from_kwargs, param
from sosp.planner import OrbitData, best_feasible_path
from sosp.progress import current as current_progress
from sosp.schedule import Schedule, items_to_schedule
from sosp.stop import Budget, FirstOf, Foresight, Interrupted, SearchStatus

if TYPE_CHECKING:
    from sosp.windows import OrbitOpps

#: No time limit (a stop request still ends an ascent).
UNLIMITED = Budget()

#: Starts of the search (:attr:`OrbitSearchParams.start`).
StartMode = Literal["auto", "lp", "hpfs", "empty"]
START_MODES = get_args(StartMode)


@dataclass(frozen=True)
class OrbitSearchParams(Params):
    """Parameters of :func:`heuristics.orbit_search.solve_orbit_dp`.

    Parameters
    ----------
    perturb_orbits
        Most orbits re-planned with noisy prices per step (1 to this, uniformly).
    noise
        Relative price noise of a perturbation, in [0, 1).
    steal
        Probability that a target observed on another orbit keeps its weight in a
        perturbation, in [0, 1].
    iterations
        Stop after this many steps (None: no limit from this rule).
    no_improve
        Stop after this many steps in a row without a new best (None: no limit from this
        rule; with no limit at all it is 500).
    workers
        Processes generating the orbits' candidate observations side by side (the search's
        re-plans depend on one another and run in one process; the result is the same).
    start
        ``"lp"``: the search starts from the plans of the column-generation root
        (``lp_start`` of :mod:`heuristics.orbit_search`, within a share of the time limit;
        with window candidates, the window relaxation's root); ``"hpfs"`` (window
        candidates only): from HPFS-STC's schedule (``hpfs_start``, when foreseen to fit in
        the time left, else as ``"lp"``); ``"empty"``: from
        the empty schedule; ``"auto"`` (default): ``"lp"`` with explicit candidates; with
        window candidates HPFS-STC's schedule, then the root's plans on their orbits when
        the root's share has time left and they do not lower the profit. When HPFS-STC's
        schedule is the start (the root made no round, or its plans were undone), the
        search also ascends from nothing where that is foreseen to fit, and goes on from
        the higher (``ascend_from_both``).
    candidates
        ``"explicit"``: every candidate observation, made once (:mod:`sosp.candidates`);
        ``"windows"``: none made up front, each re-plan prices the orbit's windows at its
        prices and plans over the real observations of the argmax rolls
        (:func:`sosp.windows.window_plan`, a restricted set); ``"auto"`` (default):
        explicit unless they would not fit in the solve's memory
        (``sosp.candidates.candidate_cap``, a third of ``--max-memory``).
    dask
        Plan the orbits of the start's pricing rounds (``lp_start``) on a Dask cluster:
        a scheduler's address, or ``"local"`` (``workers`` processes on this machine, one
        per core when ``workers`` is 1); None (default): ``workers`` processes here. The
        search's own re-plans stay in this process. Where it pays: ``docs/scenarios.md``.
    """

    perturb_orbits: int = param(2, "Most orbits re-planned with noisy prices per step.")
    noise: float = param(0.5, "Relative price noise of a perturbation, in [0, 1).")
    steal: float = param(0.3, "Probability a target observed elsewhere keeps its weight.")
    iterations: int | None = param(None, "Stop after this many steps (None: no limit).")
    no_improve: int | None = param(None, "Stop after this many steps without a new best.")
    workers: int = param(1, "Processes generating the candidates side by side.")
    start: StartMode = param("auto", "Where the search starts (lp: the column-generation root).")
    candidates: CandidateMode = param("auto", "Candidates: made up front or priced per window.")
    dask: str | None = param(None, "Dask scheduler's address or 'local' (lp start).")

    def check(self) -> None:
        # the types are checked already (sosp.params.check_types): the ranges are left
        if self.dask == "":
            raise InputError("dask: expected 'local' or a scheduler address, got ''")
        for name in ("perturb_orbits", "iterations", "no_improve", "workers"):
            value = getattr(self, name)
            if value is not None and value < 1:
                raise InputError(f"{name}: expected a positive integer, got {value!r}")
        if not 0 <= self.noise < 1:
            raise InputError(f"noise: expected a number in [0, 1), got {self.noise!r}")
        if not 0 <= self.steal <= 1:
            raise InputError(f"steal: expected a number in [0, 1], got {self.steal!r}")

    @classmethod
    def from_kwargs(cls, **params: Any) -> OrbitSearchParams:
        """Build from keyword parameters (CLI strings coerced from the type hints)."""
        return from_kwargs(cls, params, method="orbit-dp")


class OrbitSearch:
    """The search state: one plan per orbit, coverage counts, profit, and the step journal.

    Parameters
    ----------
    data
        Candidates arranged per orbit.
    rng
        The one generator (orbit order, perturbations).
    """

    def __init__(self, data: OrbitData, rng: np.random.Generator) -> None:
        self.data = data
        self.rng = rng
        self.weight = np.asarray(data.instance.target_weight, dtype=float)
        self.paths: list[np.ndarray] = [np.zeros(0, dtype=np.int64) for _ in data.orbits]
        self.covered: list[np.ndarray] = [np.zeros(0, dtype=np.int64) for _ in data.orbits]
        self.count = np.zeros(len(self.weight), dtype=np.int64)
        #: per target, the XOR of (index + 1) of the orbits whose plans cover it: with one
        #: coverer, that coverer's index + 1 (:meth:`_set`)
        self.owners = np.zeros(len(self.weight), dtype=np.int64)
        self.profit = 0.0
        self.dirty = np.ones(len(data.orbits), dtype=bool)
        self.journal: list[tuple[int, np.ndarray]] = []
        self.replans = 0
        # each orbit's last planning time, and the last timed plan's seconds per unit of
        # :meth:`_work` (plans get cheaper as the search covers targets: with the most rate
        # seen instead, orbit-dp on a polar box at 20 s gave 21,394 against 30,724)
        self.plans = Foresight(self.PLAN_S_PER_WORK, min_work=self.RATE_FROM_WORK)

    # ------------------------------------------------------------------ state changes
    def _set(self, g: int, path: np.ndarray) -> None:
        """Replace orbit g's plan (journalled), update coverage, profit and dirty flags.

        An orbit h is marked dirty only where its re-plan may now gain: where the price of a
        target changed against h's plan. A target g drops that nobody else covers rises to
        p_k for every orbit seeing it (a plan without it may now take it); a target g takes
        from its sole other coverer h falls to 0 for h (h's plan lost value). The other
        changes cannot make a re-plan gain: a target that g newly covers falls to 0 only for
        orbits whose plans do not hold it (their plans keep their value, no other plan gains),
        and a target g drops that one orbit h still covers rises for h on a target its plan
        holds (its plan gains as much as any other could). Marking instead every orbit that
        sees a changed target re-plans many orbits that cannot gain (``docs/scenarios.md``,
        "orbit-dp's ascent").
        """
        old = self.covered[g]
        new = self._covered(g, path)
        self.journal.append((g, self.paths[g]))
        dropped = np.setdiff1d(old, new, assume_unique=True)
        added = np.setdiff1d(new, old, assume_unique=True)
        self.count[dropped] -= 1
        self.owners[dropped] ^= g + 1
        lost = dropped[self.count[dropped] == 0]
        gained = added[self.count[added] == 0]
        # with one coverer, owners holds its index + 1
        taken_from = np.unique(self.owners[added[self.count[added] == 1]]) - 1
        self.count[added] += 1
        self.owners[added] ^= g + 1
        self.profit += float(self.weight[gained].sum()) - float(self.weight[lost].sum())
        self.paths[g], self.covered[g] = path, new
        if len(lost):
            self.dirty[self.data.orbits_seeing(lost)] = True
        self.dirty[taken_from] = True
        self.dirty[g] = False

    def undo(self, mark: int) -> None:
        """Roll back every plan change journalled after position ``mark``."""
        while len(self.journal) > mark:
            g, path = self.journal.pop()
            self._set(g, path)
            self.journal.pop()  # _set journalled the undo itself

    def elsewhere(self, g: int) -> np.ndarray:
        """Per target, whether an orbit other than g covers it."""
        others = self.count.copy()
        others[self.covered[g]] -= 1
        return others > 0

    def prices(self, g: int) -> np.ndarray:
        """What covering each target is worth to orbit g: p_k unless another orbit has it."""
        return np.where(self.elsewhere(g), 0.0, self.weight)

    def _plan(self, g: int, price: np.ndarray) -> Any:
        """A feasible plan of orbit g at ``price`` (the exact re-planning)."""
        return best_feasible_path(self.data.orbits[g], price)

    def _covered(self, g: int, path: Any) -> np.ndarray:
        """The distinct targets plan ``path`` of orbit g covers."""
        return self.data.orbits[g].covered(path)

    # ------------------------------------------------------------------------- moves
    #: Seconds per unit of :meth:`_work` foreseen for an orbit's plan before any was timed
    #: (none for the explicit candidates' recursion: milliseconds an orbit).
    PLAN_S_PER_WORK = 0.0
    #: Plans of less work set no rate: their fixed costs dominate (an empty orbit's plan,
    #: 40 us for no work, made every orbit of a dense instance look late).
    RATE_FROM_WORK = 1_000.0

    def _work(self, g: int) -> float:
        """The size that orbit g's planning time grows with (:meth:`foreseen`)."""
        return float(len(self.data.orbits[g].items))

    def foreseen(self, g: int) -> float:
        """Seconds a plan of orbit g is foreseen to take: its own last time, else its
        :meth:`_work` at the last timed plan's rate, none timed yet at
        :attr:`PLAN_S_PER_WORK` (:class:`sosp.stop.Foresight`)."""
        return self.plans(g, self._work(g))

    def _late(self, g: int, budget: Budget) -> bool:
        return not budget.fits(self.foreseen(g))

    def _timed_plan(self, g: int, price: np.ndarray) -> Any:
        t = time.perf_counter()
        path = self._plan(g, price)
        self.plans.record(g, self._work(g), time.perf_counter() - t)
        return path

    def replan(self, g: int) -> bool:
        """Re-plan orbit g optimally for the current prices; True when it gained."""
        self.replans += 1
        price = self.prices(g)
        path = self._timed_plan(g, price)
        new_value = float(price[self._covered(g, path)].sum())
        if new_value > float(price[self.covered[g]].sum()) + 1e-9:
            self._set(g, path)
            return True
        self.dirty[g] = False
        return False

    def ascent(self, budget: Budget = UNLIMITED) -> None:
        """Re-plan dirty orbits in random order until none gains (or the ``budget`` expires,
        or a stop is requested: :func:`sosp.stop.request_stop`).

        Both are checked before each orbit, not after each pass: one pass over a dense
        instance's orbits takes seconds, and a partial ascent leaves a feasible schedule
        (each re-plan keeps its orbit feasible). An orbit whose plan is foreseen not to fit
        in the budget (:meth:`foreseen`) is skipped: one plan over windows of a dense orbit
        takes seconds. The ascent ends when a pass plans none.
        """
        while self.dirty.any():
            planned = False
            for g in self.rng.permutation(np.flatnonzero(self.dirty)):
                if budget.expired():
                    return
                if self.dirty[g] and not self._late(int(g), budget):
                    self.replan(int(g))
                    planned = True
            if not planned:
                return

    def perturb(self, params: OrbitSearchParams, budget: Budget = UNLIMITED) -> None:
        """Re-plan 1..perturb_orbits random orbits with noisy prices (always applied; an
        orbit foreseen not to fit in ``budget`` is left as it is)."""
        n = len(self.data.orbits)
        k = int(self.rng.integers(1, min(params.perturb_orbits, n) + 1))
        for g in self.rng.choice(n, size=k, replace=False):
            g = int(g)
            keep = ~self.elsewhere(g) | (self.rng.random(len(self.weight)) < params.steal)
            noise = self.rng.uniform(1.0 - params.noise, 1.0 + params.noise, len(self.weight))
            price = np.where(keep, self.weight * noise, 0.0)
            if not self._late(g, budget):
                self._set(g, self._timed_plan(g, price))

    def chosen(self) -> list[int]:
        """Global candidate indices of the current plans."""
        return [
            int(o.items[u])
            for o, path in zip(self.data.orbits, self.paths, strict=True)
            for u in path
        ]

    def set_chosen(self, items: Sequence[int]) -> None:
        """Make ``items`` (global candidate indices, as :meth:`chosen` gives them) the plans
        of their orbits, to go on from (not journalled: nothing to undo to)."""
        if not len(items):
            return
        orbits = self.data.orbits
        flat = np.concatenate([o.items for o in orbits])
        orbit_of = np.repeat(np.arange(len(orbits)), [len(o.items) for o in orbits])
        position = np.concatenate([np.arange(len(o.items)) for o in orbits])
        order = np.argsort(flat, kind="stable")
        at = order[np.searchsorted(flat[order], np.asarray(items, dtype=np.int64))]
        mark = len(self.journal)
        for g in np.unique(orbit_of[at]):
            # positions in time order: an orbit's items are sorted by start and end
            self._set(int(g), np.sort(position[at[orbit_of[at] == g]]))
        del self.journal[mark:]

    def schedule(self) -> Schedule:
        """The schedule of the current plans."""
        return items_to_schedule(self.data.instance, self.data, self.chosen())


@dataclass(frozen=True, eq=False)
class WindowData:
    """Every orbit's opportunities (no candidates), for :class:`WindowSearch`."""

    instance: Instance
    orbits: tuple[OrbitOpps, ...]
    target_orbits_ptr: np.ndarray
    target_orbits: np.ndarray

    n_items = 0

    @classmethod
    def build(cls, instance: Instance) -> WindowData:
        from sosp.windows import orbit_opps  # numba's import only where it is used

        orbits = tuple(orbit_opps(instance, j) for j in range(instance.n_orbits))
        tgt = np.asarray(instance.opp_target, dtype=np.int64)
        orb = np.asarray(instance.opp_orbit, dtype=np.int64)
        order = np.lexsort((orb, tgt))
        pairs = np.unique(np.stack((tgt[order], orb[order]), axis=1), axis=0)
        ptr = offsets(np.bincount(pairs[:, 0], minlength=instance.n_targets))
        return cls(instance, orbits, ptr, pairs[:, 1].copy())

    #: The orbits with an opportunity of any of the targets given (the same lists).
    orbits_seeing = OrbitData.orbits_seeing


class WindowSearch(OrbitSearch):
    """:class:`OrbitSearch` whose re-plan prices the orbit's windows at its prices and plans
    over the real observations of the argmax rolls (:func:`sosp.windows.window_plan`): no
    candidate list, so it runs where the explicit candidates do not fit in memory. A plan is a
    :class:`sosp.windows.WindowPlan`."""

    def __init__(self, data: WindowData, rng: np.random.Generator) -> None:
        from sosp.windows import empty_plan, window_plan

        super().__init__(data, rng)  # type: ignore[arg-type]
        self._window_plan = window_plan
        self.paths = [empty_plan() for _ in data.orbits]  # type: ignore[misc]

    #: One plan over windows took 0.08-0.24 us per (first, covered) pair of the orbit
    #: inside one Delta T (2-core machine, the densest and a middle orbit of four drawn
    #: instances of 2,500-10,000 targets: 0.02-6.5 s a plan); the most of them.
    PLAN_S_PER_WORK = 0.25e-6
    RATE_FROM_WORK = 100_000.0

    def _work(self, g: int) -> float:
        j = self.data.orbits[g].orbit  # type: ignore[attr-defined]
        return float(orbit_pairs(self.data.instance, j))

    def _plan(self, g: int, price: np.ndarray) -> Any:
        return self._window_plan(self.data.orbits[g], price)  # type: ignore[arg-type]

    def _covered(self, g: int, path: Any) -> np.ndarray:
        return path.targets

    def set_schedule(self, schedule: Schedule) -> None:
        """Set each orbit's plan to ``schedule``'s observations on it (a feasible schedule:
        each orbit's observations are a feasible plan, as a re-plan's are)."""
        from sosp.candidates import OppGroups
        from sosp.windows import WindowPlan

        by_orbit: dict[int, list[Any]] = {}
        for ob in schedule.observations:
            by_orbit.setdefault(int(ob.orbit), []).append(ob)
        target = np.asarray(self.data.instance.opp_target, dtype=np.int64)
        for g, obs in sorted(by_orbit.items()):
            obs.sort(key=lambda ob: ob.start)
            opps = OppGroups.from_groups([ob.opps for ob in obs])
            cols = (
                np.array([getattr(ob, k) for ob in obs], float) for k in ("start", "end", "roll")
            )
            self._set(g, WindowPlan(*cols, opps, np.unique(target[opps.flat])))
        self.journal.clear()
        # a plan set from outside is no optimum at the search's prices (_set assumed so): the
        # ascent must re-plan every orbit, each only where it gains (left clean, HPFS-STC's
        # orbits were never re-planned: world4-3 at 5 s, 4,249 from HPFS-STC at the end of
        # the first ascent, the same as before it)
        self.dirty[:] = True

    def schedule(self) -> Schedule:
        obs = []
        for g, plan in enumerate(self.paths):
            for u in range(plan.size):  # type: ignore[attr-defined]
                p: Any = plan
                obs.append((g, p.start[u], p.end[u], p.roll[u], p.opps[u]))
        # observation columns as sosp.schedule.items_to_schedule reads them
        cols = SimpleNamespace(
            orbit=np.array([o[0] for o in obs], dtype=np.int64),
            start=np.array([o[1] for o in obs], dtype=float),
            end=np.array([o[2] for o in obs], dtype=float),
            roll=np.array([o[3] for o in obs], dtype=float),
            opps=[o[4] for o in obs],
        )
        return items_to_schedule(self.data.instance, cols, range(len(obs)))


@dataclass
class IlsRun:
    """What :func:`iterate` found: the best plans, their profit, and the run's counters."""

    best_profit: float
    best_paths: list[Any]
    ascent_profit: float
    steps: int
    accepted: int
    trace: list[tuple[int, float, float]]


def iterate(
    search: OrbitSearch,
    p: OrbitSearchParams,
    stop: Callable[[SearchStatus], bool],
    budget: Budget | float | None,
    t0: float,
    *,
    report: bool = True,
) -> IlsRun:
    """The iterated local search of ``orbit-dp`` on ``search``: the ascent, then perturb,
    ascend and accept (a step worth at least the current profit; else undone) until
    ``stop`` says so (and, with ``report``, a stop request; the solve's progress is
    reported at each check). The search is left at its last accepted state, the best plans
    are returned. Shared by ``orbit-dp`` (:mod:`heuristics.orbit_search`), ASA-DTC's start
    (``init="orbit-dp"``) and the exact models' heuristic start (:mod:`models.solve`).
    ``budget`` bounds the re-plans (:func:`sosp.candidates.as_budget`)."""
    budget = as_budget(budget)
    search.ascent(budget)
    first = search.profit
    best_profit, best_paths = search.profit, list(search.paths)
    trace = [(0, round(time.perf_counter() - t0, 4), best_profit)]
    steps = accepted = since = 0
    if report:
        stop = FirstOf(current_progress(), Interrupted(), stop)
    now = SearchStatus()
    while search.data.orbits:
        now.iteration, now.since_best, now.best = steps, since, best_profit
        if stop(now):
            break
        steps += 1
        since += 1
        mark, before = len(search.journal), search.profit
        search.perturb(p, budget)
        search.ascent(budget)
        if search.profit + 1e-9 >= before:
            accepted += 1
            search.journal.clear()
            if search.profit > best_profit + 1e-9:
                best_profit, best_paths, since = search.profit, list(search.paths), 0
                trace.append((steps, round(time.perf_counter() - t0, 4), best_profit))
        else:
            search.undo(mark)
            search.journal.clear()
    return IlsRun(best_profit, best_paths, first, steps, accepted, trace)


def ascent_profit(data: OrbitData, seed: int = 0) -> float:
    """Profit of one ascent from the empty schedule (a quick lower bound)."""
    search = OrbitSearch(data, np.random.default_rng(seed))
    search.ascent()
    return search.profit
