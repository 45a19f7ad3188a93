"""Dense and large instances: scenario generation, schedules, a bound, the gap, peak memory.

Usage::

    PYTHONPATH=. python benchmarks/bench_scale.py --runs d30 --time-limit 300
    PYTHONPATH=. python benchmarks/bench_scale.py --runs d100 --time-limit 600 --workers 2
    PYTHONPATH=. python benchmarks/bench_scale.py --runs g100k --steps generate

Runs (all with the scenario seed 0, a 24 h horizon, the paper's resources):

* ``d30``: 3,000 random targets in the C region (lat 30..60, lon 90..120), the four built-in
  satellites (``sosp scenario d30 --region 30 60 90 120 --targets 3000``);
* ``d100``: the same with 10,000 targets;
* ``g100k``: 100,000 targets worldwide (lat -60..70) seen by a 48-satellite Walker-delta
  constellation 48/8/1 at 550 km, sun-synchronous (``--walker 48/8/1 --altitude 550``).

Each step runs in a fresh process (``spawn``) that reports its own wall time and peak
resident memory (``resource.getrusage``), so the figures are those of one ``sosp`` command:

* ``generate``: the scenario, written as ``.json.gz`` (peak bytes per opportunity);
* ``orbit-dp``, ``asa-dtc``, ``hpfs-stc``: one run of ``--time-limit`` seconds each (seed 0;
  candidate generation included), the schedule checked by the validator (on G100k ASA-DTC
  refuses: its conflict lists would exceed ``heuristics.asa.problem.MAX_CONFLICTS``);
* ``bound``: the Lagrangian bound (``sosp bound --method lagrangian``) with ``--time-limit``
  and at most ``--bound-iterations`` steps, its Polyak target the best profit found.

Prints a Markdown table with the gap ``(bound - best) / bound``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import resource
import time
from pathlib import Path
from typing import Any

RUNS: dict[str, dict[str, Any]] = {
    "d30": {"region": (30.0, 60.0, 90.0, 120.0), "count": 3000},
    "d100": {"region": (30.0, 60.0, 90.0, 120.0), "count": 10000},
    "g100k": {"region": (-60.0, 70.0, -180.0, 180.0), "count": 100000, "walker": (48, 8, 1, 550)},
}

STEPS = ("generate", "orbit-dp", "asa-dtc", "hpfs-stc", "bound")


#: The steps that solve (each checked by the validator).
SOLVERS = ("orbit-dp", "asa-dtc", "hpfs-stc")


def _peak_mb() -> float:
    """Peak resident memory of this process, MB (Linux reports kilobytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _generate(name: str, path: str) -> dict[str, Any]:
    import numpy as np

    from sosp.orbits import walker_delta
    from sosp.scenarios import DEFAULT_START, custom_scenario, random_targets

    spec = RUNS[name]
    sats = None
    if "walker" in spec:
        t, p, f, alt = spec["walker"]
        sats = walker_delta(t, p, f, float(alt), epoch=DEFAULT_START)
    t0 = time.perf_counter()
    # the targets of ``sosp scenario NAME --region ... --targets N --seed 0``
    targets = random_targets(spec["count"], spec["region"], np.random.default_rng(0))
    inst = custom_scenario(targets=targets, seed=0, satellites=sats, name=name)
    t_gen = time.perf_counter() - t0
    inst.save(path)
    return {
        "seconds": round(time.perf_counter() - t0, 2),
        "generate_s": round(t_gen, 2),
        "opps": inst.n_opps,
        "orbits": inst.n_orbits,
        "max_orbit_opps": int(max(inst.orbit_offsets[1:] - inst.orbit_offsets[:-1])),
        "file_mb": round(os.path.getsize(path) / 2**20, 1),
    }


def _solve(path: str, method: str, time_limit: float, workers: int) -> dict[str, Any]:
    from sosp.instance import load_instance
    from sosp.solve import solve
    from sosp.validate import validate

    inst = load_instance(path)
    params: dict[str, Any] = {}
    if workers > 1 and method == "orbit-dp":
        params["workers"] = workers
    t0 = time.perf_counter()
    res = solve(inst, method, seed=0, time_limit=time_limit, **params)
    seconds = time.perf_counter() - t0
    report = validate(inst, res.schedule)
    return {
        "seconds": round(seconds, 1),
        "profit": float(res.profit),
        "valid": bool(report.feasible),
        "iterations": res.iterations,
    }


def _bound(
    path: str, time_limit: float, lower: float | None, workers: int, iterations: int
) -> dict[str, Any]:
    from models.lagrangian import lagrangian_bound
    from sosp.instance import load_instance

    inst = load_instance(path)
    t0 = time.perf_counter()
    kwargs: dict[str, Any] = {
        "time_limit": time_limit,
        "lower_bound": lower,
        "iterations": iterations,
    }
    if workers > 1:
        kwargs["workers"] = workers
    out = lagrangian_bound(inst, **kwargs)
    return {
        "seconds": round(time.perf_counter() - t0, 1),
        "bound": out["bound"],
        "iterations": out["iterations"],
        "candidates": out["candidates"],
    }


def _child(conn: Any, fn: str, args: tuple[Any, ...]) -> None:
    try:
        out = {"generate": _generate, "solve": _solve, "bound": _bound}[fn](*args)
        out["peak_mb"] = round(_peak_mb(), 0)
    except Exception as exc:  # reported in the table, not fatal to the other steps
        out = {"error": f"{type(exc).__name__}: {exc}"[:200], "peak_mb": round(_peak_mb(), 0)}
    conn.send(out)
    conn.close()


def in_process(fn: str, *args: Any) -> dict[str, Any]:
    """Run one step in a fresh process and return what it reports."""
    ctx = mp.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(child, fn, args))
    proc.start()
    out = parent.recv()
    proc.join()
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", nargs="+", default=["d30"], choices=sorted(RUNS))
    ap.add_argument("--steps", nargs="+", default=list(STEPS), choices=STEPS)
    ap.add_argument("--time-limit", type=float, default=300.0, help="seconds per solve/bound")
    ap.add_argument("--workers", type=int, default=1, help="processes for orbit-dp and bound")
    ap.add_argument(
        "--bound-iterations", type=int, default=300, help="subgradient steps at most (300)"
    )
    ap.add_argument("--dir", default="bench_scale_data", help="where the instances go")
    ap.add_argument("--json", help="also write the rows to this JSON file")
    args = ap.parse_args(argv)
    Path(args.dir).mkdir(exist_ok=True)
    rows = []
    for name in args.runs:
        path = str(Path(args.dir) / f"{name}.json.gz")
        row: dict[str, Any] = {"run": name}
        if "generate" in args.steps or not Path(path).exists():
            row["generate"] = in_process("generate", name, path)
            print(name, "generate", row["generate"], flush=True)
        for method in SOLVERS:
            if method in args.steps:
                row[method] = in_process("solve", path, method, args.time_limit, args.workers)
                print(name, method, row[method], flush=True)
        profits = [row[m]["profit"] for m in SOLVERS if "profit" in row.get(m, {})]
        best = max(profits) if profits else None
        if "bound" in args.steps:
            row["bound"] = in_process(
                "bound", path, args.time_limit, best, args.workers, args.bound_iterations
            )
            print(name, "bound", row["bound"], flush=True)
            b = row["bound"].get("bound")
            if best is not None and b:
                row["gap_pct"] = round(100.0 * (b - best) / b, 2)
        rows.append(row)
    print()
    print("| run | step | seconds | peak MB | result |")
    print("|---|---|---|---|---|")
    for row in rows:
        for step in STEPS:
            if step not in row:
                continue
            r = row[step]
            result = {k: v for k, v in r.items() if k not in ("seconds", "peak_mb")}
            print(f"| {row['run']} | {step} | {r.get('seconds', '')} | {r['peak_mb']} | {result} |")
        if "gap_pct" in row:
            print(f"| {row['run']} | gap | | | {row['gap_pct']} % |")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
