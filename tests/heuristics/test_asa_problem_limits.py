"""An instance whose conflict lists would not fit: the ASA variants refuse it with one line,
and ASA-DTC (the default method, and ``milp``'s schedule without a model) answers with the
search it starts from."""

from __future__ import annotations

import pytest

import heuristics.asa.problem as problem
from sosp.errors import InputError
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario
from tests.limits import limit_kept


@pytest.fixture(scope="module")
def c1():
    return scenario("C1")


@pytest.mark.parametrize("method", ["asa-stc", "asa-nontc"])
def test_a_variant_refuses_too_many_conflicts_in_one_line(monkeypatch, c1, method) -> None:
    monkeypatch.setattr(problem, "MAX_CONFLICTS", 5)
    with pytest.raises(InputError, match=r"^instance: more than 5 setup conflicts .*hpfs-stc\)$"):
        solve(c1, method, seed=0, iterations=10)


@pytest.mark.limits
def test_asa_dtc_answers_with_its_start_search_when_the_lists_do_not_fit(
    monkeypatch, c1, caplog
) -> None:
    monkeypatch.setattr(problem, "MAX_CONFLICTS", 5)
    res = solve(c1, "asa-dtc", seed=0, time_limit=2.0)
    assert res.method == "orbit-dp" and res.stats["fallback"] == "orbit-dp"  # what ran
    assert [(st.kind, st.name) for st in res.stages] == [("method", "orbit-dp")]  # what ran
    assert "more than 5 setup conflicts" in res.stats["fallback_reason"]
    assert "orbit-dp's search" in caplog.text
    report = validate(c1, res.schedule)
    assert report.feasible and report.profit == res.profit > 0
    limit_kept("asa-dtc fallback, 2 s", res.runtime_s, 3.0)


def test_the_fallback_start_answers_through_asa_dtc(monkeypatch, c1) -> None:
    """The start a solve falls back to when orbit-dp's candidates are not ready in its share
    (:data:`sosp.pipeline.FALLBACK_START`, ASA-DTC: then ``milp``'s schedule when its model
    cannot be built) must answer on every instance."""
    import numpy as np

    from sosp.pipeline import FALLBACK_START
    from sosp.registry import method_function

    monkeypatch.setattr(problem, "MAX_CONFLICTS", 5)
    res = method_function(FALLBACK_START)(c1, rng=np.random.default_rng(0), time_limit=3.0)
    assert FALLBACK_START == "asa-dtc"
    report = validate(c1, res.schedule)
    assert report.feasible and report.profit > 0
