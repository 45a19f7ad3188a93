"""``sosp bound``: upper bounds from the exact models (LP relaxation or time-limited MILP).

Imported by ``sosp --help``, so this module imports nothing heavy at import time: Pyomo and
HiGHS load inside :func:`cmd_bound` only.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any


def _positive_float(text: str) -> float:
    from sosp.errors import InputError

    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--time-limit: expected a number, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise InputError(f"--time-limit: must be a finite number of seconds > 0, got {text}")
    return value


def add_bound_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``bound`` subcommand to the ``sosp`` CLI's subparsers."""
    p = subparsers.add_parser(
        "bound",
        help="upper bound on the optimum (LP relaxation or MILP of an exact model)",
        description="Upper bound on the optimum profit of an instance: the clique-strengthened "
        "LP relaxation (--method lp) or HiGHS's best bound after a MILP solve (--method milp).",
    )
    p.add_argument("instance", help="instance file (JSON)")
    p.add_argument(
        "--model",
        default="cluster",
        help="cluster (default: bounds every method), task (no clustering) or static",
    )
    p.add_argument("--method", default="lp", choices=("lp", "milp"), help="lp (default) or milp")
    p.add_argument("--time-limit", type=_positive_float, default=None, help="seconds")
    p.add_argument("--threads", type=int, default=None, help="HiGHS threads")
    p.add_argument(
        "--backend",
        default="auto",
        help="pyomo (reference builder), highs (arrays passed to HiGHS directly) or auto "
        "(default: highs from 1000 items on)",
    )
    p.add_argument(
        "--lp-solver",
        default="ipm",
        help="HiGHS LP algorithm for --method lp: ipm (default), simplex, pdlp or choose",
    )
    p.add_argument(
        "--slew",
        default="auto",
        help="slew term of (4) in the LP: exact, relaxed (one row per orbit: a valid, "
        "possibly weaker bound from a much smaller LP) or auto (default: relaxed from 1000 "
        "items on)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_bound)
    return p


def cmd_bound(args: argparse.Namespace) -> int:
    """Run ``sosp bound``; returns the exit code (bad input raises ``InputError``)."""
    from models.solve import bound
    from sosp.instance import load_instance

    inst = load_instance(args.instance)
    out = bound(
        inst,
        model=args.model,
        method=args.method,
        time_limit=args.time_limit,
        threads=args.threads,
        backend=args.backend,
        lp_solver=args.lp_solver,
        slew=args.slew,
    )
    out["instance"] = inst.name or str(args.instance)
    if getattr(args, "json", False):
        sys.stdout.write(json.dumps(out, allow_nan=False) + "\n")
    else:
        text = (
            f"{out['model']} model, {out['method']} bound: {out['bound']} "
            f"({out['runtime_s']:.2f} s; {out.get('candidates', 0)} items, "
            f"{out.get('variables', 0)} variables, {out.get('constraints', 0)} constraints)"
        )
        if args.method == "milp":
            text += f"\nincumbent {out['profit']:g}, status {out['status']}"
        sys.stdout.write(text + "\n")
    return 0
