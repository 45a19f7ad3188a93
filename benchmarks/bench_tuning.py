"""ASA-DTC configurations on a tuning set of generated instances (not the paper's scenarios).

The defaults of ASA-DTC are chosen on this set, never on one or two named scenarios: dense
instances of 300-1,000 targets in several regions (and so several orbit geometries and
densities), with the four built-in satellites over 24 h. For each instance it computes the
suite's bound (``models.solve.bound``, method ``auto``: column generation, then the LP unless
it converged), runs each configuration for each seed at an equal time limit, and prints a
Markdown table of the mean profit and its share of the bound. The best proven bounds of the
set (branch and price, MILP) are in ``docs/exact.md``.

Example (the figures of ``docs/asa.md``, "Tuning set")::

    PYTHONPATH=. python benchmarks/bench_tuning.py --time-limit 60 --seeds 3 \\
        --configs default paper --out tuning.json

``--configs`` takes preset names or ``name:key=value,key=value`` for a parameter set of one's
own (e.g. ``mid:roll_rule=midpoint,nadir_singles=false``).
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
import time
from typing import Any

from sosp.io import atomic_write_json
from sosp.scenarios import custom_scenario
from sosp.solve import solve

log = logging.getLogger("bench_tuning")

#: name -> (region lat0, lat1, lon0, lon1; number of targets). Regions of different latitude
#: (revisit pattern), size (density) and shape; none is one of the paper's B or C regions.
TUNING_SET: dict[str, tuple[tuple[float, float, float, float], int]] = {
    "europe-400": ((40.0, 55.0, -5.0, 25.0), 400),
    "india-350": ((10.0, 30.0, 70.0, 90.0), 350),
    "japan-500": ((32.0, 42.0, 130.0, 142.0), 500),
    "andes-300": ((-35.0, -10.0, -75.0, -65.0), 300),
    "sahel-800": ((10.0, 18.0, -10.0, 30.0), 800),
    "na-1000": ((30.0, 48.0, -120.0, -75.0), 1000),
}


def parse_config(text: str) -> tuple[str, dict[str, Any]]:
    """``paper`` -> (``paper``, {preset: paper}); ``x:a=1,b=2`` -> (``x``, {a: "1", b: "2"})."""
    if ":" not in text:
        return text, ({} if text == "default" else {"preset": text})
    name, _, rest = text.partition(":")
    kv = dict(item.split("=", 1) for item in rest.split(",") if item)
    return name, kv


def run(
    names: list[str], configs: list[str], seeds: int, time_limit: float, bound_limit: float
) -> list[dict[str, Any]]:
    from models.solve import bound

    rows = []
    for name in names:
        region, count = TUNING_SET[name]
        t0 = time.perf_counter()
        inst = custom_scenario(region=region, count=count, seed=0, name=name)
        gen_s = time.perf_counter() - t0
        b = bound(inst, model="cluster", method="auto", time_limit=bound_limit)
        row: dict[str, Any] = {
            "instance": name,
            "targets": inst.n_targets,
            "opportunities": inst.n_opps,
            "generate_s": round(gen_s, 1),
            "bound": b["bound"],
            "bound_method": b.get("method"),
            "results": {},
        }
        for text in configs:
            label, params = parse_config(text)
            profits = []
            for seed in range(seeds):
                res = solve(inst, "asa-dtc", seed=seed, time_limit=time_limit, **params)
                profits.append(res.profit)
                log.info("%s %s seed %d: %g", name, label, seed, res.profit)
            row["results"][label] = profits
        rows.append(row)
        print(table([row], configs), flush=True)
    return rows


def table(rows: list[dict[str, Any]], configs: list[str]) -> str:
    labels = [parse_config(c)[0] for c in configs]
    head = "| instance | targets | opps | bound | " + " | ".join(
        f"{x} mean (% of bound)" for x in labels
    )
    lines = [head + " |", "|" + "---|" * (4 + len(labels))]
    for r in rows:
        cells = []
        for x in labels:
            p = r["results"].get(x, [])
            if p:
                m = statistics.mean(p)
                cells.append(f"{m:.1f} ({100 * m / r['bound']:.2f} %)")
            else:
                cells.append("-")
        lines.append(
            f"| {r['instance']} | {r['targets']} | {r['opportunities']} | {r['bound']:g} | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--names", nargs="*", default=list(TUNING_SET), choices=list(TUNING_SET))
    ap.add_argument("--configs", nargs="*", default=["default", "paper"])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--bound-limit", type=float, default=120.0)
    ap.add_argument("--out", help="JSON file for the raw results")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    rows = run(args.names, args.configs, args.seeds, args.time_limit, args.bound_limit)
    print("\n" + table(rows, args.configs))
    if args.out:
        atomic_write_json(args.out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
