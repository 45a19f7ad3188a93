"""Time limits hold, model building included: a run ends within max(1 s, 5 %) of its limit.

C10 (176 610 candidate observations, about 4 s to generate, more to arrange and build) is the
instance where building alone takes seconds; C5 is a mid-size one. Slow: seconds each.
"""

from __future__ import annotations

import math
import time

import pytest

from models.data import observable_weight
from models.solve import bound
from sosp.instance import Instance
from sosp.scenarios import generate_scenario
from sosp.solve import solve


def _slack(limit: float) -> float:
    return max(1.0, 0.05 * limit)


@pytest.fixture(scope="module")
def c5() -> Instance:
    return generate_scenario("C5", 0)


@pytest.fixture(scope="module")
def c10() -> Instance:
    return generate_scenario("C10", 0)


@pytest.mark.slow
@pytest.mark.parametrize(
    "method, limit", [("milp", 8.0), ("milp-lns", 8.0), ("rds", 4.0), ("rds-stc", 4.0)]
)
def test_methods_keep_their_time_limit(c5: Instance, method: str, limit: float) -> None:
    t0 = time.perf_counter()
    res = solve(c5, method, time_limit=limit)  # validated by solve
    assert time.perf_counter() - t0 <= limit + _slack(limit), res.stats
    assert res.profit > 0


@pytest.mark.slow
def test_milp_with_the_side_bound_keeps_its_limit(c5: Instance) -> None:
    # long enough for the branch and price beside the MILP (models.colgen.SideBound) on a
    # machine with two cores (SIDE_MIN_S left after the warm start's and the bound's shares):
    # it is stopped with the MILP
    from models.colgen import SIDE_MIN_S, side_cores

    limit = 12.0
    assert 0.8 * limit - 1.0 >= SIDE_MIN_S  # the shares (10 % each) and a second to spare
    t0 = time.perf_counter()
    res = solve(c5, "milp", time_limit=limit)
    assert time.perf_counter() - t0 <= limit + _slack(limit), res.stats
    assert ("side_bound" in res.stats) == (side_cores() >= 2)
    assert res.profit <= res.bound <= (res.stats.get("side_bound") or math.inf)


@pytest.mark.slow
@pytest.mark.parametrize("limit", [3.0, 12.0])
def test_milp_keeps_its_limit_while_building(c10: Instance, limit: float) -> None:
    # 3 s: the candidates are not even complete; 12 s: warm start, Lagrangian bound and part
    # of the build fit, the MILP may not
    t0 = time.perf_counter()
    res = solve(c10, "milp", time_limit=limit)
    assert time.perf_counter() - t0 <= limit + _slack(limit), res.stats
    assert res.bound is not None and res.profit <= res.bound <= observable_weight(c10)
    assert res.profit > 0  # without its model in time, ASA-DTC's schedule (was: empty)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["auto", "lp", "milp", "lagrangian"])
def test_bound_keeps_its_time_limit(c10: Instance, method: str) -> None:
    limit = 6.0
    t0 = time.perf_counter()
    out = bound(c10, method=method, time_limit=limit)
    assert time.perf_counter() - t0 <= limit + _slack(limit), out
    assert 0 < out["bound"] <= observable_weight(c10)
