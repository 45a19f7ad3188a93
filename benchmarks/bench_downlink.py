"""Observation and downlink together: a method's delivered profit against the certified bound,
on generated families with ground stations (issue 60).

Families (``--family``):

* ``paper``: the paper's B and C scenarios (``--names``), each with one of the station sets
  below in turn (2-3 stations: near the targets, polar, spread over the globe);
* ``regions``: random boxes (seeded) of 300-3,000 targets seen by the paper's four
  satellites, station sets in turn;
* ``walker``: a 24-satellite Walker constellation (600 km, 6 planes) over 10,000 targets
  between 60 S and 70 N, with five stations, 24 h.

Each instance is solved by ``--method`` (asa-dtc: its defaults) within ``--limit`` seconds,
then bounded by ``--bound`` within ``--bound-limit`` (the bound of the station-free
relaxation, ``docs/model.md``). Printed: delivered profit, bound, profit / bound, what the
decomposition dropped (search profit against delivered), latency and wall time.

    python benchmarks/bench_downlink.py --family paper --names B1 B5 B10 C1 C5 C10 --limit 60
    python benchmarks/bench_downlink.py --family regions --seeds 1 2 3 4 --limit 60
    python benchmarks/bench_downlink.py --family walker --limit 300 --bound-limit 240
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sosp.scenarios import DEFAULT_START, custom_scenario, generate_scenario
from sosp.solve import solve
from sosp.stations import builtin_stations
from sosp.validate import validate

#: Station sets, by built-in id: near the paper's regions, polar, spread over the globe.
STATION_SETS = {
    "asia": ("MIY", "KSH", "SYA"),
    "polar": ("SG", "TRL"),
    "spread": ("KIR", "HBK", "SAN"),
}


def stations(ids: tuple[str, ...]):
    by_id = {s.id: s for s in builtin_stations()}
    return [by_id[i] for i in ids]


def instances(args: argparse.Namespace):
    """(label, instance) of the family, station sets in turn."""
    sets = list(STATION_SETS.items())
    if args.family == "paper":
        for n, name in enumerate(args.names):
            key, ids = sets[n % len(sets)]
            yield f"{name}+{key}", generate_scenario(name, 0).with_stations(stations(ids))
    elif args.family == "regions":
        for n, seed in enumerate(args.seeds):
            rng = np.random.default_rng(seed)
            count = int(rng.integers(300, 3001))
            lat0, lon0 = rng.uniform(-50, 40), rng.uniform(-180, 150)
            box = (lat0, lat0 + rng.uniform(10, 30), lon0, lon0 + rng.uniform(10, 30))
            key, ids = sets[n % len(sets)]
            inst = custom_scenario(region=box, count=count, seed=seed, name=f"r{seed}")
            yield f"r{seed} ({count} targets)+{key}", inst.with_stations(stations(ids))
    else:
        from sosp.orbits import walker_delta

        sats = walker_delta(24, 6, 1, 600.0, epoch=DEFAULT_START)
        inst = custom_scenario(
            region=(-60.0, 70.0, -180.0, 180.0), count=10_000, seed=1, satellites=sats, name="w24"
        )
        yield (
            "walker 24 sats, 10,000 targets+5",
            inst.with_stations(stations(("SG", "TRL", "HBK", "SAN", "MIY"))),
        )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", choices=("paper", "regions", "walker"), default="paper")
    ap.add_argument("--names", nargs="+", default=["B1", "B5", "B10", "C1", "C5", "C10"])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--method", default="asa-dtc")
    ap.add_argument("--limit", type=float, default=60.0, help="the method's time limit (s)")
    ap.add_argument("--bound", default="auto")
    ap.add_argument("--bound-limit", type=float, default=60.0)
    args = ap.parse_args()
    print(
        "| instance | opportunities | delivered profit | bound | profit/bound | search profit "
        "| latency mean / max (min) | method s | bound s |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    worst = 1.0
    for label, inst in instances(args):
        t0 = time.perf_counter()
        res = solve(inst, args.method, seed=0, time_limit=args.limit)
        t_method = time.perf_counter() - t0
        t0 = time.perf_counter()
        from sosp.registry import compute_bound

        b = compute_bound(args.bound, inst, time_limit=args.bound_limit, lower_bound=res.profit)[
            "bound"
        ]
        t_bound = time.perf_counter() - t0
        rep = validate(inst, res.schedule)
        assert rep.feasible and abs(rep.profit - res.profit) < 1e-6, label
        lat = rep.downlink["latency_s"]
        ratio = res.profit / b if b else 1.0
        worst = min(worst, ratio)
        print(
            f"| {label} | {inst.n_opps} | {res.profit:g} | {b:g} | {100 * ratio:.2f} % | "
            f"{res.stats.get('search_profit', res.profit):g} | "
            f"{(lat['mean'] or 0) / 60:.1f} / {(lat['max'] or 0) / 60:.1f} | {t_method:.1f} | "
            f"{t_bound:.1f} |",
            flush=True,
        )
    print(f"\nworst profit/bound: {100 * worst:.2f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
