"""Re-planning after urgent targets: the repair against a from-scratch ASA-DTC solve.

Usage::

    PYTHONPATH=. python benchmarks/bench_replan.py                  # C10, R2k, R10k
    PYTHONPATH=. python benchmarks/bench_replan.py --families C10 --scratch 20

Families (24 h horizon, the four built-in satellites, Table 1 resources, seed 0):

* ``C10``: the paper's scenario C10 (``sosp scenario C10``) plus 30 urgent targets;
* ``R2k``, ``R10k``: 2,000 and 10,000 random targets in the region lat 0..60, lon 60..140
  (``sosp scenario r10k --region 0 60 60 140 --targets 10000``) plus 300 urgent targets.

Urgent targets are drawn uniformly in the family's region with weight 10 (the paper's
largest) and arrive at mid-horizon: ``now`` = 12 h, a freeze (uplink lead time) of 600 s.
The old plan is one ASA-DTC run of ``--old`` seconds on the family without them. Then, on
the same new problem (frozen part kept, :func:`sosp.replanning.restricted` for the search):

* ``repair``: :func:`sosp.replan` with ``method="repair"`` and a 30 s limit (profit first);
* ``repair --stability 1``: the same, each unchanged observation worth one weight unit;
* ``scratch``: ``method="asa-dtc"`` for ``--scratch`` seconds, not started from the old plan.

Each row gives time, expected profit (here the profit: no cloud), changes from the old plan
(removed + added + moved observations) and the urgent targets observed. Prints a Markdown
table (and writes it with ``--out``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from sosp import solve
from sosp.events import Events, NewTarget
from sosp.replanning import replan
from sosp.scenarios import custom_scenario, generate_scenario

REGION_R = (0.0, 60.0, 60.0, 140.0)
FAMILIES = {
    "C10": ("C10", None, (30.0, 60.0, 90.0, 120.0), 30),
    "R2k": ("r2k", 2000, REGION_R, 300),
    "R10k": ("r10k", 10000, REGION_R, 300),
}
NOW, FREEZE = 12 * 3600.0, 600.0


def family(name: str) -> tuple[object, Events]:
    scen, count, region, urgent = FAMILIES[name]
    if count is None:
        inst = generate_scenario(scen)
    else:
        inst = custom_scenario(region=region, count=count, name=scen)
    rng = np.random.default_rng([7, len(name)])
    lat = rng.uniform(region[0], region[1], urgent)
    lon = rng.uniform(region[2], region[3], urgent)
    new = tuple(NewTarget(f"U{i + 1:03d}", float(a), float(b), 10) for i, (a, b) in enumerate(
        zip(lat, lon, strict=True)))  # fmt: skip
    return inst, Events(new_targets=new)


def urgent_observed(r: object) -> int:
    inst = r.instance  # type: ignore[attr-defined]
    got = {inst.target_ids[int(inst.opp_target[i])] for i in r.schedule.observed_opps()}
    return sum(1 for t in got if t.startswith("U"))


def run(name: str, old_s: float, scratch_s: float) -> list[dict[str, object]]:
    inst, events = family(name)
    old = solve(inst, "asa-dtc", seed=0, time_limit=old_s).schedule
    rows = []
    for label, kw in (
        ("repair", {"method": "repair", "time_limit": 30.0}),
        ("repair --stability 1", {"method": "repair", "time_limit": 30.0, "stability": 1.0}),
        (f"scratch asa-dtc {scratch_s:g} s", {"method": "asa-dtc", "time_limit": scratch_s,
                                             "warm_start": False}),
    ):  # fmt: skip
        t = time.perf_counter()
        r = replan(inst, old, events, now=NOW, freeze=FREEZE, seed=0, **kw)
        c = r.counts()
        rows.append({
            "family": f"{name} + {len(events.new_targets)} urgent", "method": label,
            "time_s": time.perf_counter() - t, "profit": r.profit, "bound": r.bound,
            "changes": sum(c.values()), "detail": f"{c['removed']}/{c['added']}/{c['moved']}",
            "urgent": urgent_observed(r), "old_profit": old.coverage_profit(inst)[0],
        })  # fmt: skip
        print(rows[-1], flush=True)
    return rows


def table(rows: list[dict[str, object]]) -> str:
    lines = [
        "| family | method | time (s) | profit | % of scratch | changes (rem/add/mov) "
        "| urgent observed | old plan's profit | bound |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for i in range(0, len(rows), 3):
        scratch = float(rows[i + 2]["profit"])  # type: ignore[arg-type]
        for r in rows[i : i + 3]:
            pct = 100.0 * float(r["profit"]) / scratch  # type: ignore[arg-type]
            lines.append(
                f"| {r['family']} | {r['method']} | {r['time_s']:.2f} | {r['profit']:.0f} | "
                f"{pct:.1f} | {r['changes']} ({r['detail']}) | {r['urgent']} | "
                f"{r['old_profit']:.0f} | {r['bound']:.0f} |"
            )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--families", nargs="+", default=list(FAMILIES), choices=list(FAMILIES))
    ap.add_argument("--old", type=float, default=60.0, help="seconds of the old plan's solve")
    ap.add_argument("--scratch", type=float, default=60.0, help="seconds of the scratch solve")
    ap.add_argument("--out", help="write the table (Markdown) here")
    args = ap.parse_args()
    rows = [r for name in args.families for r in run(name, args.old, args.scratch)]
    text = table(rows)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
