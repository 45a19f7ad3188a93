"""Whole-orbit re-planning by the exact single-orbit recursion (ASA-DTC; sosp's, not the paper's).

The stretch re-planning of :mod:`heuristics.asa.replan` rebuilds at most ``replan_opps``
options of one orbit between fixed neighbours. This move re-plans a *whole* orbit with
:func:`sosp.planner.best_feasible_path`: the same recursion over the same clustering-exact
candidate observations, generated once per search (:func:`sosp.planner.orbit_data`), in
milliseconds even on an orbit with tens of thousands of candidates.

Candidates are re-rolled by the search's rule: a candidate covering the options S gets the
roll that :meth:`heuristics.asa.state.State.make_cluster` gives S (midpoint (9) of the common
range (8), or its point closest to nadir; a single option its own roll unless
``nadir_singles``). The roll lies in every member's range (7), so the recursion's (3), (4) and
(6) are exact for the cluster-tasks the search will build from the plan.

The move (:func:`orbit_move`):

1. draw an orbit uniformly among those with candidates;
2. price each target the orbit can see: its weight p_k when it is unscheduled (and not tabu)
   or scheduled on this orbit; with probability ``orbit_steal``, a target scheduled on another
   orbit is worth p_k too (the orbit may take it over); otherwise 0. Every price is then
   multiplied by U(1 - orbit_noise, 1 + orbit_noise): without noise the move is a no-op on an
   orbit already optimal for the others, and the search stalls at the first such point;
3. take the best plan for these prices under (3)-(6) (exact unless (4)-(5) bind, then a
   Lagrangian plan that fits); no move when it is worth no more than the orbit's current plan
   at the same prices (re-planning an already optimal orbit is not a move);
4. replace the orbit's cluster-tasks by the plan's, each built by (8)-(10) from the covered
   options whose task is still to be placed (a task covered twice by the plan is placed once;
   a task taken over leaves its old orbit, which loses a component by (8)-(10));
5. cascade: re-plan, at exact prices and without taking over or the tabu list, the orbits
   that lost a task to it, then those that see a task it let go, and so on, each kept only
   when it gains, at most ``orbit_ascent`` of them; then repair every touched orbit as in
   step 7 (a safety net: a member dropped from a planned observation, because another orbit
   keeps its task or the plan covers it twice, can move a midpoint roll). With
   ``orbit_share``, a task the drawn orbit's plan covers while another orbit keeps it is
   *shared*: that orbit is re-planned with the task worth nothing (the drawn orbit covers it
   anyway), and if its new plan lets the task go, the task joins the drawn orbit's planned
   observation. This is what ``orbit-dp`` gets from letting two orbits cover a target while
   its ascent runs; ASA-DTC's state holds one option per task, so the sharing lives only
   within a move.

:func:`orbit_search_start` is the search's start with ``init="orbit-dp"``: ``orbit-dp``'s
iterated local search over the same candidates, its best plans loaded into the state through
step 4 (each target placed by the first orbit whose plan covers it) and repaired.

:func:`ascend` re-plans every orbit until none gains; the search calls it when it restarts
from its best solution (``ASAParams.restart``).

The recursion sums prices per observation, so a target seen twice on one orbit (two
opportunities in one pass, which real orbits do not produce) can be counted twice; the move
then compares the plan by what it really covers (step 3) and nothing infeasible results.

Like the other moves it is judged by the annealing rule and feeds (17)-(18) through the
re-planning neighbourhood, which takes this move with probability ``replan_orbit``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator, Sequence
from functools import partial
from typing import Any

import numpy as np

from heuristics.asa.neighbourhoods import place, remove_member, repair
from heuristics.asa.params import ASAParams
from heuristics.asa.replan import replan_move
from heuristics.asa.state import MEMBERS, State
from heuristics.asa.tabu import TabuList
from heuristics.orbit_search import ascend_from_both, hpfs_start, lp_start
from sosp.ascent import UNLIMITED, OrbitSearch, OrbitSearchParams, WindowData, WindowSearch, iterate
from sosp.candidates import flatten, offsets, orbit_pairs
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.planner import OrbitItems, best_feasible_path, orbit_data
from sosp.rules import RollRule
from sosp.stop import Budget, Foresight, MaxRuntime, NoImprovement

log = logging.getLogger(__name__)

#: Steps without a gain after which the ``"orbit-dp"`` start ends when the search has no time
#: limit (iteration-limited runs: the seed alone fixes the start).
INIT_NO_IMPROVE = 20


def _rolls_of(opps: Sequence[Sequence[int]], state: State) -> np.ndarray:
    """Roll of every candidate by the search's rule (:meth:`State.group_rolls` of the
    candidate's covered options ``opps``)."""
    if len(opps) == 0:
        return np.zeros(0)
    sizes, flat = flatten(opps)
    return state.group_rolls(offsets(sizes), flat)


class OrbitPlanner:
    """The candidates of every orbit, at the search's rolls, for :func:`orbit_move`.

    Parameters
    ----------
    instance
        The problem.
    state
        The search state (DTC: a unit is a target and an option an opportunity).
    budget
        The time by which the candidates must be complete (:func:`sosp.planner.orbit_data`).

    Raises
    ------
    InputError
        The candidates are not complete within ``budget`` or too many (the caller runs without
        this move then).
    """

    #: ``orbit-dp``'s search over the same candidates (:meth:`start_search`), whose
    #: foreseen seconds of a plan per unit of :meth:`_work` (before one was timed) and least
    #: work that sets a rate this planner's :attr:`foresight` takes.
    SEARCH: type[OrbitSearch] = OrbitSearch

    def __init__(self, instance: Instance, state: State, budget: Budget = UNLIMITED) -> None:
        own = state.roll_rule == "nadir" and state.nadir_singles  # orbit_data's own rolls
        roll = None if own else partial(_rolls_of, state=state)  # the search's, arranged once
        self.data = data = orbit_data(instance, budget, roll=roll)
        self.orbit_items: dict[int, OrbitItems] = {o.orbit: o for o in data.orbits}
        self.orbits = sorted(self.orbit_items)
        self._targets = {o.orbit: o.targets for o in data.orbits}
        self._init(state, [o.orbit for o in data.orbits])

    def _init(self, state: State, orbit_of: list[int]) -> None:
        #: Per position in ``data.orbits``, its orbit.
        self._orbit_of = np.array(orbit_of, dtype=np.int64)
        self.weight = np.asarray(state.pb.target_weight, dtype=float)
        #: The time no plan should end past (the search's limit; unlimited: none). A plan over
        #: windows of a dense orbit reads no clock and takes seconds: an orbit move that
        #: started at 4.5 s of a 5 s run ended at 5.9 s.
        self.budget = UNLIMITED
        self.foresight = Foresight(self.SEARCH.PLAN_S_PER_WORK, min_work=self.SEARCH.RATE_FROM_WORK)

    def _work(self, j: int) -> float:
        """The size orbit j's planning time grows with (:class:`sosp.stop.Foresight`)."""
        return float(len(self.orbit_items[j].items))

    def late(self, j: int) -> bool:
        """Whether a plan of orbit j is foreseen to end past :attr:`budget`."""
        return not self.budget.fits(self.foresight(j, self._work(j)))

    def seeing(self, targets: list[int]) -> list[int]:
        """The orbits with a candidate covering any of ``targets``, in index order."""
        if not targets:
            return []
        pos = self.data.orbits_seeing(np.asarray(targets, dtype=np.int64))
        return sorted(self._orbit_of[pos].tolist())

    def prices(
        self,
        state: State,
        j: int,
        tabu: TabuList | None,
        rng: np.random.Generator,
        steal: float = 0.0,
        noise: float = 0.0,
    ) -> np.ndarray:
        """Step 2: what covering each target is worth to orbit j (a target scheduled on
        another orbit: p_k with probability ``steal``, else 0), each price times
        U(1 - noise, 1 + noise) when ``noise > 0``."""
        pb = state.pb
        sched, orbit, w = state.sched, pb.opt_orbit, self.weight
        price = np.zeros(len(w))
        targets = self._targets[j]  # those orbit j can observe
        draws = rng.random(len(targets)) if steal > 0 else None
        for n, k in enumerate(targets.tolist()):
            if (x := sched[k]) < 0:
                free = tabu is None or k not in tabu
            else:
                free = orbit[x] == j or (draws is not None and draws[n] < steal)
            if free:
                price[k] = w[k]
        if noise > 0:
            price[targets] *= rng.uniform(1.0 - noise, 1.0 + noise, len(targets))
        return price

    def plan(
        self, state: State, j: int, price: np.ndarray
    ) -> tuple[list[tuple[int, ...]], float] | None:
        """Step 3: the best plan of orbit j (covered options per observation, time order) and
        its value at ``price``; None when it is worth no more than the current plan, or
        foreseen to end past :attr:`budget` (:meth:`late`: not made)."""
        if self.late(j):
            return None
        t = time.perf_counter()
        plan, covered = self._best(j, price)
        self.foresight.record(j, self._work(j), time.perf_counter() - t)
        value = float(price[covered].sum()) if len(covered) else 0.0
        unit = state.pb.opt_unit
        current = {unit[x] for c in state.lines[j].obs for x in c[MEMBERS]}
        return None if value <= float(price[list(current)].sum()) + 1e-9 else (plan, value)

    def _best(self, j: int, price: np.ndarray) -> tuple[list[tuple[int, ...]], np.ndarray]:
        """The best plan of orbit j at ``price`` (options per observation) and the targets
        it covers."""
        o = self.orbit_items[j]
        path = best_feasible_path(o, price)
        return self._groups(o, path), o.covered(path)

    def _groups(self, o: Any, path: Any) -> list[tuple[int, ...]]:
        """The options of each observation of plan ``path`` of orbit ``o`` (of ``data``)."""
        return [self.data.opps[int(o.items[u])] for u in path]

    def start_search(self, rng: np.random.Generator) -> OrbitSearch:
        """``orbit-dp``'s search over this planner's candidates (for :func:`orbit_search_start`)."""
        return self.SEARCH(self.data, rng)

    def plans(self, paths: list[Any]) -> Iterator[tuple[int, list[tuple[int, ...]]]]:
        """(orbit, options per observation) of each non-empty plan of :meth:`start_search`'s
        search."""
        for o, path in zip(self.data.orbits, paths, strict=True):
            if groups := self._groups(o, path):
                yield o.orbit, groups

    @property
    def n_candidates(self) -> int:
        """Candidates generated up front (statistics)."""
        return int(self.data.n_items)

    def apply(
        self,
        state: State,
        j: int,
        plan: list[tuple[int, ...]],
        price: np.ndarray,
        shared: dict[int, tuple[int, int, tuple[int, ...]]] | None = None,
    ) -> set[int]:
        """Step 4: replace orbit j's cluster-tasks by ``plan``, placing the covered tasks worth
        something at ``price``; returns the orbits that lost a task to it.

        With ``shared`` (a dict, filled here): each task the plan covers that is worth nothing
        because another orbit has it, as ``task -> (j, option, the planned observation's
        options)`` (step 5 with ``orbit_share``)."""
        pb = state.pb
        sched, unit, orbit = state.sched, pb.opt_unit, pb.opt_orbit
        # The members each planned observation takes: options of tasks worth something at
        # ``price`` (not tabu, not kept by another orbit), each task once (first observation).
        planned: list[tuple[int, ...]] = []
        seen: set[int] = set()
        for opps in plan:
            members = []
            for x in opps:
                u = unit[x]
                if price[u] > 0.0 and u not in seen:
                    seen.add(u)
                    members.append(x)
                elif shared is not None and price[u] == 0.0 and sched[u] >= 0:
                    if orbit[sched[u]] != j:
                        shared.setdefault(u, (j, x, opps))
            if members:
                planned.append(tuple(members))
        # Cluster-tasks the plan keeps as they are stay in the line: a re-plan usually changes
        # a few observations, and removing and re-inserting the others cost a third of a move.
        wanted = {frozenset(m) for m in planned}
        line = state.touch(j)
        kept: set[frozenset[int]] = set()
        for pos in range(len(line.obs) - 1, -1, -1):
            key = frozenset(line.obs[pos][MEMBERS])
            if key in wanted:
                kept.add(key)
            else:
                for x in line.remove(pos)[MEMBERS]:
                    state.unassign(unit[x])
        losers: set[int] = set()
        for members in planned:
            if frozenset(members) in kept:
                continue
            for x in members:
                if (y := sched[unit[x]]) >= 0:
                    # Not on j: j's tasks are in kept cluster-tasks or were unassigned above.
                    i = orbit[y]
                    remove_member(state, i, state.find(i, y), y)
                    losers.add(i)
                state.assign(unit[x], x)
            line.insert(state.make_cluster(members))
        return losers


class WindowPlanner(OrbitPlanner):
    """:class:`OrbitPlanner` without candidates made up front, where they would not fit in
    memory or time (thousands of opportunities per orbit): each plan prices the orbit's
    windows at the move's prices and plans over the real observations of the argmax rolls
    (:func:`sosp.windows.window_plan`, the planner ``orbit-dp`` uses there). Rolls follow the
    search's rule for clusters; a restricted candidate set, so a plan is feasible and good,
    not the optimum over every candidate. The start (``init="orbit-dp"``) runs
    :class:`heuristics.orbit_search.WindowSearch`.
    """

    def __init__(self, instance: Instance, state: State) -> None:
        from sosp.windows import window_plan  # numba's import only where it is used

        self.data = WindowData.build(instance)
        self._window_plan = window_plan
        self._rule: RollRule = state.roll_rule
        self.orbits = [o.orbit for o in self.data.orbits if o.size]
        self._targets = {o.orbit: np.unique(o.target) for o in self.data.orbits}
        self._init(state, [o.orbit for o in self.data.orbits])

    #: As ``orbit-dp``'s over windows: its foresight per (first, covered) pair.
    SEARCH = WindowSearch

    def _work(self, j: int) -> float:
        return float(orbit_pairs(self.data.instance, j))

    def _best(self, j: int, price: np.ndarray) -> tuple[list[tuple[int, ...]], np.ndarray]:
        wp = self._window_plan(self.data.orbits[j], price, self._rule)
        return self._groups(None, wp), wp.targets

    def _groups(self, o: Any, path: Any) -> list[tuple[int, ...]]:
        # a window plan holds its observations' options (global opportunity indices)
        return [tuple(int(x) for x in group) for group in path.opps]


def orbit_move(
    state: State,
    rng: np.random.Generator,
    params: ASAParams,
    tabu: TabuList | None,
    planner: OrbitPlanner,
) -> bool:
    """Whole-orbit re-planning (steps 1-5 of the module docstring). False: no move."""
    if not planner.orbits:
        return False
    j = planner.orbits[int(rng.integers(len(planner.orbits)))]
    price = planner.prices(state, j, tabu, rng, params.orbit_steal, params.orbit_noise)
    found = planner.plan(state, j, price)
    if found is None:
        return False
    sched = state.sched
    queue: list[int] = []  # orbits to re-plan next, in order
    queued = {j}
    left = params.orbit_ascent
    orbit = state.pb.opt_orbit
    # Tasks the drawn orbit covers for free while another orbit has them (orbit_share).
    shared: dict[int, tuple[int, int, tuple[int, ...]]] = {}
    while found is not None:
        drawn = left == params.orbit_ascent  # nothing re-planned since the drawn orbit yet
        before = [state.pb.opt_unit[x] for c in state.lines[j].obs for x in c[MEMBERS]]
        keep = shared if drawn and params.orbit_share else None
        losers = planner.apply(state, j, found[0], price, keep)
        repair(state, j)
        if drawn:
            # The orbits holding a shared task are re-planned with it worth nothing.
            losers |= {orbit[sched[u]] for u in shared}
        elif shared:
            _take_shared(state, shared)
        # Next: the orbits that lost a task to j, then those seeing a task j let go.
        dropped = [u for u in before if sched[u] < 0]
        for i in [*sorted(losers), *planner.seeing(dropped)]:
            if i not in queued:
                queued.add(i)
                queue.append(i)
        found = None
        while queue and left > 0 and found is None:
            j = queue.pop(0)
            queued.discard(j)
            left -= 1
            # The tabu list keeps the drawn orbit from re-taking what a move just removed; the
            # cascade only gains, and barring the tasks the drawn orbit let go from the orbits
            # that could take them measured worse (docs/asa.md).
            price = planner.prices(state, j, None, rng)
            price[[u for u in shared if sched[u] >= 0 and orbit[sched[u]] == j]] = 0.0
            found = planner.plan(state, j, price)
    return all(repair(state, i) for i in state.touched_orbits())


def _take_shared(state: State, shared: dict[int, tuple[int, int, tuple[int, ...]]]) -> None:
    """Step 5 with ``orbit_share``: a shared task its orbit let go joins the drawn orbit's
    planned observation that covers it (or opens one of its own), then that orbit is repaired.
    """
    sched = state.sched
    for u in [u for u in shared if sched[u] < 0]:
        j, x, opps = shared.pop(u)
        obs, near = state.lines[j].obs, set(opps)
        pos = next((p for p, c in enumerate(obs) if near.intersection(c[MEMBERS])), -1)
        new = state.cluster_with(obs[pos], x) if pos >= 0 else state.make_cluster((x,))
        place(state, x, new, pos)
        repair(state, j)


def _apply_repaired(
    state: State, planner: OrbitPlanner, j: int, plan: list[tuple[int, ...]], price: np.ndarray
) -> bool:
    """Step 4 (:meth:`OrbitPlanner.apply`), then orbit j repaired; whether it is feasible."""
    planner.apply(state, j, plan, price)
    return repair(state, j)


def ascend(state: State, rng: np.random.Generator, planner: OrbitPlanner) -> int:
    """Re-plan every orbit exactly, in random order, until a whole pass gains nothing.

    A re-plan is kept only when the profit, after repair, rises strictly (with midpoint rolls
    a planned observation that loses a member can need repair and end worse than planned);
    so this ends. Used when the search restarts from its best solution. Returns the number
    of re-plans kept.
    """
    kept, last = 0, -1
    while kept > last:  # the last pass kept a re-plan
        last = kept
        for j in rng.permutation(planner.orbits).tolist():
            price = planner.prices(state, j, None, rng)
            found = planner.plan(state, j, price)
            if found is None:
                continue
            if state.attempt(partial(_apply_repaired, state, planner, j, found[0], price), 1e-9):
                kept += 1
    return kept


def orbit_search_start(
    state: State,
    rng: np.random.Generator,
    params: ASAParams,
    planner: OrbitPlanner,
    run: Budget,
    t0: float,
) -> dict[str, Any]:
    """Start the search from ``orbit-dp``'s iterated local search (``init="orbit-dp"``).

    The search runs on the planner's candidates (the rolls of the search's rule, so every
    plan is a set of cluster-tasks the state can hold) with the whole-orbit move's noise and
    steal probability, until ``init_share`` of the run's limit (``run``, counted from ``t0``)
    has passed (or :data:`INIT_NO_IMPROVE` steps without a gain when there is no limit). Its
    best plans are then applied orbit by orbit through step 4 (:meth:`OrbitPlanner.apply`),
    each target placed by the first orbit whose plan covers it, and each orbit repaired.
    Returns the start's figures for the statistics.
    """
    search = planner.start_search(rng)
    p = OrbitSearchParams(noise=params.orbit_noise, steal=params.orbit_steal)
    # its share of the limit, candidates included; but at least its share of what the
    # candidates left (where the window planner's set-up took past the share, the start
    # got no step and the greedy insertion was left to make the schedule)
    share, stop = run, NoImprovement(INIT_NO_IMPROVE)
    if run.deadline is not None:
        end = t0 + params.init_share * (run.deadline - t0)
        end = max(end, run.share(params.init_share).deadline or end)
        share, stop = Budget.until(end), MaxRuntime(end - t0, start=t0)
    started: dict[str, Any] = {}
    root = params.init == "lp"
    if root and isinstance(search, WindowSearch):
        # over windows, HPFS-STC's schedule first, as orbit-dp's default start: one plan of a
        # dense orbit takes seconds, and in a short limit the start from the root alone
        # left most orbits empty (a drawn 5,000-target instance at 5 s: 8,179 at the start's
        # end, 17,793 in all; from HPFS-STC's 14,532: 16,230 and 18,842). It may take most
        # of what is left, past the start's share.
        started = hpfs_start(search, run)
        # the root's plans then replace HPFS's on their orbits if together they do not
        # lower the profit, when the share has time left
        root = started["hpfs_profit"] is None or not share.expired()
    if root:
        # the root may take the start's whole share: what it leaves goes to the search
        started.update(
            lp_start(search, share, keep=started.get("hpfs_profit") is not None, plan_budget=run)
        )
    # where HPFS-STC's schedule is the start, from nothing as well when that fits in the
    # start's share (orbit-dp's rule)
    search, ascents = ascend_from_both(search, share, started)
    started.update(ascents)
    ils = iterate(search, p, stop, share, t0)
    sched, w = state.sched, planner.weight
    for j, plan in planner.plans(ils.best_paths):
        price = np.where(np.asarray(sched) < 0, w, 0.0)
        state.begin()
        _apply_repaired(state, planner, j, plan, price)
        state.commit()
    return {"init_profit": ils.best_profit, "init_steps": ils.steps, **started}


def make_planner(
    instance: Instance, state: State, params: ASAParams, run: Budget = UNLIMITED
) -> OrbitPlanner | None:
    """The planner when the search uses whole-orbit re-planning, else None; no plan of it is
    foreseen to end past ``run`` (the search's time, :meth:`OrbitPlanner.late`).

    Used by ASA-DTC with ``replan`` and ``replan_orbit > 0``. When the candidates would not
    fit in memory (``sosp.candidates.candidate_cap``) or cannot be generated in half the time
    ``run`` has left (thousands of opportunities on an orbit), the move plans over windows
    instead (:class:`WindowPlanner`) and the log says so.
    """
    if not (params.replan and params.replan_orbit > 0 and state.pb.mode == "dtc"):
        return None
    planner = None
    if params.candidates != "windows":
        try:
            planner = OrbitPlanner(instance, state, run.share(0.5))
        except InputError as exc:
            # The message's advice (after ";") is orbit-dp's; the cause is what matters here.
            cause = str(exc).split(";")[0]
            if params.candidates == "explicit":
                log.warning("asa-dtc: whole-orbit re-planning off, stretch moves only (%s)", cause)
                return None
            log.info("asa-dtc: whole-orbit re-planning over windows (%s)", cause)
    planner = planner or WindowPlanner(instance, state)
    planner.budget = run
    return planner


def replan_or_orbit(
    state: State,
    rng: np.random.Generator,
    params: ASAParams,
    tabu: TabuList | None,
    *,
    planner: OrbitPlanner,
) -> bool:
    """The re-planning neighbourhood with a planner: a whole orbit with probability
    ``params.replan_orbit``, else a stretch (:func:`heuristics.asa.replan.replan_move`)."""
    if rng.random() < params.replan_orbit:
        return orbit_move(state, rng, params, tabu, planner)
    return replan_move(state, rng, params, tabu)
