"""Pricing over rolls by a sweep inside each time window: single-orbit planning without the
explicit candidate observations.

:mod:`sosp.candidates` lists every non-dominated (first, last, roll) observation of an orbit;
on dense orbits (thousands of opportunities, a thousand inside one Delta T) that is tens of
gigabytes. At given prices, though, only the best roll of each window matters. For an orbit's
opportunities sorted by start, a first opportunity i and a last one k (``ts_k >= ts_i``,
``te_k >= te_i``, ``te_k <= ts_i + Delta T`` (11)), let

    G(i, k) = max over r in [lo_i, hi_i] of sum of price over the opportunities j with
              ts_j >= ts_i, te_j <= te_k and r in [lo_j, hi_j]            ((7)-(8))

(opportunities of price 0 add nothing and are left out). With i fixed and k growing in end
order this is "insert an interval of rolls with weight p, query the largest total weight at
one roll": a segment tree over the window's (clipped) left ends of the roll ranges, where the
maximum is reached, answers each insertion in O(log m) (:func:`_sweep`, compiled by numba:
about 6 times faster than a numpy sweep vectorised per first opportunity on the densest
orbit of 10,000 targets in the C region, ``benchmarks/bench_windows.py``). Only
the k where G grows are kept: a larger k at the same gain is a longer window worth no more.

Two uses:

* :func:`relaxed_items` (an upper-bound relaxation for the bounds). Item (i, k) has gain
  G(i, k), window [ts_i, te_k] and |theta| the least |r| over [lo_i, hi_i]. Every real
  observation whose first opportunity is i (nothing starts before ts_i) and whose last is k'
  (the latest end) has roll r in [lo_i, hi_i] and covers only opportunities counted in
  G(i, k'); the kept item (i, k) with the largest te_k <= te_k' has G(i, k) = G(i, k') (G did
  not grow in between). So its gain is at most G(i, k), its window holds [ts_i, te_k] and its
  |theta| is at least the item's. Hence the item's (3) interval
  ``[ts - |theta| / v, te + a + |theta| / v)`` (:mod:`sosp.rules`) lies inside the
  observation's, its duration (observe terms of (4)-(5)) is no longer, and its |theta| no
  larger (the exact slew term of (4), ``(2 sum |theta| - |theta_first| - |theta_last|) / v``,
  has nonnegative coefficients). Observations starting at an opportunity of price 0 are
  dominated the same way by the item starting at their earliest priced member. Two
  observations of one plan never map to the same item (both would start at ts_i and overlap
  in time, against (3)). So mapping a plan's observations to their items gives a sequence of
  as many items, pairwise compatible by (3), worth at least as much, with no larger
  penalties: the single-orbit recursion of :mod:`sosp.planner` (levels for (6), (4)-(5) as
  Lagrangian penalties) over the items is an upper bound on the best plan of the orbit at
  these prices, the explicit candidates' included (:func:`relaxed_best_path`).

  **Roll bands.** Taking |theta| as the least over i's whole range (6 degrees in the
  generated scenarios) under-states every slew, and the bound with it is 2-4 % above the
  explicit candidates' on dense instances. Cut the roll axis into bands
  ``[b * band, (b + 1) * band]`` and run the sweep per band, each range clipped to the band:
  item (i, k, b) is worth G_b(i, k), the best gain at a roll of i's range inside band b, with
  |theta| the least over that part. A real observation of roll r lies in some band b whose
  clipped ranges still hold r for all its members, so the argument above holds with band b's
  items, and the relaxation stays an upper bound while its |theta| is at most one band short
  of the real one (:func:`window_items` with ``band``). Each (i, k, b) is dominated by the
  whole-range item (i, k'), so the banded bound is never above the unbanded one.
* :func:`window_plan` (real observations for the schedule planners). The argmax roll
  r*(i, k) of each kept item (ties: closest to nadir) gives an observation: the priced
  opportunities of the window whose range holds r*, window (10) over them, roll by the roll
  rule in their common range (8). A restricted candidate set at those prices, over which the
  single-orbit recursion plans the orbit (``orbit-dp`` with ``candidates="windows"``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from sosp.candidates import OppGroups, offsets, readonly
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.recursion import least_penalty_plan, recursion, release_order
from sosp.rules import (
    EPS,
    OrbitRules,
    RollRule,
    check_roll_rule,
    choose_roll,
    orbit_rules,
    starts_within,
)

log = logging.getLogger(__name__)


# ------------------------------------------------------------------------ the sweep kernel
@njit(cache=True)
def _combine(t: np.ndarray, at: np.ndarray, absp: np.ndarray, node: int, add: float) -> None:
    """Node ``node`` from its two children: the larger value (ties: the point closer to
    nadir), plus the node's pending addition."""
    a, b = 2 * node, 2 * node + 1
    va, vb = t[a], t[b]
    if vb > va or (vb == va and absp[at[b]] < absp[at[a]]):
        t[node] = vb + add
        at[node] = at[b]
    else:
        t[node] = va + add
        at[node] = at[a]


@njit(cache=True)
def _range_add(
    t: np.ndarray,
    d: np.ndarray,
    at: np.ndarray,
    absp: np.ndarray,
    lft: int,
    rgt: int,
    size: int,
    val: float,
) -> None:
    """Add ``val`` to the leaves [lft, rgt) of the max tree (bottom-up, no push-down: a
    node's ``d`` is the addition pending on its whole subtree), then recombine the two
    paths to the root."""
    l0 = lft + size
    r0 = rgt + size
    lq, rq = l0, r0
    while lq < rq:
        if lq & 1:
            t[lq] += val
            if lq < size:
                d[lq] += val
            lq += 1
        if rq & 1:
            rq -= 1
            t[rq] += val
            if rq < size:
                d[rq] += val
        lq >>= 1
        rq >>= 1
    for p in (l0 >> 1, (r0 - 1) >> 1):
        while p >= 1:
            _combine(t, at, absp, p, d[p])
            p >>= 1


@njit(cache=True)
def _range_tag(
    tag_end: np.ndarray,
    tag_lo: np.ndarray,
    tag_hi: np.ndarray,
    lft: int,
    rgt: int,
    size: int,
    e_q: float,
    a_q: float,
    b_q: float,
) -> None:
    """Tag the O(log m) nodes covering the leaves [lft, rgt) with an insertion's end and
    range ends (:func:`_tag`)."""
    lq, rq = lft + size, rgt + size
    while lq < rq:
        if lq & 1:
            _tag(tag_end, tag_lo, tag_hi, lq, e_q, a_q, b_q)
            lq += 1
        if rq & 1:
            rq -= 1
            _tag(tag_end, tag_lo, tag_hi, rq, e_q, a_q, b_q)
        lq >>= 1
        rq >>= 1


@njit(cache=True)
def _tag(
    tag_end: np.ndarray,
    tag_lo: np.ndarray,
    tag_hi: np.ndarray,
    node: int,
    e_q: float,
    a_q: float,
    b_q: float,
) -> None:
    """Combine an insertion's end and range ends into ``node``'s tags (max, max, min)."""
    tag_end[node] = max(tag_end[node], e_q)
    tag_lo[node] = max(tag_lo[node], a_q)
    tag_hi[node] = min(tag_hi[node], b_q)


@njit(cache=True)
def _sweep(
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    w: np.ndarray,
    limit: float,
    eps: float,
    want_span: bool,
    out_first: np.ndarray,
    out_last: np.ndarray,
    out_gain: np.ndarray,
    out_point: np.ndarray,
    out_span: np.ndarray,
) -> int:
    """G(i, k) of the module docstring for every priced first opportunity i of one orbit.

    ``ts`` sorted; ``w`` the prices per opportunity. Writes one row per kept (i, k): first i,
    last k (the last opportunity inserted before G was read), G, the argmax roll r* and, in
    ``out_span`` (when ``want_span``: the relaxation does not need it), the members' (the
    inserted opportunities whose range holds r*) latest end and common range (8) (max of
    the lower ends, min of the upper ends, both clipped to i's range, which i itself, a
    member, bounds anyway); it returns the number of rows. The
    outputs must hold the sum over priced i of the opportunities starting in
    [ts_i, ts_i + limit].

    The span is kept by three more trees of tags over the same leaves: an insertion tags the
    O(log m) nodes covering its leaves with its end, lower and upper range ends (max, max,
    min), and a leaf's value is the combination of the tags on its path to the root, read in
    O(log m) for the argmax leaf only.
    """
    n = len(ts)
    n_out = 0
    first_same = 0
    # scratch for one window (at most every opportunity)
    idx = np.empty(n, dtype=np.int64)
    a_of = np.empty(n)
    b_of = np.empty(n)
    for i in range(n):
        if i > 0 and ts[i] != ts[i - 1]:
            first_same = i
        if w[i] <= 0.0:
            continue
        lo_i, hi_i = lo[i], hi[i]
        horizon = ts[i] + limit + eps
        # the window's priced opportunities (ties in start before i included) whose range
        # meets i's, their ranges clipped to i's
        m = 0
        j = first_same
        while j < n and ts[j] <= horizon:
            if w[j] > 0.0 and te[j] <= horizon:
                a = max(lo[j], lo_i)
                b = min(hi[j], hi_i)
                if a <= b + eps:
                    idx[m] = j
                    a_of[m] = a
                    b_of[m] = b if b >= a else a
                    m += 1
            j += 1
        # the maximum of a sum of intervals is reached at some interval's left end; equal
        # ends are one leaf (many ranges start at i's own lower end, or at the band's)
        srt = np.sort(a_of[:m])
        nl = 1
        for u in range(1, m):
            if srt[u] != srt[nl - 1]:
                srt[nl] = srt[u]
                nl += 1
        points = srt[:nl]
        absp = np.abs(points)
        size = 1
        while size < nl:
            size *= 2
        t = np.full(2 * size, -np.inf)
        d = np.zeros(2 * size)
        at = np.zeros(2 * size, dtype=np.int64)
        n_tags = 2 * size if want_span else 1
        tag_end = np.full(n_tags, -np.inf)
        tag_lo = np.full(n_tags, -np.inf)
        tag_hi = np.full(n_tags, np.inf)
        for q in range(size):
            at[size + q] = min(q, nl - 1)
            if q < nl:
                t[size + q] = 0.0
        for node in range(size - 1, 0, -1):
            _combine(t, at, absp, node, 0.0)
        order = np.argsort(te[idx[:m]], kind="mergesort")
        best = 0.0
        for s in range(m):
            q = idx[order[s]]
            lft = np.searchsorted(points, a_of[order[s]] - eps, side="left")
            rgt = np.searchsorted(points, b_of[order[s]] + eps, side="right")
            # range add of w[q] on leaves [lft, rgt)
            val = w[q]
            e_q, a_q, b_q = te[q], a_of[order[s]], min(hi[q], hi_i)
            if lft == 0 and rgt == nl:
                # every leaf: the root's pending addition alone (the padding leaves are
                # -inf and stay below every real leaf)
                t[1] += val
                d[1] += val
                if want_span:
                    _tag(tag_end, tag_lo, tag_hi, 1, e_q, a_q, b_q)
            else:
                _range_add(t, d, at, absp, lft, rgt, size, val)
                if want_span:
                    _range_tag(tag_end, tag_lo, tag_hi, lft, rgt, size, e_q, a_q, b_q)
            if s + 1 < m and te[idx[order[s + 1]]] == te[q]:
                continue  # read G once all opportunities ending at te[q] are in
            if te[q] < te[i]:
                continue  # the last opportunity ends no earlier than the first
            if t[1] > best:
                best = t[1]
                out_first[n_out] = i
                out_last[n_out] = q
                out_gain[n_out] = best
                out_point[n_out] = points[at[1]]
                n_out += 1
                if not want_span:
                    continue
                leaf = at[1] + size
                e, lo_m, hi_m = -np.inf, -np.inf, np.inf
                while leaf >= 1:
                    e = max(e, tag_end[leaf])
                    lo_m = max(lo_m, tag_lo[leaf])
                    hi_m = min(hi_m, tag_hi[leaf])
                    leaf >>= 1
                out_span[n_out - 1, 0] = e
                out_span[n_out - 1, 1] = lo_m
                out_span[n_out - 1, 2] = hi_m
    return n_out


@njit(cache=True)
def _members(
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    w: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    point: np.ndarray,
    eps: float,
    ptr: np.ndarray,
    flat: np.ndarray,
) -> int:
    """Members of each row's observation: the priced opportunities with ts >= ts_first,
    te <= te_last and ``point`` in their range (``ptr`` filled, ``flat`` as long as
    needed when given enough room; returns the total)."""
    n = len(ts)
    total = 0
    for u in range(len(first)):
        i, k, r = first[u], last[u], point[u]
        j = i
        while j > 0 and ts[j - 1] == ts[i]:
            j -= 1
        ptr[u] = total
        while j < n and ts[j] <= te[k]:
            if w[j] > 0.0 and te[j] <= te[k] and lo[j] - eps <= r and r <= hi[j] + eps:
                if total < len(flat):
                    flat[total] = j
                total += 1
            j += 1
    ptr[len(first)] = total
    return total


# ---------------------------------------------------------------------------- one orbit
@dataclass(frozen=True, eq=False)
class OrbitOpps:
    """One orbit's opportunities as columns (sorted by start, as the instance holds them).

    Attributes
    ----------
    orbit
        Orbit index j.
    first
        Global index of the orbit's first opportunity (the orbit's are ``first + local``).
    start, end, roll_min, roll_max
        Windows and roll ranges (7).
    target
        Target of each opportunity.
    rules
        The orbit's rules (:class:`sosp.rules.OrbitRules`).
    """

    orbit: int
    first: int
    start: np.ndarray
    end: np.ndarray
    roll_min: np.ndarray
    roll_max: np.ndarray
    target: np.ndarray
    rules: OrbitRules

    @property
    def size(self) -> int:
        return len(self.start)


def orbit_opps(instance: Instance, j: int) -> OrbitOpps:
    """The :class:`OrbitOpps` of orbit ``j``."""
    sl = instance.orbit_opps(j)
    cols = (getattr(instance, f"opp_{k}")[sl] for k in ("start", "end", "roll_min", "roll_max"))
    return OrbitOpps(
        j,
        int(sl.start),
        *(np.ascontiguousarray(c, dtype=float) for c in cols),
        np.asarray(instance.opp_target[sl], dtype=np.int64),
        orbit_rules(instance, j),
    )


@dataclass(frozen=True, eq=False)
class WindowItems:
    """The kept (i, k) of one orbit at some prices (local opportunity indices).

    Attributes
    ----------
    first, last
        First opportunity i and last opportunity k.
    gain
        G(i, k).
    point
        The argmax roll r*(i, k) (ties: closest to nadir).
    end, roll_lo, roll_hi
        The real observation of r*: its members' (the priced opportunities from i to k whose
        range holds r*) latest end and common range (8) (clipped to the row's band when the
        sweep ran per roll band). It starts at ts_i (i is a member). Empty when not asked
        for (``window_items(..., span=False)``).
    least_roll
        The least |r| over the rolls the row's maximum was taken over: i's range [lo_i, hi_i],
        clipped to the row's band when the sweep ran per roll band.
    """

    first: np.ndarray
    last: np.ndarray
    gain: np.ndarray
    point: np.ndarray
    end: np.ndarray
    roll_lo: np.ndarray
    roll_hi: np.ndarray
    least_roll: np.ndarray

    @property
    def size(self) -> int:
        return len(self.first)


def window_items(
    oo: OrbitOpps, price: np.ndarray, band: float | None = None, span: bool = True
) -> WindowItems:
    """G(i, k) and r*(i, k) of every kept (i, k) of the orbit at ``price`` (per target),
    with the observation's span (``end``, ``roll_lo``, ``roll_hi``) when ``span``.

    With ``band`` (degrees), the roll axis is cut into bands ``[b * band, (b + 1) * band]``
    and the sweep runs once per band over the opportunities meeting it, their ranges clipped
    to it: the rows are G_b(i, k), the maximum over the rolls of i's range inside band b.
    Every roll lies in some band, so each (i, k)'s maximum is still some row's; the rows add
    the information that a gain is reachable closer to nadir (``least_roll``), which the
    relaxation's slew terms use (:func:`relaxed_items`).
    """
    if band is not None and not band > 0.0:
        raise InputError(f"band: expected a positive number of degrees, got {band!r}")
    w = np.ascontiguousarray(np.asarray(price, dtype=float)[oo.target])
    parts: list[tuple[np.ndarray, ...]] = []
    for sel, clo, chi in _roll_cuts(oo.roll_min, oo.roll_max, w > 0.0, band):
        first, last, gain, point, spans = _window_rows(
            oo.start[sel], oo.end[sel], clo, chi, w[sel], float(oo.rules.max_duration), span
        )
        least = np.abs(choose_roll(clo[first], chi[first], "nadir"))  # the least |r|
        parts.append((sel[first], sel[last], gain, point, *spans.T, least))
    if not parts:
        return _no_items()
    return WindowItems(*(np.concatenate(c) for c in zip(*parts, strict=True)))


def _roll_cuts(
    lo: np.ndarray, hi: np.ndarray, priced: np.ndarray, band: float | None
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The sweeps :func:`window_items` runs: per roll band ``[b * band, (b + 1) * band]``
    the priced opportunities meeting it and their ranges clipped to it; without ``band``
    every opportunity with its whole range."""
    if band is None:
        yield np.arange(len(lo)), lo, hi
        return
    if not priced.any():
        return
    b_lo = int(np.floor(lo[priced].min() / band))
    b_hi = int(np.ceil(hi[priced].max() / band))
    for b in range(b_lo, max(b_hi, b_lo + 1)):
        e0, e1 = b * band, (b + 1) * band
        sel = np.flatnonzero(priced & (lo <= e1 + EPS) & (hi >= e0 - EPS))
        if len(sel):
            clo = np.maximum(lo[sel], e0)
            yield sel, clo, np.maximum(np.minimum(hi[sel], e1), clo)


def _no_items() -> WindowItems:
    z, f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return WindowItems(z, z, f, f, f, f, f, f)


def _window_rows(
    ts: np.ndarray,
    te: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    w: np.ndarray,
    limit: float,
    span: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The sweep's rows (first, last, G, r*, span (latest end, common range); no span
    rows when not ``span``) over opportunities sorted by start."""
    priced = np.flatnonzero(w > 0.0)
    if len(priced) == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z, np.zeros(0), np.zeros(0), np.zeros((0, 3))
    # room: per priced start, the opportunities starting in its window (ties before it too)
    lo_at = np.searchsorted(ts, ts[priced], side="left")
    hi_at = starts_within(ts, limit, ts[priced])
    room = int((hi_at - lo_at).sum())
    first = np.empty(room, dtype=np.int64)
    last = np.empty(room, dtype=np.int64)
    gain, point = np.empty(room), np.empty(room)
    spans = np.empty((room if span else 0, 3))
    ts, te, lo, hi, w = (readonly(c, float) for c in (ts, te, lo, hi, w))
    n = _sweep(ts, te, lo, hi, w, limit, EPS, span, first, last, gain, point, spans)
    return first[:n].copy(), last[:n].copy(), gain[:n].copy(), point[:n].copy(), spans[:n].copy()


# ----------------------------------------------------------------------- (a) the relaxation
@dataclass(frozen=True, eq=False)
class RelaxedItems:
    """The relaxation's items of one orbit at some prices (see the module docstring), in
    the arrangement :func:`sosp.recursion.recursion` takes.

    Attributes
    ----------
    items
        The kept (i, k) with their G and r*.
    start, end, duration, slew_s
        Per item: window [ts_i, te_k], its length and ``min |r| / v`` over [lo_i, hi_i].
    by_release, n_before
        Items by the right end ``R`` of their (3) interval, and per item how many of those
        may precede it (``R <= L``).
    """

    items: WindowItems
    start: np.ndarray
    end: np.ndarray
    duration: np.ndarray
    slew_s: np.ndarray
    by_release: np.ndarray
    n_before: np.ndarray

    @property
    def size(self) -> int:
        return self.items.size


def relaxed_items(oo: OrbitOpps, price: np.ndarray, band: float | None = None) -> RelaxedItems:
    """The items of the relaxation of orbit ``oo`` at ``price`` (per target), per roll band
    of ``band`` degrees when given (:func:`window_items`; the span is not needed)."""
    wi = window_items(oo, price, band, span=False)
    r = oo.rules
    start = oo.start[wi.first]
    end = oo.end[wi.last]
    # the least |roll| of each window's range: the (3) interval no observation of it beats
    by_release, n_before = release_order(r.left(start, wi.least_roll), r.right(end, wi.least_roll))
    slew_s = r.slew(wi.least_roll)
    return RelaxedItems(wi, start, end, end - start, slew_s, by_release, n_before)


def relaxed_best_path(
    oo: OrbitOpps,
    price: np.ndarray,
    lam_energy: float = 0.0,
    lam_memory: float = 0.0,
    prepared: RelaxedItems | None = None,
    band: float | None = None,
) -> tuple[float, np.ndarray, RelaxedItems]:
    """An upper bound on :func:`sosp.planner.best_path` of the orbit at these prices and
    penalties, with no candidate list: the same recursion over :func:`relaxed_items`.

    Returns
    -------
    tuple
        ``(value, path, items)``: the relaxation's value (>= the best plan's penalised value
        over the explicit candidates, 0 for the empty plan), its items in time order
        (positions into ``items``) and the items.
    """
    ri = relaxed_items(oo, price, band) if prepared is None else prepared
    if ri.size == 0:
        return 0.0, np.zeros(0, dtype=np.int64), ri
    r = oo.rules
    pe, pw = r.per_unit(lam_energy, lam_memory)
    value, path = recursion(
        ri.slew_s, ri.duration, ri.items.gain, ri.by_release, ri.n_before, r, pe, pw
    )
    return float(value), path, ri


def item_targets(oo: OrbitOpps, price: np.ndarray, ri: RelaxedItems, path: np.ndarray) -> Any:
    """The targets the items ``path`` count in their gain (priced members at r*), with
    repeats across items."""
    if len(path) == 0:
        return np.zeros(0, dtype=np.int64)
    w = np.ascontiguousarray(np.asarray(price, dtype=float)[oo.target])
    it = ri.items
    ptr, flat = _member_lists(oo, w, it.first[path], it.last[path], it.point[path])
    return oo.target[flat]


#: Most members :func:`window_candidates` lists for one orbit (8 bytes each, and as much
#: again in the model built from them): an orbit of 887 opportunities over a polar box of
#: 10,000 targets has 116 million, a denser one 3.7 billion (27.5 GiB, a MemoryError).
MAX_WINDOW_MEMBERS = 200_000_000


class TooManyMembers(ValueError):
    """An orbit's window candidates would list more than :data:`MAX_WINDOW_MEMBERS`."""


def _member_lists(
    oo: OrbitOpps, w: np.ndarray, first: np.ndarray, last: np.ndarray, point: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """CSR (ptr, flat local indices) of :func:`_members`; :class:`TooManyMembers` beyond
    :data:`MAX_WINDOW_MEMBERS`, before they are allocated."""
    cols = (readonly(c, float) for c in (oo.start, oo.end, oo.roll_min, oo.roll_max, w))
    first, last = readonly(first, np.int64), readonly(last, np.int64)
    point = readonly(point, float)
    ptr = np.zeros(len(first) + 1, dtype=np.int64)
    # int32, as OppGroups holds them: the first touch of fresh memory is slow, so the list is
    # made once, in the smallest type, and made global in place (:func:`_global`)
    guess = np.zeros(max(8 * len(first), 1), dtype=np.int32)
    args = (*cols, first, last, point, EPS)
    total = _members(*args, ptr, guess)
    if total > MAX_WINDOW_MEMBERS:
        raise TooManyMembers(
            f"orbit {oo.orbit}: {total:,} window candidate members, more than "
            f"{MAX_WINDOW_MEMBERS:,}"
        )
    if total > len(guess):
        guess = np.zeros(total, dtype=np.int32)
        _members(*args, ptr, guess)
    return ptr, guess[:total]


def _observation_opps(oo: OrbitOpps, price: np.ndarray, wi: WindowItems, rows: Any) -> OppGroups:
    """The members of the observations of rows ``rows`` of ``wi`` (:func:`_member_lists`),
    each target once (:func:`_one_per_target`), as global opportunity indices."""
    w = np.ascontiguousarray(np.asarray(price, dtype=float)[oo.target])
    ptr, flat = _member_lists(oo, w, wi.first[rows], wi.last[rows], wi.point[rows])
    ptr, flat = _one_per_target(oo, ptr, flat)
    flat += np.int32(oo.first)  # in place: the list is made once (:func:`_member_lists`)
    return OppGroups(ptr, flat)


def _one_per_target(oo: OrbitOpps, ptr: np.ndarray, flat: np.ndarray) -> tuple[Any, Any]:
    """The groups with each target once (its first opportunity kept): a target seen twice
    inside one window is covered once (2)."""
    if len(np.unique(oo.target)) == len(oo.target):
        # no target twice on the orbit, so none twice in a window: no sort (seconds on
        # millions of members)
        return ptr, flat
    seg = np.repeat(np.arange(len(ptr) - 1), np.diff(ptr))
    tgt = oo.target[flat]
    order = np.lexsort((flat, tgt, seg))
    dup = np.zeros(len(flat), dtype=bool)
    dup[order[1:]] = (seg[order[1:]] == seg[order[:-1]]) & (tgt[order[1:]] == tgt[order[:-1]])
    if not dup.any():
        return ptr, flat
    keep = ~dup
    return offsets(np.bincount(seg[keep], minlength=len(ptr) - 1)), flat[keep]


def compile_window_kernels() -> None:
    """Compile (or load from numba's cache) the sweep's kernels (:func:`_sweep`,
    :func:`_members`) now, through the functions that call them, on a two-opportunity
    orbit: :func:`sosp.planner.compile_kernels` calls it before the clocks start. Compiling
    them the first time on a machine takes about 6 s, which a first window bound spent
    inside its time limit (D30 at 0.05 s: 7 s)."""
    cols = [np.array(c) for c in ([0.0, 1.0], [2.0, 3.0], [-5.0, -4.0], [5.0, 6.0])]
    w = np.ones(2)
    first, last, _, point, _ = _window_rows(*cols, w, 10.0)
    oo = OrbitOpps(0, 0, *cols, np.arange(2), None)  # type: ignore[arg-type]
    _member_lists(oo, w, first, last, point)


# --------------------------------------------------------------------- (b) real observations


@dataclass(frozen=True, eq=False)
class WindowPlan:
    """A feasible plan of one orbit made of real observations (time order).

    Attributes
    ----------
    start, end, roll
        Per observation: window (10) and roll (7).
    opps
        Covered opportunities (global indices) per observation.
    targets
        The distinct targets the plan covers.
    """

    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: OppGroups
    targets: np.ndarray

    @property
    def size(self) -> int:
        return len(self.start)


def empty_plan() -> WindowPlan:
    z = np.zeros(0)
    groups = OppGroups(np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32))
    return WindowPlan(z, z, z, groups, np.zeros(0, dtype=np.int64))


def window_plan(oo: OrbitOpps, price: np.ndarray, roll_rule: RollRule = "nadir") -> WindowPlan:
    """A feasible plan of orbit ``oo`` at ``price`` over the real observations of the argmax
    rolls (see the module docstring), made at these prices.

    Each kept (i, k) becomes its real observation: members, window (10), roll by
    ``roll_rule`` in their common range, gain G(i, k) (the members' prices). The recursion of
    :mod:`sosp.planner` over these observations keeps (3) and (6) exactly; when its best plan
    breaks (4) or (5), a common penalty on both is doubled until it fits and bisected back
    (as :func:`sosp.planner.best_feasible_path`): the plan is always feasible, optimal over
    this restricted set when the knapsacks do not bind.
    """
    check_roll_rule(roll_rule)
    wi = window_items(oo, price)
    if wi.size == 0:
        return empty_plan()
    r = oo.rules
    keep, start, end, roll = _observations(oo, wi, roll_rule)
    gain = wi.gain[keep]
    duration = end - start
    slew_s = r.slew(roll)
    by_release, n_before = release_order(r.left(start, roll), r.right(end, roll))

    def plan(pen: float) -> np.ndarray:
        pe, pw = r.per_unit(pen, pen)
        _, path = recursion(slew_s, duration, gain, by_release, n_before, r, pe, pw)
        return path

    def fits(path: np.ndarray) -> bool:
        return r.usage_ok(*r.usage(duration[path], roll[path]))

    path = least_penalty_plan(plan, fits)
    if len(path) == 0:
        return empty_plan()
    opps = _observation_opps(oo, price, wi, keep[path])
    targets = np.unique(oo.target[opps.flat - oo.first])
    return WindowPlan(start[path], end[path], roll[path], opps, targets)


def _observations(
    oo: OrbitOpps, wi: WindowItems, roll_rule: RollRule
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The rows of ``wi`` within Delta T (11) (on an orbit where (4)-(5) leave room at all),
    with their window (10) and roll (by ``roll_rule`` in the members' common range (8)):
    (rows kept, start, end, roll)."""
    r = oo.rules
    start, end, lo, hi = oo.start[wi.first], wi.end, wi.roll_lo, wi.roll_hi
    roll = choose_roll(lo, hi, roll_rule)
    ok = r.duration_ok(start, end) & r.fits(0.0, 0.0)
    keep = np.flatnonzero(ok)
    return keep, start[keep], end[keep], roll[keep]


def member_scan(oo: OrbitOpps, first: np.ndarray, last: np.ndarray) -> int:
    """Opportunities :func:`_members` reads to list the members of rows (first, last): from
    i to the last one starting by te_k. The listing's time follows it (7-12 ns each, both
    passes, on the 2-core machine over 29 dense orbits of four drawn instances) where it
    varies 200-fold per (first, covered) pair of the orbit."""
    if not len(first):
        return 0
    stop = np.searchsorted(oo.start, oo.end[last], side="right")
    return int((stop - np.asarray(first)).sum())


def window_candidates(
    oo: OrbitOpps,
    price: np.ndarray,
    roll_rule: RollRule = "nadir",
    ahead: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, OppGroups]:
    """The real observations of the argmax rolls of orbit ``oo`` at ``price`` (those
    :func:`window_plan` plans over): start, end, roll and covered opportunities (global
    indices, each target once). A candidate set made for these prices, for a model that
    re-plans the orbit (``milp-lns`` where the explicit candidates do not fit).

    ``ahead``, when given, is called between the sweep and the members' listing with the
    listing's :func:`member_scan`, and may raise to stop before it (the listing reads no
    clock: 20-28 s on one orbit of a 10,000-target polar box)."""
    check_roll_rule(roll_rule)
    wi = window_items(oo, price)
    if wi.size == 0:
        e = empty_plan()
        return e.start, e.end, e.roll, e.opps
    keep, start, end, roll = _observations(oo, wi, roll_rule)
    if ahead is not None:
        ahead(member_scan(oo, wi.first[keep], wi.last[keep]))
    return start, end, roll, _observation_opps(oo, price, wi, keep)
