"""sosp.stop.Budget: sub-budgets never outlast their parent, a stop request expires every
budget, no limit stays no limit, and the memory limit is carried down."""

from __future__ import annotations

import pickle
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sosp.stop import Budget, clear_stop, request_stop


@pytest.fixture(autouse=True)
def _no_stop():
    clear_stop()
    yield
    clear_stop()


@given(
    limit=st.floats(0.0, 1e6),
    fraction=st.floats(0.0, 10.0),
    seconds=st.none() | st.floats(0.0, 1e7),
)
def test_a_sub_budget_never_ends_after_its_parent(limit, fraction, seconds) -> None:
    parent = Budget.of(limit, memory=123)
    for sub in (parent.share(fraction), parent.child(seconds), parent.child(fraction=fraction)):
        assert sub.deadline is not None and sub.deadline <= parent.deadline
        assert sub.memory == 123
        assert sub.child(seconds, fraction=fraction).deadline <= sub.deadline


def test_a_share_is_that_part_of_the_time_left() -> None:
    parent = Budget.of(100.0)
    half = parent.share(0.5)
    assert 49.0 < half.left() <= 50.0
    assert parent.child(10.0).left() <= 10.0
    assert parent.child(1000.0).deadline == parent.deadline


def test_no_limit_stays_no_limit() -> None:
    free = Budget.of(None)
    assert free == Budget.until(None) == Budget()
    for sub in (free.share(0.1), free.child(fraction=0.5), free.child()):
        assert sub.deadline is None and sub.left() is None and sub.deadline is None
        assert not sub.expired() and sub.fits(1e12)
    assert free.child(5.0).left() <= 5.0  # seconds cap an unlimited parent


def test_a_stop_request_expires_every_budget() -> None:
    budgets = [Budget(), Budget.of(1e6), Budget.of(1e6).share(0.5)]
    assert not any(b.expired() for b in budgets)
    request_stop("test")
    assert all(b.expired() for b in budgets)
    assert not any(b.fits(0.0) for b in budgets)
    clear_stop()
    assert not any(b.expired() for b in budgets)


def test_time_runs_out() -> None:
    assert Budget.of(0.0).expired() and Budget.of(0.0).left() == 0.0
    assert Budget.until(time.perf_counter() - 1.0).expired()
    b = Budget.of(0.02)
    assert not b.fits(60.0)
    time.sleep(0.03)
    assert b.expired() and b.left() == 0.0 and b.share(0.5).expired()


def test_until_keeps_the_deadline_and_pickles() -> None:
    t = time.perf_counter() + 30.0
    b = Budget.until(t, memory=1 << 30)
    assert b.deadline == t and b.memory == 1 << 30
    assert pickle.loads(pickle.dumps(b)) == b
