"""Every method on randomly drawn instances: do the contracts hold away from the paper's?

The instances are drawn from ``--seed`` (one ``numpy.random.Generator`` per instance, seeded
``[seed, i]``): a random box anywhere between 60 S and 70 N (``--anywhere``: over the whole
globe, poles and antimeridian included), 100-2,500 targets (``--sizes``), the four
built-in satellites or a Walker-delta constellation of 4-12 satellites at 450-800 km, a 12 or
24 h horizon and, on half of them, tight per-orbit rules (memory, energy, openings, setup,
slew rate, longest observation, roll, daylight) drawn over the ranges ``sosp scenario``
accepts. Each method then runs as a user runs it, one process at a time::

    sosp solve X --method M --time-limit T --seed 0 --json -o S
    sosp validate X S --json
    sosp bound X --method auto --time-limit 2T --json

and the run is checked against what every method promises (#17 and ``docs/model.md``):

* ``rc``: the solve exits 0;
* ``valid``: the validator accepts the schedule and finds the profit the solver reported;
* ``time``: ``runtime_s`` within max(1 s, 5 %) of the limit;
* ``bound``: the profit is at most the bound of ``sosp bound`` and at most ``milp``'s bound;
* ``optimum``: when ``milp`` proves its schedule optimal, no method reports more.

One JSON object per run goes to ``--output`` (appended: a sweep stopped half-way resumes
where it was, the instances being drawn again from the same seeds), a Markdown table to
stdout: per instance, each method's profit as a share of the best schedule found, and the
broken checks. Exit 1 if any check failed.

    python benchmarks/bench_sweep.py --instances 8 --seed 0 --limit 5 --output sweep.jsonl
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.bench_time_limits import slack  # noqa: E402  (max(1 s, 5 %), #17)
from sosp.registry import available_methods  # noqa: E402

#: Target counts drawn from by default.
SIZES = (100, 300, 600, 1200, 2500)


def draw(
    seed: int, i: int, sizes: tuple[int, ...] = SIZES, anywhere: bool = False
) -> tuple[str, list[str]]:
    """Instance ``i`` of the sweep ``seed``: its name and ``sosp scenario`` arguments.

    ``anywhere`` draws the box over the whole globe instead: up to the poles, and across the
    antimeridian (west edge east of the east edge) when it reaches past 180 degrees; the
    name then starts with ``world``. Without it, and with the default ``sizes``, a seed
    draws the instances it always drew."""
    rng = np.random.default_rng([seed, i])
    if anywhere:
        lat0 = float(rng.uniform(-90.0, 80.0))
        lat1 = min(90.0, lat0 + float(rng.uniform(5.0, 30.0)))
        lon0 = float(rng.uniform(-180.0, 180.0))
        lon1 = lon0 + float(rng.uniform(5.0, 40.0))
        if lon1 > 180.0:
            lon1 -= 360.0
    else:
        lat0 = float(rng.uniform(-60.0, 55.0))
        lat1 = min(70.0, lat0 + float(rng.uniform(5.0, 30.0)))
        lon0 = float(rng.uniform(-180.0, 140.0))
        lon1 = lon0 + float(rng.uniform(5.0, 40.0))
    targets = int(rng.choice(list(sizes)))
    name = f"{'world' if anywhere else 'sweep'}{seed}-{i}"
    args = [name, "--region", f"{lat0:.2f}", f"{lat1:.2f}", f"{lon0:.2f}", f"{lon1:.2f}"]
    args += ["--targets", str(targets), "--seed", str(i)]
    args += ["--hours", str(int(rng.choice([12, 24])))]
    if rng.random() < 0.5:
        sats = int(rng.choice([4, 6, 8, 12]))
        planes = int(rng.choice([p for p in (1, 2, 3, 4) if sats % p == 0]))
        phasing = 1 if planes > 1 else 0  # Walker phasing is in 0..planes-1
        args += ["--walker", f"{sats}/{planes}/{phasing}"]
        args += ["--altitude", f"{rng.uniform(450, 800):.0f}"]
    if rng.random() < 0.5:  # tight per-orbit rules
        args += ["--memory-capacity", f"{rng.uniform(60, 400):.0f}"]
        args += ["--energy-capacity", f"{rng.uniform(150, 800):.0f}"]
        args += ["--max-openings", str(int(rng.choice([1, 2, 3, 5, 8])))]
        args += ["--setup-time", str(int(rng.choice([5, 10, 20, 30])))]
        args += ["--slew-rate", str(float(rng.choice([0.5, 1.0, 2.0])))]
        args += ["--max-duration", str(int(rng.choice([30, 60, 120])))]
        args += ["--max-roll", str(int(rng.choice([20, 33, 45])))]
        if rng.random() < 0.4:
            args += ["--min-sun-elevation", "10"]
    return name, args


def run_json(cmd: list[str]) -> tuple[int, dict, str, float]:
    """Run ``cmd``; its exit code, its JSON output (or {}), its last stderr line, wall time."""
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    try:
        out = json.loads(p.stdout) if p.returncode in (0, 1) and p.stdout.strip() else {}
    except json.JSONDecodeError:
        out = {}
    err = p.stderr.strip().splitlines()
    return p.returncode, out, (err[-1][:160] if err else ""), round(wall, 2)


def sweep_instance(
    name: str, args: list[str], folder: Path, limit: float, methods: list[str], done: set
) -> list[dict]:
    """Generate the instance (once), run what is not in ``done``, and return the rows."""
    path = folder / f"{name}.json"
    rows: list[dict] = []
    if not path.exists():
        rc, out, err, wall = run_json(["sosp", "scenario", *args, "-o", str(path), "--json"])
        if rc != 0:
            return [{"instance": name, "kind": "scenario", "rc": rc, "error": err, "args": args}]
    for method in methods:
        if (name, "solve", method) in done:
            continue
        sched = folder / f"{name}.{method}.schedule.json"
        cmd = ["sosp", "solve", str(path), "--method", method, "--time-limit", str(limit)]
        rc, out, err, wall = run_json([*cmd, "--seed", "0", "--json", "-o", str(sched)])
        row = {"instance": name, "kind": "solve", "method": method, "limit": limit, "rc": rc}
        row.update(wall_s=wall, error=err if rc else "")
        if rc == 0:
            row.update(
                profit=out.get("profit"), status=out.get("status"), bound=out.get("bound"),
                runtime_s=out.get("runtime_s"),
            )  # fmt: skip
            vrc, v, verr, _ = run_json(["sosp", "validate", str(path), str(sched), "--json"])
            row["valid"] = vrc == 0 and bool(v.get("feasible"))
            row["valid_profit"] = v.get("profit")
            if not row["valid"]:
                row["violations"] = (v.get("violations") or [verr])[:3]
        rows.append(row)
    if (name, "bound", "auto") not in done:
        cmd = ["sosp", "bound", str(path), "--method", "auto", "--time-limit", str(2 * limit)]
        rc, out, err, wall = run_json([*cmd, "--json"])
        row = {"instance": name, "kind": "bound", "method": "auto", "limit": 2 * limit, "rc": rc}
        row.update(wall_s=wall, error=err if rc else "", bound=out.get("bound"))
        row["runtime_s"] = out.get("runtime_s")
        rows.append(row)
    return rows


def problems(rows: list[dict]) -> list[str]:
    """The broken checks among one instance's rows, one line each."""
    out: list[str] = []
    solves = [r for r in rows if r["kind"] == "solve"]
    bounds = [
        float(r["bound"]) for r in rows if r["kind"] == "bound" and r.get("bound") is not None
    ]
    milp = [r for r in solves if r["method"] == "milp" and r["rc"] == 0]
    if milp and milp[0].get("bound") is not None:
        bounds.append(float(milp[0]["bound"]))
    optimum = None
    if milp and milp[0].get("status") == "optimal":
        optimum = float(milp[0]["profit"])
    for r in rows:
        tag = f"{r['instance']} {r['kind']} {r.get('method', '')}"
        if r["rc"] != 0:
            out.append(f"{tag}: rc {r['rc']}: {r.get('error', '')}")
            continue
        if r.get("runtime_s") is not None and r.get("limit") is not None:
            if float(r["runtime_s"]) > float(r["limit"]) + slack(float(r["limit"])):
                out.append(f"{tag}: time {r['runtime_s']} s for a {r['limit']} s limit")
        if r["kind"] != "solve":
            continue
        if not r.get("valid"):
            out.append(f"{tag}: invalid: {r.get('violations')}")
        elif abs(float(r["valid_profit"]) - float(r["profit"])) > 1e-6:
            out.append(f"{tag}: profit {r['profit']} but the validator finds {r['valid_profit']}")
        for b in bounds:
            if float(r["profit"]) > b + 1e-6:
                out.append(f"{tag}: profit {r['profit']} above the bound {b}")
        if optimum is not None and float(r["profit"]) > optimum + 1e-6:
            out.append(f"{tag}: profit {r['profit']} above milp's proven optimum {optimum}")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--instances", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--limit", type=float, default=5.0, help="each solve's --time-limit")
    ap.add_argument("--methods", nargs="*", default=None, help="default: every method")
    ap.add_argument(
        "--sizes", nargs="+", type=int, default=list(SIZES), help="target counts to draw from"
    )
    ap.add_argument(
        "--anywhere",
        action="store_true",
        help="boxes over the whole globe (poles, across 180 degrees), not 60 S to 70 N",
    )
    ap.add_argument("--dir", default=None, help="where the instances are kept (default: temp)")
    ap.add_argument("--output", default=None, help="JSON lines, one per run (resumed)")
    args = ap.parse_args(argv)
    methods = args.methods or available_methods()
    folder = Path(args.dir or tempfile.mkdtemp(prefix="bench_sweep."))
    folder.mkdir(parents=True, exist_ok=True)
    old: list[dict] = []
    if args.output and os.path.exists(args.output):
        with open(args.output) as f:
            old = [json.loads(line) for line in f if line.strip()]
    old = [r for r in old if r.get("sweep_limit") == args.limit]
    done = {(r["instance"], r["kind"], r.get("method")) for r in old}
    print("| instance | " + " | ".join(methods) + " | bound |")
    print("|---|" + "---|" * (len(methods) + 1))
    broken: list[str] = []
    for i in range(args.instances):
        name, scenario = draw(args.seed, i, tuple(args.sizes), args.anywhere)
        new = sweep_instance(name, scenario, folder, args.limit, methods, done)
        for r in new:
            r["sweep_limit"] = args.limit
        if args.output:
            with open(args.output, "a") as f:
                f.writelines(json.dumps(r) + "\n" for r in new)
        # the latest row of each run (a scenario refused, then drawn again, counts once)
        latest = {(r["kind"], r.get("method")): r for r in old + new if r["instance"] == name}
        rows = list(latest.values())
        broken += problems(rows)
        profit = {r["method"]: r.get("profit") for r in rows if r["kind"] == "solve"}
        best = max((float(v) for v in profit.values() if v is not None), default=0.0)
        cells = [
            "-" if profit.get(m) is None else f"{100 * float(profit[m]) / max(best, 1e-9):.1f}"
            for m in methods
        ]
        bound = next((r.get("bound") for r in rows if r["kind"] == "bound"), None)
        print(f"| {name} ({best:g}) | " + " | ".join(cells) + f" | {bound} |", flush=True)
    print()
    for line in broken:
        print(f"- {line}")
    print(f"\n{len(broken)} broken checks.")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
