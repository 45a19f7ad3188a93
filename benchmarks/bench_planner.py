"""The planner's kernel with and without its uncapped first sweep, on the calls searches make.

Usage::

    PYTHONPATH=. python benchmarks/bench_planner.py --time-limit 10

For each instance of the tuning set (``benchmarks/bench_tuning.py``), it runs ``orbit-dp``
and ``asa-dtc`` for ``--time-limit`` seconds each and records the calls they make to the
single-orbit kernel (:func:`sosp.recursion.levels_py`, every call's inputs up to
``--max-calls``), then replays the recorded calls twice: with the sweep (``sweep`` 1, the
default) and with the levels alone (``sweep`` 0), checks that both give the same value, and
prints per instance the calls, the share whose uncapped plan fits the cap, and the kernel's
time both ways. Same session, same calls, so the ratio is the kernel's speed-up.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

import sosp.planner as planner
import sosp.recursion as recursion
from benchmarks.bench_tuning import TUNING_SET
from sosp.scenarios import custom_scenario
from sosp.solve import solve


def record(inst: Any, methods: list[str], time_limit: float, max_calls: int) -> list[tuple]:
    """The kernel's inputs over runs of ``methods`` on ``inst`` (seed 1 each)."""
    calls: list[tuple] = []
    kernel = recursion.levels()

    def recording(*args: Any) -> tuple[float, np.ndarray]:
        if len(calls) < max_calls:
            calls.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        return kernel(*args)

    saved = recursion.levels
    recursion.levels = lambda: recording
    try:
        for method in methods:
            solve(inst, method, seed=1, time_limit=time_limit)
    finally:
        recursion.levels = saved
    return calls


def replay(calls: list[tuple], sweep: int) -> tuple[float, list[float]]:
    """Seconds to replay ``calls`` with ``sweep`` and the values they give."""
    kernel = recursion.levels()
    values = []
    t0 = time.perf_counter()
    for *args, _ in calls:
        values.append(kernel(*args, sweep)[0])
    return time.perf_counter() - t0, values


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--names", nargs="+", default=list(TUNING_SET), choices=list(TUNING_SET))
    ap.add_argument("--methods", nargs="+", default=["orbit-dp", "asa-dtc"])
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per method")
    ap.add_argument("--max-calls", type=int, default=200_000)
    args = ap.parse_args(argv)
    planner.compile_kernels()
    print(f"# planner kernel, sweep against levels alone ({time.strftime('%Y-%m-%d %H:%M')})\n")
    print("| instance | calls | positions (mean) | plan fits the cap | levels alone (s) "
          "| with the sweep (s) | ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    total = [0.0, 0.0]
    for name in args.names:
        region, count = TUNING_SET[name]
        inst = custom_scenario(region=region, count=count, seed=0, name=name)
        calls = record(inst, args.methods, args.time_limit, args.max_calls)
        if not calls:
            print(f"| {name} | 0 | | | | | |")
            continue
        replay(calls[:100], 1)  # warm the caches
        t_levels, v_levels = replay(calls, 0)
        t_sweep, v_sweep = replay(calls, 1)
        if not np.allclose(v_levels, v_sweep, rtol=0.0, atol=1e-9):
            raise SystemExit(f"{name}: the sweep's values differ from the levels'")
        fits = 0
        for g, first, last, order, n_before, cap, _ in calls:
            _, path = recursion.levels()(g, first, last, order, n_before, len(g), 1)
            fits += len(path) <= cap
        mean_m = float(np.mean([len(c[0]) for c in calls]))
        total[0] += t_levels
        total[1] += t_sweep
        print(
            f"| {name} | {len(calls)} | {mean_m:.0f} | {fits / len(calls):.1%} "
            f"| {t_levels:.2f} | {t_sweep:.2f} | {t_levels / t_sweep:.2f} |",
            flush=True,
        )
    print(f"\nAll: levels alone {total[0]:.2f} s, with the sweep {total[1]:.2f} s, "
          f"ratio {total[0] / max(total[1], 1e-12):.2f}.")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
