"""Clique inequalities for the setup-time conflicts (3), found by a sweep over time.

On one orbit, give each item u (an opportunity, a cluster-task or a candidate observation) the
half-open interval

    I_u = [L_u, R_u),   L_u = ts_u - |theta_u| / v,   R_u = te_u + a + |theta_u| / v.

For two items u, w with ts_u <= ts_w, (3) fails exactly when ``ts_w - te_u < a + (|theta_u| +
|theta_w|) / v``, i.e. when ``L_w < R_u``. The other half of "the intervals overlap",
``L_u < R_w``, always holds because ``L_u <= ts_u <= ts_w < te_w <= R_w``. So the conflict graph
of (3) on one orbit *is* the interval graph of the I_u: two items conflict iff their intervals
share a point.

In an interval graph every clique has a common point (Helly property in one dimension), and the
point can be taken as the largest left end L of its members. The sweep therefore visits the left
ends in increasing order and takes K(p) = {u : L_u <= p < R_u}, the items alive at p:

* K(p) is a clique (all its members contain p), so ``sum_{u in K(p)} x_u <= 1`` is valid: it
  never cuts a schedule that satisfies (3);
* every conflict edge {u, w} with L_u <= L_w lies in K(L_w), so the cliques imply every pairwise
  form of (3);
* K(p) at one left end is contained in K at the next left end unless some interval ends in
  between, so only the sets followed by a right end (or the last one) are kept: these are the
  maximal cliques, at most one per item.

Comparisons use the solvers' margin :data:`sosp.rules.EPS`, as
:func:`sosp.conflicts.setup_conflict_pairs` (an edge needs
``R_u - L_w > EPS``), and the tests check that the two agree edge for edge.
"""

from __future__ import annotations

import numpy as np

from sosp import rules
from sosp.rules import EPS


def orbit_intervals(
    start: np.ndarray, end: np.ndarray, roll: np.ndarray, setup: float, slew_rate: float
) -> tuple[np.ndarray, np.ndarray]:
    """The conflict intervals [L_u, R_u) of one orbit's items (see the module docstring).

    Parameters
    ----------
    start, end, roll
        Windows and rolls of the items, one orbit.
    setup, slew_rate
        a_j and v_j of the orbit, constraint (3).

    Returns
    -------
    tuple of numpy.ndarray
        ``(L, R)``.
    """
    roll = np.asarray(roll, dtype=float)
    return (
        rules.left_end(np.asarray(start, dtype=float), roll, slew_rate),
        rules.right_end(np.asarray(end, dtype=float), roll, setup, slew_rate),
    )


def maximal_cliques(left: np.ndarray, right: np.ndarray) -> list[np.ndarray]:
    """Maximal cliques of the interval graph of [left, right), in the sweep's order.

    Two intervals are adjacent when they overlap by more than ``EPS``. Cliques of one item
    are dropped (they imply nothing beyond ``x <= 1``). The sweep of the module docstring,
    done by array operations (:func:`clique_events`, :func:`cliques_from_events`).

    Parameters
    ----------
    left, right
        Interval ends of one orbit's items.

    Returns
    -------
    list of numpy.ndarray
        Item indices (into ``left``, increasing) of each maximal clique of two or more items.
    """
    return cliques_from_events(*clique_events(left, right))


def clique_events(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The cliques of :func:`maximal_cliques` as one event range per item, by array operations.

    The sweep's cliques are K(p) at some left ends p (the *events*, in increasing time). An
    item is alive at the events of one consecutive run (its interval holds a range of sweep
    points), so the cliques have the consecutive-ones property and are described by the half-open
    event range [first_u, last_u) of every item (empty when it lies in no clique). This is what
    the network form of (3) in :mod:`models.highs_direct` needs, in O(n log n) and without
    materialising the cliques (whose total size is quadratic on dense orbits).

    With items sorted by left end (positions q) and ``end_q`` the last position whose left end
    is below ``R_q - EPS`` (at least q): item q is alive at positions q..end_q, and the sweep
    keeps position p iff at least two items are alive there and one of them ends there
    (``end_q == p``: it leaves before the next left end) or p is the last position.

    Parameters
    ----------
    left, right
        Interval ends of one orbit's items.

    Returns
    -------
    tuple
        ``(first, last, m)``: per item (input order) its event range, and the number of events
        (cliques of two or more items, the same as ``len(maximal_cliques(left, right))``).
    """
    n = len(left)
    first = np.zeros(n, dtype=np.int64)
    last = np.zeros(n, dtype=np.int64)
    if n < 2:
        return first, last, 0
    order = np.argsort(left, kind="stable")
    lo = np.asarray(left, dtype=float)[order]
    hi = np.asarray(right, dtype=float)[order] - EPS
    pos = np.arange(n)
    end = np.maximum(np.searchsorted(lo, hi, side="left") - 1, pos)
    diff = np.zeros(n + 1, dtype=np.int64)
    np.add.at(diff, pos, 1)
    np.add.at(diff, end + 1, -1)
    alive = np.cumsum(diff[:n])
    ends_here = np.bincount(end, minlength=n)[:n] > 0
    ends_here[-1] = True
    kept = np.flatnonzero((alive >= 2) & ends_here)
    first[order] = np.searchsorted(kept, pos, side="left")
    last[order] = np.searchsorted(kept, end, side="right")
    return first, last, int(len(kept))


def cliques_from_events(first: np.ndarray, last: np.ndarray, m: int) -> list[np.ndarray]:
    """The member items of each event 0..m-1 given the item ranges of :func:`clique_events`."""
    first = np.asarray(first, dtype=np.int64)
    length = np.maximum(np.asarray(last, dtype=np.int64) - first, 0)
    items = np.repeat(np.arange(len(first)), length)
    offset = np.cumsum(length) - length
    event = np.arange(int(length.sum())) - np.repeat(offset - first, length)
    order = np.argsort(event, kind="stable")
    cuts = np.searchsorted(event[order], np.arange(1, m))
    return [np.asarray(c) for c in np.split(items[order], cuts)] if m else []


def graph_cliques(
    n: int, edges: np.ndarray, max_cliques: int = 200_000, cover: bool = False
) -> list[np.ndarray]:
    """Cliques of two or more nodes covering every edge of a general conflict graph.

    The maximal cliques (:func:`networkx.find_cliques`) when there are at most
    ``max_cliques`` of them; past that, a greedy cover: each edge not yet covered grows into a
    maximal clique by adding common neighbours, highest degree first. Either way every edge
    lies in a returned clique, so the rows ``sum_{u in K} x_u <= 1`` imply every pairwise
    conflict row (and are at least as strong in the LP).

    Parameters
    ----------
    n
        Number of nodes (0..n-1).
    edges
        (m, 2) node pairs.
    max_cliques
        Most maximal cliques enumerated before switching to the greedy cover.
    cover
        The greedy cover directly: far fewer rows and nonzeros than every maximal clique
        (whose number grows fast on dense graphs, and HiGHS's presolve with them).

    Returns
    -------
    list of numpy.ndarray
        Sorted node indices of each clique.
    """
    import itertools

    import networkx as nx

    g = nx.Graph()
    g.add_nodes_from(range(n))
    g.add_edges_from(np.asarray(edges, dtype=np.int64).tolist())
    found = [] if cover else list(itertools.islice(nx.find_cliques(g), max_cliques + 1))
    if not cover and len(found) <= max_cliques:
        return [np.sort(np.asarray(c, dtype=np.int64)) for c in found if len(c) >= 2]
    covered: set[tuple[int, int]] = set()
    out: list[np.ndarray] = []
    for u, w in sorted(tuple(sorted(e)) for e in g.edges):
        if (u, w) in covered:
            continue
        clique = [u, w]
        common = set(g[u]) & set(g[w])
        while common:
            z = max(common, key=lambda k: (g.degree[k], -k))
            clique.append(z)
            common &= set(g[z])
        clique.sort()
        covered.update(itertools.combinations(clique, 2))
        out.append(np.asarray(clique, dtype=np.int64))
    return out
