"""The integer program with ground stations and downlinks (:mod:`models.downlink`, issue 60
item 4): equal to brute force on tiny instances, its schedules pass D1-D8, no heuristic
beats its proven optimum, and where its fluid antennas promise more than one antenna per
pass delivers, its value is reported as a bound."""

from __future__ import annotations

import pytest

from models.solve import solve_milp
from sosp.result import Status
from sosp.solve import solve
from sosp.validate import validate
from tests.models.instances import random_tiny_stations
from tests.oracle import brute_force_stations
from tests.sosp.test_downlink import tiny

SEEDS = range(20)


@pytest.fixture(scope="module")
def optima() -> dict[int, float]:
    return {seed: brute_force_stations(random_tiny_stations(seed)).profit for seed in SEEDS}


@pytest.mark.parametrize("seed", SEEDS)
def test_the_milp_equals_brute_force_and_its_schedule_flies(seed, optima) -> None:
    inst = random_tiny_stations(seed)
    res = solve_milp(inst, model="task", warm_start="none", extra_bound="none")
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations[:1]
    assert res.status is Status.OPTIMAL and res.profit == rep.profit == optima[seed]
    assert res.stats["objective"] == pytest.approx(optima[seed])
    if rep.profit and inst.downlink.count == "delivered":
        assert res.schedule.downlinks and rep.downlink["on_board_end"] == pytest.approx(0, abs=1e-6)
    # clustering can only add to the paper's task model
    cluster = solve_milp(inst, warm_start="none")
    assert validate(inst, cluster.schedule).feasible and cluster.profit >= optima[seed]


def test_some_tiny_instances_are_decided_by_their_stations(optima) -> None:
    """The test instances are no station-free problems in disguise."""
    from tests.oracle import brute_force

    lost = [
        s for s in SEEDS
        if brute_force(random_tiny_stations(s).without_stations(), "task").profit > optima[s]
    ]  # fmt: skip
    assert len(lost) >= len(SEEDS) // 2


@pytest.mark.parametrize("method", ["greedy", "asa-dtc"])
def test_no_heuristic_beats_the_proven_optimum(method) -> None:
    for seed in range(0, 20, 3):
        inst = random_tiny_stations(seed)
        best = solve(inst, "milp", time_limit=20)  # with its start and the extra bound
        assert best.status is Status.OPTIMAL and best.stats["stations"]
        assert best.profit == brute_force_stations(inst).profit
        assert solve(inst, method, seed=seed, time_limit=0.3).profit <= best.profit + 1e-9


def test_fluid_antennas_make_the_model_a_bound_where_one_antenna_is_shared() -> None:
    """Two satellites, one antenna, one 60-s contact each at the same time: the model sends
    30 s from each (a+b on one, c on the other: 10); one pass plus the 30-s set-up leaves the
    second satellite nothing, so 8 is delivered and 10 is the bound."""
    inst = tiny(contacts=((0, 0, 900.0, 960.0), (1, 0, 900.0, 960.0)), satellites=("S1", "S2"))
    res = solve_milp(inst, warm_start="none", extra_bound="none")
    assert validate(inst, res.schedule).feasible
    assert (res.profit, res.bound, res.status) == (8.0, 10.0, Status.FEASIBLE)
    assert res.stats["delivered_below_model"]
    assert solve_milp(inst, relax=True).bound >= res.bound  # the LP, of the relaxation


def test_with_stations_a_window_ending_late_is_refused_so_the_bounds_hold() -> None:
    """A window ending later than (10) would make its data later: with r > w the store drains
    faster than the longer window fills it. a (100 s, weight 5) fills the store (W 100) at
    200; b (weight 3) ends at 225, when the only contact opens (r 2), so b overflows it (110),
    but b stated [215, 265] would end with 70 on board and deliver both (8), above the
    integer program's optimum of windows (10), 5. With stations the validator refuses it."""
    from dataclasses import replace

    import numpy as np

    from sosp.downlink import DownlinkParams, plan_downlinks
    from sosp.instance import Instance, Resources
    from sosp.registry import compute_bound
    from sosp.schedule import Schedule, make_observation

    inst = Instance.from_arrays(
        epoch="2026-01-01T00:00:00Z", target_ids=["a", "b"], target_lat=np.zeros(2),
        target_lon=np.zeros(2), target_weight=[5, 3], orbit_ids=["S1-1"],
        orbit_satellite=["S1"], orbit_start=[0.0], orbit_end=[1000.0],
        resources=Resources(memory_capacity=100.0, energy_capacity=1000.0),
        opp_target=np.array([0, 1]), opp_orbit=np.array([0, 0]),
        opp_start=np.array([100.0, 215.0]), opp_end=np.array([200.0, 225.0]),
        opp_roll=np.zeros(2), opp_roll_min=np.full(2, -3.0), opp_roll_max=np.full(2, 3.0),
        stations={"id": ["G"], "lat_deg": [0.0], "lon_deg": [0.0], "alt_m": [0.0],
                  "min_elevation_deg": [5.0], "antennas": [1], "description": [""]},
        contacts={"satellite": [0], "station": [0], "start_s": [225.0], "end_s": [400.0],
                  "max_elevation_deg": [45.0]},
        downlink=DownlinkParams(rate=2.0),
    )  # fmt: skip
    a, b = make_observation(inst, [0]), make_observation(inst, [1])

    def delivered(obs):
        return validate(inst, Schedule(obs, downlinks=tuple(plan_downlinks(inst, obs)[0])))

    assert not delivered((a, b)).feasible  # store 110 > 100 when b ends at 225
    rep = delivered((a, replace(b, end=265.0)))
    assert not rep.feasible
    assert any("must end when its last opportunity ends" in v.message for v in rep.violations)
    assert {v.constraint for v in delivered((a, replace(b, start=212.0))).violations} == {"D5"}
    res = solve_milp(inst, warm_start="none", extra_bound="none")
    assert res.profit == res.bound == 5.0
    assert compute_bound("auto", inst, time_limit=5)["bound"] >= res.profit
