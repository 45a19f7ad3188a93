"""HPFS-STC: hand-computed schedules and validity on random instances."""

from __future__ import annotations

import pytest

from sosp.instance import Instance
from sosp.result import Status
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import tiny_cluster, tiny_two_orbits
from tests.heuristics.test_rds import random_tiny


def x_blocks_y_and_z() -> Instance:
    """x (6) at [10, 14] conflicts by (3) with y (5) at [0, 4] and z (4) at [20, 24]
    (gaps 6 < a = 10); y (roll 2) and z (roll -2) are compatible: gap 16 >= 10 + 4/1.
    Disjoint roll ranges, so no two can be clustered."""
    return Instance.build(
        {"x": 6, "y": 5, "z": 4},
        [
            ("y", 0, 0, 4, 2.0, 1.0, 3.0),
            ("x", 0, 10, 14, 10.0, 9.0, 11.0),
            ("z", 0, 20, 24, -2.0, -3.0, -1.0),
        ],
    )


def names(inst: Instance, res) -> list[str]:  # noqa: ANN001
    return sorted(inst.target_ids[inst.opp_target[i]] for i in res.schedule.observed_opps())


def test_highest_weight_first_is_myopic() -> None:
    # x (6) goes first and blocks y and z: profit 6, while the optimum {y, z} is 9.
    inst = x_blocks_y_and_z()
    res = solve(inst, "hpfs-stc")
    assert res.status is Status.FEASIBLE
    assert names(inst, res) == ["x"] and res.profit == 6
    assert solve(inst, "rds-stc").profit == 9


def test_cluster_task_inserted_whole() -> None:
    # Static clusters {a, b} (weight 9, roll 10, window [0, 9]) and {c} (2): both fit.
    inst = tiny_cluster()
    res = solve(inst, "hpfs-stc")
    assert res.profit == 11 and len(res.schedule) == 2
    assert res.schedule.observations[0].opps == (0, 1)
    assert res.schedule.observations[0].roll == pytest.approx(10.0)


def test_covered_target_is_not_scheduled_twice() -> None:
    # Tasks a@orbit0 (6), a@orbit1 (6), b@orbit0 (5); ties by index: a@orbit0 first, then
    # a@orbit1 adds nothing (a covered) and is skipped, b conflicts with a on orbit 0: 6.
    inst = tiny_two_orbits()
    res = solve(inst, "hpfs-stc")
    assert res.profit == 6 and len(res.schedule) == 1
    assert res.schedule.observations[0].orbit == 0


@pytest.mark.parametrize("seed", range(20))
def test_valid_on_random(seed: int) -> None:
    inst = random_tiny(100 + seed)
    res = solve(inst, "hpfs-stc")
    rep = validate(inst, res.schedule)
    assert rep.feasible and rep.profit == res.profit
    assert res.profit <= solve(inst, "rds-stc").profit
