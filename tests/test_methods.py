"""The contract every registered method keeps (``sosp.registry.METHODS``), checked for all of them.

On random tiny instances: the schedule passes the validator (the referee), its profit is never
above the brute-force optimum of the clustering-exact problem (``tests/oracle.py``; static and
no-clustering methods solve restrictions of it), and the same seed gives the same schedule.
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
from tests.conftest import small_instances, tiny_cluster
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
