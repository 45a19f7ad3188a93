"""Bounds that hold up: never above the covered weight, never below the optimum, and the MILP
never worse than its warm start nor looser than the LP; ``solve(..., bound=...)`` certifies any
method's schedule."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from models.data import observable_weight
from models.lagrangian import lagrangian_bound
from models.solve import bound, solve_milp
from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.result import Status
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import tiny_cluster
from tests.limits import limit_kept
from tests.models.instances import random_tiny
from tests.oracle import brute_force


def _with_unseen_target(inst: Instance, weight: int = 100) -> Instance:
    """``inst`` plus a heavy target no orbit sees (it must add nothing to any bound)."""
    d = inst.to_dict(layout="columns")
    t = d["targets"]
    t["id"] = [*t["id"], "unseen"]
    t["lat"] = [*t["lat"], 0.0]
    t["lon"] = [*t["lon"], 0.0]
    t["weight"] = [*t["weight"], weight]
    return Instance.from_dict(d)


def test_unseen_target_adds_nothing_to_any_bound() -> None:
    inst = _with_unseen_target(tiny_cluster())
    cap = observable_weight(inst)
    assert cap == 11  # tiny_cluster's three targets (2 + 4 + 5), not the unseen 100
    assert lagrangian_bound(inst, iterations=5)["bound"] <= cap
    for method in ("auto", "lp", "milp", "lagrangian"):
        out = bound(inst, method=method)
        assert 11 <= out["bound"] <= cap, method
    res = solve_milp(inst, warm_start="none", extra_bound="none")
    assert res.status is Status.OPTIMAL and res.bound == 11


def test_lagrangian_bound_capped_when_the_subgradient_stops_early() -> None:
    # one step from mu = p/2 is far above the optimum: the cap is what holds it
    inst = _with_unseen_target(random_tiny(4), weight=50)
    out = lagrangian_bound(inst, iterations=1, lower_bound=0.0)
    assert out["bound"] <= observable_weight(inst)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_milp_and_bounds_against_the_oracle(seed: int) -> None:
    inst = random_tiny(seed)
    optimum = brute_force(inst, "cluster").profit
    cap = observable_weight(inst)
    lp = bound(inst, method="lp", slew="exact")["bound"]
    assert optimum <= lp <= cap
    for method in ("auto", "lagrangian", "milp"):
        assert optimum <= bound(inst, method=method)["bound"] <= cap, method
    res = solve_milp(inst, time_limit=30)
    assert validate(inst, res.schedule).feasible
    assert res.profit >= res.stats["start_profit"]  # never below its warm start
    assert res.profit <= res.bound <= lp  # never looser than the LP
    assert res.status is Status.OPTIMAL and res.profit == optimum


def test_auto_runs_the_start_stage_of_the_pipeline() -> None:
    """A direct call with ``warm_start="auto"`` runs the pipeline's start stage (orbit-dp)
    once and goes on from its schedule: never below it; a restricted model takes none."""
    inst = random_tiny(11)
    res = solve_milp(inst, rng=np.random.default_rng(0))
    assert [(st.kind, st.name) for st in res.stages] == [("start", "orbit-dp"), ("method", "milp")]
    assert res.stats["start"] == "orbit-dp" and res.stats["warm_start"] is True
    assert res.profit >= res.stats["start_profit"] >= res.stages[0].profit - 1e-9
    assert validate(inst, res.schedule).feasible and res.profit <= res.bound
    for model in ("task", "static"):
        res = solve_milp(inst, model=model)
        assert res.stages == () and "start_profit" not in res.stats
        assert validate(inst, res.schedule).profit == res.profit
        assert res.profit == brute_force(inst, model).profit


def test_warm_start_none_and_bad_values() -> None:
    inst = tiny_cluster()
    res = solve_milp(inst, warm_start="none")
    assert "start_profit" not in res.stats and res.profit == 11
    with pytest.raises(InputError, match="warm_start"):
        solve_milp(inst, warm_start="greedy")
    with pytest.raises(InputError, match="warm_start"):
        solve_milp(inst, warm_start=3)
    with pytest.raises(InputError, match="extra_bound"):
        solve_milp(inst, extra_bound="pba")
    with pytest.raises(InputError, match="method"):
        bound(inst, method="simplex")


@pytest.mark.parametrize("seed", [0, 2, 6])
def test_solve_bound_certifies_a_heuristic(seed: int) -> None:
    inst = random_tiny(seed)
    optimum = brute_force(inst, "cluster").profit
    res = solve(inst, "greedy", bound="auto")
    assert res.profit <= optimum <= res.bound <= observable_weight(inst)
    assert res.stats["certified_by"] == "auto"
    assert (res.status is Status.OPTIMAL) == (res.bound == res.profit)
    assert res.gap == pytest.approx((res.bound - res.profit) / res.bound if res.bound else 0.0)
    with pytest.raises(InputError, match="bound"):
        solve(inst, "greedy", bound="pba")  # bounds the static problem, not the problem


@pytest.mark.parametrize("how", ["auto", "colgen", "lagrangian", "lp"])
def test_certifying_on_two_workers_gives_the_same_bound(how: str) -> None:
    """``bound_workers`` only spreads the pricing rounds: the bound is one process's."""
    inst = next(random_tiny(s) for s in range(100) if random_tiny(s).n_orbits >= 2)
    one = solve(inst, "greedy", bound=how)
    two = solve(inst, "greedy", bound=how, bound_workers=2)
    assert two.bound == one.bound and two.stats["certified_by"] == how
    with pytest.raises(InputError, match="bound_workers"):
        solve(inst, "greedy", bound=how, bound_workers=0)


def test_cli_bound_workers(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    args = ["solve", str(path), "--method", "greedy", "--json", "-q"]
    assert main([*args, "--bound", "colgen", "--bound-workers", "2"]) == 0
    assert json.loads(capsys.readouterr().out)["bound"] >= 11
    written = tmp_path / "out.json"
    for bad in (["--bound-workers", "2"], ["--bound", "--bound-workers", "0"]):
        assert main([*args, *bad, "-o", str(written)]) == 2
        err = capsys.readouterr().err
        assert "--bound-workers" in err and len(err.strip().splitlines()) == 1
        assert not written.exists()


def test_cli_solve_bound_and_optimal_wording(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from sosp.cli import main

    path = tmp_path / "inst.json"
    tiny_cluster().save(path)
    assert main(["solve", str(path), "--method", "milp", "-q"]) == 0
    assert "proven optimal (gap 0)" in capsys.readouterr().out
    assert main(["solve", str(path), "--method", "greedy", "--bound", "--json", "-q"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["profit"] <= 11 <= out["bound"] and out["gap"] is not None
    assert main(["solve", str(path), "--method", "milp", "--warm-start", "none", "-q"]) == 0
    capsys.readouterr()
    written = tmp_path / "out.json"
    code = main(["solve", str(path), "--method", "greedy", "--bound", "nope", "-o", str(written)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and not written.exists()


@pytest.mark.parametrize("seed", range(45))
def test_lazy_slew_matches_the_oracle(seed: int) -> None:
    inst = random_tiny(seed)
    expected = brute_force(inst, "cluster").profit
    res = solve_milp(inst, backend="highs", slew="lazy", warm_start="none", extra_bound="none")
    assert res.status is Status.OPTIMAL and res.profit == expected
    assert validate(inst, res.schedule).feasible


def test_lazy_slew_adds_the_exact_term_where_the_relaxed_row_lets_4_break() -> None:
    # random_tiny(0): the relaxed row's optimum breaks (4) on one orbit; round 2 fixes it
    inst = random_tiny(0)
    res = solve_milp(inst, backend="highs", slew="lazy", warm_start="none", extra_bound="none")
    assert res.stats["lazy_rounds"] == 2 and res.stats["lazy_exact_orbits"] == 1
    assert res.status is Status.OPTIMAL and validate(inst, res.schedule).feasible
    assert res.profit == brute_force(inst, "cluster").profit
    with pytest.raises(InputError, match="slew"):
        solve_milp(inst, slew="lazy", relax=True)


@pytest.mark.parametrize("seed", range(6))
def test_lagrangian_past_the_milp_cap_prices_the_planners_candidates(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--method lagrangian`` refused D30 ("more than 464650 candidate observations", the
    MILPs' cap) although its own pricing has no such cap; past the memory budget too, it
    gives the window relaxation's bound."""
    import models.solve as ms
    import sosp.candidates as sc

    inst = random_tiny(300 + seed)
    optimum = brute_force(inst, "cluster").profit

    def too_many(*args, **kwargs):
        raise InputError("orbit 'o': more than 1 candidate observations")

    monkeypatch.setattr(ms, "model_data", too_many)
    out = bound(inst, method="lagrangian", iterations=40)
    assert out["source"] == "lagrangian"
    assert out["bound"] == lagrangian_bound(inst, iterations=40)["bound"]
    assert optimum - 1e-9 <= out["bound"] <= observable_weight(inst)
    monkeypatch.setattr(sc, "MAX_CANDIDATE_BYTES", -1)
    inst = random_tiny(300 + seed)  # a new object: the candidates are cached per instance
    out = bound(inst, method="lagrangian", iterations=40)
    assert out["source"] == "windows" and out["method"] == "lagrangian"
    assert optimum - 1e-9 <= out["bound"] <= observable_weight(inst)


@pytest.mark.limits
@pytest.mark.parametrize("windows_share", [0.25, 1.01])
@pytest.mark.parametrize("method", ["colgen", "lagrangian", "auto"])
def test_candidates_out_of_time_before_the_limit_give_the_cap_or_windows(
    method: str, windows_share: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The arranging does not start an orbit foreseen to end past the deadline, so the
    candidates' "time limit reached" can come before the limit. It is a
    :class:`TimeLimitReached`: the bounds answer with the cap (the observable weight), as
    at the limit; before, ``colgen`` checked the clock and passed the error on (exit 2).
    ``lagrangian`` and ``auto`` with a fifth of the limit left (``WINDOWS_MIN_SHARE``)
    answer with the window relaxation's bound instead, never above the cap nor below the
    optimum."""
    import models.solve as ms
    import sosp.planner as sp

    inst = random_tiny(7)
    monkeypatch.setattr(ms, "WINDOWS_MIN_SHARE", windows_share)

    def out_of_time(*args, **kwargs):
        raise TimeLimitReached("orbit 'o': time limit reached while arranging (9)")

    def too_many(*args, **kwargs):  # as on D30, where lagrangian and auto price orbit_data
        raise InputError("orbit 'o': more than 1 candidate observations")

    monkeypatch.setattr(sp, "orbit_data", out_of_time)
    monkeypatch.setattr(ms, "model_data", too_many)
    out = bound(inst, method=method, time_limit=60)
    assert out["timed_out"] == "candidates"
    limit_kept(f"{method}, no candidates in time", out["runtime_s"], 5.0)
    if method == "colgen" or windows_share > 1:
        assert out["source"] == "cap" and out["bound"] == observable_weight(inst)
    else:
        assert out["parts"]["windows"] >= out["bound"]
        assert brute_force(inst, "cluster").profit - 1e-6 <= out["bound"]
        assert out["bound"] <= observable_weight(inst)
        assert out["source"] == ("cap" if out["bound"] == observable_weight(inst) else "windows")


def test_auto_and_lagrangian_leave_the_window_relaxation_its_share(monkeypatch, c1) -> None:
    # the candidates must be ready by (1 - WINDOWS_AFTER_SHARE) of the limit, so that when
    # they are not the window relaxation still has its share (not the cap)
    import time

    import models.solve as msolve

    seen: list = []
    real = msolve.model_data

    def spy(instance, model="cluster", deadline=None, generate_by=None):
        seen.append((deadline, generate_by, time.perf_counter()))
        return real(instance, model, deadline, generate_by)

    monkeypatch.setattr(msolve, "model_data", spy)
    inst = c1
    for method in ("auto", "lagrangian", "lp"):
        before = len(seen)
        msolve.bound(inst, method=method, time_limit=8.0)
        deadline, by, at = seen[before]  # the bound's own preparation
        if method == "lp":  # no window relaxation to leave time to
            assert by is None
        else:
            share = 1.0 - msolve.WINDOWS_AFTER_SHARE
            assert deadline - 8.0 + share * 8.0 == pytest.approx(by) and by > at
