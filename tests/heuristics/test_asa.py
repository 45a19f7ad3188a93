"""ASA-DTC and its variants: feasibility, optimality bounds, and each step by hand."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.asa import (
    AdaptiveRoulette,
    AdaptiveTemperature,
    ASAParams,
    Outcome,
    TabuList,
    solve_asa_dtc,
    trace_csv,
    write_trace_csv,
)
from heuristics.asa.neighbourhoods import (
    clustering_gain,
    initial_solution,
    insert_options,
    insertion_move,
    migration_move,
)
from heuristics.asa.problem import build_problem
from heuristics.asa.replan import replan_move
from heuristics.asa.state import MEMBERS, State
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from tests.conftest import (
    scenario,
    small_instances,
    tiny_chain,
    tiny_cluster,
    tiny_openings,
    tiny_two_orbits,
)
from tests.limits import limit_kept
from tests.oracle import brute_force

METHODS = ("asa-dtc", "asa-stc", "asa-nontc")
MODE = {"asa-dtc": "dtc", "asa-stc": "stc", "asa-nontc": "nontc"}
ORACLE = {"asa-dtc": "cluster", "asa-stc": "static", "asa-nontc": "task"}


def _state(inst: Instance, mode: str = "dtc", **kw) -> tuple[State, ASAParams]:
    """The search state under the paper's rules (``preset="paper"``, the hand computations
    below follow them), with ``kw`` overriding."""
    params = ASAParams.from_kwargs(preset="paper", **kw)
    return State(build_problem(inst, mode, params.roll_rule), params.roll_rule), params


def _opp(inst: Instance, target: str, orbit: int = 0) -> int:
    k = inst.target_index[target]
    return next(int(i) for i in inst.target_opps[k] if inst.opp_orbit[i] == orbit)


def _scheduled(state: State, inst: Instance) -> set[str]:
    return {inst.target_ids[u] for u in state.scheduled}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16), method=st.sampled_from(METHODS))
def test_every_schedule_passes_the_validator(inst: Instance, seed: int, method: str) -> None:
    res = solve(inst, method, seed=seed, iterations=150, check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8), seed=st.integers(0, 2**16), method=st.sampled_from(METHODS)
)
def test_profit_never_exceeds_the_exact_optimum(inst: Instance, seed: int, method: str) -> None:
    res = solve(inst, method, seed=seed, iterations=200)
    # the static tasks' rolls follow the search's own rule (nadir by default, not (9))
    rule = ASAParams.from_kwargs().roll_rule
    assert res.profit <= brute_force(inst, ORACLE[method], rule).profit + 1e-9


def test_stc_oracle_follows_the_roll_rule() -> None:
    """Hypothesis's case: the static task {o4, o5} (common range [19, 20]) and o6 (roll 0)
    fit (3) only at the nadir-closest roll 19 (27 + 2 + 19 = 48), not at the midpoint 19.5;
    asa-stc, nadir by default, takes both targets."""
    from sosp.instance import Resources

    res = Resources(
        memory_capacity=15.0, energy_capacity=40.0, setup_time=2.0, max_openings=2,
        max_duration=10.0,
    )  # fmt: skip
    inst = Instance.build(
        [2, 2],
        [
            (0, 0, 0, 1, 0.0, -3.0, 3.0),
            (0, 0, 0, 1, 0.0, -3.0, 3.0),
            (0, 0, 0, 8, 0.0, -3.0, 3.0),
            (0, 0, 20, 21, 22.0, 19.0, 25.0),
            (0, 0, 20, 27, 17.0, 14.0, 20.0),
            (1, 0, 48, 56, 0.0, -3.0, 3.0),
        ],
        resources=res,
        orbit_length=57.0,
    )
    assert brute_force(inst, "static", "midpoint").profit == 2
    assert brute_force(inst, "static", "nadir").profit == 4
    out = solve(inst, "asa-stc", seed=0, iterations=200)
    assert validate(inst, out.schedule).feasible and out.profit == 4


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16), mode=st.sampled_from(["dtc", "stc"]))
def test_journal_keeps_totals_exact_under_commit_and_rollback(
    inst: Instance, seed: int, mode: str
) -> None:
    """Random moves, half kept, half undone: lines stay feasible, totals equal a recount."""
    state, params = _state(inst, mode)
    rng = np.random.default_rng(seed)
    initial_solution(state, params)
    assert state.check()
    commit_or_rollback(state, params, rng, (insertion_move, migration_move, replan_move), 60)


def commit_or_rollback(state, params, rng, moves, steps: int) -> None:
    """Apply ``steps`` random ``moves``, keep half, undo the rest; check the state after each.

    An undone move must restore profit, lines and assignment exactly; after every step each
    orbit line is feasible and the profit equals a recount of the covered targets.
    """
    for _ in range(steps):
        before = (state.profit, state.snapshot(), list(state.sched))
        state.begin()
        move = moves[int(rng.integers(len(moves)))]
        made = move(state, rng, params, None)
        if made and rng.random() < 0.5:
            state.commit()
        else:
            state.rollback()
            assert (state.profit, state.snapshot(), list(state.sched)) == before
        assert state.check()
        covered = {k for u in state.scheduled for k in state.pb.unit_targets[u]}
        assert state.profit == pytest.approx(sum(state.pb.target_weight[k] for k in covered))


def test_tiny_named_instances_reach_the_cluster_optimum(tiny: Instance) -> None:
    """With (16) off every tiny instance reaches the clustering optimum."""
    res = solve(tiny, "asa-dtc", seed=3, iterations=300, rule16=False)
    assert res.profit == brute_force(tiny, "cluster").profit


def test_rule16_ignores_openings() -> None:
    """tiny_openings (c = 2): the optimum 10 clusters a+b and c+d over 98 s gaps. The literal
    (16) sees only energy and memory (roll 0: no slew saved, 98 s more memory), so ASA-DTC
    with it never clusters them and keeps the best two singles, d + c = 7 (the paper's two
    moves; orbit re-planning, which does not consult (16), finds 10)."""
    inst = tiny_openings()
    assert brute_force(inst, "cluster").profit == 10
    kw = {"seed": 3, "iterations": 300, "rule16_openings": False}
    assert solve(inst, "asa-dtc", replan=False, **kw).profit == 7
    assert solve(inst, "asa-dtc", **kw).profit == 10


def test_rule16_with_openings_clusters_when_openings_are_scarce() -> None:
    """sosp's reading (the default) counts openings: c joining d (d alone on the orbit) saves one of
    c = 2 openings. By hand: d [300, 302], c [200, 202], roll 0, E = 1500, W = 1000.
    en = 2 + 2 = 4, ec = 102 (window [200, 302]); wn = 4, wc = 102; shares consumed
    ConE/E = 2/1500, ConW/W = 2/1000; gamma = 1 opening used / 2.
    saving = (2/1500)(4 - 102)/1500 + (2/1000)(4 - 102)/1000 + (1/2)/2 = 0.25 - 2.83e-4."""
    inst = tiny_openings()
    state, params = _state(inst, rule16_openings=True)
    c, d = _opp(inst, "c"), _opp(inst, "d")
    state.begin()
    assert insert_options(state, [d], params) == d
    line = state.lines[0]
    gain = clustering_gain(state, line, line.obs[0], c, params)
    expected = (2 / 1500) * (4 - 102) / 1500 + (2 / 1000) * (4 - 102) / 1000 + 0.5 / 2
    assert gain is not None and gain[0] == pytest.approx(expected)
    assert gain[1][:3] == (200.0, 302.0, 0.0)
    # literal (16): alpha (en - ec) + beta (wn - wc) < 0, refused
    literal = ASAParams(rule16_openings=False)
    assert clustering_gain(state, line, line.obs[0], c, literal) is None
    assert solve(inst, "asa-dtc", seed=3, iterations=300).profit == 10


# ------------------------------------------------------------------------- insertion by hand
def test_isolated_then_clustering_insertion_window_and_roll() -> None:
    """tiny_cluster: a alone, then b joins a (exclusive by (3): 4 + 10 + 20 > 5).

    Common range [max(8, 6), min(14, 12)] = [8, 12] (8); midpoint 10 (9); window [0, 9] (10).
    """
    inst = tiny_cluster()
    state, params = _state(inst)
    a, b = _opp(inst, "a"), _opp(inst, "b")
    state.begin()
    assert insert_options(state, [a], params) == a
    assert state.lines[0].obs == [(0.0, 4.0, 11.0, 8.0, 14.0, (a,))]
    assert insert_options(state, [b], params) == b
    assert state.lines[0].obs == [(0.0, 9.0, 10.0, 8.0, 12.0, (a, b))]
    assert state.profit == 9
    # removing a component recomputes the cluster-task by (8)-(10): b alone, own roll 9
    assert state.cluster_without(state.lines[0].obs[0], a) == (5.0, 9.0, 9.0, 6.0, 12.0, (b,))


def test_nadir_roll_rule() -> None:
    inst = tiny_cluster()
    state, params = _state(inst, roll_rule="nadir")
    state.begin()
    insert_options(state, [_opp(inst, "a")], params)
    insert_options(state, [_opp(inst, "b")], params)
    assert state.lines[0].obs[0][2] == 8.0  # closest to nadir in [8, 12]


def test_insertion_removes_the_setup_conflict() -> None:
    """tiny_chain: b, c scheduled; inserting a (5) breaks (3) with b (gap 6 < 10 + 11): b goes."""
    inst = tiny_chain()
    state, params = _state(inst)
    state.begin()
    for t in ("b", "c"):
        insert_options(state, [_opp(inst, t)], params)
    state.commit()
    state.begin()
    insert_options(state, [_opp(inst, "a")], params)
    assert _scheduled(state, inst) == {"a", "c"}
    assert state.profit == 8
    assert [inst.target_ids[u] for u in state.commit()] == ["b"]


def test_openings_removal_prefers_low_weight() -> None:
    """tiny_openings (c = 2): with c, d scheduled, inserting b overflows (6); equal resource
    use (2 s, roll 0), so the lighter c (3) goes before d (4). The literal (16) keeps c and d
    apart (with openings counted they would cluster and (6) would not overflow)."""
    inst = tiny_openings()
    state, params = _state(inst, rule16_openings=False)
    state.begin()
    for t in ("c", "d", "b"):
        insert_options(state, [_opp(inst, t)], params)
    assert _scheduled(state, inst) == {"b", "d"}
    assert state.lines[0].feasible()


def test_conflict_trims_the_end_component_of_a_cluster() -> None:
    """Cluster {a, b} = [0, 9] roll 10; d [25, 29] roll 0 clashes (9 + 10 + 10 > 25). Only the
    facing end component b goes; a alone ([0, 4], roll 11) then fits: 4 + 10 + 11 = 25."""
    inst = Instance.build(
        {"a": 5, "b": 4, "d": 9},
        [
            ("a", 0, 0.0, 4.0, 11.0, 8.0, 14.0),
            ("b", 0, 5.0, 9.0, 9.0, 6.0, 12.0),
            ("d", 0, 25.0, 29.0, 0.0, -3.0, 3.0),
        ],
    )
    state, params = _state(inst)
    state.begin()
    for t in ("a", "b"):
        insert_options(state, [_opp(inst, t)], params)
    assert state.lines[0].obs[0][MEMBERS] == (_opp(inst, "a"), _opp(inst, "b"))
    insert_options(state, [_opp(inst, "d")], params)
    assert _scheduled(state, inst) == {"a", "d"}
    assert state.lines[0].obs[0] == (0.0, 4.0, 11.0, 8.0, 14.0, (_opp(inst, "a"),))


def test_step1_pool_and_tabu() -> None:
    """pool = 1 is the paper's deterministic rule; tabu tasks are never chosen."""
    inst = tiny_chain()
    state, params = _state(inst, pool=1)
    rng = np.random.default_rng(0)
    state.begin()
    assert insertion_move(state, rng, params, None)
    assert _scheduled(state, inst) == {"a"}
    state.rollback()
    tabu = TabuList(1)
    tabu.add([0])  # a
    state.begin()
    assert insertion_move(state, rng, params, tabu)
    assert _scheduled(state, inst) == {"b"}


def test_migration_moves_a_and_fills_its_slot() -> None:
    """tiny_two_orbits: a on orbit 0 blocks b; migration moves a to orbit 1 (its only other
    opportunity), then step 3 inserts b, its unscheduled setup-time conflicting task."""
    inst = tiny_two_orbits()
    state, params = _state(inst)
    rng = np.random.default_rng(0)
    state.begin()
    insert_options(state, [_opp(inst, "a", 0)], params)
    state.commit()
    state.begin()
    assert migration_move(state, rng, params, None)
    assert state.sched[inst.target_index["a"]] == _opp(inst, "a", 1)
    assert _scheduled(state, inst) == {"a", "b"}
    assert state.profit == 11
    assert state.commit() == []


def test_initial_solution_keeps_only_improvements() -> None:
    """5.4 on tiny_chain: a (5) in, b (4) would remove a: refused, c (3) in."""
    inst = tiny_chain()
    state, params = _state(inst)
    initial_solution(state, params)
    assert _scheduled(state, inst) == {"a", "c"}


def test_initial_solution_stops_at_its_deadline() -> None:
    """Past its deadline the pass tries no task: the (empty) solution so far is kept."""
    inst = tiny_chain()
    state, params = _state(inst)
    initial_solution(state, params, Budget.until(time.perf_counter() - 1.0))
    assert _scheduled(state, inst) == set() and state.profit == 0
    initial_solution(state, params, Budget.of(60.0))
    assert _scheduled(state, inst) == {"a", "c"}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=12), mode=st.sampled_from(["dtc", "stc", "nontc"]))
def test_problem_rows_are_the_definitions(inst: Instance, mode: str) -> None:
    """The problem's conflict rows, alternatives, migration scores and orbit options, made
    from arrays, against their definitions written out over the tasks."""
    from sosp.conflicts import setup_conflict_pairs
    from sosp.rules import all_orbit_rules

    pb = build_problem(inst, mode)
    t = pb.tasks
    rules = all_orbit_rules(inst)
    n = len(t)
    usable = [rules[t.orbit[x]].alone_ok(t.start[x], t.end[x]) for x in range(n)]
    pairs = setup_conflict_pairs(inst, t.orbit, t.start, t.end, t.roll).tolist()
    for x in range(n):
        want = sorted({h for i, h in pairs if i == x} | {i for i, h in pairs if h == x})
        assert pb.conflicts[x] == ([h for h in want if usable[h]] if usable[x] else [])
        if mode != "stc":
            same = [y for y in range(n) if usable[y] and pb.opt_unit[y] == pb.opt_unit[x]]
            assert pb.alternatives[x] == ([y for y in same if y != x] if usable[x] else [])
        expected = len(pb.conflicts[x]) if pb.alternatives[x] else -1
        assert pb.migration_score[x] == expected
    for j, opts in enumerate(pb.orbit_options):
        on_j = [x for x in range(n) if usable[x] and t.orbit[x] == j]
        assert opts == sorted(on_j, key=lambda y: (t.start[y], y))
    assert len(pb.conflicts) == len(pb.alternatives) == n


# ---------------------------------------------------------------------------- adaptive rules
def test_neighbourhood_probabilities_17_18() -> None:
    """Sel = (6, 4), Suc = (3, 0): pro' = (0.8*0.5 + 0.2*3/6, 0.8*0.5 + 0) = (0.5, 0.4),
    normalised (18) to (5/9, 4/9); counters reset."""
    sel = AdaptiveRoulette([0.5, 0.5], eta=0.8, itr=10)
    for o in (Outcome.BEST, Outcome.BETTER, Outcome.BETTER, Outcome.ACCEPTED) + (
        Outcome.REJECTED,
    ) * 2:
        sel.record(0, o)
    for _ in range(3):
        sel.record(1, Outcome.ACCEPTED)
    assert sel.probabilities == [0.5, 0.5]  # 9 iterations: no update yet
    sel.record(1, Outcome.REJECTED)
    assert sel.probabilities == pytest.approx([5 / 9, 4 / 9])
    assert sel.sel == [0, 0] and sel.suc == [0, 0]


def test_temperature_20_21() -> None:
    t = AdaptiveTemperature(0.5, 1.0, 10.0, r_update="generated")
    assert t.temperature == 0.5
    for delta, r in ((-3, 1), (0, 1), (-1, 2), (-2, 3), (4, 0), (-1, 1)):
        t.update(delta, accepted=False)
        assert t.r == r
        assert t.temperature == pytest.approx(0.5 + math.log(1 + r / 10))
    acc = AdaptiveTemperature(0.5, 1.0, 10.0, r_update="accepted")
    acc.update(-3, accepted=False)
    assert acc.r == 0  # Algorithm 1: r changes only in the acceptance branches
    acc.update(-3, accepted=True)
    assert acc.r == 1


def test_metropolis_acceptance() -> None:
    t = AdaptiveTemperature(0.5, 1.0, 10.0)
    rng = np.random.default_rng(1)
    assert t(1.0, rng) and t(0.0, rng)
    draws = np.random.default_rng(2).random(2000)
    n = sum(t(-1.0, np.random.default_rng([2, i])) for i in range(2000))
    assert abs(n / 2000 - math.exp(-2.0)) < 0.03
    del draws


def test_tabu_list_fifo() -> None:
    tabu = TabuList(2)
    tabu.add([1, 2])
    assert 1 in tabu and 2 in tabu
    tabu.add([3])
    assert 1 not in tabu and tabu.items() == [2, 3]
    tabu.add([3])  # 3 twice: stays tabu until both entries leave
    assert tabu.items() == [3, 3] and 2 not in tabu
    tabu.add([4])
    assert 3 in tabu
    tabu.add([5])
    assert 3 not in tabu
    off = TabuList(0)
    off.add([1])
    assert 1 not in off


def test_tabu_length_default_is_n_over_50() -> None:
    inst = tiny_chain()
    res = solve(inst, "asa-dtc", seed=0, iterations=5)
    assert res.stats["tabu_length"] == 1


# ------------------------------------------------------------------- params, API, trace
@pytest.mark.parametrize(
    "kw",
    [
        {"lambda_min": 0},
        {"eta": 1.5},
        {"itr": 0},
        {"pool": 0},
        {"roll_rule": "left"},
        {"r_update": "sometimes"},
        {"pro1": -1},
        {"pro1": 0, "pro2": 0, "replan": False},
        {"pro1": 0, "pro2": 0, "pro3": 0},
        {"replan": "maybe"},
        {"replan_pull": 1.5},
        {"replan_opps": 0},
        {"replan_floor": 0.5},
        {"nadir_singles": "maybe"},
        {"orbit_share": "maybe"},
        {"replan_pair": 2},
        {"replan_target": -1},
        {"replan_depth": 0},
        {"restart": 0},
        {"polish": -1},
        {"delta": float("nan")},
        {"iterations": -1},
        {"no_such": 1},
        {"rule16": "maybe"},
    ],
)
def test_bad_params_raise_input_error(kw: dict) -> None:
    with pytest.raises(InputError):
        solve(tiny_chain(), "asa-dtc", seed=0, **kw)


def test_cli_strings_are_coerced() -> None:
    p = ASAParams.from_kwargs(iterations="50", lambda_min="0.7", rule16="false", roll_rule="nadir")
    assert (p.iterations, p.lambda_min, p.rule16, p.roll_rule) == (50, 0.7, False, "nadir")


def test_preset_applies_first_and_keywords_override() -> None:
    p = ASAParams.from_kwargs(preset="quality", rho="0.5")
    assert (p.roll_rule, p.nadir_singles, p.replan_orbit) == ("nadir", True, 1.0)
    assert p.orbit_share is True
    assert (p.rho, p.lambda_min) == (0.5, 0.2)
    assert ASAParams.from_kwargs(preset="default") == ASAParams()
    with pytest.raises(InputError, match="preset"):
        ASAParams.from_kwargs(preset="fastest")


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), seed=st.integers(0, 2**16))
def test_quality_preset_is_feasible_and_never_beats_the_optimum(inst: Instance, seed: int) -> None:
    """The quality preset's nadir rolls and whole-orbit moves stay inside the one model."""
    res = solve(inst, "asa-dtc", seed=seed, iterations=200, preset="quality", check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.profit <= brute_force(inst, "cluster").profit + 1e-9
    assert res.schedule.params["preset"] == "quality"


@pytest.mark.limits
def test_stopping_rules_and_trace(tmp_path) -> None:
    inst = tiny_chain()
    res = solve(inst, "asa-dtc", seed=0, iterations=1000, no_improve=30, trace_every=10)
    assert res.iterations == 30  # the initial solution is optimal: no new best ever
    res = solve(inst, "asa-dtc", seed=0, time_limit=0.2)
    assert res.iterations > 0
    limit_kept("asa-dtc, 0.2 s", res.runtime_s, 1.0)
    text = trace_csv(res)
    head, *rows = text.strip().split("\n")
    assert head.startswith("iteration,time_s,best,current,temperature")
    assert rows and all(len(r.split(",")) == len(head.split(",")) for r in rows)
    path = tmp_path / "trace.csv"
    write_trace_csv(res, path)
    assert path.read_text() == text


def test_direct_call_signature() -> None:
    res = solve_asa_dtc(tiny_cluster(), rng=np.random.default_rng(0), iterations=50)
    assert res.status.value == "feasible" and res.profit == 11


# --------------------------------------------------------------------- reference scenarios
@pytest.mark.slow
@pytest.mark.parametrize("name", ["B1", "B2", "B3", "C1", "C2", "C3"])
def test_reference_scenarios_validate(name: str) -> None:
    inst = scenario(name)
    for method in METHODS:
        res = solve(inst, method, seed=1, iterations=1500, check=False)
        rep = validate(inst, res.schedule)
        assert rep.feasible, (method, rep.violations[:3])
        assert rep.profit == pytest.approx(res.profit)
