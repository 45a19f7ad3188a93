"""``sosp solve|bound|validate FILE.spot``: the SPOT5 benchmark's commands.

:func:`sosp.cli.main` hands a command whose instance ends in ``.spot`` to :func:`main` here,
so the SPOT5 problem type (:mod:`sosp.spot5`) gets the same three verbs as the satellite
problem without touching their parsers. Bad input prints one line and exits with code 2
(``sosp.cli.main`` catches the :class:`~sosp.errors.InputError`); nothing is written.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
from collections.abc import Sequence
from typing import Any

import numpy as np

from sosp.errors import InputError
from sosp.spot5 import load_spot5, read_solution, validate_spot5, write_solution

log = logging.getLogger(__name__)

#: Commands routed here when their instance ends in ``.spot``.
COMMANDS = ("solve", "bound", "validate")

#: Share of ``--time-limit`` the tabu search gets before the MILP (its warm start), at most
#: :data:`WARM_MAX_S` seconds, and less once :data:`WARM_STALL` iterations bring no new best
#: (on 1401-1506 and 1502 its best comes within 20,000 iterations, about 1-4 s).
WARM_SHARE, WARM_MAX_S, WARM_STALL = 0.1, 30.0, 50_000


def wants(argv: Sequence[str]) -> bool:
    """Whether ``argv`` (without the program name) is a SPOT5 command."""
    return len(argv) >= 2 and argv[0] in COMMANDS and any(a.endswith(".spot") for a in argv)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (an :class:`InputError`, exit code 2)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message}")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="sosp", description="SPOT5 instances (.spot files)")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        s = sub.add_parser(name)
        s.add_argument("instance", help="a .spot file")
        s.add_argument(
            "--capacity",
            choices=("units", "raw"),
            default="units",
            help="recorder capacity reading: units (200, default) or raw (199)",
        )
        s.add_argument("--json", action="store_true", help="print one JSON object")
        s.add_argument("-v", "--verbose", action="count", default=0)
    s = sub.choices["solve"]
    s.add_argument("--method", choices=("milp", "rds", "tabu"), default="milp")
    s.add_argument("--time-limit", type=float, default=60.0, help="wall seconds (60)")
    s.add_argument("--seed", type=int, default=0, help="seed of the tabu search (0)")
    s.add_argument("-o", "--output", help="solution file (.json, else text 'id value')")
    sub.choices["bound"].add_argument("--time-limit", type=float, default=60.0)
    sub.choices["validate"].add_argument("solution")
    return p


def solve(problem: Any, method: str, time_limit: float, seed: int = 0) -> Any:
    """Run ``method`` on ``problem``; ``milp`` starts multi-orbit instances from a short tabu
    search (:data:`WARM_SHARE` of the limit)."""
    rng = np.random.default_rng(seed)
    if method == "rds":
        from heuristics.spot5 import solve_spot5_rds

        return solve_spot5_rds(problem, time_limit)
    from heuristics.spot5 import solve_spot5_tabu

    if method == "tabu":
        return solve_spot5_tabu(problem, time_limit, rng=rng)
    from models.spot5 import solve_spot5_milp

    if problem.capacity is None:  # single orbit: HiGHS finds the optimum at once
        return solve_spot5_milp(problem, time_limit, rng=rng)
    warm = min(WARM_SHARE * time_limit, WARM_MAX_S)
    start = solve_spot5_tabu(problem, warm, rng=rng, stall=WARM_STALL)
    out = solve_spot5_milp(problem, time_limit - start.time_s, start=start.assignment, rng=rng)
    out.stats["warm_start"] = start.value
    return dataclasses.replace(  # the times of the whole method, tabu included
        out, time_s=out.time_s + start.time_s, cpu_s=out.cpu_s + start.cpu_s
    )


def main(argv: Sequence[str]) -> int:
    """Run a SPOT5 command; returns the exit code (0, 1 infeasible solution; bad input
    raises :class:`InputError`)."""
    args = _parser().parse_args(list(argv))
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2))
    if getattr(args, "time_limit", 1.0) <= 0:
        raise InputError("--time-limit: expected a positive number of seconds")
    problem = load_spot5(args.instance, args.capacity)
    if args.command == "validate":
        rep = validate_spot5(problem, read_solution(args.solution, problem))
        data = {"feasible": rep.feasible, "profit": rep.profit, "selected": rep.selected,
                "usage": rep.usage, "capacity": problem.capacity,
                "violations": rep.violations}  # fmt: skip
        text = [f"{'feasible' if rep.feasible else 'INFEASIBLE'}: profit {rep.profit}, "
                f"{rep.selected} images, recorder {rep.usage}/{problem.capacity}"]  # fmt: skip
        _emit(args, data, text + [f"  {v}" for v in rep.violations])
        return 0 if rep.feasible else 1
    if args.command == "bound":
        from models.spot5 import spot5_bound

        out = spot5_bound(problem, args.time_limit)
        _emit(args, out, [f"clique LP bound {out['bound']} ({out['time_s']:.2f} s)"])
        return 0
    if args.output:
        from sosp.io import check_output

        check_output(args.output)
    res = solve(problem, args.method, args.time_limit, args.seed)
    if not validate_spot5(problem, res.assignment).feasible:  # a bug, not bad input
        raise RuntimeError(f"{args.method} returned an infeasible solution")
    if args.output:
        write_solution(args.output, problem, res.assignment)
    gap = res.gap
    data = {"method": res.method, "value": res.value, "bound": res.bound, "gap": gap,
            "status": res.status, "time_s": res.time_s, "cpu_s": res.cpu_s}  # fmt: skip
    line = f"{problem.name} {res.method}: value {res.value}, bound {res.bound}" + (
        "" if gap is None else f", gap {100 * gap:.3f}%"
    )
    _emit(args, data, [f"{line}, {res.status}, {res.time_s:.2f} s ({res.cpu_s:.2f} s CPU)"])
    return 0


def _emit(args: argparse.Namespace, data: dict[str, Any], lines: list[str]) -> None:
    sys.stdout.write((json.dumps(data) if args.json else "\n".join(lines)) + "\n")
