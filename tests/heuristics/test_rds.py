"""Russian Doll Search: exact on tiny instances (brute force through the validator)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import heuristics.rds as rds_module
from heuristics.rds import orbit_resources_can_bind, pairwise_conflicts, russian_doll
from sosp.clustering import TaskSet, single_tasks, static_cluster_tasks, tasks_to_schedule
from sosp.instance import Instance, Resources
from sosp.result import Status
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from tests.conftest import scenario, tiny_chain, tiny_cluster, tiny_openings, tiny_two_orbits
from tests.oracle import brute_force as oracle


class Countdown(Budget):
    """A budget spent from its ``n``-th reading on (each ``fits``, ``expired`` or ``left``
    is one reading of the clock)."""

    def __init__(self, n: int) -> None:
        super().__init__(deadline=float("inf"))
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "readings", [])

    def _spent(self) -> bool:
        self.readings.append(1)
        return len(self.readings) >= self.n

    def fits(self, seconds: float) -> bool:
        return not self._spent()

    def left(self) -> float:
        return 0.0 if self._spent() else 1.0


def random_tiny(seed: int) -> Instance:
    """A random instance small enough for exhaustive search, with tight resources."""
    rng = np.random.default_rng(seed)
    n_orbits = int(rng.integers(1, 3))
    n_targets = int(rng.integers(3, 6))
    n_opps = int(rng.integers(4, 10))
    rows = []
    for _ in range(n_opps):
        s = float(rng.integers(0, 200))
        d = float(rng.integers(1, 9))
        r = float(rng.uniform(-30, 30))
        half = float(rng.choice([3.0, 8.0]))
        rows.append(
            (
                int(rng.integers(0, n_targets)),
                int(rng.integers(0, n_orbits)),
                s,
                s + d,
                r,
                max(-33.0, r - half),
                min(33.0, r + half),
            )
        )
    res = Resources(
        energy_capacity=float(rng.integers(20, 200)),
        memory_capacity=float(rng.integers(8, 40)),
        max_openings=int(rng.integers(1, 5)),
        max_duration=20.0,
    )
    weights = [int(w) for w in rng.integers(1, 11, size=n_targets)]
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"rnd{seed}")


def brute_force(instance: Instance, tasks: TaskSet) -> float:
    """Best profit over all subsets of tasks that the validator accepts."""
    best = 0.0
    n = len(tasks)
    for r in range(1, n + 1):
        for subset in itertools.combinations(range(n), r):
            rep = validate(instance, tasks_to_schedule(instance, tasks, subset))
            if rep.feasible and rep.profit > best:
                best = rep.profit
    return best


@pytest.mark.parametrize("seed", range(30))
def test_rds_equals_brute_force_on_random_tiny(seed: int) -> None:
    inst = random_tiny(seed)
    want_single = brute_force(inst, single_tasks(inst))
    want_static = brute_force(inst, static_cluster_tasks(inst))
    for variables in ("targets", "tasks"):
        for order in ("orbit", "weight"):
            for decompose in (True, False):
                kw = dict(variables=variables, order=order, decompose=decompose)
                res = solve(inst, "rds", **kw)
                assert res.status is Status.OPTIMAL and res.profit == want_single, kw
                assert res.bound == res.profit
                res = solve(inst, "rds-stc", **kw)
                assert res.status is Status.OPTIMAL and res.profit == want_static, kw
                assert validate(inst, res.schedule).feasible


# ------------------------------------------------------------ the search's own ingredients
def random_orbit(seed: int, n: int, tight: bool) -> Instance:
    """One orbit with n opportunities of distinct targets, crowded in time."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        s = float(rng.integers(0, 150))
        r = float(rng.uniform(-20, 20))
        rows.append((i, 0, s, s + float(rng.integers(1, 15)), r))
    # Tight: capacities around what the crowded sequences need, so both answers occur.
    res = (
        Resources(
            energy_capacity=float(rng.integers(10, 120)),
            memory_capacity=float(rng.integers(5, 40)),
            max_openings=int(rng.integers(1, 5)),
            setup_time=float(rng.integers(0, 6)),
        )
        if tight
        else Resources(setup_time=float(rng.integers(0, 6)))
    )
    return Instance.build([1] * n, rows, resources=res, name=f"orbit{seed}")


def sequence_ok_3(inst: Instance, subset: tuple[int, ...]) -> bool:
    """Constraint (3) alone for these opportunities of orbit 0 (consecutive pairs)."""
    order = sorted(subset, key=lambda i: (inst.opp_start[i], inst.opp_end[i]))
    a, v = float(inst.setup_time[0]), float(inst.slew_rate[0])
    for u, w in zip(order, order[1:], strict=False):
        turn = (abs(inst.opp_roll[u]) + abs(inst.opp_roll[w])) / v
        if inst.opp_end[u] + a + turn > inst.opp_start[w] + 1e-9:
            return False
    return True


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), n=st.integers(2, 8), tight=st.booleans())
def test_resources_that_cannot_bind_never_cut_a_sequence(seed: int, n: int, tight: bool) -> None:
    # If orbit_resources_can_bind says False, every subset satisfying (3) satisfies (4)-(6).
    inst = random_orbit(seed, n, tight)
    tasks = single_tasks(inst)
    if orbit_resources_can_bind(inst, tasks, np.arange(n)):
        return
    for r in range(1, n + 1):
        for subset in itertools.combinations(range(n), r):
            if sequence_ok_3(inst, subset):
                rep = validate(inst, tasks_to_schedule(inst, tasks, subset))
                assert rep.feasible, (subset, rep.violations)


def test_resources_cannot_bind_when_only_conflicting_tasks_overflow() -> None:
    # a and b overlap in time, so (3) never lets both in: 60 + 60 s exceeds W = 100 but no
    # schedule can reach it. One long orbit item c apart keeps (5) at 60 + 30 = 90.
    inst = Instance.build(
        {"a": 1, "b": 1, "c": 1},
        [("a", 0, 0, 60, 0.0), ("b", 0, 30, 90, 0.0), ("c", 0, 200, 230, 0.0)],
        resources=Resources(memory_capacity=100.0),
    )
    assert not orbit_resources_can_bind(inst, single_tasks(inst), np.arange(3))
    # With c 50 s long, a + c = 110 > 100: now (5) can bind.
    inst = Instance.build(
        {"a": 1, "b": 1, "c": 1},
        [("a", 0, 0, 60, 0.0), ("b", 0, 30, 90, 0.0), ("c", 0, 200, 250, 0.0)],
        resources=Resources(memory_capacity=100.0),
    )
    assert orbit_resources_can_bind(inst, single_tasks(inst), np.arange(3))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), n=st.integers(2, 8))
def test_pairwise_conflicts_never_share_a_schedule(seed: int, n: int) -> None:
    # The availability bound closes every task in conflict with a scheduled one: no feasible
    # schedule may hold such a pair, whatever lies between them.
    inst = random_orbit(seed, n, tight=False)
    tasks = single_tasks(inst)
    conf = pairwise_conflicts(inst, tasks, list(range(n)))
    pairs = {(u, v) for u in range(n) for v in conf[u]}
    assert all((v, u) in pairs for u, v in pairs)
    for r in range(2, n + 1):
        for subset in itertools.combinations(range(n), r):
            if any((u, v) in pairs for u, v in itertools.combinations(subset, 2)):
                rep = validate(inst, tasks_to_schedule(inst, tasks, subset))
                assert not rep.feasible, subset
    # And a pair it does not report fits alone (the conflicts are not over-reported).
    for u, v in itertools.combinations(range(n), 2):
        if (u, v) not in pairs:
            assert sequence_ok_3(inst, (u, v))


def test_fix_free_tasks_by_hand() -> None:
    # Roomy orbit: c (alone in time) is fixed; a and b conflict, so neither is; then a task
    # b2 on orbit 1 covering only c's target would be dropped as useless.
    inst = Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [
            ("a", 0, 0, 10, 0.0),
            ("b", 0, 5, 15, 0.0),
            ("c", 0, 200, 210, 0.0),
            ("c", 1, 0, 10, 0.0),
        ],
        n_orbits=2,
    )
    tasks = single_tasks(inst)
    fixed, rest = rds_module.fix_free_tasks(inst, tasks, list(range(4)))
    assert fixed == [2] and rest == [0, 1]
    # With c = 1 opening the orbit's resources can bind: nothing may be fixed there, but
    # the task on orbit 1 is alone and loose.
    inst1 = Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [("a", 0, 0, 10, 0.0), ("b", 0, 5, 15, 0.0), ("c", 0, 200, 210, 0.0)],
        resources=Resources(max_openings=1),
    )
    fixed, rest = rds_module.fix_free_tasks(inst1, single_tasks(inst1), [0, 1, 2])
    assert fixed == [] and rest == [0, 1, 2]


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16))
def test_some_optimum_contains_the_fixed_tasks(seed: int) -> None:
    # The reduction's claim, checked by brute force: the best selection containing the fixed
    # tasks is as good as the best selection at all.
    inst = crowded(seed)
    for tasks in (single_tasks(inst), static_cluster_tasks(inst)):
        fixed, _ = rds_module.fix_free_tasks(inst, tasks, list(range(len(tasks))))
        rest = [t for t in range(len(tasks)) if t not in fixed]
        best_with = 0.0
        for r in range(len(rest) + 1):
            for subset in itertools.combinations(rest, r):
                rep = validate(inst, tasks_to_schedule(inst, tasks, sorted(fixed + list(subset))))
                if rep.feasible:
                    best_with = max(best_with, rep.profit)
        assert best_with == brute_force(inst, tasks)


def crowded(seed: int) -> Instance:
    """Targets seen from two or three orbits, crowded in time: losses by (3) and (4)-(6)."""
    rng = np.random.default_rng(seed)
    n_orbits = int(rng.integers(2, 4))
    n_targets = int(rng.integers(4, 8))
    rows = []
    for k in range(n_targets):
        for j in rng.choice(n_orbits, size=int(rng.integers(1, n_orbits + 1)), replace=False):
            s = float(rng.integers(0, 60))
            rows.append((k, int(j), s, s + float(rng.integers(2, 12)), float(rng.uniform(-15, 15))))
    rows = rows[:11]
    res = Resources(
        energy_capacity=float(rng.choice([60.0, 1e6])),
        memory_capacity=float(rng.choice([25.0, 1e6])),
        max_openings=int(rng.choice([2, 10])),
        setup_time=float(rng.integers(0, 6)),
    )
    weights = [int(w) for w in rng.integers(1, 11, size=n_targets)]
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"crowd{seed}")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16), order=st.sampled_from(["orbit", "weight"]))
def test_rds_equals_the_oracle_with_restarts_in_both_branching_orders(
    seed: int, order: str
) -> None:
    # A node budget of 1 makes every search pass restart many times and alternate the static
    # and fail-first orders, so both orders and the restarts are exercised on every instance.
    inst = crowded(seed)
    for budget in (1, 1000):
        for method, model in (("rds", "task"), ("rds-stc", "static")):
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr(rds_module, "_FIRST_BUDGET", budget)
                res = solve(inst, method, order=order)
            assert res.status is Status.OPTIMAL, (method, budget)
            assert res.profit == oracle(inst, model).profit, (method, budget)
            assert validate(inst, res.schedule).feasible


def test_overlapping_windows_and_setup_conflicts() -> None:
    # tiny_chain: a-b conflict by (3); {a, c} = 8 beats {b, c} = 7.
    assert solve(tiny_chain(), "rds").profit == 8
    # tiny_cluster: alone a and b conflict ({a, c} = 7); as one cluster-task all three = 11.
    assert solve(tiny_cluster(), "rds").profit == 7
    assert solve(tiny_cluster(), "rds-stc").profit == 11


def test_target_on_two_orbits_is_moved() -> None:
    # a on orbit 0 blocks b; the optimum takes a on orbit 1 and b on orbit 0: 6 + 5.
    res = solve(tiny_two_orbits(), "rds")
    assert res.profit == 11
    assert {o.orbit for o in res.schedule.observations} == {0, 1}


def test_energy_binds_through_the_slew_term() -> None:
    # Observing costs 2 each; a-b slew (20 + 20)/1 = 40, so {a, b} needs 44 > E = 40 while
    # {a, c} needs 4 + 20 = 24: the optimum is 5 + 3 = 8, not a + b = 10.
    inst = Instance.build(
        {"a": 5, "b": 5, "c": 3},
        [("a", 0, 0, 2, 20.0), ("b", 0, 100, 102, 20.0), ("c", 0, 200, 202, 0.0)],
        resources=Resources(energy_capacity=40.0),
    )
    assert orbit_resources_can_bind(inst, single_tasks(inst), np.arange(3))
    res = solve(inst, "rds")
    assert res.profit == 8 == brute_force(inst, single_tasks(inst))


def test_memory_binds() -> None:
    # W = 10: {a, b} needs 12; {a, c} needs 10 (just fits) = 8; {b, c} = 7.
    inst = Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [("a", 0, 0, 6, 0.0), ("b", 0, 100, 106, 0.0), ("c", 0, 200, 204, 0.0)],
        resources=Resources(memory_capacity=10.0),
    )
    res = solve(inst, "rds")
    assert res.profit == 8
    assert sorted(o.opps[0] for o in res.schedule.observations) == [0, 2]


def test_openings_bind() -> None:
    # c = 2: alone, only the two heaviest, d (4) and c (3).
    assert solve(tiny_openings(), "rds").profit == 7
    # Static clusters at roll 0: a+b [0, 102] and c+d [200, 302] (spans <= 120): two
    # openings cover all four targets.
    res = solve(tiny_openings(), "rds-stc")
    assert res.profit == 10 and len(res.schedule) == 2


def test_loose_orbits_split_into_components() -> None:
    # Three targets far apart on a roomy orbit: nothing interacts, three components.
    inst = Instance.build(
        {"a": 1, "b": 2, "c": 3},
        [("a", 0, 0, 2, 0.0), ("b", 0, 100, 102, 0.0), ("c", 0, 200, 202, 0.0)],
    )
    out = russian_doll(inst, single_tasks(inst), reduce=False)
    assert len(out.components) == 3 and out.value == 6 and out.proven
    # The reduction fixes all three (no conflict, resources that cannot bind): no search.
    out = russian_doll(inst, single_tasks(inst))
    assert out.components == [] and out.value == 6 and out.proven and out.chosen == [0, 1, 2]
    # With c = 2 the openings bind: one component, and the optimum drops a.
    out = russian_doll(tiny_openings(), single_tasks(tiny_openings()))
    assert len(out.components) == 1 and out.value == 7


def test_time_limit_returns_incumbent_and_bound() -> None:
    # Many overlapping opportunities on one orbit with c = 10: not solved in 0.05 s.
    rng = np.random.default_rng(7)
    starts, rolls = rng.uniform(0, 900, 120), rng.uniform(-30, 30, 120)
    rows = [(i, 0, float(starts[i]), float(starts[i]) + 3.0, float(rolls[i])) for i in range(120)]
    inst = Instance.build([int(w) for w in rng.integers(2, 11, 120)], rows)
    res = solve(inst, "rds", time_limit=0.05)
    assert res.status is Status.TIME_LIMIT
    assert res.bound is not None and res.bound >= res.profit > 0
    assert validate(inst, res.schedule).feasible


@pytest.mark.slow
def test_rds_stc_scenario_b1_is_proven(b1) -> None:
    inst = b1
    res = solve(inst, "rds-stc", time_limit=120)
    assert res.status is Status.OPTIMAL and res.bound == res.profit
    hpfs = solve(inst, "hpfs-stc")
    assert res.profit >= hpfs.profit


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "method", "model"),
    [("B1", "rds", "task"), ("B1", "rds-stc", "static"), ("C1", "rds-stc", "static")],
)
def test_rds_proves_the_milp_optimum(name: str, method: str, model: str) -> None:
    # Issue 5's acceptance: RDS proves the optimum and equals the MILP model's optimum there
    # (C1: one interaction component of 214 static tasks, proven in about 10-45 s).
    models_solve = pytest.importorskip("models.solve")

    inst = scenario(name)
    rds = solve(inst, method, time_limit=300)
    assert rds.status is Status.OPTIMAL and rds.bound == rds.profit
    assert validate(inst, rds.schedule).feasible
    milp = models_solve.solve_milp(inst, rng=np.random.default_rng(0), time_limit=300, model=model)
    assert milp.status is Status.OPTIMAL
    assert milp.profit == pytest.approx(rds.profit), (name, method)


def test_the_preparation_reads_the_clock(monkeypatch: pytest.MonkeyPatch, b3) -> None:
    """On a 5,000-target instance the preparation before the search took 60 s under a 10 s
    limit: the fixing reads the clock before and after its (compiled) adjacency and stops
    with nothing fixed, the loops over conflict pairs read it every ``PAIRS_PER_CHECK``
    pairs, a component's search is not started, and the answer is the fall-back decode,
    valid, within the limit."""
    monkeypatch.setattr(rds_module, "PAIRS_PER_CHECK", 1)
    inst = b3
    tasks = single_tasks(inst)
    usable = list(range(len(tasks)))
    fixed, rest = rds_module.fix_free_tasks(inst, tasks, usable, Countdown(2))
    assert fixed == [] and rest == usable  # spent after one reading
    with pytest.raises(rds_module._Timeout):
        pairwise_conflicts(inst, tasks, usable, Budget.until(0.0))
    out = russian_doll(inst, tasks, time_limit=1e-9)
    assert not out.proven and out.value > 0 and out.bound >= out.value
    assert validate(inst, tasks_to_schedule(inst, tasks, out.chosen)).feasible


def test_the_work_after_the_search_has_its_time_kept_back(
    monkeypatch: pytest.MonkeyPatch,
    b1,
) -> None:
    """The fall-back decode after an unproven search reads no clock (20,000 targets: about
    1 s, and a 3 s limit ran to 4.04 s): the fixing and the search stop that much earlier,
    ``FALLBACK_S_PER_TASK`` a usable task, at most half the limit."""
    import time

    inst = b1
    tasks = single_tasks(inst)
    seen: list[float] = []
    real = rds_module.fix_free_tasks

    def spy(instance, tasks, usable, budget):
        seen.append(budget.deadline)
        return real(instance, tasks, usable, budget)

    monkeypatch.setattr(rds_module, "fix_free_tasks", spy)
    for per_task, kept in ((0.0, 0.0), (1.0, 2.0)):  # none; half of the 4 s limit
        monkeypatch.setattr(rds_module, "FALLBACK_S_PER_TASK", per_task)
        t = time.perf_counter()
        russian_doll(inst, tasks, time_limit=4.0)
        assert t + 4.0 - kept - 0.05 <= seen[-1] <= time.perf_counter() + 4.0 - kept


def test_subproblems_solved_by_repair_read_the_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every subproblem of a loose instance is solved by repairing the last optimum, so no
    search node reads the clock: the loop over the subproblems reads it itself (a polar box
    of 2,212 targets ran 6.8 s of repairs past a 5 s limit)."""
    rows = [(k, k // 6, 100.0 * (k % 6), 100.0 * (k % 6) + 5.0, 0.0) for k in range(24)]
    inst = Instance.build([1 + k % 5 for k in range(24)], rows)
    tasks = single_tasks(inst)
    items = list(range(len(tasks)))
    out = rds_module.rds_targets_component(inst, tasks, items, "orbit")
    assert out.proven and out.nodes == 0  # the repair alone solves it: no node, no clock
    budget = Countdown(12)  # spent at the 12th reading
    out = rds_module.rds_targets_component(inst, tasks, items, "orbit", budget)
    assert not out.proven and budget.readings == [1] * 12
    assert out.bound >= out.value > 0
    assert validate(inst, tasks_to_schedule(inst, tasks, out.chosen)).feasible


def test_preparation_foreseen_too_long_is_skipped(monkeypatch: pytest.MonkeyPatch, b1) -> None:
    # a reduction and a decomposition foreseen to end past the deadline are not started (a
    # 5,000-target instance: 3 s limits ran to 5.8 s); the answer is still valid
    calls: list[str] = []
    monkeypatch.setattr(rds_module, "fix_free_tasks", lambda *a: calls.append("fix"))
    monkeypatch.setattr(rds_module, "interaction_components", lambda *a: calls.append("comps"))
    monkeypatch.setattr(rds_module, "PREP_S_PER_PAIR", 1e6)
    inst = b1
    tasks = single_tasks(inst)
    out = russian_doll(inst, tasks, time_limit=2.0)
    assert calls == []
    assert out.bound >= out.value > 0
    assert validate(inst, tasks_to_schedule(inst, tasks, out.chosen)).feasible
    # without a limit both run as before
    monkeypatch.undo()
    seen = []
    real = rds_module.interaction_components
    monkeypatch.setattr(rds_module, "interaction_components", lambda *a: seen.append(1) or real(*a))
    monkeypatch.setattr(rds_module, "PREP_S_PER_PAIR", 1e6)
    russian_doll(inst, tasks, time_limit=None)
    assert seen == [1]


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**16))
def test_interaction_components_are_those_of_the_whole_graph(seed: int) -> None:
    # the components from the compiled rows and the joining edges equal those of networkx
    # over every edge: setup conflicts, every pair sharing a target, binding orbits' paths
    import networkx as nx

    from sosp.conflicts import setup_conflict_pairs

    inst = crowded(seed)
    for tasks in (single_tasks(inst), static_cluster_tasks(inst)):
        usable = np.arange(len(tasks))[::2] if seed % 2 else np.arange(len(tasks))
        g = nx.Graph()
        g.add_nodes_from(usable.tolist())
        cols = (tasks.orbit[usable], tasks.start[usable], tasks.end[usable], tasks.roll[usable])
        for a, b in setup_conflict_pairs(inst, *cols).tolist():
            g.add_edge(int(usable[a]), int(usable[b]))
        for a, b in itertools.combinations(usable.tolist(), 2):
            if set(tasks.targets[a]) & set(tasks.targets[b]):
                g.add_edge(a, b)
        for j in np.unique(tasks.orbit[usable]):
            on = usable[tasks.orbit[usable] == j]
            if orbit_resources_can_bind(inst, tasks, on):
                nx.add_path(g, on.tolist())
        want = {frozenset(c) for c in nx.connected_components(g)}
        got = rds_module.interaction_components(inst, tasks, usable)
        assert {frozenset(c) for c in got} == want
        assert [len(c) for c in got] == sorted(len(c) for c in got)


def test_conflict_lists_foreseen_late_or_too_large_are_not_made(monkeypatch, b1) -> None:
    """The (3) sweep reads no clock (167 million pairs: 5.7 s, and a 5 s run went to 7.1 s):
    foreseen past the deadline it is not started; beyond ``MAX_PAIRS`` the lists (about 80
    bytes a pair) are not made at all. Either way the search is not run and the answer is
    the fall-back decode, valid."""
    inst = b1
    tasks = single_tasks(inst)
    usable = list(range(len(tasks)))
    far = 1e12  # a deadline that never passes
    assert len(pairwise_conflicts(inst, tasks, usable, Budget.until(far))) > 0
    monkeypatch.setattr(rds_module, "PREP_S_PER_PAIR", far)
    with pytest.raises(rds_module._Timeout):
        pairwise_conflicts(inst, tasks, usable, Budget.until(far))
    pairwise_conflicts(inst, tasks, usable)  # no deadline: no foresight
    monkeypatch.undo()
    monkeypatch.setattr(rds_module, "MAX_PAIRS", 1)
    with pytest.raises(rds_module._Timeout):
        pairwise_conflicts(inst, tasks, usable)
    out = russian_doll(inst, tasks, decompose=False, reduce=False)
    assert not out.proven and out.bound >= out.value > 0
    assert validate(inst, tasks_to_schedule(inst, tasks, out.chosen)).feasible
