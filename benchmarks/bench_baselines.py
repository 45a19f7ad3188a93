"""Benchmark the paper's baselines on the reference scenarios B1..B10 and C1..C10.

For each scenario: RDS-STC (and optionally RDS) time to proof or timeout with its bound,
HPFS-STC profit, and SA-STC mean and standard deviation over several seeds at a fixed time
limit. Writes a Markdown table (stdout, and ``--out`` if given) and optionally JSON.

Example (modest settings for a shared 2-core machine)::

    python -m benchmarks.bench_baselines --rds-limit 60 --sa-limit 10 --seeds 10

With ``--compare`` it runs instead the named methods side by side at one equal time limit
over several seeds (mean, standard deviation, best, iterations), e.g. the population
baselines of issue 18 against ASA-STC and SA-STC::

    python -m benchmarks.bench_baselines --compare aco-stc aco-ls-stc ga-stc asa-stc sa-stc \
        --scenarios B1 B5 C1 C5 --limit 10 --seeds 3

With ``--proofs`` it compares instead the exact methods: RDS-STC and RDS (time to proof or
timeout, profit, bound) next to the optimum of the MILP static and task models
(``models.solve``, HiGHS), which they must equal wherever both finish::

    python -m benchmarks.bench_baselines --proofs --scenarios B1 B2 C1 C2 --rds-limit 300
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
import time
from typing import Any

from sosp.io import atomic_write_json, atomic_write_text
from sosp.scenarios import generate_scenario, scenario_names
from sosp.solve import solve

log = logging.getLogger("bench_baselines")


def bench_scenario(
    name: str,
    *,
    scenario_seed: int,
    rds_limit: float,
    sa_limit: float,
    sa_iterations: int,
    seeds: int,
    with_rds_single: bool,
) -> dict[str, Any]:
    """Run the baselines on one scenario; returns one row of figures."""
    inst = generate_scenario(name, scenario_seed)
    row: dict[str, Any] = {
        "scenario": name,
        "targets_observable": inst.observable_targets,
        "opportunities": inst.n_opps,
    }
    methods = ["rds-stc"] + (["rds"] if with_rds_single else [])
    for m in methods:
        t = time.perf_counter()
        res = solve(inst, m, time_limit=rds_limit)
        row[m] = {
            "status": res.status.value,
            "profit": res.profit,
            "bound": res.bound,
            "seconds": round(time.perf_counter() - t, 3),
            "components": res.stats["components"],
            "largest_component": res.stats["largest_component"],
        }
    res = solve(inst, "hpfs-stc")
    row["hpfs-stc"] = {"profit": res.profit, "seconds": round(res.runtime_s, 3)}
    profits, iters = [], []
    for s in range(seeds):
        res = solve(inst, "sa-stc", seed=s, time_limit=sa_limit, iterations=sa_iterations)
        profits.append(res.profit)
        iters.append(res.iterations or 0)
    row["sa-stc"] = {
        "mean": statistics.fmean(profits),
        "sd": statistics.stdev(profits) if len(profits) > 1 else 0.0,
        "best": max(profits),
        "mean_iterations": statistics.fmean(iters),
    }
    log.info("%s done", name)
    return row


def bench_proofs(
    name: str, *, scenario_seed: int, rds_limit: float, milp_limit: float
) -> dict[str, Any]:
    """RDS-STC and RDS against the MILP static and task models on one scenario."""
    inst = generate_scenario(name, scenario_seed)
    row: dict[str, Any] = {"scenario": name, "opportunities": inst.n_opps}
    runs = [
        ("rds-stc", "rds-stc", {"time_limit": rds_limit}),
        ("milp-static", "milp", {"time_limit": milp_limit, "model": "static"}),
        ("rds", "rds", {"time_limit": rds_limit}),
        ("milp-task", "milp", {"time_limit": milp_limit, "model": "task"}),
    ]
    for key, method, params in runs:
        t = time.perf_counter()
        res = solve(inst, method, **params)
        row[key] = {
            "status": res.status.value,
            "profit": res.profit,
            "bound": res.bound,
            "seconds": round(time.perf_counter() - t, 3),
        }
        if method != "milp":
            row[key]["largest_component"] = res.stats["largest_component"]
            row[key]["nodes"] = res.stats["nodes"]
        log.info("%s %s: %s", name, key, row[key])
    return row


def bench_compare(
    name: str, *, scenario_seed: int, methods: list[str], limit: float, seeds: int
) -> dict[str, Any]:
    """Each method on one scenario at the same time limit, seeds 0..seeds-1."""
    from sosp.methods import method_info

    inst = generate_scenario(name, scenario_seed)
    row: dict[str, Any] = {"scenario": name, "opportunities": inst.n_opps}
    for m in methods:
        # no iteration limit: every method stops at the time limit (or ends on its own)
        extra = {"iterations": 10**9} if "iterations" in method_info(m).keys() else {}
        profits, iters = [], []
        for s in range(seeds):
            res = solve(inst, m, seed=s, time_limit=limit, **extra)
            profits.append(res.profit)
            iters.append(res.iterations or 0)
        row[m] = {
            "profits": profits,
            "mean": statistics.fmean(profits),
            "sd": statistics.stdev(profits) if len(profits) > 1 else 0.0,
            "best": max(profits),
            "mean_iterations": statistics.fmean(iters),
        }
        log.info("%s %s: mean %.1f over %d seeds", name, m, row[m]["mean"], seeds)
    return row


def markdown_compare(rows: list[dict[str, Any]], methods: list[str]) -> str:
    """The ``--compare`` figures: per method mean, SD, best and mean iterations."""
    head = "| SN | TN |" + "".join(f" {m} mean | SD | best | iter. |" for m in methods)
    sep = "|---|---|" + "---|---|---|---|" * len(methods)
    lines = [head, sep]
    for r in rows:
        cells = [r["scenario"], str(r["opportunities"])]
        for m in methods:
            x = r[m]
            cells += [
                f"{x['mean']:.1f}",
                f"{x['sd']:.1f}",
                f"{x['best']:g}",
                f"{x['mean_iterations']:.0f}",
            ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def markdown_proofs(rows: list[dict[str, Any]]) -> str:
    """The ``--proofs`` figures as a Markdown table."""
    lines = [
        "| SN | TN | RDS-STC status | R | bound | time (s) | largest comp. | nodes "
        "| MILP static | time (s) | RDS status | R | bound | time (s) | largest comp. | nodes "
        "| MILP task | time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        cells = [r["scenario"], str(r["opportunities"])]
        for rds, milp in (("rds-stc", "milp-static"), ("rds", "milp-task")):
            x, y = r[rds], r[milp]
            cells += [
                x["status"],
                f"{x['profit']:g}",
                f"{x['bound']:g}",
                f"{x['seconds']:.2f}",
                str(x["largest_component"]),
                str(x["nodes"]),
                f"{y['profit']:g}" + ("" if y["status"] == "optimal" else f" ({y['status']})"),
                f"{y['seconds']:.2f}",
            ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def markdown(rows: list[dict[str, Any]], with_rds_single: bool) -> str:
    """The figures as a Markdown table."""
    head = "| SN | EN | TN | RDS-STC status | R | bound | time (s) | comps (largest) |"
    sep = "|---|---|---|---|---|---|---|---|"
    if with_rds_single:
        head += " RDS status | R | time (s) |"
        sep += "---|---|---|"
    head += " HPFS-STC | SA-STC mean | SD | best | iterations |"
    sep += "---|---|---|---|---|"
    lines = [head, sep]
    for r in rows:
        x = r["rds-stc"]
        cells = [
            r["scenario"],
            str(r["targets_observable"]),
            str(r["opportunities"]),
            x["status"],
            f"{x['profit']:g}",
            f"{x['bound']:g}",
            f"{x['seconds']:.2f}",
            f"{x['components']} ({x['largest_component']})",
        ]
        if with_rds_single:
            y = r["rds"]
            cells += [y["status"], f"{y['profit']:g}", f"{y['seconds']:.2f}"]
        sa = r["sa-stc"]
        cells += [
            f"{r['hpfs-stc']['profit']:g}",
            f"{sa['mean']:.1f}",
            f"{sa['sd']:.2f}",
            f"{sa['best']:g}",
            f"{sa['mean_iterations']:.0f}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--scenarios",
        nargs="*",
        default=None,
        choices=scenario_names(),
        help="default: B1..B10 C1..C10",
    )
    p.add_argument("--scenario-seed", type=int, default=0)
    p.add_argument("--rds-limit", type=float, default=60.0, help="RDS seconds per scenario")
    p.add_argument("--sa-limit", type=float, default=10.0, help="SA seconds per run")
    p.add_argument("--sa-iterations", type=int, default=10**9, help="SA moves per run")
    p.add_argument("--seeds", type=int, default=10, help="SA runs (seeds 0..n-1)")
    p.add_argument("--rds-single", action="store_true", help="also run RDS without clustering")
    p.add_argument(
        "--proofs", action="store_true", help="RDS-STC and RDS against the MILP optima instead"
    )
    p.add_argument("--milp-limit", type=float, default=300.0, help="MILP seconds (--proofs)")
    p.add_argument(
        "--compare", nargs="+", metavar="METHOD", help="these methods side by side instead"
    )
    p.add_argument("--limit", type=float, default=10.0, help="seconds per run (--compare)")
    p.add_argument("--out", help="write the Markdown table here")
    p.add_argument("--json", help="write the raw rows here")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    names = args.scenarios or scenario_names()
    if args.compare:
        rows = [
            bench_compare(
                n,
                scenario_seed=args.scenario_seed,
                methods=args.compare,
                limit=args.limit,
                seeds=args.seeds,
            )
            for n in names
        ]
        return _emit(markdown_compare(rows, args.compare), rows, args)
    if args.proofs:
        rows = [
            bench_proofs(
                n,
                scenario_seed=args.scenario_seed,
                rds_limit=args.rds_limit,
                milp_limit=args.milp_limit,
            )
            for n in names
        ]
        return _emit(markdown_proofs(rows), rows, args)
    rows = [
        bench_scenario(
            n,
            scenario_seed=args.scenario_seed,
            rds_limit=args.rds_limit,
            sa_limit=args.sa_limit,
            sa_iterations=args.sa_iterations,
            seeds=args.seeds,
            with_rds_single=args.rds_single,
        )
        for n in names
    ]
    return _emit(markdown(rows, args.rds_single), rows, args)


def _emit(table: str, rows: list[dict[str, Any]], args: argparse.Namespace) -> int:
    """Print the table; write it (``--out``) and the raw rows (``--json``) atomically."""
    sys.stdout.write(table)
    if args.out:
        atomic_write_text(args.out, table)
    if args.json:
        atomic_write_json(args.json, {"args": vars(args), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
