"""Does ``--max-memory`` hold? The peak resident memory of whole ``sosp solve`` runs.

Each run is one ``sosp solve X --method M --time-limit T --max-memory B --json`` in its own
process; its peak is the largest resident set of that process and the children it waited for
(:func:`resource.getrusage` of a wrapper process that only starts it). A run holds when the
peak is within ``--max-memory`` plus 10 %. The instances are drawn dense boxes (the issue's
case: 2,000-3,000 targets over 20 by 25 degrees), written once into ``--dir``.

    python benchmarks/bench_memory.py --targets 2500 --limit 20 --max-memory 2G
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from sosp.registry import METHODS

#: Peak of one command, in KiB (Linux ``ru_maxrss``), measured in a fresh wrapper process.
WRAPPER = (
    "import resource, subprocess, sys; p = subprocess.run(sys.argv[1:], capture_output=True,"
    " text=True); sys.stdout.write(p.stdout); sys.exit(p.returncode) if p.returncode else"
    " print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
)

UNITS = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--targets", type=int, nargs="+", default=[2500])
    ap.add_argument("--seeds", type=int, nargs="+", default=[3])
    ap.add_argument("--limit", type=float, default=20.0, help="--time-limit of each solve")
    ap.add_argument("--max-memory", default="2G")
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--dir", default=None, help="where the instances are kept (default: temp)")
    args = ap.parse_args(argv)
    cap = float(args.max_memory[:-1]) * UNITS[args.max_memory[-1].upper()]
    folder = Path(args.dir or tempfile.mkdtemp(prefix="bench_memory."))
    folder.mkdir(parents=True, exist_ok=True)
    print("| instance | method | profit | runtime (s) | peak (MB) | holds |")
    print("|---|---|---|---|---|---|")
    held = runs = 0
    for n in args.targets:
        for seed in args.seeds:
            path = folder / f"dense{n}-{seed}.npz"
            if not path.exists():
                region = ["50", "70", "90", "115"]
                cmd = ["sosp", "scenario", path.stem, "--region", *region, "--targets", str(n)]
                cmd += ["--seed", str(seed), "-o", str(path)]
                subprocess.run(cmd, check=True, capture_output=True)
            for method in args.methods:
                cmd = ["sosp", "solve", str(path), "--method", method, "--json", "-q"]
                cmd += ["--time-limit", str(args.limit), "--max-memory", args.max_memory]
                cmd += ["-o", str(folder / "out.json")]
                p = subprocess.run(
                    [sys.executable, "-c", WRAPPER, *cmd], capture_output=True, text=True
                )
                lines = p.stdout.strip().splitlines()
                if p.returncode or not lines:
                    print(f"| {path.stem} | {method} | exit {p.returncode} | | | |", flush=True)
                    continue
                out, peak = json.loads(lines[0]), int(lines[-1]) * 1024
                runs += 1
                ok = peak <= 1.1 * cap
                held += ok
                print(
                    f"| {path.stem} | {method} | {out['profit']:g} | {out['runtime_s']:.1f} "
                    f"| {peak / 2**20:.0f} | {'yes' if ok else '**no**'} |",
                    flush=True,
                )
    print(f"\n{held} of {runs} runs within --max-memory {args.max_memory} plus 10 %.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
