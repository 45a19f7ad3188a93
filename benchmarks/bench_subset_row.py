"""How far subset-row cuts would lower the column-generation root of the cluster model.

A measurement, not a solver: it decides whether subset-row cuts are worth building into
``models.colgen`` (``docs/exact.md``, "Subset-row cuts: measured, not built").

The master of ``models.colgen`` over orbit plans has the coverage rows
``z_k <= sum_P n_kP y_P``. For three targets ``S`` the rank-1 Chvatal-Gomory cut of their
coverage rows and ``z_k <= 1`` with multipliers 1/2,

    sum_{k in S} z_k - sum_P ceil(c_SP / 2) y_P <= 1,

(``c_SP``: how many of S plan P covers) holds for every schedule (one plan per orbit, each
target counted once) but cuts the fractional mixtures of the root. Its dual ``sigma_S``
enters a plan's reduced value as ``sigma_S ceil(c_SP / 2)``: not a sum over targets, so the
single-orbit recursion (``sosp.planner``) cannot price it exactly unless it carries a state
per cut. Four variants, each after the converged root (``models.colgen.column_generation``):

``fixed``
    the root's columns only, cuts separated until none is violated: how low the master can
    go on those columns (not a bound: the optimum may need other plans);
``over``
    the same cuts, with pricing rounds in between that price each cut per target
    (``sigma_S`` for each of its targets covered, never less than the true term) except on
    orbits where the cut's targets can only be covered by one observation of a plan (there
    the term is that observation's, exact). The master's value is not a bound either: the
    over-estimating pricing may miss a plan of positive reduced value;
``exact``
    only cuts that every orbit prices exactly (at most one of S seen, or one observation at
    a time), so that each round's Lagrangian value ``sum_S sigma_S + sum_k max(0, p_k -
    mu_k - sum_{S ni k} sigma_S) + sum_j [best plan + lam_j]`` is a valid upper bound;
``mip``
    every cut, each orbit priced exactly by a small MIP (:class:`MipPricing`): what a
    recursion with a state per cut would give, at 50-150 times its time per round.

Example (the table of ``docs/exact.md``; one process, a few minutes per scenario)::

    PYTHONPATH=. python benchmarks/bench_subset_row.py --names C5 C6 C7 C8 C9 C10 --seconds 120
    PYTHONPATH=. python benchmarks/bench_subset_row.py --names C5 --variants mip --seconds 600
"""

from __future__ import annotations

import argparse
import logging
import math
import time
from typing import Any

import numpy as np

from models.colgen import column_generation
from models.subset_row import CutPool, best_path_with_cuts, orbit_cuts, violated_triples
from sosp.instance import Instance, load_instance
from sosp.planner import OrbitItems, PlanPool, flat_positions, orbit_data
from sosp.recursion import recursion
from sosp.scenarios import generate_scenario, scenario_names
from sosp.stop import Budget

log = logging.getLogger("bench_subset_row")

#: At most this many new cuts per separation, and per target per separation.
CUTS_PER_ROUND = 100
CUTS_PER_TARGET = 3


class CutMaster:
    """The restricted master of ``models.colgen._Master`` (minimising ``-sum p_k z_k``) with
    subset-row rows after its knapsacks; plans are stored by their distinct target rows."""

    def __init__(self, p: np.ndarray, targets: np.ndarray, orbits: list[OrbitItems]) -> None:
        import highspy

        self.inf = highspy.kHighsInf
        self.h = h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        self.n, self.m = n, m = len(targets), len(orbits)
        self.row_of = np.full(len(p), -1, dtype=np.int64)
        self.row_of[targets] = np.arange(n)
        e_cap = [o.rules.energy_capacity for o in orbits]
        w_cap = [o.rules.memory_capacity for o in orbits]
        upper = np.concatenate([np.zeros(n), np.ones(m), e_cap, w_cap])
        h.addRows(len(upper), np.full(len(upper), -self.inf), upper, 0, [], [], [])
        idx = np.arange(n, dtype=np.int32)
        h.addCols(n, -p[targets], np.zeros(n), np.ones(n), n, idx, idx, np.ones(n))
        self.cols: list[tuple[int, np.ndarray, np.ndarray]] = []  # (orbit, target rows, counts)
        self.keys: set[tuple[int, bytes]] = set()
        self.cuts: list[np.ndarray] = []  # target rows of each cut

    @property
    def cut0(self) -> int:
        return self.n + 3 * self.m

    def add_plan(self, g: int, covered: np.ndarray, energy: float, memory: float) -> bool:
        tg, cnt = np.unique(covered, return_counts=True)
        key = (g, tg.tobytes() + cnt.tobytes())
        if key in self.keys:
            return False
        self.keys.add(key)
        rows = self.row_of[tg]
        self.cols.append((g, rows, cnt))
        n, m = self.n, self.m
        r = [*rows.tolist(), n + g, n + m + g, n + 2 * m + g]
        v = [*(-cnt.astype(float)).tolist(), 1.0, energy, memory]
        for c, cut in enumerate(self.cuts):
            hit = int(cnt[np.isin(rows, cut)].sum())
            if hit:
                r.append(self.cut0 + c)
                v.append(-float(math.ceil(hit / 2)))
        self.h.addCol(0.0, 0.0, self.inf, len(r), np.array(r, np.int32), np.array(v))
        return True

    def add_cut(self, cut: np.ndarray) -> None:
        self.cuts.append(cut)
        r, v = cut.tolist(), [1.0] * len(cut)
        for x, (_, rows, cnt) in enumerate(self.cols):
            hit = int(cnt[np.isin(rows, cut)].sum())
            if hit:
                r.append(self.n + x)
                v.append(-float(math.ceil(hit / 2)))
        self.h.addRow(-self.inf, 1.0, len(r), np.array(r, np.int32), np.array(v))

    def solve(self) -> tuple[float, np.ndarray, np.ndarray]:
        """``(value, column values, row duals >= 0)``."""
        self.h.run()
        sol = self.h.getSolution()
        duals = np.maximum(-np.asarray(sol.row_dual, dtype=float), 0.0)
        return -self.h.getInfo().objective_function_value, np.asarray(sol.col_value), duals


def violated(master: CutMaster, x: np.ndarray) -> list[tuple[float, int, int, int]]:
    """Triples whose cut the master's solution ``x`` violates, most violated first
    (:func:`models.subset_row.violated_triples` over the master's rows)."""
    n = master.n
    z, y = x[:n], x[n : n + len(master.cols)]
    used = np.flatnonzero(y > 1e-9)
    cover = np.zeros((len(used), n))
    for r, c in enumerate(used):
        cover[r, master.cols[c][1]] = 1.0  # distinct: with h >= c the row may be less violated
    return violated_triples(cover, y[used], z)


class Pricing:
    """Each orbit's best plan at the master's duals, with the cuts priced as the module
    docstring's ``over`` variant says (exact where the observations covering a cut's targets
    are pairwise incompatible by (3))."""

    def __init__(self, master: CutMaster, orbits: list[OrbitItems], targets: np.ndarray) -> None:
        self.master, self.orbits, self.targets = master, orbits, targets
        self.by_target = [o.incidence.tocsc() for o in orbits]
        self.release_rank = []
        for o in orbits:
            rank = np.empty(o.size, dtype=np.int64)
            rank[o.by_release] = np.arange(o.size)
            self.release_rank.append(rank)
        self.seen = [set(master.row_of[o.targets].tolist()) for o in orbits]
        self.memo: dict[tuple[int, bytes], tuple[bool, np.ndarray]] = {}

    def _covering(self, g: int, cut: np.ndarray) -> tuple[bool, np.ndarray]:
        """Whether a plan of orbit ``g`` covers ``cut``'s targets with one observation at most,
        and the hits per position."""
        key = (g, cut.tobytes())
        if key not in self.memo:
            a, o = self.by_target[g], self.orbits[g]
            hits = np.zeros(o.size)
            for t in self.targets[cut]:
                if t < a.shape[1]:
                    hits[a.indices[a.indptr[t] : a.indptr[t + 1]]] += 1.0
            pos = np.flatnonzero(hits)
            follows = self.release_rank[g][pos][:, None] < o.n_before[pos][None, :]
            np.fill_diagonal(follows, False)
            self.memo[key] = (not follows.any(), hits)
        return self.memo[key]

    def exact(self, cut: np.ndarray) -> bool:
        """Every orbit prices ``cut`` exactly."""
        return all(
            len(self.seen[g].intersection(cut.tolist())) < 2 or self._covering(g, cut)[0]
            for g in range(len(self.orbits))
        )

    def split(
        self, p: np.ndarray, duals: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """The master's duals as target prices (per target of the instance), energy and
        memory penalties per unit, cut duals, and the Lagrangian value's terms outside the
        orbits (the cuts' right-hand sides, the targets' ``z`` and the knapsacks')."""
        mst, n, m = self.master, self.master.n, self.master.m
        mu = np.zeros(len(p))
        mu[self.targets] = duals[:n]
        e_cap = np.array([o.rules.energy_capacity for o in self.orbits])
        w_cap = np.array([o.rules.memory_capacity for o in self.orbits])
        pe, pw = duals[n + m : n + 2 * m], duals[n + 2 * m : n + 3 * m]
        sigma = duals[mst.cut0 :]
        z_gain = p[self.targets] - duals[:n]
        for c, cut in enumerate(mst.cuts):
            z_gain[cut] -= sigma[c]
        outside = sigma.sum() + np.maximum(z_gain, 0.0).sum() + (pe * e_cap + pw * w_cap).sum()
        return mu, pe, pw, sigma, float(outside)

    def round(self, p: np.ndarray, duals: np.ndarray) -> tuple[float, int]:
        """One pricing round: the Lagrangian value at ``duals`` (a bound when every cut is
        priced exactly) and how many plans entered the master."""
        mst, n = self.master, self.master.n
        mu, pe, pw, sigma, value = self.split(p, duals)
        added = 0
        for g, o in enumerate(self.orbits):
            price, bonus = mu.copy(), np.zeros(o.size)
            for c, cut in enumerate(mst.cuts):
                if sigma[c] <= 1e-9 or not self.seen[g].intersection(cut.tolist()):
                    continue
                alone, hits = self._covering(g, cut)
                if alone:
                    bonus += sigma[c] * np.ceil(hits / 2.0)
                else:
                    price[self.targets[cut]] += sigma[c]
            v, path = recursion(
                o.slew_s, o.duration, o.gains(price) + bonus, o.by_release, o.n_before,
                o.rules, float(pe[g]), float(pw[g]),
            )  # fmt: skip
            value += max(v, 0.0)
            if len(path) and v > duals[n + g] + 1e-6:
                covered = o.target_flat[flat_positions(o, path)]
                added += mst.add_plan(g, covered, *o.usage(path))
        return value, added


class MipPricing(Pricing):
    """Exact pricing of the cuts for the ``mip`` variant: each orbit's best plan as a small
    MIP (HiGHS), a measurement of what a pricing with a state per cut would give.

    The (3) order is an interval order: with ``rank`` each position's place in
    ``by_release``, u may precede w iff ``rank[u] < n_before[w]``, so position u is the
    interval ``[n_before[u], rank[u]]`` of the points ``0 .. size - 1``, and a plan, a set of
    pairwise disjoint intervals, is a path of one unit of flow from point 0 to point
    ``size``: observation u an arc ``n_before[u] -> rank[u] + 1``, idling an arc
    ``t -> t + 1`` (a network matrix, two nonzeros per arc; the rows "at most one interval
    holds each point" had millions). At most ``c_j`` observation arcs (6). The target duals
    are summed per observation as the recursion does; a cut's term is
    ``sigma_S w_S`` with ``2 w_S <= sum_{k in S} u_k + 1``, ``u_k <= 1`` and ``u_k <=``
    the observations covering k. The knapsacks' penalties keep their observing terms and
    drop the slew term (a penalty, so the MIP's value is never below the true best)."""

    def __init__(self, master: CutMaster, orbits: list[OrbitItems], targets: np.ndarray) -> None:
        super().__init__(master, orbits, targets)
        self.arcs = [(o.n_before, self.release_rank[g] + 1) for g, o in enumerate(orbits)]

    def round(self, p: np.ndarray, duals: np.ndarray) -> tuple[float, int]:
        import highspy

        mst, n = self.master, self.master.n
        mu, pe, pw, sigma, value = self.split(p, duals)
        added = 0
        inf = highspy.kHighsInf
        for g, o in enumerate(self.orbits):
            r = o.rules
            gain = (
                o.gains(mu) - (pe[g] * r.observe_energy_rate + pw[g] * r.memory_rate) * o.duration
            )
            h = highspy.Highs()
            h.setOptionValue("output_flag", False)
            h.setOptionValue("mip_rel_gap", 0.0)
            h.changeObjectiveSense(highspy.ObjSense.kMaximize)
            size = o.size
            h.addCols(size, gain, np.zeros(size), np.ones(size), 0, [], [], [])
            h.changeColsIntegrality(size, np.arange(size, dtype=np.int32),
                                    np.full(size, highspy.HighsVarType.kInteger))  # fmt: skip
            # flow conservation at the points 0 .. size: out - in = 1 at 0, -1 at size
            tail, head = self.arcs[g]
            h.addCols(size, np.zeros(size), np.zeros(size), np.ones(size), 0, [], [], [])
            idle = np.arange(size)
            rows = np.concatenate([tail, head, idle, idle + 1])
            cols = np.concatenate([np.arange(size), np.arange(size), size + idle, size + idle])
            vals = np.concatenate([np.ones(size), -np.ones(size), np.ones(size), -np.ones(size)])
            order = np.lexsort((cols, rows))
            rows, cols, vals = rows[order], cols[order], vals[order]
            ptr = np.searchsorted(rows, np.arange(size + 1))
            rhs = np.zeros(size + 1)
            rhs[0], rhs[size] = 1.0, -1.0
            h.addRows(size + 1, rhs, rhs, len(cols), ptr, cols.astype(np.int32), vals)
            h.addRow(-inf, float(r.max_openings), size, np.arange(size, dtype=np.int32),
                     np.ones(size))  # fmt: skip
            a = self.by_target[g]
            u_of: dict[int, int] = {}
            for c, cut in enumerate(mst.cuts):
                if sigma[c] <= 1e-9 or not self.seen[g].intersection(cut.tolist()):
                    continue
                us = []
                for k in cut.tolist():
                    t = int(self.targets[k])
                    if k not in self.seen[g] or t >= a.shape[1]:
                        continue
                    if k not in u_of:
                        u_of[k] = h.getNumCol()
                        h.addCol(0.0, 0.0, 1.0, 0, [], [])
                        cov = a.indices[a.indptr[t] : a.indptr[t + 1]]
                        h.addRow(-inf, 0.0, len(cov) + 1,
                                 np.concatenate([[u_of[k]], cov]).astype(np.int32),
                                 np.concatenate([[1.0], -np.ones(len(cov))]))  # fmt: skip
                    us.append(u_of[k])
                w = h.getNumCol()
                h.addCol(float(sigma[c]), 0.0, 2.0, 0, [], [])
                h.changeColIntegrality(w, highspy.HighsVarType.kInteger)
                h.addRow(-inf, 1.0, len(us) + 1, np.array([w, *us], dtype=np.int32),
                         np.array([2.0, *([-1.0] * len(us))]))  # fmt: skip
            h.run()
            best = max(float(h.getInfo().mip_dual_bound), 0.0)
            value += best
            x = np.asarray(h.getSolution().col_value)[:size]
            path = np.flatnonzero(x > 0.5)
            path = path[np.argsort(self.release_rank[g][path])]
            if len(path) and h.getInfo().objective_function_value > duals[n + g] + 1e-6:
                covered = o.target_flat[flat_positions(o, path)]
                added += mst.add_plan(g, covered, *o.usage(path))
        return value, added


class DpPricing(Pricing):
    """Exact pricing of every cut by the recursion with a parity bit per cut
    (:func:`models.subset_row.best_path_with_cuts`): the ``dp`` variant."""

    def __init__(self, master: CutMaster, orbits: list[OrbitItems], targets: np.ndarray) -> None:
        super().__init__(master, orbits, targets)
        self.inexact = 0
        self.pool = CutPool(orbits)  # the hits of each cut on each orbit
        self.index: dict[tuple[int, ...], int] = {}

    def _hits(self, g: int, cut: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(sorted(self.targets[cut].tolist()))
        if key not in self.index:
            self.index[key] = self.pool.add(key)
        return self.pool.orbit_hits(g, self.index[key])

    def round(self, p: np.ndarray, duals: np.ndarray) -> tuple[float, int]:
        mst, n = self.master, self.master.n
        mu, pe, pw, sigma, value = self.split(p, duals)
        added = 0
        for g, o in enumerate(self.orbits):
            live = [
                c for c, cut in enumerate(mst.cuts)
                if sigma[c] > 1e-9 and self.seen[g].intersection(cut.tolist())
            ]  # fmt: skip
            cuts = orbit_cuts(
                self.release_rank[g], o.n_before,
                [self._hits(g, mst.cuts[c]) for c in live], sigma[live],
            )  # fmt: skip
            best = best_path_with_cuts(o, o.gains(mu), cuts, float(pe[g]), float(pw[g]))
            self.inexact += not best.exact
            value += best.value
            if len(best.path) and best.value > duals[n + g] + 1e-6:
                covered = o.target_flat[flat_positions(o, best.path)]
                added += mst.add_plan(g, covered, *o.usage(best.path))
        return value, added


def run(inst: Instance, variant: str, seconds: float) -> dict[str, Any]:
    """The root, then ``variant`` (module docstring) for at most ``seconds``."""
    t0 = time.perf_counter()
    orbits = list(orbit_data(inst, None).orbits)
    seen = np.zeros(inst.n_targets, dtype=bool)
    for o in orbits:
        seen[o.targets] = True
    p = np.where(seen, np.asarray(inst.target_weight, dtype=float), 0.0)
    root = column_generation(
        p, seen, [o.rules for o in orbits], PlanPool(orbits, 1).best_paths,
        (0.5 * p, np.zeros((len(orbits), 2))), Budget(),
    )  # fmt: skip
    targets = np.flatnonzero(seen)
    master = CutMaster(p, targets, orbits)
    for g, tg, cnt, energy, memory in root.master.columns:
        master.add_plan(g, np.repeat(tg, cnt.astype(int)), energy, memory)
    kinds = {"mip": MipPricing, "dp": DpPricing}
    pricing = kinds.get(variant, Pricing)(master, orbits, targets)
    end = time.perf_counter() + seconds
    bound, value = root.best, float(root.value or 0.0)
    while time.perf_counter() < end:
        value, x, duals = master.solve()
        new, per_target = 0, np.zeros(master.n, dtype=np.int64)
        for _, i, j, k in violated(master, x):
            cut = np.array([i, j, k])
            if (per_target[cut] >= CUTS_PER_TARGET).any():
                continue
            if variant == "exact" and not pricing.exact(cut):
                continue
            per_target[cut] += 1
            master.add_cut(cut)
            new += 1
            if new >= CUTS_PER_ROUND:
                break
        if new == 0:
            break
        while variant != "fixed" and time.perf_counter() < end:
            value, x, duals = master.solve()
            lagrangian, added = pricing.round(p, duals)
            log.info(
                "master %.2f, round %.2f, %d plans added, %d cuts", value, lagrangian, added,
                len(master.cuts),
            )  # fmt: skip
            if variant in ("exact", "mip", "dp"):
                bound = min(bound, lagrangian)
            if added == 0:
                break
    value = master.solve()[0]
    return {
        "root": root.value,
        "value": value,
        "bound": bound if variant in ("exact", "mip", "dp") else None,
        "cuts": len(master.cuts),
        "columns": len(master.cols),
        "seconds": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--names",
        nargs="*",
        default=["C5", "C6", "C7", "C8", "C9", "C10"],
        choices=scenario_names(),
    )
    ap.add_argument("--instance", nargs="*", default=[], help="instance files besides")
    ap.add_argument(
        "--variants", nargs="+", default=["fixed", "over", "exact"],
        choices=["fixed", "over", "exact", "mip", "dp"],
    )  # fmt: skip
    ap.add_argument("--seconds", type=float, default=120.0, help="per variant, after the root")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(relativeCreated)8.0f ms %(message)s")
    cases = [(name, generate_scenario(name, 0)) for name in args.names]
    cases += [(path.rsplit("/", 1)[-1], load_instance(path)) for path in args.instance]
    print("| instance | variant | root master | master with cuts | certified bound | cuts | s |")
    print("|---|---|---|---|---|---|---|")
    for name, inst in cases:
        for variant in args.variants:
            r = run(inst, variant, args.seconds)
            bound = "" if r["bound"] is None else f"{math.floor(r['bound'] + 1e-6)}"
            print(
                f"| {name} | {variant} | {r['root']:.2f} | {r['value']:.2f} | {bound} | "
                f"{r['cuts']} | {r['seconds']:.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
