"""Tiny named instances shared by the tests (hand-built: opportunities given directly)."""

from __future__ import annotations

import copy
import functools

import pytest
from hypothesis import strategies as st

from sosp.instance import Instance, Resources
from sosp.scenarios import generate_scenario


def tiny_chain() -> Instance:
    """One orbit, three targets in time order; b and c conflict by setup time (3).

    a [0, 4] roll 10, b [10, 14] roll 1, c [30, 34] roll -5: a-b gap 6 < 10 + 11;
    b-c gap 16 = 10 + 6 (just feasible); a-c gap 26 >= 10 + 15.
    """
    return Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [("a", 0, 0, 4, 10.0), ("b", 0, 10, 14, 1.0), ("c", 0, 30, 34, -5.0)],
        name="tiny_chain",
    )


def tiny_cluster() -> Instance:
    """One orbit; a and b overlap in time and share rolls [8, 12]: one opening covers both.

    Alone they conflict by (3); clustered, their window is [0, 9] at roll 10.
    """
    return Instance.build(
        {"a": 5, "b": 4, "c": 2},
        [
            ("a", 0, 0.0, 4.0, 11.0, 8.0, 14.0),
            ("b", 0, 5.0, 9.0, 9.0, 6.0, 12.0),
            ("c", 0, 60.0, 64.0, -20.0, -23.0, -17.0),
        ],
        name="tiny_cluster",
    )


def tiny_two_orbits() -> Instance:
    """Two orbits; target a is visible on both, b only on orbit 0 where it conflicts with a."""
    return Instance.build(
        {"a": 6, "b": 5},
        [("a", 0, 0, 5, 20.0), ("b", 0, 8, 12, -20.0), ("a", 1, 100, 105, 0.0)],
        name="tiny_two_orbits",
    )


def tiny_openings() -> Instance:
    """One orbit with max_openings 2 and four well-spaced targets: (6) binds."""
    return Instance.build(
        {"a": 1, "b": 2, "c": 3, "d": 4},
        [
            ("a", 0, 0, 2, 0.0),
            ("b", 0, 100, 102, 0.0),
            ("c", 0, 200, 202, 0.0),
            ("d", 0, 300, 302, 0.0),
        ],
        resources=Resources(max_openings=2),
        name="tiny_openings",
    )


TINY = {
    "tiny_chain": tiny_chain,
    "tiny_cluster": tiny_cluster,
    "tiny_two_orbits": tiny_two_orbits,
    "tiny_openings": tiny_openings,
}


@pytest.fixture(params=sorted(TINY))
def tiny(request: pytest.FixtureRequest) -> Instance:
    """Each tiny named instance in turn."""
    return TINY[request.param]()


# ------------------------------------------------------------- the paper's generated scenarios
@functools.cache
def _generated(name: str, seed: int) -> Instance:
    return generate_scenario(name, seed)


def scenario(name: str, seed: int = 0) -> Instance:
    """The paper's scenario ``name`` (``generate_scenario(name, seed)``), generated once per test
    process (each xdist worker has its own cache).

    The instance's arrays are read-only; each call returns a shallow copy with its own ``meta``,
    so a test that edits the metadata (or sets attributes) does not change another test's copy.
    """
    inst = copy.copy(_generated(name, seed))
    object.__setattr__(inst, "meta", copy.deepcopy(dict(inst.meta)))
    return inst


@pytest.fixture
def b1() -> Instance:
    return scenario("B1")


@pytest.fixture
def b2() -> Instance:
    return scenario("B2")


@pytest.fixture
def b3() -> Instance:
    return scenario("B3")


@pytest.fixture
def c1() -> Instance:
    return scenario("C1")


@pytest.fixture
def c2() -> Instance:
    return scenario("C2")


@pytest.fixture
def c3() -> Instance:
    return scenario("C3")


@pytest.fixture
def c5() -> Instance:
    return scenario("C5")


# ------------------------------------------------------------------- the random-instance strategy
@st.composite
def small_instances(draw: st.DrawFn, max_opps: int = 9) -> Instance:
    """Random tiny instances for property tests (every solver's and the validator's): one or
    two orbits, up to five targets, up to ``max_opps`` opportunities, tight or loose
    resources, small enough for the brute-force oracle (``tests/oracle.py``)."""
    n_orbits = draw(st.integers(1, 2))
    n_targets = draw(st.integers(1, 5))
    weights = draw(st.lists(st.integers(2, 10), min_size=n_targets, max_size=n_targets))
    n = draw(st.integers(1, max_opps))
    rows = []
    for _ in range(n):
        k = draw(st.integers(0, n_targets - 1))
        j = draw(st.integers(0, n_orbits - 1))
        s = float(draw(st.integers(0, 120)))
        d = float(draw(st.integers(1, 12)))
        r = float(draw(st.integers(-33, 33)))
        rows.append((k, j, s, s + d, r))
    res = Resources(
        energy_capacity=float(draw(st.sampled_from([40, 90, 1500]))),
        memory_capacity=float(draw(st.sampled_from([15, 40, 1000]))),
        max_openings=draw(st.integers(1, 4)),
        max_duration=float(draw(st.sampled_from([10, 30, 120]))),
        setup_time=float(draw(st.sampled_from([2, 10]))),
    )
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits)
