"""Candidate observations of the clustering-exact model (``docs/model.md``, "What makes the
exact models exact").

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

Candidates are generated per orbit on first use (:func:`orbit_candidates`) and stored as
numpy columns with the covered opportunities in CSR form (:class:`OppGroups`, about
``32 + 4 * members`` bytes per candidate), so an orbit with thousands of opportunities and
millions of candidates costs tens of megabytes, not gigabytes of Python tuples. Only the
MILP models, which turn every candidate into a variable, keep a cap on their number.
"""

from __future__ import annotations

import itertools
import logging
import time
import weakref
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import chain
from typing import Any

import numpy as np

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.rules import EPS

log = logging.getLogger(__name__)


#: Most candidates the MILP models take (a Pyomo variable each: about 0.5 GB per million).
#: C10, the densest reference scenario, has 176 610; orbits with hundreds of windows inside
#: one Delta T (thousands of targets in a small region) have millions. The single-orbit
#: planner has no such cap (:func:`orbit_candidates`).
MAX_CANDIDATES = 2_000_000

Candidates = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, "OppGroups"]


class OppGroups(Sequence[tuple[int, ...]]):
    """Groups of opportunity indices (one sorted group per candidate) stored as CSR.

    ``flat[ptr[u]:ptr[u + 1]]`` are candidate u's covered opportunities: four bytes per
    member instead of a Python tuple's forty, so that dense orbits with millions of candidates
    fit in memory. Indexing gives a tuple of ints, as the tuple-of-tuples it replaces.

    Parameters
    ----------
    ptr
        int64 offsets, one more than the groups.
    flat
        int32 members, all groups concatenated.
    """

    __slots__ = ("flat", "ptr")

    def __init__(self, ptr: np.ndarray, flat: np.ndarray) -> None:
        self.ptr = np.asarray(ptr, dtype=np.int64)
        self.flat = np.asarray(flat, dtype=np.int32)

    @classmethod
    def from_groups(cls, groups: Sequence[Sequence[int]]) -> OppGroups:
        """From any sequence of index sequences."""
        if isinstance(groups, OppGroups):
            return groups
        sizes = np.fromiter((len(g) for g in groups), dtype=np.int64, count=len(groups))
        ptr = np.zeros(len(groups) + 1, dtype=np.int64)
        np.cumsum(sizes, out=ptr[1:])
        flat = np.fromiter(chain.from_iterable(groups), dtype=np.int32, count=int(ptr[-1]))
        return cls(ptr, flat)

    @property
    def sizes(self) -> np.ndarray:
        """Members per group."""
        return np.diff(self.ptr)

    @property
    def nbytes(self) -> int:
        """Bytes held by the two arrays."""
        return int(self.ptr.nbytes + self.flat.nbytes)

    def __len__(self) -> int:
        return len(self.ptr) - 1

    def __getitem__(self, u: Any) -> Any:
        if isinstance(u, slice):
            return [self[v] for v in range(*u.indices(len(self)))]
        u = int(u)
        if u < 0:
            u += len(self)
        if not 0 <= u < len(self):
            raise IndexError(u)
        return tuple(self.flat[self.ptr[u] : self.ptr[u + 1]].tolist())

    def __iter__(self) -> Iterator[tuple[int, ...]]:
        flat, ptr = self.flat.tolist(), self.ptr.tolist()
        for a, b in itertools.pairwise(ptr):
            yield tuple(flat[a:b])

    def __eq__(self, other: object) -> bool:
        if isinstance(other, OppGroups):
            return np.array_equal(self.ptr, other.ptr) and np.array_equal(self.flat, other.flat)
        if isinstance(other, Sequence):
            return len(self) == len(other) and all(
                a == tuple(b) for a, b in zip(self, other, strict=True)
            )
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def take(self, rows: np.ndarray) -> OppGroups:
        """The groups ``rows``, in that order."""
        rows = np.asarray(rows, dtype=np.int64)
        sizes = self.ptr[rows + 1] - self.ptr[rows]
        ptr = np.zeros(len(rows) + 1, dtype=np.int64)
        np.cumsum(sizes, out=ptr[1:])
        return OppGroups(ptr, self.flat[ragged_positions(self.ptr[rows], sizes)])

    @staticmethod
    def concat(parts: Sequence[OppGroups]) -> OppGroups:
        """The groups of ``parts`` one after another."""
        if not parts:
            return OppGroups(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32))
        offsets = np.cumsum([0] + [int(p.ptr[-1]) for p in parts[:-1]])
        ptr = np.concatenate(
            [[0]] + [p.ptr[1:] + off for p, off in zip(parts, offsets, strict=True)]
        )
        return OppGroups(ptr, np.concatenate([p.flat for p in parts]))


def ragged_positions(starts: np.ndarray, sizes: np.ndarray) -> np.ndarray:
    """``concatenate([arange(s, s + n) for s, n in zip(starts, sizes)])``, vectorised."""
    sizes = np.asarray(sizes, dtype=np.int64)
    total = int(sizes.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.cumsum(sizes) - sizes  # where each run begins in the output
    step = np.ones(total, dtype=np.int64)
    nz = sizes > 0
    s, f = np.asarray(starts, dtype=np.int64)[nz], first[nz]
    step[f[0]] = s[0]
    # at each run's first slot jump from the previous run's last value to this run's start
    prev_last = s[:-1] + sizes[nz][:-1] - 1
    step[f[1:]] = s[1:] - prev_last
    return np.cumsum(step)


@dataclass(frozen=True, eq=False)
class OrbitCandidates:
    """The non-dominated candidate observations of one orbit, in generation order.

    Attributes
    ----------
    orbit
        Orbit index j.
    start, end, roll
        Per candidate: window (10) and roll (float64, read-only).
    opps
        Covered opportunity indices (global), one sorted group per candidate.
    """

    orbit: int
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: OppGroups

    @property
    def size(self) -> int:
        return len(self.roll)

    @property
    def nbytes(self) -> int:
        """Bytes held by the columns."""
        return int(self.start.nbytes + self.end.nbytes + self.roll.nbytes + self.opps.nbytes)


#: Per live instance (by ``id``): its orbits' candidates, generated once each
#: (:func:`orbit_candidates`), and the whole-instance columns (:func:`cluster_candidates`).
#: Methods run one after another on one instance (``milp-lns`` after its ``orbit-dp`` start,
#: ``sosp demo``, a benchmark over seeds) share them. An entry leaves with its instance
#: (``weakref.finalize``); the arrays are read-only, so a caller that wrote to them would fail
#: instead of changing another's data.
_CACHE: dict[int, tuple[weakref.ref, dict[Any, Any]]] = {}


def _cache_of(instance: Instance) -> dict[Any, Any]:
    """The cache entry of ``instance`` (created on first use)."""
    key = id(instance)
    hit = _CACHE.get(key)
    if hit is not None and hit[0]() is instance:
        return hit[1]
    store: dict[Any, Any] = {}
    _CACHE[key] = (weakref.ref(instance), store)
    weakref.finalize(instance, _CACHE.pop, key, None)
    return store


def orbit_candidates(
    instance: Instance,
    j: int,
    deadline: float | None = None,
    max_candidates: int | None = None,
) -> OrbitCandidates:
    """The non-dominated candidate observations of orbit ``j`` (generated once per instance).

    Parameters
    ----------
    instance
        The problem.
    j
        Orbit index.
    deadline
        A :func:`time.perf_counter` value: raise :class:`~sosp.errors.InputError` (naming the
        orbit) when it passes before the orbit's candidates are complete (None: no limit).
    max_candidates
        Raise :class:`~sosp.errors.InputError` (naming the orbit) once the orbit has more
        candidates than this (None: no cap).
    """
    store = _cache_of(instance)
    hit = store.get(j)
    if hit is not None:
        if max_candidates is not None and hit.size > max_candidates:
            raise _too_many(instance, j, max_candidates)
        return hit
    out = _generate_orbit(instance, j, deadline, max_candidates)
    store[j] = out
    return out


def cluster_candidates(
    instance: Instance,
    max_candidates: int | None = MAX_CANDIDATES,
    deadline: float | None = None,
) -> Candidates:
    """All non-dominated candidate observations of every orbit.

    Parameters
    ----------
    instance
        The problem.
    max_candidates
        Raise :class:`~sosp.errors.InputError` (naming the orbit) once more candidates than
        this have been generated (the MILP models' cap); None: no cap.
    deadline
        A :func:`time.perf_counter` value: raise :class:`~sosp.errors.InputError` when it
        passes before the candidates are complete (None: no limit).

    Returns
    -------
    tuple
        ``(orbit, start, end, roll, opps)``: one entry per candidate, orbit by orbit;
        ``opps`` (an :class:`OppGroups`) are the sorted covered opportunity indices, whose
        window is exactly [start, end]. The arrays are read-only and shared by every call on
        the same instance object (computed once).
    """
    store = _cache_of(instance)
    hit = store.get("all")
    if hit is not None and (max_candidates is None or len(hit[4]) <= max_candidates):
        return hit
    parts: list[OrbitCandidates] = []
    total = 0
    for j in range(instance.n_orbits):
        left = None if max_candidates is None else max_candidates - total
        part = orbit_candidates(instance, j, deadline, left)
        total += part.size
        parts.append(part)
    del part
    # Copy the orbits' columns into whole-instance ones, freeing each orbit's as it is copied
    # (peak: the whole plus one orbit), then make the orbits' entries views of the whole.
    n_items = total
    n_flat = sum(len(p.opps.flat) for p in parts)
    orbit = np.empty(n_items, dtype=np.int64)
    start, end, roll = np.empty(n_items), np.empty(n_items), np.empty(n_items)
    ptr = np.zeros(n_items + 1, dtype=np.int64)
    flat = np.empty(n_flat, dtype=np.int32)
    spans = []
    at = at_flat = 0
    for k in range(len(parts)):
        p = parts[k]
        a, b = at, at + p.size
        fa, fb = at_flat, at_flat + len(p.opps.flat)
        orbit[a:b] = p.orbit
        start[a:b], end[a:b], roll[a:b] = p.start, p.end, p.roll
        ptr[a + 1 : b + 1] = p.opps.ptr[1:] + fa
        flat[fa:fb] = p.opps.flat
        spans.append((p.orbit, a, b))
        parts[k] = None  # type: ignore[call-overload]
        store.pop(p.orbit, None)
        del p
        at, at_flat = b, fb
    opps = OppGroups(ptr, flat)
    for column in (orbit, start, end, roll, opps.ptr, opps.flat):
        column.flags.writeable = False
    result = (orbit, start, end, roll, opps)
    store["all"] = result
    for j, a, b in spans:
        view = OppGroups(ptr[a : b + 1] - ptr[a], flat[ptr[a] : ptr[b]])
        view.ptr.flags.writeable = False
        store[j] = OrbitCandidates(j, start[a:b], end[a:b], roll[a:b], view)
    log.debug("cluster candidates: %d", len(opps))
    return result


#: The instance a worker process generates candidates for (set before the fork).
_WORKER_INSTANCE: Instance | None = None


def _worker_orbit(args: tuple[int, float | None]) -> OrbitCandidates:
    j, deadline = args
    assert _WORKER_INSTANCE is not None
    return _generate_orbit(_WORKER_INSTANCE, j, deadline, None)


def generate_in_processes(instance: Instance, workers: int, deadline: float | None = None) -> None:
    """Generate the candidates of every orbit in ``workers`` forked processes, largest orbits
    first, and cache them as :func:`orbit_candidates` would (no cap).

    Worth it only when the orbits are many and dense: each orbit's arrays travel back through
    a pipe (about 30 bytes per candidate and 4 per member). Where processes cannot be forked
    the orbits are generated here, one after another.
    """
    import multiprocessing as mp

    store = _cache_of(instance)
    todo = [j for j in range(instance.n_orbits) if j not in store]
    sizes = np.diff(instance.orbit_offsets)
    todo.sort(key=lambda j: -int(sizes[j]))
    if workers <= 1 or len(todo) <= 1 or "fork" not in mp.get_all_start_methods():
        for j in todo:
            orbit_candidates(instance, j, deadline)
        return
    global _WORKER_INSTANCE
    _WORKER_INSTANCE = instance
    try:
        with mp.get_context("fork").Pool(min(workers, len(todo))) as pool:
            for out in pool.imap_unordered(_worker_orbit, [(j, deadline) for j in todo]):
                store[out.orbit] = out
    finally:
        _WORKER_INSTANCE = None


def _too_many(instance: Instance, j: int, max_candidates: int) -> InputError:
    return InputError(
        f"orbit {instance.orbit_ids[j]!r}: more than {max_candidates} candidate "
        "observations; the instance is too dense for the clustering-exact MILP "
        "(use orbit-dp, asa-dtc or sosp bound --method lagrangian)"
    )


def _generate_orbit(
    instance: Instance, j: int, deadline: float | None, max_candidates: int | None
) -> OrbitCandidates:
    """The work of :func:`orbit_candidates` (uncached)."""
    sl = instance.orbit_opps(j)
    out_roll: list[np.ndarray] = []
    out_sizes: list[np.ndarray] = []
    out_members: list[np.ndarray] = []
    count = 0
    ts = np.asarray(instance.opp_start[sl], dtype=float)
    te = np.asarray(instance.opp_end[sl], dtype=float)
    lo = np.asarray(instance.opp_roll_min[sl], dtype=float)
    hi = np.asarray(instance.opp_roll_max[sl], dtype=float)
    limit = float(instance.max_duration[j])
    # opportunities starting within Delta T of each start: a contiguous run (sorted by start)
    stop = np.searchsorted(ts, ts + limit + EPS, side="right")
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
                count += 1
        if max_candidates is not None and count > max_candidates:
            raise _too_many(instance, j, max_candidates)
        if deadline is not None and time.perf_counter() > deadline:
            raise InputError(
                f"orbit {instance.orbit_ids[j]!r}: time limit reached while generating "
                f"candidate observations ({count} so far); give more time or use "
                "asa-dtc"
            )
    sizes = np.concatenate(out_sizes) if out_sizes else np.zeros(0, dtype=np.int64)
    ptr = np.zeros(len(sizes) + 1, dtype=np.int64)
    np.cumsum(sizes, out=ptr[1:])
    flat = np.concatenate(out_members) if out_members else np.zeros(0, dtype=np.int32)
    roll = np.concatenate(out_roll) if out_roll else np.zeros(0)
    # Windows (10) of all candidates at once: [min ts, max te] over the members.
    if len(sizes):
        starts = np.minimum.reduceat(instance.opp_start[flat], ptr[:-1]).astype(float)
        ends_ = np.maximum.reduceat(instance.opp_end[flat], ptr[:-1]).astype(float)
    else:
        starts, ends_ = np.zeros(0), np.zeros(0)
    opps = OppGroups(ptr, flat)
    for column in (starts, ends_, roll, opps.ptr, opps.flat):
        column.flags.writeable = False
    log.debug("orbit %d: %d cluster candidates", j, len(sizes))
    return OrbitCandidates(orbit=j, start=starts, end=ends_, roll=roll, opps=opps)


def flatten(groups: Sequence[Sequence[int]]) -> tuple[np.ndarray, np.ndarray]:
    """``(sizes, flat)``: the length of each group of indices and all of them concatenated."""
    if isinstance(groups, OppGroups):
        return groups.sizes, groups.flat  # int32, read-only for cached candidates
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
