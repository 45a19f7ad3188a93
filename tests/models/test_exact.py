"""Exact models against the brute-force oracle, bounds, and the validator on every schedule."""

from __future__ import annotations

import pytest

from models.solve import bound, solve_milp
from sosp.instance import Instance
from sosp.result import Status
from sosp.validate import validate
from tests.conftest import TINY
from tests.models.instances import EDGE_CASES, random_tiny, scenario_tiny
from tests.oracle import brute_force

MODELS = ("task", "cluster", "static")
SEEDS = range(45)
#: Pyomo (the reference builder), and the direct HiGHS backend with both forms of (3).
BACKENDS = (("pyomo", "network"), ("highs", "network"), ("highs", "clique"))


def _check(inst: Instance) -> None:
    """Every backend proves the oracle's optimum, with a valid schedule and equal LP values.

    Each backend runs twice: the MILP alone with the exact slew term (no warm start, no extra
    bound) and the defaults (heuristic warm start, Lagrangian bound first, which may prove the
    start optimal with no MILP at all; the lazy slew term on the direct backend). Every bound
    is checked against the oracle, the LP and the covered weight.
    """
    from models.data import observable_weight

    best = {}
    cap = observable_weight(inst)
    for model in MODELS:
        expected = brute_force(inst, model).profit
        lp_values = []
        for backend, conflicts in BACKENDS:
            lp = bound(
                inst, model=model, method="lp", backend=backend, conflicts=conflicts, slew="exact"
            )
            assert expected - 1e-6 <= lp["bound"] <= cap, (model, backend)
            lp_values.append(lp["lp_value"] if lp["lp_value"] is not None else 0.0)
            for kw in ({"warm_start": "none", "extra_bound": "none", "slew": "exact"}, {}):
                res = solve_milp(inst, model=model, backend=backend, conflicts=conflicts, **kw)
                assert res.status is Status.OPTIMAL, (model, backend, kw, res.stats)
                assert res.profit == pytest.approx(expected), (model, backend, conflicts, kw)
                assert res.bound == pytest.approx(res.profit)
                assert res.bound <= lp["bound"] + 1e-6
                rep = validate(inst, res.schedule)
                assert rep.feasible, rep.violations
                assert rep.profit == pytest.approx(res.profit)
                if kw or model != "cluster":  # no start (a restricted model takes none)
                    assert "start_profit" not in res.stats
                else:  # the start stage ran: never below it
                    assert res.profit >= res.stats["start_profit"] >= res.stages[0].profit
        # the same polytope in every backend and form: the same LP optimum
        assert lp_values == pytest.approx([lp_values[0]] * len(lp_values), abs=1e-6), model
        lag = bound(inst, model=model, method="lagrangian", iterations=40)["bound"]
        assert expected - 1e-6 <= lag <= cap, model
        best[model] = res.profit
    # the cluster model is the problem's optimum: it dominates the other two
    assert best["cluster"] >= max(best["task"], best["static"])
    for method in ("lp", "auto", "lagrangian"):
        upper = bound(inst, model="cluster", method=method)["bound"]
        assert best["cluster"] - 1e-6 <= upper <= cap, method


@pytest.mark.parametrize("seed", SEEDS)
def test_random_tiny_matches_oracle(seed: int) -> None:
    _check(random_tiny(seed))


@pytest.mark.parametrize("name", sorted(EDGE_CASES))
def test_edge_cases_match_oracle(name: str) -> None:
    _check(EDGE_CASES[name]())


@pytest.mark.parametrize("name", sorted(TINY))
def test_named_tiny_match_oracle(name: str) -> None:
    _check(TINY[name]())


@pytest.mark.parametrize(("count", "hours", "seed"), [(3, 6, 0), (4, 6, 1), (5, 4, 2), (4, 8, 3)])
def test_scenario_tiny_matches_oracle(count: int, hours: float, seed: int) -> None:
    inst = scenario_tiny(count, hours, seed)
    if inst.n_opps > 12 or inst.n_opps == 0:
        pytest.skip(f"{inst.n_opps} opportunities: not a tiny instance")
    _check(inst)


def test_energy_exact_slew_term() -> None:
    """Hand-derived: with capacity 60 the three observations fit exactly; with 59 two do."""
    full = solve_milp(EDGE_CASES["energy_slew_60"](), model="task")
    assert full.profit == 12 and len(full.schedule) == 3
    cut = solve_milp(EDGE_CASES["energy_slew_59"](), model="task")
    assert cut.profit == 9  # a (30) + b (0): slew 30; a + c would need 60


def test_range_end_roll_is_used() -> None:
    res = solve_milp(EDGE_CASES["range_ends"](), model="cluster")
    assert res.profit == 9 and len(res.schedule) == 1
    assert res.schedule.observations[0].roll == pytest.approx(8.0)


def test_milp_bound_at_least_incumbent() -> None:
    inst = random_tiny(3)
    res = solve_milp(inst, model="cluster", time_limit=5)
    assert res.bound is not None and res.bound >= res.profit
