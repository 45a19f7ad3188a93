"""The ``sosp`` command line.

Core commands live here (``scenario``, ``info``, ``solve``, ``validate``, ``demo``); others
are contributed by their packages through :data:`EXTRA_COMMANDS` (``bound``, ``bench``,
``report``, ``plot``). Start-up stays fast: modules are imported only by the command that
needs them (``sosp --help`` and ``sosp validate`` never import Pyomo).

Every command accepts ``--json`` to print one JSON object for scripts. Bad input prints one
line ``error: ...`` on stderr and exits with code 2; outputs are written atomically.
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import json
import logging
import os
import sys
import threading
import time
from collections.abc import Sequence
from typing import Any

from sosp.errors import InputError
from sosp.params import key_values, positive

log = logging.getLogger("sosp")

#: Subcommands contributed by other modules: name -> "module:add_parser_function".
EXTRA_COMMANDS: dict[str, str] = {
    "bound": "models.cli:add_bound_parser",
    "bench": "sosp.campaign.cli:add_bench_parser",
    "report": "sosp.report:add_report_parser",
    "plot": "sosp.plot:add_plot_parser",
    "export": "sosp.export:add_export_parser",
    "view": "sosp.view:add_view_parser",
    "replan": "sosp.replanning:add_replan_parser",
    "simulate": "sosp.simulate:add_simulate_parser",
}

#: The built-in scenario of ``sosp demo``.
DEMO_SCENARIO = "C1"

#: Units of the resource options of ``sosp scenario`` (Table 1 of the paper): metavar, help.
#: Memory and energy are in the paper's abstract units (``docs/model.md``).
RESOURCE_UNITS: dict[str, tuple[str, str]] = {
    "memory_capacity": ("UNITS", "memory units per orbit"),
    "memory_rate": ("UNITS/S", "memory units per second observed"),
    "energy_capacity": ("UNITS", "energy units per orbit"),
    "observe_energy_rate": ("UNITS/S", "energy units per second observed"),
    "slew_energy_rate": ("UNITS/S", "energy units per second slewing"),
    "slew_rate": ("DEG/S", "degrees per second"),
    "setup_time": ("S", "seconds before each observation"),
    "max_openings": ("N", "sensor openings per orbit"),
    "max_duration": ("S", "longest observation, seconds"),
}


def emit(args: argparse.Namespace, data: dict[str, Any], text: str) -> None:
    out = json.dumps(data, allow_nan=False) if getattr(args, "json", False) else text.rstrip("\n")
    sys.stdout.write(out + "\n")


# --------------------------------------------------------------------------- scenario
def _resources_from_args(args: argparse.Namespace):  # -> Resources
    from sosp.instance import RESOURCE_KEYS, Resources

    given = {k: getattr(args, k) for k in RESOURCE_KEYS if getattr(args, k, None) is not None}
    if "max_openings" in given:
        if float(given["max_openings"]) != int(given["max_openings"]):
            raise InputError("--max-openings: expected a whole number")
        given["max_openings"] = int(given["max_openings"])
    return Resources(**given)


def _walker_from_args(args: argparse.Namespace):  # -> list[Satellite] | None
    """The satellites of ``--walker T/P/F --altitude KM [--inclination DEG]`` (None without)."""
    if args.walker is None:
        if args.altitude is not None or args.inclination is not None:
            raise InputError("--altitude, --inclination: give them with --walker T/P/F")
        return None
    from sosp.orbits import walker_delta
    from sosp.scenarios import DEFAULT_START

    if args.tle is not None:
        raise InputError("--walker and --tle: give one source of satellites, not both")
    parts = args.walker.split("/")
    if len(parts) != 3 or not all(x.strip().isdigit() for x in parts):
        raise InputError(
            f"--walker: expected SATS/PLANES/PHASING, e.g. 48/8/1, got {args.walker!r}"
        )
    if args.altitude is None:
        raise InputError("--walker: give the altitude with --altitude KM")
    start = args.start or DEFAULT_START
    return walker_delta(*map(int, parts), args.altitude, epoch=start, inclination=args.inclination)


def cmd_scenario(args: argparse.Namespace) -> int:
    import numpy as np

    from sosp import scenarios
    from sosp.io import check_output
    from sosp.orbits import utc_iso
    from sosp.stations import stations_from_arg

    check_output(args.output)
    common: dict[str, Any] = {
        "resources": _resources_from_args(args),
        "max_roll": args.max_roll,
        "fov": args.fov,
        "min_sun_elevation": args.min_sun_elevation,
        "start": None if args.start is None else utc_iso(args.start, "--start"),
    }
    if args.hours is not None:
        common["hours"] = args.hours
    if args.targets is not None and args.region is None:
        raise InputError("--targets: give it with --region LAT0 LAT1 LON0 LON1")
    if args.region is not None and args.targets_csv is not None:
        raise InputError("--region and --targets-csv: give one source of targets, not both")
    walker = _walker_from_args(args)
    stations = stations_from_arg(args.stations) if args.stations is not None else ()
    downlink = None
    if args.downlink is not None:
        if not stations:
            raise InputError("--downlink: give it with --stations")
        from sosp.downlink import DownlinkParams

        downlink = DownlinkParams.from_dict(
            key_values(args.downlink, "--downlink: expected KEY=VALUE")
        )
    if args.region is None and args.targets_csv is None and args.tle is None and walker is None:
        if not args.name:
            raise InputError("scenario: give a name (B1..B10, C1..C10), --region or --targets-csv")
        inst = scenarios.generate_scenario(args.name, args.seed, **common)
    else:
        if args.region is not None:
            if args.targets is None:
                raise InputError("--region: give the number of targets with --targets N")
            targets = scenarios.random_targets(
                args.targets, tuple(args.region), np.random.default_rng(args.seed)
            )
        elif args.targets_csv is not None:
            targets = scenarios.read_targets_csv(args.targets_csv)
        else:
            # A named scenario's own targets, seen by the user's satellites (--tle).
            if not args.name or args.name not in scenarios.scenario_names():
                raise InputError(
                    f"{'--tle' if args.tle is not None else 'scenario'}: targets are missing: "
                    "give --targets-csv FILE, or --region LAT0 LAT1 LON0 LON1 --targets N, or a "
                    "scenario name (B1..B10, C1..C10) to use its targets"
                )
            group, k = scenarios._parse_name(args.name)
            targets = scenarios.random_targets(
                100 * k, scenarios.REGIONS[group], scenarios._rng(args.name, args.seed)
            )
        inst = scenarios.custom_scenario(
            targets=targets,
            satellites=args.tle if walker is None else walker,
            seed=args.seed,
            name=args.name or "custom",
            **common,
        )
    if stations:
        inst = inst.with_stations(stations, downlink)
    inst.save(args.output)
    data, text = _info(inst)
    emit(args, {**data, "output": args.output}, f"wrote {args.output}\n{text}")
    return 0


# --------------------------------------------------------------------------- info
def _info(inst: Any) -> tuple[dict[str, Any], str]:
    """An instance's summary: for ``--json``, and as text."""
    import numpy as np

    per_orbit = np.diff(inst.orbit_offsets)
    d = {
        "name": inst.name,
        "epoch": inst.epoch,
        "fingerprint": inst.fingerprint,
        "targets": inst.n_targets,
        "EN": inst.observable_targets,
        "TN": inst.n_opps,
        "satellites": len(set(inst.orbit_satellite)),
        "orbits": inst.n_orbits,
        "horizon_s": float(inst.orbit_end.max() - inst.orbit_start.min()) if inst.n_orbits else 0,
        "total_weight": int(inst.target_weight.sum()),
        "opportunities_per_orbit": {
            oid: int(c) for oid, c in zip(inst.orbit_ids, per_orbit, strict=True)
        },
    }
    if inst.stations:
        c = inst.contacts
        d["stations"] = [
            {
                "id": s.id,
                "lat_deg": s.lat_deg,
                "lon_deg": s.lon_deg,
                "contacts": int(np.count_nonzero(c["station"] == g)),
                "contact_min": float((c["end_s"] - c["start_s"])[c["station"] == g].sum() / 60),
            }
            for g, s in enumerate(inst.stations)
        ]
        d["downlink"] = inst.downlink.to_dict()
    used = per_orbit[per_orbit > 0]
    lines = [
        f"instance      {d['name'] or '(unnamed)'}  ({d['fingerprint'][:19]}...)",
        f"epoch         {d['epoch']}",
        f"targets       {d['targets']}  (EN {d['EN']} with at least one opportunity)",
        f"opportunities {d['TN']} (TN)",
        f"orbits        {d['orbits']} on {d['satellites']} satellite(s), horizon "
        f"{d['horizon_s'] / 3600:.2f} h",
    ]
    if used.size:
        lines.append(
            f"per orbit     {used.size} orbits with opportunities: min {used.min()}, "
            f"mean {used.mean():.1f}, max {used.max()}"
        )
    lines += [
        f"station       {s['id']:<8} {s['contacts']:4d} contacts, {s['contact_min']:7.1f} min"
        for s in d.get("stations", [])
    ]
    if "downlink" in d:
        lines.append("downlink      " + ", ".join(f"{k} {v}" for k, v in d["downlink"].items()))
    return d, "\n".join(lines)


def cmd_info(args: argparse.Namespace) -> int:
    from sosp.instance import load_instance

    inst = load_instance(args.instance)
    emit(args, *_info(inst))
    return 0


# --------------------------------------------------------------------------- solve
def cmd_solve(args: argparse.Namespace) -> int:
    from sosp.instance import load_instance
    from sosp.io import check_output
    from sosp.schedule import load_schedule

    t0 = time.perf_counter()  # reading the instance counts in --time-limit
    if args.output:
        check_output(args.output)
    inst = load_instance(args.instance)
    params = key_values(args.param or [], "--param: expected KEY=VALUE")
    # bound: solve()'s own keyword, certify the schedule
    keys = ("iterations", "model", "mip_gap", "threads", "backend", "bound", "bound_workers")
    params.update({k: getattr(args, k) for k in keys if getattr(args, k) is not None})
    if args.warm_start in ("none", "auto"):
        params["warm_start"] = args.warm_start
    elif args.warm_start is not None:
        params["warm_start"] = load_schedule(args.warm_start, inst)
    if args.bound_workers is not None and args.bound is None:
        raise InputError("--bound-workers: give it with --bound")
    if args.max_memory is not None:  # the memory of each method's Budget
        importlib.import_module("sosp.candidates").MAX_MEMORY = args.max_memory
    # A status line on stderr (unless --quiet), and Ctrl-C / SIGTERM stop the search (not the
    # program): the best schedule so far is then written as usual. --time-limit counts from
    # t0, so the run keeps what reading the instance left of it (at least KERNEL_SHARE_LEFT).
    from sosp.planner import KERNEL_SHARE_LEFT
    from sosp.progress import Progress, StatusLine
    from sosp.solve import solve
    from sosp.stop import handle_signals, stop_reason

    limit = args.time_limit
    if limit is not None:
        limit = max(limit - (time.perf_counter() - t0), KERNEL_SHARE_LEFT * limit)
    line = None if args.quiet else StatusLine(sys.stderr)
    progress = Progress(line, interval=0.5 if line is None or line.tty else 1.0)
    # a log record to the terminal clears the live line first (StatusLine.filter)
    handlers = logging.getLogger().handlers if line is not None and line.tty else []
    for h in handlers:
        h.addFilter(line)
    with handle_signals(on_stop=None if line is None else line.stopping):
        try:
            # a line within a second of the start for every method, also one that reports
            # nothing for a while (milp inside HiGHS, a method's preparation)
            with progress.ticking():
                result = solve(
                    inst, args.method, seed=args.seed, time_limit=limit, progress=progress,
                    **params,
                )  # fmt: skip
        finally:
            if line is not None:
                line.close()
            for h in handlers:
                h.removeFilter(line)
        if args.output:
            result.schedule.save(args.output, inst)
        interrupted = stop_reason()  # the signal that stopped the search (None)
    data = result.summary()
    if args.output:
        data["output"] = args.output
    text = (
        f"{result.method}: {result.status.value}, profit {result.profit:g}, "
        f"{result.observed} targets in {len(result.schedule)} observations, "
        f"{result.runtime_s:.2f} s"
    )
    # a restriction's (static, task model) optimum and bound are labelled with its model:
    # the problem may have better schedules
    of = "" if result.restriction is None else f" for the {result.restriction} model"
    label = "bound" if result.restriction is None else f"{result.restriction}-model bound"
    kernels = result.stats.get("kernels_s") or 0.0
    if kernels >= KERNELS_NOTED_S:
        text += f" ({kernels:.2f} s of it loading the numba kernels{KERNELS_WHY})"
    if result.status.value == "optimal":
        text += f", proven optimal{of} (gap 0)"
    elif result.bound is not None:
        text += f", {label} {result.bound:g} (gap {100 * (result.gap or 0):.2f}%)"
    if of:
        text += f"\n{result.restriction} model: a restriction of the problem, whose optimum "
        text += "may be higher (--bound certifies a schedule for the problem)"
    if (down := result.stats.get("downlink")) is not None:
        text += "\n" + _downlink_text(down)
    if len(result.stages) > 1:
        text += "\nstages: " + ", ".join(_stage_text(st) for st in result.stages)
    if args.output:
        text += f"\nwrote {args.output}"
    # exit 130 when a stop cut the run short; a run that proved its schedule optimal all the
    # same lost nothing to it (exit 0)
    cut = interrupted is not None and result.status.value != "optimal"
    if cut:
        text += f"\nstopped by {interrupted}: the best schedule found so far"
    elif interrupted:
        text += f"\n{interrupted} received after optimality was proven: nothing was lost"
    emit(args, data, text)
    return 130 if cut else 0


#: Seconds of the numba kernels' load worth a mention in a solve's summary (their load from
#: the disk cache takes about 0.5 s; a first compilation on a machine, seconds).
KERNELS_NOTED_S = 1.0
KERNELS_WHY = ": compiled on first use on this machine, then loaded from the disk cache"


def _stage_text(stage: Any) -> str:
    """One stage that ran (:class:`sosp.result.Stage`) as text."""
    what = "" if stage.profit is None else f" (profit {stage.profit:g})"
    if stage.kind == "bound" and stage.bound is not None:
        what = f" (bound {stage.bound:g})"
    return f"{stage.kind} {stage.name} {stage.seconds:.2f} s{what}"


def _bytes(text: str) -> int:
    """A byte count for ``--max-memory``: a number with an optional K, M, G or T suffix
    (powers of 1024; a trailing B is allowed)."""
    t = text.strip().upper().removesuffix("B")
    unit = "KMGT".find(t[-1:]) + 1 if t[-1:] in ("K", "M", "G", "T") else 0
    try:
        value = float(t[: len(t) - (unit > 0)]) * 1024**unit
    except ValueError:
        value = 0.0
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive size such as 2G, got {text!r}")
    return int(value)


# --------------------------------------------------------------------------- methods
def cmd_methods(args: argparse.Namespace) -> int:
    from sosp.methods import describe_methods, method_info
    from sosp.pipeline import BOUND_SHARE, START_SHARE
    from sosp.registry import CERTIFYING_BOUNDS, DEFAULT_METHOD, method_start, plans_downlinks

    infos = [method_info(m) for m in args.method] if args.method else describe_methods()
    starts = {m.name: getattr(method_start(m.name, None, {}), "method", None) for m in infos}
    data = {
        "default": DEFAULT_METHOD,
        "methods": [
            {**m.to_dict(), "start": starts[m.name], "plans_downlinks": plans_downlinks(m.name)}
            for m in infos
        ],
        "pipeline": {
            "start_share": START_SHARE,
            "bound_share": BOUND_SHARE,
            "bounds": list(CERTIFYING_BOUNDS),
        },
    }
    lines = []
    for m in infos:
        tag = "  (default)" if m.name == DEFAULT_METHOD else ""
        lines.append(f"{m.name}{tag}: {m.help}")
        if starts[m.name] is not None:
            lines.append(f"    start stage: {starts[m.name]} (by default)")
        if plans_downlinks(m.name):
            lines.append("    with stations: plans the downlinks itself (docs/exact.md)")
        if not m.params:
            lines.append("    (no parameters)")
        for prm in m.params:
            unit = f", in {prm.unit}" if prm.unit else ""
            lines.append(f"    {prm.name} ({prm.type or 'any'}, default {prm.default!r}{unit})")
            if prm.help:
                lines.append(f"        {prm.help}")
        lines.append("")
    lines.append("Give a parameter with sosp solve --param KEY=VALUE (VALUE is JSON or text).")
    lines.append(
        f"Stages of a run: a start stage (in at most {START_SHARE:.0%} of the method's time), "
        "the method warm-started from it (the better schedule is kept), then with --bound "
        f"one of {', '.join(CERTIFYING_BOUNDS)} in the time left ({BOUND_SHARE:.0%} of "
        "--time-limit is kept for it); --json lists the stages that ran. With stations, a "
        "method that does not plan the downlinks itself plans observations within memory "
        "allowances and sosp lays the downlinks after it (docs/model.md)."
    )
    emit(args, data, "\n".join(lines))
    return 0


# --------------------------------------------------------------------------- validate
def _downlink_text(down: dict[str, Any], detail: bool = False) -> str:
    """The downlink figures of a validation report (``report.downlink``) in one line; with
    ``detail``, also the profit delivered of the profit observed, each satellite's store peak
    and each station's use."""
    lat = down["latency_s"]
    text = (
        f"downlink: {down['delivered']} observations delivered in {down['downlinks']} "
        f"downlinks, {round(down['on_board_end'], 6) + 0.0:.3g} units left on board"
    )  # rounded: the sums of floats leave 1e-10 where nothing is left (+ 0.0: no "-0")
    if lat["mean"] is not None:
        text += (
            f"; latency mean {lat['mean'] / 60:.1f} min, p95 {lat['p95'] / 60:.1f} min, "
            f"max {lat['max'] / 60:.1f} min"
        )
    if detail:
        peaks = ", ".join(f"{s} {v:.4g}" for s, v in down["store_peak"].items()) or "none"
        use = ", ".join(f"{g} {v / 60:.1f} min" for g, v in down["station_seconds"].items())
        text += (
            f"\ndelivered profit {down['delivered_profit']:g} of {down['observed_profit']:g} "
            f"observed; store peak {peaks}; station use {use or 'none'}"
        )
    return text


def cmd_validate(args: argparse.Namespace) -> int:
    from sosp.instance import load_instance
    from sosp.schedule import load_schedule
    from sosp.validate import validate

    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    report = validate(inst, sched)
    lines = [
        f"{'feasible' if report.feasible else 'INFEASIBLE'}: profit {report.profit:g}, "
        f"{report.observed} targets, {len(sched)} observations",
        f"energy {report.energy:.1f}, memory {report.memory:.1f}, profit/energy "
        f"{report.profit_per_energy:.4f}, profit/memory {report.profit_per_memory:.4f}",
    ]
    if report.downlink is not None:
        lines.append(_downlink_text(report.downlink, detail=True))
    lines += [f"  ({v.constraint}) {v.message}" for v in report.violations]
    emit(args, report.to_dict(), "\n".join(lines))
    return 0 if report.feasible else 1


# --------------------------------------------------------------------------- demo
def cmd_demo(args: argparse.Namespace) -> int:
    from sosp import scenarios
    from sosp.registry import available_methods, compute_bound
    from sosp.solve import solve
    from sosp.validate import validate

    t0 = time.perf_counter()
    name = args.scenario
    inst = scenarios.generate_scenario(name, args.seed)
    t_gen = time.perf_counter() - t0
    info, info_text = _info(inst)
    wanted = ("greedy", "hpfs-stc", "asa-dtc", "orbit-dp")
    methods = [m for m in wanted if m in available_methods()]
    rows = []
    for m in methods:
        limit = args.time_limit if m in ("asa-dtc", "orbit-dp") else None
        res = solve(inst, m, seed=args.seed, time_limit=limit)
        rows.append((m, res, validate(inst, res.schedule)))
    upper = None
    if "orbit-dp" in methods:
        best = max(res.profit for _, res, _ in rows)
        upper = compute_bound("lagrangian", inst, lower_bound=best)["bound"]
    data = {
        "scenario": name,
        "generate_s": t_gen,
        "instance": info,
        "upper_bound": upper,
        "results": [
            {**res.summary(), "feasible": rep.feasible, "energy": rep.energy, "memory": rep.memory}
            for _, res, rep in rows
        ],
    }
    lines = [
        f"sosp demo: scenario {name} (seed {args.seed}) generated from real orbits "
        f"in {t_gen:.2f} s",
        info_text,
        "",
        f"{'method':<10} {'status':<9} {'profit':>7} {'targets':>7} {'obs':>5} "
        f"{'energy':>8} {'memory':>8} {'time':>7}  valid",
    ]
    kernels = max(res.stats.get("kernels_s") or 0.0 for _, res, _ in rows) if rows else 0.0
    for m, res, rep in rows:
        lines.append(
            f"{m:<10} {res.status.value:<9} {res.profit:>7g} {res.observed:>7} "
            f"{len(res.schedule):>5} {rep.energy:>8.1f} {rep.memory:>8.1f} "
            f"{res.runtime_s:>6.2f}s  {'yes' if rep.feasible else 'NO'}"
        )
    if kernels >= KERNELS_NOTED_S:
        lines.append(f"(the times include {kernels:.2f} s loading the numba kernels{KERNELS_WHY})")
    lines.append("")
    if upper is not None and upper <= best:
        lines.append(
            f"The best schedule (profit {best:g}) is optimal: it meets the Lagrangian bound of "
            "the clustering-exact model (gap 0)."
        )
    elif upper is not None:
        lines.append(
            f"No schedule can exceed {upper:g} (Lagrangian bound of the clustering-exact "
            f"model): the best one is within {100 * (upper - best) / upper:.2f}% of optimal."
        )
    lines.append(
        "Every schedule was checked by the independent validator (constraints (2)-(7), (11))."
    )
    emit(args, data, "\n".join(lines))
    return 0 if all(rep.feasible for _, _, rep in rows) else 1


# --------------------------------------------------------------------------- parser
def _nonneg_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse with usage errors as one line and exit code 2 (no usage dump)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise InputError(f"{self.prog}: {message}")


def build_parser() -> argparse.ArgumentParser:
    from sosp import __version__

    parser = _Parser(
        prog="sosp",
        description="Schedule Earth-observing satellites: real-orbit instances, exact models, "
        "ASA-DTC and baselines, validation and experiments.",
    )
    parser.add_argument("--version", action="version", version=f"sosp {__version__}")
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="log more on stderr: -v INFO (each solver's summary), -vv DEBUG (search details, "
        "the HiGHS log); default WARNING",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    def add(name: str, help_: str) -> argparse.ArgumentParser:
        """The subcommand ``name``, run by this module's ``cmd_<name>``."""
        p = sub.add_parser(name, help=help_, description=help_)
        p.add_argument("--json", action="store_true", help="print one JSON object")
        p.set_defaults(func=globals()[f"cmd_{name}"])
        return p

    p = add("scenario", "generate an instance from real orbits (named scenario or your own)")
    p.add_argument(
        "name", nargs="?", help="B1..B10 or C1..C10 (paper 6.1), or a name for a custom instance"
    )
    p.add_argument("-o", "--output", required=True, help="instance file to write (.json or .npz)")
    p.add_argument("--seed", type=_nonneg_int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--region",
        nargs=4,
        type=float,
        metavar=("LAT0", "LAT1", "LON0", "LON1"),
        help="random targets in this box (degrees); LON0 > LON1 is a box across 180 degrees",
    )
    p.add_argument("--targets", type=positive(int), help="number of targets with --region")
    p.add_argument("--targets-csv", help="targets file with header id,lat,lon,weight")
    p.add_argument(
        "--tle",
        help="satellites: element file, two lines per satellite (named by catalogue number) "
        "or three (a name line first); see docs/formats.md",
    )
    p.add_argument(
        "--walker",
        metavar="SATS/PLANES/PHASING",
        help="satellites: a Walker-delta constellation (circular orbits, no TLE file)",
    )
    p.add_argument("--altitude", type=positive(float), metavar="KM", help="--walker altitude")
    p.add_argument(
        "--inclination",
        type=float,
        metavar="DEG",
        help="--walker inclination (default: sun-synchronous for the altitude)",
    )
    p.add_argument(
        "--start",
        help="horizon start, ISO 8601 with any offset (converted to UTC); default: with --tle "
        "the latest element epoch, else 2026-06-01T00:00:00Z (the built-in satellites' epoch)",
    )
    p.add_argument("--hours", type=positive(float), help="horizon length in hours (24)")
    p.add_argument(
        "--stations",
        metavar="FILE|builtin|ID,ID,...",
        help="ground stations and their contact windows: a stations CSV file, every built-in "
        "station, or built-in ids (none by default)",
    )
    p.add_argument(
        "--downlink",
        nargs="+",
        metavar="KEY=VALUE",
        help="with --stations: rate (units/s, 2), energy_rate (per s, 0.5), station_setup_s "
        "(60), while_observing (true), count (delivered|observed); docs/model.md",
    )
    p.add_argument(
        "--max-roll",
        type=positive(float),
        default=33.0,
        help="max roll either side of nadir, deg (33)",
    )
    p.add_argument("--fov", type=positive(float), default=6.0, help="field of view, deg (6)")
    p.add_argument(
        "--min-sun-elevation",
        type=float,
        help="daylight rule: minimum sun elevation at the target, deg (off)",
    )
    from sosp.instance import RESOURCE_KEYS, Resources

    defaults = Resources()
    for key in RESOURCE_KEYS:
        p.add_argument(
            f"--{key.replace('_', '-')}",
            dest=key,
            type=float,
            metavar=RESOURCE_UNITS[key][0],
            help=f"per-orbit {key.replace('_', ' ')}, {RESOURCE_UNITS[key][1]} "
            f"({getattr(defaults, key):g})",
        )

    p = add("info", "summarise an instance: targets, EN, TN, orbits, opportunities per orbit")
    p.add_argument("instance", help="instance file (.json or .npz)")

    from sosp.registry import CERTIFYING_BOUNDS, DEFAULT_METHOD, METHODS, load

    p = add("solve", "solve an instance and write the schedule")
    p.epilog = (
        "Every method and its parameters (types, defaults, help): sosp methods "
        "(sosp methods --json for scripts)."
    )
    p.add_argument("instance")
    p.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        help=f"{', '.join(METHODS)} (default {DEFAULT_METHOD}); see sosp methods",
    )
    p.add_argument("--seed", type=_nonneg_int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--time-limit",
        type=positive(float),
        help="seconds of wall time from reading the instance to the schedule",
    )
    p.add_argument("--iterations", type=positive(int), help="iteration limit (search methods)")
    p.add_argument(
        "--max-memory",
        type=_bytes,
        metavar="BYTES",
        help="memory the solve may hold, e.g. 1500M or 2G (default 2G): explicit candidates "
        "that would not fit in a third of it are replaced by pricing over time windows",
    )
    p.add_argument("--model", help="milp: task, cluster (default) or static")
    p.add_argument("--mip-gap", type=float, help="milp: relative gap to stop at")
    p.add_argument("--threads", type=positive(int), help="milp: solver threads")
    p.add_argument("--backend", help="milp: pyomo, highs or auto (default: by model size)")
    p.add_argument(
        "--warm-start",
        help="milp, milp-lns: schedule file to start from; milp: none (no start) or auto "
        "(default: the start stage, orbit-dp, on the cluster model)",
    )
    p.add_argument(
        "--bound",
        nargs="?",
        const="auto",
        choices=CERTIFYING_BOUNDS,
        help="certify the schedule: compute an upper bound of the problem after the solve "
        "(auto if no value; its own time limit = --time-limit) and report the gap",
    )
    p.add_argument(
        "--bound-workers",
        type=positive(int),
        help="--bound: processes for its pricing rounds (auto, colgen, lagrangian; default 1); "
        "they pay on instances with many busy orbits (see docs/scenarios.md)",
    )
    p.add_argument(
        "--param",
        action="append",
        metavar="KEY=VALUE",
        help="method parameter (repeatable); VALUE is JSON or text; the keys of each method: "
        "sosp methods",
    )
    p.add_argument("-o", "--output", help="schedule file to write (.json)")
    p.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="no status line (by default a solve of more than 3 s shows one on stderr: live on "
        "a terminal, a line every 10 s otherwise); Ctrl-C or SIGTERM stops the search and "
        "writes the best schedule so far (status interrupted, exit code 130; exit 0 when "
        "the schedule is proven optimal all the same)",
    )

    p = add("methods", "list every method with its parameters, types, defaults and help")
    p.add_argument("method", nargs="*", help="only these methods (default: all)")

    p = add("validate", "check a schedule against every constraint; exit 1 if infeasible")
    p.add_argument("instance")
    p.add_argument("schedule")

    p = add("demo", "generate a built-in scenario, solve, validate and summarise")
    p.add_argument(
        "scenario",
        nargs="?",
        default=DEMO_SCENARIO,
        help=f"B1..B10 or C1..C10 (default {DEMO_SCENARIO}; B10 and C10 take minutes)",
    )
    p.add_argument("--seed", type=_nonneg_int, default=0)
    p.add_argument(
        "--time-limit",
        type=positive(float),
        default=5.0,
        help="seconds for the search methods (5)",
    )

    for name, target in EXTRA_COMMANDS.items():
        if (add_parser := load(target, optional=True)) is None:
            continue  # that part of sosp is not installed
        add_parser(sub)
        p = sub.choices.get(name)
        if p is not None and not any(a.dest == "json" for a in p._actions):
            p.add_argument("--json", action="store_true", help="print one JSON object")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 ok, 1 infeasible schedule, 2 bad input)."""
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        if (spot5 := importlib.import_module("sosp.spot5_cli")).wants(argv):
            return spot5.main(argv)  # the SPOT5 benchmark's .spot files
        parser = build_parser()
        args = parser.parse_args(argv)
        logging.basicConfig(
            level=logging.WARNING - 10 * min(args.verbose, 2),
            format="%(levelname)s %(name)s: %(message)s",
        )
        if not getattr(args, "func", None):
            parser.print_help()
            return 2
        return int(args.func(args) or 0)
    except InputError as exc:
        sys.stderr.write(f"error: {exc}\n")
        return 2
    except KeyboardInterrupt:
        sys.stderr.write("interrupted\n")
        return 130
    except BrokenPipeError:
        return 0


def run() -> None:
    """The program (``sosp``, ``python -m sosp``): :func:`main`, then an exit without the
    interpreter's teardown when no other thread has work left. Freeing a large solve's
    objects one by one took 0.5-1.3 s after its schedule was written (rds on 10,000
    targets): most of a Ctrl-C's time to exit (issue 63). The exit handlers run and the
    streams are flushed first, as at a normal exit; the memory goes back with the process."""
    code = main()
    if any(t.is_alive() and not t.daemon for t in threading.enumerate()[1:]):
        sys.exit(code)  # a thread still working: the normal exit waits for it
    atexit._run_exitfuncs()  # e.g. logging's flush, multiprocessing's children
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing left to write
            pass
    os._exit(code)


if __name__ == "__main__":
    run()
