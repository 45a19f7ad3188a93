"""The stages of a solve (sosp.pipeline): a start, the method, a certifying bound."""

from __future__ import annotations

import sys

import pytest

from sosp.result import Result, Status
from sosp.schedule import Schedule
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import tiny_cluster
from tests.models.instances import random_tiny

pipeline = sys.modules["sosp.pipeline"]


def test_milp_runs_its_start_stage_first_and_says_so() -> None:
    inst = random_tiny(3)
    res = solve(inst, "milp", seed=0, time_limit=30.0)
    assert [(st.kind, st.name) for st in res.stages] == [("start", "orbit-dp"), ("method", "milp")]
    start, method = res.stages
    assert res.profit >= start.profit and res.stats["start"] == "orbit-dp"
    assert res.summary()["stages"][0]["name"] == "orbit-dp"
    # a given schedule, or none, is no start stage
    res = solve(inst, "milp", seed=0, warm_start="none")
    assert [st.kind for st in res.stages] == ["method"]


def test_the_start_is_kept_when_the_method_returns_less(monkeypatch: pytest.MonkeyPatch) -> None:
    ss = sys.modules["sosp.solve"]
    real = ss.method_function("milp")

    def loses(instance, *, rng, time_limit=None, warm_start=None, **kw) -> Result:
        assert isinstance(warm_start, Schedule) and len(warm_start) > 0  # the start's schedule
        return Result("milp", Status.TIME_LIMIT, Schedule(()), 0.0, 0, bound=1e9)

    monkeypatch.setattr(ss, "method_function", lambda m: loses if m == "milp" else real)
    inst = tiny_cluster()
    res = solve(inst, "milp", seed=0, time_limit=10.0)
    assert res.profit == res.stages[0].profit > 0 and res.stats["returned"] == "start"
    assert validate(inst, res.schedule).profit == res.profit


def test_the_time_limit_covers_the_certifying_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    ss = sys.modules["sosp.solve"]
    real, given = ss.method_function("greedy"), {}

    def greedy(instance, *, rng, time_limit=None, **kw) -> Result:
        given["method"] = time_limit
        return real(instance, rng=rng, time_limit=time_limit, **kw)

    seen = {}

    def bound(name, instance, *, time_limit=None, **kw) -> dict:
        seen["bound"] = time_limit
        return {"bound": instance.observable_weight}

    monkeypatch.setattr(ss, "method_function", lambda m: greedy)
    monkeypatch.setattr(pipeline, "compute_bound", bound)
    res = solve(tiny_cluster(), "greedy", time_limit=8.0, bound="lp")
    assert given["method"] <= (1 - pipeline.BOUND_SHARE) * 8.0 + 1e-6
    assert 0 < seen["bound"] <= 8.0  # what is left of the same limit, not a limit of its own
    assert [st.kind for st in res.stages] == ["method", "bound"]
    assert res.stages[1].bound == res.bound


def test_a_stop_before_any_schedule_still_writes_one(monkeypatch: pytest.MonkeyPatch) -> None:
    # issue 63 item 2: Ctrl-C during orbit-dp's preparation on 2,000 targets wrote an empty
    # schedule (profit 0); a run stopped before its method has a schedule returns greedy's
    import heuristics.orbit_search as orbit_search
    from sosp.stop import clear_stop, request_stop

    def stopped_in_preparation(instance, **kwargs):
        request_stop("SIGINT")
        return Result("orbit-dp", Status.FEASIBLE, Schedule(()), 0.0, 0)

    monkeypatch.setattr(orbit_search, "solve_orbit_dp", stopped_in_preparation)
    inst = random_tiny(3)
    try:
        res = solve(inst, "orbit-dp")
    finally:
        clear_stop()
    assert res.status is Status.INTERRUPTED or res.status is Status.OPTIMAL
    assert res.profit == solve(inst, "greedy").profit > 0
    assert validate(inst, res.schedule).feasible
    assert [st.name for st in res.stages] == ["orbit-dp", "greedy"]
