"""The subset-row cut pricing (:mod:`models.subset_row`) against enumeration."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from models.subset_row import (
    CutPool,
    arrange_py,
    cut_levels,
    cut_levels_py,
    label_best,
    orbit_cuts,
    violated_orbit_pairs,
    violated_triples,
)
from tests.conftest import scenario


def _orbit(rng: np.random.Generator, m: int) -> tuple[np.ndarray, ...]:
    """Random intervals [L, R): ``order`` by R, each one's rank and ``n_before``."""
    left = rng.integers(0, 4 * m, m).astype(float)
    right = left + rng.integers(1, 8, m)
    order = np.argsort(right, kind="stable")
    rank = np.empty(m, dtype=np.int64)
    rank[order] = np.arange(m)
    n_before = np.searchsorted(right[order], left, side="right").astype(np.int64)
    return order.astype(np.int64), rank, n_before


def _cuts(rng: np.random.Generator, m: int, n_cuts: int) -> tuple[list, np.ndarray]:
    hits = []
    for _ in range(n_cuts):
        # a few positions close in time (as a cut's targets are), or any
        if rng.random() < 0.7:
            lo = int(rng.integers(0, m))
            pos = np.arange(lo, min(m, lo + int(rng.integers(1, 4))))
        else:
            pos = np.sort(rng.choice(m, size=int(rng.integers(1, m + 1)), replace=False))
        hits.append((pos, rng.integers(1, 4, len(pos))))
    sigma = np.round(rng.uniform(0.0, 3.0, n_cuts), 2)
    sigma[rng.random(n_cuts) < 0.2] = 0.0
    return hits, sigma


def _enumerate(g, first, last, rank, n_before, cap, hits, sigma, inv=None) -> float:
    """The best nonempty chain's value, cut earnings ``sigma ceil(h / 2)`` exact (``sigma
    floor(h / 2)`` for the cuts ``inv`` flags)."""
    m = len(g)
    a = np.zeros((len(hits), m))
    for c, (pos, hc) in enumerate(hits):
        a[c, pos] = hc
    best = -math.inf
    by_rank = np.argsort(rank)
    for size in range(1, cap + 1):
        for chain in itertools.combinations(by_rank.tolist(), size):
            if any(rank[u] >= n_before[w] for u, w in itertools.pairwise(chain)):
                continue
            h = a[:, list(chain)].sum(axis=1)
            v = first[chain[0]] + g[list(chain)].sum() + last[chain[-1]]
            v += float(np.dot(sigma, _earned(h, inv)))
            best = max(best, v)
    return best


def _earned(h: np.ndarray, inv: np.ndarray | None) -> np.ndarray:
    """Per cut, its coefficient for a plan of ``h`` hits: ``ceil(h / 2)``, or ``floor(h /
    2)`` where ``inv``."""
    up = np.ceil(h / 2.0)
    return up if inv is None else np.where(inv, np.floor(h / 2.0), up)


def _run(kernel, g, first, last, order, n_before, cap, cuts, max_labels=512, single=0):
    return kernel(
        g + cuts.direct, first, last, order, n_before, cap, cuts.hit_ptr, cuts.hit_slot,
        cuts.hit_a, cuts.hit_sigma, cuts.hit_read, cuts.carry, cuts.keep, cuts.close,
        cuts.slot_sigma, max_labels, single, cuts.hit_inv, cuts.inv_slots,
    )  # fmt: skip


_ARRANGEMENT = (
    "hit_ptr", "hit_slot", "hit_a", "hit_sigma", "hit_read", "carry", "keep", "close",
    "slot_sigma", "direct", "hit_inv",
)  # fmt: skip


def _assert_same_arrangement(a, b) -> None:
    for field in _ARRANGEMENT:
        x, y = getattr(a, field), getattr(b, field)
        assert x.dtype == y.dtype and np.array_equal(x, y), field
    assert a.exact == b.exact
    assert a.inv_slots == b.inv_slots


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(1, 80), n_cuts=st.integers(0, 150))
def test_compiled_arrangement_equals_python(seed: int, m: int, n_cuts: int) -> None:
    """The compiled :func:`arrange_py` gives the same arrays, bit for bit, also with more
    open cuts than slots (then not exact), with and without ``floor`` cuts; a slot never
    holds both kinds."""
    rng = np.random.default_rng(seed)
    _, rank, n_before = _orbit(rng, m)
    hits, sigma = _cuts(rng, m, n_cuts)
    compiled = orbit_cuts(rank, n_before, hits, sigma)
    _assert_same_arrangement(compiled, orbit_cuts(rank, n_before, hits, sigma, kernel=arrange_py))
    assert compiled.hit_ptr[-1] == len(compiled.hit_slot)
    assert compiled.exact == _fits(rank, n_before, hits, sigma)
    assert compiled.inv_slots == 0 and not compiled.hit_inv.any()
    inv = rng.random(n_cuts) < 0.5
    mixed = orbit_cuts(rank, n_before, hits, sigma, inv=inv)
    _assert_same_arrangement(
        mixed, orbit_cuts(rank, n_before, hits, sigma, kernel=arrange_py, inv=inv)
    )
    in_inv = (mixed.inv_slots >> mixed.hit_slot) & 1
    assert np.array_equal(in_inv, mixed.hit_inv)  # each hit's slot is of its cut's kind


def _fits(rank, n_before, hits, sigma) -> bool:
    """Whether at most 64 live cuts that a plan can hit twice are open at any rank: taking
    the cuts by first rank, the lowest free slot needs exactly that many (interval graphs)."""
    depth = np.zeros(len(rank) + 1, dtype=np.int64)
    for (pos, _), s in zip(hits, sigma, strict=True):
        r = rank[pos]
        if s > 0 and len(pos) and r.min() < n_before[pos].max():
            depth[r.min()] += 1
            depth[r.max() + 1] -= 1
    return bool(np.cumsum(depth).max() <= 64)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(1, 10), n_cuts=st.integers(0, 8))
def test_cut_levels_matches_enumeration(seed: int, m: int, n_cuts: int) -> None:
    rng = np.random.default_rng(seed)
    order, rank, n_before = _orbit(rng, m)
    g = np.round(rng.uniform(-1.0, 5.0, m), 2)
    first = np.round(rng.uniform(0.0, 1.0, m), 2)
    last = np.round(rng.uniform(0.0, 1.0, m), 2)
    cap = int(rng.integers(1, 6))
    hits, sigma = _cuts(rng, m, n_cuts)
    # the floor cuts (a convexity row in the cut, models.subset_row.CutPool) on half the draws
    inv = rng.random(n_cuts) < 0.5 if seed % 2 else None
    cuts = orbit_cuts(rank, n_before, hits, sigma, inv=inv)
    assert cuts.exact
    _assert_same_arrangement(
        cuts, orbit_cuts(rank, n_before, hits, sigma, kernel=arrange_py, inv=inv)
    )
    want = _enumerate(g, first, last, rank, n_before, cap, hits, sigma, inv)
    unbounded = _enumerate(g, first, last, rank, n_before, m, hits, sigma, inv)
    for kernel in (cut_levels_py, cut_levels()):
        runs = [
            (cap, want, _run(kernel, g, first, last, order, n_before, cap, cuts)),
            (m, unbounded, _run(kernel, g, first, last, order, n_before, cap, cuts, single=1)),
            (cap, want, label_best(kernel, g + cuts.direct, first, last, order, n_before, cap,
                                   cuts)),
        ]  # fmt: skip
        for most, best, (value, path, relaxed) in runs:
            assert relaxed == 0
            assert value == pytest.approx(best, abs=1e-9)
            # the path is a chain of at most ``most`` positions worth the value returned
            assert 1 <= len(path) <= most
            assert all(rank[u] < n_before[w] for u, w in itertools.pairwise(path))
            h = np.zeros(len(hits))
            for c, (pos, hc) in enumerate(hits):
                h[c] = sum(int(hc[list(pos).index(u)]) for u in path if u in pos)
            got = first[path[0]] + g[path].sum() + last[path[-1]]
            assert got + np.dot(sigma, _earned(h, inv)) == pytest.approx(value, abs=1e-9)


def test_without_cuts_the_kernel_is_the_planner_recursion() -> None:
    from sosp.recursion import levels_py

    rng = np.random.default_rng(3)
    for _ in range(50):
        m = int(rng.integers(1, 40))
        order, rank, n_before = _orbit(rng, m)
        g = rng.uniform(-1.0, 5.0, m)
        first, last = rng.uniform(0, 1, m), rng.uniform(0, 1, m)
        cap = int(rng.integers(1, 8))
        cuts = orbit_cuts(rank, n_before, [], np.zeros(0))
        value, path, _ = _run(cut_levels(), g, first, last, order, n_before, cap, cuts)
        want, want_path = levels_py(g, first, last, order, n_before, cap)
        assert value == pytest.approx(want)


def test_pairwise_incompatible_cut_is_priced_outright() -> None:
    # three positions overlapping in time: no two on one plan, so no bit is needed
    rank = np.array([0, 1, 2])
    n_before = np.zeros(3, dtype=np.int64)
    cuts = orbit_cuts(rank, n_before, [(np.array([0, 2]), np.array([1, 3]))], np.array([2.0]))
    assert cuts.hit_ptr[-1] == 0
    assert cuts.direct.tolist() == [2.0, 0.0, 4.0]


def test_more_open_cuts_than_slots_are_priced_optimistically() -> None:
    m = 2
    order, rank = np.array([0, 1]), np.array([0, 1])
    n_before = np.array([0, 1])
    hits = [(np.array([0, 1]), np.array([1, 1]))] * 70
    cuts = orbit_cuts(rank, n_before, hits, np.ones(70))
    assert not cuts.exact
    assert cuts.direct.tolist() == [6.0, 6.0]  # the six left over earn at every hit
    g = np.array([100.0, 100.0])
    z = np.zeros(m)
    value, path, _ = _run(cut_levels(), g, z, z, order, n_before, 2, cuts)
    # both observed: 200 and one earning per cut (ceil(2 / 2)); the six unslotted earn twice
    assert value == pytest.approx(200.0 + 64.0 + 2 * 6.0)
    assert value >= 200.0 + 70.0  # never below the true best
    assert path.tolist() == [0, 1]


def test_a_shared_slot_never_reads_the_earlier_cuts_bit() -> None:
    # p0 [0, 1), p1 [2, 6) hit cut A; p2 [4, 7), p3 [8, 9) hit cut B. A's ranks (0, 1) end
    # before B's (2, 3), so both take slot 0; p2's prefix (p0) still holds A's bit there.
    left, right = np.array([0.0, 2, 4, 8]), np.array([1.0, 6, 7, 9])
    order = np.argsort(right).astype(np.int64)
    rank = np.arange(4, dtype=np.int64)
    n_before = np.searchsorted(right[order], left, side="right").astype(np.int64)
    hits = [(np.array([0, 1]), np.array([1, 1])), (np.array([2, 3]), np.array([1, 1]))]
    cuts = orbit_cuts(rank, n_before, hits, np.array([1.0, 1.0]))
    assert cuts.close.tolist()[:4] == [0, 1, 0, 1]  # one slot, reused
    g = np.array([5.0, -100.0, 5.0, -100.0])
    z = np.zeros(4)
    for kernel in (cut_levels_py, cut_levels()):
        value, path, _ = _run(kernel, g, z, z, order, n_before, 3, cuts)
        assert path.tolist() == [0, 2]
        assert value == pytest.approx(10.0 + 1.0 + 1.0)  # each cut hit once, earned once


def test_a_floor_cuts_set_bit_is_worth_keeping() -> None:
    # p0 [0, 1) and p1 [0.5, 1.5) overlap, both precede p2 [2, 3); a floor cut (sigma 5)
    # is hit once by p0 and once by p2. p1's label (value 2, bit clear) must not dominate
    # p0's (value 1, bit set): its next hit, at p2, earns floor(2 / 2) = 1 only after p0.
    left, right = np.array([0.0, 0.5, 2.0]), np.array([1.0, 1.5, 3.0])
    order = np.argsort(right).astype(np.int64)
    rank = np.arange(3, dtype=np.int64)
    n_before = np.searchsorted(right[order], left, side="right").astype(np.int64)
    hits = [(np.array([0, 2]), np.array([1, 1]))]
    g, z = np.array([1.0, 2.0, 0.0]), np.zeros(3)
    for inv, best, path in ((np.array([True]), 6.0, [0, 2]), (None, 7.0, [1, 2])):
        cuts = orbit_cuts(rank, n_before, hits, np.array([5.0]), inv=inv)
        assert cuts.exact and cuts.inv_slots == (0 if inv is None else 1)
        for kernel in (cut_levels_py, cut_levels()):
            value, found, _ = _run(kernel, g, z, z, order, n_before, 3, cuts)
            assert value == pytest.approx(best)
            assert found.tolist() == path


def test_a_floor_cut_no_plan_hits_twice_is_priced_outright() -> None:
    # as the ceil cut above, but a plan earns floor(a / 2): 0 for one hit, 1 for three
    rank = np.array([0, 1, 2])
    n_before = np.zeros(3, dtype=np.int64)
    hits = [(np.array([0, 2]), np.array([1, 3]))]
    cuts = orbit_cuts(rank, n_before, hits, np.array([2.0]), inv=np.array([True]))
    assert cuts.hit_ptr[-1] == 0 and cuts.exact
    assert cuts.direct.tolist() == [0.0, 0.0, 2.0]


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(2, 10), n_cuts=st.integers(2, 8))
def test_merged_labels_only_over_estimate(seed: int, m: int, n_cuts: int) -> None:
    # with room for one label the structure merges the others into optimistic ones: the
    # value may rise above the best plan's, never fall below it, and says so
    rng = np.random.default_rng(seed)
    order, rank, n_before = _orbit(rng, m)
    g = np.round(rng.uniform(-1.0, 5.0, m), 2)
    z = np.zeros(m)
    cap = int(rng.integers(1, 6))
    hits, sigma = _cuts(rng, m, n_cuts)
    inv = rng.random(n_cuts) < 0.5 if seed % 2 else None  # merged floor bits are or-ed
    cuts = orbit_cuts(rank, n_before, hits, sigma, inv=inv)
    want = _enumerate(g, z, z, rank, n_before, cap, hits, sigma, inv)
    for value, _, relaxed in (
        _run(cut_levels(), g, z, z, order, n_before, cap, cuts, max_labels=1),
        label_best(cut_levels(), g + cuts.direct, z, z, order, n_before, cap, cuts, 1),
    ):
        assert value >= want - 1e-9
        if relaxed == 0:
            assert value == pytest.approx(want, abs=1e-9)


def test_violated_triples_finds_the_odd_cycle_and_only_it() -> None:
    # three plans each covering two of targets 0-2 at y = 1/2 (z = 1): the cut over {0, 1,
    # 2} reads 3 - 3 * 1/2 = 1.5 > 1; target 3, covered once by a whole plan, is in no
    # violated triple
    cover = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [1, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
    w = np.array([0.5, 0.5, 0.5, 1.0])
    found = violated_triples(cover, w, np.ones(4))
    assert [t[1:] for t in found] == [(0, 1, 2)]
    assert found[0][0] == pytest.approx(0.5)
    # an integral solution violates nothing
    whole = np.array([[1, 1, 0, 0], [0, 0, 1, 1]], dtype=float)
    assert violated_triples(whole, np.ones(2), np.ones(4)) == []


def _largest_c2_orbit(seed: int, n_cuts: int) -> tuple:
    """C2's largest orbit g with ``n_cuts`` random triples of its targets in a pool:
    ``(pool, g, price, rng)``, ``price`` random on 30 % of the targets."""
    from sosp.planner import orbit_data

    inst = scenario("C2")
    groups = orbit_data(inst).orbits
    rng = np.random.default_rng(seed)
    pool = CutPool(groups)
    g = int(np.argmax([o.size for o in groups]))
    for _ in range(n_cuts):
        pool.add(rng.choice(groups[g].targets, 3, replace=False).tolist())
    price = rng.uniform(0.0, 2.0, inst.n_targets) * (rng.random(inst.n_targets) < 0.3)
    return pool, g, price, rng


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_positions_that_cannot_help_are_dropped_without_changing_the_price(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    # CutPool.best_path restricts an orbit to the positions whose gain, each cut earning its
    # most, beats their observing penalty: the best value must not move
    import models.subset_row as sr

    pool, g, price, rng = _largest_c2_orbit(seed, 20)
    sigma = rng.uniform(0.0, 3.0, len(pool)) * (rng.random(len(pool)) < 0.5)
    lam = np.array([rng.uniform(0, 5), rng.uniform(0, 5)])
    got = {}
    for share in (0.0, 2.0):  # never restrict, restrict whenever a position is dropped
        monkeypatch.setattr(sr, "KEEP_SHARE", share)
        pool._entries.clear()
        got[share] = pool.best_path(g, price, lam, sigma)
    assert got[2.0][2]  # fewer positions: every cut has its slot
    if got[0.0][2]:
        assert got[2.0][0] == pytest.approx(got[0.0][0], rel=1e-9, abs=1e-9)
    else:  # the whole orbit priced some cut optimistically: an over-estimate
        assert got[2.0][0] <= got[0.0][0] + 1e-9
    assert got[2.0][0] > 0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cuts_priced_exactly_where_the_planner_prunes(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    # on orbits the planner prunes (from PRUNE_FROM positions), the cut pricing still runs
    # the exact recursion: the same value as unpruned, and exact (japan-500's two orbits of
    # 110,000+ positions had been priced with each hit earning sigma, a loose over-estimate)
    import models.subset_row as sr
    import sosp.planner as planner

    pool, g, price, rng = _largest_c2_orbit(seed, 10)
    sigma = rng.uniform(0.5, 3.0, len(pool))
    got = {}
    for prune_from in (10**9, 1):
        monkeypatch.setattr(planner, "PRUNE_FROM", prune_from)
        # also any copy of the threshold the cut pricing keeps (it imported one before)
        monkeypatch.setattr(sr, "PRUNE_FROM", prune_from, raising=False)
        pool._entries.clear()
        got[prune_from] = pool.best_path(g, price, np.zeros(2), sigma)
    assert got[1][2] and got[10**9][2]
    assert got[1][0] == pytest.approx(got[10**9][0], rel=1e-9, abs=1e-9)
    assert np.array_equal(got[1][1], got[10**9][1])


def _cut_value(cover, w, z, orbit, targets, orbits) -> float:
    """The violation of the cut over ``targets`` and ``orbits`` from its definition (the
    plans' coefficients ``ceil`` or ``floor`` of their hits over two, the right side)."""
    h = cover[:, list(targets)].sum(axis=1)
    coef = np.where(np.isin(orbit, list(orbits)), np.floor(h / 2), np.ceil(h / 2))
    return float(z[list(targets)].sum() - coef @ w - (len(targets) + len(orbits)) // 2)


def test_violated_orbit_pairs_finds_the_split_pair_and_only_it() -> None:
    # tests/models/instances.split_pair's master: orbit 0 half on a, half on b; orbit 1 half
    # on {a, b}, half on d. The cut over {a, b} and orbit 0 reads 2 - 1/2 = 1.5 > 1.
    cover = np.array([[1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]], dtype=float)
    w = np.full(4, 0.5)
    z = np.array([1.0, 1.0, 0.5])
    orbit = np.array([0, 0, 1, 1])
    found = violated_orbit_pairs(cover, w, z, orbit)
    assert [f[1:] for f in found] == [(0, 1, 0)]
    assert found[0][0] == pytest.approx(0.5)
    assert found[0][0] == pytest.approx(_cut_value(cover, w, z, orbit, (0, 1), (0,)))
    # an integral solution violates nothing
    assert violated_orbit_pairs(cover[[2]], np.ones(1), np.array([1.0, 1.0, 0.0]), orbit[[2]]) == []


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_violated_orbit_pairs_are_the_cuts_violations(seed: int) -> None:
    # every pair reported is violated by what the cut's definition says, and every violated
    # pair (of targets some two plans cover together enough to be searched) is reported
    rng = np.random.default_rng(seed)
    n_plans, n_targets = int(rng.integers(2, 9)), int(rng.integers(2, 7))
    cover = (rng.random((n_plans, n_targets)) < 0.5).astype(float)
    w = np.round(rng.uniform(0.0, 1.0, n_plans), 2)
    orbit = rng.integers(0, 3, n_plans)
    z = np.minimum(1.0, cover.T @ w) * rng.choice([1.0, 0.8], n_targets)
    found = {f[1:]: f[0] for f in violated_orbit_pairs(cover, w, z, orbit)}
    pair = (cover * w[:, None]).T @ cover
    np.fill_diagonal(pair, 0.0)
    searched = np.flatnonzero(pair.sum(axis=1) > 0.3)
    for a, b in itertools.combinations(searched.tolist(), 2):
        for j in np.unique(orbit).tolist():
            v = _cut_value(cover, w, z, orbit, (a, b), (j,))
            if v > 1e-3:
                assert found.pop((a, b, j)) == pytest.approx(v)
    assert not found


def test_cut_pool_coefficients_read_the_orbits() -> None:
    from sosp.planner import orbit_data
    from tests.models.instances import split_pair

    pool = CutPool(orbit_data(split_pair()).orbits)
    c = pool.add([0, 1], [0])
    assert pool.add([1, 0], [0]) is None and pool.rhs[c] == 1
    both = np.array([0, 1])
    assert pool.coefficients(both, np.array([1, 1]), 1) == {c: 1}  # ceil(2 / 2)
    assert pool.coefficients(both, np.array([1, 1]), 0) == {c: 1}  # floor(2 / 2)
    assert pool.coefficients(np.array([0]), np.array([1]), 0) == {}  # floor(1 / 2)
    assert pool.coefficients(np.array([0]), np.array([1]), 1) == {c: 1}
    for bad in (([0, 1], []), ([0, 1, 2], [0]), ([0], [0, 1]), ([0, 0, 1], [])):
        with pytest.raises(ValueError):
            pool.add(*bad)
