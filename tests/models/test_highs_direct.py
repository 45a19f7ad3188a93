"""The direct HiGHS backend: same model as Pyomo, network form of (3), solver traps."""

from __future__ import annotations

import json
import logging
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from heuristics.greedy import solve_greedy
from models.cliques import clique_events, cliques_from_events, maximal_cliques
from models.highs_direct import build_arrays, run_highs
from models.solve import bound, choose_backend, model_data, solve_milp
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.result import Status
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import tiny_chain, tiny_cluster
from tests.limits import limit_kept
from tests.models.instances import random_dense, random_tiny


@given(
    st.lists(st.tuples(st.integers(0, 60), st.integers(1, 20)), min_size=0, max_size=30),
)
@settings(max_examples=200, deadline=None)
def test_clique_events_are_the_maximal_cliques(rows) -> None:
    """The array form of the sweep gives the maximal cliques of two or more items of the
    interval graph (overlap by more than EPS), in the order of their sweep points."""
    from sosp.rules import EPS

    left = np.array([float(a) for a, _ in rows])
    right = left + np.array([float(b) for _, b in rows])
    first, last, m = clique_events(left, right)
    got = [set(c.tolist()) for c in cliques_from_events(first, last, m)]
    assert [sorted(c) for c in got] == [c.tolist() for c in maximal_cliques(left, right)]
    n = len(rows)
    edges = {
        (u, w)
        for u in range(n)
        for w in range(u + 1, n)
        if min(right[u], right[w]) - max(left[u], left[w]) > EPS
    }
    for c in got:  # cliques, maximal, at increasing sweep points (the largest left end)
        assert len(c) >= 2 and all((u, w) in edges for u in c for w in c if u < w)
        assert not any(
            u not in c and all(tuple(sorted((u, w))) in edges for w in c) for u in range(n)
        )
    assert all(any({u, w} <= c for c in got) for u, w in edges)
    points = [max(left[list(c)]) for c in got]
    assert points == sorted(points)


def test_clique_form_has_the_pyomo_size() -> None:
    """With clique rows the arrays are the Pyomo model entry for entry in size."""
    for seed in range(6):
        inst = random_tiny(seed)
        for model in ("task", "cluster", "static"):
            kw = {"warm_start": "none", "extra_bound": "none", "slew": "exact"}  # always built
            a = solve_milp(inst, model=model, backend="pyomo", **kw)
            b = solve_milp(inst, model=model, backend="highs", conflicts="clique", **kw)
            for key in ("variables", "constraints", "nonzeros"):
                assert a.stats[key] == b.stats[key], (seed, model, key)


def test_network_form_has_two_nonzeros_per_item() -> None:
    """(3) in network form: each x at most twice, each slack at most twice."""
    data = model_data(random_dense(0, n=60, n_orbits=1), "cluster")
    clique = build_arrays(data, conflicts="clique")
    net = build_arrays(data, conflicts="network")
    t0 = net.offsets["t"]
    a = net.matrix.tocsc()
    n_rows_conf = data.n_events
    assert net.n_cols == clique.n_cols + n_rows_conf
    slack_nnz = np.diff(a.indptr)[t0 : t0 + n_rows_conf]
    assert slack_nnz.max() <= 2
    sum_clique = int((data.event_last - data.event_first).clip(min=0).sum())
    assert sum_clique > 2 * data.n_items  # the instance is dense enough to matter
    assert net.matrix.nnz < clique.matrix.nnz


@pytest.mark.parametrize("seed", range(12))
def test_network_equals_clique_and_pyomo_on_dense(seed: int) -> None:
    """Same LP value and same optimum in both forms of (3) and in Pyomo (no oracle: too big)."""
    inst = random_dense(seed)
    for model in ("task", "cluster"):
        lps = [
            solve_milp(inst, model=model, relax=True, backend=b, conflicts=c).stats["lp_bound"]
            for b, c in (("pyomo", "network"), ("highs", "clique"), ("highs", "network"))
        ]
        assert lps == pytest.approx([lps[0]] * 3, abs=1e-6), (model, lps)
        opt = [
            solve_milp(inst, model=model, backend=b, conflicts=c)
            for b, c in (("pyomo", "network"), ("highs", "clique"), ("highs", "network"))
        ]
        assert all(r.status is Status.OPTIMAL for r in opt)
        assert {r.profit for r in opt} == {opt[0].profit}, (model, [r.profit for r in opt])
        for r in opt:
            assert validate(inst, r.schedule).feasible
            assert r.profit <= lps[0] + 1e-6


def test_warm_start_direct() -> None:
    inst = random_dense(3)
    start = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    for model in ("task", "cluster"):
        for conflicts in ("network", "clique"):
            res = solve_milp(
                inst, model=model, warm_start=start, backend="highs", conflicts=conflicts
            )
            assert res.stats["warm_start"] is True
            assert res.status is Status.OPTIMAL and res.profit >= start_profit(inst, start)


def start_profit(inst: Instance, sched) -> float:
    return validate(inst, sched).profit


def test_start_vector_is_feasible() -> None:
    """The completed MIP start (slacks included) satisfies every row of the array model."""
    from models.highs_direct import start_vector
    from models.solve import warm_start_values

    inst = random_dense(5)
    sched = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    for model in ("task", "cluster"):
        data = model_data(inst, model)
        vals = warm_start_values(data, sched)
        assert vals is not None
        for conflicts in ("network", "clique"):
            am = build_arrays(data, conflicts=conflicts)
            y = start_vector(am, vals)
            ay = am.matrix @ y
            assert np.all(ay <= am.row_upper + 1e-9) and np.all(ay >= am.row_lower - 1e-9)
            assert np.all(y >= am.col_lower - 1e-9) and np.all(y <= am.col_upper + 1e-9)
            assert am.cost @ y == pytest.approx(validate(inst, sched).profit)


def test_direct_is_silent(capfd: pytest.CaptureFixture[str]) -> None:
    solve_milp(random_tiny(1), model="cluster", time_limit=10, backend="highs")
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_direct_log_at_debug(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.DEBUG, logger="models.solve"):
        solve_milp(random_tiny(1), model="cluster", backend="highs", warm_start="none")
    assert any("HiGHS" in r.getMessage() for r in caplog.records)


def test_no_stale_gap_direct() -> None:
    inst = random_dense(2)
    solve_milp(inst, model="cluster", mip_gap=0.9, backend="highs")
    res = solve_milp(inst, model="cluster", backend="highs")
    assert res.status is Status.OPTIMAL and res.bound == res.profit


def test_relaxation_direct() -> None:
    res = solve_milp(tiny_cluster(), relax=True, backend="highs")
    assert res.status is Status.NO_SOLUTION and len(res.schedule) == 0
    assert res.bound >= 11


def test_backend_choice_and_bad_input() -> None:
    small = model_data(tiny_chain(), "task")
    assert choose_backend(small) == "pyomo" and choose_backend(small, "highs") == "highs"
    with pytest.raises(InputError, match="backend"):
        solve_milp(tiny_chain(), backend="gurobi")
    with pytest.raises(InputError, match="conflicts"):
        solve_milp(tiny_chain(), conflicts="pairs")
    with pytest.raises(InputError, match="backend"):
        bound(tiny_chain(), backend="nope")


def test_empty_instance_direct() -> None:
    inst = Instance.build({"a": 3}, [], n_orbits=1, orbit_length=100.0)
    res = solve_milp(inst, model="cluster", backend="highs")
    assert res.status is Status.OPTIMAL and res.profit == 0


def test_through_sosp_solve_direct() -> None:
    # no start and no extra bound, so the MILP itself is built and solved
    res = solve(
        tiny_cluster(), "milp", model="cluster", backend="highs", time_limit=30,
        warm_start="none", extra_bound="none",
    )  # fmt: skip
    assert res.status is Status.OPTIMAL and res.profit == 11
    assert res.stats["backend"] == "highs" and res.stats["nonzeros"] > 0


def test_cli_bound_backend(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    assert main(["bound", str(path), "--method", "lp", "--backend", "highs", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["backend"] == "highs" and out["bound"] >= 11
    assert main(["bound", str(path), "--backend", "nope"]) == 2


@pytest.mark.limits
@pytest.mark.slow
def test_time_limit_direct_does_not_raise(c5) -> None:
    import time

    inst = c5
    t0 = time.perf_counter()
    res = solve_milp(inst, model="task", time_limit=3.0, backend="highs")
    limit_kept("task model on HiGHS, 3 s", time.perf_counter() - t0, 3.0 + 2.0)
    assert res.status in (Status.TIME_LIMIT, Status.OPTIMAL, Status.NO_SOLUTION)
    if res.status is Status.TIME_LIMIT:
        assert res.bound >= res.profit and validate(inst, res.schedule).feasible


@pytest.mark.slow
def test_no_finite_bound_is_not_a_zero_gap(c5) -> None:
    """Stopped during C5's root LP with a MIP start: an incumbent, no dual bound from HiGHS,
    and a bound from elsewhere (never a zero gap)."""

    inst = c5
    start = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    res = solve_milp(inst, model="cluster", time_limit=6.0, warm_start=start, backend="highs")
    assert res.status is Status.TIME_LIMIT and res.stats["warm_start"] is True
    assert res.profit >= validate(inst, start).profit
    if res.stats["raw_bound"] is None:
        # no dual bound from HiGHS: the extra bound, the side's or the cap, not the incumbent
        others = [res.stats.get(k) for k in ("extra_bound", "side_bound", "cap")]
        assert res.bound == max(res.profit, min(b for b in others if b is not None))
        assert res.bound > res.profit and res.gap > 0
    else:
        assert res.bound >= res.profit


def test_a_watcher_gets_the_mip_dual_bound() -> None:
    # the dual bound of a MIP solved in this process, no lower than its optimum
    from models.highs_direct import watching_bound

    am = build_arrays(model_data(random_dense(2, n=80), "cluster"), relax=False)
    got: list[tuple[float, float]] = []
    with watching_bound(lambda dual, primal: got.append((dual, primal)) or False):
        out = run_highs(am, deadline=time.perf_counter() + 30, guard=False)
    assert out.status == "optimal" and got
    assert all(primal <= out.objective <= dual + 1e-6 for dual, primal in got)
    seen = len(got)
    run_highs(am, deadline=time.perf_counter() + 30, guard=False)
    assert len(got) == seen  # ... and only within the block


def test_a_watcher_stops_the_mip() -> None:
    # True from the listener interrupts HiGHS as a time limit would (its first call comes
    # before this MIP is solved), with a valid incumbent and bound
    from models.highs_direct import watching_bound

    am = build_arrays(model_data(random_dense(2, n=80), "cluster"), relax=False)
    calls: list[float] = []
    with watching_bound(lambda dual, primal: calls.append(dual) or True):
        out = run_highs(am, deadline=time.perf_counter() + 30, guard=False)
    assert out.status == "time_limit" and len(calls) == 1
    assert out.objective <= 124 <= out.bound  # the optimum, 124, in between
