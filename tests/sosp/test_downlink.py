"""Downlinks (issue 60): the rules D1-D8 in the validator, the planner, files, and solving
with ground stations (``docs/model.md``, "Downlink")."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sosp.downlink import (
    Downlink,
    DownlinkParams,
    deliver,
    plan_downlinks,
    relaxed_instance,
    search_instance,
)
from sosp.errors import InputError
from sosp.instance import Instance, Resources, load_instance
from sosp.schedule import Schedule, load_schedule, make_observation
from sosp.validate import validate

PARAMS = DownlinkParams(rate=1.0, energy_rate=1.0, station_setup_s=30.0)
RESOURCES = Resources(memory_capacity=50.0, energy_capacity=200.0)


def tiny(
    contacts=((0, 0, 900.0, 1000.0),),
    params=PARAMS,
    antennas=1,
    satellites=("S1",),
    resources=RESOURCES,
) -> Instance:
    """Two consecutive 1000-s orbits per satellite; targets a (w 5), b (w 3), c (w 2), each
    seen once by each satellite on its first orbit (10, 20, 30 s long); one station."""
    n_s = len(satellites)
    opp = [  # target, orbit, start, end, roll
        (k, 2 * s, t0, t0 + d, 0.0)
        for s in range(n_s)
        for k, (t0, d) in enumerate(((100.0, 10.0), (300.0, 20.0), (500.0, 30.0)))
    ]
    t, o, st, en, ro = (np.array(c) for c in zip(*opp, strict=True))
    inst = Instance.from_arrays(
        epoch="2026-01-01T00:00:00Z",
        target_ids=["a", "b", "c"],
        target_lat=np.zeros(3),
        target_lon=np.zeros(3),
        target_weight=[5, 3, 2],
        orbit_ids=[f"{s}-{j}" for s in satellites for j in (1, 2)],
        orbit_satellite=[s for s in satellites for _ in (1, 2)],
        orbit_start=np.tile([0.0, 1000.0], n_s),
        orbit_end=np.tile([1000.0, 2000.0], n_s),
        resources=resources,
        opp_target=t,
        opp_orbit=o,
        opp_start=st,
        opp_end=en,
        opp_roll=ro,
        opp_roll_min=ro - 3,
        opp_roll_max=ro + 3,
        stations={
            "id": ["G"],
            "lat_deg": [0.0],
            "lon_deg": [0.0],
            "alt_m": [0.0],
            "min_elevation_deg": [5.0],
            "antennas": [antennas],
            "description": [""],
        },
        contacts={
            "satellite": [c[0] for c in contacts],
            "station": [c[1] for c in contacts],
            "start_s": [c[2] for c in contacts],
            "end_s": [c[3] for c in contacts],
            "max_elevation_deg": [45.0] * len(contacts),
        },
        downlink=params,
    )
    return inst


def obs(inst, *opps):
    return tuple(make_observation(inst, [i]) for i in opps)


def check(inst, observations, downlinks):
    return validate(inst, Schedule(observations, downlinks=tuple(downlinks)))


def rules_broken(report) -> set[str]:
    return {v.constraint for v in report.violations}


def test_delivered_data_earns_its_weight_and_undelivered_data_does_not() -> None:
    inst = tiny()
    o = obs(inst, 0, 1)  # a (10 s = 10 units), b (20 units)
    full = Downlink(0, 0, 900.0, 930.0, ((0, 10.0), (1, 20.0)))
    rep = check(inst, o, [full])
    assert rep.feasible and rep.profit == 8.0
    assert rep.downlink["delivered"] == 2 and rep.downlink["on_board_end"] == pytest.approx(0)
    assert rep.downlink["latency_s"]["max"] == pytest.approx(930.0 - 110.0)
    half = Downlink(0, 0, 900.0, 925.0, ((0, 10.0), (1, 15.0)))
    rep = check(inst, o, [half])
    assert rep.feasible and rep.profit == 5.0  # b is still partly on board: D8
    assert rep.downlink["on_board_end"] == pytest.approx(5.0)
    # counting what is observed, as without stations
    rep = check(replace(inst, downlink=replace(inst.downlink, count="observed")), o, [])
    assert rep.feasible and rep.profit == 8.0


@pytest.mark.parametrize(
    ("downlinks", "rule"),
    [
        ([Downlink(0, 0, 850.0, 880.0, ((0, 10.0),))], "D1"),  # before the contact
        ([Downlink(0, 0, 990.0, 1010.0, ((0, 10.0),))], "D1"),  # past its end
        ([Downlink(0, 0, 900.0, 905.0, ((0, 10.0),))], "D3"),  # 10 units in 5 s at rate 1
        ([Downlink(0, 0, 900.0, 930.0, ((0, 30.0),))], "D2"),  # more than a made
        ([Downlink(0, 0, 900.0, 930.0, ((4, 5.0),))], "D2"),  # c is not observed
        (
            [
                Downlink(0, 0, 900.0, 920.0, ((0, 10.0),)),
                Downlink(0, 0, 910.0, 930.0, ((1, 10.0),)),
            ],
            "D4",
        ),  # fmt: skip
    ],
)
def test_each_downlink_rule_is_checked(downlinks, rule) -> None:
    inst = tiny()
    assert rule in rules_broken(check(inst, obs(inst, 0, 1), downlinks))


def test_data_cannot_leave_before_its_observation_ends() -> None:
    inst = tiny(contacts=((0, 0, 100.0, 200.0),))
    bad = Downlink(0, 0, 105.0, 115.0, ((0, 10.0),))  # a ends at 110
    assert "D2" in rules_broken(check(inst, obs(inst, 0), [bad]))
    assert check(inst, obs(inst, 0), [replace(bad, start=110.0, end=120.0)]).feasible


def test_downlinking_while_observing_is_an_option() -> None:
    inst = tiny(contacts=((0, 0, 100.0, 400.0),))
    o = obs(inst, 0, 1)  # b observed over [300, 320]
    d = Downlink(0, 0, 290.0, 310.0, ((0, 10.0),))
    assert check(inst, o, [d]).feasible
    no = replace(inst, downlink=replace(inst.downlink, while_observing=False))
    assert "D4" in rules_broken(check(no, o, [d]))
    assert check(no, o, [replace(d, start=200.0, end=220.0)]).feasible


def test_the_store_spans_orbits_and_downlinks_empty_it() -> None:
    """W = 50 is one store across the two orbits: a (10) + b (20) + c (30) = 60 > 50 unless
    some is sent before c ends; per-orbit memory (5) no longer applies."""
    inst = tiny(contacts=((0, 0, 400.0, 450.0), (0, 0, 900.0, 1000.0)))
    o = obs(inst, 0, 1, 2)
    late = [Downlink(0, 0, 900.0, 960.0, ((0, 10.0), (1, 20.0), (2, 30.0)))]
    rep = check(inst, o, late)
    assert "D5" in rules_broken(rep)
    early = [
        Downlink(0, 0, 400.0, 430.0, ((0, 10.0), (1, 20.0))),
        Downlink(0, 0, 900.0, 930.0, ((2, 30.0),)),
    ]
    rep = check(inst, o, early)
    assert rep.feasible and rep.profit == 10.0
    assert rep.downlink["store_peak"]["S1"] == pytest.approx(30.0)


def test_antennas_and_their_setup_between_passes() -> None:
    two = tiny(contacts=((0, 0, 900.0, 1000.0), (1, 0, 900.0, 1000.0)), satellites=("S1", "S2"))
    o = obs(two, 0, 3)  # a by S1, a by S2 (different opportunities, same target)
    o = (o[0], make_observation(two, [4]))  # S2 observes b instead
    d1 = Downlink(0, 0, 900.0, 910.0, ((0, 10.0),))
    d2 = Downlink(1, 0, 920.0, 940.0, ((4, 20.0),))  # 10 s after S1's pass: set-up is 30 s
    assert "D6" in rules_broken(check(two, o, [d1, d2]))
    assert check(two, o, [d1, replace(d2, start=940.0, end=960.0)]).feasible
    dual = replace(two, stations=(replace(two.stations[0], antennas=2),))
    assert check(dual, o, [d1, d2]).feasible


def test_downlink_seconds_cost_energy_in_their_orbit() -> None:
    inst = tiny(resources=Resources(memory_capacity=50.0, energy_capacity=35.0))
    o = obs(inst, 0, 1)  # 30 s observed: 30 energy of 35 on orbit 1
    d = Downlink(0, 0, 900.0, 930.0, ((0, 10.0), (1, 20.0)))  # 30 s more in orbit 1
    assert "4" in rules_broken(check(inst, o, [d]))
    later = tiny(
        contacts=((0, 0, 1500.0, 1600.0),),
        resources=Resources(memory_capacity=50.0, energy_capacity=35.0),
    )
    assert check(later, o, [replace(d, start=1500.0, end=1530.0)]).feasible  # orbit 2's


def test_the_planner_sends_first_in_first_out_as_early_as_it_can() -> None:
    inst = tiny(contacts=((0, 0, 305.0, 315.0), (0, 0, 900.0, 1000.0)))
    o = obs(inst, 0, 1, 2)
    downlinks, sent = plan_downlinks(inst, o)
    assert downlinks[0].start == 305.0 and downlinks[0].parts == ((0, 10.0),)
    assert sum(v for _, v in sent.items()) == pytest.approx(60.0)
    kept, dls = deliver(inst, o)
    rep = check(inst, kept, dls)
    assert rep.feasible and rep.profit == 10.0 and rep.downlink["delivered"] == 3


def test_deliver_drops_what_cannot_reach_the_ground() -> None:
    # 15 s of contact at 1 unit/s carries a (10) but not b (20) as well
    inst = tiny(contacts=((0, 0, 900.0, 915.0),))
    kept, dls = deliver(inst, obs(inst, 0, 1))
    rep = check(inst, kept, dls)
    assert rep.feasible and [o.opps for o in kept] == [(0,)] and rep.profit == 5.0


def test_deliver_keeps_what_the_contacts_can_carry() -> None:
    """By hand: at 320 a and b (30 units) are on board and 15 s send a and 5 of b; c ends at
    530 with 45 on board (store 50); 40 s at 900 leave 5 of c: c is dropped and a, b fly."""
    inst = tiny(contacts=((0, 0, 320.0, 335.0), (0, 0, 900.0, 940.0)))
    kept, dls = deliver(inst, obs(inst, 0, 1, 2))
    rep = check(inst, kept, dls)
    assert rep.feasible and [o.opps for o in kept] == [(0,), (1,)] and rep.profit == 8.0
    assert [d.start for d in dls] == [320.0, 900.0]


def test_files_keep_downlinks_and_their_parameters(tmp_path) -> None:
    inst = tiny(params=DownlinkParams(rate=1.0, energy_rate=0.0, count="observed"))
    for suffix in (".json", ".npz"):
        inst.save(tmp_path / f"i{suffix}")
        back = load_instance(tmp_path / f"i{suffix}")
        assert back.downlink == inst.downlink and back.fingerprint == inst.fingerprint
    kept, dls = deliver(inst, obs(inst, 0, 1))
    sched = Schedule(kept, downlinks=tuple(dls), profit=8.0)
    sched.save(tmp_path / "s.json", inst)
    again = load_schedule(tmp_path / "s.json", inst)
    assert again.downlinks == sched.downlinks and validate(inst, again).feasible


@pytest.mark.parametrize(
    ("params", "field"),
    [
        ({"rate": -1}, "rate"),
        ({"rate": 0}, "rate"),
        ({"energy_rate": float("nan")}, "energy_rate"),
        ({"count": "sent"}, "count"),
        ({"speed": 3}, "speed"),
    ],
)
def test_bad_downlink_parameters_name_the_field(params, field) -> None:
    with pytest.raises(InputError, match=field):
        DownlinkParams.from_dict(params)


def test_search_and_relaxed_instances_bracket_the_problem() -> None:
    """Data made after the last contact gets no memory allowance (it would never be
    delivered); the relaxation adds what the orbit's contacts carry away."""
    inst = tiny(contacts=((0, 0, 400.0, 450.0),))
    search, index = search_instance(inst)
    assert not search.stations and not relaxed_instance(inst).stations
    assert list(index) == [0, 1] and search.opp_ids == inst.opp_ids[:2]  # c ends at 530
    assert search.memory_capacity[1] == 0.0
    assert search.memory_capacity[0] == pytest.approx(
        25.0
    )  # 50 carried of a, b: 30 and c: 30 (cap 50)
    relaxed = relaxed_instance(inst)
    # a and b end by 320 s, before the contact: nothing leaves in between, so the orbit makes
    # at most the store W = 50 (not W + the orbit's 50 contact seconds)
    assert relaxed.memory_capacity[0] == pytest.approx(50.0) and relaxed.n_opps == 2
    observed = replace(inst, downlink=replace(inst.downlink, count="observed"))
    assert relaxed_instance(observed).n_opps == search_instance(observed)[0].n_opps == 3


@pytest.mark.parametrize("method", ["greedy", "orbit-dp", "asa-dtc", "hpfs-stc"])
def test_every_method_plans_downlinks_that_the_validator_accepts(c1, method) -> None:
    from sosp.solve import solve
    from sosp.stations import builtin_stations

    stations = [s for s in builtin_stations() if s.id in ("SG", "MIY", "KSH")]
    inst = c1.with_stations(stations)
    res = solve(inst, method, seed=1, time_limit=2, bound="lp")
    rep = validate(inst, res.schedule)
    assert rep.feasible and rep.profit == res.profit > 0
    assert res.schedule.downlinks and rep.downlink["on_board_end"] == pytest.approx(0, abs=1e-6)
    assert res.bound is None or res.bound >= res.profit - 1e-6


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["--downlink", "rate=-1"], "downlink.rate"),
        (["--downlink", "count=sent"], "downlink.count"),
        (["--downlink", "rate"], "--downlink"),
        (["--downlink", "rate=1"], "--downlink: give it with --stations"),
    ],
)
def test_bad_downlink_options_get_one_line_and_write_nothing(tmp_path, capsys, argv, field):
    from sosp.cli import main

    out = tmp_path / "s.json"
    stations = [] if "with --stations" in field else ["--stations", "SG"]
    args = ["scenario", "C1", *stations, *argv, "-o", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert field in err and "\n" not in err and not out.exists()


def test_a_scenario_with_downlink_options_records_them(tmp_path, capsys):
    from sosp.cli import main

    out = tmp_path / "s.json"
    argv = ["scenario", "C1", "--stations", "SG,KSH", "--downlink", "rate=4", "count=observed"]
    assert main([*argv, "-o", str(out)]) == 0
    inst = load_instance(out)
    assert inst.downlink == DownlinkParams(rate=4.0, count="observed")
    assert "rate 4" in capsys.readouterr().out


def test_a_warm_start_with_stations_is_read_in_the_search_problem() -> None:
    """A schedule of the instance (its opportunity indices) starts milp-lns, which plans on
    the search problem (S1's b and c cannot be delivered, so S2's opportunities move down
    two places), and is never lost."""
    from sosp.solve import solve

    inst = tiny(contacts=((0, 0, 150.0, 200.0), (1, 0, 900.0, 1000.0)), satellites=("S1", "S2"))
    kept, dls = deliver(inst, obs(inst, 0, 4, 5))  # a by S1, b and c by S2
    start = Schedule(kept, downlinks=tuple(dls))
    assert validate(inst, start).profit == 10.0
    again = solve(inst, "milp-lns", warm_start=start, time_limit=3)
    assert validate(inst, again.schedule).feasible and again.profit == 10.0


def two_orbits_one_late_contact() -> Instance:
    """One satellite, store 50: a 40-s observation of a (w 5) on its first orbit, of b (w 3)
    on its second, and one contact at the very end of the second (100 s, rate 1)."""
    return Instance.from_arrays(
        epoch="2026-01-01T00:00:00Z",
        target_ids=["a", "b"],
        target_lat=np.zeros(2),
        target_lon=np.zeros(2),
        target_weight=[5, 3],
        orbit_ids=["S1-1", "S1-2"],
        orbit_satellite=["S1", "S1"],
        orbit_start=np.array([0.0, 1000.0]),
        orbit_end=np.array([1000.0, 2000.0]),
        resources=RESOURCES,
        opp_target=np.array([0, 1]),
        opp_orbit=np.array([0, 1]),
        opp_start=np.array([100.0, 1100.0]),
        opp_end=np.array([140.0, 1140.0]),
        opp_roll=np.zeros(2),
        opp_roll_min=np.full(2, -3.0),
        opp_roll_max=np.full(2, 3.0),
        stations={"id": ["G"], "lat_deg": [0.0], "lon_deg": [0.0], "alt_m": [0.0],
                  "min_elevation_deg": [5.0], "antennas": [1], "description": [""]},
        contacts={"satellite": [0], "station": [0], "start_s": [1900.0], "end_s": [2000.0],
                  "max_elevation_deg": [45.0]},
        downlink=PARAMS,
    )  # fmt: skip


def test_store_rows_bound_what_orbits_make_together() -> None:
    """Both observations fit their orbit's limit (orbit 2 may send its 100 contact seconds),
    but the store holds 50 and nothing leaves before the second ends: only one flies. The
    per-orbit relaxation's bound is 8; the row over both orbits (made <= W + r x contact
    seconds between a's end and b's end = 50) brings the column generation's to 5."""
    from sosp.downlink import STORE_ROWS, store_rows
    from sosp.registry import compute_bound
    from tests.oracle import brute_force_stations

    inst = two_orbits_one_late_contact()
    assert brute_force_stations(inst).profit == 5.0
    cap, rows = store_rows(inst)
    assert list(cap) == pytest.approx([50.0, 50.0]) and rows == [([0, 1], 50.0)]
    assert relaxed_instance(inst).meta[STORE_ROWS] == [[[0, 1], 50.0]]
    # without the row (the relaxation as it was) the bound is both weights
    plain = replace(relaxed_instance(inst), meta={})
    assert compute_bound("colgen", plain)["bound"] == 8.0
    assert compute_bound("colgen", inst)["bound"] == 5.0
    assert compute_bound("auto", inst)["bound"] == 5.0


@pytest.mark.parametrize("seed", range(20))
def test_the_bounds_with_store_rows_stay_above_brute_force(seed) -> None:
    from sosp.registry import compute_bound
    from tests.models.instances import random_tiny_stations
    from tests.oracle import brute_force_stations

    inst = random_tiny_stations(seed)
    best = brute_force_stations(inst).profit
    for name in ("colgen", "auto", "lp"):
        assert compute_bound(name, inst)["bound"] >= best - 1e-9, name


def test_allowances_let_data_wait_on_board_for_a_later_contact() -> None:
    """Segments asking 30, 40, 10 of a store of 50, contacts sending 10, 100, then nothing:
    the first takes 30 (20 stays on board after its contact), the second the 30 of room left,
    the third 10, which no contact sends, so it is taken back when weights count on delivery
    (the old rule, each segment its own contact's min(W, r x length), gave 10, 40, 0)."""
    from sosp.downlink import _carried

    load, sends = np.array([30.0, 40.0, 10.0]), np.array([10.0, 100.0, 0.0])
    assert list(_carried(load, sends, 50.0, keep_last=False)) == [30.0, 30.0, 0.0]
    assert list(_carried(load, sends, 50.0, keep_last=True)) == [30.0, 30.0, 10.0]


def test_solving_with_stations_refills_what_the_allowances_left_out() -> None:
    """On this instance the allowances give the search no memory at all: before the refill,
    greedy delivered nothing; now it delivers the optimum (the brute force's)."""
    from sosp.solve import solve
    from tests.models.instances import random_tiny_stations
    from tests.oracle import brute_force_stations

    inst = random_tiny_stations(184)
    search, _ = search_instance(inst)
    assert solve(search, "greedy").profit == 0.0
    res = solve(inst, "greedy")
    assert res.profit == brute_force_stations(inst).profit == 24.0
    assert validate(inst, res.schedule).feasible and res.stats["search_profit"] == 0.0


@pytest.mark.parametrize("seed", range(20))
def test_the_refill_never_delivers_less_and_always_passes(seed) -> None:
    """From what greedy plans on the allowances (as :func:`sosp.solve.solve` does)."""
    from heuristics.refill import refill
    from sosp.solve import solve
    from tests.models.instances import random_tiny_stations
    from tests.oracle import brute_force_stations

    inst = random_tiny_stations(seed)
    search, index = search_instance(inst)
    found = [
        replace(o, opps=tuple(int(index[i]) for i in o.opps))
        for o in solve(search, "greedy").schedule.observations
    ]
    before = Schedule(deliver(inst, found)[0]).coverage_profit(inst)[0]
    kept, dls = refill(inst, found)
    rep = check(inst, kept, dls)
    assert rep.feasible and before <= rep.profit <= brute_force_stations(inst).profit


def test_the_refill_adds_a_target_and_merges_into_a_cluster() -> None:
    """a alone is delivered; b fits beside it (store 50, 100 s of contact); c, 30 s more,
    would overflow the store before the contact, so it stays out. Two opportunities of one
    window and a common roll join one observation; an expired budget adds nothing."""
    from heuristics.refill import refill
    from sosp.stop import Budget

    inst = tiny()
    kept, dls = refill(inst, obs(inst, 0))
    assert [o.opps for o in kept] == [(0,), (1,)] and check(inst, kept, dls).profit == 8.0
    assert refill(inst, obs(inst, 0), Budget.until(0.0))[0] == obs(inst, 0)
    # b overlaps a (3): only as one observation of 25 s, and c still does not fit
    wide = replace(inst, opp_start=np.array([100.0, 105, 500]), opp_end=np.array([110.0, 125, 530]))
    kept, dls = refill(wide, obs(wide, 0))
    assert [o.opps for o in kept] == [(0, 1)] and check(wide, kept, dls).profit == 8.0
