"""The window sweep of ``sosp.windows``: numba kernel against a vectorised numpy sweep.

Usage::

    PYTHONPATH=. python benchmarks/bench_windows.py --instance d100.json.gz --starts 600

On the densest orbit of the instance, G(i, k) of the first ``--starts`` priced first
opportunities (prices: the targets' weights) by both sweeps; checks that they agree and
prints the seconds of each. The numpy sweep handles one first opportunity at a time as a
matrix (window opportunities in end order x candidate rolls: the running sum over the rows
and its maximum per row), O(m^2) per start against the kernel's O(m log m).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sosp.instance import load_instance
from sosp.rules import EPS
from sosp.windows import OrbitOpps, orbit_opps, window_items


def numpy_sweep(oo: OrbitOpps, w: np.ndarray, starts: np.ndarray) -> list[tuple]:
    """``(first, last, gain)`` rows as :func:`sosp.windows._sweep` keeps them."""
    ts, te, lo, hi = oo.start, oo.end, oo.roll_min, oo.roll_max
    limit = oo.rules.max_duration
    rows = []
    for i in starts:
        a0 = np.searchsorted(ts, ts[i], side="left")
        a1 = np.searchsorted(ts, ts[i] + limit + EPS, side="right")
        j = np.arange(a0, a1)
        a = np.maximum(lo[j], lo[i])
        b = np.minimum(hi[j], hi[i])
        ok = (w[j] > 0) & (te[j] <= ts[i] + limit + EPS) & (a <= b + EPS)
        j, a, b = j[ok], a[ok], np.maximum(b[ok], a[ok])
        order = np.argsort(te[j], kind="stable")
        j, a, b = j[order], a[order], b[order]
        hold = (a[None, :] >= a[:, None] - EPS) & (a[None, :] <= b[:, None] + EPS)
        g = np.cumsum(hold * w[j][:, None], axis=0).max(axis=1)
        last_of_end = np.append(te[j][1:] != te[j][:-1], True)
        best = 0.0
        for s in np.flatnonzero(last_of_end & (te[j] >= te[i])):
            if g[s] > best:
                best = g[s]
                rows.append((int(i), int(j[s]), float(g[s])))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--instance", required=True)
    ap.add_argument("--starts", type=int, default=600)
    args = ap.parse_args()
    inst = load_instance(args.instance)
    j = int(np.argmax(np.diff(inst.orbit_offsets)))
    full = orbit_opps(inst, j)
    price = np.asarray(inst.target_weight, dtype=float)
    w = price[full.target]
    # the first ``starts`` priced opportunities, and every opportunity their windows reach
    starts = np.flatnonzero(w > 0)[: args.starts]
    reach = int(
        np.searchsorted(full.start, full.start[starts[-1]] + full.rules.max_duration, "right")
    )
    oo = OrbitOpps(
        j,
        full.first,
        full.start[:reach],
        full.end[:reach],
        full.roll_min[:reach],
        full.roll_max[:reach],
        full.target[:reach],
        full.rules,
    )
    window_items(oo, price)  # compile (or load the cached machine code)
    t = time.perf_counter()
    wi = window_items(oo, price)
    t_numba = time.perf_counter() - t
    t = time.perf_counter()
    rows = numpy_sweep(oo, price[oo.target], starts)
    t_numpy = time.perf_counter() - t
    keep = np.isin(wi.first, starts)
    cols = (wi.first[keep].tolist(), wi.last[keep].tolist(), wi.gain[keep].tolist())
    got = list(zip(*cols, strict=True))
    same = len(got) == len(rows) and all(
        x[:2] == y[:2] and abs(x[2] - y[2]) < 1e-6 for x, y in zip(got, rows, strict=True)
    )
    # the kernel swept every start up to ``reach``: scale its time to the same starts
    n_priced = int(np.count_nonzero(price[oo.target] > 0))
    per_start = t_numba / max(n_priced, 1)
    print(
        f"orbit {inst.orbit_ids[j]} ({full.size} opportunities), {len(starts)} starts: "
        f"numba {per_start * len(starts):.3f} s, numpy {t_numpy:.3f} s, "
        f"ratio {t_numpy / (per_start * len(starts)):.1f}, rows agree: {same}"
    )


if __name__ == "__main__":
    main()
