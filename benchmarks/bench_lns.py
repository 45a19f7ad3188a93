"""Best known schedules and gaps: milp-lns and ASA-DTC against the cluster model's LP bound.

Usage::

    PYTHONPATH=. python benchmarks/bench_lns.py --names B10 C10 --time-limit 60
    PYTHONPATH=. python benchmarks/bench_lns.py --names B5 B10 --time-limit 300 --no-lp

For each scenario (target draw seed 0): the LP bound of the cluster model (interior point,
with its time; ``--lp-time-limit``), ASA-DTC's profit at the limit, and milp-lns's profit at
checkpoints of one run of the same limit (it starts from ASA-DTC); then the gaps of both to
the bound and of ASA-DTC to the best known profit. Prints one Markdown table.
"""

from __future__ import annotations

import argparse
import time

from benchmarks.bench_asa import profit_at
from models.solve import bound
from sosp.scenarios import generate_scenario, scenario_names
from sosp.solve import solve


def _pct(a: float | None, b: float | None) -> str:
    if a is None or b is None or b == 0:
        return ""
    return f"{100 * (a - b) / b:.1f}%"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--names", nargs="+", default=["B10", "C10"], choices=scenario_names())
    ap.add_argument("--time-limit", type=float, default=60.0, help="seconds per heuristic run")
    ap.add_argument("--lp-time-limit", type=float, default=300.0)
    ap.add_argument("--no-lp", action="store_true", help="skip the LP bound")
    ap.add_argument("--seed", type=int, default=1, help="seed of the heuristic runs")
    ap.add_argument("--scenario-seed", type=int, default=0)
    ap.add_argument("--orbits", type=int, default=None, help="milp-lns orbits per step")
    args = ap.parse_args(argv)
    marks = [t for t in (10, 30, 60, 120, 300, 600) if t < args.time_limit] + [args.time_limit]

    print(f"# milp-lns benchmark ({time.strftime('%Y-%m-%d %H:%M')})\n")
    head = ["scenario", "LP bound (s)", "asa-dtc"] + [f"lns {t:g} s" for t in marks]
    head += ["lns steps", "asa-dtc below best", "LP over best"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name in args.names:
        inst = generate_scenario(name, args.scenario_seed)
        lp = None
        lp_cell = "not run"
        if not args.no_lp:
            out = bound(inst, model="cluster", method="lp", time_limit=args.lp_time_limit)
            lp = out["bound"]
            lp_cell = (
                f"{lp:g} ({out['runtime_s']:.0f} s)"
                if lp is not None
                else f"none in {args.lp_time_limit:g} s"
            )
        asa = solve(inst, "asa-dtc", seed=args.seed, time_limit=args.time_limit)
        extra = {} if args.orbits is None else {"orbits": args.orbits}
        lns = solve(inst, "milp-lns", seed=args.seed, time_limit=args.time_limit, **extra)
        best = max(lns.profit, asa.profit)
        cells = [name, lp_cell, f"{asa.profit:g}"]
        cells += [f"{profit_at(lns.stats['trace'], t):g}" for t in marks]
        cells += [
            f"{lns.iterations} ({lns.stats['mean_items']:.0f} items)",
            f"{100 * (best - asa.profit) / best:.1f}%" if best else "",
            _pct(lp, best),
        ]
        print("| " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
