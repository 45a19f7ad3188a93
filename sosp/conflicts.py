"""Setup-time conflicts (3) between schedulable items, found by a sweep over time.

Two items u, v on the same orbit, u starting first, can both be scheduled only if

    ts_v - te_u >= a + (|theta_u| + |theta_v|) / v                                      (3)

(the sensor returns through nadir between observations). For a set of items on one orbit,
(3) holds for every consecutive pair if and only if it holds for every pair (gaps and slews
add up), so (3) is exactly a pairwise conflict relation: a schedule is (3)-feasible iff it is
an independent set of the conflict graph.

The sweep sorts each orbit's items by start; item i can only conflict with later items that
start before ``te_i + a + (|theta_i| + max|theta|) / v``, found by binary search, and the exact
test is then applied to those candidates in one compiled pass. No all-pairs test.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from sosp.instance import Instance
from sosp.kernels import compiled
from sosp.rules import EPS, left_end, right_end, slew_time

if TYPE_CHECKING:
    import networkx as nx

    from sosp.clustering import TaskSet


def setup_conflict_pairs(
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    max_pairs: int | None = None,
) -> np.ndarray:
    """All pairs of items that cannot both be scheduled because of (3).

    The upper triangle of :func:`setup_conflict_rows`' adjacency (one compiled sweep).

    Parameters
    ----------
    instance
        Supplies each orbit's setup time a_j and slew rate v_j.
    orbit, start, end, roll
        One entry per item (opportunities, cluster-tasks or candidate observations).
    max_pairs
        Raise :class:`TooManyConflicts` as soon as more pairs than this are found (None: no
        cap), before any pair is stored.

    Returns
    -------
    numpy.ndarray
        Shape ``(m, 2)``, int64, each row ``(i, h)`` with ``i < h`` (item indices), sorted.
    """
    indptr, indices = setup_conflict_rows(instance, orbit, start, end, roll, max_pairs=max_pairs)
    first = np.repeat(np.arange(len(indptr) - 1, dtype=np.int64), np.diff(indptr))
    later = first < indices
    return np.column_stack((first[later], indices[later].astype(np.int64)))


def _sweep_order(
    instance: Instance, orbit: np.ndarray, start: np.ndarray, end: np.ndarray, roll: np.ndarray
) -> tuple[np.ndarray, ...]:
    """The items sorted for the sweep (by orbit, start, end) and, per sorted item, the ends of
    its (3) interval (``R`` by :func:`~sosp.rules.right_end`, ``L`` by
    :func:`~sosp.rules.left_end`: u before w clashes unless ``may_precede(R_u, L_w)``) and
    one past the last later item it may conflict with (binary search)."""
    orbit = np.asarray(orbit, dtype=np.int64)
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    absroll = np.abs(np.asarray(roll, dtype=float))
    order = np.lexsort((end, start, orbit))
    o, s, e, r = orbit[order], start[order], end[order], absroll[order]
    a = instance.setup_time[o]
    v = instance.slew_rate[o]
    # Per-orbit maximum |roll| bounds the partner's slew for the binary search.
    rmax = np.zeros(instance.n_orbits)
    np.maximum.at(rmax, o, r)
    right = right_end(e, r, a, v)
    reach = right + slew_time(rmax[o], v) + EPS
    # Search within each orbit's block: offset keys by orbit so blocks never mix.
    span = float(max(np.max(np.abs(s)), np.max(np.abs(reach)))) * 2.0 + 1.0
    key = o * span + s
    hi = np.searchsorted(key, o * span + reach, side="left")
    return order, right, left_end(s, r, v), hi


def _conflict_rows_py(
    order: np.ndarray,
    right: np.ndarray,
    left: np.ndarray,
    hi: np.ndarray,
    keep: np.ndarray,
    cap: int,
) -> tuple[np.ndarray, np.ndarray, int]:
    """The (3) adjacency of the kept items as compressed sparse rows, each row ascending,
    from the sweep's columns (:func:`_sweep_order`): a counting pass, then a filling pass,
    so the memory is the rows' and nothing more. The test is ``not may_precede(R_u, L_w)``
    (:func:`sosp.rules.may_precede`, u the earlier), written out for numba. Returns
    ``(indptr, indices, pairs)``; with more than ``cap`` pairs, empty rows and the count up
    to the item where it passed ``cap`` (the count stops there)."""
    n = len(order)
    deg = np.zeros(n + 1, dtype=np.int64)
    indptr = deg
    fill = deg[:-1]
    indices = np.empty(0, dtype=np.int32)
    pairs = 0
    for counting in (True, False):  # the same sweep twice: count the rows, then fill them
        for p in range(n):
            i = order[p]
            if not keep[i]:
                continue
            for q in range(p + 1, hi[p]):
                h = order[q]
                if keep[h] and not right[p] <= left[q] + EPS:
                    if counting:
                        deg[i + 1] += 1
                        deg[h + 1] += 1
                        pairs += 1
                    else:
                        indices[fill[i]] = h
                        fill[i] += 1
                        indices[fill[h]] = i
                        fill[h] += 1
            if counting and pairs > cap:
                break  # refused whatever the rest holds: counting on is wasted work
        if counting:
            if pairs > cap:
                return np.zeros(n + 1, dtype=np.int64), indices, pairs
            indptr = np.cumsum(deg)
            fill = indptr[:-1].copy()
            indices = np.empty(indptr[n], dtype=np.int32)
    for x in range(n):
        indices[indptr[x] : indptr[x + 1]].sort()
    return indptr, indices, pairs


#: :func:`_conflict_rows_py`'s numba signature.
CONFLICT_ROWS_SIGNATURE = (
    "Tuple((int64[::1], int32[::1], int64))(int64[::1], float64[::1], float64[::1], "
    "int64[::1], boolean[::1], int64)"
)


def _conflict_rows() -> Any:
    """:func:`_conflict_rows_py` compiled by numba (one signature, cached on disk)."""
    return compiled(_conflict_rows_py, CONFLICT_ROWS_SIGNATURE)


def setup_conflict_rows(
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    keep: np.ndarray | None = None,
    max_pairs: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The pairs of :func:`setup_conflict_pairs` as an adjacency: per item, the items it
    conflicts with by (3), ascending, as compressed sparse rows.

    Made by one compiled sweep that counts, then fills (:func:`_conflict_rows_py`), without
    the pairs' arrays, whose first touch of memory costs most of the time on large lists.

    Parameters
    ----------
    instance, orbit, start, end, roll
        As :func:`setup_conflict_pairs`.
    keep
        Per item, whether it takes part (None: all); the others get empty rows.
    max_pairs
        Raise :class:`TooManyConflicts` when more pairs than this are found, before the rows
        are allocated (None: no cap).

    Returns
    -------
    tuple
        ``(indptr, indices)``: int64 and int32; row x is ``indices[indptr[x]:indptr[x + 1]]``.
    """
    n = len(np.asarray(orbit))
    keep = np.ones(n, dtype=bool) if keep is None else np.ascontiguousarray(keep, dtype=bool)
    if n < 2:
        return np.zeros(n + 1, dtype=np.int64), np.empty(0, dtype=np.int32)
    cols = _sweep_order(instance, orbit, start, end, roll)
    cols = tuple(np.ascontiguousarray(c) for c in cols)
    cap = np.iinfo(np.int64).max if max_pairs is None else int(max_pairs)
    indptr, indices, pairs = _conflict_rows()(*cols, keep, cap)
    if pairs > cap:
        candidates = int(_tested(cols[-1]).sum())
        raise TooManyConflicts(pairs, cap, candidates)
    return indptr, indices


def setup_pair_candidates(
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
) -> int:
    """How many pairs the sweep of :func:`setup_conflict_pairs` tests: at least the number
    of (3) conflict pairs, and what their cost grows with (counted without testing them)."""
    if np.asarray(orbit).size < 2:
        return 0
    return int(_tested(_sweep_order(instance, orbit, start, end, roll)[-1]).sum())


def _tested(hi: np.ndarray) -> np.ndarray:
    """Per sorted item, how many later items the sweep tests it against (``hi`` from
    :func:`_sweep_order`: one past the last it may conflict with)."""
    return np.maximum(hi - np.arange(len(hi)) - 1, 0)


def compile_conflict_kernel() -> None:
    """Compile (or load from numba's cache) :func:`setup_conflict_rows`'s kernel now
    (:func:`sosp.planner.compile_kernels` calls it before the clocks start)."""
    _conflict_rows()


class TooManyConflicts(ValueError):
    """More (3) conflict pairs than a caller's cap (:func:`setup_conflict_pairs`)."""

    def __init__(self, found: int, cap: int, candidates: int) -> None:
        super().__init__(
            f"more than {cap:,} setup conflicts (3) between items ({found:,} found in part of "
            f"{candidates:,} candidate pairs)"
        )
        self.found, self.cap, self.candidates = found, cap, candidates


def target_sharing_pairs(targets: tuple[tuple[int, ...], ...]) -> np.ndarray:
    """Pairs of items that cover a common target (exclusivity (2) for single opportunities)."""
    by_target: dict[int, list[int]] = {}
    for i, ts in enumerate(targets):
        for k in ts:
            by_target.setdefault(k, []).append(i)
    rows = [
        (a, b) for items in by_target.values() for x, a in enumerate(items) for b in items[x + 1 :]
    ]
    if not rows:
        return np.empty((0, 2), dtype=np.int64)
    return np.unique(np.array(rows, dtype=np.int64), axis=0)


def conflict_graph(
    instance: Instance, tasks: TaskSet | None = None, *, target_edges: bool = True
) -> nx.Graph:
    """The conflict graph of opportunities (default) or of a :class:`~sosp.clustering.TaskSet`.

    Nodes are item indices with attributes ``orbit`` and ``weight``. Edges have attribute
    ``kind``: ``"setup"`` for (3) conflicts on one orbit, ``"target"`` for items sharing a
    target (constraint (2) for single opportunities; for cluster-tasks, sharing a target is
    not infeasible, only redundant: pass ``target_edges=False`` to leave those edges out).
    """
    import networkx as nx

    from sosp.clustering import single_tasks

    if tasks is None:
        tasks = single_tasks(instance)
    g = nx.Graph()
    g.add_nodes_from(
        (i, {"orbit": int(o), "weight": int(w)})
        for i, (o, w) in enumerate(zip(tasks.orbit, tasks.weight, strict=True))
    )
    if target_edges:
        g.add_edges_from(map(tuple, target_sharing_pairs(tasks.targets).tolist()), kind="target")
    pairs = setup_conflict_pairs(instance, tasks.orbit, tasks.start, tasks.end, tasks.roll)
    g.add_edges_from(map(tuple, pairs.tolist()), kind="setup")
    return g
