"""Ctrl-C benchmark: seconds from SIGINT to exit of ``sosp solve``, per method and instance.

Usage::

    PYTHONPATH=. python benchmarks/bench_ctrl_c.py          # every method; C10, 2k, 10k targets
    PYTHONPATH=. python benchmarks/bench_ctrl_c.py --methods asa-dtc orbit-dp --instances C10
    PYTHONPATH=. python benchmarks/bench_ctrl_c.py --after 6 --bound     # the bound stage too

Each run is what a user does: ``sosp solve INSTANCE --method M --time-limit 60 -o out.json``
in a child process, sent SIGINT ``--after`` seconds after it started (``timeout -s INT 6``).
The table gives the seconds from the signal to the exit, the exit code, the status and profit
of the ``-o`` file (validated by ``sosp validate``) and the profit the run reported on stdout
(the best found: the file must hold it). Instances: C10 (paper 6.1) and two region instances
of 2,000 and 10,000 targets (4 satellites, 24 h), generated with ``sosp scenario`` into a
temporary folder.
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Instance name -> ``sosp scenario`` arguments.
INSTANCES = {
    "C10": ["C10"],
    "region-2k": ["r2k", "--region", "20", "50", "70", "120", "--targets", "2000"],
    "region-10k": ["r10k", "--region", "0", "60", "60", "140", "--targets", "10000"],
}


def sosp(*args: str, **kwargs) -> subprocess.CompletedProcess:
    """``python -m sosp ARGS`` (the package of this interpreter's path)."""
    return subprocess.run([sys.executable, "-m", "sosp", *args], **kwargs)


def methods() -> list[str]:
    """The methods of ``sosp methods --json``."""
    out = sosp("methods", "--json", capture_output=True, text=True, check=True).stdout
    return [m["name"] for m in json.loads(out)["methods"]]


def one_run(inst: Path, method: str, after: float, limit: float, bound: bool, tmp: Path) -> dict:
    """One interrupted solve; its row of the table."""
    out = tmp / f"{inst.stem}-{method}.json"
    out.unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "sosp", "solve", str(inst), "--method", method]
    cmd += ["--time-limit", str(limit), "-o", str(out), "--json", "-q"]
    cmd += ["--bound"] if bound else []
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        proc.wait(timeout=after)
        signalled = None  # it ended before the signal
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        signalled = time.perf_counter()
    stdout, stderr = proc.communicate()
    end = time.perf_counter()
    row = {"method": method, "exit": proc.returncode, "total_s": round(end - t0, 2)}
    row["stop_s"] = None if signalled is None else round(end - signalled, 2)
    try:
        row["reported"] = json.loads(stdout)["profit"]
    except (json.JSONDecodeError, KeyError):
        row["reported"] = None
        row["error"] = (stderr.strip().splitlines() or ["?"])[-1][:80]
    if out.exists():
        data = json.loads(out.read_text())
        row["status"], row["written"] = data.get("status"), data.get("profit")
        check = sosp("validate", str(inst), str(out), "--json", capture_output=True, text=True)
        row["valid"] = check.returncode == 0
    return row


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--methods", nargs="*", help="methods (default: every one, sosp methods)")
    ap.add_argument("--instances", nargs="*", default=list(INSTANCES), choices=list(INSTANCES))
    ap.add_argument("--after", type=float, default=6.0, help="seconds before SIGINT (6)")
    ap.add_argument("--time-limit", type=float, default=60.0, help="the runs' --time-limit")
    ap.add_argument("--bound", action="store_true", help="solve with --bound (auto)")
    args = ap.parse_args(argv)
    names = args.methods or methods()
    print("| instance | method | stop s | exit | status | written | reported | valid |")
    print("| --- | --- | ---: | ---: | --- | ---: | ---: | --- |")
    with tempfile.TemporaryDirectory(prefix="sosp-ctrl-c-") as folder:
        tmp = Path(folder)
        for name in args.instances:
            inst = tmp / f"{name}.npz"
            sosp("scenario", *INSTANCES[name], "-o", str(inst), check=True, capture_output=True)
            for method in names:
                r = one_run(inst, method, args.after, args.time_limit, args.bound, tmp)
                stop = "ended first" if r["stop_s"] is None else f"{r['stop_s']:.2f}"
                print(
                    f"| {name} | {method} | {stop} | {r['exit']} | {r.get('status')} | "
                    f"{r.get('written')} | {r['reported']} | {r.get('valid')} |"
                    + (f" {r['error']}" if "error" in r else ""),
                    flush=True,
                )


if __name__ == "__main__":
    main()
