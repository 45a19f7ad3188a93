"""Benchmark of the exact models on the paper's scenarios B1..B10 and C1..C10 (seed 0).

For each scenario: model size, build time and the MILP outcome (optimal, or incumbent, bound
and gap at the time limit) of the task and cluster models, and the cluster model's LP bound
with its time (at the same limit). ``--heuristics`` runs heuristics first (same limit) for the
best known profit; the cluster MILP starts from the best schedule found so far. One JSON object
per line goes to ``--output``; a Markdown table to stdout.

    python benchmarks/bench_exact.py --time-limit 300 --output exact.jsonl
    python benchmarks/bench_exact.py --time-limit 30 --names B1 C1 B10 C10 --backend highs
    python benchmarks/bench_exact.py --time-limit 60 --heuristics greedy hpfs-stc asa-dtc

``--proofs`` compares formulations of the cluster model for proving its optimum instead: per
scenario and per ``--slews`` form (``exact``: the exact slew term of (4) on every
energy-binding orbit; ``lazy``: the relaxed row, the exact term added only on orbits whose
solution breaks (4)), one ``solve_milp`` with its defaults (warm start from an orbit search,
Lagrangian bound first, direct backend) and the result: optimal with its time, or best / bound
and the gap at the limit.

    python benchmarks/bench_exact.py --proofs --time-limit 120 --names B7 B8 --slews exact lazy

``--branch-and-price`` runs the branch and price alone (``colgen_bound(..., branch=True)``,
the bound beside ``milp``'s MILP) per scenario, stopping at the best schedule known
(:data:`BEST_KNOWN`), with ``--cuts`` choosing its cut families (``orbit``: subset-row
triples and the cuts over two targets and one orbit's convexity row, the default;
``triples``: the triples alone; ``none``); the gap is to the best schedule known::

    python benchmarks/bench_exact.py --branch-and-price --time-limit 600 --names C5 C7
    python benchmarks/bench_exact.py --branch-and-price --time-limit 600 --cuts triples \
        --names C5 C7
    python benchmarks/bench_exact.py --branch-and-price --time-limit 300 --strong 0 5 10 \
        --names C7 C8

``--strong`` sets the strong branching's candidates (``models.colgen.STRONG_CANDIDATES``),
``--workers`` the processes (2: the two children of each branching side by side; run such
a row alone on a 2-core machine)::

    python benchmarks/bench_exact.py --branch-and-price --time-limit 300 --workers 1 2 \
        --names C7 C8

Besides the paper's names, ``--names`` takes the generated dense instances of :data:`GENERATED`
(300-500 targets in regions that are none of the paper's; target draw seed ``--seed``), e.g.
the proofs of ``docs/exact.md``'s table of generated instances::

    python benchmarks/bench_exact.py --proofs --time-limit 600 --slews lazy --names \\
        europe-400 india-350 japan-500 andes-300 iberia-450 mekong-400
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from typing import Any

from models.solve import bound, solve_milp
from sosp.instance import Instance
from sosp.scenarios import custom_scenario, generate_scenario, scenario_names
from sosp.solve import solve

log = logging.getLogger("bench_exact")

NAMES = scenario_names()

#: Generated dense instances (name -> region lat0, lat1, lon0, lon1; targets), with the four
#: built-in satellites over 24 h: the first four are ASA-DTC's tuning set
#: (``benchmarks/bench_tuning.py``), the last four are used nowhere else (the last two were
#: added, regions chosen before any run, when branch and price joined the MILP).
GENERATED: dict[str, tuple[tuple[float, float, float, float], int]] = {
    "europe-400": ((40.0, 55.0, -5.0, 25.0), 400),
    "india-350": ((10.0, 30.0, 70.0, 90.0), 350),
    "japan-500": ((32.0, 42.0, 130.0, 142.0), 500),
    "andes-300": ((-35.0, -10.0, -75.0, -65.0), 300),
    "iberia-450": ((36.0, 44.0, -10.0, 4.0), 450),
    "mekong-400": ((10.0, 22.0, 98.0, 110.0), 400),
    "anatolia-400": ((37.0, 42.0, 27.0, 44.0), 400),
    "plains-450": ((34.0, 46.0, -104.0, -90.0), 450),
}


#: The best schedules known for the C scenarios the MILP does not prove (target seed 0),
#: each validated (``docs/exact.md``, *The C scenarios at 10 minutes*, *The MILP's core
#: given to a longer search instead* and, for C9's 3480, *Orbit cuts*): the branch and
#: price's ``lower_bound`` and the reference of its gap.
BEST_KNOWN: dict[str, float] = {
    "C5": 2202.0,
    "C6": 2583.0,
    "C7": 2854.0,
    "C8": 3166.0,
    "C9": 3480.0,
    "C10": 3864.0,
}


def run_branch_and_price(
    name: str,
    seed: int,
    time_limit: float,
    cuts: str,
    strong: int | None = None,
    workers: int = 1,
) -> dict[str, Any]:
    """One ``colgen_bound(..., branch=True)`` run with the cut families ``cuts``, ``strong``
    strong-branching candidates (None: the default) and ``workers`` processes."""
    import models.colgen as colgen
    import models.subset_row as subset_row
    from models.colgen import colgen_bound

    if strong is not None:
        colgen.STRONG_CANDIDATES = strong

    inst = scenario(name, seed)
    best = BEST_KNOWN.get(name) if seed == 0 else None
    subset_row.ORBIT_CUTS = cuts == "orbit"
    t0 = time.perf_counter()
    out = colgen_bound(
        inst,
        branch=True,
        time_limit=time_limit,
        lower_bound=best,
        cut_rounds=0 if cuts == "none" else None,
        workers=workers,
    )
    runtime = time.perf_counter() - t0
    gap = None if best is None else (out["bound"] - best) / best
    return {
        "name": name,
        "seed": seed,
        "cuts": cuts,
        "strong": colgen.STRONG_CANDIDATES,
        "workers": workers,
        "time_limit": time_limit,
        "bound": out["bound"],
        "best_known": best,
        "gap": gap,
        "nodes": out.get("nodes"),
        "runtime_s": round(runtime, 2),
    }


def scenario(name: str, seed: int) -> Instance:
    """A paper scenario by name, or one of :data:`GENERATED`."""
    if name in GENERATED:
        region, count = GENERATED[name]
        return custom_scenario(region=region, count=count, seed=seed, name=name)
    return generate_scenario(name, seed)


def run(
    name: str,
    seed: int,
    time_limit: float,
    models: list[str],
    threads: int | None,
    backend: str = "auto",
    heuristics: tuple[str, ...] = (),
) -> dict[str, Any]:
    """Benchmark one scenario; returns a JSON-ready record."""
    t0 = time.perf_counter()
    inst = scenario(name, seed)
    rec: dict[str, Any] = {
        "name": name,
        "seed": seed,
        "targets": inst.n_targets,
        "opportunities": inst.n_opps,
        "scenario_s": round(time.perf_counter() - t0, 3),
        "time_limit": time_limit,
        "backend": backend,
    }
    start, start_profit = None, -1.0
    found: list[float] = []
    for method in heuristics:
        hres = solve(inst, method, seed=seed, time_limit=time_limit)
        rec[method] = {"profit": hres.profit, "runtime_s": round(hres.runtime_s, 3)}
        found.append(hres.profit)
        log.info("%s %s: %s", name, method, rec[method])
        if hres.profit > start_profit:
            start, start_profit = hres.schedule, hres.profit
    for model in models:
        # later models start from the best schedule so far (task schedules map onto candidates;
        # a clustered one is ignored by the task model with a warning)
        res = solve_milp(
            inst,
            model=model,
            time_limit=time_limit,
            threads=threads,
            warm_start=start,
            backend=backend,
        )
        found.append(res.profit)
        if len(res.schedule) and res.profit > start_profit:
            start, start_profit = res.schedule, res.profit
        s = res.stats
        rec[model] = {
            "status": res.status.value,
            "profit": res.profit,
            "bound": res.bound,
            "gap": res.gap,
            "runtime_s": round(res.runtime_s, 3),
            **{k: s.get(k) for k in ("candidates", "cliques", "variables", "constraints")},
            **{k: s.get(k) for k in ("nonzeros", "build_s", "load_s", "solve_s")},
            **{k: s.get(k) for k in ("backend", "warm_start")},
        }
        log.info("%s %s: %s", name, model, rec[model])
    lp = bound(
        inst,
        model="cluster",
        method="lp",
        threads=threads,
        time_limit=time_limit,
        backend=backend,
    )
    rec["lp_cluster"] = {
        "bound": lp["bound"],
        "value": lp.get("lp_value"),
        "runtime_s": lp["runtime_s"],
        **{k: lp.get(k) for k in ("variables", "constraints", "nonzeros", "termination")},
    }
    log.info("%s LP: %s", name, rec["lp_cluster"])
    best = max(found) if found else 0.0
    rec["best_known"] = best
    if lp["bound"] and best:
        rec["lp_over_best"] = round(lp["bound"] / best - 1.0, 4)
    return rec


def run_proof(
    name: str, seed: int, time_limit: float, slew: str, threads: int | None
) -> dict[str, Any]:
    """One proof attempt on the cluster model (direct backend) with the ``slew`` form."""
    inst = scenario(name, seed)
    res = solve_milp(
        inst, model="cluster", time_limit=time_limit, threads=threads, backend="highs", slew=slew
    )
    s = res.stats
    return {
        "name": name,
        "seed": seed,
        "slew": slew,
        "time_limit": time_limit,
        "threads": threads,
        "status": res.status.value,
        "profit": res.profit,
        "bound": res.bound,
        "gap": res.gap,
        "runtime_s": round(res.runtime_s, 2),
        **{
            k: s.get(k)
            for k in (
                "candidates",
                "variables",
                "constraints",
                "start_profit",
                "extra_bound",
                "side_bound",
                "side_yielded_s",
                "gave_way_s",
                "search_on_profit",
                "raw_bound",
                "start_from",
                "start_s",
                "extra_bound_s",
                "lazy_rounds",
                "lazy_exact_orbits",
                "proven_by",
                "mip_node_count",
            )
        },
    }


def _report(output: str | None, rec: dict[str, Any], row: str) -> None:
    """Append ``rec`` to the JSON lines file ``output`` (None: none) and print its row."""
    if output:
        with open(output, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(rec) + "\n")
    sys.stdout.write(row + "\n")
    sys.stdout.flush()


def _branch_and_price_row(rec: dict[str, Any]) -> str:
    """One table row of :func:`run_branch_and_price`'s record."""
    gap = "" if rec["gap"] is None else f"{100 * rec['gap']:.2f}%"
    cells = [rec["name"], rec["cuts"], str(rec.get("strong", "")), str(rec.get("workers", 1))]
    cells += [f"{rec['bound']:g}"]
    cells += [f"{rec['best_known'] or ''}", gap]
    cells += [str(rec["nodes"]), f"{rec['runtime_s']:.0f}"]
    return "| " + " | ".join(cells) + " |"


def _proof_row(rec: dict[str, Any]) -> str:
    if rec["status"] == "optimal":
        result = f"**optimal {rec['profit']:g}**"
    else:
        result = f"{rec['profit']:g} / {rec['bound']:g}"
    gap = "0" if rec["gap"] in (None, 0) else f"{100 * rec['gap']:.2f}%"
    rounds = rec.get("lazy_rounds") or ""
    cells = [
        rec["name"],
        rec["slew"],
        result,
        gap,
        f"{rec['runtime_s']:.0f}",
        f"{rec.get('start_profit') or 0:g}",
        f"{rec.get('extra_bound') or '':}",
        f"{rec.get('variables') or ''}/{rec.get('constraints') or ''}",
        str(rounds),
    ]
    return "| " + " | ".join(cells) + " |"


def _row(rec: dict[str, Any], models: list[str], heuristics: list[str]) -> str:
    cells = [rec["name"], str(rec["opportunities"])]
    cells += [f"{rec[h]['profit']:g} ({rec[h]['runtime_s']:.0f}s)" for h in heuristics]
    for m in models:
        r = rec[m]
        gap = "" if r["gap"] is None else f"{100 * r['gap']:.1f}%"
        cells += [
            f"{r['candidates']}/{r['variables']}/{r['constraints']}/{r['nonzeros']}",
            f"{r['build_s'] or 0:.1f}+{r['load_s'] or 0:.1f}",
            f"{r['status']} {r['profit']:g}/{r['bound']} {gap} {r['runtime_s']:.0f}s",
        ]
    lp = rec["lp_cluster"]
    over = rec.get("lp_over_best")
    cells += [
        f"{lp['bound']} ({lp['runtime_s']:.0f}s)",
        f"{rec['best_known']:g}",
        "" if over is None else f"{100 * over:.1f}%",
    ]
    return "| " + " | ".join(cells) + " |"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--names", nargs="*", default=NAMES, choices=[*scenario_names(), *GENERATED])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--time-limit", type=float, default=300.0, help="per MILP solve, seconds")
    p.add_argument("--models", nargs="*", default=["task", "cluster"])
    p.add_argument(
        "--threads", type=int, default=None, help="HiGHS threads (default: HiGHS's, as the CLI)"
    )
    p.add_argument("--backend", default="auto", choices=("auto", "pyomo", "highs"))
    p.add_argument(
        "--heuristics", nargs="*", default=[], help="methods run first for the best known profit"
    )
    p.add_argument("--output", default=None, help="JSON lines file (appended)")
    p.add_argument("--proofs", action="store_true", help="compare formulations (--slews)")
    p.add_argument("--slews", nargs="*", default=["exact", "lazy"], help="with --proofs")
    p.add_argument(
        "--branch-and-price", action="store_true", help="the branch and price alone (--cuts)"
    )
    p.add_argument(
        "--cuts", nargs="*", default=["orbit"], choices=("orbit", "triples", "none"),
        help="with --branch-and-price: cut families",
    )  # fmt: skip
    p.add_argument(
        "--strong", nargs="*", type=int, default=[None],
        help="with --branch-and-price: strong-branching candidates (default: the library's)",
    )  # fmt: skip
    p.add_argument(
        "--workers", nargs="*", type=int, default=[1],
        help="with --branch-and-price: processes (2: two children at a time)",
    )  # fmt: skip
    args = p.parse_args(argv)
    if any(w < 1 for w in args.workers):
        p.error(f"--workers: expected positive process counts, got {args.workers}")
    if any(s is not None and s < 0 for s in args.strong):
        p.error(f"--strong: expected non-negative candidate counts, got {args.strong}")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    if args.branch_and_price:
        head = ["scenario", "cuts", "strong", "workers", "bound", "best known", "gap", "nodes"]
        head += ["time s"]
        sys.stdout.write("| " + " | ".join(head) + " |\n|" + "---|" * len(head) + "\n")
        for name in args.names:
            for cuts in args.cuts:
                for strong in args.strong:
                    for workers in args.workers:
                        rec = run_branch_and_price(
                            name, args.seed, args.time_limit, cuts, strong, workers
                        )
                        _report(args.output, rec, _branch_and_price_row(rec))
        return 0
    if args.proofs:
        head = ["scenario", "slew", "result", "gap", "time s", "start", "extra bound"]
        head += ["cols/rows", "rounds"]
        sys.stdout.write("| " + " | ".join(head) + " |\n|" + "---|" * len(head) + "\n")
        for name in args.names:
            for slew in args.slews:
                rec = run_proof(name, args.seed, args.time_limit, slew, args.threads)
                _report(args.output, rec, _proof_row(rec))
        return 0
    head = ["scenario", "opps", *args.heuristics]
    for m in args.models:
        head += [f"{m} items/vars/rows/nnz", f"{m} build+load s", f"{m} result"]
    head += ["LP bound (cluster)", "best known", "LP over best"]
    sys.stdout.write("| " + " | ".join(head) + " |\n")
    sys.stdout.write("|" + "---|" * len(head) + "\n")
    for name in args.names:
        rec = run(
            name,
            args.seed,
            args.time_limit,
            args.models,
            args.threads,
            args.backend,
            tuple(args.heuristics),
        )
        _report(args.output, rec, _row(rec, args.models, args.heuristics))
    return 0


if __name__ == "__main__":
    sys.exit(main())
