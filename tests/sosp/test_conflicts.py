"""The setup-conflict sweep and static clustering against brute force and hand results."""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sosp.clustering import single_tasks, static_cluster_tasks, tasks_to_schedule
from sosp.conflicts import conflict_graph, setup_conflict_pairs
from sosp.instance import Instance, Resources
from sosp.schedule import Observation, Schedule
from sosp.validate import validate
from tests.conftest import tiny_chain, tiny_cluster, tiny_two_orbits


@st.composite
def instances(draw) -> Instance:
    n = draw(st.integers(1, 14))
    m = draw(st.integers(1, 3))
    rows = []
    for _ in range(n):
        s = draw(st.floats(0, 300))
        rows.append(
            (
                draw(st.integers(0, 5)),
                draw(st.integers(0, m - 1)),
                s,
                s + draw(st.floats(0.5, 9)),
                draw(st.floats(-33, 33)),
            )
        )
    res = Resources(
        setup_time=draw(st.sampled_from([0.0, 10.0])),
        slew_rate=draw(st.sampled_from([0.5, 1.0, 3.0])),
        max_duration=draw(st.sampled_from([10.0, 120.0])),
    )
    return Instance.build([3] * 6, rows, resources=res, n_orbits=m)


def brute_pairs(inst: Instance) -> set[tuple[int, int]]:
    out = set()
    for i, h in itertools.combinations(range(inst.n_opps), 2):
        if inst.opp_orbit[i] != inst.opp_orbit[h]:
            continue
        j = int(inst.opp_orbit[i])
        key = lambda x: (inst.opp_start[x], inst.opp_end[x])  # noqa: E731
        u, v = (i, h) if key(i) <= key(h) else (h, i)
        need = (
            inst.setup_time[j] + (abs(inst.opp_roll[u]) + abs(inst.opp_roll[v])) / inst.slew_rate[j]
        )
        if inst.opp_start[v] - inst.opp_end[u] < need - 1e-9:
            out.add((i, h))
    return out


@settings(max_examples=200, deadline=None)
@given(inst=instances())
def test_sweep_equals_all_pairs(inst: Instance) -> None:
    t = single_tasks(inst)
    pairs = setup_conflict_pairs(inst, t.orbit, t.start, t.end, t.roll)
    assert set(map(tuple, pairs.tolist())) == brute_pairs(inst)
    assert np.all(pairs[:, 0] < pairs[:, 1]) if len(pairs) else True


def test_conflicts_hand_computed() -> None:
    inst = tiny_chain()  # a-b conflict (gap 6 < 21); b-c exactly feasible; a-c feasible
    g = conflict_graph(inst)
    assert sorted(g.edges) == [(0, 1)]
    assert g.nodes[0]["weight"] == 5 and g.edges[0, 1]["kind"] == "setup"


def test_target_edges_across_orbits() -> None:
    inst = tiny_two_orbits()  # a on orbits 0 and 1, b conflicts with a on orbit 0
    g = conflict_graph(inst)
    kinds = {tuple(sorted(e)): d["kind"] for *e, d in g.edges(data=True)}
    assert kinds == {(0, 1): "setup", (0, 2): "target"}
    assert sorted(conflict_graph(inst, target_edges=False).edges) == [(0, 1)]


def test_static_clusters_hand_computed() -> None:
    inst = tiny_cluster()  # a [0,4] range [8,14], b [5,9] range [6,12] -> one cluster; c alone
    tasks = static_cluster_tasks(inst)
    assert tasks.opps == ((0, 1), (2,))
    assert (tasks.start[0], tasks.end[0], tasks.roll[0]) == (0.0, 9.0, 10.0)  # (10), (9)
    assert tasks.weight.tolist() == [9, 2]
    assert static_cluster_tasks(inst, roll_rule="nadir").roll[0] == 8.0
    assert tasks.roll[1] == inst.opp_roll[2]  # a lone opportunity keeps its own roll


def test_static_clusters_respect_max_duration() -> None:
    inst = Instance.build(
        {"a": 1, "b": 1, "c": 1},
        [("a", 0, 0, 4, 5.0), ("b", 0, 100, 104, 5.0), ("c", 0, 118, 122, 5.0)],
    )
    tasks = static_cluster_tasks(inst)
    assert tasks.opps == ((0, 1), (2,))  # c would stretch the window to 122 > 120
    # with Delta T = 50, b and c (window 22) still cluster but a and b no longer do
    short = Instance.build(
        {"a": 1, "b": 1, "c": 1},
        [("a", 0, 0, 4, 5.0), ("b", 0, 100, 104, 5.0), ("c", 0, 118, 122, 5.0)],
        resources=Resources(max_duration=50.0),
    )
    assert static_cluster_tasks(short).opps == ((0,), (1, 2))


@settings(max_examples=150, deadline=None)
@given(inst=instances())
def test_static_clusters_partition_and_are_valid(inst: Instance) -> None:
    tasks = static_cluster_tasks(inst)
    assert sorted(i for t in tasks.opps for i in t) == list(range(inst.n_opps))
    for t in range(len(tasks)):
        ob = Observation(
            int(tasks.orbit[t]), tasks.start[t], tasks.end[t], tasks.roll[t], tasks.opps[t]
        )
        rep = validate(inst, Schedule((ob,)))
        assert not [v for v in rep.violations if v.constraint in ("7", "11", "structure")]


def _reference_groups(inst: Instance) -> list[tuple[int, ...]]:
    """The static clustering's rule, written plainly: in start order, each opportunity joins
    the open group of its orbit whose window it grows least, among those it keeps within
    (11) and the common roll range (7); a group is closed once a start outruns it."""
    groups: list[tuple[int, ...]] = []
    for j in range(inst.n_orbits):
        limit = float(inst.max_duration[j])
        open_: list[list] = []
        for i in range(inst.orbit_opps(j).start, inst.orbit_opps(j).stop):
            s, e = float(inst.opp_start[i]), float(inst.opp_end[i])
            lo, hi = float(inst.opp_roll_min[i]), float(inst.opp_roll_max[i])
            groups += [tuple(g[4]) for g in open_ if s - g[0] >= limit]
            open_ = [g for g in open_ if s - g[0] < limit]
            fits = [
                g for g in open_ if max(g[2], lo) <= min(g[3], hi) and max(g[1], e) - g[0] <= limit
            ]
            if not fits:
                open_.append([s, e, lo, hi, [i]])
                continue
            best = min(fits, key=lambda g: max(g[1], e) - g[1])  # the first of the least
            best[1], best[2], best[3] = max(best[1], e), max(best[2], lo), min(best[3], hi)
            best[4].append(i)
        groups += [tuple(g[4]) for g in open_]
    return sorted(groups)


@settings(max_examples=150, deadline=None)
@given(inst=instances())
def test_static_clusters_follow_the_plain_rule(inst: Instance) -> None:
    """The tightened loop (plain floats, inlined min/max, closing skipped while the oldest
    open group is in reach) forms exactly the groups of the rule written plainly."""
    assert sorted(static_cluster_tasks(inst).opps) == _reference_groups(inst)


def test_tasks_to_schedule_claims_each_target_once() -> None:
    inst = Instance.build(
        {"a": 5, "b": 4}, [("a", 0, 0, 4, 5.0), ("b", 0, 2, 6, 5.0), ("a", 1, 50, 54, 0.0)]
    )
    tasks = static_cluster_tasks(inst)
    assert tasks.opps == ((0, 1), (2,))
    sched = tasks_to_schedule(inst, tasks, [0, 1])
    assert len(sched) == 1  # the orbit-1 task has nothing left to claim and is dropped
    rep = validate(inst, sched)
    assert rep.feasible and rep.profit == 9


def test_pairs_are_the_rows_upper_triangle_and_the_cap_raises(c3) -> None:
    import pytest

    import sosp.conflicts as conflicts

    inst = c3
    args = (inst, inst.opp_orbit, inst.opp_start, inst.opp_end, inst.opp_roll)
    whole = conflicts.setup_conflict_pairs(*args)
    assert {(int(a), int(b)) for a, b in whole} == rows_as_pairs(
        *conflicts.setup_conflict_rows(*args)
    )
    assert np.array_equal(whole, np.unique(whole, axis=0))  # sorted, i < h
    assert (whole[:, 0] < whole[:, 1]).all()
    assert len(whole) > 10
    with pytest.raises(conflicts.TooManyConflicts, match="more than 10 setup conflicts"):
        conflicts.setup_conflict_pairs(*args, max_pairs=10)
    assert len(conflicts.setup_conflict_pairs(*args, max_pairs=len(whole))) == len(whole)


def rows_as_pairs(indptr: np.ndarray, indices: np.ndarray) -> set[tuple[int, int]]:
    src = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    return {(int(a), int(b)) for a, b in zip(src, indices, strict=True) if a < b}


@settings(max_examples=200, deadline=None)
@given(inst=instances(), seed=st.integers(0, 2**16))
def test_conflict_rows_are_the_pairs_as_sorted_symmetric_rows(inst: Instance, seed: int) -> None:
    from sosp.conflicts import setup_conflict_rows

    t = single_tasks(inst)
    rng = np.random.default_rng(seed)
    keep = rng.random(len(t)) < 0.7
    # items in any order (the sweep sorts them), each in the rows under its own index
    perm = rng.permutation(len(t))
    pos = np.argsort(perm)
    cols = (t.orbit[perm], t.start[perm], t.end[perm], t.roll[perm])
    indptr, indices = setup_conflict_rows(inst, *cols, keep=keep[perm])
    assert len(indptr) == len(t) + 1
    want = set()
    for i, h in brute_pairs(inst):
        if keep[i] and keep[h]:
            a, b = int(pos[i]), int(pos[h])
            want.add((min(a, b), max(a, b)))
    assert rows_as_pairs(indptr, indices) == want
    for x in range(len(t)):
        row = indices[indptr[x] : indptr[x + 1]].tolist()
        assert row == sorted({h for i, h in want if i == x} | {i for i, h in want if h == x})


def test_conflict_rows_cap_raises_before_the_rows(c3) -> None:
    import pytest

    from sosp.conflicts import TooManyConflicts, setup_conflict_rows

    inst = c3
    args = (inst, inst.opp_orbit, inst.opp_start, inst.opp_end, inst.opp_roll)
    n_pairs = len(setup_conflict_pairs(*args))
    assert n_pairs > 10
    with pytest.raises(TooManyConflicts, match="more than 10 setup conflicts") as refused:
        setup_conflict_rows(*args, max_pairs=10)
    # the count stops at the item where it passed the cap, not at the last one
    assert 10 < refused.value.found < n_pairs
    indptr, indices = setup_conflict_rows(*args, max_pairs=n_pairs)
    assert len(indices) == 2 * n_pairs and rows_as_pairs(indptr, indices) == set(
        map(tuple, setup_conflict_pairs(*args).tolist())
    )


@settings(max_examples=100, deadline=None)
@given(inst=instances())
def test_pair_candidates_bound_the_pairs(inst: Instance) -> None:
    # what the sweep tests: at least the conflicts, at most all pairs within an orbit
    from sosp.conflicts import setup_pair_candidates

    t = single_tasks(inst)
    n = setup_pair_candidates(inst, t.orbit, t.start, t.end, t.roll)
    within = sum(c * (c - 1) // 2 for c in np.bincount(t.orbit, minlength=1))
    assert len(brute_pairs(inst)) <= n <= within
