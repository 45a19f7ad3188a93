"""The window bound's roll bands against the explicit candidates' bound, on generated instances.

The window relaxation (``sosp.windows``) prices each orbit without its candidate list; the
width of its roll bands trades the bound's tightness against the pricing's time. For each
instance this prints the window bound (``models.window_bound.window_colgen_bound``) at each
band width (``none``: each first opportunity's whole range; each band alone, not refined),
optionally the default bound (``--refined S``: bands halved while ``S`` seconds last) and
the explicit candidates' converged column-generation bound (``models.colgen.colgen_bound``,
the root only), with the seconds and rounds of each, as a Markdown table.

The instances are the tuning set of ``bench_tuning.py`` (generated regions, none of them the
paper's) plus, with ``--instance``, any instance files (D30, D100 of ``bench_scale.py``;
``--no-explicit`` where the explicit candidates would not fit).

Example (the table of ``docs/scenarios.md``, "The window bound's roll bands")::

    PYTHONPATH=. python benchmarks/bench_window_bound.py --bands none 1 0.5 0.25 --refined 30
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from bench_tuning import TUNING_SET

from models.colgen import colgen_bound
from models.window_bound import window_colgen_bound
from sosp.instance import Instance, load_instance
from sosp.scenarios import custom_scenario


def _instances(args: argparse.Namespace) -> list[tuple[str, Instance]]:
    out = []
    for name in args.set:
        region, n = TUNING_SET[name]
        out.append((name, custom_scenario(region=region, count=n, seed=0, name=name)))
    for path in args.instance:
        out.append((path.rsplit("/", 1)[-1], load_instance(path)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", nargs="*", default=list(TUNING_SET), choices=list(TUNING_SET))
    ap.add_argument("--instance", nargs="*", default=[])
    ap.add_argument("--bands", nargs="+", default=["none", "2", "1", "0.5"])
    ap.add_argument("--time-limit", type=float, default=600.0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--no-explicit", action="store_true")
    ap.add_argument(
        "--refined",
        type=float,
        default=0.0,
        help="also the default bound (bands refined until this many seconds; 0: not run)",
    )
    args = ap.parse_args()
    bands = [None if b == "none" else float(b) for b in args.bands]
    head = [f"band {b if b is not None else 'none'}" for b in bands]
    if args.refined:
        head.append(f"default, {args.refined:g} s (refined)")
    if not args.no_explicit:
        head.append("explicit")
    print("| instance | " + " | ".join(head) + " |")
    print("|---" * (len(head) + 1) + "|")
    for name, inst in _instances(args):
        cells: list[str] = []
        for b in bands:
            t = time.perf_counter()
            r: dict[str, Any] = window_colgen_bound(
                inst, time_limit=args.time_limit, band=b, workers=args.workers, refine=False
            )
            cells.append(_cell(r, time.perf_counter() - t))
        if args.refined:
            t = time.perf_counter()
            r = window_colgen_bound(inst, time_limit=args.refined, workers=args.workers)
            cells.append(_cell(r, time.perf_counter() - t))
        if not args.no_explicit:
            t = time.perf_counter()
            r = colgen_bound(inst, time_limit=args.time_limit, workers=args.workers)
            cells.append(_cell(r, time.perf_counter() - t))
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def _cell(r: dict[str, Any], seconds: float) -> str:
    tail = "" if r["converged"] else ", not converged"
    return f"{r['bound']:,.0f} ({seconds:.0f} s, {r['rounds']} rounds{tail})"


if __name__ == "__main__":
    main()
