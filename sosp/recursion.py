"""The single-orbit recursion shared by every planner, bound and stretch move.

Over one orbit's positions (candidate observations, a stretch's, or a window's argmax
observations), with (3) given as an order ``by_release`` (the items by ``R``) and, per item,
how many of them may precede it (``n_before``, :func:`release_order`), :func:`recursion`
finds the best plan of at most c_j observations: per position the gain net of the (4)-(5)
penalties (the slew term exact over consecutive pairs), then one sweep
(:func:`levels_py`, compiled by numba) and the levels only when that sweep's plan is longer
than the cap. :func:`least_penalty_plan` searches the least common penalty whose plan fits
(4)-(5). :mod:`sosp.planner` (candidates), :mod:`sosp.windows` (windows) and
:mod:`models.subset_row` (the same recursion with subset-row cuts as labels) build on it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from sosp.kernels import compiled
from sosp.rules import EPS, OrbitRules

#: Penalty doublings tried before :func:`least_penalty_plan` settles for the empty plan.
_MAX_DOUBLINGS = 60

#: Bisection steps of :func:`least_penalty_plan` between an infeasible and a fitting penalty.
_BISECTIONS = 12


def release_order(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The recursion's view of (3) on one orbit from the items' interval ends (``L``, ``R``
    of :mod:`sosp.rules`): the items by ``R`` (``by_release``), and per item how many of
    them have ``R <= L + EPS``, i.e. may precede it (``n_before``, a prefix of that order)."""
    by_release = np.argsort(right, kind="stable")
    return by_release, np.searchsorted(right[by_release], left + EPS, side="right")


def restrict(
    by_release: np.ndarray, n_before: np.ndarray, keep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``by_release`` and ``n_before`` of the sub-orbit of positions ``keep`` (sorted), in
    the sub-orbit's positions."""
    size = len(n_before)
    inside = np.zeros(size, dtype=bool)
    inside[keep] = True
    new_pos = np.cumsum(inside) - 1
    kept_release = inside[by_release]
    sub_release = new_pos[by_release[kept_release]]
    # kept positions among the first n of by_release, for each n
    prefix = np.zeros(size + 1, dtype=np.int64)
    np.cumsum(kept_release, out=prefix[1:])
    return sub_release, prefix[n_before[keep]]


def recursion(
    slew_s: np.ndarray,
    duration: np.ndarray,
    gain: np.ndarray,
    by_release: np.ndarray | None,
    n_before: np.ndarray,
    r: OrbitRules,
    pe: float,
    pw: float,
    *,
    openings: int | None = None,
    left_slew: float | None = None,
    right_slew: float | None = None,
    run: Callable[..., tuple[float, np.ndarray]] | None = None,
) -> tuple[float, np.ndarray]:
    """The level-by-level recursion of :func:`sosp.planner.best_path` and
    :func:`sosp.planner.plan_sequence`, and of :mod:`models.subset_row` with its cuts.

    Level n holds, per position, the best penalised value of a plan of at most n
    observations ending there ((3) through ``by_release``/``n_before``, ``by_release`` None
    when the positions are already in ``R`` order; (6) through the
    number of levels, at most ``openings``, default c_j). The gain of each position is taken
    net of the (4)-(5) penalties. The slew term of (4) runs over
    consecutive pairs: each observation pays ``2 |theta| / v`` and the first one gets
    ``|theta_first| / v`` back, or, after a fixed neighbour of slew ``left_slew`` (seconds
    ``|theta| / v``), pays that neighbour's half of the turn instead; the same at the end
    with ``right_slew``. ``run(g, first, last, order, n_before, cap)`` replaces the levels
    (:func:`levels_py`) by another kernel over the same inputs (the subset-row cuts' labels),
    all contiguous arrays.

    Returns
    -------
    tuple
        ``(value, path)``: the plan's penalised value and its positions in (3) order; the
        empty plan (value ``-pe * es * (left_slew + right_slew)`` with both neighbours, the
        turn between them, else 0) when nothing beats it (or no observation is allowed: a
        local search's stretch with no opening left).
    """
    m = len(gain)
    es = pe * r.slew_energy_rate
    cap = min(r.max_openings if openings is None else openings, m)
    empty = 0.0
    if left_slew is not None and right_slew is not None:
        empty = -es * (left_slew + right_slew)
    if cap <= 0:
        return empty, np.zeros(0, dtype=np.int64)
    # What the first (last) observation gets back: |theta| of the missing turn from (to)
    # nadir, or minus the fixed neighbour's half of the turn to it.
    first: Any = 0.0
    last: Any = 0.0
    g = gain
    if pe > 0.0 or pw > 0.0:
        slew_cost = es * slew_s
        g = gain - pe * r.observe_energy_rate * duration
        g -= pw * r.memory_rate * duration
        g -= 2.0 * slew_cost
        first = slew_cost if left_slew is None else -es * left_slew
        last = slew_cost if right_slew is None else -es * right_slew
    firsts = np.full(m, first) if np.ndim(first) == 0 else first
    lasts = np.full(m, last) if np.ndim(last) == 0 else last
    order = np.arange(m) if by_release is None else by_release
    kernel = run if run is not None else lambda *args: levels()(*args, 1)  # sweep, then levels
    f8, i8 = np.float64, np.int64
    columns = ((g, f8), (firsts, f8), (lasts, f8), (order, i8), (n_before, i8))
    value, path = kernel(*(np.ascontiguousarray(c, dtype=t) for c, t in columns), cap)
    if not value > empty:
        return empty, np.zeros(0, dtype=np.int64)
    return value, path


def levels_py(
    g: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    order: np.ndarray,
    n_before: np.ndarray,
    cap: int,
    sweep: int = 1,
) -> tuple[float, np.ndarray]:
    """The levels of :func:`recursion` and the way back (compiled by numba, :func:`levels`).

    With ``sweep`` 1 (the callers' choice), one sweep without the cap first, and the levels
    only when its plan is longer than ``cap`` (see below); 0: the levels alone (kept for
    ``benchmarks/bench_planner.py``, which times one against the other).

    Level n holds, per position u, ``g[u] + max(first[u], best of level n - 1 over the first
    n_before[u] positions of order)``; a level equal (bit for bit) to the one before ends the
    recursion, itself kept as the top level. The best final value ``level + last`` is taken
    at its first position, and each step back takes the first position by ``order``
    reaching its predecessors' maximum, while that maximum beats starting at u. Loops, not
    array operations: a local search's stretch has a few dozen positions, where numpy's
    fixed cost per call was most of the time.
    """
    m = g.shape[0]
    # First one sweep without the cap: every predecessor of u is among the first n_before[u]
    # positions of ``order`` and u is not (positive durations), so visiting the positions
    # in that order gives each the best plan of any length ending there. When the best of
    # these plans has at most ``cap`` observations it is the best under the cap too, and
    # the levels (cap sweeps, or until two agree) are not needed: most plans are shorter.
    s = np.empty(m)
    pm = np.empty(m + 1)
    run = -np.inf
    pm[0] = run
    use_sweep = sweep == 1
    for k in range(m if use_sweep else 0):
        u = order[k]
        if n_before[u] > k:
            use_sweep = False  # not a (3) order (u among its own predecessors): the levels
            break
        b = pm[n_before[u]]
        f = first[u]
        s[u] = (b if b > f else f) + g[u]
        if s[u] > run:
            run = s[u]
        pm[k + 1] = run
    lv = np.empty((0, m))  # the levels, allocated only when they run
    path = np.empty(cap, dtype=np.int64)
    top = cap
    while True:
        if not use_sweep:
            lv = np.empty((cap, m))
            for u in range(m):
                lv[0, u] = g[u] + first[u]
            top = 1
            while top < cap:
                prev = lv[top - 1]
                run = -np.inf
                pm[0] = run
                for k in range(m):
                    x = prev[order[k]]
                    if x > run:
                        run = x
                    pm[k + 1] = run
                cur = lv[top]
                same = True
                for u in range(m):
                    b = pm[n_before[u]]
                    f = first[u]
                    v = (b if b > f else f) + g[u]
                    cur[u] = v
                    if same and (
                        v != prev[u] or math.copysign(1.0, v) != math.copysign(1.0, prev[u])
                    ):
                        same = False
                top += 1
                if same:
                    break
        end = s if use_sweep else lv[top - 1]
        best_u = 0
        best_v = end[0] + last[0]
        for u in range(1, m):
            v = end[u] + last[u]
            if v > best_v:
                best_u, best_v = u, v
        u = best_u
        path[0] = u
        count = 1
        n = top  # levels left below the plan's last position (the sweep: no such limit)
        while use_sweep or n > 1:
            prev = s if use_sweep else lv[n - 2]
            best = -np.inf
            pick = -1
            for k in range(n_before[u]):
                x = prev[order[k]]
                if x > best:  # strict: the first position reaching the maximum
                    best, pick = x, order[k]
            if not best > first[u]:
                break  # u starts the plan (or has no predecessor)
            if count == cap:
                count = cap + 1  # the sweep's plan is longer than the cap
                break
            u = pick
            path[count] = u
            count += 1
            n -= 1
        if count <= cap:
            return best_v, path[:count][::-1].copy()
        use_sweep = False  # the levels decide


#: :func:`levels_py`'s numba signature.
LEVELS_SIGNATURE = (
    "Tuple((float64, int64[::1]))(float64[::1], float64[::1], float64[::1], "
    "int64[::1], int64[::1], int64, int64)"
)


def levels() -> Callable[..., tuple[float, np.ndarray]]:
    """:func:`levels_py` compiled by numba on first use (cached on disk: about 1.5 s the
    first time, then about 0.5 s a process to import numba and load it)."""
    return compiled(levels_py, LEVELS_SIGNATURE)


def least_penalty_plan(
    plan: Callable[[float], np.ndarray], fits: Callable[[np.ndarray], bool]
) -> np.ndarray:
    """The plan at about the least common penalty on (4)-(5) whose plan fits them.

    ``plan(t)`` is the recursion's plan with penalty ``t`` per unit of energy and memory
    capacity. ``plan(0)`` when it fits (then optimal under (3), (6)); otherwise ``t`` is
    doubled from 1 (at most :data:`_MAX_DOUBLINGS` times; the empty plan when none fits) and
    bisected :data:`_BISECTIONS` times towards the least fitting penalty (a larger penalty
    makes the plan's penalised use of the two budgets no larger). Only a plan that passed
    ``fits`` is returned, so it is feasible: a Lagrangian heuristic, not proven optimal when
    the knapsacks bind.
    """
    path = plan(0.0)
    if fits(path):
        return path
    lo, hi = 0.0, 1.0
    for _ in range(_MAX_DOUBLINGS):
        path = plan(hi)
        if fits(path):
            break
        lo, hi = hi, 2.0 * hi
    else:
        return np.zeros(0, dtype=np.int64)
    best = path
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        trial = plan(mid)
        if fits(trial):
            hi, best = mid, trial
        else:
            lo = mid
    return best
