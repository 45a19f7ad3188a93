"""Whole-orbit re-planning (heuristics.asa.orbit): by hand, against the oracle, as properties."""

from __future__ import annotations

import logging
import time
from functools import partial

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.asa import ASAParams
from heuristics.asa.orbit import (
    OrbitPlanner,
    WindowPlanner,
    _rolls_of,
    ascend,
    make_planner,
    orbit_move,
    orbit_search_start,
)
from heuristics.asa.problem import build_problem
from heuristics.asa.search import build_schedule
from heuristics.asa.state import MEMBERS, ROLL, State
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from tests.conftest import small_instances
from tests.heuristics.test_asa import commit_or_rollback
from tests.heuristics.test_asa_replan import _abc, _only
from tests.limits import limit_kept
from tests.oracle import brute_force

#: The hand computations below use the paper's rolls (midpoint (9), singles at their own roll)
#: unless a case says otherwise.
PAPER_ROLLS = {"roll_rule": "midpoint", "nadir_singles": False}


def _planner(inst: Instance, **kw) -> tuple[State, ASAParams, OrbitPlanner]:
    params = ASAParams(**{**PAPER_ROLLS, **kw})
    pb = build_problem(inst, "dtc", params.roll_rule)
    state = State(pb, params.roll_rule, params.nadir_singles)
    return state, params, OrbitPlanner(inst, state)


class _Draw:
    """A generator stand-in that draws orbit ``j`` and nothing else random."""

    def __init__(self, j: int = 0) -> None:
        self.j = j

    def integers(self, n: int) -> int:
        return self.j

    def random(self, n: int | None = None):
        return 0.99 if n is None else np.full(n, 0.99)


@pytest.mark.parametrize(
    ("kw", "pair_roll", "c_roll"),
    [
        ({}, 1.0, 20.0),  # (9): midpoint of [-1, 3]; c alone at its own roll
        ({"roll_rule": "nadir"}, 0.0, 20.0),
        ({"roll_rule": "nadir", "nadir_singles": True}, 0.0, 17.0),  # c's range [17, 23]
    ],
)
def test_candidates_take_the_searchs_roll_by_hand(kw: dict, pair_roll: float, c_roll: float):
    inst = _abc()
    state, _, planner = _planner(inst, **kw)
    a, b, c = (inst.target_opps[inst.target_index[t]][0] for t in "abc")
    rolls = dict(zip(planner.data.opps, planner.data.roll.tolist(), strict=True))
    assert rolls[(a, b)] == pair_roll
    assert rolls[(c,)] == c_roll
    assert np.array_equal(_rolls_of(planner.data.opps, state), planner.data.roll)


@pytest.mark.parametrize("kw", [{}, {"roll_rule": "nadir", "nadir_singles": True}])
def test_orbit_move_reclusters_the_whole_orbit_by_hand(kw: dict) -> None:
    """c alone (5) is replaced by the cluster {a, b} (6), at the search's roll."""
    inst = _abc()
    state, params, planner = _planner(inst, orbit_noise=0.0, orbit_steal=0.0, **kw)
    a, b, c = (inst.target_opps[inst.target_index[t]][0] for t in "abc")
    _only(state, c)
    state.begin()
    assert orbit_move(state, _Draw(), params, None, planner)  # type: ignore[arg-type]
    assert state.profit == 6 and state.check()
    (obs,) = state.lines[0].obs
    assert set(obs[MEMBERS]) == {a, b} and obs[ROLL] == (1.0 if not kw else 0.0)
    # Now optimal for its prices: re-planning it again is no move.
    state.commit()
    state.begin()
    assert not orbit_move(state, _Draw(), params, None, planner)  # type: ignore[arg-type]


def test_orbit_move_keeps_the_memory_budget_by_hand() -> None:
    """W = 10: {a, b} observes 12 s > 10; c alone (5) is the best plan, and no move."""
    inst = _abc(memory=10.0)
    state, params, planner = _planner(inst, orbit_noise=0.0)
    c = inst.target_opps[inst.target_index["c"]][0]
    _only(state, c)
    state.begin()
    assert not orbit_move(state, _Draw(), params, None, planner)  # type: ignore[arg-type]
    assert state.profit == 5


def test_steal_takes_a_task_over_and_the_cascade_refills_the_loser() -> None:
    """Orbit 0 sees a; orbit 1 sees a and d, which clash there. Start: a on orbit 1 (3).
    Re-planning orbit 0 with a stolen moves a over, then orbit 1 takes d: 3 + 4 = 7."""
    rows = [("a", 0, 0.0, 2.0, 0.0), ("a", 1, 0.0, 2.0, 0.0), ("d", 1, 5.0, 7.0, 0.0)]
    inst = Instance.build({"a": 3, "d": 4}, rows, n_orbits=2)
    state, params, planner = _planner(inst, orbit_noise=0.0, orbit_steal=1.0)
    a1 = next(x for x in state.pb.orbit_options[1] if state.pb.opt_unit[x] == 0)
    _only(state, a1)

    class Steal(_Draw):
        def random(self, n: int | None = None):
            return 0.0 if n is None else np.zeros(n)

    state.begin()
    assert orbit_move(state, Steal(0), params, None, planner)  # type: ignore[arg-type]
    assert state.profit == 7 and state.check()
    assert brute_force(inst, "cluster").profit == 7
    # Without the cascade the loser keeps nothing: 3.
    state.rollback()
    no_cascade = ASAParams(orbit_noise=0.0, orbit_steal=1.0, orbit_ascent=0)
    state.begin()
    assert orbit_move(state, Steal(0), no_cascade, None, planner)  # type: ignore[arg-type]
    assert state.profit == 3 and state.check()


@pytest.mark.parametrize(("share", "profit"), [(True, 10), (False, 7)])
def test_shared_task_moves_to_the_drawn_orbit_when_its_orbit_lets_it_go(
    share: bool, profit: int
) -> None:
    """Orbit 0: c [0, 9] rolls [8, 12] holds a [2, 6] rolls [6, 14] in its only candidate
    (roll 8 is the one point of c's range that is a candidate roll), so planning c covers a
    for free. Orbit 1: a and d clash (a roll 0, d roll 20, 1 s apart). Start: a on orbit 1.

    Re-planning orbit 0 (no steal, no noise) takes c; a, worth nothing to orbit 0, stays on
    orbit 1 (5 + 2 = 7). With ``orbit_share`` a is shared: orbit 1 is re-planned with a worth
    nothing and takes d, and a joins c's observation on orbit 0: 5 + 2 + 3 = 10, the optimum.
    """
    rows = [
        ("c", 0, 0.0, 9.0, 10.0, 8.0, 12.0),
        ("a", 0, 2.0, 6.0, 10.0, 6.0, 14.0),
        ("a", 1, 0.0, 4.0, 0.0, -1.0, 1.0),
        ("d", 1, 5.0, 9.0, 20.0, 19.0, 21.0),
    ]
    inst = Instance.build({"a": 5, "c": 2, "d": 3}, rows, n_orbits=2)
    state, params, planner = _planner(inst, orbit_noise=0.0, orbit_share=share)
    a1 = next(x for x in state.pb.orbit_options[1] if state.pb.opt_unit[x] == 0)
    _only(state, a1)
    state.begin()
    assert orbit_move(state, _Draw(0), params, None, planner)  # type: ignore[arg-type]
    assert state.profit == profit and state.check()
    on0 = [sorted(state.pb.opt_unit[x] for x in c[MEMBERS]) for c in state.lines[0].obs]
    assert on0 == ([[0, 1]] if share else [[1]])  # a (unit 0) clustered with c (unit 1)
    assert brute_force(inst, "cluster").profit == 10
    assert validate(inst, build_schedule(inst, state.pb, state.snapshot())).feasible


def test_tabu_tasks_are_worth_nothing_to_the_drawn_orbit() -> None:
    inst = _abc()
    state, params, planner = _planner(inst, orbit_noise=0.0)
    a, b, c = (inst.target_opps[inst.target_index[t]][0] for t in "abc")
    tabu = {state.pb.opt_unit[a]}
    price = planner.prices(state, 0, tabu, np.random.default_rng(0))  # type: ignore[arg-type]
    assert price.tolist() == [0.0, 3.0, 5.0]
    state.begin()
    assert orbit_move(state, _Draw(), params, tabu, planner)  # type: ignore[arg-type]
    assert [o[MEMBERS] for o in state.lines[0].obs] == [(c,)]  # b alone (3) < c (5)


@st.composite
def single_orbit_instances(draw: st.DrawFn) -> Instance:
    """One orbit, each target seen once (one pass), loose energy and memory so (4)-(5) never
    bind: the recursion is then exact (a target seen twice on one orbit could be counted
    twice by it, ``sosp.planner``; real orbits see a target at most once)."""
    n = draw(st.integers(1, 7))
    weights = draw(st.lists(st.integers(2, 10), min_size=n, max_size=n))
    rows = []
    for k in range(n):
        s = float(draw(st.integers(0, 120)))
        d = float(draw(st.integers(1, 12)))
        rows.append((k, 0, s, s + d, float(draw(st.integers(-33, 33)))))
    res = Resources(
        energy_capacity=1e6,
        memory_capacity=1e6,
        max_openings=draw(st.integers(1, 4)),
        max_duration=float(draw(st.sampled_from([10, 30, 120]))),
        setup_time=float(draw(st.sampled_from([2, 10]))),
    )
    return Instance.build(weights, rows, resources=res, n_orbits=1)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=single_orbit_instances(), rule=st.sampled_from(["midpoint", "nadir"]))
def test_one_replan_of_a_single_orbit(inst: Instance, rule: str) -> None:
    """From the empty schedule one exact re-plan of the only orbit gives, with nadir rolls,
    the cluster model's optimum (the oracle's rolls); with midpoint rolls a plan that needs no
    repair, never above the optimum."""
    state, _, planner = _planner(inst, roll_rule=rule, nadir_singles=rule == "nadir")
    optimum = brute_force(inst, "cluster").profit
    if not planner.orbits:
        assert optimum == 0
        return
    price = planner.prices(state, 0, None, np.random.default_rng(0))
    found = planner.plan(state, 0, price)
    state.begin()
    if found is not None:
        plan = found[0]
        planner.apply(state, 0, plan, price)
        assert state.lines[0].feasible()  # exact for the search's rolls: nothing to repair
    assert ascend(state, np.random.default_rng(0), planner) >= 0
    assert state.check()
    if rule == "nadir":
        assert state.profit == optimum
    else:
        assert state.profit <= optimum


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8),
    seed=st.integers(0, 2**16),
    rule=st.sampled_from(["midpoint", "nadir"]),
    share=st.booleans(),
)
def test_orbit_moves_keep_orbits_feasible_and_totals_exact(
    inst: Instance, seed: int, rule: str, share: bool
):
    state, params, planner = _planner(inst, roll_rule=rule, orbit_steal=0.5, orbit_share=share)
    rng = np.random.default_rng(seed)
    commit_or_rollback(state, params, rng, [partial(orbit_move, planner=planner)], 25)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), seed=st.integers(0, 2**16))
def test_asa_dtc_with_whole_orbit_moves_is_valid_and_below_the_optimum(inst: Instance, seed: int):
    res = solve(inst, "asa-dtc", seed=seed, iterations=150, replan_orbit=1.0, restart=20)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.profit <= brute_force(inst, "cluster").profit + 1e-9


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), seed=st.integers(0, 2**16))
def test_asa_dtc_over_windows_is_valid_and_below_the_optimum(inst: Instance, seed: int):
    res = solve(inst, "asa-dtc", seed=seed, iterations=100, restart=20, candidates="windows")
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.profit <= brute_force(inst, "cluster").profit + 1e-9
    assert res.stats["orbit_candidates"] == 0


def test_ascend_leaves_every_orbit_optimal_for_the_others(tiny: Instance) -> None:
    state, _, planner = _planner(tiny)
    rng = np.random.default_rng(1)
    ascend(state, rng, planner)
    for j in planner.orbits:
        assert planner.plan(state, j, planner.prices(state, j, None, rng)) is None


def test_no_candidates_in_time_plans_over_windows(caplog: pytest.LogCaptureFixture) -> None:
    inst = _abc()
    params = ASAParams()
    state = State(build_problem(inst, "dtc"), "midpoint")
    with caplog.at_level(logging.INFO):
        planner = make_planner(inst, state, params, Budget.until(time.perf_counter() - 1.0))
    assert isinstance(planner, WindowPlanner) and planner.n_candidates == 0
    late = Budget.until(time.perf_counter() - 1.0)  # explicit only: no move then
    assert make_planner(inst, state, ASAParams(candidates="explicit"), late) is None
    assert "re-planning over windows" in caplog.text
    assert make_planner(inst, state, ASAParams(replan_orbit=0.0)) is None
    stc = State(build_problem(inst, "stc"), "midpoint")
    assert make_planner(inst, stc, params) is None
    assert make_planner(inst, state, params) is not None
    assert isinstance(make_planner(inst, state, ASAParams(candidates="windows")), WindowPlanner)


def test_whole_orbit_moves_are_counted_and_deterministic(tiny: Instance) -> None:
    one = solve(tiny, "asa-dtc", seed=5, iterations=200, replan_orbit=1.0)
    two = solve(tiny, "asa-dtc", seed=5, iterations=200, replan_orbit=1.0)
    assert one.schedule == two.schedule and one.profit == two.profit
    assert one.stats["orbit_candidates"] > 0
    off = solve(tiny, "asa-dtc", seed=5, iterations=200, replan_orbit=0.0)
    assert off.stats["orbit_candidates"] == 0


@pytest.mark.parametrize(
    ("rule", "init"), [("nadir", "orbit-dp"), ("midpoint", "orbit-dp"), ("nadir", "lp")]
)
def test_orbit_dp_start_loads_the_searchs_best_plans(rule: str, init: str, c1) -> None:
    # C1's orbits share targets, so loading must place each target once and lose nothing.

    inst = c1
    params = ASAParams(roll_rule=rule, init=init)
    state = State(build_problem(inst, "dtc", rule), rule, params.nadir_singles)
    planner = OrbitPlanner(inst, state)
    figures = orbit_search_start(state, np.random.default_rng(3), params, planner, Budget(), 0.0)
    assert figures["init_steps"] >= 1
    # the LP start runs the column generation first, and only with init="lp"
    assert ("lp_rounds" in figures) == (init == "lp")
    assert state.profit == pytest.approx(figures["init_profit"])
    covered = [w for w, c in zip(state.pb.target_weight, state.cover, strict=True) if c > 0]
    assert state.profit == pytest.approx(sum(covered))
    rep = validate(inst, build_schedule(inst, state.pb, state.snapshot()))
    assert rep.feasible, rep.violations


def test_the_lp_start_over_windows_begins_from_hpfs(c1) -> None:
    """Over windows ``init="lp"`` sets HPFS-STC's schedule first, then the root's plans (no
    limit here: the root has time); with explicit candidates, the root alone."""
    from heuristics.hpfs import solve_hpfs_stc

    inst = c1
    hpfs = solve_hpfs_stc(inst, rng=np.random.default_rng(0)).profit
    params = ASAParams(init="lp", candidates="windows")
    state = State(build_problem(inst, "dtc", "nadir"), "nadir", params.nadir_singles)
    planner = make_planner(inst, state, params)
    assert isinstance(planner, WindowPlanner)
    figures = orbit_search_start(state, np.random.default_rng(3), params, planner, Budget(), 0.0)
    assert figures["hpfs_profit"] == hpfs > 0 and figures["lp_rounds"] >= 1
    assert state.profit == pytest.approx(figures["init_profit"])
    rep = validate(inst, build_schedule(inst, state.pb, state.snapshot()))
    assert rep.feasible, rep.violations
    explicit = solve(inst, "asa-dtc", seed=0, iterations=50, candidates="explicit")
    assert "hpfs_s" not in explicit.stats and explicit.stats["lp_rounds"] >= 1
    late = ASAParams(init="lp", candidates="windows")
    state = State(build_problem(inst, "dtc", "nadir"), "nadir", late.nadir_singles)
    planner = make_planner(inst, state, late)
    t0 = time.perf_counter() - 10.0  # the limit has passed: no HPFS, the root as before
    figures = orbit_search_start(
        state, np.random.default_rng(3), late, planner, Budget.until(t0 + 10.0), t0
    )
    assert figures["hpfs_profit"] is None and "lp_rounds" in figures


def test_orbit_dp_start_is_at_least_the_greedy_start_and_seeded(tiny: Instance) -> None:
    dp = solve(tiny, "asa-dtc", seed=2, iterations=0)
    again = solve(tiny, "asa-dtc", seed=2, iterations=0)
    greedy = solve(tiny, "asa-dtc", seed=2, iterations=0, init="greedy")
    assert dp.schedule == again.schedule
    # no step once the start observes every target: nothing is left to find (issue 63, 5)
    capped = dp.stats["init_profit"] >= tiny.observable_weight
    assert dp.stats["init_steps"] >= (0 if capped else 1) and "init_steps" not in greedy.stats
    # Section 5.4's insertion runs after the loaded plans, so it can only add.
    assert dp.profit >= dp.stats["init_profit"] - 1e-9
    lp = solve(tiny, "asa-dtc", seed=2, iterations=0, init="lp")
    assert lp.schedule == solve(tiny, "asa-dtc", seed=2, iterations=0, init="lp").schedule
    assert lp.stats["lp_rounds"] >= 1 and lp.profit >= lp.stats["init_profit"] - 1e-9


@pytest.mark.parametrize(
    ("key", "value"), [("init_share", 0.0), ("init_share", 1.5), ("init", "x")]
)
def test_bad_start_parameters_name_the_field(key: str, value: object) -> None:
    with pytest.raises(InputError, match=key):
        ASAParams(**{key: value})


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("replan_orbit", 1.5),
        ("replan_orbit", -0.1),
        ("orbit_steal", 2.0),
        ("orbit_noise", 1.0),
        ("orbit_noise", -0.5),
        ("orbit_ascent", -1),
        ("orbit_ascent", 2.5),
    ],
)
def test_bad_orbit_parameters_name_the_field(key: str, value: float) -> None:
    with pytest.raises(InputError, match=key):
        ASAParams(**{key: value})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8),
    seed=st.integers(0, 2**16),
    rule=st.sampled_from(["midpoint", "nadir"]),
)
def test_ascend_only_keeps_gains(inst: Instance, seed: int, rule: str) -> None:
    """From a state reached by random moves, every re-plan ascend keeps raises the profit (so
    it ends even when midpoint rolls make a planned gain vanish in repair)."""
    state, params, planner = _planner(inst, roll_rule=rule, orbit_steal=0.5)
    rng = np.random.default_rng(seed)
    commit_or_rollback(state, params, rng, [partial(orbit_move, planner=planner)], 5)
    before = state.profit
    kept = ascend(state, rng, planner)
    assert state.check()
    assert state.profit >= before + kept - 1e-9  # integer weights: each kept re-plan adds >= 1


@pytest.mark.limits
def test_the_start_keeps_its_share_of_what_the_set_up_left(c1) -> None:
    """A set-up (the planner's candidates) that took the start's whole share of the limit
    still leaves the start its share of the time left (a 5,000-target instance at 5 s had
    no start step: 57 % of orbit-dp's profit)."""

    inst = c1
    params = ASAParams(init="orbit-dp")
    state = State(build_problem(inst, "dtc", "nadir"), "nadir", params.nadir_singles)
    planner = OrbitPlanner(inst, state)
    limit = 4.0
    t0 = time.perf_counter() - 0.5 * limit  # half the limit gone: past its 0.3 share
    t = time.perf_counter()
    figures = orbit_search_start(
        state, np.random.default_rng(3), params, planner, Budget.until(t0 + limit), t0
    )
    took = time.perf_counter() - t
    assert figures["init_steps"] >= 1 and figures["init_profit"] > 0
    limit_kept("start, its share of 2 s", took, params.init_share * 0.5 * limit + 0.5)


def test_insertion_after_an_orbit_start_has_its_share_of_the_time_left(monkeypatch, c1) -> None:
    """Section 5.4's insertion after an orbit start gets ``init_share`` of the time left, not
    all of it (it spent 14 s of a 20 s run on targets the start could not place)."""
    import heuristics.asa.search as search_mod

    seen: list[float] = []
    real = search_mod.initial_solution

    def spy(state, params, budget):
        seen.append(budget.left())
        return real(state, params, budget)

    monkeypatch.setattr(search_mod, "initial_solution", spy)
    inst = c1
    search_mod.Search(inst, "dtc", rng=np.random.default_rng(0), time_limit=10.0)
    greedy = ASAParams(init="greedy")
    search_mod.Search(inst, "dtc", rng=np.random.default_rng(0), time_limit=10.0, params=greedy)
    after_start, alone = seen
    assert after_start <= 0.3 * 10.0 + 0.05  # at most its share of what the start left
    assert alone > 5.0  # without an orbit start: the whole limit


@pytest.mark.parametrize("candidates", ["explicit", "windows"])
def test_a_plan_foreseen_past_the_deadline_is_not_made(
    candidates: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A whole-orbit plan reads no clock (over windows on a dense orbit: seconds; a 5 s
    ``asa-dtc`` ran to 5.9 s): one foreseen past the planner's deadline is not made and the
    move is none; without a deadline nothing is foreseen."""
    inst = _abc()
    state = State(build_problem(inst, "dtc"), "midpoint")
    planner = make_planner(inst, state, ASAParams(candidates=candidates))
    assert planner is not None and planner.budget.deadline is None
    rng = np.random.default_rng(0)
    j = planner.orbits[0]
    price = planner.prices(state, j, None, rng)
    assert planner.plan(state, j, price) is not None  # made and timed
    assert planner.foresight.took[j] >= 0.0 and not planner.late(j)
    made: list[int] = []
    real = planner._best
    monkeypatch.setattr(planner, "_best", lambda j, p: made.append(j) or real(j, p))
    planner.budget = Budget.of(3600.0)
    planner.foresight.took[j] = 7200.0  # "its last plan took two hours"
    assert planner.late(j) and planner.plan(state, j, price) is None and made == []
    planner.budget = Budget()
    assert planner.plan(state, j, price) is not None and made == [j]


def test_asa_sets_the_planners_deadline() -> None:
    """With a time limit, the search's planner foresees against it; without, it does not."""
    from heuristics.asa.search import Search

    inst = _abc()
    # 2 s, not 60: the start search (orbit_search_start) runs for its share of the limit
    for limit, has in ((2.0, True), (None, False)):
        s = Search(inst, "dtc", rng=np.random.default_rng(0), time_limit=limit)
        assert s.planner is not None and (s.planner.budget.deadline is not None) == has
