"""ACO-STC and ACO-LS-STC: validity, the static optimum as a ceiling, and each
characteristic step (trail update, trail limits, arcs of a schedule, the exchange move) by hand."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.aco import (
    ACOLSParams,
    ACOParams,
    Graph,
    construct,
    exchange,
    local_search,
    loss_eta,
    resource_eta,
    tau_bounds,
    update_pheromone,
)
from heuristics.stc import Selection, stc_data
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.params import from_kwargs
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, small_instances
from tests.heuristics.test_hpfs import x_blocks_y_and_z
from tests.oracle import brute_force

METHODS = ("aco-stc", "aco-ls-stc")


def four_apart() -> Instance:
    """One orbit, max_openings 2, targets a, b, c, d (weights 1-4) 200 s apart: too far apart
    to share a static cluster-task (span > Delta T = 120 s), so (6) alone binds."""
    return Instance.build(
        {"a": 1, "b": 2, "c": 3, "d": 4},
        [(k, 0, 200.0 * i, 200.0 * i + 2, 0.0) for i, k in enumerate("abcd")],
        resources=Resources(max_openings=2),
        name="four_apart",
    )


def _task(inst: Instance, data, name: str) -> int:  # noqa: ANN001
    """The static cluster-task covering target ``name`` (tiny cases: one task per target)."""
    k = inst.target_index[name]
    (t,) = data.target_tasks[k]
    return t


def _selection(inst: Instance, names: list[str]) -> Selection:
    data = stc_data(inst)
    sol = Selection(data)
    for n in names:
        assert sol.try_add(_task(inst, data, n))
    sol.commit()
    return sol


def _names(inst: Instance, sol: Selection) -> list[str]:
    return sorted(inst.target_ids[k] for t in sol.chosen for k in sol.data.targets[t])


# ---------------------------------------------------------------------------- properties
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16), method=st.sampled_from(METHODS))
def test_every_schedule_passes_the_validator(inst: Instance, seed: int, method: str) -> None:
    res = solve(inst, method, seed=seed, iterations=5, check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8), seed=st.integers(0, 2**16), method=st.sampled_from(METHODS)
)
def test_profit_never_exceeds_the_static_optimum(inst: Instance, seed: int, method: str) -> None:
    res = solve(inst, method, seed=seed, iterations=5)
    assert res.profit <= brute_force(inst, "static").profit + 1e-9


@pytest.mark.parametrize("method", METHODS)
def test_finds_the_pair_that_highest_weight_first_misses(method: str) -> None:
    # x (6) blocks y (5) and z (4); the optimum is {y, z} = 9 (tests/heuristics/test_hpfs).
    res = solve(x_blocks_y_and_z(), method, seed=0, iterations=20)
    assert res.profit == 9


def test_local_search_reaches_the_optimum_of_four_apart() -> None:
    res = solve(four_apart(), "aco-ls-stc", seed=0, iterations=1, ants=1)
    assert res.profit == 7  # c + d, the two heaviest under max_openings = 2


def test_time_limit_stops_early(c1) -> None:
    inst = c1
    res = solve(inst, "aco-stc", time_limit=0.3, iterations=10**6)
    assert 0 < res.iterations < 10**6
    assert validate(inst, res.schedule).feasible


# -------------------------------------------------------------------------------- pheromone
def test_update_evaporates_every_trail_and_deposits_on_the_arcs() -> None:
    tau = {0: np.full((3, 2), 5.0), 4: np.full((2, 1), 2.0)}
    update_pheromone(tau, [(0, 0, 1), (0, 2, 0)], amount=0.5, rho=0.2, tau_min=1.0, tau_max=5.0)
    # 5 * 0.8 = 4 everywhere, + 0.5 on the two arcs; orbit 4: 2 * 0.8 = 1.6
    np.testing.assert_allclose(tau[0], [[4.0, 4.5], [4.0, 4.0], [4.5, 4.0]])
    np.testing.assert_allclose(tau[4], [[1.6], [1.6]])


def test_update_clamps_to_the_trail_limits() -> None:
    tau = {0: np.array([[1.1, 4.9]])}
    update_pheromone(tau, [(0, 0, 1)], amount=1.0, rho=0.2, tau_min=1.0, tau_max=5.0)
    # 1.1 * 0.8 = 0.88 -> tau_min 1.0; 4.9 * 0.8 + 1 = 4.92 stays; a second deposit: 4.936 + 1
    np.testing.assert_allclose(tau[0], [[1.0, 4.92]])
    update_pheromone(tau, [(0, 0, 1), (0, 0, 1)], amount=1.0, rho=0.2, tau_min=1.0, tau_max=5.0)
    np.testing.assert_allclose(tau[0], [[1.0, 5.0]])


def test_trail_limits_follow_mmas() -> None:
    tau_min, tau_max = tau_bounds(rho=0.2, p_best=0.05, n_arcs=10, candidates=20)
    p_dec = 0.05**0.1
    assert tau_max == pytest.approx(5.0)
    assert tau_min == pytest.approx(5.0 * (1 - p_dec) / (9 * p_dec))
    # one decision: p_dec = p_best, tau_min would exceed tau_max and is capped
    assert tau_bounds(0.2, 0.05, 1, 20) == (pytest.approx(5.0), pytest.approx(5.0))


def test_arcs_follow_each_orbit_path_from_the_source() -> None:
    inst = x_blocks_y_and_z()  # y [0, 4], x [10, 14], z [20, 24]: local indices 0, 1, 2
    sol = _selection(inst, ["y", "z"])
    graph = Graph(sol.data)
    assert graph.arcs(sol) == [(0, 0, 0), (0, 1, 2)]  # source -> y, y -> z
    assert graph.tau[0].shape == (4, 3)


# ----------------------------------------------------------------- heuristic information
def test_successors_follow_rule_3_in_start_order() -> None:
    graph = Graph(stc_data(x_blocks_y_and_z()))  # local y 0, x 1, z 2; only y -> z by (3)
    expect = [[1, 1, 1], [0, 0, 1], [0, 0, 0], [0, 0, 0]]  # source, y, x, z
    np.testing.assert_array_equal(graph.successors(0, np.arange(4)), np.array(expect, bool))
    np.testing.assert_array_equal(graph.successors(0, 1), [False, False, True])


def test_loss_eta_by_hand() -> None:
    # From the source, y (5), x (6), z (4) all earn: 15 in all. Taking y loses y and x
    # (z may still follow): 11; taking x or z loses every task: 15.
    graph = Graph(stc_data(x_blocks_y_and_z()))
    gains = np.array([5.0, 6.0, 4.0])
    cand = np.arange(3)
    eta = loss_eta(gains, cand, graph.successors(0, cand + 1))
    np.testing.assert_allclose(eta, [5 / 11, 6 / 15, 4 / 15])
    # after y, z is the only successor: it loses nothing but itself
    gains_after_y = gains * graph.successors(0, 1)
    np.testing.assert_allclose(
        loss_eta(gains_after_y, np.array([2]), graph.successors(0, np.array([3]))), [1.0]
    )


def test_one_greedy_ant_takes_the_pair_not_the_heaviest() -> None:
    # HPFS takes x (6) first (tests/heuristics/test_hpfs); eta ranks y above x, then z
    inst = x_blocks_y_and_z()
    assert solve(inst, "aco-stc", seed=0, iterations=1, ants=1, q0=1.0).profit == 9


def test_resource_eta_by_hand() -> None:
    # the former rule: g / (cost + gap_weight * gap / H), gap already over H
    eta = resource_eta(np.array([2.0, 3.0]), np.array([0.5, 1.0]), np.array([0.1, 0.0]), 10.0)
    np.testing.assert_allclose(eta, [2.0 / 1.5, 3.0 / 1.0])
    res = solve(x_blocks_y_and_z(), "aco-stc", seed=0, iterations=3, heuristic="resource")
    assert validate(x_blocks_y_and_z(), res.schedule).feasible


def test_a_covered_target_earns_nothing_on_another_orbit() -> None:
    # target a on two orbits: once one ant's path covers it, the other orbit's task has gain
    # 0 and is no candidate; b on orbit 1 only is still taken
    inst = Instance.build(
        {"a": 3, "b": 1},
        [("a", 0, 0.0, 2.0, 0.0), ("a", 1, 0.0, 2.0, 0.0), ("b", 1, 500.0, 502.0, 0.0)],
        name="shared_target",
    )
    graph = Graph(stc_data(inst))
    for seed in range(4):
        sol = construct(graph, ACOParams(q0=0.0), np.random.default_rng(seed))
        assert len(sol.chosen) == 2 and sol.profit == 4


def test_computed_successor_rows_equal_the_kept_matrix(monkeypatch) -> None:  # noqa: ANN001
    import heuristics.aco as aco

    inst = scenario("C1")
    dense = Graph(stc_data(inst))
    monkeypatch.setattr(aco, "DENSE_TASKS", 0)
    lazy = Graph(stc_data(inst))
    for j in dense.orbits:
        rows = np.arange(len(dense.data.orbit_tasks[j]) + 1)
        np.testing.assert_array_equal(lazy.successors(j, rows), dense.successors(j, rows))
        assert lazy._succ[j] is None and dense._succ[j] is not None
    a = solve(inst, "aco-stc", seed=3, iterations=3)
    monkeypatch.setattr(aco, "DENSE_TASKS", 2048)
    b = solve(inst, "aco-stc", seed=3, iterations=3)
    assert a.schedule.observations == b.schedule.observations


def test_restart_resets_every_trail() -> None:
    graph = Graph(stc_data(x_blocks_y_and_z()))
    graph.tau[0][:] = 0.3
    graph.reset(7.0)
    assert np.all(graph.tau[0] == 7.0)


# ----------------------------------------------------------------------------- local search
def _rank(data) -> np.ndarray:  # noqa: ANN001
    rank = np.empty(len(data.tasks), dtype=np.int64)
    rank[data.by_utility] = np.arange(len(data.by_utility))
    return rank


def test_exchange_takes_out_the_blocker_and_refills() -> None:
    inst = x_blocks_y_and_z()
    sol = _selection(inst, ["x"])
    y = _task(inst, sol.data, "y")
    assert exchange(sol, y, _rank(sol.data))  # x out (6), y in (5), z refilled (4): 9 > 6
    assert _names(inst, sol) == ["y", "z"] and sol.profit == 9


def test_exchange_that_does_not_pay_is_undone() -> None:
    inst = x_blocks_y_and_z()
    sol = _selection(inst, ["y", "z"])
    x = _task(inst, sol.data, "x")
    assert not exchange(sol, x, _rank(sol.data))  # x (6) would cost y and z (9)
    assert _names(inst, sol) == ["y", "z"] and sol.profit == 9
    assert len(sol.lines[0]) == 2 and sol.lines[0].observe == pytest.approx(8.0)


def test_exchange_frees_an_opening() -> None:
    inst = four_apart()  # max_openings 2; a, b, c, d weigh 1, 2, 3, 4
    sol = _selection(inst, ["a", "b"])
    d = _task(inst, sol.data, "d")
    assert exchange(sol, d, _rank(sol.data))  # (6) binds: a (loses least) out, d in
    assert _names(inst, sol) == ["b", "d"] and sol.profit == 6


def test_local_search_climbs_to_a_local_optimum() -> None:
    inst = four_apart()
    sol = _selection(inst, ["a", "b"])
    assert local_search(sol, max_passes=10) == 2
    assert _names(inst, sol) == ["c", "d"] and sol.profit == 7


# ------------------------------------------------------------------------------- parameters
def test_params_from_command_line_strings() -> None:
    p = from_kwargs(
        ACOParams,
        {"ants": "5", "rho": "0.5", "local_search": "false", "alpha": 2},
        method="aco-stc",
    )
    assert (p.ants, p.rho, p.local_search, p.alpha) == (5, 0.5, False, 2.0)
    assert isinstance(p.alpha, float)
    q = from_kwargs(ACOLSParams, {}, method="aco-ls-stc")
    assert (q.ants, q.rho, q.q0, q.local_search) == (10, 0.2, 0.0, True)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"ants": 0}, "ants"),
        ({"rho": 0.0}, "rho"),
        ({"rho": "x"}, "rho"),
        ({"p_best": 1.0}, "p_best"),
        ({"q0": 1.5}, "q0"),
        ({"heuristic": "weight"}, "heuristic"),
        ({"roll_rule": "left"}, "roll_rule"),
        ({"local_search": "maybe"}, "local_search"),
        ({"iterations": -1}, "iterations"),
        ({"bogus": 1}, "bogus"),
    ],
)
def test_bad_params_name_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(InputError, match=field):
        from_kwargs(ACOParams, kwargs, method="aco-stc")


@pytest.mark.parametrize("method", METHODS)
def test_a_stop_request_ends_the_colony_with_its_best(method: str, c1) -> None:
    from sosp.progress import Progress
    from sosp.result import Status
    from sosp.stop import clear_stop, request_stop

    inst = c1

    def cb(snap) -> None:  # noqa: ANN001
        if snap.elapsed > 0.3:
            request_stop("test")

    try:
        res = solve(inst, method, seed=1, iterations=10**9, progress=Progress(cb, interval=0.05))
    finally:
        clear_stop()
    assert res.status is Status.INTERRUPTED and 0 < res.iterations < 10**9
    assert validate(inst, res.schedule).feasible and res.profit > 0


def test_iterations_default_to_the_time_limit_else_a_constant(monkeypatch) -> None:  # noqa: ANN001
    import heuristics.aco as aco

    monkeypatch.setattr(aco, "DEFAULT_ITERATIONS", 3)
    inst = x_blocks_y_and_z()
    assert solve(inst, "aco-stc", seed=0).iterations == 3
    assert solve(inst, "aco-stc", seed=0, time_limit=0.3).iterations > 3
