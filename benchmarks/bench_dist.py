"""Pricing rounds in one process, in forked processes and on a Dask cluster.

Usage::

    PYTHONPATH=. python benchmarks/bench_dist.py d100.json.gz --band 0.5 --workers 2
    PYTHONPATH=. python benchmarks/bench_dist.py g100k.npz --band 1 --workers 2 --rounds 2
    PYTHONPATH=. python benchmarks/bench_dist.py d100.json.gz --dask tcp://scheduler:8786

One round is what every pricing round of ``sosp bound``'s window relaxation does
(:class:`sosp.planner.PlanPool` over :func:`models.window_bound._relaxed_plans` at roll bands
of ``--band`` degrees): plan every orbit at one price vector. The prices of each round are
the targets' weights scaled by a random factor in [0.3, 1] (seed 0), so no round repeats
one before it. Per configuration, the pool is built (for Dask: the cluster started and the
orbits sent) and then ``--rounds`` rounds are timed; the first round includes the workers'
loading of the numba kernels from their cache.

Also printed: the bytes sent once (the orbits, pickled) and per round (the prices), and the
longest single orbit's planning time, under which no number of workers can bring a round
(the orbits are planned whole).

The speed-up is against the one-process rounds (without ``here``: the orbit-by-orbit round).

Configurations: ``here`` (one process), ``fork`` (``--workers`` forked processes), ``dask``
(a ``LocalCluster`` of ``--workers`` single-threaded processes on this machine, or the
cluster at ``--dask``).
"""

from __future__ import annotations

import argparse
import logging
import pickle
import time
from functools import partial

import numpy as np

from models.window_bound import _observable, _relaxed_plans
from sosp.instance import load_instance
from sosp.parallel import cluster_size, dask_client
from sosp.planner import PlanPool
from sosp.windows import orbit_opps


def _rounds(pool: PlanPool, prices: list[np.ndarray], lam: np.ndarray) -> list[float]:
    out = []
    for mu in prices:
        t = time.perf_counter()
        assert pool.best_paths(mu, lam) is not None
        out.append(time.perf_counter() - t)
    return out


def _row(name: str, setup_s: float, times: list[float], serial: float) -> str:
    later = times[1:] or times
    mean = sum(later) / len(later)
    speed = f"{serial / mean:.2f}"
    rounds = ", ".join(f"{t:.2f}" for t in times)
    return f"| {name} | {setup_s:.2f} | {rounds} | {mean:.2f} | {speed} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("instance")
    ap.add_argument("--band", type=float, default=0.5, help="roll band, degrees (0: none)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dask", default="local", help="'local' or a scheduler address")
    ap.add_argument("--only", default="here,fork,dask", help="configurations to run")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    logging.getLogger("distributed").setLevel(logging.WARNING)  # its own INFO lines
    only = set(args.only.split(","))

    inst = load_instance(args.instance)
    orbits = [orbit_opps(inst, j) for j in range(inst.n_orbits)]
    _, p = _observable(inst)
    lam = np.zeros((len(orbits), 2))
    plans_of = partial(_relaxed_plans, band=args.band or None)
    busy = [g for g in range(len(orbits)) if orbits[g].size]
    plans_of(orbits, [min(busy, key=lambda g: orbits[g].size)], p, lam)  # compile or load
    rng = np.random.default_rng(0)
    prices = [p * rng.uniform(0.3, 1.0, len(p)) for _ in range(args.rounds)]

    # the longest orbit: the floor of a round on any number of workers
    per_orbit = []
    for g in busy:
        t = time.perf_counter()
        plans_of(orbits, [g], prices[0], lam)
        per_orbit.append(time.perf_counter() - t)
    serial = sum(per_orbit)
    print(
        f"{inst.n_orbits} orbits ({len(busy)} with opportunities), {inst.n_opps} "
        f"opportunities, band {args.band} deg\n"
        f"sent once: {len(pickle.dumps(orbits)) / 1e6:.1f} MB of orbits; per round: "
        f"{p.nbytes / 1e6:.2f} MB of prices\n"
        f"one round in one process (orbit by orbit): {serial:.2f} s; longest orbit "
        f"{max(per_orbit):.2f} s (a round's floor: {serial / max(per_orbit):.0f} times "
        f"faster at most)\n"
    )
    print("| configuration | setup s | rounds s | mean of rounds 2+ s | speed-up |")
    print("|---|---|---|---|---|")
    base = serial  # replaced by the pool's own rounds where "here" runs
    if "here" in only:
        t = time.perf_counter()
        with PlanPool(orbits, 1, plans_of) as pool:
            setup = time.perf_counter() - t
            times = _rounds(pool, prices, lam)
        print(_row("one process", setup, times, serial), flush=True)
        later = times[1:] or times
        base = sum(later) / len(later)
    if "fork" in only:
        t = time.perf_counter()
        with PlanPool(orbits, args.workers, plans_of) as pool:
            setup = time.perf_counter() - t
            times = _rounds(pool, prices, lam)
        print(_row(f"fork, {args.workers} processes", setup, times, base), flush=True)
    if "dask" in only:
        t = time.perf_counter()
        with dask_client(args.dask, args.workers) as client:
            up = time.perf_counter() - t
            with PlanPool(orbits, client, plans_of) as pool:
                setup = time.perf_counter() - t
                times = _rounds(pool, prices, lam)
            size = cluster_size(client)
        name = f"dask {args.dask}, {size} threads (cluster up in {up:.2f} s)"
        print(_row(name, setup, times, base), flush=True)


if __name__ == "__main__":
    main()
