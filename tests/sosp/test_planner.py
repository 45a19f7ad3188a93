"""The single-orbit recursion, the Lagrangian bound and ``orbit-dp``, against brute force."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
import types

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.orbit_search import lp_start, solve_orbit_dp
from models.colgen import colgen_bound
from models.lagrangian import lagrangian_bound
from sosp.ascent import START_MODES, OrbitSearch, OrbitSearchParams
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance, Resources
from sosp.planner import (
    OrbitItems,
    best_feasible_path,
    best_path,
    orbit_data,
    plan_sequence,
    with_rolls,
)
from sosp.recursion import recursion
from sosp.result import Status
from sosp.rules import orbit_rules
from sosp.schedule import Observation, Schedule
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from tests.conftest import (
    TINY,
    small_instances,
    tiny_cluster,
    tiny_openings,
    tiny_two_orbits,
)
from tests.models.instances import EDGE_CASES, random_tiny
from tests.oracle import brute_force


def _plans(data, o: OrbitItems):
    """Every sequence of positions of orbit o that keeps (3) and (6), by enumeration."""
    inst = data.instance
    j = o.orbit
    a, v = float(inst.setup_time[j]), float(inst.slew_rate[j])
    st_, en, th = data.start[o.items], data.end[o.items], np.abs(data.roll[o.items])
    for r in range(0, min(o.rules.max_openings, o.size) + 1):
        for combo in itertools.combinations(range(o.size), r):
            seq = sorted(combo, key=lambda u: (st_[u], en[u]))
            if all(
                st_[w] - en[u] >= a + (th[u] + th[w]) / v - 1e-9 for u, w in itertools.pairwise(seq)
            ):
                yield np.array(seq, dtype=np.int64)


def _penalised(o: OrbitItems, path, price, lam_e: float, lam_w: float) -> float:
    gain = sum(
        float(price[o.target_flat[o.target_ptr[u] : o.target_ptr[u + 1]]].sum()) for u in path
    )
    energy, memory = o.usage(path)
    cap = o.rules
    return gain - lam_e * energy / cap.energy_capacity - lam_w * memory / cap.memory_capacity


@pytest.mark.parametrize("seed", range(25))
def test_recursion_equals_enumeration_of_plans(seed: int) -> None:
    inst = random_tiny(seed)
    data = orbit_data(inst)
    rng = np.random.default_rng(seed)
    for o in data.orbits:
        if o.size > 14:
            continue  # enumeration too large; random_tiny keeps most orbits far smaller
        price = rng.uniform(0, 10, inst.n_targets)
        lam_e, lam_w = [(0.0, 0.0), (float(rng.uniform(0, 20)), float(rng.uniform(0, 20)))][
            seed % 2
        ]
        value, path = best_path(o, price, lam_e, lam_w)
        best = max(_penalised(o, p, price, lam_e, lam_w) for p in _plans(data, o))
        assert value == pytest.approx(max(best, 0.0), abs=1e-9)
        if len(path):
            # the returned plan is one of the enumerated ones and is worth the value
            assert any(np.array_equal(path, p) for p in _plans(data, o))
            assert _penalised(o, path, price, lam_e, lam_w) == pytest.approx(value, abs=1e-9)


def _capped_reference(g, first, last, order, n_before, cap) -> float:
    """The best value of a chain of at most ``cap`` positions, level by level (numpy)."""
    level = g + first
    best = float(np.max(level + last))
    for _ in range(cap - 1):
        prefix = np.concatenate([[-np.inf], np.maximum.accumulate(level[order])])
        level = np.maximum(first, prefix[n_before]) + g
        best = max(best, float(np.max(level + last)))
    return best


def test_levels_kernel_with_and_without_the_cap_binding() -> None:
    # the kernel's uncapped sweep is taken only when its plan fits the cap, the levels
    # otherwise: both give the best chain of at most cap positions, compiled or not, and
    # the same as the levels alone (sweep 0)
    from sosp.recursion import levels, levels_py, release_order

    binding = fitting = 0
    for seed in range(40):
        rng = np.random.default_rng(seed)
        m = int(rng.integers(1, 40))
        left = rng.uniform(0, 100, m)
        right = left + rng.uniform(0.5, 10, m)
        order, n_before = release_order(left, right)
        n_before = n_before.astype(np.int64)
        g = rng.normal(1.0, 2.0, m)
        first = rng.uniform(0, 1, m) if seed % 2 else np.zeros(m)
        last = rng.uniform(-1, 1, m) if seed % 3 else np.zeros(m)
        uncapped = _capped_reference(g, first, last, order, n_before, m)
        for cap in range(1, 8):
            want = _capped_reference(g, first, last, order, n_before, cap)
            binding += uncapped > want + 1e-9
            fitting += uncapped <= want + 1e-9
            for kernel, sweep in ((levels_py, 1), (levels(), 1), (levels(), 0)):
                value, path = kernel(g, first, last, order, n_before, cap, sweep)
                assert value == pytest.approx(want, abs=1e-9), (seed, cap)
                assert 1 <= len(path) <= cap
                for u, w in itertools.pairwise(path):
                    assert u in order[: n_before[w]]  # u may precede w by (3)
                got = first[path[0]] + g[path].sum() + last[path[-1]]
                assert got == pytest.approx(value, abs=1e-9)
    assert binding >= 40 and fitting >= 40


@pytest.mark.parametrize("seed", range(10))
def test_sparse_and_bincount_gains_agree(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Both ways of summing prices per position (large orbits take the CSR product) give the
    sum over each position's targets, and the recursion the same plan."""
    import sosp.planner as odp

    inst = random_tiny(seed)
    data = orbit_data(inst)
    rng = np.random.default_rng(seed)
    price = rng.uniform(0, 10, inst.n_targets)
    dense = [o.gains(price) for o in data.orbits]
    plans = [best_path(o, price)[1] for o in data.orbits]
    monkeypatch.setattr(odp, "_SPARSE_GAINS", 0)
    for o, d, plan in zip(data.orbits, dense, plans, strict=True):
        by_hand = [
            price[o.target_flat[o.target_ptr[u] : o.target_ptr[u + 1]]].sum() for u in range(o.size)
        ]
        assert o.gains(price) == pytest.approx(by_hand, abs=1e-9)
        assert d == pytest.approx(by_hand, abs=1e-9)
        assert np.array_equal(best_path(o, price)[1], plan)


@pytest.mark.parametrize("seed", range(25))
def test_feasible_path_keeps_every_constraint_and_is_exact_when_knapsacks_are_slack(
    seed: int,
) -> None:
    inst = random_tiny(100 + seed)
    data = orbit_data(inst)
    price = np.asarray(inst.target_weight, dtype=float)
    for o in data.orbits:
        if o.size > 14:
            continue
        path = best_feasible_path(o, price)
        assert o.fits(path)
        plans = [p for p in _plans(data, o) if o.fits(p)]
        best = max(_penalised(o, p, price, 0.0, 0.0) for p in plans)
        got = _penalised(o, path, price, 0.0, 0.0)
        assert got <= best + 1e-9
        _, free = best_path(o, price)
        if o.fits(free):
            assert got == pytest.approx(best)


def test_energy_through_slews_only_is_exact() -> None:
    # rolls 30, 0, 30 with ranges [27, 33], [-3, 3], [27, 33] (tests/models/instances.py):
    # the nadir-closest rolls are 27, 0, 27, so all three cost 27 + 0 + 0 + 27 = 54 of slew
    # energy (eo = 0) and any two at most 27 + 27 = 54 (a, c) or 27 (with b). Capacity 54 fits
    # all three (an over-approximated 2 sum |theta| = 108 would cut it); 53 fits a or c with b.
    from tests.models.instances import energy_slew_only

    for cap, expect in ((54.0, 12.0), (53.0, 9.0)):
        inst = energy_slew_only(cap)
        res = solve(inst, "orbit-dp", seed=0, iterations=5)
        assert res.profit == expect == brute_force(inst, "cluster").profit


@pytest.mark.parametrize("name", sorted(EDGE_CASES))
def test_lagrangian_bound_is_never_below_the_optimum_edge_cases(name: str) -> None:
    inst = EDGE_CASES[name]()
    optimum = brute_force(inst, "cluster").profit
    assert lagrangian_bound(inst, iterations=50)["bound"] >= optimum


@pytest.mark.parametrize("seed", range(40))
def test_lagrangian_bound_and_orbit_dp_against_the_oracle(seed: int) -> None:
    inst = random_tiny(seed)
    optimum = brute_force(inst, "cluster").profit
    out = lagrangian_bound(inst, iterations=60)
    assert out["bound"] >= optimum
    assert out["bound"] == int(out["bound"])
    res = solve(inst, "orbit-dp", seed=seed, iterations=30)
    assert validate(inst, res.schedule).feasible
    assert res.profit <= optimum + 1e-9


def test_one_orbit_with_slack_knapsacks_is_solved_exactly(tiny: Instance) -> None:
    # one orbit: the first ascent re-plans it optimally (knapsacks do not bind in TINY)
    res = solve(tiny, "orbit-dp", seed=0, iterations=1)
    assert res.profit == brute_force(tiny, "cluster").profit


def test_hand_built_cluster_and_openings() -> None:
    # tiny_cluster: a and b share rolls [8, 12] and overlap: one opening at roll 8 (the
    # nadir-closest common roll) covers both (9), c far away on the other side adds 2.
    res = solve(tiny_cluster(), "orbit-dp", seed=0, iterations=1)
    assert res.profit == 11.0
    ob = [o for o in res.schedule.observations if len(o.opps) == 2][0]
    assert (ob.start, ob.end, ob.roll) == (0.0, 9.0, 8.0)
    # tiny_openings: two openings, four 2 s windows at roll 0, 100 s apart. A strip may span
    # gaps up to Delta T = 120 s (11): [0, 102] covers a, b and [200, 302] covers c, d, so
    # both openings take everything (1 + 2 + 3 + 4); single-target observations would give 7.
    res = solve(tiny_openings(), "orbit-dp", seed=0, iterations=1)
    assert res.profit == 10.0
    assert sorted((o.start, o.end) for o in res.schedule.observations) == [
        (0.0, 102.0),
        (200.0, 302.0),
    ]


def test_two_orbits_share_a_target_counted_once() -> None:
    res = solve(TINY["tiny_two_orbits"](), "orbit-dp", seed=0, iterations=10)
    assert res.profit == 11.0  # a on orbit 1, b on orbit 0


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=8),
    seed=st.integers(0, 2**16),
    steps=st.integers(1, 40),
    start=st.sampled_from(START_MODES),
)
def test_property_valid_and_bounded(inst: Instance, seed: int, steps: int, start: str) -> None:
    res = solve(inst, "orbit-dp", seed=seed, iterations=steps, check=False, start=start)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    optimum = brute_force(inst, "cluster").profit
    assert res.profit <= optimum + 1e-9
    assert lagrangian_bound(inst, iterations=40)["bound"] >= optimum


def _slack_instance(seed: int) -> Instance:
    """Several orbits seeing the same few targets (each at most once per orbit), knapsacks
    that never bind: the single-orbit planner is exact there."""
    rng = np.random.default_rng(seed)
    n_orbits, n_targets = int(rng.integers(2, 5)), int(rng.integers(3, 9))
    rows = []
    for j in range(n_orbits):
        for k in rng.choice(
            n_targets, size=int(rng.integers(1, min(n_targets, 6) + 1)), replace=False
        ):
            s = float(np.round(rng.uniform(0, 150), 1))
            roll = float(np.round(rng.uniform(-30, 30), 1))
            rows.append(
                (int(k), j, s, s + float(np.round(rng.uniform(1, 12), 1)), roll, roll - 3, roll + 3)
            )
    rows.sort(key=lambda r: (r[1], r[2], r[3]))
    res = Resources(
        memory_capacity=1e6,
        energy_capacity=1e6,
        slew_rate=float(rng.choice([1.0, 4.0])),
        setup_time=float(rng.choice([10.0, 2.0])),
        max_openings=int(rng.choice([10, 2])),
        max_duration=float(rng.choice([120.0, 15.0])),
    )
    weights = [int(w) for w in rng.integers(2, 11, size=n_targets)]
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"slack{seed}")


def _check_coverage(search: OrbitSearch) -> None:
    count = np.zeros_like(search.count)
    owners = np.zeros_like(search.owners)
    for g, covered in enumerate(search.covered):
        count[covered] += 1
        owners[covered] ^= g + 1
    assert np.array_equal(search.count, count)
    assert np.array_equal(search.owners, owners)
    assert search.profit == pytest.approx(float(search.weight[count > 0].sum()))


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**16))
def test_ascent_ends_where_no_orbit_gains(seed: int) -> None:
    """The ascent re-plans only the orbits whose prices changed against their plans
    (:meth:`OrbitSearch._set`); with an exact planner it still ends where no orbit's re-plan
    gains, after any sequence of plan changes."""
    inst = _slack_instance(seed)
    data = orbit_data(inst)
    search = OrbitSearch(data, np.random.default_rng(seed))
    rng = np.random.default_rng(seed + 1)
    search.ascent()  # every orbit starts dirty
    for _ in range(4):
        changed = rng.choice(inst.n_orbits, size=int(rng.integers(1, 3)), replace=False)
        for g in changed:
            # any prices: the plan may take targets from other orbits or drop its own
            price = np.where(
                rng.random(inst.n_targets) < 0.6, rng.uniform(0, 10, inst.n_targets), 0
            )
            search._set(int(g), best_feasible_path(data.orbits[int(g)], price))
            _check_coverage(search)
        # a changed orbit is left as it is (as in :meth:`OrbitSearch.perturb`) unless the
        # others' changes call for its re-plan; here it is to be settled too
        search.dirty[changed] = True
        search.ascent()
        _check_coverage(search)
        assert not search.dirty.any()
        assert not any(search.replan(g) for g in range(inst.n_orbits))

        mark = len(search.journal)
        search._set(0, np.zeros(0, dtype=np.int64))
        search.undo(mark)
        _check_coverage(search)


def test_ascent_checks_its_deadline_before_each_orbit(monkeypatch) -> None:
    """A pass over a dense instance's orbits takes seconds: the deadline is read before each
    orbit's re-plan, so an ascent whose deadline passes after the second re-plan stops
    there (and leaves a feasible, partly ascended schedule), not at the end of the pass."""
    import sosp.ascent as ascent
    import sosp.stop

    inst = _slack_instance(0)
    assert inst.n_orbits >= 3
    data = orbit_data(inst)
    search = OrbitSearch(data, np.random.default_rng(0))
    search._late = lambda g, deadline: False  # (no foresight here: below)
    # one tick per reading: the check before an orbit reads once, its timed re-plan twice,
    # so the deadline 3.5 passes at the check before the third orbit
    clock = itertools.count()
    fake = types.SimpleNamespace(perf_counter=lambda: float(next(clock)))
    monkeypatch.setattr(ascent, "time", fake)
    monkeypatch.setattr(sosp.stop, "time", fake)  # the budget reads the same clock
    search.ascent(Budget.until(3.5))
    assert search.replans == 2
    assert validate(inst, search.schedule()).feasible


def test_ascent_skips_orbits_foreseen_past_the_deadline() -> None:
    """An orbit whose plan is foreseen to end past the deadline (its own last time, else its
    work at the last rate or the prior) is skipped and the others are planned; the ascent
    ends when a pass plans none (one plan over windows of an orbit of 8,191 opportunities
    took seconds, and a 1 s ``orbit-dp`` ran 2.8 s)."""
    import time

    inst = _slack_instance(0)
    data = orbit_data(inst)
    busy = [g for g in range(len(data.orbits)) if len(data.orbits[g].items)]
    assert len(busy) >= 2
    search = OrbitSearch(data, np.random.default_rng(0))
    search.plans.took[busy[0]] = 1e6  # its last plan took "a million seconds"
    search.ascent(Budget.until(time.perf_counter() + 60.0))
    assert search.plans.took[busy[0]] == 1e6 and len(search.paths[busy[0]]) == 0
    assert all(g in search.plans.took for g in busy[1:])
    assert validate(inst, search.schedule()).feasible
    search.ascent()  # no deadline: no foresight
    assert search.plans.took[busy[0]] < 1e6


@pytest.mark.parametrize("name", sorted(TINY))
def test_lp_start_alone_reaches_an_integral_masters_optimum(name: str) -> None:
    # on the named tiny instances the master's optimum is integral (one plan per orbit at
    # value 1): the start sets those plans, and their profit is the oracle's optimum
    inst = TINY[name]()
    search = OrbitSearch(orbit_data(inst), np.random.default_rng(0))
    figures = lp_start(search, None)
    optimum = brute_force(inst, "cluster").profit
    assert figures["lp_master"] == pytest.approx(optimum)
    assert figures["lp_profit"] == search.profit == optimum
    assert validate(inst, search.schedule()).feasible


@pytest.mark.parametrize("seed", range(30))
def test_lp_start_sets_a_plan_where_the_master_has_one(seed: int) -> None:
    inst = random_tiny(seed)
    data = orbit_data(inst)
    search = OrbitSearch(data, np.random.default_rng(0))
    figures = lp_start(search, None)
    root = colgen_bound(inst, data=data)
    assert figures["lp_master"] == root["master"]
    assert all(value > 0 for _, _, value, _, _ in root["plans"])
    with_plan = {g for g, targets, _, _, _ in root["plans"] if len(targets)}
    for g in range(len(data.orbits)):
        assert (len(search.paths[g]) > 0) == (g in with_plan)
    rep = validate(inst, search.schedule())
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(search.profit) == pytest.approx(figures["lp_profit"])
    weight = np.asarray(inst.target_weight, dtype=float)
    covered = np.unique(np.concatenate([np.zeros(0, dtype=np.int64), *search.covered]))
    assert search.profit == pytest.approx(weight[covered].sum())


def test_lp_start_is_the_default_and_can_be_turned_off() -> None:
    inst = random_tiny(3)
    on = solve(inst, "orbit-dp", seed=0, iterations=5)
    off = solve(inst, "orbit-dp", seed=0, iterations=5, start="empty")
    assert on.stats["lp_rounds"] >= 1 and "lp_rounds" not in off.stats


def test_no_opportunities_gives_an_empty_schedule() -> None:
    inst = Instance.build({"a": 3}, [], resources=Resources(), n_orbits=1)
    res = solve(inst, "orbit-dp", seed=0, time_limit=1)
    assert res.status is Status.OPTIMAL and res.bound == 0.0
    assert res.schedule.observations == ()
    res = solve_orbit_dp(
        inst, rng=np.random.default_rng(0), time_limit=1
    )  # without solve's shortcut
    assert res.status is Status.OPTIMAL and res.schedule.observations == ()
    assert lagrangian_bound(inst)["bound"] == 0.0


@pytest.mark.parametrize(
    "params, field",
    [
        ({"perturb_orbits": 0}, "perturb_orbits"),
        ({"noise": 1.0}, "noise"),
        ({"steal": -0.1}, "steal"),
        ({"steal": True}, "steal"),
        ({"iterations": 2.5}, "iterations"),
        ({"no_improve": 0}, "no_improve"),
        ({"bogus": 1}, "bogus"),
        ({"start": "greedy"}, "start"),
    ],
)
def test_bad_parameters(params: dict, field: str) -> None:
    with pytest.raises(InputError, match=field):
        OrbitSearchParams.from_kwargs(**params)
    with pytest.raises(InputError, match=field):
        solve(tiny_cluster(), "orbit-dp", seed=0, **{"iterations": 1, **params})


def test_bound_iterations_must_be_positive() -> None:
    with pytest.raises(InputError, match="iterations"):
        lagrangian_bound(tiny_cluster(), iterations=0)


def test_cli_bound_lagrangian_and_solve(tmp_path) -> None:
    path = tmp_path / "inst.json"
    inst = random_tiny(3)
    inst.save(path)
    out = subprocess.run(
        [sys.executable, "-m", "sosp", "bound", str(path), "--method", "lagrangian", "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    got = json.loads(out.stdout)
    assert got["method"] == "lagrangian"
    assert got["bound"] >= brute_force(inst, "cluster").profit
    sched = tmp_path / "s.json"
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "sosp",
            "solve",
            str(path),
            "--method",
            "orbit-dp",
            "--seed",
            "1",
            "--time-limit",
            "1",
            "-o",
            str(sched),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(out.stdout)["profit"] <= brute_force(inst, "cluster").profit
    assert sched.exists()


def test_too_many_candidates_is_a_one_line_error_naming_the_orbit() -> None:
    from sosp.candidates import cluster_candidates

    inst = tiny_cluster()
    assert len(cluster_candidates(inst)[4]) > 1
    with pytest.raises(InputError, match="^orbit 'orbit0': more than 1 candidate observations"):
        cluster_candidates(inst, max_candidates=1)


def test_candidates_past_the_deadline_are_a_one_line_error() -> None:
    import time

    from sosp.candidates import cluster_candidates

    with pytest.raises(TimeLimitReached, match="^orbit 'orbit0': time limit reached"):
        cluster_candidates(tiny_cluster(), deadline=time.perf_counter() - 1.0)
    # orbit-dp asked for explicit candidates passes its limit on: a limit too short for them
    # is that error; by default it plans over windows instead (and answers: validated)
    with pytest.raises(TimeLimitReached, match="time limit reached while generating"):
        solve(random_tiny(5), "orbit-dp", seed=0, time_limit=1e-9, candidates="explicit")
    res = solve(random_tiny(5), "orbit-dp", seed=0, time_limit=1e-9)
    assert res.stats["candidate_mode"] == "windows"


def test_orbit_dp_plans_over_windows_when_the_candidates_are_foreseen_late(monkeypatch, c3) -> None:
    """Candidates foreseen not ready within ``EXPLICIT_SHARE`` of the limit: by default
    orbit-dp plans over windows (and answers); asked for explicit candidates, it is the
    one-line error."""
    import sosp.candidates as cands

    inst = c3
    monkeypatch.setattr(cands, "FORESIGHT_AFTER_S", 0.0)
    monkeypatch.setattr(cands, "FORESIGHT_MARGIN", 1e-12)  # any rate is too slow
    res = solve(inst, "orbit-dp", seed=0, time_limit=60, iterations=2)  # validated by solve
    assert res.stats["candidate_mode"] == "windows" and res.profit > 0
    with pytest.raises(TimeLimitReached, match="foreseen"):
        solve(inst, "orbit-dp", seed=0, time_limit=60, iterations=2, candidates="explicit")


def test_generation_has_its_own_earlier_deadline() -> None:
    """``generate_by`` bounds the generation alone: past it, the generation's error, however
    far the deadline (orbit-dp's ``auto`` gives the generation 40 % of its limit)."""
    import time

    now = time.perf_counter()
    with pytest.raises(TimeLimitReached, match="time limit reached while generating"):
        orbit_data(random_tiny(6), now + 60.0, generate_by=now - 1.0)
    assert len(orbit_data(random_tiny(6), now + 60.0, generate_by=now + 60.0).orbits) >= 1


def test_arranging_past_the_deadline_is_the_same_one_line_error() -> None:
    """Arranging millions of candidates takes seconds: it reads the clock after each orbit
    (orbit-dp ran 1.6 s past an 8 s limit on 2.4 million candidates before)."""
    import time

    inst = random_tiny(5)
    whole = orbit_data(inst)  # the candidates are generated (and kept) here
    assert len(whole.orbits) >= 1
    with pytest.raises(TimeLimitReached, match="^orbit '.*': time limit reached while arranging"):
        orbit_data(inst, deadline=time.perf_counter() - 1.0)
    later = orbit_data(inst, deadline=time.perf_counter() + 60.0)
    assert [o.orbit for o in later.orbits] == [o.orbit for o in whole.orbits]


def test_arranging_gives_up_at_once_when_the_rest_is_foreseen_past_the_deadline(
    monkeypatch,
    c3,
) -> None:
    """The second orbit would end before the deadline, but all the orbits left would not
    (at the rate of the first): nothing more is started."""
    import sosp.planner as planner

    inst = c3
    whole = orbit_data(inst)
    sizes = [len(o.items) for o in whole.orbits]
    assert len(sizes) > 3 and sum(sizes[2:]) > 2 * sizes[1]
    clock = [0.0]
    covered = planner._covered_targets

    def work(opp_target, members):
        clock[0] += len(members)
        return covered(opp_target, members)

    monkeypatch.setattr(planner, "_covered_targets", work)
    monkeypatch.setattr(planner, "time", types.SimpleNamespace(perf_counter=lambda: clock[0]))
    args = (inst, whole.orbit, whole.start, whole.end, whole.roll, whole.opps)
    with pytest.raises(TimeLimitReached, match="time limit reached while arranging"):
        planner._arrange(*args, deadline=sizes[0] + sizes[1] + 0.5)
    assert clock[0] == sizes[0]


@pytest.mark.parametrize("spare", [-0.5, 0.5])
def test_arranging_does_not_start_an_orbit_foreseen_to_end_past_the_deadline(
    monkeypatch, spare: float
) -> None:
    """One dense orbit takes more than a second to arrange (D30: 1.5 s), so each orbit's
    time is foreseen at the rate of those before it. On a clock that moves one unit per
    candidate arranged, with the deadline half a unit before (after) the two orbits' end,
    the second orbit is not started (is arranged)."""
    import sosp.planner as planner

    inst = tiny_two_orbits()
    whole = orbit_data(inst)
    sizes = [len(o.items) for o in whole.orbits]
    assert len(sizes) == 2
    clock = [0.0]
    covered = planner._covered_targets

    def work(opp_target, members):  # the heavy part of an orbit: the clock moves with it
        clock[0] += len(members)
        return covered(opp_target, members)

    monkeypatch.setattr(planner, "_covered_targets", work)
    monkeypatch.setattr(planner, "time", types.SimpleNamespace(perf_counter=lambda: clock[0]))
    args = (inst, whole.orbit, whole.start, whole.end, whole.roll, whole.opps)
    deadline = sum(sizes) + spare
    if spare < 0:
        with pytest.raises(TimeLimitReached, match="time limit reached while arranging"):
            planner._arrange(*args, deadline=deadline)
        assert clock[0] == sizes[0]  # the second orbit was not started
    else:
        arranged = planner._arrange(*args, deadline=deadline)
        assert [len(o.items) for o in arranged.orbits] == sizes


def test_with_rolls_rebuilds_the_slew_terms_and_checks_the_shape() -> None:
    """Same rolls: the same arrangement; other rolls: |theta| / v and the (3) order follow;
    a wrong number of rolls is refused."""
    inst = tiny_cluster()
    data = orbit_data(inst)
    same = with_rolls(data, data.roll)
    for a, b in zip(data.orbits, same.orbits, strict=True):
        assert np.array_equal(a.slew_s, b.slew_s) and np.array_equal(a.n_before, b.n_before)
    wide = with_rolls(data, np.full(data.n_items, 30.0))
    for o in wide.orbits:
        v = float(inst.slew_rate[o.orbit])
        assert np.allclose(o.slew_s, 30.0 / v)
    with pytest.raises(ValueError, match="roll"):
        with_rolls(data, np.zeros(data.n_items + 1))


def test_candidates_are_computed_once_per_instance_and_read_only() -> None:
    import gc

    from sosp.candidates import _CACHE, cluster_candidates

    inst = tiny_cluster()
    first = cluster_candidates(inst)
    assert cluster_candidates(inst) is first  # the same instance: no second generation
    other = cluster_candidates(tiny_cluster())  # an equal but distinct instance: its own
    assert other is not first and other[4] == first[4]
    with pytest.raises(ValueError, match="read-only"):
        first[3][0] = 1.0
    key = id(inst)
    del inst
    gc.collect()
    assert key not in _CACHE  # the entry leaves with its instance


# ------------------------------------------------------------------ dense orbits: pruning
def _zeroed(rng: np.random.Generator, n: int, share: float) -> np.ndarray:
    """Prices in [0, 10) with about ``share`` of them 0 (targets another orbit covers)."""
    price = rng.uniform(0, 10, n)
    price[rng.random(n) < share] = 0.0
    return price


@pytest.mark.parametrize("seed", range(30))
def test_pruned_recursion_equals_the_full_one_and_the_enumeration(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With pruning on every orbit (PRUNE_FROM = 0) the recursion keeps its optimum: the same
    value as without, the brute-force best over all plans, and a plan worth it."""
    import sosp.planner as odp

    inst = random_tiny(seed)
    data = orbit_data(inst)
    rng = np.random.default_rng(seed)
    for o in data.orbits:
        for share in (0.0, 0.4, 0.8):
            price = _zeroed(rng, inst.n_targets, share)
            lam = (0.0, 0.0) if rng.random() < 0.5 else tuple(rng.uniform(0, 20, 2))
            monkeypatch.setattr(odp, "PRUNE_FROM", 10**9)
            full, _ = best_path(o, price, *lam)
            monkeypatch.setattr(odp, "PRUNE_FROM", 0)
            value, path = best_path(o, price, *lam)
            assert value == pytest.approx(full, abs=1e-9)
            assert _penalised(o, path, price, *lam) == pytest.approx(value, abs=1e-9)
            if o.size <= 12:
                best = max(_penalised(o, p, price, *lam) for p in _plans(data, o))
                assert value == pytest.approx(max(best, 0.0), abs=1e-9)
            assert o.fits(best_feasible_path(o, price))


def test_pruning_drops_what_is_worth_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """Positions with a worthless end opportunity or no gain are not kept; with every price
    positive no position is dropped for its ends."""
    import sosp.planner as odp

    monkeypatch.setattr(odp, "PRUNE_FROM", 0)
    inst = tiny_cluster()
    o = orbit_data(inst).orbits[0]
    price = np.ones(inst.n_targets)
    sub = odp.priced(o, price)
    kept = np.arange(o.size) if sub.keep is None else sub.keep
    assert len(kept) >= 1
    zero = int(o.first_target[kept[0]])
    price[zero] = 0.0
    sub = odp.priced(o, price)
    assert sub.keep is not None
    assert not np.any(o.first_target[sub.keep] == zero)
    assert not np.any(o.last_target[sub.keep] == zero)
    assert np.all(sub.gain > 0)


def test_opp_groups_behave_as_a_tuple_of_tuples() -> None:
    from sosp.candidates import OppGroups, flatten, ragged_positions

    groups = [(1, 2, 3), (4,), (), (5, 6)]
    g = OppGroups.from_groups(groups)
    assert len(g) == 4 and g[0] == (1, 2, 3) and g[-1] == (5, 6) and g[2] == ()
    assert list(g) == groups and g == groups and g == tuple(groups)
    assert g.take(np.array([3, 0])) == [(5, 6), (1, 2, 3)]
    sizes, flat = flatten(g)
    assert sizes.tolist() == [3, 1, 0, 2] and flat.tolist() == [1, 2, 3, 4, 5, 6]
    with pytest.raises(IndexError):
        g[4]
    starts, lens = np.array([5, 0, 9]), np.array([2, 0, 3])
    assert ragged_positions(starts, lens).tolist() == [5, 6, 9, 10, 11]


def test_orbit_candidates_are_the_whole_instance_columns_per_orbit() -> None:
    """Per-orbit candidates are exactly the orbit's slice of cluster_candidates, with the
    window (10) of their members and a roll in every member's range (7)."""
    from sosp.candidates import cluster_candidates, orbit_candidates

    inst = random_tiny(3)
    orbit, start, end, roll, opps = cluster_candidates(inst, max_candidates=None)
    at = 0
    for j in range(inst.n_orbits):
        oc = orbit_candidates(inst, j)
        sl = slice(at, at + oc.size)
        at += oc.size
        assert np.all(orbit[sl] == j)
        assert np.array_equal(oc.start, start[sl]) and np.array_equal(oc.roll, roll[sl])
        assert list(oc.opps) == list(opps[sl])
        for u in range(oc.size):
            m = list(oc.opps[u])
            assert oc.start[u] == inst.opp_start[m].min() and oc.end[u] == inst.opp_end[m].max()
            assert np.all(inst.opp_roll_min[m] <= oc.roll[u] + 1e-9)
            assert np.all(oc.roll[u] <= inst.opp_roll_max[m] + 1e-9)
    assert at == len(opps)


def test_candidates_generated_in_processes_are_the_same() -> None:
    from sosp.candidates import cluster_candidates, generate_in_processes

    serial = cluster_candidates(random_tiny(4), max_candidates=None)
    inst = random_tiny(4)
    generate_in_processes(inst, 2)
    forked = cluster_candidates(inst, max_candidates=None)
    for a, b in zip(serial[:4], forked[:4], strict=True):
        assert np.array_equal(a, b)
    assert serial[4] == forked[4]
    data = orbit_data(random_tiny(4), workers=2)
    assert data.n_items == len(serial[4])


def _dense_orbit(seed: int, n: int = 60) -> Instance:
    """One orbit crowded with opportunities on coarse time and roll grids, so that start and
    end times tie, rolls meet at +-theta and windows nest (the vectorised generator's corner
    cases)."""
    rng = np.random.default_rng(seed)
    start = rng.integers(0, 40, n) * 2.0
    end = start + rng.choice([2.0, 4.0, 6.0], n)
    roll = rng.integers(-6, 7, n) * 1.5
    width = rng.choice([1.5, 3.0, 4.5], n)
    return Instance.from_arrays(
        epoch="2026-06-01T00:00:00Z",
        target_ids=[f"t{k}" for k in range(n)],
        target_lat=np.zeros(n),
        target_lon=np.zeros(n),
        target_weight=rng.integers(1, 10, n),
        orbit_ids=["o"],
        orbit_satellite=["s"],
        orbit_start=[0.0],
        orbit_end=[200.0],
        opp_target=np.arange(n),
        opp_orbit=np.zeros(n, dtype=int),
        opp_start=start,
        opp_end=end,
        opp_roll=roll,
        opp_roll_min=np.maximum(roll - width, -33.0),
        opp_roll_max=np.minimum(roll + width, 33.0),
        resources=Resources(max_duration=float(rng.choice([6.0, 12.0, 30.0]))),
    )


@pytest.mark.parametrize("seed", range(40))
def test_vectorised_generator_equals_the_reference_loop(seed: int) -> None:
    """Same candidates, same order, as the one-end-at-a-time loop (random tiny instances and
    crowded orbits with tied times and mirrored rolls)."""
    from sosp.candidates import _generate_orbit
    from tests.sosp.candidates_reference import generate_orbit_loop

    for inst in (random_tiny(seed), _dense_orbit(seed)):
        for j in range(inst.n_orbits):
            a = generate_orbit_loop(inst, j)
            b = _generate_orbit(inst, j, None, None)
            assert np.array_equal(a.roll, b.roll) and np.array_equal(a.start, b.start)
            assert np.array_equal(a.end, b.end)
            assert np.array_equal(a.opps.ptr, b.opps.ptr)
            assert np.array_equal(a.opps.flat, b.opps.flat)


@pytest.mark.parametrize("seed", range(40))
def test_start_counts_are_the_sizes_of_the_start_candidates(seed: int) -> None:
    """The estimate's counts (:func:`sosp.candidates._start_counts`, no members built) are
    the numbers of candidates and of members that :func:`_start_candidates` builds, start
    by start."""
    from sosp.candidates import _start_candidates, _start_counts, orbit_columns

    for inst in (random_tiny(seed), _dense_orbit(seed)):
        for j in range(inst.n_orbits):
            ts, te, lo, hi, limit, stop = orbit_columns(inst, j)
            for i in range(len(ts)):
                got = _start_candidates(i, ts, te, lo, hi, int(stop[i]), limit)
                want = (0, 0) if got is None else (len(got[1]), len(got[3]))
                assert _start_counts(i, ts, te, lo, hi, int(stop[i]), limit) == want


@pytest.mark.parametrize("seed", range(60))
def test_pruning_keeps_the_optimum_on_crowded_orbits(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sosp.planner as odp

    inst = _dense_orbit(seed, n=40)
    o = orbit_data(inst).orbits[0]
    rng = np.random.default_rng(seed)
    for share in (0.0, 0.3, 0.6, 0.9):
        price = _zeroed(rng, inst.n_targets, share)
        lam = tuple(rng.uniform(0, 30, 2)) if share > 0.5 else (0.0, 0.0)
        monkeypatch.setattr(odp, "PRUNE_FROM", 10**9)
        full, _ = best_path(o, price, *lam)
        monkeypatch.setattr(odp, "PRUNE_FROM", 0)
        value, path = best_path(o, price, *lam)
        assert value == pytest.approx(full, abs=1e-9)
        assert _penalised(o, path, price, *lam) == pytest.approx(value, abs=1e-9)


@pytest.mark.parametrize("seed", [1, 7])
def test_workers_give_the_same_bound_and_plans(seed: int) -> None:
    """The Lagrangian bound and the orbits' plans are the same in two processes as in one."""
    from sosp.planner import PlanPool

    inst = random_tiny(seed)
    one = lagrangian_bound(inst, iterations=40)
    two = lagrangian_bound(inst, iterations=40, workers=2)
    assert two["bound"] == one["bound"] and two["iterations"] == one["iterations"]
    data = orbit_data(inst)
    rng = np.random.default_rng(seed)
    price = rng.uniform(0, 5, inst.n_targets)
    lam = rng.uniform(0, 3, (len(data.orbits), 2))
    with PlanPool(data.orbits, 1) as a, PlanPool(data.orbits, 2) as b:
        for (va, ca, ua), (vb, cb, ub) in zip(
            a.best_paths(price, lam), b.best_paths(price, lam), strict=True
        ):
            assert va == vb and np.array_equal(ca, cb) and ua == ub


def _signal_dispositions() -> tuple[bool, bool]:
    """In a pool worker: SIGTERM at its default, SIGINT ignored."""
    import signal

    return (
        signal.getsignal(signal.SIGTERM) == signal.SIG_DFL,
        signal.getsignal(signal.SIGINT) == signal.SIG_IGN,
    )


def test_pool_workers_end_on_sigterm_under_the_cli_handlers() -> None:
    """``Pool.terminate`` ends each worker with one SIGTERM and waits: a worker that kept
    ``handle_signals``'s handler (a stop request) lived on and ``close`` hung."""
    from sosp.planner import PlanPool
    from sosp.stop import handle_signals

    inst = next(random_tiny(s) for s in range(100) if random_tiny(s).n_orbits >= 2)
    data = orbit_data(inst)
    with handle_signals(), PlanPool(data.orbits, 2) as pool:
        pool.best_paths(np.ones(inst.n_targets), np.zeros((len(data.orbits), 2)))
        assert pool.pool.apply(_signal_dispositions) == (True, True)


def test_orbit_dp_with_workers_finds_the_same_schedule() -> None:
    inst = random_tiny(3)
    one = solve(inst, "orbit-dp", seed=1, iterations=30)
    two = solve(inst, "orbit-dp", seed=1, iterations=30, workers=2)
    assert one.schedule.observations == two.schedule.observations
    assert validate(inst, two.schedule).feasible
    with pytest.raises(InputError, match="workers"):
        OrbitSearchParams(workers=0)


def test_candidates_beyond_the_memory_budget_are_a_one_line_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The planner's candidates are estimated before any is generated; beyond the budget the
    one-line error names the densest orbit (no half-built cache is left behind)."""
    import sosp.candidates as sc

    inst = _dense_orbit(3)
    monkeypatch.setattr(sc, "_SAMPLE_FROM", 0)
    need = sc.estimate_bytes(inst)
    exact = sc._generate_orbit(inst, 0, None, None)
    assert need > 0 and 0.2 * exact.nbytes < need < 5 * exact.nbytes
    monkeypatch.setattr(sc, "MAX_CANDIDATE_BYTES", need // 2)
    for workers in (1, 2):  # in processes too: checked before any process generates
        with pytest.raises(InputError, match=r"^about .* GB of candidate observations") as err:
            orbit_data(inst, workers=workers)
        assert "candidates=auto or windows" in str(err.value)  # names what still works
        assert set(sc._cache_of(inst)) <= {"need"}  # no orbit's candidates
    monkeypatch.setattr(sc, "MAX_CANDIDATE_BYTES", need * 2)
    assert orbit_data(inst).n_items == exact.size


def _stretch_case(seed: int):
    """A random stretch: up to 7 single-opportunity candidates on one orbit, optional fixed
    neighbours, budgets net of the neighbours' observing, an openings cap below c_j.

    Returns the one-orbit instance (candidates first, then the neighbours), its rules and
    the keyword arguments of :func:`plan_sequence`."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))
    start = rng.integers(5, 100, n).astype(float)
    end = start + rng.integers(1, 9, n)
    roll = rng.integers(-30, 31, n).astype(float)
    gain = rng.integers(0, 10, n).astype(float)  # zero gains: never worth a place
    res = Resources(
        energy_capacity=float(rng.choice([40, 90, 1500])),
        memory_capacity=float(rng.choice([10, 25, 1000])),
        max_openings=int(rng.integers(1, 6)),
        setup_time=float(rng.choice([1, 4])),
        slew_rate=float(rng.choice([1, 3])),
        slew_energy_rate=float(rng.choice([0.5, 2])),
    )
    rows = [(u, 0, start[u], end[u], roll[u], roll[u] - 1, roll[u] + 1) for u in range(n)]
    kw: dict = {}
    fixed = 0
    if rng.random() < 0.6:
        s0, r0 = float(rng.integers(0, 10)), float(rng.integers(-30, 31))
        rows.append((n + fixed, 0, s0, s0 + 2, r0, r0 - 1, r0 + 1))
        kw["left"] = (s0 + 2, r0)
        fixed += 1
    if rng.random() < 0.6:
        s1, r1 = float(rng.integers(95, 115)), float(rng.integers(-30, 31))
        rows.append((n + fixed, 0, s1, s1 + 2, r1, r1 - 1, r1 + 1))
        kw["right"] = (s1, r1)
        fixed += 1
    weights = [max(int(g), 1) for g in gain] + [1] * fixed
    inst = Instance.build(weights, rows, resources=res, n_orbits=1)
    r = orbit_rules(inst, 0)
    kw["energy"] = r.energy_capacity - r.observe_energy_rate * 2 * fixed
    kw["memory"] = r.memory_capacity - r.memory_rate * 2 * fixed
    kw["openings"] = r.max_openings - fixed - int(rng.integers(0, 2))
    return inst, r, (start, end, roll, gain), kw


def _sequences(r, cols, kw):
    """Every sequence of the candidates keeping (3) with the neighbours and (6), by
    enumeration, with its (gain, observed seconds, exact slew seconds of (4))."""
    start, end, roll, gain = cols
    n = len(start)
    a, v = r.setup_time, r.slew_rate
    for k in range(0, min(max(kw["openings"], 0), n) + 1):
        for combo in itertools.combinations(range(n), k):
            seq = sorted(combo, key=lambda u: (start[u], end[u]))
            obs = [(kw["left"][0] - 2, kw["left"][0], kw["left"][1])] if "left" in kw else []
            obs += [(start[u], end[u], roll[u]) for u in seq]
            if "right" in kw:
                obs.append((kw["right"][0], kw["right"][0] + 2, kw["right"][1]))
            # (3) written out from docs/model.md, independently of the kernel
            if all(
                w[0] - u[1] >= a + (abs(u[2]) + abs(w[2])) / v - 1e-9
                for u, w in itertools.pairwise(obs)
            ):
                slew = sum((abs(u[2]) + abs(w[2])) / v for u, w in itertools.pairwise(obs))
                observed = float(sum(end[u] - start[u] for u in seq))
                yield seq, float(sum(gain[u] for u in seq)), observed, slew


@pytest.mark.parametrize("seed", range(150))
def test_plan_sequence_against_enumeration_and_validator(seed: int) -> None:
    inst, r, cols, kw = _stretch_case(seed)
    gain, path = plan_sequence(*cols, r, **kw)
    start, end, roll, g = cols
    seqs = list(_sequences(r, cols, kw))

    def fits(observed: float, slew: float) -> bool:
        e = r.observe_energy_rate * observed + r.slew_energy_rate * slew
        return e <= kw["energy"] + 1e-9 and r.memory_rate * observed <= kw["memory"] + 1e-9

    # the plan is one of the enumerated sequences, within the budgets, worth its gain
    found = [x for x in seqs if list(x[0]) == list(path)]
    assert len(found) == 1 or (len(path) == 0 and gain == 0.0)
    if len(path):
        _, value, observed, slew = found[0]
        assert fits(observed, slew) and gain == pytest.approx(value)
        # the kernel agrees on (3) between consecutive observations
        assert not any(
            r.clash(end[u], roll[u], start[w], roll[w]) for u, w in itertools.pairwise(path)
        )
    optimum = max([x[1] for x in seqs if fits(x[2], x[3])], default=0.0)
    assert gain <= optimum + 1e-9
    unconstrained = max(seqs, key=lambda x: x[1], default=None)
    if unconstrained is not None and fits(unconstrained[2], unconstrained[3]):
        assert gain == pytest.approx(unconstrained[1])  # exact when (4)-(5) do not bind
    # with neighbours the validator accepts on their own, the validator accepts the orbit
    # with the plan between them
    n = len(start)

    def schedule(opps: list[int]) -> Schedule:
        return Schedule(
            tuple(
                Observation(
                    0,
                    float(inst.opp_start[x]),
                    float(inst.opp_end[x]),
                    float(inst.opp_roll[x]),
                    (int(x),),
                )
                for x in opps
            )
        )

    opp = [int(inst.target_opps[k][0]) for k in range(inst.n_targets)]  # target k: row k
    fixed = opp[n:]
    if validate(inst, schedule(fixed)).feasible:
        rep = validate(inst, schedule(fixed + [opp[u] for u in path]))
        assert rep.feasible, rep.violations
    else:
        assert len(path) == 0 or kw["openings"] < len(path) + 1


@pytest.mark.parametrize("seed", range(60))
def test_stretch_recursion_is_exact_under_penalties(seed: int) -> None:
    """The recursion with fixed neighbours maximises the penalised value (gain minus
    ``pe`` per unit of (4), its slew term over the consecutive pairs with the neighbours, and
    ``pw`` per unit of (5)) over the enumerated sequences, the empty one included."""
    inst, r, cols, kw = _stretch_case(seed)
    start, end, roll, gain = cols
    rng = np.random.default_rng(seed + 1000)
    pe, pw = float(rng.uniform(0, 0.5)), float(rng.uniform(0, 0.5))
    lo_end, hi_end = r.left(start, roll), r.right(end, roll)
    ok = np.ones(len(start), dtype=bool)
    if "left" in kw:
        ok &= r.right(*kw["left"]) <= lo_end + 1e-9
    if "right" in kw:
        ok &= hi_end <= r.left(*kw["right"]) + 1e-9
    idx = np.flatnonzero(ok)
    by_release = np.argsort(hi_end[idx], kind="stable")
    n_before = np.searchsorted(hi_end[idx][by_release], lo_end[idx] + 1e-9, side="right")
    value, path = recursion(
        r.slew(roll[idx]),
        (end - start)[idx],
        gain[idx],
        by_release,
        n_before,
        r,
        pe,
        pw,
        openings=kw["openings"],
        left_slew=r.slew(kw["left"][1]) if "left" in kw else None,
        right_slew=r.slew(kw["right"][1]) if "right" in kw else None,
    )

    def penalised(x) -> float:
        _, g, observed, slew = x
        energy = r.observe_energy_rate * observed + r.slew_energy_rate * slew
        return g - pe * energy - pw * r.memory_rate * observed

    seqs = {tuple(x[0]): penalised(x) for x in _sequences(r, cols, kw)}
    assert value == pytest.approx(max(seqs.values()), abs=1e-9)
    assert seqs[tuple(idx[path])] == pytest.approx(value, abs=1e-9)


def test_plan_sequence_without_neighbours_is_best_path() -> None:
    """Without neighbours and with slack budgets, the stretch planner is the orbit planner:
    the same optimum of the same recursion."""
    for seed in range(10):
        inst = random_tiny(seed)
        data = orbit_data(inst)
        rng = np.random.default_rng(seed)
        for o in data.orbits:
            price = rng.uniform(0, 10, inst.n_targets)
            value, path = best_path(o, price)
            if not o.fits(path):
                continue
            gain, seq = plan_sequence(
                data.start[o.items], data.end[o.items], o.roll, o.gains(price), o.rules
            )
            assert gain == pytest.approx(value)
            assert o.fits(seq)


def test_plan_sequence_fixed_neighbours_by_hand() -> None:
    """Setup 10 s, slew 1 deg/s; A [30, 32] roll 5 (gain 4), B [20, 22] roll 0 (9), C [60, 62]
    roll 0 (1). Alone: B then A clashes (22 + 10 + 5 > 30), B then C fits: 10. After a
    neighbour ending at 8 with roll 5 (R = 8 + 10 + 5 = 23) B cannot start (L = 20 < 23) but
    A can (L = 25): A then C, 5. Before a neighbour starting at 75 with roll 10 (L = 65) C
    cannot end (R = 72): A alone, 4, which observes 2 s and slews 5 + 5 + 5 + 10 = 25 s:
    energy 27 (eo = es = 1)."""
    r = orbit_rules(Instance.build([1], [(0, 0, 0.0, 1.0, 0.0)]), 0)
    cols = (
        np.array([30.0, 20.0, 60.0]),
        np.array([32.0, 22.0, 62.0]),
        np.array([5.0, 0.0, 0.0]),
        np.array([4.0, 9.0, 1.0]),
    )
    left, right = (8.0, 5.0), (75.0, 10.0)

    def plan(**kw) -> tuple[float, list[int]]:
        g, path = plan_sequence(*cols, r, **kw)
        return g, path.tolist()

    assert plan() == (10.0, [1, 2])
    assert plan(left=left) == (5.0, [0, 2])
    assert plan(left=left, openings=1) == (4.0, [0])
    assert plan(left=left, right=right) == (4.0, [0])
    assert plan(left=left, right=right, energy=27.0) == (4.0, [0])
    assert plan(left=left, right=right, energy=26.9) == (0.0, [])
    assert plan(left=left, right=right, memory=1.9) == (0.0, [])
    assert plan(right=right) == (9.0, [1])
