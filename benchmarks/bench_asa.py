"""ASA-DTC benchmark: speed, profit against time, and the DTC / STC / NONTC ablation.

Usage (the defaults are the full protocol; shorten with the options)::

    PYTHONPATH=. python benchmarks/bench_asa.py --time-limit 60 --seeds 10
    PYTHONPATH=. python benchmarks/bench_asa.py --time-limit 3 --seeds 3 --curve-time 20
    PYTHONPATH=. python benchmarks/bench_asa.py --curve --names --known C1=566 --seeds 10 \
        --time-limit 10 [--param replan=false --param restart=none]

Prints Markdown tables: iterations per second, best profit at checkpoints of one long run on
B10 and C10, mean and SD over seeds with equal time limits on C3, C6, C10, B6, B10, and with
``--known NAME=VALUE`` ASA-DTC's profit per seed against a known optimum or best value.
``--param replan=false --param restart=none`` runs the paper's Algorithm 1 (two moves, no
restarts) for the before/after comparison of ``docs/asa.md``; ``--param preset=quality
--param workers=2`` the 1 % target's configuration (runs are one at a time, so each has every
core of the machine).
"""

from __future__ import annotations

import argparse
import statistics
import time

from sosp.scenarios import generate_scenario, scenario_names
from sosp.solve import solve

METHODS = ("asa-dtc", "asa-stc", "asa-nontc")


def profit_at(trace: list[list[float]], t: float) -> float:
    """Best profit reached by time t (trace columns: iteration or step, time_s, best, ...)."""
    best = trace[0][2]
    for row in trace:
        if row[1] <= t:
            best = row[2]
    return best


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--time-limit", type=float, default=60.0, help="seconds per ablation run")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0..n-1 per ablation cell")
    ap.add_argument(
        "--names", nargs="*", default=["C3", "C6", "C10", "B6", "B10"], choices=scenario_names()
    )
    ap.add_argument("--curve", nargs="*", default=["B10", "C10"], help="profit-vs-time runs")
    ap.add_argument("--curve-time", type=float, default=60.0)
    ap.add_argument("--scenario-seed", type=int, default=0, help="seed of the target draw")
    ap.add_argument("--param", action="append", default=[], help="key=value for every run")
    ap.add_argument(
        "--methods",
        nargs="+",
        default=list(METHODS),
        choices=METHODS,
        help="variants of the curve and ablation runs (to re-run one column)",
    )
    ap.add_argument(
        "--known", nargs="*", default=[], help="NAME=VALUE: ASA-DTC per seed against VALUE"
    )
    args = ap.parse_args(argv)
    extra = dict(p.split("=", 1) for p in args.param)

    print(f"# ASA benchmark ({time.strftime('%Y-%m-%d %H:%M')})\n")
    for item in args.known:
        name, value = item.split("=", 1)
        known = float(value)
        inst = generate_scenario(name, args.scenario_seed)
        runs = [
            solve(inst, "asa-dtc", seed=s, time_limit=args.time_limit, **extra)
            for s in range(args.seeds)
        ]
        profits = ", ".join(f"{r.profit:g}" for r in runs)
        hits = sum(r.profit >= known - 1e-9 for r in runs)
        rate = statistics.fmean(r.stats["iterations_per_s"] for r in runs)
        print(f"## {name}: ASA-DTC per seed, {args.time_limit:g} s, against {known:g}\n")
        mean = statistics.fmean(r.profit for r in runs)
        within = sum(r.profit >= 0.99 * known - 1e-9 for r in runs)
        print(f"profits {profits}; at or above {known:g}: {hits} of {len(runs)}; {rate:.0f} it/s")
        print(
            f"mean {mean:.2f}, {100 * (known - mean) / known:.2f} % below {known:g}; "
            f"within 1 %: {within} of {len(runs)}\n"
        )
    print("## Profit against time (seed 0; best profit at t seconds)\n")
    marks = [t for t in (1, 2, 5, 10, 20, 30, 60, 120) if t <= args.curve_time]
    print("| scenario | method | it/s | " + " | ".join(f"{t} s" for t in marks) + " |")
    print("|---|---|---|" + "---|" * len(marks))
    for name in args.curve:
        inst = generate_scenario(name, args.scenario_seed)
        for method in args.methods:
            res = solve(inst, method, seed=0, time_limit=args.curve_time, **extra)
            cells = [f"{profit_at(res.stats['trace'], t):g}" for t in marks]
            print(
                f"| {name} | {method} | {res.stats['iterations_per_s']:.0f} | "
                + " | ".join(cells)
                + " |",
                flush=True,
            )

    print(f"\n## Ablation: mean (SD) over seeds 0..{args.seeds - 1}, {args.time_limit:g} s each\n")
    full = tuple(args.methods) == METHODS
    order_head = " order DTC>=STC>=NONTC |" if full else ""
    print("| scenario | " + " | ".join(args.methods) + " |" + order_head)
    print("|---|" + "---|" * (len(args.methods) + full))
    for name in args.names:
        inst = generate_scenario(name, args.scenario_seed)
        means = []
        cells = []
        for method in args.methods:
            vals = [
                solve(inst, method, seed=s, time_limit=args.time_limit, **extra).profit
                for s in range(args.seeds)
            ]
            m = statistics.fmean(vals)
            sd = statistics.stdev(vals) if len(vals) > 1 else 0.0
            means.append(m)
            cells.append(f"{m:.1f} ({sd:.1f})")
        order = (" yes |" if means[0] >= means[1] >= means[2] else " no |") if full else ""
        print(f"| {name} | " + " | ".join(cells) + " |" + order, flush=True)


if __name__ == "__main__":
    main()
