"""Benchmark instance generation: C10 and a large run (10,000 targets x 24 satellites x 24 h).

Targets: C10 <= 2 s; the large run <= 30 s and <= 4 GB peak memory; with ``--g100k`` also
G100k (100,000 targets at latitudes -60..70, a Walker-delta 48/8/1 constellation at 550 km,
24 h) <= 120 s and <= 6 GB, and the time to write it as ``.json.gz``. Run from the repository
root::

    python benchmarks/bench_generate.py [--repeat 3] [--skip-large] [--g100k]

Prints a table (best wall time of ``--repeat`` runs; the traced peak of numpy/Python
allocations during one run via tracemalloc, also per opportunity; the process's peak resident
set size from ``resource.getrusage``). The figures go into ``docs/scenarios.md``.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sosp.instance import Instance  # noqa: E402
from sosp.orbits import Satellite, builtin_satellites, from_elements, walker_delta  # noqa: E402
from sosp.scenarios import DEFAULT_START, custom_scenario, generate_scenario  # noqa: E402


def constellation(n_extra: int = 20) -> list[Satellite]:
    """The four built-in satellites plus ``n_extra`` sun-synchronous ones (450-800 km) in
    planes 9 degrees apart with varied phases (synthetic, for scale only)."""
    sats = builtin_satellites()
    for i in range(n_extra):
        alt = 450.0 + 350.0 * i / max(n_extra - 1, 1)
        a = 6378.137 + alt
        n_rev_day = 86400.0 / (2 * 3.141592653589793 * (a**3 / 398600.4418) ** 0.5)
        incl = 96.0 + 3.0 * alt / 800.0  # roughly sun-synchronous
        sats.append(
            from_elements(
                f"SYN-{i + 1:02d}",
                epoch=DEFAULT_START,
                inclination=incl,
                raan=(9.0 * i) % 360.0,
                eccentricity=0.001,
                arg_perigee=90.0,
                mean_anomaly=(137.5 * i) % 360.0,
                mean_motion=n_rev_day,
                norad=90000 + i,
            )
        )
    return sats


def measure(fn: Callable[[], Instance], repeat: int) -> tuple[Instance, float, float]:
    """Best wall time over ``repeat`` runs and the traced allocation peak of one run (MB)."""
    best = float("inf")
    inst = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        inst = fn()
        best = min(best, time.perf_counter() - t0)
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert inst is not None
    return inst, best, peak / 1e6


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-large", action="store_true")
    ap.add_argument("--g100k", action="store_true", help="also 100,000 targets x 48 satellites")
    args = ap.parse_args(argv)

    generate_scenario("C1")  # warm-up: imports, data file
    rows = []
    inst, t, peak = measure(lambda: generate_scenario("C10"), args.repeat)
    rows.append(("C10 (1,000 targets x 4 sat x 24 h)", inst, t, peak, 2.0))
    inst, t, peak = measure(lambda: generate_scenario("B10"), args.repeat)
    rows.append(("B10 (1,000 targets x 4 sat x 24 h)", inst, t, peak, 2.0))
    if not args.skip_large:
        sats = constellation()

        def large() -> Instance:
            return custom_scenario(
                region=(-60.0, 70.0, -180.0, 180.0),
                count=10_000,
                seed=0,
                satellites=sats,
                name="large",
            )

        inst, t, peak = measure(large, max(1, args.repeat - 1))
        rows.append(("10,000 targets x 24 sat x 24 h", inst, t, peak, 30.0))
    written = ""
    if args.g100k:
        walker = walker_delta(48, 8, 1, 550.0, epoch=DEFAULT_START)

        def g100k() -> Instance:
            return custom_scenario(
                region=(-60.0, 70.0, -180.0, 180.0),
                count=100_000,
                seed=0,
                satellites=walker,
                name="g100k",
            )

        inst, t, peak = measure(g100k, 1)
        rows.append(("G100k: 100,000 targets x 48 sat x 24 h", inst, t, peak, 120.0))
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            inst.save(Path(tmp) / "g100k.json.gz")
            size = (Path(tmp) / "g100k.json.gz").stat().st_size / 2**20
            written = f"G100k written as .json.gz: {time.perf_counter() - t0:.1f} s, {size:.0f} MB"
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KB -> MB on Linux

    print(f"python {platform.python_version()}, {platform.machine()}")
    head = f"| {'run':<34} | {'orbits':>6} | {'opps':>7} | {'EN':>6} | {'time s':>6} |"
    head += f" {'target s':>8} | {'traced peak MB':>14} | {'B/opp':>5} |"
    print(head)
    print("|" + "|".join("-" * (len(c)) for c in head.split("|")[1:-1]) + "|")
    for label, inst, t, peak, target in rows:
        print(
            f"| {label:<34} | {inst.n_orbits:>6} | {inst.n_opps:>7} | "
            f"{inst.observable_targets:>6} | {t:>6.2f} | {target:>8.0f} | {peak:>14.0f} | "
            f"{peak * 1e6 / max(inst.n_opps, 1):>5.0f} |"
        )
    print(f"process peak RSS: {rss:.0f} MB")
    if written:
        print(written)
    ok = all(t <= target for _, _, t, _, target in rows)
    ok = ok and rss <= (6144 if args.g100k else 4096)
    print("targets met" if ok else "TARGET MISSED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
