"""The solve entry point and the greedy baseline."""

from __future__ import annotations

import pytest

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.registry import METHODS, available_methods
from sosp.result import Status
from sosp.solve import SolverError, solve
from sosp.validate import validate
from tests.conftest import tiny_chain, tiny_openings, tiny_two_orbits
from tests.limits import limit_kept


def test_greedy_hand_computed_chain() -> None:
    # a (5) first, then b (4) conflicts with a by (3), then c (3) fits after a.
    inst = tiny_chain()
    res = solve(inst, "greedy")
    assert res.status is Status.FEASIBLE
    assert [inst.target_ids[inst.opp_target[o.opps[0]]] for o in res.schedule.observations] == [
        "a",
        "c",
    ]
    assert res.profit == 8 and res.observed == 2


def test_greedy_respects_openings() -> None:
    res = solve(tiny_openings(), "greedy")  # c = 2: the two heaviest, d (4) and c (3)
    assert res.profit == 7 and len(res.schedule) == 2


def test_greedy_uses_the_freer_orbit() -> None:
    # c (9) goes first, on orbit 0; a (6) can go on either orbit: orbit 1 has more resources
    # left, so a goes there and b (5), which conflicts with a on orbit 0, still fits.
    inst = Instance.build(
        {"c": 9, "a": 6, "b": 5},
        [
            ("c", 0, 300, 305, 0.0),
            ("a", 0, 0, 5, 20.0),
            ("a", 1, 100, 105, 0.0),
            ("b", 0, 8, 12, -20.0),
        ],
    )
    res = solve(inst, "greedy")
    assert res.profit == 20
    placed = {
        inst.target_ids[inst.opp_target[o.opps[0]]]: o.orbit for o in res.schedule.observations
    }
    assert placed == {"c": 0, "a": 1, "b": 0}


def test_greedy_breaks_ties_by_instance_order() -> None:
    # Both orbits empty: a takes its first opportunity (orbit 0) and b then conflicts.
    assert solve(tiny_two_orbits(), "greedy").profit == 6


def test_result_is_stamped_and_valid(tiny: Instance) -> None:
    res = solve(tiny, "greedy", seed=3)
    s = res.schedule
    assert (s.method, s.seed, s.profit, s.fingerprint) == (
        "greedy",
        3,
        res.profit,
        tiny.fingerprint,
    )
    rep = validate(tiny, s)
    assert rep.feasible and rep.profit == res.profit and rep.observed == res.observed
    assert res.runtime_s >= 0


def test_every_registered_method_is_named_consistently() -> None:
    for name, entry in METHODS.items():
        module, func = entry.function.split(":")
        assert func.startswith("solve_"), name
    assert "greedy" in available_methods()


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"method": "nope"}, "unknown method"),
        ({"method": "greedy", "seed": -1}, "seed"),
        ({"method": "greedy", "seed": 1.5}, "seed"),
        ({"method": "greedy", "time_limit": 0}, "time_limit"),
        ({"method": "greedy", "time_limit": float("nan")}, "time_limit"),
        ({"method": "greedy", "iterations": 3}, "no parameter 'iterations'"),
    ],
)
def test_bad_arguments(kwargs: dict, needle: str) -> None:
    with pytest.raises(InputError, match=needle):
        solve(tiny_chain(), **kwargs)


def test_infeasible_solver_output_is_refused(monkeypatch) -> None:
    import heuristics.greedy as greedy
    from sosp.result import Result
    from sosp.schedule import Schedule, make_observation

    inst = tiny_chain()

    def broken(instance, *, rng, time_limit=None):
        sched = Schedule((make_observation(instance, [0]), make_observation(instance, [1])))
        return Result("greedy", Status.FEASIBLE, sched, 9.0, 2)

    monkeypatch.setattr(greedy, "solve_greedy", broken)
    with pytest.raises(SolverError, match=r"\(3\)"):
        solve(inst, "greedy")


@pytest.mark.parametrize("load_s, limit, expected", [(0.3, 2.0, 1.7), (1.0, 1.0, 0.25)])
def test_the_kernels_load_counts_in_the_time_limit(
    monkeypatch: pytest.MonkeyPatch, load_s: float, limit: float, expected: float
) -> None:
    # a fresh process loads the numba kernels in about 1.6 s: a user timing the run sees
    # it, so the method gets what the load left of the limit (at least a quarter of it)
    import importlib
    import time

    import sosp.planner

    solve_module = importlib.import_module("sosp.solve")  # the package exports solve()
    monkeypatch.setattr(sosp.planner, "compile_kernels", lambda: time.sleep(load_s))
    given: list[float] = []
    greedy = solve_module.method_function("greedy")

    def method(instance: Instance, *, time_limit: float | None, **kw: object):  # noqa: ANN202
        given.append(time_limit)
        return greedy(instance, time_limit=time_limit, **kw)

    monkeypatch.setattr(solve_module, "method_function", lambda name: method)
    res = solve(tiny_chain(), "hpfs-stc", time_limit=limit)  # greedy loads no kernels
    assert given[0] == pytest.approx(expected, abs=0.05)
    assert res.runtime_s >= load_s  # the run's time counts from the call


@pytest.mark.limits
@pytest.mark.parametrize("method", sorted(METHODS))
def test_nothing_observable_is_optimal_at_once(method: str) -> None:
    # no opportunity at all: the empty schedule is optimal for every method, and no search
    # spends its limit finding that out (orbit-dp said no_solution, asa-dtc ran 2 s of 2)
    from sosp.instance import Resources

    inst = Instance.build({"a": 3, "b": 2}, [], resources=Resources(), n_orbits=2)
    res = solve(inst, method, time_limit=30)
    assert res.status is Status.OPTIMAL and res.profit == 0 and res.bound == 0
    assert len(res.schedule) == 0 and res.gap == 0
    limit_kept(f"{method}, no opportunity", res.runtime_s, 5.0)


def test_every_observable_target_observed_is_optimal() -> None:
    # a schedule is optimal, whatever the method, when its profit is the total weight of the
    # targets with an opportunity: nothing can be better
    inst = tiny_chain()  # a (5) and b (4) conflict: greedy takes a and c, 8 of 12
    res = solve(inst, "greedy")
    assert res.status is Status.FEASIBLE and res.bound is None
    easy = Instance.build(
        {"a": 5, "b": 4, "z": 7},  # z has no opportunity: it bounds nothing
        [("a", 0, 0, 5, 0.0), ("b", 0, 100, 105, 0.0)],
        resources=inst.resources(0),
        n_orbits=1,
    )
    res = solve(easy, "greedy")
    assert res.profit == 9 and res.status is Status.OPTIMAL and res.bound == 9
    assert res.gap == 0 and res.stats["proven_by"] == "cap"


def test_a_bound_of_a_restriction_certifies_nothing() -> None:
    # PBA-STC's own bound is of the static model: on tiny_chain 7, below the problem's
    # optimum 8 (the oracle), so a certified result must not take it as the problem's bound
    from tests.oracle import brute_force

    inst = tiny_chain()
    optimum = brute_force(inst, "cluster").profit
    own = solve(inst, "pba-stc")
    assert own.bound == own.profit < optimum
    res = solve(inst, "pba-stc", bound="lagrangian")
    assert res.bound >= optimum and res.status is not Status.OPTIMAL


@pytest.mark.parametrize(("method", "params"), [("rds-stc", {}), ("milp", {"model": "task"})])
def test_a_restrictions_optimum_and_bound_are_labelled_with_its_model(method, params) -> None:
    # issue 63 item 1: RDS-STC proves the static model's optimum 7 on tiny_chain, below the
    # problem's 8; its "bound" and "optimal" are the static model's and must say so (result,
    # --json, text), and the schedule file claims nothing for the problem
    from sosp.registry import bounded_model

    pytest.importorskip("highspy") if method == "milp" else None
    res = solve(tiny_chain(), method, time_limit=10, **params)
    model = bounded_model(method, params)
    assert res.restriction == model and res.summary()["restriction"] == model
    assert res.schedule.status != "optimal" and res.schedule.bound is None
    greedy = solve(tiny_chain(), "greedy")
    assert greedy.restriction is None and greedy.summary()["restriction"] is None
    # a certifying bound is of the problem: the restriction's optimality is dropped
    cert = solve(tiny_chain(), "rds-stc", bound="lagrangian")
    assert cert.restriction is None and cert.status is not Status.OPTIMAL and cert.bound >= 8


def test_a_stop_skips_the_certifying_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    # issue 63 item 2: after a Ctrl-C, --bound's certifying bound ran its whole share (78.8 s
    # in all on 2,000 targets): a stopped run computes no bound after the search
    import sys

    import sosp.pipeline
    from sosp.stop import clear_stop, request_stop

    real = sosp.pipeline.improve

    def stopped(*args, **kwargs):
        request_stop("SIGINT")
        return real(*args, **kwargs)

    monkeypatch.setattr(sys.modules["sosp.solve"], "improve", stopped)
    try:
        res = solve(tiny_chain(), "greedy", bound="lagrangian")
    finally:
        clear_stop()
    assert [st.kind for st in res.stages] == ["method"]
    assert res.status is Status.INTERRUPTED and res.bound is None


def test_greedy_loads_no_kernels(monkeypatch: pytest.MonkeyPatch) -> None:
    # issue 63 items 2 and 11: greedy runs no numba kernel, yet paid their load (seconds to
    # compile on a first run, which no Ctrl-C could cut short) before its one pass
    import sosp.planner

    def no(*args, **kwargs):
        raise AssertionError("kernels loaded")

    monkeypatch.setattr(sosp.planner, "compile_kernels", no)
    res = solve(tiny_chain(), "greedy", time_limit=5)
    assert res.profit == 8 and res.stats["kernels_s"] < 0.5
