"""The column-generation bound (models/colgen.py): never below the optimum, never above the cap,
at its limit no looser than any Lagrangian bound of the same relaxation nor than the LP, and
within its time limit."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings

from models.colgen import colgen_bound
from models.data import observable_weight
from models.lagrangian import lagrangian_bound
from models.solve import bound
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.planner import orbit_data
from sosp.registry import compute_bound
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, small_instances
from tests.limits import limit_kept
from tests.models.instances import random_dense, random_tiny, shared_tiny, split_pair, triangle
from tests.oracle import brute_force


def _check(inst: Instance) -> dict:
    optimum = brute_force(inst, "cluster").profit
    out = colgen_bound(inst)
    assert optimum <= out["bound"] <= observable_weight(inst)
    assert out["converged"]
    if out["master"] is not None:
        # converged: the rounded bound is the rounded optimum of the master LP
        assert out["bound"] == min(math.floor(out["master"] + 1e-6), observable_weight(inst))
    return out


@settings(max_examples=60, deadline=None)
@given(inst=small_instances())
def test_colgen_bound_against_the_oracle(inst: Instance) -> None:
    out = _check(inst)
    # every subgradient step's value is a Lagrangian bound of the relaxation whose master
    # the column generation solves: none is below the master's optimum
    assert out["bound"] <= lagrangian_bound(inst, iterations=50)["bound"]


@pytest.mark.parametrize("seed", range(0, 40, 3))
def test_colgen_bound_no_looser_than_the_lp(seed: int) -> None:
    # the master LP is the LP over the convex hulls of the orbits' plans under (3), (6), with
    # the exact knapsacks of each plan: inside the clique LP's feasible set
    inst = random_tiny(seed)
    out = _check(inst)
    assert out["bound"] <= bound(inst, method="lp", slew="exact")["bound"]


def test_tiny_named_instances(tiny: Instance) -> None:
    _check(tiny)


def test_registered_and_dispatched(tiny: Instance) -> None:
    cap = observable_weight(tiny)
    optimum = brute_force(tiny, "cluster").profit
    for out in (
        bound(tiny, method="colgen"),
        compute_bound("colgen", tiny, time_limit=10.0, lower_bound=None),
    ):
        assert optimum <= out["bound"] <= cap
    out = bound(tiny, method="colgen")
    assert out["bound"] == colgen_bound(tiny)["bound"] and out["converged"] is True
    assert out["cap"] == cap and out["source"] in ("colgen", "cap") and out["rounds"] >= 1
    auto = bound(tiny, method="auto")
    assert "colgen" in auto["parts"] and optimum <= auto["bound"] <= cap
    # a converged column generation leaves no LP to run: the LP could not be tighter
    assert auto["converged"] is True and "lp" not in auto["parts"]


def test_lower_bound_stops_early() -> None:
    inst = random_tiny(5)
    optimum = brute_force(inst, "cluster").profit
    out = colgen_bound(inst, lower_bound=optimum + 100.0)
    assert out["rounds"] == 1 and out["bound"] >= optimum


def test_bad_parameters() -> None:
    inst = random_tiny(1)
    with pytest.raises(InputError, match="max_rounds"):
        colgen_bound(inst, max_rounds=0)
    with pytest.raises(InputError, match="smoothing"):
        colgen_bound(inst, smoothing=1.0)
    for bad in (-1, 1.5, True):
        with pytest.raises(InputError, match="cut_rounds"):
            colgen_bound(inst, branch=True, cut_rounds=bad)
    with pytest.raises(InputError, match="start"):
        colgen_bound(inst, start=(np.zeros(inst.n_targets), np.zeros((99, 2))))


def test_warm_start_reaches_the_same_limit() -> None:
    inst = random_tiny(19)
    cold = colgen_bound(inst)
    p = np.asarray(inst.target_weight, dtype=float)
    data = orbit_data(inst)
    warm = colgen_bound(inst, data=data, start=(p, np.ones((len(data.orbits), 2))))
    assert warm["bound"] == cold["bound"] and warm["converged"]


@pytest.mark.limits
@pytest.mark.slow
def test_keeps_its_time_limit(c2) -> None:
    inst = c2  # about 50 rounds to converge
    data = orbit_data(inst)
    colgen_bound(inst, data=data)  # the first run compiles the planner
    t0 = time.perf_counter()
    full = colgen_bound(inst, data=data)
    # a quarter of the converged run's time (0.12 s on the 2-core machine): it stops early
    limit = (time.perf_counter() - t0) / 4
    t0 = time.perf_counter()
    out = colgen_bound(inst, data=data, time_limit=limit)
    limit_kept("colgen, a quarter of its run", time.perf_counter() - t0, limit + 0.2)
    assert not out["converged"] and out["bound"] >= full["bound"]


@pytest.mark.limits
@pytest.mark.slow
def test_bound_dispatch_keeps_its_time_limit() -> None:
    for limit in (0.3, 2.5):  # candidates unfinished (about 1.3 s); colgen cut short
        inst = scenario("C2")
        t0 = time.perf_counter()
        out = bound(inst, method="colgen", time_limit=limit)
        limit_kept(
            f"colgen bound, {limit} s", time.perf_counter() - t0, limit + 1.0
        )  # max(1 s, 5 %)
        assert out["bound"] <= observable_weight(inst)
        # whatever finished in time (the cap when the candidates or the first round did not:
        # how far it gets depends on the machine), the bound holds a schedule's profit
        assert out["source"] in ("cap", "colgen")
        assert out["bound"] >= solve(inst, "greedy").profit


def test_auto_falls_back_to_colgen_when_the_model_is_too_large(monkeypatch) -> None:
    import models.solve as ms

    inst = random_tiny(7)
    optimum = brute_force(inst, "cluster").profit

    def refuse(*args, **kwargs):
        raise InputError("orbit 'x': more than 10 candidate observations")

    monkeypatch.setattr(ms, "model_data", refuse)
    out = bound(inst, method="auto")
    assert out["method"] == "auto" and out["parts"] == {"colgen": out["bound"]}
    assert optimum <= out["bound"] <= observable_weight(inst)
    with pytest.raises(InputError, match="candidate"):
        bound(inst, method="lp")  # the LP has no such fallback


def test_workers_give_the_same_bound() -> None:
    inst = next(random_tiny(s) for s in range(100) if random_tiny(s).n_orbits >= 2)
    one = colgen_bound(inst)
    two = colgen_bound(inst, workers=2)
    assert (two["bound"], two["rounds"]) == (one["bound"], one["rounds"])


def test_certifies_a_schedule() -> None:
    from sosp.solve import solve

    inst = random_tiny(2)
    optimum = brute_force(inst, "cluster").profit
    res = solve(inst, "greedy", bound="colgen")
    assert res.profit <= optimum <= res.bound <= observable_weight(inst)
    assert res.stats["certified_by"] == "colgen"


# ------------------------------------------------------------------------ branch and price
@settings(max_examples=60, deadline=None)
@given(inst=small_instances())
def test_branch_and_price_never_below_the_optimum(inst: Instance) -> None:
    optimum = brute_force(inst, "cluster").profit
    root = colgen_bound(inst)["bound"]
    out = colgen_bound(inst, branch=True)
    assert optimum <= out["bound"] <= root
    if "profit" in out:
        assert validate(inst, out["schedule"]).feasible and out["profit"] <= optimum


@pytest.mark.parametrize(("seed", "optimum", "root"), [(19, 24, 27), (105, 23, 28), (226, 34, 39)])
def test_branch_and_price_closes_the_root_gap(seed: int, optimum: float, root: float) -> None:
    # instances whose master LP is above the optimum; branching on fractional
    # (target, orbit) covers reaches the optimum
    inst = random_tiny(seed)
    assert brute_force(inst, "cluster").profit == optimum
    assert colgen_bound(inst)["bound"] == root
    out = colgen_bound(inst, branch=True)
    assert out["bound"] == optimum and out["nodes"] >= 2
    # the node it ends on is integral in its covers: its plans give a valid schedule (all of
    # the node's value only when no plan of the mixture breaks (4)-(5), not so here)
    assert validate(inst, out["schedule"]).profit == out["profit"] <= optimum


@settings(max_examples=40, deadline=None)
@given(inst=small_instances())
def test_nodes_pruned_by_a_known_schedule_never_hide_the_optimum(inst: Instance) -> None:
    # a node's column generation stops once its bound is at most a known schedule's profit:
    # with a profit one or two below the optimum, the node holding the optimum is never
    # pruned, so the answer stays at least the optimum
    optimum = brute_force(inst, "cluster").profit
    for below in (1, 2):
        out = colgen_bound(inst, branch=True, lower_bound=optimum - below)
        assert out["bound"] >= optimum


@pytest.mark.parametrize(("seed", "optimum"), [(19, 24), (105, 23), (226, 34)])
def test_pruning_by_a_known_schedule_proves_it(monkeypatch, seed: int, optimum: int) -> None:
    # given the optimum as the known profit, the search ends at it; the children whose bound
    # reaches it stop there (returned without a cover)
    import models.colgen as colgen

    real, pruned = colgen._solve_node, []

    def watched(node, *args, **kwargs):
        out = real(node, *args, **kwargs)
        if kwargs.get("prune") is not None and out.cover is None:
            pruned.append((out.bound, kwargs["prune"]))
        return out

    monkeypatch.setattr(colgen, "_solve_node", watched)
    inst = random_tiny(seed)
    assert colgen_bound(inst, branch=True, lower_bound=optimum)["bound"] == optimum
    assert colgen_bound(inst, branch=True, lower_bound=optimum - 1)["bound"] == optimum
    assert pruned and all(math.floor(b + 1e-6) <= known for b, known in pruned)


@pytest.mark.parametrize(("seed", "optimum"), [(19, 24), (105, 23), (226, 34)])
def test_branch_and_price_with_a_restricted_start_master(monkeypatch, seed, optimum) -> None:
    # the nodes' masters start from a few pool columns (as on large pools): the answer is
    # the same optimum, the pricing adding back the columns each master needs
    import models.colgen as colgen

    monkeypatch.setattr(colgen, "POOL_ALL", 0)
    monkeypatch.setattr(colgen, "PER_ORBIT", 1)
    out = colgen_bound(random_tiny(seed), branch=True)
    assert out["bound"] == optimum


@pytest.mark.parametrize(("seed", "optimum"), [(19, 24), (105, 23), (226, 34)])
def test_children_start_from_their_parents_basis(monkeypatch, seed, optimum) -> None:
    # every child's first solve is given its parent's basis; with it, and with an absurd
    # alien basis (every row and column basic), the answer is the same optimum
    import highspy

    import models.colgen as colgen

    real = colgen._start_basis
    given: list[int] = []

    def counted(h, parent, free, forced, in_lp, cut_ids):
        given.append(len(in_lp))
        real(h, parent, free, forced, in_lp, cut_ids)

    monkeypatch.setattr(colgen, "_start_basis", counted)
    monkeypatch.setattr(colgen, "STRONG_CANDIDATES", 0)  # no node solved twice: one basis each
    out = colgen_bound(random_tiny(seed), branch=True)
    assert out["bound"] == optimum and len(given) == out["nodes"] >= 2

    def absurd(h, parent, free, forced, in_lp, cut_ids):
        basis = highspy.HighsBasis()
        basis.col_status = [highspy.HighsBasisStatus.kBasic] * h.getNumCol()
        basis.row_status = [highspy.HighsBasisStatus.kBasic] * h.getNumRow()
        basis.alien = True
        h.setBasis(basis)

    monkeypatch.setattr(colgen, "_start_basis", absurd)
    assert colgen_bound(random_tiny(seed), branch=True)["bound"] == optimum


@settings(max_examples=30, deadline=None)
@given(inst=small_instances())
def test_restricted_start_masters_never_below_the_optimum(inst: Instance) -> None:
    import models.colgen as colgen

    optimum = brute_force(inst, "cluster").profit
    saved = colgen.POOL_ALL, colgen.PER_ORBIT
    colgen.POOL_ALL, colgen.PER_ORBIT = 0, 1
    try:
        out = colgen_bound(inst, branch=True)
    finally:
        colgen.POOL_ALL, colgen.PER_ORBIT = saved
    assert optimum <= out["bound"]


@pytest.mark.limits
@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_branch_and_price_keeps_its_time_limit(workers: int, c2) -> None:
    # with two processes too: the helper's child is cut by the same deadline

    inst = c2
    data = orbit_data(inst)
    root = colgen_bound(inst, data=data)
    limit = root["runtime_s"] + 3.0
    t0 = time.perf_counter()
    out = colgen_bound(
        inst, data=data, time_limit=limit, branch=True, cut_rounds=0, workers=workers
    )
    limit_kept("branch and price, no cuts", time.perf_counter() - t0, limit + 0.5)
    assert out["bound"] <= root["bound"] and out["nodes"] >= 1
    # with the default cuts, whose separation reads no clock (here they take the time left)
    t0 = time.perf_counter()
    out = colgen_bound(inst, data=data, time_limit=limit, branch=True, workers=workers)
    limit_kept("branch and price, cuts", time.perf_counter() - t0, limit + 0.5)
    assert out["bound"] <= root["bound"]


@pytest.mark.parametrize(("seed", "optimum"), [(19, 24), (226, 34)])
def test_side_bound_in_its_own_process(seed: int, optimum: float) -> None:
    # the child runs the same branch and price and sends its bound: the optimum on these
    # instances (their master is above it), and the schedule the search ends on
    from models.colgen import SideBound

    inst = random_tiny(seed)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    deadline = time.perf_counter() + 30.0
    while side.poll() != optimum and time.perf_counter() < deadline:
        time.sleep(0.05)
    got, found = side.finish(wait=5.0)
    assert got == optimum
    if found is not None:
        assert validate(inst, found[0]).profit == found[1] <= optimum


def test_side_bound_that_cannot_start_is_no_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    # its child ended before reading the instance (a script without the __main__ guard):
    # the MILP beside it goes on alone, and nothing waits for the child
    import models.colgen as colgen
    from models.colgen import SideBound
    from sosp.parallel import ChildStartError

    def refuse(*args: object, **kwargs: object) -> None:
        raise ChildStartError("ended at its start")

    monkeypatch.setattr(colgen, "Child", refuse)
    inst = random_tiny(105)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    assert side.poll() is None and not side.yield_to(0.0) and not side.watch(0.0, 0.0)
    assert side.finish(wait=5.0) == (None, None)


def test_side_bound_stopped_early_keeps_a_valid_bound() -> None:
    from models.colgen import SideBound

    inst = random_tiny(105)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    got, _ = side.finish(wait=0.0)  # stopped at once: no bound, or a valid one
    assert got is None or got >= brute_force(inst, "cluster").profit


def test_side_bound_yields_to_a_lower_milp_bound() -> None:
    # the child stops once a MILP's bound is below its own (both rounded down); not before,
    # and only once
    from models.colgen import SideBound

    inst = random_tiny(226)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    side.bound = 40.7
    side._done = True  # what the child sent so far: 40.7
    assert not side.yield_to(1e9)  # above: goes on
    assert not side.yield_to(40.9)  # 40 after rounding down, as its own: goes on
    assert side._child.proc.is_alive() and side.yielded_at is None
    assert side.yield_to(39.99)
    assert side.yielded_at is not None and not side._child.proc.is_alive()
    first = side.yielded_at
    assert side.yield_to(0.0) and side.yielded_at == first
    got, _ = side.finish(wait=5.0)  # already stopped: its last bound
    assert got == 40.7


def test_side_bound_without_a_bound_does_not_yield() -> None:
    from models.colgen import SideBound

    inst = random_tiny(226)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    side.bound = None
    side._done = True  # nothing read from the child: no bound shown
    assert not side.yield_to(0.0)
    side.finish(wait=0.0)


def test_side_bound_watch_stops_the_milp_at_a_proven_incumbent() -> None:
    from models.colgen import SideBound

    inst = random_tiny(226)
    side = SideBound(inst, orbit_data(inst), 30.0, None)
    side.bound = 40.5
    side._done = True  # what the child sent so far: 40.5
    assert not side.watch(1e9, 39.0) and side.proved_at is None  # 39 < 40: not proven
    assert not side.watch(1e9, -np.inf)  # no incumbent yet
    assert side.watch(1e9, 40.0) and side.proved_at is not None  # stop the MILP
    assert side.yielded_at is None  # ... and the child, proven right, is not stopped here
    assert not side.watch(40.2, 39.0) and side.yielded_at is None  # not below its 40
    assert not side.watch(39.2, 39.0) and side.yielded_at is not None  # the yield rule
    side.finish(wait=0.0)


def test_side_bound_watch_proves_the_start_before_highs_reports() -> None:
    # the start the MILP was given (the child's lower bound) is proven as its incumbent
    # would be, also before HiGHS has a bound or an incumbent (inf, -inf)
    from models.colgen import SideBound

    inst = random_tiny(226)
    side = SideBound(inst, orbit_data(inst), 30.0, 40.0)
    side.bound = 41.5
    side._done = True
    assert not side.watch(np.inf, -np.inf) and side.yielded_at is None  # 41 > 40
    side.bound = 40.9
    assert side.watch(np.inf, -np.inf) and side.proved_at is not None
    assert not side.yield_to(np.inf)  # no MILP bound: nothing to yield to
    side.finish(wait=0.0)


def test_side_bound_watch_proves_the_schedule_the_child_ended_on() -> None:
    # the child's branch and price ended on a schedule better than the MILP's start and
    # incumbent, with its bound at that schedule's profit: the MILP is stopped
    from models.colgen import SideBound

    inst = random_tiny(226)
    side = SideBound(inst, orbit_data(inst), 30.0, 30.0)
    side.bound, side.found = 34.0, (None, 34.0)
    side._done = True
    assert side.watch(np.inf, 32.0) and side.proved_at is not None
    side.finish(wait=0.0)


def _side_says(monkeypatch, bound: float) -> None:
    """The MILP runs with a side process (no bound first spares it) whose bound is ``bound``."""
    import models.colgen as colgen
    import models.solve as msolve

    def poll(self):
        self.bound = bound
        return bound

    monkeypatch.setattr(colgen, "SIDE_MIN_S", 0.0)
    monkeypatch.setattr(colgen, "side_cores", lambda: 2)
    monkeypatch.setattr(colgen.SideBound, "poll", poll)
    monkeypatch.setattr(msolve, "_extra_bound", lambda *a, **k: (1e6, None))


def test_milp_stopped_when_its_side_bound_proves_the_incumbent(monkeypatch) -> None:
    # the side's bound (the optimum, 124) reaches the MILP through
    # models.highs_direct.watching_bound, which interrupts HiGHS: the answer is optimal
    from models.solve import solve_milp

    inst = random_dense(2, n=80)
    best = solve_milp(inst, extra_bound="none", backend="highs").schedule  # 124
    _side_says(monkeypatch, 124.0)
    res = solve_milp(inst, time_limit=20.0, backend="highs", warm_start=best)
    assert res.stats["side_proved_s"] <= res.runtime_s
    assert res.stats["termination"] == "Interrupted by user" and "side_yielded_s" not in res.stats
    assert res.status == "optimal" and res.bound == validate(inst, res.schedule).profit == 124


def test_milp_stops_its_side_bound_once_its_own_is_lower(monkeypatch) -> None:
    # HiGHS's dual bound reaches the side process through models.highs_direct.watching_bound;
    # below the branch and price's (here a loose one) the side stops
    from models.solve import solve_milp

    _side_says(monkeypatch, 1e6)
    inst = random_dense(2, n=80)
    res = solve_milp(inst, time_limit=20.0, backend="highs", warm_start="none")
    assert res.stats["side_yielded_s"] <= res.runtime_s and "side_proved_s" not in res.stats
    assert res.status == "optimal" and validate(inst, res.schedule).profit == res.profit == 124


def test_milp_with_the_side_bound(monkeypatch) -> None:
    # the bound before the MILP gets no time, so the MILP runs with the side process beside
    # it; the answer is the oracle's optimum whichever of the two proves it
    import models.colgen as colgen
    import models.solve as msolve

    monkeypatch.setattr(colgen, "SIDE_MIN_S", 0.0)
    monkeypatch.setattr(colgen, "side_cores", lambda: 2)
    monkeypatch.setattr(msolve, "EXTRA_BOUND_SHARE", 1e-9)
    inst = random_tiny(226)
    res = msolve.solve_milp(inst, time_limit=20.0, backend="highs")
    assert "side_bound" in res.stats
    assert res.stats["side_bound"] is None or res.stats["side_bound"] >= 34
    assert res.status == "optimal" and res.profit == res.bound == 34
    assert validate(inst, res.schedule).profit == 34


def test_solver_children_end_with_their_parent(tmp_path) -> None:
    # a parent killed outright cannot stop its children (a guarded HiGHS solve, a side
    # branch and price): sosp.parallel.child_setup makes them end by themselves
    import os
    import subprocess
    import sys

    script = tmp_path / "parent.py"
    script.write_text(
        "import multiprocessing as mp, os, signal, time\n"
        "def child():\n"
        "    from sosp.parallel import child_setup\n"
        "    child_setup()\n"
        "    time.sleep(60.0)\n"
        "if __name__ == '__main__':\n"
        "    p = mp.get_context('spawn').Process(target=child, daemon=True)\n"
        "    p.start()\n"
        "    print(p.pid, flush=True)\n"
        "    time.sleep(2.0)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = {**os.environ, "PYTHONPATH": root}
    # (not subprocess.run: it would wait for the child too, which holds the pipe)
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, env=env)
    child = int(parent.stdout.readline())
    parent.wait(timeout=60)
    parent.stdout.close()
    deadline = time.perf_counter() + 10.0
    while time.perf_counter() < deadline:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            return
        time.sleep(0.2)
    os.kill(child, 9)
    raise AssertionError("the child outlived its parent")


def test_a_root_too_slow_for_its_deadline_stops_after_one_round(monkeypatch) -> None:
    import heuristics.orbit_search as orbit_search

    inst = random_tiny(4)
    optimum = brute_force(inst, "cluster").profit
    # no deadline: expect_rounds changes nothing
    assert colgen_bound(inst, expect_rounds=10**9)["rounds"] == colgen_bound(inst)["rounds"]
    out = colgen_bound(inst, time_limit=60.0, expect_rounds=10**9)
    assert out["rounds"] == 1 and out["master"] is None and out["plans"] == []
    assert optimum <= out["bound"] <= observable_weight(inst)
    # the orbit search then starts from nothing
    monkeypatch.setattr(orbit_search, "LP_START_ROUNDS", 10**9)
    search = orbit_search.OrbitSearch(orbit_data(inst), np.random.default_rng(0))
    figures = orbit_search.lp_start(search, time.perf_counter() + 60.0)
    assert figures["lp_rounds"] == 1 and figures["lp_profit"] == 0.0
    assert all(len(path) == 0 for path in search.paths)


def _random_lp(h: object, n: int, seed: int) -> None:
    """max c x over [0, 1]^n with n random sparse rows <= 1: a cold solve of some
    milliseconds."""
    import highspy
    import scipy.sparse as sp

    rng = np.random.default_rng(seed)
    a = sp.csr_matrix(sp.random(n, n, density=0.02, random_state=seed))
    h.addVars(n, np.zeros(n), np.ones(n))
    h.changeColsCost(n, np.arange(n, dtype=np.int32), -rng.random(n))
    idx = a.indptr[:-1].astype(np.int32)
    h.addRows(n, np.full(n, -highspy.kHighsInf), np.ones(n), a.nnz, idx, a.indices, a.data)


def test_a_master_solved_again_gets_its_own_seconds() -> None:
    """HiGHS's time limit counts the object's run clock over every run: a re-solve allowed
    less than the earlier solves took together must still run (it stopped at once before,
    ending G100k's column generation after three rounds)."""
    import highspy

    from models.colgen import _Master, allow_seconds

    h = _Master(np.zeros(0), np.zeros(0, dtype=bool), np.zeros((0, 2))).h  # an empty master
    _random_lp(h, 300, 0)
    once = []
    for _ in range(20):  # the clock adds up: about 20 cold solves' worth
        h.clearSolver()
        t = time.perf_counter()
        allow_seconds(h, None)
        h.run()
        once.append(time.perf_counter() - t)
        assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    h.clearSolver()
    allow_seconds(h, 5 * max(once))  # room for a cold solve, far below the clock's sum
    assert 5 * max(once) < h.getRunTime()
    h.run()
    assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
    assert h.getInfo().simplex_iteration_count > 0


@pytest.mark.limits
def test_highs_gives_way_to_the_search_on_large_models(monkeypatch) -> None:
    # on a model counted as large, HiGHS whose incumbent is still its start after its share
    # of the time is stopped, and the search goes on from the start until the deadline
    import models.highs_direct as hd
    import models.solve as msolve

    _side_says(monkeypatch, 1e6)  # a side that never proves and never yields
    monkeypatch.setattr(msolve, "LARGE_MODEL_ITEMS", 0)
    monkeypatch.setattr(msolve, "GIVE_WAY_SHARE", 0.0)
    # guarded, as the large models are (their nonzeros): the parent watches HiGHS also while
    # its root is unfinished
    monkeypatch.setattr(hd, "GUARD_NNZ", 0)
    inst = random_dense(2, n=400)  # HiGHS does not finish its root in 6 s
    start = solve(inst, "orbit-dp", seed=0, no_improve=200).schedule  # the 6 s are the MILP's
    res = msolve.solve_milp(inst, time_limit=6.0, backend="highs", warm_start=start)
    s = res.stats
    assert s["gave_way_s"] <= res.runtime_s
    limit_kept("gave way, 6 s", res.runtime_s, 6.0 + 1.0)
    assert s["search_on_s"] > 0 and s["search_on_profit"] >= s["start_profit"] - 1e-9
    assert validate(inst, res.schedule).profit == res.profit >= s["start_profit"]
    assert res.profit <= res.bound


@pytest.mark.limits
def test_search_after_giving_way_stops_when_the_side_proves(monkeypatch) -> None:
    # once HiGHS has given way, the search asks the side after each step: a side bound that
    # meets the best schedule ends the run before its deadline, proven
    import models.colgen as colgen
    import models.highs_direct as hd
    import models.solve as msolve

    _side_says(monkeypatch, 1e6)
    searching = []
    search_on = msolve._search_on

    def search(*args, **kwargs):  # the search after giving way
        searching.append(True)
        return search_on(*args, **kwargs)

    def poll(self):
        # no proof while HiGHS runs; the start's profit (the side's lower bound) after
        self.bound = self.lower_bound if searching else 1e6
        return self.bound

    monkeypatch.setattr(msolve, "_search_on", search)
    monkeypatch.setattr(colgen.SideBound, "poll", poll)
    monkeypatch.setattr(msolve, "LARGE_MODEL_ITEMS", 0)
    monkeypatch.setattr(msolve, "GIVE_WAY_SHARE", 0.0)
    monkeypatch.setattr(hd, "GUARD_NNZ", 0)
    inst = random_dense(2, n=400)
    res = msolve.solve_milp(inst, time_limit=20.0, backend="highs")
    s = res.stats
    assert s["gave_way_s"] <= s["side_proved_s"] and s["search_on_stopped"] == "proven"
    limit_kept("side proves, 20 s", res.runtime_s, 15.0)  # not the 20 s limit
    assert res.status == "optimal" and validate(inst, res.schedule).profit == res.profit


def test_highs_keeps_its_time_below_the_large_models(monkeypatch) -> None:
    import models.solve as msolve

    _side_says(monkeypatch, 1e6)
    monkeypatch.setattr(msolve, "GIVE_WAY_SHARE", 0.0)
    inst = random_dense(2, n=80)
    res = msolve.solve_milp(inst, time_limit=6.0, backend="highs")
    assert "gave_way_s" not in res.stats and "search_on_s" not in res.stats
    assert res.status == "optimal" and validate(inst, res.schedule).profit == res.profit == 124


def test_give_way_rule() -> None:
    # proof first; then only after the share, while the side has not yielded and HiGHS has
    # nothing above its start
    from models.solve import GIVE_WAY_SHARE, _GiveWay
    from sosp.stop import Budget

    class Side:
        yielded_at = None
        proves = False

        def watch(self, dual, incumbent):
            return self.proves

    side = Side()
    now = time.perf_counter()
    late = _GiveWay(side, 100.0, Budget.until(now + 0.2 / max(GIVE_WAY_SHARE, 1e-9)))
    assert not late(np.inf, 100.0) and late.gave_at is None  # before its share
    soon = _GiveWay(side, 100.0, Budget.until(time.perf_counter()))
    assert not soon(200.0, 101.0) and soon.gave_at is None  # HiGHS found better than its start
    side.yielded_at = 1.0
    assert not soon(150.0, 100.0) and soon.gave_at is None  # HiGHS holds the better bound
    side.yielded_at = None
    assert soon(200.0, 100.0) and soon.gave_at is not None
    first = soon.gave_at
    assert soon(200.0, -np.inf) and soon.gave_at == first  # the first time is kept
    side.proves = True
    assert late(np.inf, 100.0) and late.gave_at is None  # a proof stops HiGHS, no giving way


@pytest.mark.limits
def test_a_round_foreseen_past_the_deadline_is_not_started() -> None:
    """A pricing round reads no clock inside an orbit (over windows of a dense orbit:
    seconds), and a partial round is no bound: a round foreseen, at the longest one so
    far, to end past the deadline is not started (a drawn 1,200-target instance's window
    bound ran 7.9 s for a 5 s limit)."""
    import time
    import types

    import numpy as np

    from models.colgen import _Master, column_generation
    from sosp.stop import Budget

    _Master(np.zeros(0), np.zeros(0, dtype=bool), np.zeros((0, 2)))  # HiGHS loaded first
    calls: list[float] = []

    def slow_price(mu, lam, deadline):
        calls.append(time.perf_counter())
        time.sleep(0.5)
        return [(2.0, np.array([0]), (0.0, 0.0))]  # an over-estimate: never converges

    rules = [types.SimpleNamespace(energy_capacity=10.0, memory_capacity=10.0)]
    p, seen = np.array([1.0]), np.array([True])
    start = (p.copy(), np.zeros((1, 2)))
    t = time.perf_counter()
    root = column_generation(p, seen, rules, slow_price, start, Budget.until(t + 0.8))
    assert len(calls) == 1 and root.rounds == 1 and root.round_s >= 0.5
    assert root.best >= 1.0
    limit_kept("no round past 0.8 s", time.perf_counter() - t, 0.8)
    calls.clear()
    root = column_generation(p, seen, rules, slow_price, start, Budget(), max_rounds=2)
    assert len(calls) == 2  # no deadline: no foresight


# --------------------------------------------------------------------- subset-row cuts
def _root_only(monkeypatch) -> None:
    """``colgen_bound(branch=True)`` stops after the branching's root node (its cuts)."""
    import models.colgen as colgen

    whole = colgen.branch_and_price
    monkeypatch.setattr(
        colgen, "branch_and_price", lambda *a, **k: whole(*a, **{**k, "max_nodes": 0})
    )


def test_subset_row_cuts_close_the_triangle_at_the_root() -> None:
    inst = triangle()
    assert brute_force(inst, "cluster").profit == 38
    assert colgen_bound(inst)["bound"] == 42  # each orbit half on its pair, half alone
    out = colgen_bound(inst, branch=True, cut_rounds=3)
    assert out["bound"] == 38 and out["nodes"] == 0  # no branching needed
    assert validate(inst, out["schedule"]).profit == out["profit"] == 38
    assert colgen_bound(inst, branch=True, cut_rounds=0)["nodes"] >= 2


def test_orbit_cuts_close_the_split_pair_at_the_root(monkeypatch) -> None:
    # the cut over two targets and one orbit's convexity row closes what triples cannot
    import models.subset_row as sr

    inst = split_pair()
    assert brute_force(inst, "cluster").profit == 20
    assert colgen_bound(inst)["bound"] == 24
    out = colgen_bound(inst, branch=True, cut_rounds=3)
    assert out["bound"] == 20 and out["nodes"] == 0
    assert validate(inst, out["schedule"]).profit == out["profit"] == 20
    monkeypatch.setattr(sr, "ORBIT_CUTS", False)
    _root_only(monkeypatch)
    assert colgen_bound(inst, branch=True, cut_rounds=3)["bound"] == 24


def test_subset_row_cuts_never_below_the_optimum(monkeypatch) -> None:
    # instances whose masters mix pair plans: the cuts lower the root on some (8 of these
    # 60), never below the optimum, and the branch and price with them stays exact
    lowered = 0
    for seed in range(60):
        inst = shared_tiny(seed)
        optimum = brute_force(inst, "cluster").profit
        full = colgen_bound(inst, branch=True, cut_rounds=10)
        assert full["bound"] == optimum, seed
        with monkeypatch.context() as m:
            _root_only(m)
            plain = colgen_bound(inst, branch=True, cut_rounds=0)["bound"]
            cut = colgen_bound(inst, branch=True, cut_rounds=10)["bound"]
        assert optimum <= cut <= plain, seed
        lowered += cut < plain
    assert lowered >= 5


@pytest.mark.parametrize("strong", [0, 1, 5, 50])
def test_strong_branching_reaches_the_optimum(monkeypatch, strong: int) -> None:
    # whatever the candidates, the branching ends on the oracle's optimum; with strong
    # branching every branched node's pair is the one _strong_pick chose, among the node's
    # fractional pairs, and the master it probed is left as it was (same optimum after)
    import highspy

    import models.colgen as colgen

    real = colgen._strong_pick
    picked: list[tuple[int, int]] = []

    def checked(h, node, p, n, m_value, pf, *rest):  # noqa: ANN001, ANN202
        pick = real(h, node, p, n, m_value, pf, *rest)
        candidates = colgen._candidates(node, p, n)
        assert pick in candidates if candidates else pick is None  # None: nothing fractional
        h.run()
        assert h.getModelStatus() == highspy.HighsModelStatus.kOptimal
        after = -h.getInfo().objective_function_value + float(pf.sum())
        assert after == pytest.approx(m_value, abs=1e-7)
        if pick is not None:
            picked.append(pick)
        return pick

    monkeypatch.setattr(colgen, "_strong_pick", checked)
    monkeypatch.setattr(colgen, "STRONG_CANDIDATES", strong)
    for seed, optimum in [(19, 24), (105, 23), (226, 34)]:
        picked.clear()
        out = colgen_bound(random_tiny(seed), branch=True)
        assert out["bound"] == optimum and out["nodes"] >= 2
        assert (len(picked) >= out["nodes"] // 2) if strong else not picked
    for seed in range(6):
        inst = random_dense(seed)
        out = colgen_bound(inst, branch=True, cut_rounds=2)
        monkeypatch.setattr(colgen, "STRONG_CANDIDATES", 0)
        assert out["bound"] == colgen_bound(inst, branch=True, cut_rounds=2)["bound"]
        monkeypatch.setattr(colgen, "STRONG_CANDIDATES", strong)


@settings(max_examples=40, deadline=None)
@given(inst=small_instances())
def test_branch_and_price_with_cuts_never_below_the_optimum(inst: Instance) -> None:
    optimum = brute_force(inst, "cluster").profit
    out = colgen_bound(inst, branch=True, cut_rounds=10)
    assert optimum <= out["bound"]
    if "profit" in out:
        assert validate(inst, out["schedule"]).feasible and out["profit"] <= optimum


def test_cuts_separated_in_the_nodes_keep_the_branch_and_price_exact(monkeypatch) -> None:
    # cuts found below the root join the pool every later node keeps: still the optimum
    # (models.colgen.NODE_CUT_ROUNDS is 0 by default: measured slower on C5)
    import models.colgen as colgen
    from models.subset_row import CutPool

    added: list[int] = []
    separate = CutPool.separate

    def counted(self, *a, **k):  # noqa: ANN001, ANN202
        new = separate(self, *a, **k)
        added.append(len(new))
        return new

    monkeypatch.setattr(CutPool, "separate", counted)
    monkeypatch.setattr(colgen, "NODE_CUT_ROUNDS", 2)
    in_nodes = 0
    for seed in range(40):  # the orbit cuts leave the nodes little to find: 9 of 40 do
        inst = random_dense(seed)
        optimum = colgen_bound(inst, branch=True, cut_rounds=0)["bound"]  # exact, no limit
        added.clear()
        out = colgen_bound(inst, branch=True, cut_rounds=1)
        assert out["bound"] == optimum, seed
        in_nodes += sum(added[1:]) > 0  # the root separates once (cut_rounds=1)
    assert in_nodes >= 3


def test_long_runs_take_more_root_cut_rounds(monkeypatch) -> None:
    # measured: 5 rounds lowered 5 of C5-C10's bounds at 600 s, 3 were as good or better at
    # 60 s; no time limit counts as long
    import models.colgen as colgen

    assert colgen.root_cut_rounds(60.0) == colgen.CUT_ROUNDS == 3
    assert colgen.root_cut_rounds(600.0) == colgen.LONG_CUT_ROUNDS == 5
    assert colgen.root_cut_rounds(None) == colgen.LONG_CUT_ROUNDS
    assert colgen.root_cut_rounds(colgen.LONG_RUN_S) == colgen.LONG_CUT_ROUNDS
    taken: list[int] = []
    branch = colgen.branch_and_price

    def spy(*a, **k):  # noqa: ANN002, ANN003, ANN202
        taken.append(k["cut_rounds"])
        return branch(*a, **k)

    monkeypatch.setattr(colgen, "branch_and_price", spy)
    inst = random_tiny(19)  # a root gap: the branching runs
    for limit, rounds in ((30.0, None), (None, None), (30.0, 1)):
        colgen_bound(inst, branch=True, time_limit=limit, cut_rounds=rounds)
    assert taken == [3, 5, 1]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cached_cut_coefficients_follow_the_growing_pool(seed: int) -> None:
    # a column's cut coefficients are computed once per cut and kept (_Columns.coefficients):
    # after more cuts join the pool they must still equal the pool's, computed from scratch
    from models.colgen import _Columns
    from models.subset_row import CutPool

    groups = orbit_data(random_dense(seed, 40, 3)).orbits
    rng = np.random.default_rng(seed)
    pool, cols = CutPool(groups), _Columns()
    for _ in range(30):
        g = int(rng.integers(len(groups)))
        tg = np.unique(rng.choice(groups[g].targets, min(6, len(groups[g].targets))))
        cols.add(g, tg, rng.integers(1, 3, len(tg)), 1.0, 1.0)
    every = np.unique(np.concatenate([o.targets for o in groups]))
    for step in range(4):
        for _ in range(10):
            if rng.random() < 0.5 and len(groups) > 1:
                pool.add(
                    rng.choice(every, 2, replace=False).tolist(), [int(rng.integers(len(groups)))]
                )
            else:
                pool.add(rng.choice(every, 3, replace=False).tolist())
        for i in rng.permutation(len(cols.items))[: 10 + 7 * step]:
            g, tg, cnt, _, _ = cols.items[i]
            assert cols.coefficients(int(i), pool) == pool.coefficients(tg, cnt, g)
    assert any(cols.coefficients(i, pool) for i in range(len(cols.items)))


# ------------------------------------------------------- two processes in the branch and price
def test_truncated_pool_is_its_first_columns() -> None:
    # a helper drops its own columns before taking the parent's (_Columns.truncate): what is
    # left must be the pool of the first n columns, keys and flat values included
    from models.colgen import _Columns

    rng = np.random.default_rng(3)
    items = []
    for _ in range(12):
        tg = np.unique(rng.integers(0, 20, 4))
        items.append((int(rng.integers(3)), tg, rng.integers(1, 3, len(tg)), 1.0, 2.0))
    full, first = _Columns(), _Columns()
    for item in items:
        full.add(*item)
    for item in items[:7]:
        first.add(*item)
    price, per_unit = rng.random((3, 20)), rng.random((3, 2))
    full.values(price, per_unit)  # flat arrays made for all twelve before the cut
    full.truncate(7)
    assert full.keys == first.keys and len(full.items) == 7
    np.testing.assert_allclose(full.values(price, per_unit)[0], first.values(price, per_unit)[0])
    # the same plan with integer or float counts (priced here, received from a helper) is one
    g, tg, cnt, e, m = items[8]
    assert full.add(g, tg, cnt, e, m) == full.add(g, tg, cnt.astype(float), e, m) == 7


def _helper_answers(monkeypatch) -> list[int]:
    """Count the children the helper process returns."""
    import models.colgen as colgen

    real, answered = colgen._Helper.receive, []

    def counted(self, cols, deadline):
        out = real(self, cols, deadline)
        answered.append(out is not None)
        return out

    monkeypatch.setattr(colgen._Helper, "receive", counted)
    return answered


@pytest.mark.parametrize(("seed", "optimum"), [(19, 24), (105, 23), (226, 34)])
def test_two_processes_reach_the_optimum(monkeypatch, seed: int, optimum: int) -> None:
    answered = _helper_answers(monkeypatch)
    inst = random_tiny(seed)
    for cut_rounds in (0, 5):
        out = colgen_bound(inst, branch=True, workers=2, cut_rounds=cut_rounds)
        assert out["bound"] == optimum and out["nodes"] >= 2
        if "schedule" in out:
            assert validate(inst, out["schedule"]).profit == out["profit"] <= optimum
    assert answered and all(answered)  # the helper solved every second child


def test_two_processes_search_the_same_tree_every_time() -> None:
    # both children start from the pool at the branching, whichever process is faster: the
    # same nodes and bound on every run, and with any number of processes from two on
    inst = random_tiny(226)
    runs = [colgen_bound(inst, branch=True, workers=w, cut_rounds=0) for w in (2, 2, 3)]
    assert len({(r["bound"], r["nodes"], r["profit"]) for r in runs}) == 1


@settings(max_examples=10, deadline=None)
@given(inst=small_instances())
def test_two_processes_never_below_the_optimum(inst: Instance) -> None:
    optimum = brute_force(inst, "cluster").profit
    out = colgen_bound(inst, branch=True, workers=2)
    assert optimum <= out["bound"] <= colgen_bound(inst)["bound"]


@pytest.mark.parametrize("fails", ["send", "receive"])
def test_a_failed_helper_leaves_the_search_to_this_process(monkeypatch, fails: str) -> None:
    # a helper gone before it takes its child, or one that never returns it: this process
    # solves that child itself and goes on alone
    import models.colgen as colgen

    monkeypatch.setattr(
        colgen._Helper, fails, lambda self, *args: False if fails == "send" else None
    )
    assert colgen_bound(random_tiny(19), branch=True, workers=2)["bound"] == 24


def test_no_helper_where_none_can_start(monkeypatch) -> None:
    # a helper that ends at its start (as under a script without the __main__ guard): the
    # search runs in this process
    import models.colgen as colgen
    from sosp.parallel import ChildStartError

    def refuse(*args, **kwargs):
        raise ChildStartError("ended at its start")

    monkeypatch.setattr(colgen, "Child", refuse)
    assert colgen_bound(random_tiny(105), branch=True, workers=2)["bound"] == 23


def test_no_helper_with_too_little_time_left(monkeypatch) -> None:
    # a helper's start costs more than a child: with less than HELPER_MIN_LEFT_S left at the
    # first branching none starts; with a limit that leaves it, one starts and is stopped
    import models.colgen as colgen

    started = []
    real = colgen._Helper.start.__func__

    def counted(cls, *args):
        helper = real(cls, *args)
        started.append(helper)
        return helper

    monkeypatch.setattr(colgen._Helper, "start", classmethod(counted))
    inst = random_tiny(226)
    monkeypatch.setattr(colgen, "HELPER_MIN_LEFT_S", 1e6)
    assert colgen_bound(inst, branch=True, workers=2, time_limit=60.0)["bound"] == 34
    assert not started
    monkeypatch.setattr(colgen, "HELPER_MIN_LEFT_S", 0.0)
    assert colgen_bound(inst, branch=True, workers=2, time_limit=60.0)["bound"] == 34
    assert len(started) == 1 and not started[0]._child.proc.is_alive()  # closed, not left running
