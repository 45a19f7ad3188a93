"""ASA-DTC refuses, with one line, an instance whose conflict lists would not fit."""

from __future__ import annotations

import pytest

import heuristics.asa.problem as problem
from sosp.errors import InputError
from sosp.scenarios import generate_scenario
from sosp.solve import solve


def test_too_many_conflicts_is_one_line(monkeypatch) -> None:
    inst = generate_scenario("C1", 0)
    monkeypatch.setattr(problem, "MAX_CONFLICTS", 5)
    with pytest.raises(InputError, match=r"^instance: more than 5 setup conflicts .*hpfs-stc\)$"):
        solve(inst, "asa-dtc", seed=0, iterations=10)
