"""Bounds against the best schedules: LP and Lagrangian bounds, orbit-dp, milp-lns from it.

Usage::

    PYTHONPATH=. python benchmarks/bench_orbit_dp.py --names B10 C10 --time-limit 60
    PYTHONPATH=. python benchmarks/bench_orbit_dp.py --names C1 C5 --seeds 1 2 3 --no-lp

For each scenario (target draw ``--scenario-seed``): the cluster model's LP bound (interior
point, relaxed slew term on large models; with its time) and Lagrangian bound (``sosp bound
--method lagrangian``; with its time), then per seed ``orbit-dp``'s best profit at checkpoints
of one run of ``--time-limit`` seconds (candidate generation included) and, with ``--lns``,
``milp-lns`` started from ``orbit-dp`` (half the limit each). Last, the gaps of the bounds to
the best profit found. Prints one Markdown table.
"""

from __future__ import annotations

import argparse
import time

from benchmarks.bench_asa import profit_at
from benchmarks.bench_lns import _pct
from models.lagrangian import lagrangian_bound
from models.solve import bound
from sosp.scenarios import generate_scenario, scenario_names
from sosp.solve import solve


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--names", nargs="+", default=["B10", "C10"], choices=scenario_names())
    ap.add_argument("--time-limit", type=float, default=60.0, help="seconds per orbit-dp run")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--scenario-seed", type=int, default=0)
    ap.add_argument("--lp-time-limit", type=float, default=300.0)
    ap.add_argument("--no-lp", action="store_true", help="skip the LP bound")
    ap.add_argument("--lns", action="store_true", help="also milp-lns started from orbit-dp")
    ap.add_argument("--param", action="append", default=[], help="orbit-dp key=value")
    args = ap.parse_args(argv)
    params = {k: float(v) if "." in v else int(v) for k, v in (p.split("=", 1) for p in args.param)}
    marks = [t for t in (5, 10, 30) if t < args.time_limit] + [args.time_limit]

    print(f"# orbit-dp and bounds ({time.strftime('%Y-%m-%d %H:%M')}), params {params}\n")
    head = ["scenario", "LP bound (s)", "Lagrangian bound (s)", "seed"]
    head += [f"orbit-dp {t:g} s" for t in marks] + ["steps"]
    head += ["milp-lns from it"] if args.lns else []
    head += ["LP over best", "Lagrangian over best"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name in args.names:
        inst = generate_scenario(name, args.scenario_seed)
        lp, lp_cell = None, "not run"
        if not args.no_lp:
            out = bound(inst, model="cluster", method="lp", time_limit=args.lp_time_limit)
            lp = out["bound"]
            lp_cell = "none" if lp is None else f"{lp:g} ({out['runtime_s']:.0f})"
        rows, best = [], 0.0
        for seed in args.seeds:
            res = solve(inst, "orbit-dp", seed=seed, time_limit=args.time_limit, **params)
            cells = [f"{profit_at(res.stats['trace'], t):g}" for t in marks]
            cells.append(str(res.iterations))
            best = max(best, res.profit)
            if args.lns:
                lns = solve(
                    inst,
                    "milp-lns",
                    seed=seed,
                    time_limit=args.time_limit,
                    start="orbit-dp",
                    start_time_limit=args.time_limit / 2,
                )
                cells.append(f"{lns.profit:g}")
                best = max(best, lns.profit)
            rows.append((seed, cells))
        lag = lagrangian_bound(inst, lower_bound=best)
        lag_cell = f"{lag['bound']:g} ({lag['runtime_s']:.0f})"
        for i, (seed, cells) in enumerate(rows):
            first = [name, lp_cell, lag_cell] if i == 0 else ["", "", ""]
            last = [_pct(lp, best), _pct(lag["bound"], best)] if i == 0 else ["", ""]
            print("| " + " | ".join([*first, str(seed), *cells, *last]) + " |", flush=True)


if __name__ == "__main__":
    main()
