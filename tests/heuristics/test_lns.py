"""milp-lns: exact re-planning of a few orbits at a time, judged by the validator and the oracle."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.lns import LNSParams
from sosp.errors import InputError, TimeLimitReached
from sosp.result import Status
from sosp.schedule import Schedule
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from tests.conftest import TINY, tiny_two_orbits
from tests.heuristics.test_asa import small_instances
from tests.limits import limit_kept
from tests.models.instances import random_tiny
from tests.oracle import brute_force


@pytest.mark.parametrize("seed", range(12))
def test_never_above_the_optimum_and_exact_with_every_orbit_freed(seed: int) -> None:
    inst = random_tiny(seed)
    optimum = brute_force(inst, "cluster").profit
    # a few orbits per step: a valid schedule, never above the optimum
    small = solve(inst, "milp-lns", start="hpfs-stc", seed=seed, orbits=1, iterations=6)
    assert validate(inst, small.schedule).feasible
    assert small.profit <= optimum + 1e-9
    # every orbit freed at once: one step is the whole cluster model, solved to optimality
    whole = solve(inst, "milp-lns", start="hpfs-stc", seed=seed, orbits=inst.n_orbits, iterations=1)
    # (optimal by the cap when the optimum observes every target with an opportunity)
    everything = optimum >= inst.observable_weight - 1e-9
    assert whole.status is (Status.OPTIMAL if everything else Status.FEASIBLE)
    assert whole.profit == pytest.approx(optimum)
    assert validate(inst, whole.schedule).profit == pytest.approx(optimum)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8),
    seed=st.integers(0, 2**16),
    k=st.integers(1, 2),
    hood=st.sampled_from(["orbits", "window"]),
    window=st.sampled_from([5.0, 30.0, 80.0, 300.0]),
)
def test_property_valid_and_bounded_by_the_oracle(
    inst, seed: int, k: int, hood: str, window: float
) -> None:
    # window steps keep the rest of the orbit: (3) against its neighbours and the residual
    # (4)-(6) (small_instances has binding energy, memory and openings) are what is tested
    res = solve(
        inst,
        "milp-lns",
        start="hpfs-stc",
        seed=seed,
        orbits=k,
        neighbourhood=hood,
        window=window,
        iterations=4,
        check=False,
    )
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit) and res.profit >= res.stats["start_profit"]
    assert res.profit <= brute_force(inst, "cluster").profit + 1e-9


def _window_runs(inst, seeds=range(6)) -> list:
    """Window steps from the HPFS-STC start, each result judged by the validator."""
    out = []
    for seed in seeds:
        res = solve(
            inst, "milp-lns", start="hpfs-stc", seed=seed, neighbourhood="window", window=30.0,
            iterations=12,
        )  # fmt: skip
        assert validate(inst, res.schedule).feasible
        out.append(res)
    return out


def test_window_step_respects_setup_time_to_the_fixed_neighbour() -> None:
    # p [0, 4] roll 30 (weight 10) stays; q [20, 24] roll -30 would need 10 + 60 s after p:
    # a window around q must not insert it (the start has p only)
    from sosp.instance import Instance

    inst = Instance.build({"p": 10, "q": 1}, [("p", 0, 0, 4, 30.0), ("q", 0, 20, 24, -30.0)])
    assert brute_force(inst, "cluster").profit == 10
    assert all(r.profit == 10 for r in _window_runs(inst))


def test_window_step_charges_the_slew_back_to_the_kept_observation() -> None:
    # energy on slews only, E = 26: p [0, 4] roll 30 (range [27, 33]) stays; q [200, 204] at
    # nadir after it would slew 30 + 0 = 30 > 26 (27 > 26 even at p's nadir-closest roll),
    # although q's own share (2 |0|) is 0
    from sosp.instance import Instance, Resources

    inst = Instance.build(
        {"p": 10, "q": 5},
        [("p", 0, 0, 4, 30.0), ("q", 0, 200, 204, 0.0)],
        resources=Resources(observe_energy_rate=0.0, energy_capacity=26.0),
    )
    assert brute_force(inst, "cluster").profit == 10
    assert all(r.profit == 10 for r in _window_runs(inst))


@pytest.mark.parametrize("name", sorted(TINY))
def test_tiny_named_instances_reach_the_oracle(name: str) -> None:
    inst = TINY[name]()
    res = solve(inst, "milp-lns", start="hpfs-stc", seed=0, orbits=inst.n_orbits, iterations=1)
    assert res.profit == pytest.approx(brute_force(inst, "cluster").profit)


def test_targets_fixed_elsewhere_are_not_claimed_twice() -> None:
    # a is visible on both orbits; the start observes a on orbit 1, so re-planning orbit 0
    # alone must not observe a again (2), and b on orbit 0 conflicts with a there (3)
    inst = tiny_two_orbits()
    start = solve(inst, "milp-lns", start="hpfs-stc", seed=0, orbits=2, iterations=1).schedule
    assert {ob.orbit for ob in start.observations} == {0, 1}  # a on 1, b on 0: profit 11
    res = solve(
        inst, "milp-lns", start="hpfs-stc", seed=3, orbits=1, iterations=8, warm_start=start
    )
    rep = validate(inst, res.schedule)
    assert rep.feasible and rep.profit == 11


def test_profit_never_below_the_start_and_trace_increases() -> None:
    from sosp.scenarios import custom_scenario

    # 60 targets, 24 h, 64 orbits, 268 opportunities (HPFS-STC 354, LNS 390 when written)
    inst = custom_scenario(region=(30.0, 60.0, 90.0, 120.0), count=60, seed=2, hours=24.0)
    hpfs = solve(inst, "hpfs-stc", seed=0)
    res = solve(inst, "milp-lns", start="hpfs-stc", seed=1, orbits=2, iterations=10)
    assert res.stats["start_profit"] == hpfs.profit
    assert res.profit > hpfs.profit  # clustering across static tasks pays here
    profits = [row[2] for row in res.stats["trace"]]
    assert profits == sorted(profits) and profits[-1] == res.profit
    assert validate(inst, res.schedule).profit == res.profit


def test_default_start_is_orbit_dp_and_never_lost() -> None:
    # the start gets the fresh generator first, so it is orbit-dp's same-seed run
    inst = random_tiny(3)
    first = solve(inst, "orbit-dp", seed=7, time_limit=10.0, iterations=30)
    res = solve(inst, "milp-lns", seed=7, iterations=4, start_params={"iterations": 30})
    assert res.stats["start"] == "orbit-dp" and res.stats["start_profit"] == first.profit
    assert res.profit >= first.profit


def test_start_from_asa_dtc_is_never_lost() -> None:
    inst = random_tiny(3)
    asa = solve(inst, "asa-dtc", seed=7, time_limit=10.0, iterations=300)
    res = solve(
        inst, "milp-lns", seed=7, iterations=4, start="asa-dtc", start_params={"iterations": 300}
    )
    assert res.stats["start"] == "asa-dtc" and res.stats["start_profit"] == asa.profit
    assert res.profit >= asa.profit


@pytest.mark.limits
def test_a_tiny_time_limit_returns_the_start() -> None:
    inst = random_tiny(2)
    res = solve(inst, "milp-lns", start="hpfs-stc", seed=0, time_limit=0.01)
    assert res.iterations == 0 and res.stats["candidates"] == 0
    assert res.profit == solve(inst, "hpfs-stc").profit
    limit_kept("milp-lns, 0.01 s", res.runtime_s, 1.0)


def test_a_start_out_of_its_time_falls_back_to_asa_dtc(monkeypatch: pytest.MonkeyPatch) -> None:
    # orbit-dp refuses to answer when its candidates are not arranged by its limit (D30 at
    # 30 s): that limit is the start's share, so the run goes on from ASA-DTC's schedule
    ss = sys.modules["sosp.pipeline"]
    lookup = ss.method_function

    def out_of_time(instance, *, rng, time_limit=None, **params):
        # at once: the arranging does not start an orbit foreseen to end past the limit
        raise TimeLimitReached("orbit 'A': time limit reached while arranging ...")

    monkeypatch.setattr(
        ss, "method_function", lambda m: out_of_time if m == "orbit-dp" else lookup(m)
    )
    inst = random_tiny(3)
    res = solve(inst, "milp-lns", seed=0, time_limit=2.0, start_time_limit=0.5)
    assert res.stats["start"] == "asa-dtc" and res.stats["start_profit"] > 0
    assert res.profit >= res.stats["start_profit"]
    assert validate(inst, res.schedule).feasible


def test_a_start_refused_within_its_time_is_an_error() -> None:
    with pytest.raises(InputError, match="bogus"):
        solve(random_tiny(3), "milp-lns", seed=0, iterations=2, start_params={"bogus": 1})


def test_too_dense_is_refused_before_the_start_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    import sosp.candidates as sc

    ss = sys.modules["sosp.pipeline"]  # the module (the package exports the function solve)

    inst = random_tiny(2)
    monkeypatch.setattr(sc, "MAX_CANDIDATE_BYTES", -1)  # tiny instances estimate 0 bytes
    lookup = ss.method_function

    def no_start(method: str):
        assert method == "milp-lns", f"the start {method} ran"
        return lookup(method)

    monkeypatch.setattr(ss, "method_function", no_start)
    with pytest.raises(InputError, match="candidate observations estimated"):
        solve(inst, "milp-lns", start="hpfs-stc", seed=0, time_limit=10, candidates="explicit")


def test_auto_plans_over_windows_where_the_candidates_do_not_fit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import sosp.candidates as sc

    inst = random_tiny(4)
    monkeypatch.setattr(sc, "MAX_CANDIDATE_BYTES", -1)
    res = solve(inst, "milp-lns", start="hpfs-stc", seed=0, iterations=6)
    assert res.stats["candidate_mode"] == "windows"
    assert validate(inst, res.schedule).feasible
    assert res.profit >= res.stats["start_profit"]


def test_candidates_out_of_time_after_the_start_go_on_over_windows(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the candidates foreseen not ready by the deadline (20,000 targets at 10 s): the steps
    # plan over windows instead of returning the start with the rest of the limit unused
    import sosp.candidates as sc

    def out_of_time(*args, **kwargs):
        raise TimeLimitReached("time limit foreseen to be reached while generating ...")

    monkeypatch.setattr(sc, "cluster_candidates", out_of_time)
    inst = random_tiny(7)  # the start (17) leaves the steps something to find (cap 29)
    res = solve(inst, "milp-lns", start="hpfs-stc", seed=0, iterations=6, time_limit=30)
    assert res.stats["candidate_mode"] == "windows" and res.iterations == 6
    assert validate(inst, res.schedule).feasible
    assert res.profit >= res.stats["start_profit"]


@pytest.mark.parametrize("seed", range(12))
def test_windows_mode_valid_never_below_its_start_nor_above_the_optimum(seed: int) -> None:
    inst = random_tiny(200 + seed)
    hood = ("auto", "window")[seed % 2]
    params = {"start": "hpfs-stc", "iterations": 8, "candidates": "windows", "neighbourhood": hood}
    res = solve(inst, "milp-lns", seed=seed, **params)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    assert res.stats["start_profit"] <= res.profit <= brute_force(inst, "cluster").profit + 1e-9
    same = solve(inst, "milp-lns", seed=seed, **params)
    assert same.schedule.to_dict(inst) == res.schedule.to_dict(inst)


@pytest.mark.parametrize("neighbourhood", ["orbits", "window"])
def test_windows_mode_gains_where_the_start_is_poor(neighbourhood: str) -> None:
    inst = TINY["tiny_cluster"]()  # greedy: 7, optimum: 11
    res = solve(
        inst,
        "milp-lns",
        start="greedy",
        seed=0,
        iterations=5,
        candidates="windows",
        neighbourhood=neighbourhood,
    )
    assert validate(inst, res.schedule).feasible
    assert res.stats["start_profit"] == 7 and res.profit == brute_force(inst, "cluster").profit


def test_infeasible_warm_start_is_ignored(caplog: pytest.LogCaptureFixture) -> None:
    inst = tiny_two_orbits()
    bad = solve(inst, "milp-lns", start="hpfs-stc", seed=0, orbits=2, iterations=1).schedule
    doubled = Schedule(bad.observations + bad.observations)
    res = solve(
        inst, "milp-lns", start="hpfs-stc", seed=0, orbits=2, iterations=1, warm_start=doubled
    )
    assert res.stats["start"] == "hpfs-stc" and "warm start ignored" in caplog.text
    assert validate(inst, res.schedule).feasible


@pytest.mark.parametrize(
    ("params", "field"),
    [
        ({"orbits": 0}, "orbits"),
        ({"orbits": 1.5}, "orbits"),
        ({"sub_time_limit": -1}, "sub_time_limit"),
        ({"start": "milp"}, "start"),
        ({"start": "nope"}, "start"),
        ({"no_improve": 0}, "no_improve"),
        ({"threads": True}, "threads"),
        ({"start_params": [1]}, "start_params"),
        ({"neighbourhood": "ring"}, "neighbourhood"),
        ({"window": 0}, "window"),
        ({"max_items": -3}, "max_items"),
        ({"candidates": "bogus"}, "candidates"),
    ],
)
def test_bad_parameters_name_the_field(params: dict, field: str) -> None:
    with pytest.raises(InputError, match=field):
        LNSParams(**params)
    with pytest.raises(InputError, match=field):
        solve(random_tiny(0), "milp-lns", **params)


def test_cli_solve_json_is_one_object_and_bad_param_exits_2(tmp_path) -> None:
    # a fresh process: highspy prints its banner on the first solver object of a process,
    # which must not reach standard output (the JSON)
    path = tmp_path / "inst.json"
    random_tiny(1).save(path)
    out = tmp_path / "s.json"
    cmd = [sys.executable, "-m", "sosp", "solve", str(path), "--method", "milp-lns"]
    done = subprocess.run(
        [*cmd, "--iterations", "3", "--param", "start=hpfs-stc", "-o", str(out), "--json"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    data = json.loads(done.stdout)
    assert data["method"] == "milp-lns" and data["status"] == "feasible" and out.exists()
    bad = subprocess.run(
        [*cmd, "--param", "orbits=0", "-o", str(tmp_path / "t.json")],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "orbits" in bad.stderr and "Traceback" not in bad.stderr
    assert not (tmp_path / "t.json").exists()


def test_cli_bound_json_with_the_direct_backend_is_clean(tmp_path) -> None:
    path = tmp_path / "inst.json"
    random_tiny(2).save(path)
    done = subprocess.run(
        [sys.executable, "-m", "sosp", "bound", str(path), "--backend", "highs", "--json"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["bound"] >= 0


def test_window_columns_are_not_started_when_foreseen_late() -> None:
    """A dense orbit's window columns take seconds without reading the clock (a 5 s run went
    to 12.8 s): an orbit is not started when its own last time, or the most seconds per
    (first, covered) pair seen times its pairs (at least ``WINDOW_S_PER_PAIR``), exceeds
    the time left."""
    import numpy as np

    from heuristics.lns import WINDOW_S_PER_PAIR, _Late, _WindowColumns
    from sosp.candidates import orbit_pairs

    inst = tiny_two_orbits()
    price = np.asarray(inst.target_weight, dtype=float)
    cols = _WindowColumns(inst, Budget.of(0.0))
    busy = [j for j in range(inst.n_orbits) if cols.n_opps[j]]
    assert cols.foreseen(busy[0]) == WINDOW_S_PER_PAIR * orbit_pairs(inst, busy[0]) > 0
    with pytest.raises(_Late) as late:
        cols(busy[0], price)  # nothing timed yet: foreseen at the prior rate, not made
    assert late.value.args[0] == busy[0] and not cols.whole.took
    cols.budget = Budget.of(10.0)
    orbit, *_ = cols(busy[0], price)
    assert set(orbit.tolist()) <= {busy[0]} and cols.whole.rate >= WINDOW_S_PER_PAIR
    cols.whole.took[busy[0]] = 5.0
    cols.budget = Budget.of(4.0)
    with pytest.raises(_Late):
        cols(busy[0], price)  # its own last time does not fit
    fresh = _WindowColumns(inst, Budget())
    fresh.whole.record("other", 1e12, 1e-3)  # a rate below the prior: the prior stands
    assert fresh.foreseen(busy[-1]) == WINDOW_S_PER_PAIR * orbit_pairs(inst, busy[-1])
    cols.whole.record("other", 1, 10.0)  # 10 s per pair: the other orbit is foreseen late
    with pytest.raises(_Late):
        cols(busy[-1], price)
    cols.budget = Budget()
    cols(busy[-1], price)


def test_window_members_are_not_listed_when_foreseen_late(monkeypatch) -> None:
    """After the sweep, the members' listing is foreseen by the opportunities it reads (per
    pair it varied 200-fold, and a 5 s run on a polar box went to 8.0 s): foreseen past the
    time left, the orbit is late, its time so far plus the listing's is kept, and no
    listing runs."""
    import numpy as np

    import heuristics.lns as lns
    import sosp.windows as sw

    inst = tiny_two_orbits()
    price = np.asarray(inst.target_weight, dtype=float)
    listed: list[int] = []
    real = sw._member_lists
    monkeypatch.setattr(sw, "_member_lists", lambda *a: listed.append(1) or real(*a))
    monkeypatch.setattr(lns, "WINDOW_S_PER_SCAN", 1e3)  # 1,000 s an opportunity read
    cols = lns._WindowColumns(inst, Budget.of(100.0))
    busy = [j for j in range(inst.n_orbits) if cols.n_opps[j]]
    assert cols.foreseen(busy[0]) < 100.0  # the sweep is in time
    with pytest.raises(lns._Late):
        cols(busy[0], price)
    assert listed == [] and cols.whole.took[busy[0]] > 100.0 and not cols.scan.took
    monkeypatch.setattr(lns, "WINDOW_S_PER_SCAN", 1e-12)
    cols = lns._WindowColumns(inst, Budget.of(100.0))
    cols(busy[-1], price)
    assert listed == [1] and cols.scan.rate > 1e-12
    assert cols.listing(10**6) == pytest.approx(cols.scan.rate * 10**6)


def test_an_orbit_foreseen_late_is_left_out_and_the_steps_go_on(monkeypatch, b2) -> None:
    """Windowed steps drop an orbit whose columns are foreseen late and go on over the others
    (they ended at the first such orbit: a drawn 5,000-target instance kept its start)."""
    import numpy as np

    import heuristics.lns as lns
    from sosp.validate import validate

    inst = b2
    real = lns._WindowColumns.foreseen
    n_opps = np.diff(inst.orbit_offsets)
    dense = int(np.argmax(n_opps))
    monkeypatch.setattr(
        lns._WindowColumns, "foreseen", lambda self, j: 1e9 if j == dense else real(self, j)
    )
    made: list[int] = []
    real_call = lns._WindowColumns.__call__

    def spy(self, j, price):
        out = real_call(self, j, price)
        made.append(j)  # made (not refused)
        return out

    monkeypatch.setattr(lns._WindowColumns, "__call__", spy)
    res = lns.solve_milp_lns(
        inst,
        rng=np.random.default_rng(0),
        candidates="windows",
        iterations=12,
        orbits=2,
        start="greedy",
        time_limit=60.0,  # (a time left to compare with)
    )
    assert validate(inst, res.schedule).feasible
    assert dense not in made, made
    assert len(set(made)) > 2 and res.iterations == 12, (made, res.iterations)


def test_one_per_target_keeps_each_target_once_per_window() -> None:
    """The duplicate-free shortcut (no target twice on the orbit) and the sort agree."""
    import numpy as np

    from sosp.windows import _one_per_target, orbit_opps

    inst = tiny_two_orbits()
    oo = orbit_opps(inst, int(np.argmax(np.diff(inst.orbit_offsets))))
    n = len(oo.target)
    ptr = np.array([0, n, 2 * n])
    flat = np.concatenate([np.arange(n), np.arange(n)[::-1]])
    p2, f2 = _one_per_target(oo, ptr, flat)
    assert np.array_equal(p2, ptr) and np.array_equal(f2, flat)
    twice = replace(oo, target=np.zeros(n, dtype=oo.target.dtype))  # one target seen n times
    p3, f3 = _one_per_target(twice, ptr, flat)
    assert p3.tolist() == [0, 1, 2] and f3.tolist() == [0, 0]


def test_a_model_foreseen_past_the_deadline_is_not_built(monkeypatch, b2) -> None:
    """A step's model (data, arrays) reads no clock (3 million members: 1.7 s, and a 5 s run
    went to 7.4 s): foreseen past the deadline at ``BUILD_S_PER_MEMBER`` (until one was
    timed), it is not built; the answer is the start's."""
    import numpy as np

    import heuristics.lns as lns
    import models.data
    from sosp.validate import validate

    inst = b2
    built: list[int] = []
    real = models.data.prepare
    monkeypatch.setattr(models.data, "prepare", lambda *a, **k: built.append(1) or real(*a, **k))
    kw = dict(candidates="windows", iterations=5, start="greedy", time_limit=60.0)
    monkeypatch.setattr(lns, "BUILD_S_PER_MEMBER", 1e6)  # never in time, however small
    res = lns.solve_milp_lns(inst, rng=np.random.default_rng(0), **kw)
    assert built == [] and res.stats["steps_improved"] == 0
    assert res.profit == res.stats["start_profit"] and validate(inst, res.schedule).feasible
    monkeypatch.setattr(lns, "BUILD_S_PER_MEMBER", 1e-12)
    lns.solve_milp_lns(inst, rng=np.random.default_rng(0), **kw)
    assert built


def test_a_model_foreseen_too_long_skips_its_step_not_the_search(monkeypatch, b2) -> None:
    """One neighbourhood too large for the time left ends that step only: the next step
    draws another (it ended the search, and a 20 s run on a 600-target instance at 14 s)."""
    import numpy as np

    import heuristics.lns as lns
    import models.data
    from sosp.validate import validate

    inst = b2
    built: list[int] = []
    real = models.data.prepare
    monkeypatch.setattr(models.data, "prepare", lambda *a, **k: built.append(1) or real(*a, **k))
    asked: list[int] = []
    seconds = lns.BuildForesight.seconds

    def first_too_long(self, members: int) -> float:
        asked.append(members)
        return float("inf") if len(asked) == 1 else seconds(self, members)

    monkeypatch.setattr(lns.BuildForesight, "seconds", first_too_long)
    kw = dict(candidates="windows", iterations=5, start="greedy", time_limit=60.0)
    res = lns.solve_milp_lns(inst, rng=np.random.default_rng(0), **kw)
    assert len(asked) >= 2 and len(built) == len(asked) - 1
    assert res.profit >= res.stats["start_profit"] and validate(inst, res.schedule).feasible


def test_build_foresight_keeps_a_small_models_time_out_of_the_rate() -> None:
    # one member's model takes about 1 ms, all of it fixed cost: read as a rate (820 us a
    # member) it foresaw 7.6 s for a model of 25,718 members that takes 11 ms
    from heuristics.lns import BUILD_S_PER_MEMBER, RATE_MIN_MEMBERS, BuildForesight

    f = BuildForesight()
    assert f.seconds(1000) == pytest.approx(1000 * BUILD_S_PER_MEMBER)
    f.record(1, 0.0008)
    assert f.seconds(25_718) == pytest.approx(0.0008 + 25_718 * BUILD_S_PER_MEMBER)
    f.record(RATE_MIN_MEMBERS - 1, 0.002)  # small: the fixed part, the most so far
    f.record(100_000, 0.05)  # large: the rate, 0.5 us a member
    assert f.seconds(1_000_000) == pytest.approx(0.002 + 0.5)
    f.record(50_000, 0.01)  # a faster large model does not lower the rate
    f.record(10, 0.001)  # nor a faster small one the fixed part
    assert f.seconds(1_000_000) == pytest.approx(0.002 + 0.5)


def test_window_columns_beyond_the_members_cap_leave_the_orbit_out(monkeypatch) -> None:
    """An orbit whose window candidates would list more than ``MAX_WINDOW_MEMBERS`` (a polar
    box of 10,000 targets: 3.7 billion, a MemoryError) raises before they are allocated,
    and milp-lns leaves that orbit out of its steps."""
    import numpy as np

    import sosp.windows as sw
    from heuristics.lns import _Late, _WindowColumns

    inst = tiny_two_orbits()
    price = np.asarray(inst.target_weight, dtype=float)
    cols = _WindowColumns(inst, Budget())
    busy = [j for j in range(inst.n_orbits) if cols.n_opps[j]]
    monkeypatch.setattr(sw, "MAX_WINDOW_MEMBERS", 0)
    with pytest.raises(sw.TooManyMembers):
        sw.window_candidates(sw.orbit_opps(inst, busy[0]), price)
    with pytest.raises(_Late):
        cols(busy[0], price)
    assert cols.foreseen(busy[0]) == float("inf")


def test_stacked_columns_read_their_groups_in_place() -> None:
    """A step's columns read each orbit's groups where they are: the same tuples and offsets
    as one concatenated list, with no copy of the members (the copy of one dense orbit's 70
    million took 1.2 s on a fresh process, past a 5 s limit)."""
    import numpy as np

    from heuristics.lns import _stack_columns
    from sosp.candidates import OppGroups
    from sosp.schedule import Observation

    a = OppGroups.from_groups([(1, 2), (3,), ()])
    b = OppGroups.from_groups([(7, 8, 9)])

    def part(j: int, g: OppGroups) -> tuple:
        n = len(g)
        return np.full(n, j), np.arange(n, dtype=float), np.ones(n), np.zeros(n), g

    freed = [Observation(orbit=5, start=1.0, end=2.0, roll=0.0, opps=(4, 6))]
    orbit, start, end, roll, opps = _stack_columns([part(0, a), part(3, b)], freed)
    groups = [(1, 2), (3,), (), (7, 8, 9), (4, 6)]
    assert len(opps) == len(orbit) == 5 and orbit.tolist() == [0, 0, 0, 3, 5]
    assert [opps[u] for u in range(5)] == groups
    assert np.diff(opps.ptr).tolist() == [len(g) for g in groups]
    assert opps.parts[0].flat is a.flat and opps.parts[1].flat is b.flat
    with pytest.raises(IndexError):
        opps[5]
