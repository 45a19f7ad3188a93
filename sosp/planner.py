"""Exact single-orbit planning by dynamic programming over candidate observations.

On one orbit j, with each target given a price (what covering it is worth), the best plan is
a sequence of candidate observations (:func:`sosp.candidates.cluster_candidates`; every
feasible observation is dominated by one of them) that

* respects (3) between consecutive observations: with the conflict intervals of
  :mod:`models.cliques`, u may precede w iff ``R_u <= L_w``, where
  ``R_u = te_u + a + |theta_u| / v`` and ``L_w = ts_w - |theta_w| / v``. The condition splits
  into one number per item on each side, so "the best plan ending before w" is a prefix
  maximum over the items sorted by ``R``;
* opens the sensor at most c_j times (6): the plan is built level by level, level n holding
  the best plan of at most n observations ending at each item (at most c_j levels, fewer when
  a level adds nothing);
* keeps (4) and (5). Their observation terms are sums over the plan; the slew term of (4) is
  ``es / v * (2 sum |theta| - |theta_first| - |theta_last|)`` over consecutive pairs, exact in
  the recursion (the first and the last observation each get ``es |theta| / v`` back). The
  knapsacks enter as Lagrangian penalties ``lam_e * energy / E + lam_w * memory / W``: with
  zero penalties the recursion maximises over (3) and (6) only, and the plan it finds is the
  exact optimum whenever it also fits (4)-(5) (:func:`best_feasible_path`).

Prices of the covered targets are summed per observation: a target seen twice on one orbit
(two passes) could be counted twice, which only over-estimates (harmless in a bound, and the
heuristic counts real coverage).

Built on the recursion: :func:`models.lagrangian.lagrangian_bound` (an upper bound with no LP
solver), ``orbit-dp`` (:mod:`heuristics.orbit_search`, an iterated local search whose move is
the exact re-planning of one orbit), ASA-DTC's whole-orbit move (:mod:`heuristics.asa.orbit`)
and the MILP LNS (:mod:`heuristics.lns`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from sosp.candidates import cluster_candidates, flatten
from sosp.instance import Instance
from sosp.rules import EPS, OrbitRules, orbit_rules

log = logging.getLogger(__name__)


#: Penalty doublings tried before :func:`best_feasible_path` settles for the empty plan.
_MAX_DOUBLINGS = 60

#: Bisection steps of :func:`best_feasible_path` between an infeasible and a feasible penalty.
_BISECTIONS = 12

#: From this many (position, target) pairs on, an orbit's gains are one ``scipy.sparse`` CSR
#: product instead of ``np.bincount`` over ``price[target_flat]``: the product's fixed cost is
#: about 4 us, the gather and bincount's 2.7 us per 1000 pairs (C10's largest orbit, 310 000
#: pairs: 0.1 against 0.28 ms per orbit on average, a fifth of a plan).
_SPARSE_GAINS = 2000


@dataclass(frozen=True, eq=False)
class OrbitItems:
    """The candidate observations of one orbit, arranged for the recursion.

    Attributes
    ----------
    orbit
        Orbit index j.
    items
        Global candidate indices, in (start, end) order; positions below index into it.
    duration, roll, slew_s
        Per position: te - ts (seconds observed, (4)-(5)), the roll theta and |theta| / v
        (seconds of slew to or from nadir, (3)-(4)).
    by_release
        Positions sorted by ``R`` (the end of the conflict interval).
    n_before
        Per position w: how many positions of ``by_release`` may precede w by (3).
    target_ptr, target_flat, target_seg
        Covered targets per position (CSR: ``target_flat[target_ptr[u]:target_ptr[u+1]]``),
        and the position of each flat entry.
    targets
        The distinct targets any candidate of the orbit covers.
    rules
        The orbit's rules and parameters (:class:`sosp.rules.OrbitRules`).
    """

    orbit: int
    items: np.ndarray
    duration: np.ndarray
    roll: np.ndarray
    slew_s: np.ndarray
    by_release: np.ndarray
    n_before: np.ndarray
    target_ptr: np.ndarray
    target_flat: np.ndarray
    target_seg: np.ndarray
    targets: np.ndarray
    rules: OrbitRules

    @property
    def size(self) -> int:
        return len(self.items)

    @cached_property
    def incidence(self) -> Any:
        """Positions x targets 0/1 matrix (``scipy.sparse`` CSR over ``target_ptr`` and
        ``target_flat``), as many columns as the largest target covered plus one."""
        from scipy.sparse import csr_array

        cols = int(self.target_flat.max()) + 1 if len(self.target_flat) else 0
        data = np.ones(len(self.target_flat))
        return csr_array((data, self.target_flat, self.target_ptr), shape=(self.size, cols))

    def gains(self, price: np.ndarray) -> np.ndarray:
        """Sum of ``price`` over the targets each position covers."""
        if len(self.target_flat) < _SPARSE_GAINS:
            return np.bincount(
                self.target_seg, weights=price[self.target_flat], minlength=self.size
            )
        a = self.incidence
        return a @ np.ascontiguousarray(price[: a.shape[1]], dtype=float)

    def usage(self, path: np.ndarray) -> tuple[float, float]:
        """Energy (4) and memory (5) of a plan (positions in time order), slew term exact."""
        if len(path) == 0:
            return 0.0, 0.0
        return self.rules.usage(self.duration[path], self.roll[path])

    def fits(self, path: np.ndarray) -> bool:
        """Whether a plan keeps (4) and (5) ((3), (6) hold by construction)."""
        energy, memory = self.usage(path)
        r = self.rules
        return energy <= r.energy_capacity + EPS and memory <= r.memory_capacity + EPS

    def covered(self, path: np.ndarray) -> np.ndarray:
        """The distinct targets a plan covers."""
        if len(path) == 0:
            return np.zeros(0, dtype=np.int64)
        ptr = self.target_ptr
        return np.unique(np.concatenate([self.target_flat[ptr[u] : ptr[u + 1]] for u in path]))


@dataclass(frozen=True, eq=False)
class OrbitData:
    """Candidate observations of every orbit (the cluster model's items) for the recursion.

    ``orbit, start, end, roll, opps`` are the candidate columns (the attribute names of
    :class:`models.data.ModelData` that :func:`sosp.schedule.items_to_schedule` reads).
    """

    instance: Instance
    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: tuple[tuple[int, ...], ...]
    orbits: tuple[OrbitItems, ...]
    target_orbits_ptr: np.ndarray
    target_orbits: np.ndarray

    @property
    def n_items(self) -> int:
        return len(self.opps)

    def orbits_seeing(self, targets: np.ndarray) -> np.ndarray:
        """Positions in :attr:`orbits` of the orbits with a candidate covering any target."""
        if len(targets) == 0:
            return np.zeros(0, dtype=np.int64)
        ptr = self.target_orbits_ptr
        parts = [self.target_orbits[ptr[k] : ptr[k + 1]] for k in targets]
        return np.unique(np.concatenate(parts))


def orbit_data(instance: Instance, deadline: float | None = None) -> OrbitData:
    """Build :class:`OrbitData` from the cluster model's candidates.

    Parameters
    ----------
    instance
        The problem.
    deadline
        :func:`time.perf_counter` value by which the candidates must be complete (else
        :class:`~sosp.errors.InputError`, see :func:`sosp.candidates.cluster_candidates`).
    """
    orbit, start, end, roll, opps = cluster_candidates(instance, deadline=deadline)
    return _arrange(instance, orbit, start, end, roll, opps)


def with_rolls(data: OrbitData, roll: np.ndarray) -> OrbitData:
    """The same candidate observations at other rolls (one per candidate, in degrees).

    For searches whose observations follow another roll rule than the nadir-closest point
    (ASA-DTC's midpoint (9)): each roll must lie in the range of every covered opportunity
    (7), and then the recursion is exact for observations at these rolls.
    """
    roll = np.asarray(roll, dtype=float)
    if roll.shape != data.roll.shape:
        raise ValueError(f"roll: expected {data.roll.shape[0]} values, got {roll.shape}")
    return _arrange(data.instance, data.orbit, data.start, data.end, roll, data.opps)


def _arrange(
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    opps: tuple[tuple[int, ...], ...],
) -> OrbitData:
    """Group candidate columns per orbit for the recursion (:class:`OrbitData`)."""
    tgt = instance.opp_target
    groups: list[OrbitItems] = []
    seen_by: list[list[int]] = [[] for _ in range(instance.n_targets)]
    if len(opps):
        order = np.lexsort((end, start, orbit))
        cuts = np.flatnonzero(np.diff(orbit[order])) + 1
        for block in np.split(order, cuts):
            j = int(orbit[block[0]])
            rj = orbit_rules(instance, j)
            slew_s = rj.slew(roll[block])
            left = rj.left(start[block], roll[block])
            right = rj.right(end[block], roll[block])
            by_release = np.argsort(right, kind="stable")
            n_before = np.searchsorted(right[by_release], left + EPS, side="right")
            flat, seg = _covered_targets(tgt, [opps[u] for u in block])
            sizes = np.bincount(seg, minlength=len(block))
            ptr = np.zeros(len(block) + 1, dtype=np.int64)
            ptr[1:] = np.cumsum(sizes)
            targets = np.unique(flat)
            for k in targets:
                seen_by[int(k)].append(len(groups))
            groups.append(
                OrbitItems(
                    orbit=j,
                    items=block,
                    duration=end[block] - start[block],
                    roll=roll[block],
                    slew_s=slew_s,
                    by_release=by_release,
                    n_before=n_before,
                    target_ptr=ptr,
                    target_flat=flat,
                    target_seg=seg,
                    targets=targets,
                    rules=rj,
                )
            )
    counts = np.array([len(s) for s in seen_by], dtype=np.int64)
    tptr = np.zeros(instance.n_targets + 1, dtype=np.int64)
    tptr[1:] = np.cumsum(counts)
    flat_orbits = np.array([g for s in seen_by for g in s], dtype=np.int64)
    return OrbitData(
        instance=instance,
        orbit=orbit,
        start=start,
        end=end,
        roll=roll,
        opps=opps,
        orbits=tuple(groups),
        target_orbits_ptr=tptr,
        target_orbits=flat_orbits,
    )


def _covered_targets(
    opp_target: np.ndarray, opps: list[tuple[int, ...]]
) -> tuple[np.ndarray, np.ndarray]:
    """The distinct targets of each group of opportunities, sorted within the group, flat, and
    the group of each entry (both in group order)."""
    sizes, flat_opps = flatten(opps)
    seg = np.repeat(np.arange(len(opps), dtype=np.int64), sizes)
    tg = opp_target[flat_opps].astype(np.int64)
    order = np.lexsort((tg, seg))
    tg, seg = tg[order], seg[order]
    keep = np.ones(len(tg), dtype=bool)
    keep[1:] = (tg[1:] != tg[:-1]) | (seg[1:] != seg[:-1])
    return tg[keep], seg[keep]


def best_path(
    o: OrbitItems, price: np.ndarray, lam_energy: float = 0.0, lam_memory: float = 0.0
) -> tuple[float, np.ndarray]:
    """The best plan of one orbit under (3) and (6), knapsacks (4)-(5) as penalties.

    Maximises ``sum over the plan of (gain_u - lam_energy * energy_u / E - lam_memory *
    memory_u / W)``, with the slew term of (4) exact over consecutive observations (see the
    module docstring), over sequences of at most c_j observations pairwise compatible by (3).

    Parameters
    ----------
    o
        The orbit.
    price
        Per target of the instance, what covering it is worth (>= 0).
    lam_energy, lam_memory
        Penalties per whole capacity E_j, W_j (>= 0).

    Returns
    -------
    tuple
        ``(value, path)``: the penalised value (0 for the empty plan, never below) and the
        plan's positions in time order.
    """
    m = o.size
    if m == 0:
        return 0.0, np.zeros(0, dtype=np.int64)
    r = o.rules
    pe = lam_energy / r.energy_capacity if r.energy_capacity > 0 else 0.0
    pw = lam_memory / r.memory_capacity if r.memory_capacity > 0 else 0.0
    slew_cost = pe * r.slew_energy_rate * o.slew_s
    g = o.gains(price) - pe * r.observe_energy_rate * o.duration
    g -= pw * r.memory_rate * o.duration
    g -= 2.0 * slew_cost
    bonus = slew_cost  # the first (and, separately, the last) observation's |theta| back
    levels = [np.full(m, -np.inf)]
    for _ in range(max(r.max_openings, 0)):
        prev = levels[-1]
        best_before = np.empty(m + 1)
        best_before[0] = -np.inf
        np.maximum.accumulate(prev[o.by_release], out=best_before[1:])
        cur = g + np.maximum(bonus, best_before[o.n_before])
        levels.append(cur)
        # One more opening adds nothing: neither will the next. Bytes, not np.array_equal:
        # ten times faster on an orbit's few hundred items, and a false "differ" (-0.0 vs
        # 0.0) only costs one more level.
        if cur.tobytes() == prev.tobytes():
            break
    final = levels[-1] + bonus
    u = int(np.argmax(final))
    value = float(final[u])
    if not value > 0.0:
        return 0.0, np.zeros(0, dtype=np.int64)
    path = [u]
    n = len(levels) - 1
    while n > 1:
        k = int(o.n_before[u])
        if k == 0:
            break
        before = o.by_release[:k]
        prev = levels[n - 1][before]
        q = int(np.argmax(prev))
        if not prev[q] > bonus[u]:
            break  # u starts the plan
        u = int(before[q])
        path.append(u)
        n -= 1
    return value, np.array(path[::-1], dtype=np.int64)


def best_feasible_path(o: OrbitItems, price: np.ndarray) -> np.ndarray:
    """A plan of one orbit that keeps (3)-(6), exact when the knapsacks do not bind.

    The recursion without penalties gives the optimum over (3) and (6); when that plan also
    fits (4) and (5) it is optimal. Otherwise a common penalty on energy and memory (per unit
    of capacity) is doubled until the plan fits, then bisected 12 times towards the smallest
    penalty that fits: a Lagrangian heuristic, feasible but not proven optimal.
    """
    _, path = best_path(o, price)
    if o.fits(path):
        return path
    lo, hi = 0.0, 1.0
    for _ in range(_MAX_DOUBLINGS):
        _, path = best_path(o, price, hi, hi)
        if o.fits(path):
            break
        lo, hi = hi, 2.0 * hi
    else:
        return np.zeros(0, dtype=np.int64)
    best = path
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        _, path = best_path(o, price, mid, mid)
        if o.fits(path):
            hi, best = mid, path
        else:
            lo = mid
    return best


def flat_positions(o: OrbitItems, path: np.ndarray) -> np.ndarray:
    """Indices into ``o.target_flat`` of the targets of the positions in ``path``."""
    ptr = o.target_ptr
    return np.concatenate([np.arange(ptr[u], ptr[u + 1]) for u in path])
