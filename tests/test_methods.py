"""The contract every registered method keeps (``sosp.registry.METHODS``), checked for all of them.

On random tiny instances: the schedule passes the validator (the referee), its profit is never
above the brute-force optimum of the clustering-exact problem (``tests/oracle.py``; static and
no-clustering methods solve restrictions of it), and the same seed gives the same schedule.
On the paper's C1 (B1 for the slower exact ones), the same seed gives the same schedule, the
same iterations and the same statistics, timings aside (:data:`SAME_SEED`: every method, and
the options that take other paths: ASA with two chains, TS with restarts, GA's population).
Methods are run with an iteration limit where they take one, so the result does not depend on
the machine's speed.
"""

from __future__ import annotations

import inspect

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.registry import METHODS, available_methods, method_function
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, small_instances, tiny_cluster
from tests.oracle import brute_force

#: Keyword limits that make a run short and deterministic, tried in this order; the first one a
#: method accepts is used (a method without any runs to its own end).
LIMITS = ({"iterations": 60},)

#: Methods whose iteration is a whole solve (a sub-MILP per step) get fewer.
FEWER = {"milp-lns": {"iterations": 4, "start_params": {"iterations": 20}}}


def _limits(method: str) -> dict:
    """The iteration limit ``method`` accepts, found by asking it on a tiny instance."""
    if method in FEWER:
        return FEWER[method]
    for kw in LIMITS:
        try:
            solve(tiny_cluster(), method, seed=0, **kw)
        except InputError as exc:
            if any(k in str(exc) for k in kw):
                continue
            raise
        return kw
    return {}


_METHODS = available_methods()
_KW = {m: _limits(m) for m in _METHODS}


def test_every_method_is_registered_as_a_solver_function() -> None:
    for m in METHODS:
        func = method_function(m)
        params = inspect.signature(func).parameters
        assert "rng" in params and "time_limit" in params, m
        assert params["rng"].kind is inspect.Parameter.KEYWORD_ONLY, m


@pytest.mark.slow
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=7), seed=st.integers(0, 2**16))
@pytest.mark.parametrize("method", _METHODS)
def test_contract(method: str, inst: Instance, seed: int) -> None:
    first = solve(inst, method, seed=seed, check=False, **_KW[method])
    report = validate(inst, first.schedule)
    assert report.feasible, (method, report.violations[:3])
    assert report.profit == pytest.approx(first.profit)
    assert first.profit <= brute_force(inst, "cluster").profit + 1e-9
    again = solve(inst, method, seed=seed, check=False, **_KW[method])
    assert again.schedule.observations == first.schedule.observations


#: Same seed, same schedule, on a generated scenario: (method, scenario, options) per run. Every
#: registered method is here; options with paths of their own are runs of their own.
SAME_SEED = [
    ("greedy", "C1", {}),
    ("hpfs-stc", "C1", {}),
    ("asa-dtc", "C1", {"iterations": 400}),
    ("asa-stc", "C1", {"iterations": 400}),
    ("asa-nontc", "C1", {"iterations": 400}),
    # independent chains (heuristics.asa.parallel): each chain's generator comes from the seed
    ("asa-dtc", "C1", {"iterations": 300, "workers": 2}),
    ("asa-stc", "C1", {"iterations": 300, "workers": 2}),
    ("asa-nontc", "C1", {"iterations": 300, "workers": 2}),
    ("rds", "B1", {}),
    ("rds-stc", "B1", {}),
    ("sa-stc", "C1", {"iterations": 300}),
    ("aco-stc", "C1", {"iterations": 4}),
    ("aco-ls-stc", "C1", {"iterations": 4}),
    ("ga-stc", "C1", {"iterations": 40, "population": 8}),
    ("ts-stc", "C1", {"iterations": 40, "restart_after": 5}),
    ("pba-stc", "C1", {}),
    ("milp", "B1", {}),
    ("milp-lns", "C1", {"start": "hpfs-stc", "orbits": 1, "iterations": 5}),
    ("orbit-dp", "C1", {"iterations": 25}),
]


def _untimed(value):
    """``value`` (a result's statistics) without what depends on the clock: entries named
    ``*_s`` (seconds, rates per second) and the time column of traces."""
    if isinstance(value, dict):
        return {
            k: _trace_untimed(v) if k == "trace" else _untimed(v)
            for k, v in value.items()
            if not k.endswith("_s")
        }
    if isinstance(value, list | tuple):
        return [_untimed(v) for v in value]
    return value


def _trace_untimed(trace):
    """A trace's rows (iteration, time_s, best, ...) without their time column."""
    return [[row[0], *row[2:]] for row in trace]


def test_same_seed_covers_every_method() -> None:
    assert {m for m, _, _ in SAME_SEED} == set(METHODS)


@pytest.mark.parametrize(
    "method, name, options",
    SAME_SEED,
    ids=[f"{m}-{n}" + "".join(f"-{k}{v}" for k, v in o.items()) for m, n, o in SAME_SEED],
)
def test_same_seed_same_schedule(method: str, name: str, options: dict) -> None:
    inst = scenario(name)
    first = solve(inst, method, seed=7, check=False, **options)
    again = solve(inst, method, seed=7, check=False, **options)
    assert again.schedule.observations == first.schedule.observations
    assert again.schedule.to_dict(inst) == first.schedule.to_dict(inst)
    assert again.profit == first.profit and again.iterations == first.iterations
    if "iterations" in options:
        assert first.iterations <= options["iterations"] * options.get("workers", 1)
    assert _untimed(again.stats) == _untimed(first.stats)
    report = validate(inst, first.schedule)
    assert report.feasible, (method, report.violations[:3])
    assert report.profit == pytest.approx(first.profit)
