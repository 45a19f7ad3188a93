"""The one incremental orbit timeline: its deltas against a recount, its checks against the rules
evaluated from scratch on the whole sequence (kernel :mod:`sosp.rules`)."""

from __future__ import annotations

import numpy as np
import pytest

from heuristics.timeline import InsertCheck, OrbitTimeline, fits_alone
from sosp.clustering import static_cluster_tasks
from sosp.instance import Instance
from sosp.rules import OrbitRules, orbit_rules, sequence_slew_time
from tests.models.instances import duration_binding, memory_binding, random_tiny

RULES = OrbitRules(
    memory_capacity=50.0,
    memory_rate=1.0,
    energy_capacity=80.0,
    observe_energy_rate=1.0,
    slew_energy_rate=1.0,
    slew_rate=2.0,
    setup_time=3.0,
    max_openings=3,
    max_duration=25.0,
)


def recount(r: OrbitRules, obs: list[tuple]) -> tuple[float, float]:
    """Observed and slew seconds of a sequence, from scratch."""
    observe = float(sum(e[1] - e[0] for e in obs))
    return observe, sequence_slew_time(np.array([e[2] for e in obs]), r.slew_rate)


def refused(r: OrbitRules, obs: list[tuple]) -> str:
    """The first rule a time-ordered sequence breaks, in the timeline's order (11), (6), (3),
    (5), (4); "" when it keeps them all."""
    if any(not r.duration_ok(e[0], e[1]) for e in obs):
        return "11"
    if len(obs) > r.max_openings:
        return "6"
    if any(r.clash(u[1], u[2], w[0], w[2]) for u, w in zip(obs, obs[1:], strict=False)):
        return "3"
    observe, slew = recount(r, obs)
    if not r.memory_ok(observe):
        return "5"
    if not r.energy_ok(observe, slew):
        return "4"
    return ""


def ordered(obs: list[tuple]) -> bool:
    keys = [(e[0], e[1]) for e in obs]
    return keys == sorted(keys)


def random_entry(rng: np.random.Generator, tag: int, longest: float) -> tuple:
    start = float(rng.uniform(0.0, 400.0))
    return (start, start + float(rng.uniform(1.0, longest)), float(rng.uniform(-30.0, 30.0)), tag)


def assert_totals(line: OrbitTimeline) -> None:
    observe, slew = recount(line.rules, line.obs)
    assert line.observe == pytest.approx(observe, abs=1e-9)
    assert line.slew == pytest.approx(slew, abs=1e-9)
    assert ordered(line.obs)


@pytest.mark.parametrize("seed", range(5))
def test_random_moves_match_a_recount_and_the_rules_from_scratch(seed: int) -> None:
    """Checked and unchecked inserts, removals and replacements: the totals always equal a
    recount, a check says what the rules say of the whole new sequence (reason included)."""
    rng = np.random.default_rng(seed)
    line = OrbitTimeline(RULES)
    reasons = set()
    for step in range(600):
        feasible = refused(RULES, line.obs) == ""
        assert line.feasible() == feasible
        op = rng.random()
        # checked inserts may break (11) (Delta T = 25 s); the unchecked moves never do
        entry = random_entry(rng, step, 30.0 if op < 0.5 else 25.0)
        if op < 0.5:
            chk = line.check_insert(entry)
            want = sorted([*line.obs, entry], key=lambda e: (e[0], e[1]))
            if feasible:
                reason = refused(RULES, want)
                assert bool(chk) is (reason == "") and chk.reason == reason
                reasons.add(reason)
            if chk:
                assert want[chk.pos] is entry
                assert line.insert(entry, chk) == chk.pos
                assert line.obs == want
        elif op < 0.6 or not line.obs:
            line.insert(entry)  # unchecked: the orbit may break the rules
        elif op < 0.8:
            pos = int(rng.integers(len(line.obs)))
            gone = line.obs[pos]
            assert line.remove(pos) is gone
        else:
            pos = int(rng.integers(len(line.obs)))
            if rng.random() < 0.5:  # a nearby window: often keeps the order
                old = line.obs[pos]
                shift = float(rng.uniform(-5.0, 5.0))
                entry = (old[0] + shift, old[1] + shift, entry[2], step)
            want = list(line.obs)
            want[pos] = entry
            if feasible:
                ok = line.check_replace(pos, entry)
                assert ok == (ordered(want) and refused(RULES, want) == "")
            line.replace(pos, entry)
            assert sorted(line.obs, key=lambda e: (e[0], e[1])) == line.obs
            assert sorted(line.obs) == sorted(want)
        assert_totals(line)
        if len(line.obs) > 8:  # keep the orbit short enough to be feasible again
            while line.obs:
                line.remove(int(rng.integers(len(line.obs))))
            assert line.observe == 0.0 and line.slew == 0.0
    assert reasons >= {"", "3", "4", "5", "6", "11"}


def test_each_rule_refuses_by_hand() -> None:
    """One case per rule, numbers by hand: a = 3 s setup, v = 2 deg/s, c = 2, Delta T = 25 s."""
    r = OrbitRules(
        memory_capacity=40.0,
        memory_rate=1.0,
        energy_capacity=60.0,
        observe_energy_rate=1.0,
        slew_energy_rate=1.0,
        slew_rate=2.0,
        setup_time=3.0,
        max_openings=2,
        max_duration=25.0,
    )
    line = OrbitTimeline(r)
    assert line.check_insert((0.0, 26.0, 0.0)).reason == "11"  # 26 s > Delta T
    chk = line.check_insert((100.0, 110.0, 10.0, "a"))
    assert chk and chk == InsertCheck(True, 0, 0.0, "")
    line.insert((100.0, 110.0, 10.0, "a"), chk)
    # (3): 110 + 3 + (10 + 10) / 2 = 123 > 120
    assert line.check_insert((120.0, 121.0, 10.0)).reason == "3"
    assert line.check_insert((80.0, 90.0, 10.0)).reason == "3"  # 90 + 3 + 10 > 100
    # 10 + 25 = 35 s <= 40 of memory, energy 35 + (10 + 0) / 2 = 40 <= 60
    assert line.check_insert((200.0, 225.0, 0.0)).reason == ""
    assert line.check_insert((200.0, 231.0, 0.0)).reason == "11"
    long_line = OrbitTimeline(r)
    long_line.insert((0.0, 20.0, 0.0))
    assert long_line.check_insert((100.0, 121.0, 0.0)).reason == "5"  # 20 + 21 > 40
    # roll 30: slew (10 + 30) / 2 = 20, energy 35 + 20 = 55 <= 60; then c = 2 is reached
    chk = line.check_insert((200.0, 225.0, 30.0, "b"))
    assert chk and chk.d_slew == pytest.approx(20.0)
    line.insert((200.0, 225.0, 30.0, "b"), chk)
    assert line.energy == pytest.approx(35.0 + 20.0) and line.memory == pytest.approx(35.0)
    assert line.check_insert((300.0, 301.0, 0.0)).reason == "6"
    roomy = OrbitTimeline(
        OrbitRules(
            memory_capacity=100.0,
            memory_rate=1.0,
            energy_capacity=60.0,
            observe_energy_rate=1.0,
            slew_energy_rate=1.0,
            slew_rate=2.0,
            setup_time=3.0,
            max_openings=5,
            max_duration=25.0,
        )
    )
    roomy.insert((100.0, 110.0, 10.0))
    roomy.insert((200.0, 225.0, 30.0))
    # memory 35 + 2 = 37 <= 100; energy 37 + (10 + 30 + 30 + 10) / 2 = 77 > 60
    assert roomy.check_insert((300.0, 302.0, 10.0)).reason == "4"
    assert not roomy.check_insert((300.0, 302.0, 10.0))
    with pytest.raises(ValueError, match="rule 4"):
        roomy.insert((300.0, 302.0, 10.0), roomy.check_insert((300.0, 302.0, 10.0)))


def test_conflicts_overruns_snapshot_and_ties() -> None:
    """Unchecked inserts can break (3), (6): first_conflict, over and feasible say which;
    restore undoes them; an entry goes after the entries of the same window."""
    line = OrbitTimeline(RULES)
    line.insert((10.0, 20.0, 0.0, "a"))
    snap = line.snapshot()
    line.insert((10.0, 20.0, 0.0, "b"))  # same window: after "a", and (3) breaks
    assert [e[3] for e in line.obs] == ["a", "b"]
    assert line.first_conflict() == 0 and not line.feasible()
    for k in range(6):
        line.insert((100.0 + 50 * k, 101.0 + 50 * k, 0.0, k))
    assert line.over() == (False, False, True)  # 8 openings > 3
    line.restore(snap)
    assert line.obs == [(10.0, 20.0, 0.0, "a")] and line.feasible()
    assert line.observe == 10.0 and line.slew == 0.0


def test_replace_reorders_and_load_recounts() -> None:
    line = OrbitTimeline(RULES)
    for e in [(0.0, 5.0, 10.0, "a"), (50.0, 55.0, -10.0, "b"), (100.0, 105.0, 20.0, "c")]:
        line.insert(e)
    line.replace(0, (200.0, 210.0, 0.0, "a2"))  # moves to the end
    assert [e[3] for e in line.obs] == ["b", "c", "a2"]
    assert_totals(line)
    line.replace(1, None)
    assert [e[3] for e in line.obs] == ["b", "a2"]
    assert_totals(line)
    other = OrbitTimeline(RULES)
    other.load(line.obs)
    assert other.obs == line.obs and other.obs is not line.obs
    assert (other.observe, other.slew) == pytest.approx((line.observe, line.slew))


@pytest.mark.parametrize(
    "inst", [random_tiny(0), random_tiny(1), duration_binding(), memory_binding()]
)
def test_fits_alone_is_the_check_on_an_empty_orbit(inst: Instance) -> None:
    tasks = static_cluster_tasks(inst)
    alone = fits_alone(inst, tasks)
    for t in range(len(tasks)):
        j = int(tasks.orbit[t])
        line = OrbitTimeline.of(inst, j)
        assert line.rules == orbit_rules(inst, j)
        chk = line.check_insert((float(tasks.start[t]), float(tasks.end[t]), float(tasks.roll[t])))
        assert alone[t] == chk.ok


def test_checked_insert_goes_after_the_same_window() -> None:
    """With no setup time and nadir rolls, instants at one time keep (3): a checked insertion
    goes after the entries of the same (start, end), as an unchecked one does."""
    r = OrbitRules(
        memory_capacity=10.0,
        memory_rate=1.0,
        energy_capacity=10.0,
        observe_energy_rate=1.0,
        slew_energy_rate=1.0,
        slew_rate=1.0,
        setup_time=0.0,
        max_openings=5,
        max_duration=1.0,
    )
    line = OrbitTimeline(r)
    for tag in "abc":
        chk = line.check_insert((5.0, 5.0, 0.0, tag))
        assert chk and chk.pos == len(line.obs)
        line.insert((5.0, 5.0, 0.0, tag), chk)
    chk = line.check_insert((4.0, 5.0, 0.0, "d"))  # ends at 5 too, starts earlier: first
    assert chk and chk.pos == 0
    assert [e[3] for e in line.obs] == ["a", "b", "c"]
