"""Same seed, same schedule: a fingerprint of every method's iteration-limited schedule.

A refactoring that does not change an algorithm must leave every schedule as it was. This
script solves a fixed set of instances (the paper's B1, C1, C6, B10 and a generated dense
400-target region) with every registered method, limited by iterations rather than time
(so the result does not depend on the machine's speed), and prints each schedule's profit,
its number of observations and a short hash of its observations. ``--save FILE`` writes the
table as JSON; ``--check FILE`` compares against such a file and exits 1 on any difference.

    python benchmarks/bench_same_seed.py --save before.json      # at the old commit
    python benchmarks/bench_same_seed.py --check before.json     # at the new one

Methods with no iteration limit (greedy, HPFS, RDS, PBA, the MILP) are run where they end
well within ``TIME_LIMIT_S`` on their own, so their result is not cut by the clock.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time

from sosp.scenarios import custom_scenario, generate_scenario
from sosp.solve import solve

#: Iteration limits that keep each run to a few seconds on the 2-core machine.
LIMITED = {
    "asa-dtc": {"iterations": 3000},
    "asa-stc": {"iterations": 3000},
    "asa-nontc": {"iterations": 3000},
    "sa-stc": {"iterations": 5000},
    "aco-stc": {"iterations": 5},
    "aco-ls-stc": {"iterations": 3},
    "ga-stc": {"iterations": 20},
    "ts-stc": {"iterations": 2000},
    "milp-lns": {"iterations": 20},
    "orbit-dp": {"iterations": 300},
}
#: Methods that end by themselves, and the instances on which they do so quickly.
UNLIMITED = {
    "greedy": None,
    "hpfs-stc": None,
    "pba-stc": ("B1", "C1"),
    "rds": ("B1",),
    "rds-stc": ("B1",),
    "milp": ("B1", "C1"),
}
#: A safety net for the unlimited methods (never reached on the instances above).
TIME_LIMIT_S = 120.0


def instances() -> dict:
    out = {name: generate_scenario(name, seed=1) for name in ("B1", "C1", "C6", "B10")}
    out["dense400"] = custom_scenario(region=(30.0, 40.0, 100.0, 112.0), count=400, seed=1)
    return out


def fingerprint(result) -> str:
    rows = [(o.orbit, round(o.start, 6), round(o.end, 6), round(o.roll, 6), o.opps)
            for o in result.schedule.observations]  # fmt: skip
    return hashlib.sha256(repr(sorted(rows)).encode()).hexdigest()[:12]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--save")
    ap.add_argument("--check")
    ap.add_argument("--methods", help="comma-separated subset")
    args = ap.parse_args(argv)
    wanted = set(args.methods.split(",")) if args.methods else None
    table: dict[str, dict] = {}
    for iname, inst in instances().items():
        for method in [*LIMITED, *UNLIMITED]:
            if wanted and method not in wanted:
                continue
            if method in UNLIMITED and UNLIMITED[method] and iname not in UNLIMITED[method]:
                continue
            params = LIMITED.get(method, {})
            limit = None if method in LIMITED else TIME_LIMIT_S
            t0 = time.perf_counter()
            res = solve(inst, method, seed=1, time_limit=limit, **params)
            seconds = round(time.perf_counter() - t0, 2)
            row = {"profit": res.profit, "observed": len(res.schedule.observations),
                   "hash": fingerprint(res), "seconds": seconds}  # fmt: skip
            table[f"{iname}/{method}"] = row
            print(f"{iname:9s} {method:11s} {row['profit']:9.1f} {row['observed']:5d} "
                  f"{row['hash']} {row['seconds']:7.2f} s", flush=True)  # fmt: skip
    if args.save:
        with open(args.save, "w") as f:
            json.dump(table, f, indent=1)
    if args.check:
        with open(args.check) as f:
            old = json.load(f)
        diff = [k for k in table if k in old and (old[k]["hash"], old[k]["profit"])
                != (table[k]["hash"], table[k]["profit"])]  # fmt: skip
        for k in diff:
            print(f"DIFFERENT {k}: {old[k]} -> {table[k]}")
        print(f"{len(table) - len(diff)} same, {len(diff)} different")
        return 1 if diff else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
