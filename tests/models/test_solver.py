"""Solver traps: time limit, stale options, silence, warm start, bad input, the CLI, cliques."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from heuristics.greedy import solve_greedy
from models.cliques import maximal_cliques, orbit_intervals
from models.solve import solve_milp
from sosp.candidates import cluster_candidates
from sosp.conflicts import setup_conflict_pairs
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.result import Status
from sosp.schedule import Observation, Schedule
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, tiny_chain, tiny_cluster
from tests.limits import limit_kept
from tests.models.instances import random_tiny


def _hard() -> Instance:
    return scenario("C5")


@given(
    st.lists(
        st.tuples(
            st.floats(0, 200), st.floats(0.5, 20), st.floats(-33, 33), st.sampled_from([0, 1])
        ),
        min_size=1,
        max_size=25,
    )
)
@settings(max_examples=60, deadline=None)
def test_cliques_cover_exactly_the_conflict_pairs(rows) -> None:
    """Every conflict edge of (3) is in a clique, and every clique pair is a conflict."""
    inst = Instance.build(
        [1] * len(rows),
        [(k, o, s, s + d, r) for k, (s, d, r, o) in enumerate(rows)],
        resources=Resources(setup_time=5.0, slew_rate=2.0),
        n_orbits=2,
    )
    pairs = {
        tuple(p)
        for p in setup_conflict_pairs(
            inst, inst.opp_orbit, inst.opp_start, inst.opp_end, inst.opp_roll
        ).tolist()
    }
    got: set[tuple[int, int]] = set()
    for j in range(inst.n_orbits):
        sl = inst.orbit_opps(j)
        left, right = orbit_intervals(
            inst.opp_start[sl], inst.opp_end[sl], inst.opp_roll[sl], 5.0, 2.0
        )
        cl = [c + sl.start for c in maximal_cliques(left, right)]
        got |= clique_cover_pairs(cl)
    assert got == pairs


def test_candidates_are_valid_observations() -> None:
    for seed in range(10):
        inst = random_tiny(seed)
        orbit, start, end, roll, opps = cluster_candidates(inst)
        for u in range(len(opps)):
            ob = Observation(int(orbit[u]), float(start[u]), float(end[u]), float(roll[u]), opps[u])
            # structure, (7) and (11) hold by construction; resources are the model's job
            kinds = {v.constraint for v in validate(inst, Schedule((ob,))).violations}
            assert kinds <= {"2", "4", "5", "6"}, kinds
            idx = np.array(opps[u])
            assert start[u] == inst.opp_start[idx].min() and end[u] == inst.opp_end[idx].max()


@pytest.mark.limits
@pytest.mark.slow
def test_time_limit_applies_and_does_not_raise() -> None:
    inst = _hard()
    t0 = time.perf_counter()
    res = solve_milp(inst, model="task", time_limit=3.0)
    wall = time.perf_counter() - t0
    limit_kept("task model, 3 s", wall, 3.0 + 2.0)  # reading the solution, the overshoot
    assert res.status in (Status.TIME_LIMIT, Status.OPTIMAL, Status.NO_SOLUTION)
    if res.status is Status.TIME_LIMIT:
        assert res.bound >= res.profit and validate(inst, res.schedule).feasible
    # a fresh solver per solve: no stale limit or gap carried into the next solve
    res2 = solve_milp(tiny_chain(), model="task")
    assert res2.status is Status.OPTIMAL


@pytest.mark.limits
def test_candidates_get_half_the_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 20,000-target worldwide instance spent ``milp``'s whole limit generating the
    model's candidates and returned the empty schedule: they get half of it, and past that
    the start's schedule is returned."""
    import models.solve as ms
    from models.data import TimeUp

    seen = {}

    def out_of_time(instance, model, deadline, generate_by=None):
        seen["rest"] = deadline - generate_by  # the other half of the limit
        time.sleep(max(0.0, generate_by - time.perf_counter()))  # generating until then
        raise TimeUp("candidate generation")

    monkeypatch.setattr(ms, "model_data", out_of_time)
    inst = random_tiny(4)
    start = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    res = solve_milp(inst, time_limit=2.0, warm_start=start)
    assert seen["rest"] == pytest.approx((1 - ms.MODEL_SHARE) * 2.0)
    assert res.stats["returned"] == "warm_start" and res.profit > 0
    assert validate(inst, res.schedule).feasible
    limit_kept("candidates out of time, 2 s", res.runtime_s, 2.0 + 1.0)


@pytest.mark.limits
@pytest.mark.parametrize("start", ["auto", "schedule", "none"])
def test_no_model_in_time_still_gives_a_schedule(
    start: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """When the model's items are not ready by the deadline (C10 at 5 s: the empty schedule
    after 0.7 s before), ``milp`` returns the given warm start, or with ``auto`` its start
    stage's, and the observable weight as its bound."""
    import models.solve as ms
    from models.data import TimeUp, observable_weight

    def out_of_time(*args, **kwargs):
        raise TimeUp("candidate generation")

    monkeypatch.setattr(ms, "model_data", out_of_time)
    inst = random_tiny(4)
    greedy = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    warm = {"auto": "auto", "schedule": greedy, "none": "none"}[start]
    res = solve_milp(inst, time_limit=2.0, warm_start=warm)
    assert res.stats["timed_out"] == "candidates" and res.bound == observable_weight(inst)
    assert validate(inst, res.schedule).feasible
    if start == "none":
        assert res.profit == 0
    elif start == "schedule":
        assert res.schedule == greedy and res.stats["returned"] == "warm_start"
    else:
        assert res.stats["start"] == "orbit-dp" and res.stats["returned"] == "warm_start"
        assert res.profit == res.stages[0].profit > 0
        limit_kept("no model, the start's schedule, 2 s", res.runtime_s, 2.0 + 1.0)


@pytest.mark.limits
def test_time_the_milp_cannot_use_goes_to_the_search(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where HiGHS is not run (its model not foreseen to be built in the time left; C10 at
    10 s returned its 1-s warm start after 3.4 s), the orbit search goes on from the warm
    start until the deadline: never below it, valid, and the limit kept."""
    import models.solve as ms

    fits = ms.fits
    monkeypatch.setattr(ms, "fits", lambda stage, n, d: stage != "build" and fits(stage, n, d))
    inst = random_tiny(6)  # its warm start is below the cap: the MILP would be run
    res = solve_milp(inst, time_limit=2.0, extra_bound="none", backend="highs")
    assert res.stats["timed_out"] == "building" and "search_on_s" in res.stats
    assert res.profit >= res.stats["search_on_profit"] >= 0
    assert res.profit >= res.stats["start_profit"] - 1e-9
    # the search goes on from the start: never below it
    assert res.stats["search_on_profit"] >= res.stats["start_profit"] - 1e-9
    assert validate(inst, res.schedule).feasible
    limit_kept("search on, 2 s", res.runtime_s, 3.0)


def test_no_stale_gap_between_solves() -> None:
    inst = random_tiny(7)
    solve_milp(inst, model="cluster", mip_gap=0.9)
    res = solve_milp(inst, model="cluster")
    assert res.status is Status.OPTIMAL and res.bound == res.profit


def test_highs_is_silent(capfd: pytest.CaptureFixture[str]) -> None:
    solve_milp(random_tiny(1), model="cluster", time_limit=10)
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_highs_log_at_debug(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.DEBUG, logger="models.solve"):
        solve_milp(random_tiny(1), model="cluster", warm_start="none")
    assert any("HiGHS" in r.getMessage() or "MIP" in r.getMessage() for r in caplog.records)


def test_warm_start_from_greedy() -> None:
    inst = random_tiny(5)
    start = solve_greedy(inst, rng=np.random.default_rng(0)).schedule
    for model in ("task", "cluster"):
        res = solve_milp(inst, model=model, warm_start=start)
        assert res.stats["warm_start"] is True
        assert res.status is Status.OPTIMAL


def test_infeasible_warm_start_is_ignored(caplog: pytest.LogCaptureFixture) -> None:
    inst = tiny_chain()
    # a and b conflict by (3)
    bad = Schedule(
        (
            Observation(0, 0.0, 4.0, 10.0, (0,)),
            Observation(0, 10.0, 14.0, 1.0, (1,)),
        )
    )
    with caplog.at_level(logging.WARNING, logger="models.solve"):
        res = solve_milp(inst, model="task", warm_start=bad)
    assert res.stats["warm_start"] is False
    assert any("warm start ignored" in r.getMessage() for r in caplog.records)
    assert res.status is Status.OPTIMAL and res.profit == 8


def test_clustered_warm_start_ignored_by_task_model(caplog: pytest.LogCaptureFixture) -> None:
    inst = tiny_cluster()
    clustered = Schedule((Observation(0, 0.0, 9.0, 10.0, (0, 1)),))
    with caplog.at_level(logging.WARNING, logger="models.solve"):
        res = solve_milp(inst, model="task", warm_start=clustered)
    assert res.stats["warm_start"] is False
    res = solve_milp(inst, model="cluster", warm_start=clustered)
    assert res.stats["warm_start"] is True and res.profit == 11


def test_bad_input() -> None:
    inst = tiny_chain()
    with pytest.raises(InputError, match="model"):
        solve_milp(inst, model="nope")
    with pytest.raises(InputError, match="time_limit"):
        solve_milp(inst, time_limit=0)
    with pytest.raises(InputError, match="mip_gap"):
        solve_milp(inst, mip_gap=-1)
    with pytest.raises(InputError, match="threads"):
        solve_milp(inst, threads=0)
    with pytest.raises(InputError, match="method"):
        from models.solve import bound

        bound(inst, method="simplex")


def test_no_opportunities_is_optimal_and_empty() -> None:
    inst = Instance.build({"a": 3}, [], n_orbits=1, orbit_length=100.0)
    for model in ("task", "cluster", "static"):
        res = solve_milp(inst, model=model)
        assert res.status is Status.OPTIMAL and res.profit == 0 and len(res.schedule) == 0


def test_through_sosp_solve_with_params(monkeypatch) -> None:
    import models.colgen as colgen

    monkeypatch.setattr(colgen, "side_cores", lambda: 2)  # as on the 2-core machine
    inst = tiny_cluster()
    res = solve(inst, "milp", model="cluster", mip_gap=0.0, threads=1, time_limit=30)
    assert res.status is Status.OPTIMAL and res.profit == 11
    assert res.schedule.method == "milp"
    # the warm start observes every target: proven without building the MILP
    assert res.stats["proven_by"] == "cap" and "variables" not in res.stats
    # without a start and no side process to come (less than SIDE_MIN_S left) the branch and
    # price before the MILP ends on an integral node: proven, no MILP either
    res = solve(inst, "milp", mip_gap=0.0, threads=1, time_limit=3, warm_start="none")
    assert res.status is Status.OPTIMAL and res.profit == 11
    assert res.stats["start_from"] == "branch_and_price" and "variables" not in res.stats
    # with one to come, the branching is the side's and the MILP is built
    res = solve(inst, "milp", mip_gap=0.0, threads=1, time_limit=30, warm_start="none")
    assert res.status is Status.OPTIMAL and res.profit == 11
    assert res.stats["variables"] > 0
    res = solve(
        inst, "milp", mip_gap=0.0, threads=1, time_limit=30, warm_start="none",
        extra_bound="none",
    )  # fmt: skip
    assert res.status is Status.OPTIMAL and res.profit == 11
    for key in ("variables", "constraints", "nonzeros", "candidates"):
        assert res.stats[key] > 0


@pytest.mark.parametrize("backend", ["pyomo", "highs"])
def test_changing_threads_between_solves(backend: str) -> None:
    # HiGHS keeps one task scheduler per process: a later solve asking for another thread
    # count used to end "unknown" with no solution (seen in CI after earlier default solves).
    inst = tiny_cluster()
    for threads in (None, 1, 2, 1, None):
        res = solve_milp(inst, model="cluster", threads=threads, backend=backend, time_limit=30)
        assert res.status is Status.OPTIMAL and res.profit == 11, (threads, res.stats)


@pytest.mark.parametrize("backend", ["pyomo", "highs"])
@pytest.mark.parametrize("seed", [0, 3, 8])
def test_lp_solvers_give_the_same_lp_value(backend: str, seed: int) -> None:
    from models.solve import bound

    inst = random_tiny(seed)
    values = {
        algo: bound(inst, method="lp", backend=backend, lp_solver=algo)
        for algo in ("choose", "simplex", "ipm")
    }
    ref = values["choose"]["lp_value"]
    for algo, out in values.items():
        assert out["lp_value"] == pytest.approx(ref, abs=1e-6), algo
        assert out["bound"] == values["choose"]["bound"] and out["lp_solver"] == algo
    with pytest.raises(InputError, match="lp_solver"):
        bound(inst, lp_solver="barrier")


@pytest.mark.parametrize("case", [*range(20), "energy_slew_60", "energy_slew_59", "memory"])
def test_relaxed_slew_lp_is_a_bound_above_the_exact_lp(case) -> None:
    from models.solve import bound
    from tests.models.instances import EDGE_CASES
    from tests.oracle import brute_force

    inst = random_tiny(case) if isinstance(case, int) else EDGE_CASES[case]()
    optimum = brute_force(inst, "cluster").profit
    exact = bound(inst, method="lp", backend="highs", slew="exact")
    relaxed = bound(inst, method="lp", slew="relaxed")
    assert relaxed["slew"] == "relaxed" and exact["slew"] == "exact"
    assert relaxed["lp_value"] >= exact["lp_value"] - 1e-6 >= optimum - 1e-6
    assert relaxed["bound"] >= optimum


def test_relaxed_slew_row_by_hand() -> None:
    # rolls 30, 0, 30, eo = 0, E = 59: the relaxed row counts every slew twice and gives back
    # twice the largest: 60 x_a + 0 x_b + 60 x_c <= 59 + 60, so the LP takes a, b and 59/60 of
    # c: 5 + 4 + 3 * 59 / 60 = 11.95 (the exact optimum is 9: a and c cannot both go)
    from models.solve import bound
    from tests.models.instances import energy_slew_only

    out = bound(energy_slew_only(59.0), model="task", method="lp", slew="relaxed")
    assert out["lp_value"] == pytest.approx(5 + 4 + 3 * 59 / 60) and out["bound"] == 11


def test_slew_option_bad_input() -> None:
    from models.solve import bound

    inst = random_tiny(0)
    with pytest.raises(InputError, match="slew"):
        bound(inst, slew="approximate")
    with pytest.raises(InputError, match="slew"):
        solve_milp(inst, slew="relaxed")  # a MILP with a relaxed (4) could break (4)
    with pytest.raises(InputError, match="slew"):
        bound(inst, slew="relaxed", backend="pyomo")
    # auto: exact where Pyomo is chosen (small), relaxed where the direct backend is
    assert bound(inst, method="lp")["slew"] == "exact"
    assert bound(inst, method="lp", backend="highs")["slew"] == "relaxed"


@pytest.mark.parametrize("backend", ["pyomo", "highs"])
def test_cli_solve_milp_backend(tmp_path, capsys: pytest.CaptureFixture[str], backend: str) -> None:
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    argv = ["solve", str(path), "--method", "milp", "--backend", backend, "--json"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "optimal" and out["profit"] == 11
    assert main(["solve", str(path), "--method", "milp", "--backend", "gurobi"]) == 2
    err = capsys.readouterr().err
    assert "backend" in err and len(err.strip().splitlines()) == 1


def test_relaxation_gives_bound_only() -> None:
    res = solve_milp(tiny_cluster(), relax=True)
    assert res.status is Status.NO_SOLUTION and len(res.schedule) == 0
    assert res.bound >= 11


def test_cli_bound_json(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    assert main(["bound", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "auto" and out["bound"] >= 11 and out["runtime_s"] >= 0
    assert out["bound"] <= out["cap"] and out["source"] in ("lp", "lagrangian", "colgen", "cap")
    assert main(["bound", str(path), "--method", "lp", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["method"] == "lp"
    assert main(["bound", str(path), "--method", "milp", "--model", "task", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bound"] == 7 and out["profit"] == 7
    assert main(["bound", str(path), "--model", "nope"]) == 2
    assert main(["bound", str(path), "--time-limit", "-1"]) == 2
    err = capsys.readouterr().err
    # the option's name, not an internal one (issue 63, item 8: "invalid _positive_float")
    assert "error:" in err and "--time-limit" in err and "_positive" not in err
    # two processes plan the orbits: the same bound as one
    assert main(["bound", str(path), "--method", "lagrangian", "--workers", "2", "--json"]) == 0
    two = json.loads(capsys.readouterr().out)["bound"]
    assert main(["bound", str(path), "--method", "lagrangian", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["bound"] == two
    assert main(["bound", str(path), "--workers", "0"]) == 2
    assert "--workers" in capsys.readouterr().err


def test_cli_bound_says_when_the_lp_was_not_solved(
    tmp_path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # an LP too large for its time limit leaves only the cap: the text says so, and where to
    # turn, instead of quoting "0 items" for candidates that were never generated
    import models.solve as msolve
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    cut_short = {
        "bound": 15.0, "method": "lp", "model": "cluster", "runtime_s": 0.5,
        "timed_out": "candidates", "source": "cap",
    }  # fmt: skip
    monkeypatch.setattr(msolve, "bound", lambda *a, **k: dict(cut_short))
    assert main(["bound", str(path), "--method", "lp", "--time-limit", "1"]) == 0
    text = capsys.readouterr().out
    assert "lp bound: 15 (from cap" in text and "stopped before its candidates" in text
    assert "the LP was not solved within the time limit" in text and "0 items" not in text
    # solved: no such line
    monkeypatch.undo()
    assert main(["bound", str(path), "--method", "lp"]) == 0
    text = capsys.readouterr().out
    assert "from lp" in text and "not solved" not in text


def test_cli_module_imports_nothing_heavy() -> None:
    code = (
        "import sys, models.cli; "
        "print(any(m.split('.')[0] in ('pyomo', 'highspy', 'networkx') for m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("backend", ["pyomo", "highs"])
@pytest.mark.parametrize("seed", [0, 4, 9])
def test_probing_on_or_off_gives_the_same_optimum(backend: str, seed: int) -> None:
    from models.solve import solve_milp
    from tests.models.instances import random_tiny
    from tests.oracle import brute_force

    inst = random_tiny(seed)
    optimum = brute_force(inst, "cluster").profit
    for probing, limit, used in (("on", 30.0, True), ("off", None, False), ("auto", 30.0, False)):
        res = solve_milp(inst, backend=backend, probing=probing, time_limit=limit)
        assert res.status is Status.OPTIMAL and res.profit == optimum
        assert res.stats["probing"] is used
    assert solve_milp(inst, backend=backend).stats["probing"] is True  # auto without a limit


def test_probing_must_be_auto_on_or_off() -> None:
    from models.solve import solve_milp
    from tests.models.instances import random_tiny

    with pytest.raises(InputError, match="probing"):
        solve_milp(random_tiny(0), probing="yes")


def clique_cover_pairs(cliques: list[np.ndarray]) -> set[tuple[int, int]]:
    """All item pairs implied by ``cliques`` (for checks: equals the conflict pairs of (3))."""
    pairs: set[tuple[int, int]] = set()
    for c in cliques:
        c = sorted(int(x) for x in c)
        for a in range(len(c)):
            for b in range(a + 1, len(c)):
                pairs.add((c[a], c[b]))
    return pairs
