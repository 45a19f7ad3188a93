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
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from itertools import chain
from typing import Any, Literal, get_args

import numpy as np

from sosp.errors import InputError, TimeLimitReached
from sosp.instance import Instance
from sosp.parallel import fork_pool, inherited
from sosp.rules import EPS, roll_in_range, starts_within
from sosp.stop import Budget, stop_requested

log = logging.getLogger(__name__)


#: Bytes a whole solve may hold when its :class:`~sosp.stop.Budget` gives no ``memory``
#: (``sosp solve --max-memory``, default 2 GB): the candidates' cap derives from it
#: (:func:`candidate_cap`), so a search plans over windows where they would not fit.
MAX_MEMORY = 2 * 2**30

#: Bytes the planner's candidates may take in all (estimated before any is generated, see
#: :func:`estimate_bytes`), or None: a third of the solve's memory (:func:`candidate_cap`).
#: Beyond it :func:`cluster_candidates` refuses with a one-line error instead of running the
#: machine out of memory. A search over explicit candidates peaks at about three times their
#: estimate (the planner arranges them per orbit beside the whole-instance columns).
MAX_CANDIDATE_BYTES: int | None = None


def as_budget(budget: Budget | float | None) -> Budget:
    """``budget``, or one until ``budget`` (a :func:`time.perf_counter` deadline; None: no
    limit) for the callers that still pass deadlines."""
    return budget if isinstance(budget, Budget) else Budget.until(budget)


def candidate_cap(memory: int | None = None) -> int:
    """Bytes the candidates may take in a solve that may hold ``memory`` bytes (None:
    :data:`MAX_MEMORY`): :data:`MAX_CANDIDATE_BYTES` when set, else a third of it."""
    return MAX_CANDIDATE_BYTES if MAX_CANDIDATE_BYTES is not None else (memory or MAX_MEMORY) // 3


#: Orbits with fewer (first, covered) pairs inside one Delta T than this are not sampled by
#: :func:`estimate_bytes` (their candidates are few: C10's densest orbit has about 10 000).
_SAMPLE_FROM = 100_000

#: First opportunities sampled per dense orbit by :func:`estimate_bytes`.
_SAMPLES = 24

#: :func:`candidate_mode` with ``"auto"`` plans over windows, and :func:`cluster_candidates`
#: raises :class:`~sosp.errors.TimeLimitReached`, when the estimate alone is foreseen (its
#: samples left at the rate of those done) to take more than this share of the time left:
#: generating the candidates takes one such sample per opportunity of the dense orbits, far
#: more than the estimate's :data:`_SAMPLES` per orbit, so they could not be ready in time
#: either (``milp-lns`` on that instance at 3 s spent 2.4 s estimating, then planned over
#: windows anyway).
ESTIMATE_SHARE = 0.25

#: Foreseen seconds of generation per byte of :func:`estimate_bytes`'s estimate: with a
#: deadline, :func:`candidate_mode` answers windows and :func:`cluster_candidates` refuses
#: at once when this many seconds would pass it. Measured on the 2-core machine, generation
#: without a deadline: 27-47 ns per estimated byte (d30 354 MB in 17.6 s; three drawn
#: instances of 0.86-1.85 GB in 36-70 s); the least of them, so only generations clearly
#: too long are refused. ``orbit-dp`` and ``asa-dtc`` at 5 s on a drawn 5,000-target
#: instance (1.66 GB: 69 s) spent 2-2.5 s generating before switching to windows.
GENERATE_S_PER_BYTE = 27e-9

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
        ptr = offsets(sizes)
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
        ptr = offsets(sizes)
        return OppGroups(ptr, self.flat[ragged_positions(self.ptr[rows], sizes)])


def offsets(sizes: np.ndarray) -> np.ndarray:
    """CSR pointers of groups of ``sizes`` members: 0, then their running sums (int64)."""
    ptr = np.zeros(len(sizes) + 1, dtype=np.int64)
    np.cumsum(sizes, out=ptr[1:])
    return ptr


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

    def within(
        self, opts: np.ndarray, n_options: int, t0: float, t1: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The candidates inside ``[t0, t1]``, each cut to its members among ``opts``.

        A candidate is kept when its window (10) lies in ``[t0, t1]`` (within :data:`EPS`)
        and one of its members is in ``opts``; cut to the same members, two are one (the
        first kept). Returns ``(ptr, flat)``: the kept groups in CSR form (int64), in
        generation order, members sorted as stored. A local search's stretch re-plan calls
        this thousands of times a second on small stretches, where a dozen numpy calls cost
        more than the work, so it is one compiled loop (:func:`_within_py`).

        Parameters
        ----------
        opts
            Option (global opportunity) indices allowed as members, int64.
        n_options
            Number of options of the instance (indices are below it).
        t0, t1
            The span, seconds.
        """
        a = int(np.searchsorted(self.start, t0 - EPS, side="left"))
        b = int(np.searchsorted(self.start, t1 + EPS, side="right"))
        return _within()(
            readonly(self.end, np.float64),
            readonly(self.opps.ptr, np.int64),
            readonly(self.opps.flat, np.int32),
            np.ascontiguousarray(opts, dtype=np.int64),
            n_options,
            a,
            b,
            t1 + EPS,
        )


def readonly(column: np.ndarray, dtype: Any) -> np.ndarray:
    """``column`` as a read-only contiguous array of ``dtype`` (itself when it is one).

    The compiled kernels' inputs are passed in this one form: numba compiles a kernel once
    per combination of argument types, read-only and writeable arrays differ, and the callers
    hold both (an instance's arrays are read-only, their slices and copies not)."""
    if column.dtype != dtype or not column.flags.c_contiguous:
        column = np.ascontiguousarray(column, dtype=dtype)
    if column.flags.writeable:
        column = column.view()
        column.flags.writeable = False
    return column


def _within_py(
    end: np.ndarray,
    ptr: np.ndarray,
    flat: np.ndarray,
    opts: np.ndarray,
    n_options: int,
    a: int,
    b: int,
    t1: float,
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`OrbitCandidates.within`'s loop over candidates ``a..b-1`` (by start).

    Duplicates are found by open addressing on a hash of the cut members, each hit compared
    member by member, so two different member sets are never taken for one.
    """
    inside = np.zeros(n_options, dtype=np.bool_)
    for x in opts:
        inside[x] = True
    out_flat = np.empty(ptr[b] - ptr[a], dtype=np.int64)
    out_ptr = np.zeros(b - a + 1, dtype=np.int64)
    size = 1
    while size < 2 * (b - a) + 2:
        size *= 2
    table = np.full(size, -1, dtype=np.int64)
    rows = 0
    pos = 0
    for v in range(a, b):
        if end[v] > t1:
            continue
        first = pos
        h = np.int64(-3750763034362895579)  # FNV-1a offset basis
        for q in range(ptr[v], ptr[v + 1]):
            x = flat[q]
            if inside[x]:
                out_flat[pos] = x
                pos += 1
                h = (h ^ np.int64(x)) * np.int64(1099511628211)
        n = pos - first
        if n == 0:
            continue
        slot = h & (size - 1)
        while True:
            r = table[slot]
            if r < 0:
                table[slot] = rows
                rows += 1
                out_ptr[rows] = pos
                break
            r0 = out_ptr[r]
            if out_ptr[r + 1] - r0 == n:
                same = True
                for i in range(n):
                    if out_flat[r0 + i] != out_flat[first + i]:
                        same = False
                        break
                if same:
                    pos = first  # one already kept
                    break
            slot = (slot + 1) & (size - 1)
    return out_ptr[: rows + 1].copy(), out_flat[:pos].copy()


_WITHIN: Any = None


def compile_within() -> None:
    """Compile (or load from numba's cache) :meth:`OrbitCandidates.within`'s loop now."""
    _within()


def _within() -> Any:
    """:func:`_within_py` compiled by numba on first use (cached on disk)."""
    global _WITHIN
    if _WITHIN is None:
        from numba import njit
        from numba import types as nt

        def arr(dtype: Any, readonly: bool = True) -> Any:
            return nt.Array(dtype, 1, "C", readonly=readonly)

        # the stored columns are read-only (:meth:`OrbitCandidates.within` passes them so)
        sig = nt.Tuple((arr(nt.int64, False), arr(nt.int64, False)))(
            arr(nt.float64), arr(nt.int64), arr(nt.int32), arr(nt.int64, False),
            nt.int64, nt.int64, nt.int64, nt.float64,
        )  # fmt: skip
        _WITHIN = njit(sig, cache=True)(_within_py)
    return _WITHIN


#: Per live instance (by ``id``): its orbits' candidates, generated once each
#: (:func:`orbit_candidates`), and the whole-instance columns (:func:`cluster_candidates`).
#: Methods run one after another on one instance (``milp-lns`` after its ``orbit-dp`` start,
#: ``sosp demo``, a benchmark over seeds) share them. An entry leaves with its instance
#: (``weakref.finalize``); the arrays are read-only, so a caller that wrote to them would fail
#: instead of changing another's data.
_CACHE: dict[int, tuple[weakref.ref, dict[Any, Any]]] = {}

#: Each instance's orbits' pairs (:func:`orbit_pairs`), kept apart from the candidates.
_PAIRS: dict[int, tuple[weakref.ref, dict[Any, Any]]] = {}


def _cache_of(
    instance: Instance, table: dict[int, tuple[weakref.ref, dict[Any, Any]]] = _CACHE
) -> dict[Any, Any]:
    """The entry of ``instance`` in ``table`` (created on first use)."""
    key = id(instance)
    hit = table.get(key)
    if hit is not None and hit[0]() is instance:
        return hit[1]
    store: dict[Any, Any] = {}
    table[key] = (weakref.ref(instance), store)
    weakref.finalize(instance, table.pop, key, None)
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


def cached_orbit_candidates(instance: Instance, j: int) -> OrbitCandidates | None:
    """Orbit ``j``'s candidates when they have been generated already, else None."""
    return _cache_of(instance).get(j)


def pairs_within(start: np.ndarray, limit: float) -> int:
    """(first, covered) pairs of opportunities sorted by ``start`` whose starts lie within
    ``limit`` seconds (one Delta T) of each other (the ``stop`` of :func:`orbit_columns`)."""
    return int((starts_within(start, limit) - np.arange(len(start))).sum())


def orbit_pairs(instance: Instance, j: int) -> int:
    """Orbit ``j``'s (first, covered) pairs of opportunities within one Delta T: what its
    candidates' number and generation time, its window sweep and its plans grow with
    (cached per instance)."""
    store = _cache_of(instance, _PAIRS)
    if j not in store:
        start = np.asarray(instance.opp_start[instance.orbit_opps(j)], dtype=float)
        store[j] = pairs_within(start, float(instance.max_duration[j]))
    return store[j]


#: :func:`cluster_candidates` gives up at once when the orbits left are foreseen to take more
#: than this many times the time left (the foresight's margin: after 5 % of the work, the
#: rate so far foresaw the whole from 0.67 to 1.11 times its length on six instances).
FORESIGHT_MARGIN = 1.25

#: Seconds of generation before the foresight is trusted (a few orbits' worth).
FORESIGHT_AFTER_S = 0.1


class Pace:
    """The foresight of a stage that cannot answer in part (candidate generation, their
    arranging, :mod:`sosp.planner`): the work left, foreseen at the rate of the work done
    so far, against the deadline. Saves the time of a stage that would end in
    :class:`~sosp.errors.TimeLimitReached` anyway: on a 20,000-target instance the whole
    deadline, half of ASA-DTC's time limit.

    Time a unit of work with :meth:`begin` and :meth:`end`; :meth:`need` is the foreseen
    seconds of more units, and :meth:`late` says whether they are foreseen to need more
    than :data:`FORESIGHT_MARGIN` times the time left (only after
    :data:`FORESIGHT_AFTER_S` of work: the first units are not yet a rate).
    """

    def __init__(
        self, deadline: float | None, clock: Callable[[], float] = time.perf_counter
    ) -> None:
        self.deadline = deadline
        self.clock = clock
        self.spent = 0.0
        self.done = 0
        self._t = 0.0

    def begin(self) -> float:
        """Start timing a unit; returns the time now."""
        self._t = self.clock()
        return self._t

    def end(self, units: int) -> None:
        """The unit started by :meth:`begin` is done, ``units`` of work."""
        self.spent += self.clock() - self._t
        self.done += units

    def need(self, units: int) -> float:
        """Seconds foreseen for ``units`` more at the rate so far."""
        return self.spent / max(self.done, 1) * units

    def late(self, units: int, now: float) -> bool:
        """Whether ``units`` more are foreseen to need more than :data:`FORESIGHT_MARGIN`
        times the time from ``now`` to the deadline."""
        if self.deadline is None or self.spent < FORESIGHT_AFTER_S:
            return False
        return self.need(units) > FORESIGHT_MARGIN * (self.deadline - now)


def cluster_candidates(
    instance: Instance,
    max_candidates: int | None = MAX_CANDIDATES,
    deadline: Budget | float | None = None,
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
        A :class:`~sosp.stop.Budget` (or a :func:`time.perf_counter` deadline): raise
        :class:`~sosp.errors.InputError` when it expires before the candidates are
        complete, or when they are foreseen not to be (:class:`~sosp.errors.TimeLimitReached`:
        the orbits left at the rate so far, or, without a cap, their size estimate alone
        past :data:`ESTIMATE_SHARE` of the time left, or their generation past the time
        left); without a cap, candidates that would not fit in its memory are refused
        (:func:`check_memory`). None: no limit.

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
    budget = as_budget(deadline)
    if max_candidates is None:
        if _need_by(instance, budget.share(ESTIMATE_SHARE)) is None:
            raise TimeLimitReached(
                "time limit foreseen to be reached while estimating the candidate "
                "observations' size; give more time or use asa-dtc"
            )
        check_memory(instance, budget.memory)
        if _generation_late(instance, budget):
            raise TimeLimitReached(
                "time limit foreseen to be reached while generating candidate observations "
                f"(about {estimate_bytes(instance) / 2**30:.2f} GB estimated); give more time "
                "or use asa-dtc"
            )
    parts: list[OrbitCandidates] = []
    total = 0
    # the foresight counts the orbits to generate (not those cached) by their opportunities
    # (an orbit's generation time grows with them, about one start each)
    size = np.diff(instance.orbit_offsets)
    todo = [j for j in range(instance.n_orbits) if j not in store]
    pace, opps_left = Pace(budget.deadline), int(size[todo].sum())
    for j in range(instance.n_orbits):
        left = None if max_candidates is None else max_candidates - total
        generated = j not in store
        if generated:
            now = pace.begin()
            if pace.late(opps_left, now):
                raise TimeLimitReached(
                    "time limit foreseen to be reached while generating candidate observations "
                    f"(about {pace.need(opps_left):.1f} s left to generate, "
                    f"{budget.left():.1f} s to the deadline); give more time or use asa-dtc"
                )
        part = orbit_candidates(instance, j, budget.deadline, left)
        if generated:
            pace.end(int(size[j]))
            opps_left -= int(size[j])
        total += part.size
        parts.append(part)
    del part
    # Copy the orbits' columns into whole-instance ones, freeing each orbit's as it is copied
    # (peak: the whole plus one orbit), then make the orbits' entries views of the whole.
    orbit = np.empty(total, dtype=np.int64)
    start, end, roll = np.empty(total), np.empty(total), np.empty(total)
    ptr = np.zeros(total + 1, dtype=np.int64)
    flat = np.empty(sum(len(p.opps.flat) for p in parts), dtype=np.int32)
    spans = []
    b = 0
    for k in range(len(parts)):
        p = parts[k]
        a, b = b, b + p.size
        fa, fb = ptr[a], ptr[a] + len(p.opps.flat)
        orbit[a:b] = p.orbit
        start[a:b], end[a:b], roll[a:b] = p.start, p.end, p.roll
        ptr[a + 1 : b + 1] = p.opps.ptr[1:] + fa
        flat[fa:fb] = p.opps.flat
        spans.append((p.orbit, a, b))
        parts[k] = None  # type: ignore[call-overload]
        store.pop(p.orbit, None)
        del p
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


def _worker_orbit(args: tuple[int, float | None]) -> OrbitCandidates:
    j, deadline = args
    return _generate_orbit(inherited(), j, deadline, None)


def _need_by(instance: Instance, budget: Budget | None) -> int | None:
    """:func:`estimate_bytes`, or None when the estimate is foreseen not to be done within
    ``budget`` (None: no limit), which is then not kept: before each sample, the samples
    left at the rate of those done so far (measured here: a sample's time varies by orders
    of magnitude with the orbit's density) must fit in it."""
    store = _cache_of(instance)
    if "need" not in store:
        total = float(_cached_bytes(instance))
        samples = _samples(instance)
        left, done, t0 = sum(len(picks) for _, picks in samples), 0, time.perf_counter()
        for j, picks in samples:
            ts, te, lo, hi, limit, stop = orbit_columns(instance, j)
            size = 0.0
            for i in picks:
                rate = (time.perf_counter() - t0) / max(done, 1)
                if budget is not None and not budget.fits(rate * (left - done)):
                    log.info("candidates: their size estimate foreseen past its share of the time")
                    return None
                n_cand, n_members = _start_counts(int(i), ts, te, lo, hi, int(stop[i]), limit)
                size += 32.0 * n_cand + 4.0 * n_members
                done += 1
            total += size * len(ts) / len(picks)
        store["need"] = int(total)
    return int(store["need"])


#: What a search's ``candidates`` parameter takes (``orbit-dp``, ``milp-lns``).
CandidateMode = Literal["auto", "explicit", "windows"]
CANDIDATE_MODES = get_args(CandidateMode)


def candidate_mode(instance: Instance, requested: str, budget: Budget | float | None = None) -> str:
    """``"explicit"`` or ``"windows"``: the candidates a search uses when ``candidates`` is
    ``requested`` (one of :data:`CANDIDATE_MODES`). ``"auto"`` is explicit where they fit
    in the ``budget``'s memory (:func:`candidate_cap`) and, with a time limit, where their
    estimate is not foreseen to take more than :data:`ESTIMATE_SHARE` of the time left
    (a :func:`time.perf_counter` deadline is taken as a budget until it); ``"explicit"``
    where they do not fit is refused here, before the search spends any time
    (:func:`check_memory`)."""
    budget = as_budget(budget)
    if requested == "auto":
        need = _need_by(instance, budget.share(ESTIMATE_SHARE))
        if need is None or need > candidate_cap(budget.memory):
            return "windows"
        return "windows" if _generation_late(instance, budget) else "explicit"
    if requested == "explicit":
        check_memory(instance, budget.memory)
    return requested


def check_memory(instance: Instance, memory: int | None = None) -> None:
    """Refuse with a one-line :class:`~sosp.errors.InputError` when every orbit's candidates
    would take more than :func:`candidate_cap` of ``memory`` bytes (None: the default)."""
    need, cap = estimate_bytes(instance), candidate_cap(memory)
    if need > cap:
        raise InputError(
            f"about {need / 2**30:.1f} GB of candidate observations estimated (densest "
            f"orbit {instance.orbit_ids[_densest(instance)]!r}); more than the "
            f"{cap / 2**30:.1f} GB allowed (a third of --max-memory): too dense for the "
            "clustering-exact candidates (orbit-dp and asa-dtc plan over time windows instead: "
            "--param candidates=auto or windows)"
        )


def generate_in_processes(instance: Instance, workers: int, deadline: float | None = None) -> None:
    """Generate the candidates of every orbit in ``workers`` forked processes, largest orbits
    first, and cache them as :func:`orbit_candidates` would (no cap).

    Worth it only when the orbits are many and dense: each orbit's arrays travel back through
    a pipe (about 30 bytes per candidate and 4 per member). Where processes cannot be forked
    the orbits are generated here, one after another.
    """
    store = _cache_of(instance)
    todo = [j for j in range(instance.n_orbits) if j not in store]
    if todo:
        # before any process generates: each would fill its memory with a dense orbit's
        # candidates (D100 with two workers was killed at 24 GB before this check)
        check_memory(instance)
    sizes = np.diff(instance.orbit_offsets)
    todo.sort(key=lambda j: -int(sizes[j]))
    pool = fork_pool(min(workers, len(todo)), instance)
    if pool is None:
        for j in todo:
            orbit_candidates(instance, j, deadline)
        return
    with pool:
        for out in pool.imap_unordered(_worker_orbit, [(j, deadline) for j in todo]):
            store[out.orbit] = out


def orbit_columns(
    instance: Instance, j: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    """Orbit j's opportunities as the generators use them: ``ts, te``, the roll range
    ``lo, hi``, Delta T and, per opportunity, one past the last one starting within Delta T
    of it (a contiguous run: the opportunities are sorted by start)."""
    sl = instance.orbit_opps(j)
    ts = np.asarray(instance.opp_start[sl], dtype=float)
    te = np.asarray(instance.opp_end[sl], dtype=float)
    lo = np.asarray(instance.opp_roll_min[sl], dtype=float)
    hi = np.asarray(instance.opp_roll_max[sl], dtype=float)
    limit = float(instance.max_duration[j])
    return ts, te, lo, hi, limit, starts_within(ts, limit)


def _densest(instance: Instance) -> int:
    """The orbit with the most (first, covered) pairs inside one Delta T."""
    return max(range(instance.n_orbits), key=lambda j: orbit_pairs(instance, j), default=0)


def _generation_late(instance: Instance, budget: Budget) -> bool:
    """Whether generating the candidates of the orbits not cached yet is foreseen not to fit
    in ``budget`` (never without a time limit) at :data:`GENERATE_S_PER_BYTE` of their
    estimate."""
    if budget.deadline is None:
        return False
    foreseen = GENERATE_S_PER_BYTE * max(0, estimate_bytes(instance) - _cached_bytes(instance))
    if foreseen == 0.0 or budget.fits(foreseen):
        return False  # (nothing estimated: no foresight, even past the deadline)
    log.info("candidates: their generation foreseen at %.1f s", foreseen)
    return True


def _cached_bytes(instance: Instance) -> int:
    """Bytes of the orbits' candidates generated (cached) so far."""
    store = _cache_of(instance)
    return sum(store[j].nbytes for j in range(instance.n_orbits) if j in store)


def _samples(instance: Instance) -> list[tuple[int, np.ndarray]]:
    """The orbits :func:`estimate_bytes` samples (dense ones not generated yet) and, for
    each, the first opportunities sampled (orbit positions)."""
    store = _cache_of(instance)
    out = []
    for j in range(instance.n_orbits):
        if j in store:
            continue
        sl = instance.orbit_opps(j)
        n = sl.stop - sl.start
        if n == 0 or orbit_pairs(instance, j) < _SAMPLE_FROM:
            continue
        out.append((j, np.unique(np.linspace(0, n - 1, min(_SAMPLES, n)).astype(np.int64))))
    return out


def estimate_bytes(instance: Instance) -> int:
    """Estimated bytes of every orbit's candidates (what :func:`cluster_candidates` would hold),
    computed once per instance object (seconds on dense ones).

    Orbits with few (first, covered) pairs inside one Delta T count 0 (their candidates are a
    few megabytes); on the others the candidates of a fixed, evenly spaced sample of first
    opportunities are counted (:func:`_start_counts`) and scaled to the orbit (under a
    second on an orbit with thousands of opportunities). Deterministic.
    """
    need = _need_by(instance, None)
    assert need is not None  # (no deadline)
    return need


def _too_many(instance: Instance, j: int, max_candidates: int) -> InputError:
    return InputError(
        f"orbit {instance.orbit_ids[j]!r}: more than {max_candidates} candidate "
        "observations; the instance is too dense for the clustering-exact MILP "
        "(use orbit-dp, asa-dtc or sosp bound --method lagrangian)"
    )


def _generate_orbit(
    instance: Instance, j: int, deadline: float | None, max_candidates: int | None
) -> OrbitCandidates:
    """The work of :func:`orbit_candidates` (uncached): :func:`generate` over the orbit's
    opportunities, stopped with an error naming the orbit at ``deadline`` or beyond
    ``max_candidates``."""
    sl = instance.orbit_opps(j)
    ts, te, lo, hi, limit, stop = orbit_columns(instance, j)
    out_roll: list[np.ndarray] = []
    out_sizes: list[np.ndarray] = []
    out_members: list[np.ndarray] = []
    count = 0
    for roll, sizes, members in generate(ts, te, lo, hi, limit, stop):
        out_roll.append(roll)
        out_sizes.append(sizes)
        out_members.append((members + sl.start).astype(np.int32))
        count += len(roll)
        if max_candidates is not None and count > max_candidates:
            raise _too_many(instance, j, max_candidates)
        # A stop request ends the generation as the deadline does: callers fall back alike.
        if stop_requested() or (deadline is not None and time.perf_counter() > deadline):
            why = "stopped" if stop_requested() else "time limit reached"
            raise TimeLimitReached(
                f"orbit {instance.orbit_ids[j]!r}: {why} "
                f"while generating candidate observations ({count} so far); give more time "
                "or use asa-dtc"
            )
    return _pack(instance, j, out_roll, out_sizes, out_members)


def generate(
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    limit: float,
    stop: np.ndarray | None = None,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The non-dominated candidate observations over one orbit's opportunities, by first one.

    The one generator of the clustering-exact candidates (module docstring): whole orbits
    (:func:`orbit_candidates`) and any subset of an orbit's opportunities (ASA-DTC's stretch
    re-planning, which plans over the options still free) go through it.

    Parameters
    ----------
    ts, te, lo, hi
        Window and roll range of each opportunity, sorted by start ``ts``.
    limit
        Delta T of (11).
    stop
        Per opportunity, one past the last one starting within ``limit`` of it (computed when
        None).

    Yields
    ------
    tuple
        Per first opportunity with candidates: ``(roll, sizes, members)``, the candidates'
        rolls, their numbers of covered opportunities and those opportunities' positions
        (concatenated, each group sorted). Two starts or two ends at the same time can give
        the same candidate twice; the first is kept.
    """
    n = len(ts)
    if stop is None:
        stop = starts_within(ts, limit)
    same = ts[1:] == ts[:-1]
    tied = np.r_[False, same] | np.r_[same, False]  # a start time shared with a neighbour
    seen: set[tuple[float, bytes]] = set()
    seen_ts = None
    for i in range(n):
        if ts[i] != seen_ts:
            seen.clear()
            seen_ts = ts[i]
        got = _start_candidates(i, ts, te, lo, hi, int(stop[i]), limit)
        if got is None:
            continue
        end_pos, roll, ptr, members = got
        sizes = np.diff(ptr)
        if tied[i] or len(np.unique(te[end_pos])) < len(np.unique(end_pos)):
            keep = []
            for u in range(len(roll)):
                key = (float(te[end_pos[u]]), members[ptr[u] : ptr[u + 1]].tobytes())
                if key not in seen:
                    seen.add(key)
                    keep.append(u)
            if len(keep) < len(roll):
                keep_a = np.asarray(keep, dtype=np.int64)
                members = members[ragged_positions(ptr[keep_a], sizes[keep_a])]
                roll, sizes = roll[keep_a], sizes[keep_a]
        yield roll, sizes, members


def _pack(
    instance: Instance,
    j: int,
    out_roll: list[np.ndarray],
    out_sizes: list[np.ndarray],
    out_members: list[np.ndarray],
) -> OrbitCandidates:
    """One orbit's candidates as read-only columns, windows (10) from the members."""
    sizes = np.concatenate(out_sizes) if out_sizes else np.zeros(0, dtype=np.int64)
    ptr = offsets(sizes)
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


def _start_candidates(
    i: int,
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    stop: int,
    limit: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The candidates whose first opportunity is i (orbit positions), vectorised
    (:func:`_start_kept`, then their members).

    Returns
    -------
    tuple or None
        ``(end_pos, roll, member_ptr, member_pos)``: per candidate the end opportunity and the
        roll, and the covered opportunities (orbit positions, CSR); None when there are none.
    """
    got = _start_kept(i, ts, te, lo, hi, stop, limit)
    if got is None:
        return None
    w, ends, rolls, inside, pair_l, pair_t, size, keep = got
    te_w = te[w]
    cost = np.abs(rolls)
    # per end, the kept rolls in rank order (|theta|, then larger cover, then roll index)
    keep = keep[np.lexsort((pair_t[keep], -size[keep], cost[pair_t[keep]], pair_l[keep]))]
    kl, kt = pair_l[keep], pair_t[keep]
    # members: k with the roll in range and te_k <= te_l + EPS, in index order
    cover = inside[:, kt].T & (te_w[None, :] <= te_w[ends[kl]][:, None] + EPS)
    rows, cols = np.nonzero(cover)
    ptr = offsets(np.bincount(rows, minlength=len(kt)))
    return w[ends[kl]], rolls[kt], ptr, w[cols]


def _start_counts(
    i: int,
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    stop: int,
    limit: float,
) -> tuple[int, int]:
    """How many candidates start at i and how many members they have in all: the sizes of
    :func:`_start_candidates`'s answer without building it (a candidate's size is its count
    of opportunities whose range holds its roll, among those ending by its end: exactly its
    members). What :func:`estimate_bytes` needs; building the members took 17 s of samples
    on an orbit of 2,983 opportunities, where the counts take a fraction."""
    got = _start_kept(i, ts, te, lo, hi, stop, limit)
    if got is None:
        return 0, 0
    size, keep = got[6], got[7]
    return len(keep), int(size[keep].sum())


def _start_kept(
    i: int,
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    stop: int,
    limit: float,
) -> tuple[np.ndarray, ...] | None:
    """The non-dominated (end, roll) pairs of the candidates whose first opportunity is i.

    The same candidates, in the same order, as the reference loop of the tests
    (``tests/sosp/candidates_reference.py``): for each end l (in index order) the rolls of the
    common range of i and l, those not dominated at l (no earlier one in the order (|theta|,
    larger cover, index) covers a superset) in that order. Domination is decided without
    building each l's cover matrix:

    * each opportunity k's roll range holds an interval ``[a_k, b_k]`` of the sorted rolls,
      so ``cover_l(t)`` is not inside ``cover_l(q)`` iff some k with ``te_k <= te_l`` has
      ``t`` in its interval and ``q`` not; with the opportunities in te order, ``viol[t, q]``
      is the first such k, found for every pair (t, q) from the intervals by cumulative
      minima, and ``cover_l(t) <= cover_l(q)`` iff ``viol[t, q] >= n_l`` (those with
      ``te_k <= te_l``);
    * the rolls of no larger |theta| than t form an interval around nadir, so "an earlier one
      covers a superset" is a range maximum of ``viol[t, .]`` (sparse table) over that
      interval cut to l's rolls, plus the one roll of equal |theta| (-theta), if any.

    Returns
    -------
    tuple or None
        ``(w, ends, rolls, inside, pair_l, pair_t, size, keep)``: the positions ``w`` from i
        to ``stop``, the ends (indices into ``w``), the roll grid, which rolls each of ``w``
        holds, the (end, roll) pairs as indices into ``ends`` and ``rolls`` with their
        covers' sizes, and the pairs kept (not dominated); None when there are none.
    """
    w = np.arange(i, stop)
    te_w, lo_w, hi_w = te[w], lo[w], hi[w]
    end_ok = (te_w >= te[i] - EPS) & (te_w - ts[i] <= limit + EPS)
    if not end_ok.any():
        return None
    rolls = np.unique(np.concatenate(([0.0], lo_w[lo_w > 0], hi_w[hi_w < 0])))
    rolls = rolls[roll_in_range(rolls, lo[i], hi[i])]
    n_t = len(rolls)
    if n_t == 0:
        return None
    inside = roll_in_range(rolls[None, :], lo_w[:, None], hi_w[:, None])
    n_k = len(w)
    has = inside.any(axis=1)
    a = np.where(has, inside.argmax(axis=1), n_t)  # interval [a_k, b_k] of rolls (empty: a > b)
    b = np.where(has, n_t - 1 - inside[:, ::-1].argmax(axis=1), -1)
    # opportunities in te order: position p of each, and n_l = how many have te <= te_l + EPS
    by_te = np.argsort(te_w, kind="stable")
    p_of = np.empty(n_k, dtype=np.int64)
    p_of[by_te] = np.arange(n_k)
    ends = np.flatnonzero(end_ok & has)
    if ends.size == 0:
        return None
    n_l = np.searchsorted(te_w[by_te], te_w[ends] + EPS, side="right")
    # viol[t, q]: first te position of a k with t in [a_k, b_k] and q outside (n_k: none)
    big = n_k
    m0 = np.full((n_t, n_t), big, dtype=np.int64)  # m0[a, b]: first k with interval (a, b)
    hk = np.flatnonzero(has)
    np.minimum.at(m0, (a[hk], b[hk]), p_of[hk])
    # q < t: violators have a_k in (q, t] and b_k >= t
    m = np.minimum.accumulate(m0[:, ::-1], axis=1)[:, ::-1]  # m[a, t] = min over b >= t
    tri = np.arange(n_t)
    m_up = np.where(tri[:, None] <= tri[None, :], m, big)  # keep a <= t
    r = np.minimum.accumulate(m_up[::-1], axis=0)[::-1]  # r[a, t] = min over a' in [a, t]
    viol = np.full((n_t, n_t), big, dtype=np.int64)
    low = tri[:, None] > tri[None, :]  # (t, q) with q < t
    tq_t, tq_q = np.nonzero(low)
    viol[tq_t, tq_q] = r[tq_q + 1, tq_t]
    # q > t: violators have b_k in [t, q) and a_k <= t
    n0 = m0.T  # n0[b, a]
    nn = np.minimum.accumulate(n0, axis=1)  # nn[b, t] = min over a <= t
    n_dn = np.where(tri[:, None] >= tri[None, :], nn, big)  # keep b >= t
    qq = np.minimum.accumulate(n_dn, axis=0)  # qq[b, t] = min over b' in [t, b]
    tq_t, tq_q = np.nonzero(~low & (tri[:, None] != tri[None, :]))
    viol[tq_t, tq_q] = qq[tq_q - 1, tq_t]
    # sizes: cnt[t, n] = opportunities among the first n in te order whose range holds t
    cnt = np.zeros((n_t, n_k + 1), dtype=np.int64)
    np.cumsum(inside[by_te].T, axis=1, out=cnt[:, 1:])
    # every (end, roll) pair with the roll in the end's range, ends in index order
    a_l, b_l = a[ends], b[ends]
    per = b_l - a_l + 1
    pair_l = np.repeat(np.arange(len(ends)), per)
    pair_t = ragged_positions(a_l, per)
    nl = n_l[pair_l]
    size = cnt[pair_t, nl]
    cost = np.abs(rolls)
    # rolls of strictly smaller |theta| than t: an interval [lo_t, hi_t] around nadir
    lo_t = np.searchsorted(rolls, -cost, side="right")
    hi_t = np.searchsorted(rolls, cost, side="left") - 1
    qa = np.maximum(lo_t[pair_t], a_l[pair_l])
    qb = np.minimum(hi_t[pair_t], b_l[pair_l])
    dropped = np.zeros(len(pair_t), dtype=bool)
    nonempty = qa <= qb
    if nonempty.any():
        best = _range_max_rows(viol, pair_t[nonempty], qa[nonempty], qb[nonempty])
        dropped[nonempty] = best >= nl[nonempty]
    # the roll of equal |theta| (-theta), if in the grid and in l's range
    mirror = np.searchsorted(rolls, -rolls)
    mirror = np.where(
        (mirror < n_t) & (rolls[np.minimum(mirror, n_t - 1)] == -rolls) & (rolls != 0), mirror, -1
    )
    q = mirror[pair_t]
    has_q = (q >= a_l[pair_l]) & (q <= b_l[pair_l]) & (q >= 0)
    if has_q.any():
        idx = np.flatnonzero(has_q)
        qi, ti = q[idx], pair_t[idx]
        size_q = cnt[qi, nl[idx]]
        earlier = (size_q > size[idx]) | ((size_q == size[idx]) & (qi < ti))
        dropped[idx] |= earlier & (viol[ti, qi] >= nl[idx])
    keep = np.flatnonzero(~dropped)
    return w, ends, rolls, inside, pair_l, pair_t, size, keep


def _range_max_rows(
    mat: np.ndarray, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """``max(mat[r, lo:hi + 1])`` for each query (lo <= hi), by a sparse table per row."""
    n = mat.shape[1]
    tables = [mat]
    span = 1
    while 2 * span <= n:
        prev = tables[-1]
        width = prev.shape[1]  # n - span + 1 windows of length span
        tables.append(np.maximum(prev[:, : width - span], prev[:, span:]))  # length 2 * span
        span *= 2
    length = hi - lo + 1
    level = np.floor(np.log2(length)).astype(np.int64)
    out = np.empty(len(rows), dtype=mat.dtype)
    for lev in np.unique(level):
        sel = level == lev
        tab = tables[lev]
        width = 1 << int(lev)
        r, a_, b_ = rows[sel], lo[sel], hi[sel]
        out[sel] = np.maximum(tab[r, a_], tab[r, b_ - width + 1])
    return out


def flatten(groups: Sequence[Sequence[int]]) -> tuple[np.ndarray, np.ndarray]:
    """``(sizes, flat)``: the length of each group of indices and all of them concatenated."""
    if isinstance(groups, OppGroups):
        return groups.sizes, groups.flat  # int32, read-only for cached candidates
    sizes = np.fromiter((len(g) for g in groups), dtype=np.int64, count=len(groups))
    flat = np.fromiter(chain.from_iterable(groups), dtype=np.int64, count=int(sizes.sum()))
    return sizes, flat
