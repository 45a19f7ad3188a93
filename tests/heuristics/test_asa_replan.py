"""Orbit re-planning (heuristics.asa.replan): by hand on tiny orbits, and against the oracle."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.asa import ASAParams
from heuristics.asa.neighbourhoods import initial_solution
from heuristics.asa.problem import build_problem
from heuristics.asa.replan import (
    best_chain,
    candidates,
    polish,
    replan_move,
    replan_pair,
    replan_stretch,
)
from heuristics.asa.state import MEMBERS, State
from sosp.instance import Instance, Resources
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import small_instances
from tests.heuristics.test_asa import commit_or_rollback
from tests.oracle import brute_force


def _abc(memory: float = 1000.0) -> Instance:
    """One orbit, setup 10 s, slew 1 deg/s; ranges are roll +- 3 deg.

    a [0, 2] roll 0 (range [-3, 3]), weight 3; b [10, 12] roll 2 ([-1, 5]), weight 3;
    c [20, 22] roll 20 ([17, 23]), weight 5. Alone, every pair clashes by (3): a then b needs
    10 + 0 + 2 = 12 s > 8 s; b then c 10 + 2 + 20 > 8; a then c 10 + 20 > 18. a and b can be
    clustered: common range [-1, 3], window [0, 12] (12 s <= Delta T), midpoint roll 1; the
    cluster then clashes with c (10 + 1 + 20 > 8). So the best orbit is {a, b} = 6 > c = 5.
    """
    rows = [("a", 0, 0.0, 2.0, 0.0), ("b", 0, 10.0, 12.0, 2.0), ("c", 0, 20.0, 22.0, 20.0)]
    res = Resources(memory_capacity=memory, max_duration=120.0, setup_time=10.0)
    return Instance.build({"a": 3, "b": 3, "c": 5}, rows, resources=res, n_orbits=1)


#: The hand computations below use the paper's rolls (midpoint (9), singles at their own roll)
#: unless a case says otherwise.
PAPER_ROLLS = {"roll_rule": "midpoint", "nadir_singles": False}


def _state(inst: Instance, mode: str = "dtc", **kw) -> tuple[State, ASAParams]:
    params = ASAParams(**{**PAPER_ROLLS, **kw})
    pb = build_problem(inst, mode, params.roll_rule)
    return State(pb, params.roll_rule, params.nadir_singles), params


def _only(state: State, x: int) -> None:
    """Schedule option x alone (a committed start)."""
    state.begin()
    state.touch(state.pb.opt_orbit[x]).insert(state.make_cluster((x,)))
    state.assign(state.pb.opt_unit[x], x)
    state.commit()


def test_replan_reclusters_the_orbit_by_hand() -> None:
    inst = _abc()
    state, _ = _state(inst)
    a, b, c = (inst.target_opps[inst.target_index[t]][0] for t in "abc")
    _only(state, c)
    assert state.profit == 5
    state.begin()
    holes = replan_stretch(state, 0, state.pb.orbit_options[0], None)
    assert holes == []
    assert state.profit == 6
    (obs,) = state.lines[0].obs
    assert obs[:3] == (0.0, 12.0, 1.0) and set(obs[MEMBERS]) == {a, b}
    assert state.check()


def test_replan_keeps_the_memory_budget_by_hand() -> None:
    """W = 10: the cluster {a, b} observes 12 s > 10, so the best within (5) is c alone (5),
    and a stretch worth less than what it replaces is not proposed."""
    inst = _abc(memory=10.0)
    state, _ = _state(inst)
    c = inst.target_opps[inst.target_index["c"]][0]
    opts = state.pb.orbit_options[0]
    cands = candidates(state, 0, opts)
    assert sorted(cands.members(v) for v in range(len(cands))) == sorted(
        [(opts[0],), (opts[1],), (opts[2],), (opts[0], opts[1])]
    )
    gains = cands.sums(np.array([state.pb.unit_weight[state.pb.opt_unit[x]] for x in cands.flat]))
    gain, chain = best_chain(state, 0, cands, gains, None, None, 1500.0, 10.0, 10)
    assert gain == 5 and [cands.members(v) for v in chain] == [(c,)]
    gain, chain = best_chain(state, 0, cands, gains, None, None, 1500.0, 1000.0, 10)
    assert gain == 6
    gain, chain = best_chain(state, 0, cands, gains, None, None, 1500.0, 1000.0, 0)
    assert (gain, chain) == (0.0, [])


@pytest.mark.parametrize("orbit_source", [True, False], ids=["orbit-candidates", "generated"])
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), drop=st.integers(0, 255))
def test_candidates_dominate_every_cluster_task_of_the_options(
    orbit_source: bool, inst: Instance, drop: int
) -> None:
    """The stretch's candidates dominate every cluster-task of the options left, found by
    brute force, both ways they are made (cut from the orbit's candidates, and generated
    over the options when those are not at hand): some candidate covers a superset of its
    options in a window inside its window, at a roll no farther from nadir; and each
    candidate is a feasible cluster-task (7), (11)."""
    state, _ = _state(inst, roll_rule="nadir")
    pb = state.pb
    if not orbit_source:
        pb.instance = None
    opts = [x for a, x in enumerate(pb.orbit_options[0]) if not drop >> a & 1]
    dT = inst.max_duration[0]
    got = candidates(state, 0, opts)
    cands = [state.make_cluster(got.members(v)) for v in range(len(got))]
    for v, c in enumerate(cands):  # feasible (7), within Delta T (11), columns as made
        assert all(pb.opt_lo[x] - 1e-9 <= c[2] <= pb.opt_hi[x] + 1e-9 for x in c[MEMBERS])
        assert c[1] - c[0] <= dT + 1e-9
        assert (got.start[v], got.end[v], got.roll[v]) == c[:3]
    for size in range(1, len(opts) + 1):
        for sub in itertools.combinations(opts, size):
            k = state.make_cluster(sub)
            if k[3] > k[4] or k[1] - k[0] > dT:
                continue  # no common range (7) or longer than Delta T (11)
            assert any(
                set(sub) <= set(c[MEMBERS])
                and c[0] >= k[0] - 1e-9
                and c[1] <= k[1] + 1e-9
                and abs(c[2]) <= abs(k[2]) + 1e-9
                for c in cands
            ), sub


def test_replan_respects_fixed_neighbours() -> None:
    """With c fixed on the right of a stretch holding only b, b alone clashes with c (3): the
    chain between must be empty, so the move proposes nothing better and changes nothing."""
    inst = _abc()
    state, _ = _state(inst)
    a, b, c = (inst.target_opps[inst.target_index[t]][0] for t in "abc")
    _only(state, c)
    state.begin()
    assert replan_stretch(state, 0, [b], None) == []
    assert state.profit == 5 and [o[MEMBERS] for o in state.lines[0].obs] == [(c,)]


def test_pull_takes_a_task_from_another_orbit_and_refills_it() -> None:
    """Orbit 0 sees a, orbit 1 sees a and d, which clash on orbit 1. Start: a on orbit 1.
    Re-planning orbit 0 with pull pulls a over (worth half its weight there), then orbit 1
    is re-planned and takes d: 3 + 4 = 7 instead of 3."""
    rows = [("a", 0, 0.0, 2.0, 0.0), ("a", 1, 0.0, 2.0, 0.0), ("d", 1, 5.0, 7.0, 0.0)]
    inst = Instance.build({"a": 3, "d": 4}, rows, n_orbits=2)
    state, params = _state(inst, replan_pull=0.5, replan_opps=40, replan_pair=0.0)
    a1 = next(x for x in state.pb.orbit_options[1] if state.pb.opt_unit[x] == 0)
    _only(state, a1)

    class Orbit0:
        def integers(self, n: int) -> int:
            return 0

    state.begin()
    assert replan_move(state, Orbit0(), params, None)  # type: ignore[arg-type]
    assert state.profit == 7 and state.check()
    assert brute_force(inst, "cluster").profit == 7


def test_nadir_singles_roll_toward_nadir() -> None:
    inst = _abc()
    state, _ = _state(inst, roll_rule="nadir", nadir_singles=True)
    c = inst.target_opps[inst.target_index["c"]][0]
    assert state.make_cluster((c,))[2] == 17.0  # range [17, 23], closest to nadir
    nontc, _ = _state(inst, mode="nontc", nadir_singles=True)
    assert nontc.make_cluster((c,))[2] == 20.0  # NONTC keeps the task model's own roll


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), seed=st.integers(0, 2**16))
def test_nadir_singles_valid_and_never_above_the_optimum(inst: Instance, seed: int) -> None:
    res = solve(inst, "asa-dtc", seed=seed, iterations=200, roll_rule="nadir", nadir_singles=True)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert res.profit <= brute_force(inst, "cluster").profit + 1e-9


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(),
    seed=st.integers(0, 2**16),
    mode=st.sampled_from(["dtc", "stc", "nontc"]),
    pull=st.sampled_from([0.0, 0.5, 1.0]),
)
def test_replan_moves_keep_orbits_feasible_and_totals_exact(
    inst: Instance, seed: int, mode: str, pull: float
) -> None:
    """Only re-planning moves, half kept, half undone: feasible lines, exact totals."""
    state, params = _state(inst, mode, replan_pull=pull, replan_opps=3)
    rng = np.random.default_rng(seed)
    initial_solution(state, params)
    commit_or_rollback(state, params, rng, (replan_move,), 30)


def test_replan_off_is_the_papers_two_moves() -> None:
    inst = _abc()
    res = solve(inst, "asa-dtc", seed=0, iterations=50, replan=False)
    assert set(res.stats["accepted"]) == {"insertion", "migration"}
    res = solve(inst, "asa-dtc", seed=0, iterations=50)
    assert set(res.stats["accepted"]) == {"insertion", "migration", "replan"}


def test_pair_moves_a_shared_task_to_free_its_orbit_by_hand() -> None:
    """Orbit 0 sees a [0, 2] roll 0 and b [5, 7] roll 20 (no common range (7); setup 10: they
    clash by (3)); orbit 1 sees a only. Start: a on orbit 0 (3). Re-planning orbits 0 and 1
    together puts a on orbit 1 and b on orbit 0: 3 + 4 = 7, the optimum, in one move (orbit 1
    alone can only take a, which is observed; orbit 0 alone trades a for b)."""
    rows = [("a", 0, 0.0, 2.0, 0.0), ("b", 0, 5.0, 7.0, 20.0), ("a", 1, 0.0, 2.0, 0.0)]
    inst = Instance.build({"a": 3, "b": 4}, rows, n_orbits=2)
    state, _ = _state(inst)
    a0 = next(x for x in state.pb.orbit_options[0] if state.pb.opt_unit[x] == 0)
    _only(state, a0)
    state.begin()
    rng = np.random.default_rng(0)
    assert replan_pair(state, rng, 0, state.pb.orbit_options[0], 40, None)
    assert state.profit == 7 == brute_force(inst, "cluster").profit and state.check()
    on = {u: state.pb.opt_orbit[x] for u, x in enumerate(state.sched) if x >= 0}
    assert on == {0: 1, 1: 0}
    state.rollback()
    assert polish(state, rng, ASAParams(), None) == 2 and state.profit == 7  # (0, 1), (1, 0)


def test_load_restores_a_snapshot() -> None:
    inst = _abc()
    state, params = _state(inst)
    initial_solution(state, params)
    snap, profit, sched = state.snapshot(), state.profit, list(state.sched)
    state.begin()
    replan_stretch(state, 0, state.pb.orbit_options[0], None)
    state.commit()
    state.load(snap)
    assert (state.snapshot(), state.profit, state.sched) == (snap, profit, sched)
    assert state.check()


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8),
    seed=st.integers(0, 2**16),
    method=st.sampled_from(["asa-dtc", "asa-stc", "asa-nontc"]),
)
def test_restarts_and_polish_stay_valid_and_below_the_optimum(
    inst: Instance, seed: int, method: str
) -> None:
    res = solve(inst, method, seed=seed, iterations=150, restart=20, polish=5, replan_pair=1.0)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    oracle = {"asa-dtc": "cluster", "asa-stc": "static", "asa-nontc": "task"}[method]
    # the static optimum at the search's own roll rule (ASA's default is "nadir", the
    # oracle's "midpoint": with midpoint rolls a static slew can be 0.5 s too long where the
    # nadir-closest roll fits, and asa-stc then rightly beats that oracle)
    roll_rule = ASAParams().roll_rule
    assert res.profit <= brute_force(inst, oracle, roll_rule=roll_rule).profit + 1e-9
    assert res.stats["restarts"] >= 1 or res.iterations < 150


def test_replan_leaves_a_best_stretch_untouched() -> None:
    """With {a, b} already clustered (the optimum of ``_abc``), the best chain is the stretch
    as it stands: the move changes nothing and does not even free it (no orbit touched)."""
    inst = _abc()
    state, _ = _state(inst)
    a, b = (inst.target_opps[inst.target_index[t]][0] for t in "ab")
    state.begin()
    state.touch(0).insert(state.make_cluster((a, b)))
    state.assign(state.pb.opt_unit[a], a)
    state.assign(state.pb.opt_unit[b], b)
    state.commit()
    before = list(state.lines[0].obs)
    state.begin()
    assert replan_stretch(state, 0, state.pb.orbit_options[0], None) == []
    assert list(state.touched_orbits()) == [] and state.lines[0].obs == before
    assert state.profit == 6 and state.check()
