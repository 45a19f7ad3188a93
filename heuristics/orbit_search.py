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
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np

from sosp.candidates import CandidateMode, candidate_mode, orbit_pairs
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.parallel import workers_for
from sosp.params import Params, from_kwargs, param
from sosp.planner import OrbitData, best_feasible_path, orbit_data
from sosp.progress import current as current_progress
from sosp.result import Result, Status
from sosp.schedule import Schedule, items_to_schedule

if TYPE_CHECKING:
    from sosp.parallel import Workers
    from sosp.windows import OrbitOpps

from sosp.stop import (
    FirstOf,
    Foresight,
    Interrupted,
    MaxIterations,
    MaxRuntime,
    NoImprovement,
    SearchStatus,
    StoppingCriterion,
    stop_requested,
)

log = logging.getLogger(__name__)

#: Steps without a gain after which the search stops when no other limit is given.
DEFAULT_NO_IMPROVE = 500

#: Starts of the search (:attr:`OrbitSearchParams.start`).
StartMode = Literal["auto", "lp", "hpfs", "empty"]
START_MODES = get_args(StartMode)

#: Seconds per opportunity foreseen for :func:`hpfs_start` (static clustering and the
#: insertion, pure Python, one pass each, then the plans set): about twice the most
#: measured inside ``sosp solve``, 2-core machine, drawn instances of up to 65,416
#: opportunities (6.3 us on a 10,000-target polar box, 0.39 s; before the static
#: clustering's loop was tightened, 31-37 us there).
HPFS_S_PER_OPP = 1.5e-5

#: Share of the time left (after the candidates' mode is decided: 2 s of a 5 s limit on a
#: 10,000-target polar box) that :func:`hpfs_start` may be foreseen to take; past it the
#: search starts as ``"lp"`` would. Most of it: on the densest instances the search over
#: windows from any other start stays far below HPFS-STC's schedule (that box at 5 s:
#: 6,962 from the LP start, 37,460 from HPFS-STC's 30,276 in 1.35 s).
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


@dataclass(frozen=True)
class OrbitSearchParams(Params):
    """Parameters of :func:`solve_orbit_dp`.

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
        (:func:`lp_start`, at most :data:`LP_START_SHARE` of the time limit; with window
        candidates, the window relaxation's root); ``"hpfs"`` (window candidates only):
        from HPFS-STC's schedule (:func:`hpfs_start`, when foreseen within
        :data:`HPFS_START_SHARE` of the time left, else as ``"lp"``); ``"empty"``: from
        the empty schedule; ``"auto"`` (default): ``"lp"`` with explicit candidates; with
        window candidates HPFS-STC's schedule, then the root's plans on their orbits when
        the root's share has time left and they do not lower the profit. When HPFS-STC's
        schedule is the start (the root made no round, or its plans were undone), the
        search also ascends from nothing where that is foreseen to fit, and goes on from
        the higher (:func:`ascend_from_both`).
    candidates
        ``"explicit"``: every candidate observation, made once (:mod:`sosp.candidates`);
        ``"windows"``: none made up front, each re-plan prices the orbit's windows at its
        prices and plans over the real observations of the argmax rolls
        (:func:`sosp.windows.window_plan`, a restricted set); ``"auto"`` (default):
        explicit unless they would take more than ``sosp.candidates.MAX_CANDIDATE_BYTES``.
    dask
        Plan the orbits of the start's pricing rounds (:func:`lp_start`) on a Dask cluster:
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
        if self.dask is not None and (not isinstance(self.dask, str) or not self.dask):
            raise InputError(f"dask: expected 'local' or a scheduler address, got {self.dask!r}")
        for name in ("perturb_orbits", "iterations", "no_improve", "workers"):
            value = getattr(self, name)
            if value is None and name not in ("perturb_orbits", "workers"):
                continue
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise InputError(f"{name}: expected a positive integer, got {value!r}")
        for name, upper_open in (("noise", True), ("steal", False)):
            value = getattr(self, name)
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            ok = ok and math.isfinite(value) and value >= 0
            ok = ok and (value < 1 if upper_open else value <= 1)
            if not ok:
                interval = "[0, 1)" if upper_open else "[0, 1]"
                raise InputError(f"{name}: expected a number in {interval}, got {value!r}")

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

    def _late(self, g: int, deadline: float | None) -> bool:
        return self.plans.late(g, self._work(g), deadline)

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

    def ascent(self, deadline: float | None = None) -> None:
        """Re-plan dirty orbits in random order until none gains (or the deadline passes, or a
        stop is requested: :func:`sosp.stop.request_stop`).

        Both are checked before each orbit, not after each pass: one pass over a dense
        instance's orbits takes seconds (walker12-1500: 0.8 s; worldwide ones: minutes), and
        a partial ascent leaves a feasible schedule (each re-plan keeps its orbit feasible).
        An orbit whose plan is foreseen to end past the deadline (:meth:`foreseen`) is
        skipped: one plan over windows of an orbit of 8,191 opportunities takes seconds, and
        a 1 s ``orbit-dp`` ran 2.8 s. The ascent ends when a pass plans none.
        """
        while self.dirty.any():
            planned = False
            for g in self.rng.permutation(np.flatnonzero(self.dirty)):
                if deadline is not None and time.perf_counter() > deadline:
                    return
                if stop_requested():
                    return
                if self.dirty[g] and not self._late(int(g), deadline):
                    self.replan(int(g))
                    planned = True
            if not planned:
                return

    def perturb(self, params: OrbitSearchParams, deadline: float | None = None) -> None:
        """Re-plan 1..perturb_orbits random orbits with noisy prices (always applied; an
        orbit foreseen to end past ``deadline`` is left as it is)."""
        n = len(self.data.orbits)
        k = int(self.rng.integers(1, min(params.perturb_orbits, n) + 1))
        for g in self.rng.choice(n, size=k, replace=False):
            g = int(g)
            keep = ~self.elsewhere(g) | (self.rng.random(len(self.weight)) < params.steal)
            noise = self.rng.uniform(1.0 - params.noise, 1.0 + params.noise, len(self.weight))
            price = np.where(keep, self.weight * noise, 0.0)
            if not self._late(g, deadline):
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
        ptr = np.zeros(instance.n_targets + 1, dtype=np.int64)
        ptr[1:] = np.cumsum(np.bincount(pairs[:, 0], minlength=instance.n_targets))
        return cls(instance, orbits, ptr, pairs[:, 1].copy())

    def orbits_seeing(self, targets: np.ndarray) -> np.ndarray:
        """The orbits with an opportunity of any of ``targets``."""
        if len(targets) == 0:
            return np.zeros(0, dtype=np.int64)
        ptr = self.target_orbits_ptr
        return np.unique(np.concatenate([self.target_orbits[ptr[k] : ptr[k + 1]] for k in targets]))


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
            plan = WindowPlan(
                start=np.array([ob.start for ob in obs], dtype=float),
                end=np.array([ob.end for ob in obs], dtype=float),
                roll=np.array([ob.roll for ob in obs], dtype=float),
                opps=opps,
                targets=np.unique(target[opps.flat]),
            )
            self._set(g, plan)
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
        cols = _Columns(
            orbit=np.array([o[0] for o in obs], dtype=np.int64),
            start=np.array([o[1] for o in obs], dtype=float),
            end=np.array([o[2] for o in obs], dtype=float),
            roll=np.array([o[3] for o in obs], dtype=float),
            opps=[o[4] for o in obs],
        )
        return items_to_schedule(self.data.instance, cols, range(len(obs)))


@dataclass(frozen=True)
class _Columns:
    """Observation columns as :func:`sosp.schedule.items_to_schedule` reads them."""

    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: list[tuple[int, ...]]


def ascent_profit(data: OrbitData, seed: int = 0) -> float:
    """Profit of one ascent from the empty schedule (a quick lower bound)."""
    search = OrbitSearch(data, np.random.default_rng(seed))
    search.ascent()
    return search.profit


def lp_start(
    search: OrbitSearch,
    deadline: float | None,
    workers: Workers = 1,
    keep: bool = False,
    plan_deadline: float | None = None,
) -> dict[str, Any]:
    """Set each orbit's plan from the fractional schedule of the column-generation root.

    The root of :func:`models.colgen.colgen_bound` (the Dantzig-Wolfe master of the cluster
    model over orbit plans, priced by the same planner; for a :class:`WindowSearch`, the
    window relaxation's, :func:`models.window_bound.window_colgen_bound`) is solved until
    it converges or ``deadline`` passes (or, when its first round shows that
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

    An orbit's re-plan foreseen to end past ``plan_deadline`` (the run's own limit; the
    root's ``deadline`` is only its share) is not made, and the orbit keeps its plan: over
    windows one re-plan of a dense orbit takes seconds.

    Returns the start's figures (rounds, seconds, the master's value, the profit set, and
    ``lp_kept``: whether the root's plans went in and stayed).
    """
    t0 = time.perf_counter()
    instance = search.data.instance
    left = None if deadline is None else max(deadline - t0, 1e-3)
    if isinstance(search, WindowSearch):
        from models.window_bound import window_colgen_bound

        root = window_colgen_bound(
            instance,
            time_limit=left,
            expect_rounds=LP_START_ROUNDS,
            orbits=search.data.orbits,
            workers=workers,
            # unbanded: a banded round is 3-4 times longer (D100: 16 s against 5 s), and
            # LP_START_ROUNDS of them do not fit in the start's share; the start's plans are
            # re-planned by the search anyway, only their coordination counts
            band=None,
        )
    else:
        from models.colgen import colgen_bound

        root = colgen_bound(
            instance,
            time_limit=left,
            data=search.data,
            workers=workers,
            expect_rounds=LP_START_ROUNDS,
        )
    best: dict[int, tuple[float, np.ndarray]] = {}
    mark, before = len(search.journal), search.profit
    for g, targets, value, _, _ in root.get("plans", []):
        if g not in best or value > best[g][0]:
            best[g] = (value, targets)
    for g, (_, targets) in sorted(best.items()):
        price = np.zeros(len(search.weight))
        if search._late(g, plan_deadline):
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


def hpfs_start(search: WindowSearch, deadline: float | None) -> dict[str, Any]:
    """Set each orbit's plan from HPFS-STC's schedule (:func:`heuristics.hpfs.solve_hpfs_stc`:
    static cluster-tasks by decreasing weight, each inserted when feasible), unless it is
    foreseen (:data:`HPFS_S_PER_OPP`) to take more than :data:`HPFS_START_SHARE` of the
    time left before ``deadline`` (the run's end).

    Why: over windows one plan of a dense orbit takes seconds (a 10,000-target polar box:
    up to 6.5 s), so at short limits the ascent from nothing plans a few orbits and leaves
    the rest empty, while HPFS-STC fills every orbit in under half a second (0.39 s on
    61,223 opportunities). The ascent then re-plans orbits against that schedule, each only
    where it gains.

    Returns the start's figures (seconds, the profit set; none when foreseen late).
    """
    t0 = time.perf_counter()
    instance = search.data.instance
    left = None if deadline is None else max(deadline - t0, 0.0)
    if left is not None and HPFS_S_PER_OPP * instance.n_opps > HPFS_START_SHARE * left:
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
    search: OrbitSearch, deadline: float | None, started: dict[str, Any] | None = None
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
    one is higher depends on the instance. From HPFS-STC's schedule (static cluster-tasks,
    inserted by weight) the orbits keep its assignment of targets to orbits; from nothing the
    first orbits re-planned take whole dense strips. On the drawn instances of 1,200 to
    5,000 targets where both were made, either ended higher, by instance and seed (world4-4
    at 5 s: 13,901 from HPFS-STC's and 13,963 from nothing at seed 0, 13,821 and 14,112 at
    seed 1; world4-3: 6,564 and 6,645, then 6,464 and 6,310); on G100k at 290 s, from nothing
    585,092 (2026-11-27), from HPFS-STC's alone 578,426. Where a pass does not fit (a
    10,000-target polar box at 5 s: one plan of its densest orbit takes seconds, the ascent
    from nothing ends at a fifth of the other) only HPFS-STC's is made.

    Both searches draw from the one generator in turn, so a seed gives one result. The
    second search takes the first's foresight (its measured planning times).
    """
    if started is not None and (started.get("hpfs_profit") is None or started.get("lp_kept")):
        return search, {}
    search.ascent(deadline)
    first = search.profit
    now = time.perf_counter()
    pass_s = sum(search.foreseen(g) for g in range(len(search.paths)))
    figures: dict[str, Any] = {"hpfs_ascent": first, "empty_ascent": None}
    if deadline is not None and pass_s > SECOND_ASCENT_SHARE * (deadline - now):
        return search, figures
    other = type(search)(search.data, search.rng)
    other.plans = search.plans
    other.ascent(deadline)
    figures["empty_ascent"] = other.profit
    figures["empty_ascent_s"] = round(time.perf_counter() - now, 4)
    if other.profit > first + 1e-9:
        other.replans += search.replans
        return other, figures
    search.replans += other.replans
    return search, figures


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
    stop: StoppingCriterion,
    deadline: float | None,
    t0: float,
) -> IlsRun:
    """Steps 1-3 of the module docstring on ``search`` (ascent, then perturb / ascend /
    accept until ``stop``, a stop request or the progress says so); the search is left at
    its last accepted state, the best plans are returned. Shared by ``orbit-dp`` and
    ASA-DTC's start (``init="orbit-dp"``)."""
    search.ascent(deadline)
    first = search.profit
    best_profit, best_paths = search.profit, list(search.paths)
    trace = [(0, round(time.perf_counter() - t0, 4), best_profit)]
    steps = accepted = since = 0
    stop = FirstOf(current_progress(), Interrupted(), stop)
    now = SearchStatus()
    while search.data.orbits:
        now.iteration, now.since_best, now.best = steps, since, best_profit
        if stop(now):
            break
        steps += 1
        since += 1
        mark, before = len(search.journal), search.profit
        search.perturb(p, deadline)
        search.ascent(deadline)
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


#: With ``candidates="auto"`` and a time limit, the explicit candidates must be generated and
#: arranged within this share of it, else the search plans over windows in the rest. Where
#: they take longer, the windows win or the run failed: at 5, 10, 20 s, D30 (3,000 targets)
#: windows 8842, 8886, 8894 against explicit 8810, exit 2, 8836; walker12-1500 at 5 s
#: windows 8061 against exit 2 (at 10 and 20 s, where its candidates take 8.7 s, windows
#: 8144 and 8322 against 8199 and 8363). Where they are quick (B10, C10) explicit is better.
EXPLICIT_SHARE = 0.75

#: ... and generated within this share of it (arranging them takes about as long again:
#: D30 7.6 s and 8.2 s), so that the generation's foresight gives up early, with most of the
#: limit left for the windows.
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
        plans over windows where the candidates would take more than
        ``sosp.candidates.MAX_CANDIDATE_BYTES`` (estimated before any is generated; 3,000
        targets in the C region take 0.4 GB) or are not generated within
        :data:`GENERATE_SHARE` and arranged within :data:`EXPLICIT_SHARE` of the limit
        (foreseen early:
        :func:`sosp.candidates.cluster_candidates`); with ``candidates="explicit"`` both
        are :class:`InputError` (C10, the densest reference scenario, needs about 5 s).
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
    deadline = None if time_limit is None else t0 + float(time_limit)
    iterations, no_improve = p.iterations, p.no_improve
    if iterations is None and no_improve is None and time_limit is None:
        no_improve = DEFAULT_NO_IMPROVE
    mode = candidate_mode(instance, p.candidates, deadline)
    search: OrbitSearch
    data: Any = None
    if mode == "explicit":
        until = generate_by = deadline
        if p.candidates == "auto" and time_limit is not None:
            until = t0 + EXPLICIT_SHARE * float(time_limit)
            generate_by = t0 + GENERATE_SHARE * float(time_limit)
        try:
            data = orbit_data(instance, until, workers=p.workers, generate_by=generate_by)
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
        started = hpfs_start(search, deadline)  # type: ignore[arg-type]
        if started["hpfs_profit"] is None:
            start = "lp"
    until = None if time_limit is None else t0 + LP_START_SHARE * float(time_limit)
    if start == "auto":
        # then the root's plans where its share leaves time for them (they replace HPFS's
        # on their orbits when together they gain: coordinated plans, D100 at 600 s 26,040
        # against 25,716 from nothing); HPFS's stay on the others
        # (explicit candidates: the root, as before)
        late = until is not None and time.perf_counter() >= until
        start = "hpfs" if mode == "windows" and late else "lp"
    if start == "lp" and data.orbits:
        # after HPFS-STC's schedule the root's plans stay only where together they do not
        # lower the profit: the start is never below HPFS-STC's
        keep = started.get("hpfs_profit") is not None
        local = p.workers if p.workers > 1 else None
        with workers_for(p.workers, p.dask, local) as workers:
            started.update(lp_start(search, until, workers, keep, deadline))
    crit: list[Any] = []
    if time_limit is not None:
        crit.append(MaxRuntime(float(time_limit), start=t0))
    if iterations is not None:
        crit.append(MaxIterations(iterations))
    if no_improve is not None:
        crit.append(NoImprovement(no_improve))
    # where HPFS-STC's schedule is the start, from nothing as well when that fits
    search, ascents = ascend_from_both(search, deadline, started)
    started.update(ascents)
    run = iterate(search, p, FirstOf(*crit), deadline, t0)
    search.paths = run.best_paths
    schedule = search.schedule()
    profit, observed = schedule.coverage_profit(instance)
    # without candidates (none in time) the empty schedule is still a schedule: feasible
    status = Status.FEASIBLE if instance.n_opps else Status.OPTIMAL
    return Result(
        method="orbit-dp",
        status=status,
        schedule=schedule,
        profit=profit,
        observed=observed,
        runtime_s=time.perf_counter() - t0,
        iterations=run.steps,
        stats={
            "candidates": data.n_items,
            "candidate_mode": mode,
            "candidates_s": round(t_data, 4),
            **started,
            "ascent_profit": run.ascent_profit,
            "replans": search.replans,
            "accepted": run.accepted,
            "trace": run.trace,
        },
    )
