"""Independent ASA chains (``workers > 1``, :mod:`heuristics.asa.parallel`)."""

from __future__ import annotations

import numpy as np
import pytest

from heuristics.asa.parallel import run_parallel
from heuristics.asa.params import ASAParams
from heuristics.asa.search import Search
from sosp.errors import InputError
from sosp.solve import solve
from tests.conftest import scenario, tiny_cluster, tiny_two_orbits
from tests.limits import limit_kept
from tests.oracle import brute_force


@pytest.fixture(scope="module")
def c1():
    # C2, not C1: ASA-DTC observes all of C1's targets within 113 iterations and then stops
    # (nothing is left to find), and these tests count the chains' iterations
    return scenario("C2")


def test_chains_differ_and_the_best_is_returned(c1) -> None:
    res = solve(c1, "asa-dtc", seed=5, iterations=200, workers=2)
    chains = res.stats["chains"]
    assert len(chains) == 2 and res.stats["workers"] == 2
    assert res.profit == max(c["best"] for c in chains)
    assert res.iterations == sum(c["iterations"] for c in chains) == 400
    # The chains' generators differ.
    seeds = np.random.default_rng(5).spawn(2)
    assert seeds[0].random() != seeds[1].random()


def test_never_beats_the_optimum_on_tiny_instances() -> None:
    for inst in (tiny_cluster(), tiny_two_orbits()):
        res = solve(inst, "asa-dtc", seed=0, iterations=50, workers=2)
        assert res.profit == brute_force(inst, "cluster").profit


@pytest.mark.limits
def test_time_limit_and_no_improve_stop_the_chains(c1) -> None:
    res = solve(c1, "asa-dtc", seed=0, time_limit=2.0, workers=2)
    assert all(c["iterations"] > 0 for c in res.stats["chains"])
    limit_kept("two chains, 2 s", res.runtime_s, 3.0)
    res = solve(c1, "asa-dtc", seed=0, no_improve=50, workers=2)
    assert all(c["iterations"] >= 50 for c in res.stats["chains"])


@pytest.mark.parametrize("kw", [{"workers": 0}, {"workers": "two"}, {"epochs": 3}])
def test_bad_workers(kw: dict) -> None:
    with pytest.raises(InputError, match=next(iter(kw))):
        solve(tiny_cluster(), "asa-dtc", seed=0, iterations=10, **kw)


def test_a_failing_chain_is_reported_and_the_others_stopped(c1, monkeypatch) -> None:
    # Under fork the children inherit the patched method; a chain failing to build its search
    # must surface as an error in the parent, not as a hang.
    import multiprocessing as mp

    if mp.get_start_method() != "fork":
        pytest.skip("needs the fork start method to inject the failure")

    def broken(self, *a, **k):
        raise ValueError("boom")

    monkeypatch.setattr(Search, "__init__", broken)
    with pytest.raises(RuntimeError, match="chain 0: ValueError: boom"):
        run_parallel(
            c1,
            "dtc",
            rng=np.random.default_rng(0),
            time_limit=None,
            params=ASAParams(workers=2, iterations=10),
        )
