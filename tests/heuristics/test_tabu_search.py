"""TS-STC: feasibility, the static optimum as a ceiling, tenure and aspiration."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.tabu_search import TabuSearch, TSParams, is_allowed, tabu_tenure
from sosp.clustering import static_cluster_tasks
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import small_instances, tiny_chain
from tests.oracle import brute_force


def chain_no_cluster() -> Instance:
    """tiny_chain with single-roll ranges (no static cluster): a conflicts with b by (3)."""
    return Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [
            ("a", 0, 0, 4, 10.0, 10.0, 10.0),
            ("b", 0, 10, 14, 1.0, 1.0, 1.0),
            ("c", 0, 30, 34, -5.0, -5.0, -5.0),
        ],
    )


def openings_no_cluster() -> Instance:
    """tiny_openings (c = 2, weights a 1, b 2, c 3, d 4) with rolls that never cluster."""
    rows = [
        (x, 0, 100 * q, 100 * q + 2, r, r, r)
        for q, (x, r) in enumerate(zip("abcd", (0, 5, -5, 3), strict=True))
    ]
    return Instance.build(
        {"a": 1, "b": 2, "c": 3, "d": 4}, rows, resources=Resources(max_openings=2)
    )


def _search(inst: Instance, **kw) -> TabuSearch:
    tasks = static_cluster_tasks(inst)
    return TabuSearch(inst, tasks, TSParams(**kw), np.random.default_rng(0))


def _local(ts: TabuSearch, inst: Instance, target: str) -> int:
    k = inst.target_index[target]
    return next(i for i in range(ts.n) if ts.tg[i] == (k,))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16))
def test_every_schedule_is_valid_and_at_most_the_static_optimum(inst: Instance, seed: int) -> None:
    res = solve(inst, "ts-stc", seed=seed, iterations=60, restart_after=7, check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.profit <= brute_force(inst, "static").profit + 1e-9


def test_tiny_instances_reach_the_static_optimum(tiny: Instance) -> None:
    res = solve(tiny, "ts-stc", seed=3, iterations=50)
    assert res.profit == brute_force(tiny, "static").profit


def test_tenure_grows_with_the_drops_of_a_task() -> None:
    p = TSParams(tenure_min=7, tenure_freq=2.0)
    assert [tabu_tenure(p, d) for d in (1, 2, 3)] == [7, 9, 11]
    assert tabu_tenure(TSParams(tenure_min=4, tenure_freq=0.5), 4) == 4 + 1


def test_aspiration_allows_a_tabu_move_only_above_the_best() -> None:
    assert is_allowed(tabu_until=5, it=5, value=10, gain=-3, best=20)  # tenure over
    assert not is_allowed(tabu_until=6, it=5, value=10, gain=10, best=20)  # ties the best
    assert is_allowed(tabu_until=6, it=5, value=10, gain=11, best=20)  # beats it
    got = is_allowed(np.array([5, 6, 6]), 5, 10, np.array([-3.0, 10.0, 11.0]), 20)
    assert got.tolist() == [True, False, True]  # the same rule per move, as the search uses it


def test_a_dropped_task_is_tabu_for_its_tenure_unless_it_aspires() -> None:
    inst = chain_no_cluster()  # a (5) conflicts with b (4); c (3) fits with both
    ts = _search(inst, tenure_min=4)
    a, b, c = (_local(ts, inst, x) for x in "abc")
    ts.load([a, c])
    assert ts.value == 8
    assert ts.gain[b] == 4 - 5 and ts.plan[b] == (a,)  # add b drops a by (3)
    ts.apply(b, it=1)
    assert ts.value == 7 and ts.tabu_until[a] == 1 + 4 and ts.drops[a] == 1
    assert ts.gain[a] == 1  # a back (b out) would restore 8
    assert ts.choose(2, best=8) == -1  # tabu, and 8 does not beat the best
    assert ts.choose(2, best=7) == a  # aspiration: it beats the best
    assert ts.choose(5, best=8) == a  # tenure over


def test_knapsack_repair_drops_the_cheapest_task_of_the_orbit() -> None:
    inst = openings_no_cluster()
    ts = _search(inst)
    a, b, c, d = (_local(ts, inst, x) for x in "abcd")
    ts.load([c, d])
    ev = ts.evaluate(b)
    assert ev == (2 - 3, (c,))  # (6) binds: c loses less than d
    assert ts.evaluate(c) is None  # scheduled: no add move
    assert ts.gain[a] == 1 - 3


@pytest.mark.parametrize(
    "kw",
    [
        {"iterations": -1},
        {"tenure_min": 1.5},
        {"tenure_freq": -1.0},
        {"restart_after": 0},
        {"perturb": True},
        {"roll_rule": "left"},
    ],
)
def test_bad_parameters_raise_input_error(kw: dict) -> None:
    with pytest.raises(InputError):
        TSParams(**kw)
    with pytest.raises(InputError):
        solve(tiny_chain(), "ts-stc", **kw)


def test_a_stop_request_ends_the_search_with_its_best(c1) -> None:
    from sosp.progress import Progress
    from sosp.result import Status
    from sosp.stop import clear_stop, request_stop

    inst = c1

    def cb(snap) -> None:  # noqa: ANN001
        if snap.elapsed > 0.3:
            request_stop("test")

    try:
        res = solve(inst, "ts-stc", seed=1, iterations=10**9, progress=Progress(cb, interval=0.05))
    finally:
        clear_stop()
    assert res.status is Status.INTERRUPTED and 0 < res.iterations < 10**9
    assert validate(inst, res.schedule).feasible and res.profit > 0
