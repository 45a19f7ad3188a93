"""The registry is the one table: the CLI's choices are read from it, every registered bound of
the problem bounds the brute-force optimum, and a bound of another model certifies nothing."""

from __future__ import annotations

import dataclasses

import pytest

from sosp.errors import InputError
from sosp.params import Params
from sosp.registry import (
    BOUNDS,
    CERTIFYING_BOUNDS,
    METHODS,
    PROBLEM_MODEL,
    available_methods,
    compute_bound,
    param_class,
)
from sosp.solve import solve
from tests.conftest import tiny_chain
from tests.oracle import brute_force


def _choices(command: str, option: str) -> tuple[str, ...]:
    from sosp.cli import build_parser

    sub = build_parser()._subparsers._group_actions[0].choices[command]
    (action,) = [a for a in sub._actions if option in a.option_strings]
    return tuple(action.choices)


def test_cli_choices_are_the_registry() -> None:
    assert _choices("bound", "--method") == tuple(BOUNDS)
    assert _choices("solve", "--bound") == CERTIFYING_BOUNDS
    assert set(CERTIFYING_BOUNDS) == {n for n, b in BOUNDS.items() if b.model == PROBLEM_MODEL}
    assert "pba" in BOUNDS and "pba" not in CERTIFYING_BOUNDS  # the static model's


def test_every_method_has_a_parameter_class_with_help() -> None:
    for name in METHODS:
        cls = param_class(name)
        assert issubclass(cls, Params), name
        for f in dataclasses.fields(cls):
            assert f.metadata.get("help"), (name, f.name)


@pytest.mark.parametrize("name", CERTIFYING_BOUNDS)
def test_every_bound_of_the_problem_bounds_the_optimum(name: str) -> None:
    inst = tiny_chain()
    optimum = brute_force(inst, "cluster").profit  # 8; the static model's is 7
    out = compute_bound(name, inst, time_limit=20.0, lower_bound=None, workers=1)
    assert out["bound"] >= optimum - 1e-9


def test_a_bound_of_another_model_is_refused_as_a_certificate() -> None:
    assert "greedy" in available_methods()
    with pytest.raises(InputError, match="bound"):
        solve(tiny_chain(), "greedy", bound="pba")
