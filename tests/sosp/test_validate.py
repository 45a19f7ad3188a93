"""The validator: for each of (2)-(7) and (11), a schedule that just meets the constraint is
accepted and one that breaks it is caught with the right constraint named and the right amount.
Plus property tests against an independent all-pairs check."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from heuristics.timeline import OrbitTimeline
from sosp.instance import Instance, Resources
from sosp.schedule import Observation, Schedule, make_observation
from sosp.validate import validate
from tests.conftest import tiny_chain, tiny_cluster, tiny_openings, tiny_two_orbits


def obs(inst: Instance, *opps: int, roll: float | None = None, start=None, end=None):
    o = make_observation(inst, opps)
    return Observation(
        o.orbit,
        o.start if start is None else start,
        o.end if end is None else end,
        o.roll if roll is None else roll,
        o.opps,
    )


def only(report, constraint: str):
    assert not report.feasible
    kinds = {v.constraint for v in report.violations}
    assert kinds == {constraint}, report.violations
    return report.violations


def test_empty_schedule_is_feasible(tiny: Instance) -> None:
    rep = validate(tiny, Schedule())
    assert rep.feasible and rep.profit == 0 and rep.observed == 0 and rep.energy == 0


# (2) each target at most once -------------------------------------------------------------
def test_2_target_once_accepted_and_caught() -> None:
    inst = tiny_two_orbits()  # a on orbit 0 (opp 0) and orbit 1 (opp 2)
    a0, a1 = (int(i) for i in inst.target_opps[inst.target_index["a"]])
    assert validate(inst, Schedule((obs(inst, a1),))).feasible
    v = only(validate(inst, Schedule((obs(inst, a0), obs(inst, a1)))), "2")
    assert v[0].target == "a"
    assert validate(inst, Schedule((obs(inst, a0), obs(inst, a1)))).profit == 6


# (3) setup and slew time ------------------------------------------------------------------
def test_3_gap_exactly_met_is_accepted() -> None:
    inst = tiny_chain()  # b [10,14] roll 1, c [30,34] roll -5: gap 16 = 10 + (1 + 5)/1
    b, c = inst.target_opps[1][0], inst.target_opps[2][0]
    rep = validate(inst, Schedule((obs(inst, b), obs(inst, c))))
    assert rep.feasible and rep.profit == 7


def test_3_short_gap_is_caught_with_amount() -> None:
    inst = tiny_chain()  # a [0,4] roll 10, b [10,14] roll 1: gap 6 < 10 + 11
    a, b = inst.target_opps[0][0], inst.target_opps[1][0]
    v = only(validate(inst, Schedule((obs(inst, a), obs(inst, b)))), "3")
    assert v[0].amount == pytest.approx(15.0)
    assert v[0].orbit == "orbit0"


def test_3_checks_consecutive_by_start_time_whatever_the_listing_order() -> None:
    inst = tiny_chain()
    b, c = inst.target_opps[1][0], inst.target_opps[2][0]
    sched = Schedule.__new__(Schedule)  # bypass sorting to feed observations out of order
    object.__setattr__(sched, "observations", (obs(inst, c), obs(inst, b)))
    for k in ("method", "params", "seed", "profit", "fingerprint"):
        object.__setattr__(sched, k, getattr(Schedule(), k))
    assert validate(inst, sched).feasible


# (4) energy, binding through the slew term only ---------------------------------------------
def energy_instance(capacity: float) -> Instance:
    # Observe 4 + 4 s, slew (10 + 10)/1 = 20 s between them: energy 28, memory 8.
    return Instance.build(
        {"a": 3, "b": 4},
        [("a", 0, 0, 4, 10.0), ("b", 0, 40, 44, -10.0)],
        resources=Resources(energy_capacity=capacity),
    )


def test_4_energy_exactly_met_is_accepted() -> None:
    inst = energy_instance(28.0)
    rep = validate(inst, Schedule((obs(inst, 0), obs(inst, 1))))
    assert rep.feasible
    assert rep.energy == pytest.approx(28.0)
    assert rep.orbits[0].slew_time == pytest.approx(20.0)


def test_4_energy_over_by_slew_is_caught() -> None:
    inst = energy_instance(27.5)
    v = only(validate(inst, Schedule((obs(inst, 0), obs(inst, 1)))), "4")
    assert v[0].amount == pytest.approx(0.5)
    # Either observation alone has no slew term and fits.
    assert validate(inst, Schedule((obs(inst, 1),))).feasible


# (5) memory ---------------------------------------------------------------------------------
@pytest.mark.parametrize(("capacity", "ok"), [(8.0, True), (7.5, False)])
def test_5_memory(capacity: float, ok: bool) -> None:
    inst = Instance.build(
        {"a": 3, "b": 4},
        [("a", 0, 0, 4, 0.0), ("b", 0, 40, 44, 0.0)],
        resources=Resources(memory_capacity=capacity),
    )
    rep = validate(inst, Schedule((obs(inst, 0), obs(inst, 1))))
    if ok:
        assert rep.feasible and rep.memory == pytest.approx(8.0)
    else:
        assert only(rep, "5")[0].amount == pytest.approx(0.5)


# (6) openings -------------------------------------------------------------------------------
def test_6_openings() -> None:
    inst = tiny_openings()  # c = 2
    assert validate(inst, Schedule((obs(inst, 2), obs(inst, 3)))).feasible
    v = only(validate(inst, Schedule((obs(inst, 1), obs(inst, 2), obs(inst, 3)))), "6")
    assert v[0].amount == 1


# (7) common roll ----------------------------------------------------------------------------
def test_7_roll_at_range_end_is_accepted_and_beyond_is_caught() -> None:
    inst = tiny_cluster()  # a range [8, 14], b range [6, 12]: common [8, 12]
    assert validate(inst, Schedule((obs(inst, 0, 1, roll=12.0),))).feasible
    assert validate(inst, Schedule((obs(inst, 0, 1, roll=8.0),))).feasible
    v = only(validate(inst, Schedule((obs(inst, 0, 1, roll=12.5),))), "7")
    assert v[0].amount == pytest.approx(0.5) and v[0].target == "b"


def test_cluster_beats_separate_observations() -> None:
    inst = tiny_cluster()
    assert not validate(inst, Schedule((obs(inst, 0), obs(inst, 1)))).feasible  # (3)
    rep = validate(inst, Schedule((obs(inst, 0, 1), obs(inst, 2))))
    assert rep.feasible and rep.profit == 11 and rep.observed == 3


# (11) longest observation -------------------------------------------------------------------
@pytest.mark.parametrize(("last_end", "ok"), [(120.0, True), (120.5, False)])
def test_11_max_duration(last_end: float, ok: bool) -> None:
    inst = Instance.build({"a": 1, "b": 1}, [("a", 0, 0, 4, 5.0), ("b", 0, 116, last_end, 5.0)])
    rep = validate(inst, Schedule((obs(inst, 0, 1),)))
    if ok:
        assert rep.feasible
    else:
        assert only(rep, "11")[0].amount == pytest.approx(0.5)


# structure and claims ------------------------------------------------------------------------
def test_window_must_contain_components() -> None:
    inst = tiny_chain()
    rep = validate(inst, Schedule((obs(inst, 0, start=1.0),)))
    assert {v.constraint for v in rep.violations} == {"structure"}


def test_opportunity_on_another_orbit_is_caught() -> None:
    inst = tiny_two_orbits()
    a1 = int(inst.target_opps[0][1])
    bad = Observation(0, inst.opp_start[a1], inst.opp_end[a1], 0.0, (a1,))
    rep = validate(inst, Schedule((bad,)))
    assert any("not on orbit" in v.message for v in rep.violations)


def test_claimed_profit_is_checked() -> None:
    inst = tiny_chain()
    assert validate(inst, Schedule((obs(inst, 0),), profit=5)).feasible
    assert only(validate(inst, Schedule((obs(inst, 0),), profit=6)), "profit")


def test_reports_every_violation() -> None:
    inst = tiny_openings()  # c = 2; also shrink memory
    sched = Schedule(tuple(obs(inst, i) for i in range(4)))
    rep = validate(inst, sched)
    assert [v.constraint for v in rep.violations] == ["6"]
    assert rep.profit == 10 and rep.observed == 4


# properties ----------------------------------------------------------------------------------
@st.composite
def instances(draw) -> Instance:
    n = draw(st.integers(1, 9))
    m = draw(st.integers(1, 3))
    rows = []
    for _ in range(n):
        s = draw(st.floats(0, 400, allow_nan=False))
        d = draw(st.floats(0.5, 10))
        r = draw(st.floats(-33, 33))
        rows.append((draw(st.integers(0, 4)), draw(st.integers(0, m - 1)), s, s + d, r))
    res = Resources(
        energy_capacity=draw(st.sampled_from([20.0, 60.0, 1500.0])),
        memory_capacity=draw(st.sampled_from([6.0, 20.0, 1000.0])),
        max_openings=draw(st.integers(1, 4)),
        setup_time=draw(st.sampled_from([0.0, 10.0])),
    )
    weights = draw(st.lists(st.integers(0, 10), min_size=5, max_size=5))
    return Instance.build(weights, rows, resources=res, n_orbits=m)


def independent_feasible(inst: Instance, sched: Schedule) -> bool:
    """A second, all-pairs statement of (2)-(7), (11) (no consecutive-pair shortcut)."""
    targets = [int(inst.opp_target[i]) for o in sched.observations for i in o.opps]
    if len(targets) != len(set(targets)):
        return False
    for j in range(inst.n_orbits):
        mine = [o for o in sched.observations if o.orbit == j]
        r = inst.resources(j)
        if len(mine) > r.max_openings:
            return False
        for p, q in itertools.combinations(mine, 2):
            u, w = (p, q) if (p.start, p.end) <= (q.start, q.end) else (q, p)
            if w.start - u.end < r.setup_time + (abs(u.roll) + abs(w.roll)) / r.slew_rate - 1e-6:
                return False
        dur = sum(o.end - o.start for o in mine)
        order = sorted(mine, key=lambda o: o.start)
        slew = sum((abs(p.roll) + abs(q.roll)) / r.slew_rate for p, q in itertools.pairwise(order))
        if r.observe_energy_rate * dur + r.slew_energy_rate * slew > r.energy_capacity + 1e-6:
            return False
        if r.memory_rate * dur > r.memory_capacity + 1e-6:
            return False
        for o in mine:
            if o.end - o.start > r.max_duration + 1e-6:
                return False
            for i in o.opps:
                if not inst.opp_roll_min[i] - 1e-6 <= o.roll <= inst.opp_roll_max[i] + 1e-6:
                    return False
    return True


@settings(max_examples=150, deadline=None)
@given(inst=instances(), seed=st.integers(0, 2**32 - 1))
def test_constructive_schedules_always_pass(inst: Instance, seed: int) -> None:
    """Random insertion of single opportunities and random pairs as clusters: all valid."""
    rng = np.random.default_rng(seed)
    lines = [OrbitTimeline.of(inst, j) for j in range(inst.n_orbits)]
    used: set[int] = set()
    profit = 0
    for i in rng.permutation(inst.n_opps):
        k = int(inst.opp_target[i])
        if k in used:
            continue
        group = [int(i)]
        j = int(inst.opp_orbit[i])
        mates = [
            h
            for h in range(inst.orbit_opps(j).start, inst.orbit_opps(j).stop)
            if h != i and int(inst.opp_target[h]) not in used | {k}
        ]
        if mates and rng.random() < 0.5:
            group.append(int(rng.choice(mates)))
        try:
            o = make_observation(inst, group, rule=rng.choice(["midpoint", "nadir"]))
        except ValueError:
            continue
        chk = lines[j].check_insert((o.start, o.end, o.roll, o))
        if chk:
            lines[j].insert((o.start, o.end, o.roll, o), chk)
            ks = {int(inst.opp_target[h]) for h in o.opps}
            used |= ks
            profit += int(inst.target_weight[list(ks)].sum())
    sched = Schedule(tuple(e[3] for line in lines for e in line.obs))
    rep = validate(inst, sched)
    assert rep.feasible, rep.violations
    assert rep.profit == profit
    assert independent_feasible(inst, sched)


@settings(max_examples=200, deadline=None)
@given(
    inst=instances(),
    picks=st.lists(st.integers(0, 50), max_size=6),
    rolls=st.lists(st.floats(-35, 35), min_size=6, max_size=6),
)
def test_verdict_agrees_with_all_pairs_check(
    inst: Instance, picks: list[int], rolls: list[float]
) -> None:
    """On arbitrary (mostly infeasible) schedules the verdict matches the all-pairs check."""
    chosen = sorted({p % inst.n_opps for p in picks})
    observations = []
    for n, i in enumerate(chosen):
        o = make_observation(inst, [i])
        observations.append(Observation(o.orbit, o.start, o.end, rolls[n], o.opps))
    sched = Schedule(tuple(observations))
    assert validate(inst, sched).feasible == independent_feasible(inst, sched)
