"""Parameters read from ``--param`` strings by their dataclass's type hints (sosp.params)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import pytest

from heuristics.asa.params import PRESETS, ASAParams
from sosp import params as P
from sosp.errors import InputError


@dataclass(frozen=True)
class Knobs:
    count: int = 3
    share: float = 0.5
    flag: bool = False
    rule: Literal["a", "b"] = "a"
    limit: int | None = None

    def __post_init__(self) -> None:
        P.check_types(self)


def test_strings_take_the_field_types() -> None:
    k = P.from_kwargs(
        Knobs,
        {"count": "7", "share": "0.25", "flag": "yes", "rule": "b", "limit": "none"},
        method="knobs",
    )
    assert k == Knobs(count=7, share=0.25, flag=True, rule="b", limit=None)
    assert P.from_kwargs(Knobs, {"limit": "12"}, method="knobs").limit == 12


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"count": "1.5"}, "count: expected an integer"),
        ({"share": "half"}, "share: expected a number"),
        ({"flag": "maybe"}, "flag: expected true or false"),
        ({"rule": "c"}, "rule: expected one of a, b"),
        ({"flag": 1}, "flag: expected true or false"),
        (
            {"nope": 1},
            r"knobs: unknown parameter 'nope' \(valid: count, flag, limit, rule, share\)",
        ),
    ],
)
def test_bad_values_name_the_field(kw: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        P.from_kwargs(Knobs, kw, method="knobs")


def test_choices_of_a_literal_field() -> None:
    types = P.field_types(Knobs)
    assert P.choices(types["rule"]) == ("a", "b")


def test_asa_presets() -> None:
    default = ASAParams()
    assert ASAParams.from_kwargs(preset="quality") == default
    paper = ASAParams.from_kwargs(preset="paper")
    # Table 2 and Algorithm 1 as published
    assert (paper.lambda_min, paper.rho, paper.delta, paper.eta, paper.itr) == (
        0.5,
        1.0,
        10.0,
        0.8,
        10,
    )
    assert (paper.pro1, paper.pro2, paper.replan, paper.restart) == (0.5, 0.5, False, None)
    assert (paper.roll_rule, paper.nadir_singles) == ("midpoint", False)
    # the paper's self-contradicting rules read as docs/asa.md decides (decisions 3 and 5)
    assert (paper.rule16_openings, paper.option_rule) == (True, "feasible-first")
    # keywords override the preset
    assert ASAParams.from_kwargs(preset="paper", rho="0.3").rho == 0.3
    assert set(PRESETS) == {"default", "quality", "paper"}
    with pytest.raises(InputError, match="preset: expected one of"):
        ASAParams.from_kwargs(preset="fast")
