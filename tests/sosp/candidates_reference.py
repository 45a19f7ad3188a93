"""The reference for :func:`sosp.candidates._generate_orbit`: one end and one cover matrix at
a time, slow but plain. The vectorised generator must give the same candidates in the same
order (``tests/sosp/test_planner.py``)."""

from __future__ import annotations

import numpy as np

from sosp.candidates import OrbitCandidates, _pack, orbit_columns
from sosp.instance import Instance
from sosp.rules import EPS


def generate_orbit_loop(instance: Instance, j: int) -> OrbitCandidates:
    """The non-dominated candidate observations of orbit ``j``, one end at a time."""
    out_roll: list[np.ndarray] = []
    out_sizes: list[np.ndarray] = []
    out_members: list[np.ndarray] = []
    sl = instance.orbit_opps(j)
    ts, te, lo, hi, limit, stop = orbit_columns(instance, j)
    # Two starts can only give the same candidate when their ts are equal: the duplicate
    # check keeps the keys of the current start value only.
    seen: set[tuple[float, bytes]] = set()
    seen_ts = None
    for i in range(len(ts)):
        if ts[i] != seen_ts:
            seen.clear()
            seen_ts = ts[i]
        w = np.arange(i, stop[i])  # candidates for l and for covered opportunities
        w = w[ts[w] >= ts[i] - EPS]
        ends = w[(te[w] >= te[i] - EPS) & (te[w] - ts[i] <= limit + EPS)]
        if ends.size == 0:
            continue
        lo_w, hi_w, te_w = lo[w], hi[w], te[w]
        rolls = np.unique(np.concatenate(([0.0], lo_w[lo_w > 0], hi_w[hi_w < 0])))
        # keep rolls inside i's own range (7)
        rolls = rolls[(rolls >= lo[i] - EPS) & (rolls <= hi[i] + EPS)]
        if rolls.size == 0:
            continue
        # inside[k, t]: opportunity w[k]'s range holds rolls[t]
        inside = (lo_w[:, None] <= rolls[None, :] + EPS) & (rolls[None, :] <= hi_w[:, None] + EPS)
        for l_ in ends:
            lpos = int(np.searchsorted(w, l_))
            ok_roll = inside[lpos]
            if not ok_roll.any():
                continue
            within = te_w <= te[l_] + EPS
            cover = inside[:, ok_roll] & within[:, None]  # (k, t)
            r_ok = rolls[ok_roll]
            kept = _nondominated(cover, np.abs(r_ok))
            for t in kept:
                members = (w[cover[:, t]] + sl.start).astype(np.int32)
                key = (float(te[l_]), members.tobytes())
                if key in seen:
                    continue
                seen.add(key)
                out_roll.append(r_ok[t : t + 1])
                out_sizes.append(np.array([len(members)], dtype=np.int64))
                out_members.append(members)
    return _pack(instance, j, out_roll, out_sizes, out_members)


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
