"""PBA-STC: the bound never below the static optimum, the parts and their recombination."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.pba import (
    PBAParams,
    lp_prices,
    orbit_cliques,
    part_optimum,
    part_problem,
    partition_dp,
    pba_bound,
    pba_partition,
    target_order,
)
from sosp.clustering import static_cluster_tasks
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.registry import compute_bound
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, small_instances
from tests.heuristics.test_tabu_search import chain_no_cluster, openings_no_cluster
from tests.oracle import brute_force


def _pp(inst: Instance):
    return part_problem(inst, static_cluster_tasks(inst))


def _k(inst: Instance, names: str) -> list[int]:
    return [inst.target_index[x] for x in names]


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), max_part=st.integers(1, 5), order=st.sampled_from(["rcm", "index"]))
def test_bound_is_never_below_the_static_optimum(inst: Instance, max_part: int, order) -> None:
    opt = brute_force(inst, "static").profit
    out = pba_bound(inst, max_part=max_part, order=order)
    assert out["bound"] >= opt - 1e-9
    assert out["bound"] <= out["unpriced_bound"]
    assert out["bound"] <= sum(int(w) for w in inst.target_weight)
    # R* is the lesser of two bounds: check the priced one on its own too, since on these
    # tiny instances the bound without prices is often the optimum itself and would hide it.
    pp = _pp(inst)
    prices = lp_prices(inst, pp)
    params = PBAParams(max_part=max_part, order=order)
    priced = partition_dp(pp, target_order(pp, order), params, prices)
    assert priced["value"] + prices.constant >= opt - 1e-9
    if pp.targets:
        # Single-target parts with the LP's prices give the LP bound (lp_prices), no more.
        single = partition_dp(pp, pp.targets, PBAParams(max_part=1), prices)
        assert single["value"] + prices.constant <= prices.lp_value + 1e-6
        assert priced["value"] <= single["value"] + 1e-9  # the DP can take single targets


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances())
def test_f_star_bounds_the_targets_of_every_static_schedule(inst: Instance) -> None:
    # F* is R* of the same instance with every weight 1: at least the count of the static
    # optimum of that unit-weight instance, which is the most targets a static schedule sees.
    data = inst.to_dict(layout="columns")
    data["targets"]["weight"] = [1] * inst.n_targets
    unit = Instance.from_dict(data)
    best_count = brute_force(unit, "static").profit
    out = pba_bound(inst)
    assert out["targets"] >= best_count - 1e-9
    assert out["targets"] == pba_bound(unit)["bound"]
    res = solve(inst, "pba-stc", seed=0)
    assert res.observed <= res.stats["bound_targets"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances())
def test_priced_cliques_are_cliques_of_setup_conflicts(inst: Instance) -> None:
    pp = _pp(inst)
    capped, cliques = orbit_cliques(inst, pp)
    for members in cliques:
        assert len({int(pp.tasks.orbit[t]) for t in members}) == 1
        for a in members:
            for b in members:
                assert a == b or b in pp.conflicts[a]
    # every (3) conflict lies in some clique, so the LP keeps all of (3)
    for a, others in pp.conflicts.items():
        for b in others:
            assert any(a in m and b in m for m in cliques)
    for j in capped:
        assert sum(int(pp.tasks.orbit[t]) == j for t in pp.conflicts) > pp.openings[j]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16))
def test_schedule_is_valid_and_between_nothing_and_the_bound(inst: Instance, seed: int) -> None:
    res = solve(inst, "pba-stc", seed=seed, max_part=3, check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.profit <= brute_force(inst, "static").profit + 1e-9 <= res.bound + 2e-9
    again = solve(inst, "pba-stc", seed=seed + 1, max_part=3)
    assert again.schedule.observations == res.schedule.observations  # deterministic


def test_part_optimum_keeps_setup_conflicts_inside_a_part() -> None:
    inst = chain_no_cluster()  # a 5 conflicts with b 4 by (3); c 3 fits with both
    pp = _pp(inst)
    assert part_optimum(pp, _k(inst, "abc"))[0] == 5 + 3
    assert part_optimum(pp, _k(inst, "ab"))[0] == 5
    assert part_optimum(pp, _k(inst, "bc"))[0] == 4 + 3
    value, tasks, exact = part_optimum(pp, _k(inst, "abc"))
    assert exact and sorted(k for t in tasks for k in pp.tasks.targets[t]) == _k(inst, "ac")


def test_partition_by_dynamic_programming_takes_the_least_sum() -> None:
    inst = chain_no_cluster()
    # Without prices, parts of one target relax every conflict: 5 + 4 + 3.
    assert pba_bound(inst, max_part=1, order="index", prices="none")["bound"] == 12
    # With two, [a b] [c] = 5 + 3 beats [a] [b c] = 5 + 7: the DP finds it.
    out = pba_partition(inst, PBAParams(max_part=2, order="index", prices="none"))
    assert out["bound"] == 8
    assert out["parts"] == [_k(inst, "ab"), _k(inst, "c")]
    assert out["targets"] == 2 and out["inexact_parts"] == 0


def test_prices_carry_setup_conflicts_across_parts() -> None:
    inst = chain_no_cluster()  # a 5 and b 4 conflict by (3): their clique is priced
    out = pba_bound(inst, max_part=1, order="index")
    assert (out["bound"], out["unpriced_bound"], out["lp_bound"]) == (8, 12, 8.0)


def test_openings_are_kept_inside_a_part_and_relaxed_between_parts_without_prices() -> None:
    inst = openings_no_cluster()  # c = 2 openings; weights a 1, b 2, c 3, d 4
    assert pba_bound(inst, max_part=4, order="index", prices="none")["bound"] == 3 + 4
    assert pba_bound(inst, max_part=2, order="index", prices="none")["bound"] == 1 + 2 + 3 + 4
    assert brute_force(inst, "static").profit == 7


def test_prices_carry_the_openings_across_parts() -> None:
    inst = openings_no_cluster()  # c = 2; the parts [a b] [c d] got two openings each
    out = pba_bound(inst, max_part=2, order="index")
    assert out["unpriced_bound"] == 1 + 2 + 3 + 4
    assert out["bound"] == 3 + 4 == brute_force(inst, "static").profit


def test_one_opening_two_parts_counts_the_better_part_only() -> None:
    # One orbit with c = 1, two targets far apart in time (no (3) conflict): each part of
    # one target had the opening to itself (3 + 5); the priced opening goes to one (5).
    inst = Instance.build(
        {"a": 3, "b": 5},
        [("a", 0, 0.0, 2.0, 0.0, 0.0, 0.0), ("b", 0, 500.0, 502.0, 0.0, 0.0, 0.0)],
        resources=Resources(max_openings=1),
    )
    out = pba_bound(inst, max_part=1)
    assert out["unpriced_bound"] == 3 + 5
    assert out["bound"] == 5 == brute_force(inst, "static").profit
    assert solve(inst, "pba-stc").profit == 5


def test_a_priced_part_skips_a_task_worth_less_than_its_share() -> None:
    inst = openings_no_cluster()
    pp = _pp(inst)
    prices = lp_prices(inst, pp)
    # The LP takes c 3 and d 4; the opening's price (3, from c) exceeds a's and b's weight.
    for x in "ab":
        assert part_optimum(pp, _k(inst, x), prices=prices)[:2] == (0.0, [])
    value, tasks, exact = part_optimum(pp, _k(inst, "abcd"), prices=prices)
    assert exact and value + prices.constant == pytest.approx(7.0)


def test_memory_and_energy_are_relaxed() -> None:
    # Two targets on one orbit, each fitting memory alone, not both: the static optimum
    # takes one, the bound (knapsacks relaxed as the paper says) both.
    inst = Instance.build(
        {"a": 3, "b": 2},
        [("a", 0, 0, 10, 0.0, 0.0, 0.0), ("b", 0, 100, 110, 5.0, 5.0, 5.0)],
        resources=Resources(memory_capacity=15.0),
    )
    assert brute_force(inst, "static").profit == 3
    assert pba_bound(inst)["bound"] == 5


def test_a_part_over_its_node_limit_counts_its_total_weight() -> None:
    inst = chain_no_cluster()
    value, tasks, exact = part_optimum(_pp(inst), _k(inst, "abc"), node_limit=1)
    assert (value, tasks, exact) == (12, [], False)


def test_registered_as_a_bound_and_a_method() -> None:
    inst = chain_no_cluster()
    assert compute_bound("pba", inst)["bound"] == 8
    res = solve(inst, "pba-stc")
    assert res.bound == 8 and res.profit == 8


@pytest.mark.parametrize(
    "kw",
    [{"max_part": 0}, {"node_limit": 1.5}, {"order": "lat"}, {"roll_rule": "x"}, {"prices": "x"}],
)
def test_bad_parameters_raise_input_error(kw: dict) -> None:
    with pytest.raises(InputError):
        PBAParams(**kw)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["B1", "C1"])
def test_bound_is_at_least_the_static_milp_optimum(name: str) -> None:
    pytest.importorskip("highspy")

    inst = scenario(name)
    exact = solve(inst, "milp", model="static", time_limit=300)
    assert exact.status == "optimal"
    out = pba_bound(inst)
    assert out["bound"] >= exact.profit - 1e-6
    assert out["bound"] < out["unpriced_bound"] or out["bound"] == exact.profit


def test_cli_bound_method_pba(tmp_path) -> None:
    import json
    import subprocess
    import sys

    path = tmp_path / "inst.json"
    chain_no_cluster().save(path)
    cmd = [sys.executable, "-m", "sosp", "bound", str(path), "--method", "pba"]
    done = subprocess.run([*cmd, "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert (out["bound"], out["model"], out["method"]) == (8, "static", "pba")
    text = subprocess.run(cmd, capture_output=True, text=True)
    assert text.returncode == 0 and "pba bound: 8" in text.stdout
    bad = subprocess.run([*cmd, "--model", "task"], capture_output=True, text=True)
    assert bad.returncode == 2 and "--model" in bad.stderr and "Traceback" not in bad.stderr


def test_parts_not_reached_in_time_keep_the_lp_bound() -> None:
    inst = openings_no_cluster()  # LP bound 7 = the optimum
    pp = _pp(inst)
    prices = lp_prices(inst, pp)
    late = partition_dp(pp, pp.targets, PBAParams(max_part=4), prices, deadline=0.0)
    assert late["stopped"] and late["subproblems"] == 0 and late["inexact_parts"] >= 1
    assert late["value"] + prices.constant == pytest.approx(prices.lp_value) == 7.0


def test_a_stop_request_leaves_a_valid_bound() -> None:
    from sosp.stop import clear_stop, request_stop

    inst = chain_no_cluster()
    request_stop("test")
    try:
        out = pba_bound(inst, max_part=3, order="index")
    finally:
        clear_stop()
    assert out["bound"] == 5 + 4 + 3 and out["subproblems"] == 0  # every part at its weight


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8))
def test_f_star_past_the_deadline_is_the_partition_with_every_part_stopped(
    inst: Instance,
) -> None:
    # past its deadline count_bound skips the partition's set-up; the count is the one
    # the partition gives when no part is reached (each counts all its targets)
    from heuristics.pba import count_bound

    params = PBAParams()
    tasks = static_cluster_tasks(inst)
    fast = count_bound(inst, params, tasks, deadline=0.0)
    stopped = pba_partition(inst, params, 0.0, tasks, unit=True)["bound"]
    assert fast == stopped == len(part_problem(inst, tasks, unit=True).targets)
    assert pba_partition(inst, params, None, tasks, unit=True)["bound"] <= fast


def _order_reference(pp) -> list[int]:
    """target_order's graph read literally: each target of a usable task joined to every
    other target of it and of the tasks in conflict with it; then reverse Cuthill-McKee."""
    import numpy as np
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    pos = {k: i for i, k in enumerate(pp.targets)}
    rows, cols = [], []
    for t, others in pp.conflicts.items():
        mine = [pos[k] for k in pp.tasks.targets[t] if k in pos]
        near = {pos[k] for h in others for k in pp.tasks.targets[h] if k in pos} | set(mine)
        for a in mine:
            rows += [a] * len(near - {a})
            cols += sorted(near - {a})
    n = len(pp.targets)
    m = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n)).tocsr()
    m = m + m.T
    return [pp.targets[int(i)] for i in reverse_cuthill_mckee(m, symmetric_mode=True)]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=10), unit=st.booleans())
def test_target_order_is_rcm_over_its_graph(inst: Instance, unit: bool) -> None:
    pp = part_problem(inst, static_cluster_tasks(inst), unit)
    if len(pp.targets) >= 3:
        assert target_order(pp) == _order_reference(pp)


def test_an_rcm_order_foreseen_past_its_share_is_the_index_order(monkeypatch, c1) -> None:
    """The order's sparse products read no clock (a polar box of 10,000 targets: 13.4 s,
    and a 5 s run went to 14.5 s): with a deadline, an order foreseen past its share of the
    time left keeps the targets' index order; without one, or with room, it is the rcm."""
    import time

    import heuristics.pba as pba

    inst = c1
    pp = part_problem(inst, static_cluster_tasks(inst), False)
    rcm = target_order(pp)
    assert rcm != list(pp.targets)  # (else the test could not tell them apart)
    soon = time.perf_counter() + 60.0
    assert target_order(pp, "rcm", soon) == rcm
    monkeypatch.setattr(pba, "RCM_S_PER_WORK", 1.0)  # a second per unit of work
    assert target_order(pp, "rcm", soon) == list(pp.targets)
    assert target_order(pp, "rcm") == rcm
    res = solve(inst, "pba-stc", time_limit=5.0)
    assert validate(inst, res.schedule).feasible and res.bound >= res.profit
