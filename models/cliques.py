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

Comparisons use the same margin :data:`sosp.conflicts.EPS` as
:func:`sosp.conflicts.setup_conflict_pairs` (an edge needs
``R_u - L_w > EPS``), and the tests check that the two agree edge for edge.
"""

from __future__ import annotations

import numpy as np

from sosp.conflicts import EPS


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
    r = np.abs(np.asarray(roll, dtype=float)) / slew_rate
    return np.asarray(start, dtype=float) - r, np.asarray(end, dtype=float) + setup + r


def maximal_cliques(left: np.ndarray, right: np.ndarray) -> list[np.ndarray]:
    """Maximal cliques of the interval graph of [left, right) by a sweep over time.

    Two intervals are adjacent when they overlap by more than ``EPS``. Cliques of one item
    are dropped (they imply nothing beyond ``x <= 1``).

    Parameters
    ----------
    left, right
        Interval ends of one orbit's items.

    Returns
    -------
    list of numpy.ndarray
        Item indices (into ``left``) of each maximal clique of two or more items.
    """
    n = len(left)
    if n < 2:
        return []
    order = np.argsort(left, kind="stable")
    lo = np.asarray(left, dtype=float)[order]
    hi = np.asarray(right, dtype=float)[order] - EPS
    out: list[np.ndarray] = []
    alive: list[int] = []  # positions in ``order`` whose interval contains the sweep point
    for pos in range(n):
        p = lo[pos]
        # An item is alive at p when L <= p < R - EPS (strict: touching is no conflict).
        alive = [q for q in alive if hi[q] > p]
        alive.append(pos)
        nxt = lo[pos + 1] if pos + 1 < n else np.inf
        # Keep K(p) only if someone leaves before the next left end (else K(p) grows there).
        if len(alive) >= 2 and min(hi[q] for q in alive) <= nxt:
            out.append(np.sort(order[np.array(alive)]))
    return out


def clique_cover_pairs(cliques: list[np.ndarray]) -> set[tuple[int, int]]:
    """All item pairs implied by ``cliques`` (for checks: equals the conflict pairs of (3))."""
    pairs: set[tuple[int, int]] = set()
    for c in cliques:
        c = sorted(int(x) for x in c)
        for a in range(len(c)):
            for b in range(a + 1, len(c)):
                pairs.add((c[a], c[b]))
    return pairs
