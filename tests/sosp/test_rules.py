"""The rule kernel (:mod:`sosp.rules`) against the validator, which is written independently.

Inputs are integers and halves (slew rates 0.5, 1, 2), so every slack is either exactly zero or
at least 0.25: the kernel's margin (1e-9) and the validator's tolerance (1e-6) then agree on
every boundary, and any disagreement is a real difference between the two codings.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sosp import rules
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.schedule import Observation, Schedule, make_observation
from sosp.validate import validate


@st.composite
def one_orbit(draw: st.DrawFn) -> tuple[Instance, list[int]]:
    """An orbit with up to 7 opportunities of distinct targets, and a subset to observe."""
    n = draw(st.integers(1, 7))
    res = Resources(
        memory_capacity=float(draw(st.integers(0, 60))),
        memory_rate=float(draw(st.integers(0, 3))),
        energy_capacity=float(draw(st.integers(0, 120))),
        observe_energy_rate=float(draw(st.integers(0, 3))),
        slew_energy_rate=float(draw(st.integers(0, 3))),
        slew_rate=draw(st.sampled_from([0.5, 1.0, 2.0])),
        setup_time=float(draw(st.integers(0, 6))),
        max_openings=draw(st.integers(0, 5)),
        max_duration=float(draw(st.integers(1, 12))),
    )
    rows = []
    for k in range(n):
        start = draw(st.integers(0, 120))
        length = draw(st.integers(1, 15))
        roll = float(draw(st.integers(-30, 30)))
        rows.append((k, 0, float(start), float(start + length), roll))
    inst = Instance.build([1] * n, rows, resources=res, n_orbits=1, orbit_length=200.0)
    chosen = draw(st.lists(st.integers(0, n - 1), unique=True, min_size=1, max_size=n))
    return inst, chosen


def kernel_violations(inst: Instance, opps: list[int]) -> set[str]:
    """The rules broken by observing ``opps`` alone each, by the kernel."""
    r = rules.orbit_rules(inst, 0)
    order = sorted(opps, key=lambda i: (inst.opp_start[i], inst.opp_end[i]))
    start = inst.opp_start[order]
    end = inst.opp_end[order]
    roll = inst.opp_roll[order]
    out = set()
    if any(not r.duration_ok(s, e) for s, e in zip(start, end, strict=True)):
        out.add("11")
    if any(r.clash(end[i], roll[i], start[i + 1], roll[i + 1]) for i in range(len(order) - 1)):
        out.add("3")
    energy, memory = r.usage(end - start, roll)
    if energy > r.energy_capacity + rules.EPS:
        out.add("4")
    if memory > r.memory_capacity + rules.EPS:
        out.add("5")
    if len(order) > r.max_openings:
        out.add("6")
    return out


@settings(max_examples=300, deadline=None)
@given(one_orbit())
def test_kernel_and_validator_agree_on_random_sequences(case: tuple[Instance, list[int]]) -> None:
    inst, chosen = case
    obs = [
        Observation(
            0, float(inst.opp_start[i]), float(inst.opp_end[i]), float(inst.opp_roll[i]), (i,)
        )
        for i in chosen
    ]
    report = validate(inst, Schedule(tuple(obs)))
    found = {v.constraint for v in report.violations} & {"3", "4", "5", "6", "11"}
    assert found == kernel_violations(inst, chosen)


@settings(max_examples=200, deadline=None)
@given(one_orbit())
def test_cluster_rules_agree_with_the_validator(case: tuple[Instance, list[int]]) -> None:
    """The kernel's common roll range (8) and window (10): non-empty and no longer than
    Delta T iff one observation covering the opportunities passes (7), (11)."""
    inst, chosen = case
    idx = np.array(sorted(chosen))
    lo, hi = rules.common_roll_range(inst.opp_roll_min[idx], inst.opp_roll_max[idx])
    s, e = rules.cluster_window(inst.opp_start[idx], inst.opp_end[idx])
    ok = lo <= hi + rules.EPS and e - s <= float(inst.max_duration[0]) + rules.EPS
    try:
        ob = make_observation(inst, idx.tolist(), "nadir")
    except ValueError:
        assert not ok  # no common roll (7)
        return
    report = validate(inst, Schedule((ob,)))
    broken = {v.constraint for v in report.violations} & {"7", "11"}
    assert ok == (not broken)


def test_turn_and_interval_ends_by_hand() -> None:
    # a = 10 s, v = 1 deg/s; u = [0, 4] at 10 deg, w starts at 30 at -5 deg
    r = rules.OrbitRules(1000.0, 1.0, 1500.0, 1.0, 1.0, 1.0, 10.0, 10, 120.0)
    assert r.turn(10.0, -5.0) == 15.0
    assert r.right(4.0, 10.0) == 24.0 and r.left(30.0, -5.0) == 25.0
    assert not r.clash(4.0, 10.0, 30.0, -5.0)  # gap 26 >= 10 + 15
    assert r.clash(4.0, 10.0, 28.0, -5.0)  # gap 24 < 25
    assert rules.may_precede(r.right(4.0, 10.0), r.left(30.0, -5.0))
    # exact slew of (4) over three observations: (10+5) + (5+20) = 40 = 2*35 - 10 - 20
    assert rules.sequence_slew_time(np.array([10.0, -5.0, 20.0]), 1.0) == 40.0
    assert rules.slew_upper(35.0, 1.0) == 70.0 >= 40.0


def test_slew_upper_is_at_least_the_exact_slew() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        rolls = rng.uniform(-33, 33, size=int(rng.integers(1, 8)))
        exact = rules.sequence_slew_time(rolls, 1.5)
        assert exact <= rules.slew_upper(np.abs(rolls).sum(), 1.5) + 1e-9


def test_roll_rules() -> None:
    assert rules.choose_roll(-4.0, 6.0, "midpoint") == 1.0
    assert rules.choose_roll(-4.0, 6.0, "nadir") == 0.0
    assert rules.choose_roll(2.0, 6.0, "nadir") == 2.0
    assert rules.choose_roll(-6.0, -2.0, "nadir") == -2.0
    with pytest.raises(InputError, match="roll rule"):
        rules.choose_roll(0.0, 1.0, "widest")  # type: ignore[arg-type]


def test_orbit_rules_take_the_instance_columns() -> None:
    inst = Instance.build([1], [(0, 0, 0.0, 4.0, 3.0)], resources=Resources(setup_time=7.0))
    r = rules.orbit_rules(inst, 0)
    assert r.setup_time == 7.0 and r.max_openings == 10 and isinstance(r.max_openings, int)
    assert rules.all_orbit_rules(inst) == (r,)
