"""Benchmark of sosp's SPOT5 solvers on the 21 instances, beside the published values.

For each instance and method: the value found, the proven bound, the gap, wall and CPU time
(``time.process_time``; the machine is shared, so CPU time is the fairer figure for RDS
against its 1996 times). ``milp`` starts from a short tabu search (``sosp.spot5_cli.solve``),
``rds`` runs on the single-orbit instances only (ids below 1000) unless named, ``lp`` is the
clique LP bound (every maximal clique). Numba kernels are compiled before any timing. One JSON
object per line goes to ``--output``; a Markdown table to stdout.

    python benchmarks/bench_spot5.py --methods milp rds lp --time-limit 60
    python benchmarks/bench_spot5.py --names 1401 1403 --methods milp --time-limit 200
"""

from __future__ import annotations

import argparse
import json
import sys

from heuristics.spot5 import solve_spot5_rds, solve_spot5_tabu
from models.spot5 import spot5_bound
from sosp.spot5 import PUBLISHED, instance_path, load_spot5, validate_spot5
from sosp.spot5_cli import solve


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--names", nargs="*", default=list(PUBLISHED))
    ap.add_argument("--methods", nargs="*", default=["milp", "rds", "tabu", "lp"])
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--capacity", choices=("units", "raw"), default="units")
    ap.add_argument("--output", help="JSON lines file")
    args = ap.parse_args(argv)
    warm = load_spot5(instance_path("8"))
    solve_spot5_rds(warm), solve_spot5_tabu(warm, 0.01)  # compile the numba kernels
    out = open(args.output, "a") if args.output else None  # noqa: SIM115
    print("| instance | published | method | value | bound | gap % | wall s | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.names:
        problem = load_spot5(instance_path(name), args.capacity)
        pub, proven = PUBLISHED[name]
        for method in args.methods:
            if method == "rds" and int(name) >= 1000 and len(args.names) > 1:
                continue
            if method == "lp":
                b = spot5_bound(problem, args.time_limit)
                row = {"value": None, "bound": b["bound"], "gap": None,
                       "time_s": b["time_s"], "cpu_s": None, "status": b["status"]}  # fmt: skip
            else:
                r = solve(problem, method, args.time_limit)
                assert validate_spot5(problem, r.assignment).feasible, (name, method)
                row = {"value": r.value, "bound": r.bound, "gap": r.gap, "time_s": r.time_s,
                       "cpu_s": r.cpu_s, "status": r.status, "stats": r.stats}  # fmt: skip
            row |= {"instance": name, "published": pub, "method": method}
            if out:
                out.write(json.dumps(row, default=str) + "\n")
                out.flush()
            gap = "" if row["gap"] is None else f"{100 * row['gap']:.3f}"
            cpu = "" if row["cpu_s"] is None else f"{row['cpu_s']:.2f}"
            print(
                f"| {name} | {pub:,}{'*' if proven else ''} | {method} | "
                f"{'' if row['value'] is None else format(row['value'], ',')} | "
                f"{'' if row['bound'] is None else format(row['bound'], ',')} | {gap} | "
                f"{row['time_s']:.2f} | {cpu} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
