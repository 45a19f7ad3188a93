"""``sosp bench``: run a campaign (options or a TOML file) into a SQLite results database."""

from __future__ import annotations

import argparse
import json
import sys
import time
from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path
from typing import Any

from sosp.errors import InputError


def add_bench_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``bench`` to the ``sosp`` subcommands (called by :func:`sosp.cli.build_parser`)."""
    p = subparsers.add_parser(
        "bench",
        help="run scenarios x methods x seeds x time limits into a results database (resumable)",
        description="Run a campaign: every combination of scenarios, methods, seeds and time "
        "limits, in parallel, each finished run stored at once in SQLite. Rerunning the same "
        "command resumes: stored runs are skipped.",
    )
    p.add_argument("campaign", nargs="?", help="campaign file (TOML), e.g. campaigns/paper.toml")
    p.add_argument("--scenarios", help="B1..B10, C1..C10, ranges (B1-B5), 'all' or instance files")
    p.add_argument(
        "--methods", help="comma list, parameters after ':' e.g. greedy,milp:model=cluster"
    )
    p.add_argument("--seeds", help="seeds, e.g. 1-10 or 1,2,5 (default 1)")
    p.add_argument(
        "--time-limit", dest="time_limit", help="seconds per run, comma list; 0 = none (0)"
    )
    p.add_argument("--instance-seed", type=int, default=None, help="scenario generator seed (0)")
    p.add_argument("--db", help="results database (default: next to the campaign file)")
    p.add_argument("--workers", type=int, default=None, help="parallel runs (default: all cores)")
    p.add_argument(
        "--dask", metavar="ADDRESS", help="run on a Dask cluster (scheduler address or 'local')"
    )
    p.add_argument("--retry-failed", action="store_true", help="rerun runs stored as errors")
    p.add_argument("--dry-run", action="store_true", help="only count stored and pending runs")
    p.set_defaults(func=cmd_bench)
    return p


def build_campaign(args: argparse.Namespace) -> tuple[Any, Path]:
    """The campaign and database path described by the ``bench`` arguments."""
    from sosp.campaign.spec import campaign_from_options, load_campaign

    base = load_campaign(args.campaign) if args.campaign else None
    if base is None and not (args.scenarios and args.methods):
        raise InputError("bench: give a campaign file, or --scenarios and --methods")
    camp = campaign_from_options(
        args.scenarios or "B1",
        args.methods or "greedy",
        args.seeds or "1",
        args.time_limit or "0",
        instance_seed=args.instance_seed or 0,
    )
    db = Path(args.db or "results.db")
    if base is not None:  # the options given replace the file's
        given = {
            "scenarios": args.scenarios,
            "methods": args.methods,
            "seeds": args.seeds,
            "time_limits": args.time_limit,
            "instance_seed": args.instance_seed is not None,
        }
        camp = replace(base, **{k: getattr(camp, k) for k, v in given.items() if v})
        db = Path(args.db) if args.db else Path(args.campaign).with_suffix(".db")
    if args.instance_seed is not None and args.instance_seed < 0:
        raise InputError("--instance-seed: must be >= 0")
    return camp, db


def cmd_bench(args: argparse.Namespace) -> int:
    """Run the campaign; exit 0 if every run succeeded, 1 if some failed or were infeasible."""
    from sosp.campaign.progress import Progress
    from sosp.campaign.runner import check_methods, plan, run_campaign
    from sosp.campaign.store import Store, new_database_guard
    from sosp.io import check_output

    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers: must be >= 1, got {args.workers}")
    camp, db = build_campaign(args)
    check_output(db, "--db")
    # Methods and their parameter values are checked before the database is touched: a
    # refused campaign leaves nothing behind.
    check_methods(camp)
    if args.dry_run:  # reads the database if there is one, writes nothing
        with Store(db, readonly=True, allow_empty=True) if db.exists() else nullcontext() as ro:
            p = plan(camp, ro, retry_failed=args.retry_failed)
        data = {
            "db": str(db),
            "total": len(p.runs),
            "stored": p.done,
            "pending": len(p.pending),
            "skipped_methods": p.skipped_methods,
        }
        text = f"{db}: {len(p.runs)} runs, {p.done} stored, {len(p.pending)} to run"
        sys.stdout.write((json.dumps(data) if args.json else text) + "\n")
        return 0
    with new_database_guard(db), Store(db) as store:
        progress: Progress | None = None
        started = time.monotonic()

        def on_result(row: dict[str, Any], done: int, total: int) -> None:
            nonlocal progress
            progress = Progress(total, t0=started) if progress is None else progress
            progress.update(row)

        out = run_campaign(
            camp,
            store,
            workers=args.workers,
            dask=args.dask,
            retry_failed=args.retry_failed,
            on_result=on_result,
        )
        if progress is not None:
            progress.close()
    data = {**out.to_dict(), "db": str(db)}
    text = (
        f"{db}: {out.total} runs in the campaign, {out.already} already stored, {out.ran} run now"
        f" ({out.failed} failed, {out.infeasible} infeasible) in {out.elapsed_s:.1f} s"
    )
    if out.skipped_methods:
        text += f"; skipped (not available): {', '.join(out.skipped_methods)}"
    sys.stdout.write((json.dumps(data) if args.json else text) + "\n")
    return 1 if out.failed or out.infeasible else 0
