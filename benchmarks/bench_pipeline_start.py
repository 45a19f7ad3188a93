"""Does the pipeline give each stage what it needs? ``milp`` at a limit of T against its start
stage alone at T/2, on generated dense instances.

``milp``'s default start is the pipeline's ``orbit-dp`` stage (at most half the limit,
``sosp.pipeline.START_SHARE``); the better of the start and the MILP's incumbent is kept. So
``milp`` at T should never return less than ``orbit-dp`` with the start stage's parameters at
T/2. Each instance is a dense box (``--targets`` over ``--region``, the paper's four
satellites), one per seed; the runs are in this process, one at a time.

    python benchmarks/bench_pipeline_start.py --seeds 1 2 3 4 5 --limit 30
"""

from __future__ import annotations

import argparse

from sosp.registry import method_start
from sosp.scenarios import custom_scenario
from sosp.solve import solve


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--targets", type=int, default=400)
    ap.add_argument("--region", type=float, nargs=4, default=[30, 40, 100, 112])
    ap.add_argument("--limit", type=float, default=30.0, help="milp's --time-limit (s)")
    args = ap.parse_args()
    print(f"| seed | start stage, {args.limit / 2:g} s | milp {args.limit:g} s | milp >= start |")
    print("|---|---|---|---|")
    below = 0
    for seed in args.seeds:
        inst = custom_scenario(region=tuple(args.region), count=args.targets, seed=seed)
        start = method_start("milp", inst, {})
        alone = solve(inst, start.method, seed=0, time_limit=args.limit / 2, **start.params)
        milp = solve(inst, "milp", seed=0, time_limit=args.limit)
        ok = milp.profit >= alone.profit - 1e-6
        below += not ok
        print(
            f"| {seed} | {alone.profit:g} | {milp.profit:g} ({milp.status.value}, "
            f"{milp.runtime_s:.1f} s) | {'yes' if ok else 'NO'} |"
        )
    return 1 if below else 0


if __name__ == "__main__":
    raise SystemExit(main())
