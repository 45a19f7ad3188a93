"""``sosp bound``: upper bounds from the exact models (LP relaxation or time-limited MILP).

Imported by ``sosp --help``, so this module imports nothing heavy at import time: Pyomo and
HiGHS load inside :func:`cmd_bound` only.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from sosp.parallel import workers_for


def add_bound_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``bound`` subcommand to the ``sosp`` CLI's subparsers."""
    from sosp.params import positive
    from sosp.registry import BOUNDS, PROBLEM_MODEL

    p = subparsers.add_parser(
        "bound",
        help="upper bound on the optimum (LP relaxation or MILP of an exact model)",
        description="Upper bound on the optimum profit of an instance, within --time-limit: "
        "the clique-strengthened LP relaxation (--method lp), the bound of a time-limited MILP "
        "solve (--method milp), the Lagrangian relaxation across orbits solved by dynamic "
        "programming (--method lagrangian: no LP solver, seconds on the largest scenarios), "
        "its Dantzig-Wolfe master solved by column generation then branch and price "
        "(--method colgen), or (default, auto) the column-generation bound then, unless it "
        "converged, the LP with the time left. Every bound is "
        "at most the total weight of the targets some schedule could observe.",
    )
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument(
        "--model",
        help=f"{PROBLEM_MODEL} (default: bounds every method), task (no clustering) or static "
        f"(the model of {', '.join(n for n, b in BOUNDS.items() if b.model == 'static')})",
    )
    p.add_argument(
        "--method",
        default="auto",
        choices=tuple(BOUNDS),
        help="; ".join(f"{name}: {b.help}" for name, b in BOUNDS.items()) + " (default auto)",
    )
    p.add_argument(
        "--iterations",
        type=positive(int),
        default=300,
        help="subgradient steps of --method lagrangian (default 300)",
    )
    p.add_argument(
        "--time-limit",
        type=positive(float),
        help="seconds of wall time from reading the instance to the bound",
    )
    p.add_argument("--threads", type=int, help="HiGHS threads")
    p.add_argument(
        "--workers",
        type=positive(int),
        help="processes planning the orbits of each pricing round of colgen, lagrangian and "
        "auto (default 1), and from 2 on solving the two children of each branching of their "
        "branch and price side by side; with --dask local, the local cluster's processes "
        "(default: one per core)",
    )
    p.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="plan the orbits of each pricing round on a Dask cluster: a scheduler's address "
        "or 'local' (needs pip install -e '.[dist]'; where it pays: docs/scenarios.md)",
    )
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
    p.set_defaults(func=cmd_bound)
    return p


def cmd_bound(args: argparse.Namespace) -> int:
    """Run ``sosp bound``; returns the exit code (bad input raises ``InputError``)."""
    from models.solve import bound
    from sosp.cli import emit
    from sosp.instance import load_instance
    from sosp.registry import BOUNDS, PROBLEM_MODEL

    t0 = time.perf_counter()  # reading the instance counts in --time-limit
    inst = load_instance(args.instance)
    if BOUNDS[args.method].model != PROBLEM_MODEL:
        return _of_its_model(inst, args)
    args.model = args.model or PROBLEM_MODEL
    t_workers = time.perf_counter()
    with workers_for(args.workers or 1, args.dask, args.workers) as workers:
        limit = args.time_limit
        if limit is not None:
            # a cluster's start-up (about 1 s for a local one) counts, and a local cluster
            # takes about as long again to close after the bound
            now = time.perf_counter()
            closing = now - t_workers if args.dask == "local" else 0.0
            limit = max(limit - (now - t0) - closing, 1e-3)
        keys = ("model", "method", "threads", "backend", "lp_solver", "slew", "iterations")
        out = bound(inst, time_limit=limit, workers=workers, **{k: getattr(args, k) for k in keys})
    out["instance"] = inst.name or str(args.instance)
    # what was computed: no item count where none was generated (the windows bound needs
    # none; a run can stop before its candidates)
    items = out.get("candidates", out.get("items"))
    size = [] if items is None else [f"{items} items"]
    if items is None and out.get("timed_out") == "candidates":
        size.append("stopped before its candidates")
    if "variables" in out:
        size.append(f"{out['variables']} variables, {out.get('constraints', 0)} constraints")
    for key, what in (
        ("iterations", "subgradient steps"),
        ("rounds", "pricing rounds"),
        ("nodes", "branch-and-price nodes"),
    ):
        size += [f"{out[key]} {what}"] if key in out else []
    head = f"{out['model']} model, {out['method']} bound: {out['bound']:g}"
    said = ", ".join([f"{out['runtime_s']:.2f} s", *size])
    text = f"{head} (from {out['source']}; {said})"
    if inst.stations:
        out["of"] = "station-free relaxation"
        text += "\nwith stations: a bound of their station-free relaxation (docs/model.md)"
    if args.method == "milp":
        text += f"\nincumbent {out['profit']:g}, status {out['status']}"
    unsolved = out["source"] == "cap" and out["bound"] and out.get("lp_value") is None
    if args.method == "lp" and unsolved:
        # the cap is a bound, but a weak one: say why, and what is quicker on such sizes
        text += (
            "\nthe LP was not solved within the time limit: only the total observable weight "
            "holds; --method auto or colgen bounds large instances faster"
        )
    emit(args, out, text)
    return 0


def _of_its_model(inst: Any, args: argparse.Namespace) -> int:
    """A bound of one model only (``pba``: the static model's partition-based bound)."""
    from sosp.cli import emit
    from sosp.errors import InputError
    from sosp.registry import BOUNDS, compute_bound

    model = BOUNDS[args.method].model
    if args.model not in (None, model):
        raise InputError(
            f"--model: the {args.method} bound is of the {model} model, got {args.model!r}"
        )
    out = compute_bound(args.method, inst, time_limit=args.time_limit)
    out["instance"] = inst.name or str(args.instance)
    text = f"{model} model, {args.method} bound: {out['bound']:g} ({out['runtime_s']:.2f} s"
    if "parts" in out:
        text += f"; {out['parts']} parts, {out['targets']} targets covered by the parts' optima"
    emit(args, out, text + ")")
    return 0
