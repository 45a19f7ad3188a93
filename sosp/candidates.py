"""Candidate observations of the clustering-exact model (MODEL-NOTES, "Exact models").

Take any feasible observation covering a set S of opportunities of orbit j. Shrinking its
window to [min ts, max te] of S (10) and moving its roll to the point of the common range (8)
closest to nadir keeps it feasible and costs no more: (3) gaps only grow, the observe and slew
terms of (4), (5) only shrink, (11) only shrinks. The nadir-closest point of
[lo, hi] = [max roll_min, min roll_max] over S is 0, or lo when lo > 0 (a ``roll_min`` of some
opportunity in S), or hi when hi < 0 (a ``roll_max``). So every observation is dominated by a
*candidate* (first opportunity i, last opportunity l, roll theta) with

* window [ts_i, te_l], ts_i <= ts_l, te_i <= te_l, te_l - ts_i <= Delta T (11);
* theta in {0} U {roll_min > 0} U {roll_max < 0} of the opportunities inside the window, with
  theta in the ranges of i and l (7);
* covering *every* opportunity of orbit j whose window lies in [ts_i, te_l] and whose range
  holds theta (covering more targets is never worse: each target counts once).

A candidate is dropped when another with the same window covers a superset at no larger |theta|
(windows of two candidates where one covers the other's ends i and l cannot differ, so only
candidates with the same window can dominate one another).
"""

from __future__ import annotations

import logging
import time
import weakref
from collections.abc import Sequence
from itertools import chain

import numpy as np

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.rules import EPS

log = logging.getLogger(__name__)


#: Most candidates generated before giving up (memory: roughly 0.5 GB per million). C10, the
#: densest reference scenario, has 176 610; orbits with hundreds of windows inside one Delta T
#: (thousands of targets in a small region) can have tens of millions.
MAX_CANDIDATES = 2_000_000


Candidates = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[tuple[int, ...], ...]]

#: Candidates of live instances, by ``id``: methods run one after another on one instance
#: (``milp-lns`` after its ``orbit-dp`` start, ``sosp demo``, a benchmark over seeds) generate
#: them once. An entry leaves with its instance (``weakref.finalize``); the arrays are
#: read-only, so a caller that wrote to them would fail instead of changing another's data.
_CACHE: dict[int, tuple[weakref.ref, Candidates]] = {}


def cluster_candidates(
    instance: Instance, max_candidates: int = MAX_CANDIDATES, deadline: float | None = None
) -> Candidates:
    """All non-dominated candidate observations of every orbit.

    Parameters
    ----------
    instance
        The problem.
    max_candidates
        Raise :class:`~sosp.errors.InputError` (naming the orbit) once more candidates than
        this have been generated, instead of running out of memory.
    deadline
        A :func:`time.perf_counter` value: raise :class:`~sosp.errors.InputError` when it
        passes before the candidates are complete (None: no limit).

    Returns
    -------
    tuple
        ``(orbit, start, end, roll, opps)``: one entry per candidate; ``opps`` are the sorted
        covered opportunity indices, whose window is exactly [start, end]. The arrays are
        read-only and shared by every call on the same instance object (computed once).
    """
    hit = _CACHE.get(id(instance))
    if hit is not None and hit[0]() is instance and len(hit[1][4]) <= max_candidates:
        return hit[1]
    result = _generate(instance, max_candidates, deadline)
    for column in result[:4]:
        column.flags.writeable = False
    key = id(instance)
    _CACHE[key] = (weakref.ref(instance), result)
    weakref.finalize(instance, _CACHE.pop, key, None)
    return result


def _generate(instance: Instance, max_candidates: int, deadline: float | None) -> Candidates:
    """The work of :func:`cluster_candidates` (uncached)."""
    out_orbit: list[int] = []
    out_roll: list[float] = []
    out_opps: list[tuple[int, ...]] = []
    ts_all, te_all = instance.opp_start, instance.opp_end
    lo_all, hi_all = instance.opp_roll_min, instance.opp_roll_max
    for j in range(instance.n_orbits):
        sl = instance.orbit_opps(j)
        if sl.stop == sl.start:
            continue
        ts, te = ts_all[sl], te_all[sl]
        lo, hi = lo_all[sl], hi_all[sl]
        limit = float(instance.max_duration[j])
        # opportunities starting within Delta T of each start: a contiguous run (sorted by start)
        stop = np.searchsorted(ts, ts + limit + EPS, side="right")
        seen: set[tuple[float, float, tuple[int, ...]]] = set()
        for i in range(len(ts)):
            w = np.arange(i, stop[i])  # candidates for l and for covered opportunities
            w = w[ts[w] >= ts[i] - EPS]
            ends = w[(te[w] >= te[i] - EPS) & (te[w] - ts[i] <= limit + EPS)]
            if ends.size == 0:
                continue
            rolls = np.unique(np.concatenate(([0.0], lo[w][lo[w] > 0], hi[w][hi[w] < 0])))
            # keep rolls inside i's own range (7)
            rolls = rolls[(rolls >= lo[i] - EPS) & (rolls <= hi[i] + EPS)]
            if rolls.size == 0:
                continue
            # inside[k, t]: opportunity w[k]'s range holds rolls[t]
            inside = (lo[w][:, None] <= rolls[None, :] + EPS) & (
                rolls[None, :] <= hi[w][:, None] + EPS
            )
            for l_ in ends:
                lpos = int(np.searchsorted(w, l_))
                ok_roll = inside[lpos]
                if not ok_roll.any():
                    continue
                within = te[w] <= te[l_] + EPS
                cover = inside[:, ok_roll] & within[:, None]  # (k, t)
                r_ok = rolls[ok_roll]
                kept = _nondominated(cover, np.abs(r_ok))
                for t in kept:
                    members = tuple((w[cover[:, t]] + sl.start).tolist())
                    key = (float(ts[i]), float(te[l_]), members)
                    if key in seen:
                        continue
                    seen.add(key)
                    out_orbit.append(j)
                    out_roll.append(float(r_ok[t]))
                    out_opps.append(members)
            if len(out_opps) > max_candidates:
                raise InputError(
                    f"orbit {instance.orbit_ids[j]!r}: more than {max_candidates} candidate "
                    "observations; the instance is too dense for the clustering-exact "
                    "candidate set (use asa-dtc)"
                )
            if deadline is not None and time.perf_counter() > deadline:
                raise InputError(
                    f"orbit {instance.orbit_ids[j]!r}: time limit reached while generating "
                    f"candidate observations ({len(out_opps)} so far); give more time or use "
                    "asa-dtc"
                )
    log.debug("cluster candidates: %d", len(out_opps))
    # Windows (10) of all candidates at once: [min ts, max te] over the members.
    sizes, flat = flatten(out_opps)
    first = np.concatenate(([0], np.cumsum(sizes)[:-1])) if len(sizes) else sizes
    starts = np.minimum.reduceat(ts_all[flat], first) if len(sizes) else np.zeros(0)
    ends = np.maximum.reduceat(te_all[flat], first) if len(sizes) else np.zeros(0)
    return (
        np.array(out_orbit, dtype=np.int64),
        np.asarray(starts, dtype=float),
        np.asarray(ends, dtype=float),
        np.array(out_roll, dtype=float),
        tuple(out_opps),
    )


def flatten(groups: Sequence[Sequence[int]]) -> tuple[np.ndarray, np.ndarray]:
    """``(sizes, flat)``: the length of each group of indices and all of them concatenated."""
    sizes = np.fromiter((len(g) for g in groups), dtype=np.int64, count=len(groups))
    flat = np.fromiter(chain.from_iterable(groups), dtype=np.int64, count=int(sizes.sum()))
    return sizes, flat


def _nondominated(cover: np.ndarray, cost: np.ndarray) -> list[int]:
    """Columns of ``cover`` not dominated by another with a superset cover and cost <= its own.

    Columns are taken by increasing cost, then decreasing cover size, then index; a column is
    dropped when an earlier one covers a superset. Domination is transitive, so "an earlier
    one" may be kept or dropped itself: the kept columns are those with no earlier superset.
    Ties (same cover, same cost) keep the first column. Returned in that order.
    """
    n = cover.shape[1]
    if n == 1:
        return [0]
    size = cover.sum(axis=0)
    order = np.lexsort((np.arange(n), -size, cost))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    # subset[t, q]: every row covered by t is covered by q
    subset = ~(cover[:, :, None] & ~cover[:, None, :]).any(axis=0)
    earlier = rank[None, :] < rank[:, None]
    dropped = (subset & earlier).any(axis=1)
    return [int(t) for t in order if not dropped[t]]
