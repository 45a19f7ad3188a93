"""The exact models as arrays, passed to HiGHS directly (no Pyomo): the fast backend.

:func:`build_arrays` assembles the SAME formulation as :func:`models.formulation.build_model`
(the reference builder, the design card) from a :class:`models.data.ModelData`, as numpy
columns and one ``scipy.sparse`` CSR matrix, and :func:`run_highs` hands it to a fresh
``highspy.Highs`` with ``passModel``. On C5's cluster model Pyomo spends 13.6 s building and
30.7 s loading; here both are array operations.

Columns, in this order (u an item, k a covered target, S the items of the orbits whose energy
constraint (4) can bind, e an event of (3)):

* x_u in {0, 1} (continuous in [0, 1] for the LP relaxation);
* z_k in [0, 1] (coverage models only);
* f_u, l_u, s_u, r_u in [0, 1] for u in S (first / last indicators and prefix / suffix
  variables of the exact slew term of (4), see :mod:`models.formulation`);
* t_e >= 0, one slack per clique of (3) (network form only).

Rows: (2), (3), the slew-order rows, (4), (5), (6), exactly as in :mod:`models.formulation`,
except that (3) has two forms:

``conflicts="clique"``
    ``sum_{u in Q_e} x_u <= 1`` for every maximal clique Q_e (sum of the clique sizes in
    nonzeros: quadratic in the density of an orbit).
``conflicts="network"`` (default)
    On one orbit the cliques Q_1, ..., Q_m (in time order) have the consecutive-ones property:
    item u lies in Q_e exactly for e in a run [a_u, b_u) (:func:`models.cliques.clique_events`).
    Write the clique rows as equalities with slacks, ``R_e: sum_{u in Q_e} x_u + t_e = 1``,
    ``t_e >= 0``, and replace them by ``R_1`` and the differences ``R_e - R_{e-1}``
    (e = 2..m)::

        x_u with a_u = e  - x_u with b_u = e  + t_e - t_{e-1} = [e == 1]

    The map (R_1, ..., R_m) -> (R_1, R_2 - R_1, ..., R_m - R_{m-1}) is unimodular
    (lower bidiagonal, inverse: partial sums R_e = sum_{i <= e} D_i), so the two systems have
    the same solutions (x, t); t_e >= 0 is the clique inequality itself, so projecting t out
    gives the same polytope in x for the LP and the same integer points for the MILP: identical
    LP values and optima. Every x_u now has at most 2 nonzeros in (3) (+1 at a_u, -1 at b_u
    when b_u <= m) and every t_e at most 2, so (3) costs O(2n + 2m) nonzeros instead of the sum
    of the clique sizes. (The matrix is a network matrix: a flow through the events.)
"""

from __future__ import annotations

import logging
import os
import sys
import time
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
import scipy.sparse as sp

from models.data import ModelData
from sosp.candidates import flatten
from sosp.parallel import Child, ChildStartError, child_setup
from sosp.progress import current as current_progress
from sosp.stop import stop_requested

log = logging.getLogger("models.solve")

#: HiGHS ``presolve_rule_off`` bit of probing (HiGHS's own hint when probing hits the limit).
PROBING_OFF = 1 << 15

#: Seconds of HiGHS's MIP presolve per nonzero: twice what C10's cluster model with the
#: relaxed slew row took (13.4 s for 2.3 M nonzeros, 2 cores shared by other jobs). Presolve
#: reads the clock rarely; :func:`run_highs` does not start a MIP whose estimate does not fit.
PRESOLVE_S_PER_NONZERO = 1.2e-5

#: From this many nonzeros on, a MIP with a deadline runs in a child process that is stopped
#: :data:`GUARD_GRACE_S` after the deadline if HiGHS has not returned (:func:`run_highs`):
#: parts of HiGHS's MIP presolve read no clock (japan-500's cluster model, 600 s limit: still in
#: ``HPresolve::dominatedColumns`` after 25 minutes). Below it the solves are short and the
#: child's start (about a second: a fresh interpreter imports numpy, scipy, highspy) would
#: dominate.
GUARD_NNZ = 100_000

#: Seconds a guarded solve may run past its deadline before its process is stopped.
GUARD_GRACE_S = 0.5

#: Seconds a guarded solve may take to return after a stop request (its incumbents and dual
#: bound are already with the parent; HiGHS's presolve sees no interrupt, and a Ctrl-C during
#: it waited the whole :data:`GUARD_GRACE_S`, issue 63).
STOP_GRACE_S = 0.1

#: The forms of (3) :func:`build_arrays` accepts.
CONFLICT_FORMS = ("network", "clique")

#: Forms of the slew term of (4) :func:`build_arrays` accepts.
SLEW_FORMS = ("exact", "relaxed", "conservative")

#: HiGHS LP algorithms for relaxations (its ``solver`` option; "choose" lets HiGHS decide).
LP_SOLVERS = ("choose", "simplex", "ipm", "pdlp")

#: Whether this process has made its first ``highspy.Highs`` (see :func:`new_highs`).
_banner_done = False


def new_highs() -> Any:
    """A fresh ``highspy.Highs``, without HiGHS's start-up banner on standard output.

    highspy prints its banner ("Running HiGHS ...") straight to the C-level standard output
    when the first solver object of a process is made, whatever ``output_flag`` says; that
    would corrupt the single JSON object ``sosp solve/bound --json`` print. So the first
    construction runs with file descriptor 1 pointed at the null device.
    """
    import highspy

    global _banner_done
    if _banner_done:
        return highspy.Highs()
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            h = highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    _banner_done = True
    return h


#: Threads HiGHS's process-wide task scheduler runs with (None: HiGHS's default), as last set
#: by :func:`use_threads`.
_scheduler_threads: int | None = None


def use_threads(threads: int | None) -> None:
    """Make HiGHS's process-wide task scheduler run with ``threads`` (None: HiGHS's default).

    HiGHS starts one scheduler per process at its first solve and keeps its thread count: a
    later solve whose ``threads`` option differs ends with model status "unknown" and no
    solution (HiGHS logs "the scheduler has already been initialized"), and a solve without
    the option silently runs with the old count. So whenever the request changes, the
    scheduler is restarted first. Both backends (APPSI uses highspy too) call this before
    every solve; solves in one process are sequential, so no solve is running meanwhile.
    """
    global _scheduler_threads
    if threads != _scheduler_threads:
        import highspy

        highspy.Highs.resetGlobalScheduler(True)
        _scheduler_threads = threads


@dataclass
class _Lp:
    """What HiGHS needs of a model: max c'y s.t. row_lower <= A y <= row_upper, bounds,
    integrality, the first ``n_items`` columns the x block; of an :class:`ArrayModel`, what
    is sent to the child process of a guarded solve (:func:`run_highs`)."""

    matrix: sp.csr_matrix
    cost: np.ndarray
    col_lower: np.ndarray
    col_upper: np.ndarray
    row_lower: np.ndarray
    row_upper: np.ndarray
    integer: np.ndarray
    n_items: int

    @classmethod
    def of(cls, am: _Lp) -> _Lp:
        return cls(*(getattr(am, f.name) for f in fields(cls)))

    @property
    def n_cols(self) -> int:
        return int(self.matrix.shape[1])


@dataclass
class ArrayModel(_Lp):
    """One exact model as arrays (:class:`_Lp`) with what it was built from.

    Attributes
    ----------
    matrix
        Constraint matrix, CSR, rows x columns.
    cost, col_lower, col_upper, row_lower, row_upper
        Objective (1) (maximised) and bounds.
    integer
        Columns that are integer (x in the MILP; none in the LP relaxation).
    n_items
        Number of x columns (the first block).
    data
        The model data it was built from.
    z_targets
        The covered targets, in the order of the z columns.
    slew_items
        The items of S, in the order of the f, l, s, r blocks.
    offsets
        First column of each block: ``x``, ``z``, ``f``, ``l``, ``s``, ``r``, ``t``, ``end``.
    conflicts
        ``"network"`` or ``"clique"``, the form of (3).
    """

    data: ModelData
    z_targets: np.ndarray
    slew_items: np.ndarray
    offsets: dict[str, int]
    conflicts: str
    stats: dict[str, Any] = field(default_factory=dict)


class _Rows:
    """Accumulates rows as COO triplets (row, column, value) with their bounds."""

    def __init__(self) -> None:
        # the parts of each array, and the rows so far
        self.rows, self.cols, self.vals, self.lower, self.upper = [], [], [], [], []
        self.n = 0

    def add(
        self,
        rows: np.ndarray,
        cols: np.ndarray,
        vals: np.ndarray | float,
        lower: np.ndarray | float,
        upper: np.ndarray | float,
        count: int,
    ) -> None:
        """Add ``count`` rows; ``rows`` are local (0..count-1)."""
        if count == 0:
            return
        rows = np.asarray(rows, dtype=np.int64)
        self.rows.append(rows + self.n)
        self.cols.append(np.asarray(cols, dtype=np.int64))
        self.vals.append(np.broadcast_to(np.asarray(vals, dtype=float), rows.shape).copy())
        self.lower.append(np.broadcast_to(np.asarray(lower, dtype=float), (count,)).copy())
        self.upper.append(np.broadcast_to(np.asarray(upper, dtype=float), (count,)).copy())
        self.n += count

    def matrix(self, n_cols: int) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
        if not self.rows:
            return sp.csr_matrix((0, n_cols)), np.zeros(0), np.zeros(0)
        a = sp.coo_matrix(
            (np.concatenate(self.vals), (np.concatenate(self.rows), np.concatenate(self.cols))),
            shape=(self.n, n_cols),
        ).tocsr()
        a.sum_duplicates()
        a.eliminate_zeros()
        return a, np.concatenate(self.lower), np.concatenate(self.upper)


def build_arrays(
    data: ModelData,
    *,
    relax: bool = False,
    conflicts: str = "network",
    slew: str = "exact",
    exact_orbits: Collection[int] | None = None,
) -> ArrayModel:
    """Assemble the model of ``data`` as arrays (the formulation of :mod:`models.formulation`).

    Parameters
    ----------
    data
        Items and constraint data from :mod:`models.data`.
    relax
        x continuous in [0, 1]: the clique-strengthened LP relaxation (an upper bound on (1)).
    conflicts
        Form of the setup-time constraints (3): ``"network"`` (default, O(2n + 2m) nonzeros,
        same polytope) or ``"clique"`` (one row per maximal clique, as the Pyomo builder).
    slew
        The slew term of (4): ``"exact"`` (default; first/last indicators, 8 rows and 4
        columns per item of an energy-binding orbit) or ``"relaxed"``, for bounds only: the
        scheduled items u_1..u_n of an orbit slew ``(2 sum |theta| - |theta_1| - |theta_n|)/v
        >= (2 sum |theta| - 2 max_orbit |theta|)/v``, so the single row
        ``sum (eo d_u + 2 es |theta_u|/v) x_u <= E + 2 es max |theta|/v`` is implied by (4):
        a relaxation (its optimum is an upper bound) with no extra rows or columns.
        ``"conservative"``, for heuristic sub-problems only: the same row with right-hand side
        E, i.e. every slew counted twice, which over-estimates (4) (its solutions are
        feasible, some feasible ones are cut).
    exact_orbits
        With ``slew="exact"``: the energy-binding orbits that get the exact term; the others
        get the relaxed row (None: all of them). A model with some orbits relaxed is a
        relaxation (its dual bound and optimum bound the problem); its solution is feasible
        when it keeps (4) on the relaxed orbits (see :func:`models.solve.solve_milp`,
        ``slew="lazy"``).

    Returns
    -------
    ArrayModel
        Ready for :func:`run_highs`.
    """
    if conflicts not in CONFLICT_FORMS:
        raise ValueError(f"conflicts: expected one of {CONFLICT_FORMS}, got {conflicts!r}")
    if slew not in SLEW_FORMS:
        raise ValueError(f"slew: expected one of {SLEW_FORMS}, got {slew!r}")
    n = data.n_items
    z_targets = np.array(list(data.target_items), dtype=np.int64) if data.coverage else None
    nz = 0 if z_targets is None else len(z_targets)
    exact = [
        j
        for j in data.energy_orbits
        if slew == "exact" and (exact_orbits is None or j in exact_orbits)
    ]
    none = [np.zeros(0, dtype=np.int64)]
    slew_items = np.concatenate(none + [np.asarray(data.orbit_items[j], np.int64) for j in exact])
    ns = len(slew_items)
    m_events = data.n_events if conflicts == "network" else 0
    starts = np.cumsum([0, n, nz, ns, ns, ns, ns, m_events]).tolist()
    off: dict[str, int] = dict(zip(("x", "z", "f", "l", "s", "r", "t", "end"), starts, strict=True))
    n_cols = off["end"]

    cost, lower = np.zeros((2, n_cols))
    upper = np.ones(n_cols)
    upper[off["t"] :] = np.inf
    integer = np.arange(n_cols) < (0 if relax else n)  # x in the MILP

    rows = _Rows()
    _target_rows(rows, data, z_targets, off)
    _conflict_rows(rows, data, conflicts, off)
    _slew_order_rows(rows, data, slew_items, off)
    _resource_rows(rows, data, slew_items, off, give_back=slew != "conservative")

    # (1) objective
    if data.coverage:
        cost[off["z"] : off["f"]] = data.weight[z_targets]
    else:
        first_target = np.array([t[0] for t in data.targets], dtype=np.int64)
        cost[:n] = data.weight[first_target] if n else 0.0
    a, row_lower, row_upper = rows.matrix(n_cols)
    zs = none[0] if z_targets is None else z_targets
    lp = (a, cost, lower, upper, row_lower, row_upper, integer, n)
    return ArrayModel(*lp, data, zs, slew_items, off, conflicts)


def _target_rows(
    rows: _Rows, d: ModelData, z_targets: np.ndarray | None, off: dict[str, int]
) -> None:
    """(2): ``z_k - sum_{u covers k} x_u <= 0`` (coverage) or ``sum x_u <= 1`` (task)."""
    lens, target = flatten(d.targets)
    item = np.repeat(np.arange(d.n_items), lens)
    if z_targets is not None:
        k = np.searchsorted(z_targets, target)
        nk = len(z_targets)
        rows.add(
            np.concatenate([np.arange(nk), k]),
            np.concatenate([off["z"] + np.arange(nk), item]),
            np.concatenate([np.ones(nk), -np.ones(len(item))]),
            -np.inf,
            0.0,
            nk,
        )
        return
    # task model: one row per target covered by two or more items (others imply x <= 1)
    _, inv, counts = np.unique(target, return_inverse=True, return_counts=True)
    multi = counts >= 2
    new_id = np.cumsum(multi) - 1
    sel = multi[inv]
    rows.add(new_id[inv[sel]], item[sel], 1.0, -np.inf, 1.0, int(multi.sum()))


def _conflict_rows(rows: _Rows, d: ModelData, conflicts: str, off: dict[str, int]) -> None:
    """(3) setup time: clique rows, or their network form (module docstring)."""
    first, last = d.event_first, d.event_last
    m = d.n_events
    if m == 0:
        return
    has = last > first
    if conflicts == "clique":
        length = np.where(has, last - first, 0)
        item = np.repeat(np.arange(d.n_items), length)
        start = np.cumsum(length) - length
        event = np.arange(int(length.sum())) - np.repeat(start - first, length)
        rows.add(event, item, 1.0, -np.inf, 1.0, m)
        return
    # network form: D_e = R_e - R_{e-1} within an orbit; x_u: +1 at a_u, -1 at b_u (if in orbit)
    u = np.flatnonzero(has)
    block_end = d.event_block_end
    tail = u[last[u] < block_end[first[u]]]
    e = np.arange(m)
    inner = e[e + 1 < block_end]  # t_e appears again (with -1) in the next row of its orbit
    rhs = np.r_[True, block_end[1:] != block_end[:-1]].astype(float)  # 1 at an orbit's first
    rows.add(
        np.concatenate([first[u], last[tail], e, inner + 1]),
        np.concatenate([u, tail, off["t"] + e, off["t"] + inner]),
        np.concatenate([np.ones(len(u)), -np.ones(len(tail)), np.ones(m), -np.ones(len(inner))]),
        rhs,
        rhs,
        m,
    )


def _slew_order_rows(rows: _Rows, d: ModelData, slew: np.ndarray, off: dict[str, int]) -> None:
    """First/last indicators of (4) via prefix/suffix variables (as ``models.formulation``)."""
    ns = len(slew)
    if ns == 0:
        return
    pos = np.arange(ns)
    orbit = d.orbit[slew]
    same = orbit[1:] == orbit[:-1]
    x = slew
    f, l_, s, r = (off[b] + pos for b in ("f", "l", "s", "r"))
    p, q = pos[1:][same], pos[:-1][same]  # with a previous / a next item on their orbit

    def pair(a: np.ndarray, b: np.ndarray, vb: float, upper: float) -> None:
        """Rows ``a_i + vb * b_i <= upper``, one per i."""
        at = np.arange(len(a))
        rows.add(np.r_[at, at], np.r_[a, b], np.repeat([1.0, vb], len(a)), -np.inf, upper, len(a))

    pair(x, s, -1.0, 0.0)  # prefix_self: s_u >= x_u
    pair(off["s"] + p - 1, s[p], -1.0, 0.0)  # prefix_chain: s_u >= s_prev
    pair(x, r, -1.0, 0.0)  # suffix_self: r_u >= x_u
    pair(off["r"] + q + 1, r[q], -1.0, 0.0)  # suffix_chain: r_u >= r_next
    pair(f, x, -1.0, 0.0)  # first_taken: f_u <= x_u
    pair(f[p], off["s"] + p - 1, 1.0, 1.0)  # first_nothing_before: f_u <= 1 - s_prev
    pair(l_, x, -1.0, 0.0)  # last_taken: l_u <= x_u
    pair(l_[q], off["r"] + q + 1, 1.0, 1.0)  # last_nothing_after: l_u <= 1 - r_next


def _resource_rows(
    rows: _Rows, d: ModelData, slew: np.ndarray, off: dict[str, int], give_back: bool = True
) -> None:
    """(4) energy with the exact slew term, (5) memory, (6) openings, one row per orbit.

    On an orbit without slew variables (its items not in ``slew``) the energy row counts
    every slew twice and, with ``give_back``, adds twice the orbit's largest slew to E
    (relaxed) or not (conservative).
    """
    inst = d.instance
    dur = d.duration
    half = d.slew_time()
    where = {int(u): i for i, u in enumerate(slew.tolist())}
    for j in d.energy_orbits:
        seq = np.asarray(d.orbit_items[j], dtype=np.int64)
        eo, es = float(inst.observe_energy_rate[j]), float(inst.slew_energy_rate[j])
        h = es * half[seq]
        cap = float(inst.energy_capacity[j])
        if int(seq[0]) not in where:  # relaxed or conservative: every slew counted twice
            rhs = cap + 2 * h.max() if give_back else cap
            rows.add(np.zeros(len(seq)), seq, eo * dur[seq] + 2.0 * h, -np.inf, rhs, 1)
            continue
        pos = np.array([where[int(u)] for u in seq], dtype=np.int64)
        rolled = h > 0
        cols = np.concatenate([seq, off["f"] + pos[rolled], off["l"] + pos[rolled]])
        vals = np.concatenate([eo * dur[seq] + 2.0 * h, -h[rolled], -h[rolled]])
        rows.add(np.zeros(len(cols)), cols, vals, -np.inf, cap, 1)
    for j in d.memory_orbits:
        seq = np.asarray(d.orbit_items[j], dtype=np.int64)
        w = float(inst.memory_rate[j])
        rows.add(np.zeros(len(seq)), seq, w * dur[seq], -np.inf, float(inst.memory_capacity[j]), 1)
    for j in d.opening_orbits:
        seq = np.asarray(d.orbit_items[j], dtype=np.int64)
        rows.add(np.zeros(len(seq)), seq, 1.0, -np.inf, float(inst.max_openings[j]), 1)


# --------------------------------------------------------------------------- warm start
def start_vector(am: ArrayModel, values: dict[str, dict[int, float]]) -> np.ndarray:
    """A full column vector from :func:`models.solve.warm_start_values` (slacks t completed)."""
    off, d = am.offsets, am.data
    y = np.zeros(am.n_cols)
    blocks = [("x", range(d.n_items)), ("z", am.z_targets), *((b, am.slew_items) for b in "flsr")]
    for name, keys in blocks:
        got = values.get(name, {})
        y[off[name] : off[name] + len(keys)] = [got.get(int(k), 0.0) for k in keys]
    x = y[: d.n_items]
    if am.conflicts == "network" and d.n_events:
        taken = np.flatnonzero((x > 0.5) & (d.event_last > d.event_first))
        diff = np.zeros(d.n_events + 1)
        np.add.at(diff, d.event_first[taken], 1.0)
        np.add.at(diff, d.event_last[taken], -1.0)
        y[off["t"] : off["end"]] = 1.0 - np.cumsum(diff[:-1])
    return y


# --------------------------------------------------------------------------- solve
@dataclass
class HighsOutcome:
    """What :func:`run_highs` read back from HiGHS.

    Attributes
    ----------
    status
        ``"optimal"``, ``"time_limit"``, ``"infeasible"`` or ``"other"`` (HiGHS's model status
        in ``model_status``).
    objective
        Incumbent objective (MILP) or LP optimum; None without a primal feasible solution.
    bound
        ``mip_dual_bound`` (MILP) or the LP optimum; None when unknown.
    x
        Values of the x columns (None without a solution).
    """

    status: str
    model_status: str
    objective: float | None
    bound: float | None
    x: np.ndarray | None
    load_s: float
    solve_s: float
    info: dict[str, Any]


#: Seconds between two calls of a :func:`watching_bound` listener.
BOUND_WATCH_S = 0.5


#: A :func:`watching_bound` listener: called with the MIP's dual bound (inf before one) and
#: its incumbent's objective (-inf before one), it returns True to stop the solve.
BoundListener = Callable[[float, float], bool]


@dataclass
class _BoundWatch:
    """A :func:`watching_bound` listener and when it may be called next."""

    listener: BoundListener
    next: float = 0.0
    stop: bool = False

    def offer(self, dual_bound: float, primal: float) -> bool:
        now = time.perf_counter()
        if not self.stop and now >= self.next:
            self.next = now + BOUND_WATCH_S
            dual_bound = float(dual_bound) if np.isfinite(dual_bound) else np.inf
            primal = float(primal) if np.isfinite(primal) else -np.inf
            self.stop = bool(self.listener(dual_bound, primal))
        return self.stop


#: The listeners of :func:`watching_bound` blocks in hand, innermost last.
_bound_watches: list[_BoundWatch] = []


@contextmanager
def watching_bound(listener: BoundListener | None) -> Iterator[None]:
    """Within the block, the MIP solves of :func:`run_highs` (in this process or guarded)
    hand their dual bound (HiGHS's ``mip_dual_bound``) and their incumbent's objective to
    ``listener``, at most every :data:`BOUND_WATCH_S` seconds (a guarded solve's also while
    HiGHS reports nothing, with the last values it reported); when it returns
    True the solve is interrupted as at a time limit (with its incumbent and bound). Ambient,
    as :mod:`sosp.progress`: only the MILP of :func:`models.solve.solve_milp` is watched, by
    its side branch and price (:meth:`models.colgen.SideBound.watch`), not every solve the
    call chain makes. None: nothing is watched."""
    if listener is not None:
        _bound_watches.append(_BoundWatch(listener))
    try:
        yield
    finally:
        if listener is not None:
            _bound_watches.pop()


def _offer_bound(dual_bound: float, primal: float) -> bool:
    """Hand a MIP's bounds to the :func:`watching_bound` listener in hand; True: stop it."""
    return bool(_bound_watches) and _bound_watches[-1].offer(dual_bound, primal)


def _mip_check(event: Any) -> None:
    """HiGHS's MIP interrupt callback: report the node count to the solve's progress (its
    time and rate; a sub-MILP's bounds are not the problem's, so none are reported) and the
    dual bound to a :func:`watching_bound` listener; a stop request
    (:func:`sosp.stop.request_stop`) interrupts too."""
    d = event.data_out
    current_progress().update(int(d.mip_node_count), None)
    dual = float(d.mip_dual_bound)
    # before its first dual bound HiGHS calls back within moments (models this small)
    if (np.isfinite(dual) and _offer_bound(dual, float(d.mip_primal_bound))) or stop_requested():
        event.interrupt()


def run_highs(
    am: ArrayModel,
    *,
    time_limit: float | None = None,
    deadline: float | None = None,
    mip_gap: float | None = None,
    threads: int | None = None,
    start: np.ndarray | None = None,
    lp_solver: str | None = None,
    probing: bool = True,
    guard: bool | None = None,
) -> HighsOutcome:
    """Solve ``am`` with a fresh ``highspy.Highs`` (no option survives the call).

    Parameters
    ----------
    am
        The model.
    time_limit
        Seconds for HiGHS (None: no limit); with ``deadline`` (a ``time.perf_counter`` value)
        HiGHS gets only what is left after loading the model.
    mip_gap
        ``mip_rel_gap`` (None: HiGHS default 1e-4).
    threads
        HiGHS ``threads``.
    start
        A full feasible column vector given as a MIP start (``setSolution``).
    lp_solver
        HiGHS's ``solver`` option for a pure LP (``"simplex"``, ``"ipm"``, ``"pdlp"``;
        None: HiGHS chooses); ignored for a MIP.
    probing
        False: switch off probing in MIP presolve (it checks the clock rarely and can run far
        past ``time_limit``, see :func:`models.solve.solve_milp`).
    guard
        Run HiGHS in a child process, stopped :data:`GUARD_GRACE_S` after ``deadline`` if it
        has not returned by then (the time limit then holds even where HiGHS reads no clock);
        the incumbents and the dual bound it reported on the way are returned, as after a
        time limit. None (default): for a MIP with a deadline and at least :data:`GUARD_NNZ`
        nonzeros.
    """
    mip = bool(am.integer.any())
    if guard is None:
        guard = mip and deadline is not None and am.matrix.nnz >= GUARD_NNZ
    kwargs = {
        "mip_gap": mip_gap, "threads": threads, "start": start, "lp_solver": lp_solver,
        "probing": probing,
    }  # fmt: skip
    if guard and deadline is not None:
        return _run_guarded(_Lp.of(am), deadline, kwargs)
    return _run_here(am, time_limit=time_limit, deadline=deadline, **kwargs)


def _run_here(
    am: _Lp,
    *,
    time_limit: float | None = None,
    deadline: float | None = None,
    mip_gap: float | None = None,
    threads: int | None = None,
    start: np.ndarray | None = None,
    lp_solver: str | None = None,
    probing: bool = True,
    report: Any = None,
    halt: Any = None,
) -> HighsOutcome:
    """:func:`run_highs` in this process. With ``report`` (a guarded solve's child), HiGHS's
    incumbents and MIP progress are sent through ``report(kind, *values)`` and the solve is
    interrupted once the event ``halt`` is set."""

    import highspy

    t0 = time.perf_counter()
    h = new_highs()
    debug, mip = log.isEnabledFor(logging.DEBUG), bool(am.integer.any())
    options = {
        "output_flag": debug,
        "log_to_console": False if debug else None,
        "mip_rel_gap": None if mip_gap is None else float(mip_gap),
        "threads": None if threads is None else int(threads),
        "solver": None if lp_solver is None or mip else str(lp_solver),
        "presolve_rule_off": PROBING_OFF if mip and not probing else None,
    }
    for name, value in options.items():
        if value is not None:
            h.setOptionValue(name, value)
    if debug:
        h.cbLogging.subscribe(lambda e: log.debug("HiGHS: %s", str(e.message).rstrip()))
    a = am.matrix
    bounds = (am.cost, am.col_lower, am.col_upper, am.row_lower, am.row_upper)
    csr = (a.indptr.astype(np.int32), a.indices.astype(np.int32), a.data.astype(float))
    rowwise, maximize = int(highspy.MatrixFormat.kRowwise), int(highspy.ObjSense.kMaximize)
    # integrality: 1 (kInteger) for the x of a MILP, 0 (kContinuous) elsewhere
    h.passModel(
        *a.shape[::-1], a.nnz, rowwise, maximize, 0.0, *bounds, *csr, am.integer.astype(np.int32)
    )
    if start is not None and mip:
        sol = highspy.HighsSolution()
        sol.col_value = np.asarray(start, dtype=float).tolist()
        sol.value_valid = True
        h.setSolution(sol)
    load_s = time.perf_counter() - t0
    left = time_limit if deadline is None else max(deadline - time.perf_counter(), 0.01)
    if left is not None:
        h.setOptionValue("time_limit", float(left))
    if mip and left is not None and left < PRESOLVE_S_PER_NONZERO * am.matrix.nnz:
        # presolve would not end in time and reads the clock rarely (C10: 13.4 s with 12 s
        # left); without it HiGHS's MIP set-up was worse (90 s with 10 s left): not started
        log.debug("HiGHS not started: %.1f s left for %d nonzeros", left, am.matrix.nnz)
        return HighsOutcome("time_limit", "not started", None, None, None, load_s, 0.0, {})
    use_threads(threads)
    # A stop request (sosp.stop: Ctrl-C / SIGTERM under the CLI) ends the solve at HiGHS's
    # next interrupt point with its incumbent, as a time limit would.
    stop = stop_requested if halt is None else halt.is_set

    def lp_interrupt(event: Any) -> None:
        if stop():
            event.interrupt()

    h.cbSimplexInterrupt += lp_interrupt
    h.cbIpmInterrupt += lp_interrupt
    if report is None:
        h.cbMipInterrupt += _mip_check
    else:  # a guarded solve's child: incumbents and (five times a second) progress to report
        last = [0.0]

        def interrupt(event: Any) -> None:
            now, d = time.perf_counter(), event.data_out
            if now - last[0] >= 0.2:
                last[0] = now
                report("progress", int(d.mip_node_count), float(d.mip_dual_bound))
            lp_interrupt(event)

        def improving(event: Any) -> None:
            d = event.data_out
            x = np.asarray(d.mip_solution[: am.n_items], dtype=float)
            report("incumbent", float(d.objective_function_value), x)

        h.cbMipInterrupt += interrupt
        h.cbMipImprovingSolution += improving
    t1 = time.perf_counter()
    h.run()
    solve_s = time.perf_counter() - t1
    ms = h.getModelStatus()
    info = h.getInfo()
    feasible = int(info.primal_solution_status) == 2  # kSolutionStatusFeasible
    K = highspy.HighsModelStatus
    status = {K.kOptimal: "optimal", K.kInfeasible: "infeasible"}.get(ms, "other")
    if ms in (K.kTimeLimit, K.kIterationLimit, K.kInterrupt, K.kHighsInterrupt):
        status = "time_limit"
    objective = float(info.objective_function_value) if feasible else None
    raw = float(info.mip_dual_bound) if mip else objective if status == "optimal" else None
    bound = raw if raw is not None and np.isfinite(raw) else None
    x = np.asarray(h.getSolution().col_value[: am.n_items]) if feasible else None
    out_info = {
        "mip_node_count": int(info.mip_node_count) if mip else 0,
        "simplex_iteration_count": int(info.simplex_iteration_count),
    }
    return HighsOutcome(
        status, str(h.modelStatusToString(ms)), objective, bound, x, load_s, solve_s, out_info
    )


def _guarded_child(conn: Any, halt: Any, lp: _Lp, left: float, kwargs: dict[str, Any]) -> None:
    """A guarded solve's child process: solve ``lp`` within ``left`` seconds, reporting to the
    parent through ``conn``; the last message is ``("done", HighsOutcome)`` or
    ``("error", text)``."""
    child_setup()
    try:
        deadline = time.perf_counter() + left
        out = _run_here(
            lp, deadline=deadline, report=lambda *msg: conn.send(msg), halt=halt, **kwargs
        )
        conn.send(("done", out))
    except Exception as exc:  # pragma: no cover - HiGHS or pickling failures
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        conn.close()


def _run_guarded(
    lp: _Lp, deadline: float, kwargs: dict[str, Any], child: Any = _guarded_child
) -> HighsOutcome:
    """:func:`run_highs` in a child process stopped :data:`GUARD_GRACE_S` after ``deadline``.

    The child is started with ``spawn``: a forked child would inherit HiGHS's process-wide
    task scheduler without its threads (:func:`use_threads`). A stop request here
    (:mod:`sosp.stop`) interrupts the child as a time limit would. When the child has to be
    stopped, the best incumbent it reported and its last dual bound (both valid) are the
    outcome, with status ``"time_limit"``. ``child`` is the child's function (tests replace
    it to hang).
    """
    import multiprocessing as mp

    if stop_requested():  # its child would take a second to start (a fresh interpreter)
        return HighsOutcome("time_limit", "not started", None, None, None, 0.0, 0.0, {})
    t0 = time.perf_counter()
    halt = mp.get_context("spawn").Event()
    left = max(deadline - time.perf_counter(), 0.01)
    try:
        guard = Child(child, (halt,), (lp, left, kwargs))
    except ChildStartError as exc:
        # no guard against HiGHS's clockless parts then, but an answer
        log.warning("%s; HiGHS runs in this process", exc)
        return _run_here(lp, deadline=deadline, **kwargs)
    recv, progress = guard.conn, current_progress()
    best: tuple[float, np.ndarray | None] = (-np.inf, None)  # the best incumbent and its x
    dual, nodes, out = None, 0, None  # its last dual bound and node count; the outcome
    try:
        while out is None:
            # a watcher is asked also while HiGHS reports nothing (parts of its presolve):
            # a side bound that proves the start must be able to stop it then too
            watched = _offer_bound(np.inf if dual is None else dual, best[0])
            if (watched or stop_requested()) and not halt.is_set():
                halt.set()  # the child stops as at its time limit, with what it has ...
                deadline = min(deadline, time.perf_counter())  # ... or is stopped
            grace = STOP_GRACE_S if stop_requested() else GUARD_GRACE_S
            if time.perf_counter() > deadline + grace:
                log.info("HiGHS still running %.1f s after its deadline: stopped", grace)
                break
            if not recv.poll(0.1):  # the parent looks ten times a second
                continue
            try:
                kind, *got = recv.recv()
            except EOFError:
                code = guard.proc.exitcode
                raise RuntimeError(f"HiGHS's process ended (exit code {code})") from None
            if kind == "incumbent":
                best = (got[0], got[1]) if got[0] > best[0] else best
            elif kind == "progress":
                nodes, dual = got[0], got[1] if np.isfinite(got[1]) else dual
                progress.update(nodes, None)
            elif kind == "done":
                out = got[0]
            else:
                raise RuntimeError(f"HiGHS's process failed: {got[0]}")
    finally:
        guard.stop()
    if out is not None:
        return out
    objective, x = (None, None) if best[1] is None else best
    why = "stopped at the deadline (HiGHS had not returned)"
    info = {"mip_node_count": nodes, "simplex_iteration_count": 0, "guard_stopped": True}
    return HighsOutcome("time_limit", why, objective, dual, x, 0.0, time.perf_counter() - t0, info)
