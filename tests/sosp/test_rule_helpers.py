"""The vectorised rule helpers of :mod:`sosp.rules` against scalar references written here
from ``docs/model.md`` (one element or one group at a time, plain Python)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sosp.errors import InputError
from sosp.rules import (
    EPS,
    choose_roll,
    group_roll_ranges,
    may_precede,
    range_empty,
    roll_in_range,
    starts_within,
    within_duration,
)

SEEDS = st.integers(0, 2**32 - 1)


def _ranges(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Roll ranges [lo, hi] of opportunities (degrees): 6 deg wide, clipped to +-33."""
    centre = rng.uniform(-36.0, 36.0, n)
    return np.maximum(centre - 3.0, -33.0), np.minimum(centre + 3.0, 33.0)


def _groups(rng: np.random.Generator, n: int, n_groups: int) -> tuple[np.ndarray, np.ndarray]:
    """Non-empty groups of members (indices below n), as ``ptr``, ``flat``."""
    sizes = rng.integers(1, 5, n_groups)
    ptr = np.zeros(n_groups + 1, dtype=np.int64)
    np.cumsum(sizes, out=ptr[1:])
    return ptr, rng.integers(0, n, int(ptr[-1]))


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, n_groups=st.integers(1, 40), block=st.integers(1, 7))
def test_group_roll_ranges_are_each_groups_common_range(seed, n_groups, block) -> None:
    rng = np.random.default_rng(seed)
    lo, hi = _ranges(rng, 30)
    ptr, flat = _groups(rng, 30, n_groups)
    glo, ghi = group_roll_ranges(lo, hi, ptr, flat, block=block)
    for g in range(n_groups):
        members = flat[ptr[g] : ptr[g + 1]].tolist()
        assert glo[g] == max(float(lo[x]) for x in members)  # (8)
        assert ghi[g] == min(float(hi[x]) for x in members)
        assert bool(range_empty(glo[g], ghi[g])) == (glo[g] > ghi[g])


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, rule=st.sampled_from(["midpoint", "nadir"]))
def test_choose_roll_on_arrays_is_the_scalar_rule(seed, rule) -> None:
    rng = np.random.default_rng(seed)
    lo, hi = _ranges(rng, 50)
    lo[:5] = np.sort(rng.uniform(-5.0, 5.0, 5))  # ranges holding nadir
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    rolls = choose_roll(lo, hi, rule)
    for a, b, r in zip(lo.tolist(), hi.tolist(), rolls.tolist(), strict=True):
        want = (a + b) / 2.0 if rule == "midpoint" else (a if a > 0 else b if b < 0 else 0.0)
        assert r == pytest.approx(want, abs=1e-12)
        assert choose_roll(a, b, rule) == r  # the scalar path gives the same float
        assert a - EPS <= r <= b + EPS  # (7)
        if rule == "nadir":  # never farther from nadir than the midpoint
            assert abs(r) <= abs(choose_roll(a, b, "midpoint")) + 1e-12
    with pytest.raises(InputError):
        choose_roll(lo, hi, "leftmost")  # type: ignore[arg-type]


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS)
def test_roll_in_range_is_the_elementwise_test(seed) -> None:
    rng = np.random.default_rng(seed)
    lo, hi = _ranges(rng, 40)
    roll = rng.uniform(-36.0, 36.0, 40)
    roll[:4] = lo[:4] - EPS / 2  # within the margin of the ends: inside
    roll[4:8] = hi[4:8] + 2 * EPS  # just past the margin: outside
    got = roll_in_range(roll, lo, hi)
    for r, a, b, g in zip(roll.tolist(), lo.tolist(), hi.tolist(), got.tolist(), strict=True):
        assert g == (a - EPS <= r <= b + EPS)
    assert got[:4].all() and not got[4:8].any()
    grid = roll_in_range(roll[None, :], lo[:, None], hi[:, None])  # broadcasts
    assert grid.shape == (40, 40) and (np.diagonal(grid) == got).all()


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, limit=st.floats(1.0, 200.0))
def test_starts_within_counts_the_starts_one_window_may_cover(seed, limit) -> None:
    rng = np.random.default_rng(seed)
    start = np.sort(rng.uniform(0.0, 1000.0, 60))
    start[10] = start[9] + limit + EPS / 2  # within Delta T and the margin of start[9]
    start = np.sort(start)
    stop = starts_within(start, limit)
    for i, s in enumerate(start.tolist()):
        last = max(k for k, t in enumerate(start.tolist()) if within_duration(s, t, limit))
        assert stop[i] == last + 1  # (11): the run [i, stop) starts within Delta T of s
    at = rng.uniform(-50.0, 1000.0, 10)
    got = starts_within(start, limit, at)
    assert got.tolist() == [sum(t <= a + limit + EPS for t in start.tolist()) for a in at.tolist()]


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS)
def test_may_precede_is_r_at_most_l_with_the_margin(seed) -> None:
    rng = np.random.default_rng(seed)
    right, left = rng.uniform(0.0, 100.0, 30), rng.uniform(0.0, 100.0, 30)
    left[:3] = right[:3]  # touching: may precede, not with room asked for
    for margin in (EPS, -EPS):
        got = may_precede(right, left, margin)
        for r, lft, g in zip(right.tolist(), left.tolist(), got.tolist(), strict=True):
            assert g == (r <= lft + margin)
    assert may_precede(right[:3], left[:3]).all()
    assert not may_precede(right[:3], left[:3], -EPS).any()


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS, n=st.integers(0, 8), ends_paid=st.booleans())
def test_budget_between_is_what_the_rest_of_the_orbit_leaves(seed, n, ends_paid) -> None:
    from heuristics.timeline import OrbitTimeline
    from sosp.rules import OrbitRules

    rng = np.random.default_rng(seed)
    # W, w, E, eo, es, v, a, c, Delta T
    r = OrbitRules(1000.0, 1.0, 1500.0, 1.0, 2.0, 1.5, 10.0, 10, 120.0)
    start = np.sort(rng.uniform(0.0, 5000.0, n)).tolist()
    end = [s + d for s, d in zip(start, rng.uniform(1.0, 60.0, n).tolist(), strict=True)]
    entries = list(zip(start, end, rng.uniform(-33.0, 33.0, n).tolist(), strict=True))
    line = OrbitTimeline(r)
    line.load(entries)
    first = int(rng.integers(0, n + 1))
    last = int(rng.integers(first - 1, n))
    kept = entries[:first] + entries[last + 1 :]
    # the reference: the kept entries' own (4)-(6), without the neighbours' turn
    observe = sum(e - s for s, e, _ in kept)
    slew = sum((abs(a[2]) + abs(b[2])) / r.slew_rate for a, b in zip(kept, kept[1:], strict=False))
    ends = [entries[k] for k in (first - 1, last + 1) if 0 <= k < n]
    if len(ends) == 2:
        slew -= (abs(ends[0][2]) + abs(ends[1][2])) / r.slew_rate
    if ends_paid:
        slew += sum(abs(e[2]) / r.slew_rate for e in ends)
    energy, memory, openings = line.budget_between(first, last, ends_paid=ends_paid)
    assert energy == pytest.approx(1500.0 - observe - 2.0 * slew, abs=1e-9)
    assert memory == pytest.approx(1000.0 - observe, abs=1e-9)
    assert openings == 10 - len(kept)
