"""Exact pricing of subset-row cuts in the single-orbit recursion.

The master of :mod:`models.colgen` has, per target k, the coverage row ``z_k <= sum_P n_kP
y_P`` (``n_kP``: how many observations of plan P cover k). For three targets S, the rank-1
Chvatal-Gomory cut of their coverage rows and ``z_k <= 1`` with multipliers 1/2 is the
subset-row cut

    sum_{k in S} z_k - sum_P ceil(h_SP / 2) y_P <= 1,        h_SP = sum_{k in S} n_kP.

It holds for every schedule (one plan per orbit): when two targets of S are covered, the
plans' hits of S add up to two or more and ``sum ceil(h / 2) >= 1``; when all three are,
to three or more and ``sum ceil(h / 2) >= 2`` (``ceil(3 / 2) = 2``, ``1 + 1``, ``1 + 1 +
1``). Counting hits with their multiplicity (``h``, not the distinct targets) only raises a
column's coefficient, so the cut stays valid, and it matches what the recursion sees: it
sums the prices per observation.

Its dual ``sigma_S >= 0`` takes ``sigma_S`` from each ``z_k`` of S and gives a plan
``sigma_S ceil(h_SP / 2)`` (the plan's ``y_P`` loosens the row): not a sum over the plan's
observations. Along a plan in time order it is one bit, the parity of the hits so far: an
observation with ``a`` hits of S at parity ``b`` earns ``sigma_S (ceil((b + a) / 2) - b)``
and leaves parity ``(b + a) mod 2`` (the first hit earns, the second nothing, the third
earns again). :func:`cut_levels_py` is :func:`sosp.recursion.levels_py` with such bits as
labels: per position and level a set of ``(bits, value)`` labels, none dominated (a label
dominates another if its value, less the sigmas of the bits it has and the other lacks, is
still at least the other's: a set bit can cost at most one earning of its cut).

Bits live only where they can matter. With ``rank`` the positions' places in the (3) order
``by_release``, a plan's observations have strictly increasing ranks, so cut S's bit is
needed between its first relevant rank ``lo_S`` and its last ``hi_S``; cuts whose rank spans
do not overlap share a bit (a slot of an int64), so an orbit holds up to 64 cuts open at once.
A cut whose relevant observations are pairwise incompatible by (3) needs no bit: each such
observation earns ``sigma_S ceil(a / 2)`` outright. A cut beyond 64 open slots is priced the
same way, never below its true earning (``ceil`` is subadditive): the value is then an
over-estimate, still a valid bound, and :class:`CutPrice` reports it as not exact.

Orbit cuts. Adding an orbit j's convexity row ``sum_{P of j} y_P <= 1`` to two targets'
rows, all with multipliers 1/2, gives the cut over S = {a, b} and G = {j}

    z_a + z_b - sum_{P not of j} ceil(h_SP / 2) y_P - sum_{P of j} floor(h_SP / 2) y_P <= 1:

orbit j earns both a and b only from a plan that sees both. The root masters of the dense
scenarios break it wherever j mixes a plan for a with one for b while another orbit covers
the pair in part (:func:`violated_orbit_pairs`). On j's plans the term ``floor(h / 2)`` is
the parity bit read the other way: a hit at parity b earns ``ceil((1 - b + a) / 2) - (1 -
b)``, so there a *clear* bit can cost a label one earning. Such cuts get slots of their own
(``OrbitCuts.inv_slots``), so that dominance and merging know which way each bit reads.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sosp.kernels import compiled
from sosp.planner import OrbitItems, best_path
from sosp.recursion import recursion, restrict

#: The cut pricing restricts an orbit to the positions that may help a plan
#: (:meth:`CutPool.best_path`) when fewer than this share of them can.
KEEP_SHARE = 0.8

#: Slots of one int64 label mask.
SLOTS = 64

#: At most this many labels in the sweep's prefix structure; beyond it the two lowest are
#: merged into one optimistic label (their bits and-ed, their best value), an over-estimate.
MAX_LABELS = 512


@dataclass(frozen=True, eq=False)
class OrbitCuts:
    """The cuts of one orbit, arranged for :func:`cut_levels_py`.

    Attributes
    ----------
    hit_ptr, hit_slot, hit_a, hit_sigma, hit_read
        Per position (CSR): the slotted cuts it hits, with its hits ``a`` of the cut's
        targets, the cut's dual, and whether the bit in the prefix before the position
        (``n_before``) belongs to that cut (its first relevant rank lies in the prefix).
    carry, keep
        Per position: the slots whose prefix bits it carries (cuts open in its prefix and
        after it), and the slots its labels keep (cuts open after it).
    close
        Per boundary k (0 .. m): the slots whose cut's last relevant rank is k.
    slot_sigma
        Per slot, the largest dual of the cuts sharing it (for the dominance test).
    direct
        Per position, the earnings of the cuts priced outright (unslotted), added to its
        gain.
    exact
        False when some cut had no slot (priced optimistically).
    hit_inv
        Per hit, 1 when its cut earns ``floor(h / 2)`` on this orbit (the orbit is in the
        cut's G, :class:`CutPool`), else 0 (``ceil(h / 2)``).
    inv_slots
        The slots holding such cuts (never shared with the others).
    """

    hit_ptr: np.ndarray
    hit_slot: np.ndarray
    hit_a: np.ndarray
    hit_sigma: np.ndarray
    hit_read: np.ndarray
    carry: np.ndarray
    keep: np.ndarray
    close: np.ndarray
    slot_sigma: np.ndarray
    direct: np.ndarray
    exact: bool
    hit_inv: np.ndarray
    inv_slots: int


@dataclass(frozen=True, eq=False)
class CutEntries:
    """Cuts' hits on one orbit, independent of their duals (built once per set of cuts).

    Attributes
    ----------
    cut, pos, a
        Per entry: the cut (0 .. n_cuts - 1), a position covering some of its targets, and
        how many (with multiplicity).
    lo, hi
        Per cut: its first and last relevant rank in the (3) order (``lo`` above every rank
        and ``hi`` -1 for a cut the orbit cannot hit).
    chained
        Per cut: whether two of its relevant positions can be on one plan (``r_u < nb_w``
        for some pair, which holds iff the least rank is below the largest ``n_before``: a
        position never precedes itself). Else a plan hits it once at most, no bit needed.
    """

    cut: np.ndarray
    pos: np.ndarray
    a: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    chained: np.ndarray


def cut_entries(
    rank: np.ndarray, n_before: np.ndarray, hits: Sequence[tuple[np.ndarray, np.ndarray]]
) -> CutEntries:
    """:class:`CutEntries` from each cut's ``(positions, a)`` (positions distinct)."""
    sizes = np.array([len(p) for p, _ in hits], dtype=np.int64)
    cut = np.repeat(np.arange(len(hits), dtype=np.int64), sizes)
    none = [np.zeros(0, dtype=np.int64)]
    pos = np.concatenate(none + [np.asarray(p, dtype=np.int64) for p, _ in hits])
    a = np.concatenate(none + [np.asarray(x, dtype=np.int64) for _, x in hits])
    return _entries(len(hits), cut, pos, a, rank, n_before)


def _entries(
    n_cuts: int,
    cut: np.ndarray,
    pos: np.ndarray,
    a: np.ndarray,
    rank: np.ndarray,
    n_before: np.ndarray,
) -> CutEntries:
    """:class:`CutEntries` from its flat entries, over an orbit with this (3) order."""
    m = len(rank)
    lo = np.full(n_cuts, m, dtype=np.int64)
    hi = np.full(n_cuts, -1, dtype=np.int64)
    top_nb = np.full(n_cuts, -1, dtype=np.int64)
    np.minimum.at(lo, cut, rank[pos])
    np.maximum.at(hi, cut, rank[pos])
    np.maximum.at(top_nb, cut, n_before[pos])
    return CutEntries(cut, pos, a, lo, hi, lo < top_nb)


def restrict_entries(
    ent: CutEntries, keep: np.ndarray, size: int, rank: np.ndarray, n_before: np.ndarray
) -> CutEntries:
    """``ent`` over the sub-orbit of positions ``keep`` (sorted, of ``size``), whose places in
    the (3) order and predecessors are ``rank`` and ``n_before``
    (:func:`sosp.recursion.restrict`)."""
    new_pos = np.full(size, -1, dtype=np.int64)
    new_pos[keep] = np.arange(len(keep))
    inside = new_pos[ent.pos] >= 0
    return _entries(
        len(ent.lo), ent.cut[inside], new_pos[ent.pos[inside]], ent.a[inside], rank, n_before
    )


def orbit_cuts(
    rank: np.ndarray,
    n_before: np.ndarray,
    hits: Sequence[tuple[np.ndarray, np.ndarray]] | CutEntries,
    sigma: np.ndarray,
    kernel: Callable[..., tuple[Any, ...]] | None = None,
    inv: np.ndarray | None = None,
) -> OrbitCuts:
    """Arrange cuts for one orbit (:func:`arrange_py`).

    Parameters
    ----------
    rank, n_before
        Per position: its place in the (3) order, and how many positions of that order may
        precede it.
    hits
        Per cut, ``(positions, a)``: the positions covering some of its targets and how
        many (with multiplicity), positions distinct; or their :class:`CutEntries`.
    sigma
        Per cut, its dual (>= 0; cuts at 0 are skipped).
    kernel
        :func:`arrange_py` or a compiled copy (None: the compiled one, :func:`arrange`).
    inv
        Per cut, whether it earns ``floor(h / 2)`` on this orbit instead of ``ceil(h / 2)``
        (None: none does).
    """
    ent = hits if isinstance(hits, CutEntries) else cut_entries(rank, n_before, hits)
    run = arrange() if kernel is None else kernel
    flags = np.zeros(len(sigma), dtype=bool) if inv is None else inv
    out = run(
        np.ascontiguousarray(rank, dtype=np.int64),
        np.ascontiguousarray(n_before, dtype=np.int64),
        ent.cut, ent.pos, ent.a, ent.lo, ent.hi, ent.chained,
        np.ascontiguousarray(sigma, dtype=float),
        np.ascontiguousarray(flags, dtype=np.bool_),
    )  # fmt: skip
    return OrbitCuts(*out[:10], exact=bool(out[10]), hit_inv=out[11], inv_slots=int(out[12]))


def arrange_py(
    rank: np.ndarray,
    n_before: np.ndarray,
    cut: np.ndarray,
    pos: np.ndarray,
    a: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    chained: np.ndarray,
    sigma: np.ndarray,
    inv: np.ndarray,
) -> tuple[Any, ...]:
    """:class:`OrbitCuts`' arrays (in field order) from a :class:`CutEntries` (``cut`` ..
    ``chained``), the cuts' duals ``sigma`` and their ``inv`` flags (earning ``floor(h /
    2)`` on this orbit); compiled by numba (:func:`arrange`), as the pricing arranges an
    orbit's cuts on every call.

    Slots: the live cuts (``sigma > 0``, hit by the orbit) that a plan can hit twice
    (``chained``), taken by their first relevant rank ``lo`` (ties by index), each get the
    lowest slot of their kind (``inv`` or not: a slot never holds both, so a bit's meaning
    is the slot's) whose last cut ended (``hi``) before its ``lo``, none when all 64 are
    busy (then ``exact`` is False). Its bit is kept by the positions of ranks ``lo .. hi -
    1`` and carried by those of them whose prefix holds rank ``lo``. A live cut without a
    slot is priced outright: each of its entries adds ``sigma ceil(a / 2)`` to its
    position's ``direct`` (exact when no plan hits the cut twice; else an over-estimate, as
    ``ceil`` is subadditive and ``floor(h / 2) <= ceil(h / 2)``), or ``sigma floor(a / 2)``
    for an ``inv`` cut no plan hits twice. The slotted cuts' entries, grouped by position
    in entry order, are the hits.
    """
    m = rank.shape[0]
    n_cuts = sigma.shape[0]
    live = (sigma > 0.0) & (hi >= 0)
    slotted = np.flatnonzero(live & chained)
    by_lo = slotted[np.argsort(lo[slotted], kind="mergesort")]
    by_rank = np.empty(m, dtype=np.int64)
    by_rank[rank] = np.arange(m)
    slot_of = np.full(n_cuts, -1, dtype=np.int64)
    slot_end = np.full(SLOTS, -1, dtype=np.int64)
    slot_kind = np.full(SLOTS, -1, dtype=np.int64)  # unused, 0 ceil, 1 floor (inv)
    inv_slots = np.int64(0)
    keep = np.zeros(m, dtype=np.int64)
    carry = np.zeros(m, dtype=np.int64)
    slot_sigma = np.zeros(SLOTS)
    close = np.zeros(m + 1, dtype=np.int64)
    # a slot's cuts have disjoint rank spans, so a bit flipped at each end of a span and
    # xor-ed along the ranks is set exactly on ranks lo .. hi - 1 (``flip``)
    flip = np.zeros(m + 1, dtype=np.int64)
    for c in by_lo:
        kind = 1 if inv[c] else 0
        for b in range(SLOTS):
            if slot_end[b] < lo[c] and (slot_kind[b] < 0 or slot_kind[b] == kind):
                slot_of[c] = b
                slot_end[b] = hi[c]
                slot_kind[b] = kind
                bit = np.int64(1) << b
                if kind == 1:
                    inv_slots |= bit
                flip[lo[c]] ^= bit
                flip[hi[c]] ^= bit
                slot_sigma[b] = max(slot_sigma[b], sigma[c])
                close[hi[c]] |= bit
                break
    in_slot = by_lo[slot_of[by_lo] >= 0]
    exact = len(in_slot) == len(by_lo)
    start, start_bit = lo[in_slot], np.int64(1) << slot_of[in_slot]  # lo ascending
    # Position u at rank r keeps the bits open there and carries those whose cut's lo lies
    # in its prefix (lo < n_before[u]): all but the cuts that started at ranks n_before[u]
    # .. r (the one in a slot at r is the slot's latest start; few start that close to r).
    mask = np.int64(0)
    begun = 0  # the cuts with lo <= r
    for r in range(m):
        mask ^= flip[r]
        while begun < len(start) and start[begun] <= r:
            begun += 1
        if mask == 0:
            continue
        u = by_rank[r]
        keep[u] = mask
        recent = np.int64(0)
        q = begun - 1
        while q >= 0 and start[q] >= n_before[u]:
            recent |= start_bit[q]
            q -= 1
        carry[u] = mask & ~recent
    direct = np.zeros(m)
    for e in range(cut.shape[0]):
        c = cut[e]
        if live[c] and slot_of[c] < 0:
            half = a[e] // 2 if inv[c] and not chained[c] else (a[e] + 1) // 2
            direct[pos[e]] += sigma[c] * half
    # the slotted cuts' entries, grouped by position in entry order
    hit = np.flatnonzero(live[cut] & (slot_of[cut] >= 0))
    hit = hit[np.argsort(pos[hit], kind="mergesort")]
    hit_cut, hit_pos = cut[hit], pos[hit]
    ptr = np.zeros(m + 1, dtype=np.int64)
    for u in hit_pos:
        ptr[u + 1] += 1
    return (
        np.cumsum(ptr), slot_of[hit_cut], a[hit], sigma[hit_cut],
        (lo[hit_cut] < n_before[hit_pos]).astype(np.int64), carry, keep, close, slot_sigma,
        direct, exact, inv[hit_cut].astype(np.int64), inv_slots,
    )  # fmt: skip


#: :func:`arrange_py`'s numba signature.
ARRANGE_SIGNATURE = (
    "Tuple((int64[::1], int64[::1], int64[::1], float64[::1], int64[::1], int64[::1], "
    "int64[::1], int64[::1], float64[::1], float64[::1], boolean, int64[::1], int64))"
    "(int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], "
    "boolean[::1], float64[::1], boolean[::1])"
)


def arrange() -> Callable[..., tuple[Any, ...]]:
    """:func:`arrange_py` compiled by numba on first use (cached on disk)."""
    return compiled(arrange_py, ARRANGE_SIGNATURE)


def cut_levels_py(
    g: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    order: np.ndarray,
    n_before: np.ndarray,
    cap: int,
    hit_ptr: np.ndarray,
    hit_slot: np.ndarray,
    hit_a: np.ndarray,
    hit_sigma: np.ndarray,
    hit_read: np.ndarray,
    carry: np.ndarray,
    keep: np.ndarray,
    close: np.ndarray,
    slot_sigma: np.ndarray,
    max_labels: int,
    single: int,
    hit_inv: np.ndarray,
    inv_slots: int,
) -> tuple[float, np.ndarray, int]:
    """The levels of :func:`sosp.recursion.levels_py` with a cut's parity bit per slot.

    Level n holds, per position u, the labels ``(bits, value)`` of the plans of at most n
    observations ending at u, none dominated. Level n sweeps the (3) order once: the prefix
    structure holds the level n - 1 labels of the positions before the boundary k (bits of
    the cuts open at k), and answers the positions with ``n_before == k`` from it. Returns
    the best ``value + last``, its path, and 1 if a merge beyond ``max_labels`` made the
    value an over-estimate (else 0).

    With ``single`` 1, one sweep without the cap ``cap``: the structure takes each
    position's labels as soon as the boundary passes it (a position's predecessors all come
    before its own place in the (3) order, so its labels are final by then). The plans of
    any length ending at u are then one level, a tenth of the work with C5's cap of 10
    (:func:`label_best` uses it first).

    A bit is the parity of the plan's hits of its cut. A ``ceil`` cut's next hit earns when
    the bit is clear, so a set bit can cost a label one earning; a ``floor`` cut's
    (``hit_inv``, its slots ``inv_slots``) earns when the bit is set, so there a clear bit
    can. Dominance and merging read the bits so (:class:`OrbitCuts`).
    """
    m = g.shape[0]
    relaxed = 0
    low56 = np.int64(0x00FFFFFFFFFFFFFF)  # a right shift keeps the sign: clear it

    inv = np.int64(inv_slots)

    def worse(mi: np.int64, mj: np.int64) -> np.int64:
        """The bits where a label of bits ``mi`` is worse placed than one of ``mj``."""
        return (mi & ~mj & ~inv) | (mj & ~mi & inv)

    def bits_loss(e: np.int64, room: float) -> float:
        """The sigmas of the bits ``e`` (one label has them, the other not), by byte,
        skipping empty bytes, stopping once they exceed ``room`` (no domination then)."""
        loss = 0.0
        base = 0
        while e != 0 and loss <= room:
            byte = e & 255
            if byte != 0:
                for b in range(8):
                    if (byte >> b) & 1:
                        loss += slot_sigma[base + b]
            e = (e >> 8) & low56
            base += 8
        return loss

    # label store (grown by doubling)
    size = 4 * m + 16
    l_val = np.empty(size)
    l_mask = np.empty(size, dtype=np.int64)
    l_pred = np.empty(size, dtype=np.int64)
    l_pos = np.empty(size, dtype=np.int64)
    n_lab = 0
    lo = np.zeros((cap, m), dtype=np.int64)
    hi = np.zeros((cap, m), dtype=np.int64)
    q_order = np.argsort(n_before, kind="mergesort")
    room = 2 * max_labels + 4  # the structure, then one position's labels on top
    s_mask = np.empty(room, dtype=np.int64)
    s_val = np.empty(room)
    s_id = np.empty(room, dtype=np.int64)
    c_mask = np.empty(room, dtype=np.int64)
    c_val = np.empty(room)
    c_pred = np.empty(room, dtype=np.int64)
    c_live = np.empty(room, dtype=np.int64)
    top = 0
    levels = 1 if single == 1 else cap
    for n in range(levels):
        n_s = 0
        level0 = n_lab
        qi = 0
        for k in range(m + 1):
            while qi < m and n_before[q_order[qi]] == k:
                u = q_order[qi]
                qi += 1
                # candidates: the start, then each prefix label (level n - 1)
                n_c = 0
                n_in = n_s + 1 if n > 0 or single == 1 else 1
                for i in range(n_in):
                    if i == 0:
                        base, bits, pred = first[u], np.int64(0), np.int64(-1)
                    else:
                        base, bits, pred = s_val[i - 1], s_mask[i - 1], s_id[i - 1]
                    v = base + g[u]
                    out = bits & carry[u]
                    for h in range(hit_ptr[u], hit_ptr[u + 1]):
                        bit = np.int64(1) << hit_slot[h]
                        b = 1 if hit_read[h] == 1 and (bits & bit) != 0 else 0
                        a = hit_a[h]
                        bb = 1 - b if hit_inv[h] == 1 else b
                        v += hit_sigma[h] * ((bb + a + 1) // 2 - bb)
                        out = out | bit if (b + a) % 2 == 1 else out & ~bit
                    out &= keep[u]
                    c_mask[n_c] = out
                    c_val[n_c] = v
                    c_pred[n_c] = pred
                    c_live[n_c] = 1
                    n_c += 1
                # drop dominated candidates (ties: the earlier stays); a lower value never
                # dominates, so the bits' loss is summed only when it might. Where u hits
                # no cut and keeps every bit of the prefix, its candidates past the start
                # are the prefix's labels shifted by g[u], already undominated among
                # themselves: only the pairs with the start (0) need a test.
                fast = hit_ptr[u] == hit_ptr[u + 1]
                if fast:
                    for i in range(1, n_c):
                        if s_mask[i - 1] & ~carry[u] != 0:
                            fast = False
                            break
                for i in range(n_c):
                    if c_live[i] == 0:
                        continue
                    j_end = n_c if i == 0 or not fast else 1
                    for j in range(j_end):
                        if i == j or c_live[j] == 0 or c_val[i] < c_val[j]:
                            continue
                        loss = bits_loss(worse(c_mask[i], c_mask[j]), c_val[i] - c_val[j])
                        if c_val[i] - loss > c_val[j] or (c_val[i] - loss == c_val[j] and i < j):
                            c_live[j] = 0
                lo[n, u] = n_lab
                for i in range(n_c):
                    if c_live[i] == 1:
                        if n_lab == size:  # doubled
                            size *= 2
                            l_val = np.concatenate((l_val, np.empty_like(l_val)))
                            l_mask = np.concatenate((l_mask, np.empty_like(l_mask)))
                            l_pred = np.concatenate((l_pred, np.empty_like(l_pred)))
                            l_pos = np.concatenate((l_pos, np.empty_like(l_pos)))
                        l_val[n_lab] = c_val[i]
                        l_mask[n_lab] = c_mask[i]
                        l_pred[n_lab] = c_pred[i]
                        l_pos[n_lab] = u
                        n_lab += 1
                hi[n, u] = n_lab
            if k == m or (n == 0 and single == 0):
                continue
            # advance the boundary to k + 1: clear the closing cuts, add position order[k]
            w = order[k]
            cl = close[k]
            cleared = False
            if cl != 0:
                for i in range(n_s):
                    if s_mask[i] & cl:
                        s_mask[i] &= ~cl
                        cleared = True
            first_new = n_s
            src = n if single == 1 else n - 1
            for x in range(lo[src, w], hi[src, w]):
                s_mask[n_s] = l_mask[x]
                s_val[n_s] = l_val[x]
                s_id[n_s] = x
                n_s += 1
            if n_s > 1 and (cleared or n_s > first_new):
                # prune: dominated labels out (ties: the earlier stays); after a clearing any
                # pair may dominate, else only pairs with a new label
                for i in range(n_s):
                    c_live[i] = 1
                for i in range(n_s):
                    if c_live[i] == 0:
                        continue
                    j0 = 0 if cleared or i >= first_new else first_new
                    for j in range(j0, n_s):
                        if i == j or c_live[j] == 0 or s_val[i] < s_val[j]:
                            continue
                        loss = bits_loss(worse(s_mask[i], s_mask[j]), s_val[i] - s_val[j])
                        if s_val[i] - loss > s_val[j] or (s_val[i] - loss == s_val[j] and i < j):
                            c_live[j] = 0
                t = 0
                for i in range(n_s):
                    if c_live[i] == 1:
                        s_mask[t] = s_mask[i]
                        s_val[t] = s_val[i]
                        s_id[t] = s_id[i]
                        t += 1
                n_s = t
                while n_s > max_labels:
                    # merge the two lowest into one optimistic label
                    relaxed = 1
                    a1 = np.argmin(s_val[:n_s])
                    a2 = 0 if a1 != 0 else 1
                    for i in range(n_s):
                        if i != a1 and s_val[i] < s_val[a2]:
                            a2 = i
                    both = s_mask[a2] & s_mask[a1]
                    either = s_mask[a2] | s_mask[a1]
                    s_mask[a2] = (both & ~inv) | (either & inv)
                    s_mask[a1] = s_mask[n_s - 1]
                    s_val[a1] = s_val[n_s - 1]
                    s_id[a1] = s_id[n_s - 1]
                    n_s -= 1
        top = n + 1
        # the same labels as the level before (as many per position, each found there): done
        same = n > 0 and np.array_equal(hi[n] - lo[n], hi[n - 1] - lo[n - 1])
        for x in range(level0, n_lab if same else level0):  # this level's labels
            found = False
            for y in range(lo[n - 1, l_pos[x]], hi[n - 1, l_pos[x]]):
                if l_mask[y] == l_mask[x] and l_val[y] == l_val[x]:
                    found = True
                    break
            if not found:
                same = False
                break
        if same:
            break
    best_x = -1
    best_v = -np.inf
    for u in range(m):
        for x in range(lo[top - 1, u], hi[top - 1, u]):
            v = l_val[x] + last[u]
            if v > best_v:
                best_x, best_v = x, v
    path = np.empty(m, dtype=np.int64)
    count = 0
    x = best_x
    while x >= 0 and count < m:
        path[count] = l_pos[x]
        count += 1
        x = l_pred[x]
    return best_v, path[:count][::-1].copy(), relaxed


#: :func:`cut_levels_py`'s numba signature.
CUT_LEVELS_SIGNATURE = (
    "Tuple((float64, int64[::1], int64))(float64[::1], float64[::1], float64[::1], "
    "int64[::1], int64[::1], int64, int64[::1], int64[::1], int64[::1], float64[::1], "
    "int64[::1], int64[::1], int64[::1], int64[::1], float64[::1], int64, int64, int64[::1], "
    "int64)"
)


def cut_levels() -> Callable[..., tuple[float, np.ndarray, int]]:
    """:func:`cut_levels_py` compiled by numba on first use (cached on disk); loads
    :func:`arrange` too, so one call before a clock starts loads both."""
    arrange()
    return compiled(cut_levels_py, CUT_LEVELS_SIGNATURE)


def label_best(
    run: Callable[..., tuple[float, np.ndarray, int]],
    g: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    order: np.ndarray,
    n_before: np.ndarray,
    cap: int,
    cuts: OrbitCuts,
    max_labels: int = MAX_LABELS,
) -> tuple[float, np.ndarray, int]:
    """The best plan of at most ``cap`` observations by the kernel ``run``
    (:func:`cut_levels_py`, compiled or not; ``g`` with ``cuts.direct`` added): one sweep
    without the cap first, and the levels only when that sweep's best plan has more than
    ``cap`` observations. Otherwise that plan is also the best of at most ``cap`` (the sweep
    bounds every plan, and it is one of them). On C5 the cap bound in 3 % of the calls."""
    for sweep in (1, 0):
        value, path, relaxed = run(
            g, first, last, order, n_before, cap, cuts.hit_ptr, cuts.hit_slot, cuts.hit_a,
            cuts.hit_sigma, cuts.hit_read, cuts.carry, cuts.keep, cuts.close, cuts.slot_sigma,
            max_labels, sweep, cuts.hit_inv, cuts.inv_slots,
        )  # fmt: skip
        if len(path) <= cap:
            break
    return value, path, relaxed


@dataclass(frozen=True)
class CutPrice:
    """One orbit's best plan with its cuts priced: ``value`` (penalised, the cuts' earnings
    included), ``path`` (positions in time order) and ``exact`` (False when some cut was
    priced optimistically, so ``value`` is an over-estimate)."""

    value: float
    path: np.ndarray
    exact: bool


def best_path_with_cuts(
    o: OrbitItems,
    gain: np.ndarray,
    cuts: OrbitCuts,
    pe: float = 0.0,
    pw: float = 0.0,
    sub: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> CutPrice:
    """The best plan of orbit ``o`` at per-position ``gain`` (target prices summed per
    observation), energy and memory penalties per unit ``pe``, ``pw`` ((4)-(5) as in
    :func:`sosp.planner.best_path`), plus each plan's earning ``sum_S sigma_S ceil(h_SP /
    2)`` from the cuts in ``cuts``. The empty plan (value 0) when nothing beats it. The
    recursion (:func:`sosp.recursion.recursion`) with the cuts' labels (:func:`label_best`).

    With ``sub``, ``(keep, by_release, n_before)``: the plan is sought among the positions
    ``keep`` only, in their (3) order (:func:`sosp.recursion.restrict`), ``cuts`` arranged
    for them; the path is still of the orbit's positions.
    """
    keep, by_release, n_before = (slice(None), o.by_release, o.n_before) if sub is None else sub
    relaxed = []

    def labels(*args: Any) -> tuple[float, np.ndarray]:
        value, path, over = label_best(cut_levels(), *args, cuts)
        relaxed.append(over)
        return value, path

    value, path = recursion(
        o.slew_s[keep], o.duration[keep], gain[keep] + cuts.direct, by_release, n_before,
        o.rules, pe, pw, run=labels,
    )  # fmt: skip
    return CutPrice(
        float(value), path if sub is None else keep[path], cuts.exact and not any(relaxed)
    )


#: Separation: at most this many new cuts per round, and per target per round.
CUTS_PER_ROUND = 100
CUTS_PER_TARGET = 3

#: No separation above this many targets with a fractional cover (the pair matrix is dense).
SEPARATE_MAX_TARGETS = 4000

#: Whether the separation seeks the cuts over two targets and an orbit
#: (:func:`violated_orbit_pairs`).
ORBIT_CUTS = True


def co_cover(
    cover: np.ndarray, w: np.ndarray, z: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the searches for violated cuts share: per target its over-cover ``cover_k -
    z_k``, the plans' pairwise co-cover ``sum_P y_P [k, l in P]`` (zero diagonal), and the
    targets searched, those whose co-cover sums to more than 1/3 (a violated triple has a
    pair above 1/3, and so does a violated orbit pair: its co-cover and orbit term exceed
    1). ``cover``, ``w`` and ``z`` are as in :func:`violated_triples`."""
    over = cover.T @ w - z
    pair = (cover * w[:, None]).T @ cover
    np.fill_diagonal(pair, 0.0)
    return over, pair, np.flatnonzero(pair.sum(axis=1) > 0.3)


def violated_triples(
    cover: np.ndarray,
    w: np.ndarray,
    z: np.ndarray,
    deadline: float | None = None,
    shared: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> list[tuple[float, int, int, int]]:
    """The triples (i, j, k) of columns of ``cover`` whose subset-row cut a master's solution
    violates, as ``(violation, i, j, k)`` with i < j < k, most violated first.

    ``cover`` is 0/1, a row per positive plan and a column per target, ``w`` the plans'
    ``y_P`` and ``z`` the targets' ``z_k``. With ``c`` the targets of S a plan covers,
    ``ceil(c / 2) = c - [c >= 2]`` for ``c <= 3``, so the violation is ``sum_P [c_SP >= 2]
    y_P - sum_{k in S} (cover_k - z_k) - 1``: the plans' pairwise co-cover summed over S's
    pairs, less twice their triple co-cover, less the over-cover. At ``deadline``
    (:func:`time.perf_counter`) the search stops with what it has found. ``shared`` is
    :func:`co_cover` of the same arguments, when the caller has it.
    """
    over, pair, cand = co_cover(cover, w, z) if shared is None else shared
    found: list[tuple[float, int, int, int]] = []
    for a, i in enumerate(cand):
        if deadline is not None and time.perf_counter() > deadline:
            break
        later = cand[a + 1 :]
        for j in later[pair[i, later] > 1e-6]:
            triple = cover.T @ (w * cover[:, i] * cover[:, j])
            ks = cand[cand > j]
            v = pair[i, j] + pair[i, ks] + pair[j, ks] - 2.0 * triple[ks]
            v -= over[i] + over[j] + over[ks] + 1.0
            hit = np.flatnonzero(v > 1e-3)
            found.extend((float(v[q]), int(i), int(j), int(ks[q])) for q in hit)
    found.sort(reverse=True)
    return found


def violated_orbit_pairs(
    cover: np.ndarray,
    w: np.ndarray,
    z: np.ndarray,
    orbit: np.ndarray,
    deadline: float | None = None,
    shared: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> list[tuple[float, int, int, int]]:
    """The cuts over two targets {a, b} and one orbit j (:class:`CutPool`) that a master's
    solution violates, as ``(violation, a, b, j)`` with a < b, most violated first.

    ``cover``, ``w`` and ``z`` are as in :func:`violated_triples`, ``orbit`` gives each
    plan's orbit. The violation is ``sum_{P not of j} [c_P = 2] y_P + sum_{P of j} [c_P >=
    1] y_P - (cover_a - z_a) - (cover_b - z_b) - 1`` (``c_P``: how many of a, b plan P
    covers), that is the pair's co-cover plus j's plans that cover exactly one of them,
    less the over-cover, less 1. At ``deadline`` (:func:`time.perf_counter`) the search
    stops with what it has found; ``shared`` as in :func:`violated_triples`.
    """
    over, pair, col = co_cover(cover, w, z) if shared is None else shared
    if len(col) < 2:
        return []
    sub = cover[:, col]
    base = pair[np.ix_(col, col)] - over[col][:, None] - over[col][None, :] - 1.0
    iu, ju = np.triu_indices(len(col), 1)
    found: list[tuple[float, int, int, int]] = []
    for j in np.unique(orbit).tolist():
        if deadline is not None and time.perf_counter() > deadline:
            break
        mine = orbit == j
        cj, wj = sub[mine], w[mine]
        one = (cj * wj[:, None]).T @ (1.0 - cj)  # j's plans covering a and not b
        v = (base + one + one.T)[iu, ju]
        hit = np.flatnonzero(v > 1e-3)
        found.extend((float(v[q]), int(col[iu[q]]), int(col[ju[q]]), int(j)) for q in hit)
    found.sort(reverse=True)
    return found


class CutPool:
    """The subset-row cuts of a branch and price (:func:`models.colgen.branch_and_price`),
    valid for every schedule and so shared by every node, with what pricing them needs.

    A cut is a set S of targets (instance indices) and a set G of orbits with ``|S| + |G|``
    odd: the rank-1 Chvatal-Gomory cut, multipliers 1/2, of S's coverage rows, their ``z_k
    <= 1`` and G's convexity rows ``sum_{P of j} y_P <= 1``,

        sum_{k in S} z_k - sum_{P not of G} ceil(h_SP / 2) y_P - sum_{P of G} floor(h_SP / 2) y_P
            <= floor((|S| + |G|) / 2)

    (a plan's coefficient ``-(h_SP - [P of G]) / 2`` rounded down; ``rhs`` holds the right
    side). With G empty and |S| = 3 it is the module docstring's subset-row cut. With S =
    {a, b} and G = {j} it says that orbit j gives both a and b only from one plan that sees
    both, which the master's mixture of j's plans for a and for b breaks. On j's plans the
    term ``floor(h / 2)`` is the same parity bit read the other way
    (:class:`OrbitCuts`' ``hit_inv``). Per orbit the pool keeps the cuts some of whose
    targets the orbit can cover, and, computed on first use, each such cut's hits per
    position (:func:`orbit_cuts`' input).
    """

    def __init__(self, groups: Sequence[OrbitItems]) -> None:
        self.groups = groups
        self.cuts: list[np.ndarray] = []
        self.orbits: list[frozenset[int]] = []  # per cut, its G
        self.rhs: list[int] = []
        self._keys: set[tuple[int, ...]] = set()  # S, then -1, then G
        self._of_target: dict[int, list[int]] = {}
        self._on_orbit: list[list[int]] = [[] for _ in groups]
        self._hits: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
        self._csc: list[Any] = [None] * len(groups)
        self._rank: list[np.ndarray | None] = [None] * len(groups)
        # orbit: (cuts then, their entries, whether the orbit is in each one's G)
        self._entries: dict[int, tuple[int, CutEntries, np.ndarray]] = {}

    def __len__(self) -> int:
        return len(self.cuts)

    def add(self, targets: Sequence[int], orbits: Sequence[int] = ()) -> int | None:
        """Add the cut over ``targets`` (S, two or more, distinct) and ``orbits`` (G, with
        ``|S| + |G|`` odd); its index, or None if the pool has it."""
        tg = tuple(sorted(int(k) for k in targets))
        og = tuple(sorted(int(j) for j in orbits))
        if len(tg) < 2 or len(set(tg)) != len(tg) or len(set(og)) != len(og):
            raise ValueError(f"a cut needs two or more distinct targets: {tg}, orbits {og}")
        if (len(tg) + len(og)) % 2 == 0:
            raise ValueError(f"a cut needs an odd number of targets and orbits: {tg}, {og}")
        key = (*tg, -1, *og)
        if key in self._keys:
            return None
        self._keys.add(key)
        c = len(self.cuts)
        arr = np.array(tg, dtype=np.int64)
        self.cuts.append(arr)
        self.orbits.append(frozenset(og))
        self.rhs.append((len(tg) + len(og)) // 2)
        for k in tg:
            self._of_target.setdefault(k, []).append(c)
        for g, o in enumerate(self.groups):
            if np.isin(arr, o.targets).any():
                self._on_orbit[g].append(c)
        return c

    def coefficients(
        self, tg: np.ndarray, cnt: np.ndarray, g: int, since: int = 0
    ) -> dict[int, int]:
        """A plan of orbit ``g``'s coefficient per cut it hits (``ceil(h_SP / 2)``, or
        ``floor(h_SP / 2)`` where g is in the cut's G; zeros left out), from its targets
        ``tg`` and how many of its observations cover each (``cnt``); only the cuts from
        index ``since`` on."""
        h: dict[int, int] = {}
        for k, n in zip(tg.tolist(), np.asarray(cnt).tolist(), strict=True):
            for c in self._of_target.get(k, ()):
                if c >= since:
                    h[c] = h.get(c, 0) + int(round(n))
        out = {c: (x // 2 if g in self.orbits[c] else (x + 1) // 2) for c, x in h.items()}
        return {c: v for c, v in out.items() if v}

    def orbit_hits(self, g: int, c: int) -> tuple[np.ndarray, np.ndarray]:
        """Cut c's ``(positions, a)`` on orbit g (computed on first use)."""
        key = (g, c)
        if key not in self._hits:
            if self._csc[g] is None:
                self._csc[g] = self.groups[g].incidence.tocsc()
            a, tg = self._csc[g], self.cuts[c]
            self._hits[key] = np.unique(a[:, tg[tg < a.shape[1]]].indices, return_counts=True)
        return self._hits[key]

    def best_path(
        self, g: int, price: np.ndarray, lam: np.ndarray, sigma: np.ndarray
    ) -> tuple[float, np.ndarray, bool]:
        """Orbit g's best plan at target ``price``, knapsack multipliers ``lam`` (per whole
        capacity, as :func:`sosp.planner.best_path` takes them) and cut duals ``sigma`` (per
        cut of the pool): ``(value, path, exact)``, the value never below the true best."""
        o = self.groups[g]
        on = np.array(self._on_orbit[g], dtype=np.int64)
        on = on[on < len(sigma)]
        s_on = np.where(sigma[on] > 1e-9, sigma[on], 0.0)
        if not s_on.any():
            v, path = best_path(o, price, float(lam[0]), float(lam[1]))
            return v, path, True
        # No shortcut on the largest orbits: best_path's pruning from PRUNE_FROM positions
        # ranks positions by their gains alone, which the cuts' parity earnings break, and
        # pricing each cut per target instead (every hit earning sigma) was so loose that
        # japan-500's search ended at a node of bound 1850 whose plans gave 1836 at most;
        # priced here (20 ms a call on its 120,000 positions) its root proves 1836.
        if self._rank[g] is None:
            self._rank[g] = np.argsort(o.by_release)  # each position's place in (3) order
        made = self._entries.get(g)
        if made is None or made[0] != len(on):
            hits = [self.orbit_hits(g, c) for c in on.tolist()]
            inv = np.array([g in self.orbits[c] for c in on.tolist()], dtype=bool)
            made = (len(on), cut_entries(self._rank[g], o.n_before, hits), inv)
            self._entries[g] = made
        r = o.rules
        pe, pw = r.per_unit(float(lam[0]), float(lam[1]))
        gain = o.gains(price)
        ent = made[1]
        # A position whose gain, with every cut it hits earning its most, is worth no more
        # than its observing penalty never helps a plan: dropping it from a plan gives back
        # its penalties and slews (as in sosp.planner.best_path) and costs each cut at most
        # sigma ceil(a / 2) (ceil(h / 2) - ceil((h - a) / 2) <= ceil(a / 2)). Fewer positions
        # make the labelling faster and leave fewer cuts overlapping for the 64 slots.
        most = gain.copy()
        np.add.at(most, ent.pos, s_on[ent.cut] * ((ent.a + 1) // 2))
        worth = most > (pe * r.observe_energy_rate + pw * r.memory_rate) * o.duration
        n_worth = int(np.count_nonzero(worth))
        if n_worth == 0:
            return 0.0, np.zeros(0, dtype=np.int64), True
        sub, n_before, rank = None, o.n_before, self._rank[g]
        if n_worth < KEEP_SHARE * o.size:
            keep = np.flatnonzero(worth)
            by_release, n_before = restrict(o.by_release, o.n_before, keep)
            rank = np.argsort(by_release)
            ent = restrict_entries(ent, keep, o.size, rank, n_before)
            sub = (keep, by_release, n_before)
        arranged = orbit_cuts(rank, n_before, ent, s_on, inv=made[2])
        found = best_path_with_cuts(o, gain, arranged, pe, pw, sub)
        return found.value, found.path, found.exact

    def separate(
        self,
        z: np.ndarray,
        plans: Sequence[tuple[np.ndarray, float]],
        limit: int = CUTS_PER_ROUND,
        deadline: float | None = None,
        orbits: Sequence[int] | None = None,
    ) -> list[int]:
        """Add cuts that a master's solution violates, most violated first; their indices.

        ``z`` holds each target's ``z_k`` (instance indices), ``plans`` the positive plans as
        (distinct targets, ``y_P``) and ``orbits`` their orbits (None: no cut with orbits is
        sought); the search is :func:`violated_triples` and, with ``orbits`` and
        :data:`ORBIT_CUTS`, :func:`violated_orbit_pairs`, which stop at ``deadline``. Covers are
        counted once per plan here, while the master counts a plan seeing a target twice
        twice: a cut found may then be violated less than computed, or not at all (it is
        valid all the same).
        """
        if not plans:
            return []
        tg_all = np.unique(np.concatenate([tg for tg, _ in plans]))
        if len(tg_all) > SEPARATE_MAX_TARGETS:
            return []
        cover = np.zeros((len(plans), len(tg_all)))
        for r, (tg, _) in enumerate(plans):
            cover[r, np.searchsorted(tg_all, tg)] = 1.0
        w = np.array([y for _, y in plans])
        zs = z[tg_all]
        shared = co_cover(cover, w, zs)  # both searches start from it
        found: list[tuple[float, tuple[int, ...], tuple[int, ...]]] = [
            (v, (i, j, k), ()) for v, i, j, k in violated_triples(cover, w, zs, deadline, shared)
        ]
        if orbits is not None and ORBIT_CUTS:
            of = np.asarray(orbits, dtype=np.int64)
            pairs = violated_orbit_pairs(cover, w, zs, of, deadline, shared)
            found.extend((v, (a, b), (j,)) for v, a, b, j in pairs)
        found.sort(key=lambda f: -f[0])  # stable: triples first among equals
        added: list[int] = []
        per_target: Counter[int] = Counter()
        for _, members, in_g in found:
            targets = [int(tg_all[i]) for i in members]
            if any(per_target[t] >= CUTS_PER_TARGET for t in targets):
                continue
            c = self.add(targets, in_g)
            if c is None:
                continue
            per_target.update(targets)
            added.append(c)
            if len(added) >= limit:
                break
        return added
