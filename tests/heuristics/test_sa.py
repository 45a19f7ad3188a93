"""SA-STC: hand-computed optimum on tiny instances, validity."""

from __future__ import annotations

import pytest

from heuristics.sa import swap_distance
from sosp.result import Status
from sosp.solve import solve
from sosp.validate import validate
from tests.heuristics.test_hpfs import names, x_blocks_y_and_z
from tests.heuristics.test_rds import random_tiny


def test_swap_distance_shrinks_with_temperature() -> None:
    assert swap_distance(101, 10.0, 10.0) == 100
    assert swap_distance(101, 5.0, 10.0) == 50
    assert swap_distance(101, 0.01, 10.0) == 1
    assert swap_distance(1, 1.0, 1.0) == 0


def test_zero_iterations_is_hpfs() -> None:
    inst = x_blocks_y_and_z()
    res = solve(inst, "sa-stc", iterations=0)
    assert res.iterations == 0 and res.profit == solve(inst, "hpfs-stc").profit == 6


def test_finds_the_pair_that_hpfs_misses() -> None:
    # Starting from x, y, z (decoded to {x} = 6), any permutation with y or z before x
    # decodes to {y, z} = 9, the optimum (worked out in test_hpfs).
    inst = x_blocks_y_and_z()
    res = solve(inst, "sa-stc", seed=0, iterations=200)
    assert res.status is Status.FEASIBLE and res.iterations == 200
    assert names(inst, res) == ["y", "z"] and res.profit == 9


@pytest.mark.parametrize("seed", range(20))
def test_valid_and_never_worse_than_hpfs(seed: int) -> None:
    inst = random_tiny(200 + seed)
    res = solve(inst, "sa-stc", seed=seed, iterations=300)
    rep = validate(inst, res.schedule)
    assert rep.feasible and rep.profit == res.profit
    assert solve(inst, "hpfs-stc").profit <= res.profit <= solve(inst, "rds-stc").profit


def test_reaches_rds_optimum_on_random_tiny() -> None:
    # Tiny permutations are fully explored by 2000 moves: SA reaches the static optimum.
    for seed in range(10):
        inst = random_tiny(300 + seed)
        assert (
            solve(inst, "sa-stc", seed=seed, iterations=2000).profit
            == solve(inst, "rds-stc").profit
        )


def test_time_limit_stops_early(c1) -> None:
    inst = c1
    res = solve(inst, "sa-stc", time_limit=0.2, iterations=10**9)
    assert 0 < res.iterations < 10**9
    assert validate(inst, res.schedule).feasible
