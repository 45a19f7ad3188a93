"""How fast are contact windows? Walker constellations of several sizes and altitudes
against the built-in ground stations over 24 h (``sosp.stations.contact_windows``).

Each case is timed best of ``--repeat`` runs, in this process, after one warm-up.

    python benchmarks/bench_contacts.py --sizes 6/3/1 12/3/1 24/4/1 48/6/1 --altitudes 500 800
"""

from __future__ import annotations

import argparse
import time

from sosp.orbits import walker_delta
from sosp.stations import builtin_stations, contact_windows

EPOCH = "2026-06-01T00:00:00Z"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["6/3/1", "12/3/1", "24/4/1", "48/6/1"])
    ap.add_argument("--altitudes", type=float, nargs="+", default=[500.0, 800.0])
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    stations = builtin_stations()
    print("| constellation | altitude (km) | stations | windows | time (s) |")
    print("|---|---|---|---|---|")
    for size in args.sizes:
        for alt in args.altitudes:
            sats = walker_delta(*map(int, size.split("/")), alt, epoch=EPOCH)
            horizon = (EPOCH, 0.0, 3600.0 * args.hours)
            contact_windows(sats, stations, *horizon)  # warm-up
            best = float("inf")
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                n = len(contact_windows(sats, stations, *horizon))
                best = min(best, time.perf_counter() - t0)
            print(f"| {size} | {alt:g} | {len(stations)} | {n} | {best:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
