"""A day of operations with re-planning at each event (``sosp simulate``, issue 61 item 5).

The day: urgent targets arrive as a Poisson stream (``rate`` per hour, weight 10, uniform in
the box of the instance's targets), one satellite fails for ``outage_hours`` at a random
time (announced when it starts), and a cloud forecast over a random quarter of that box
(probability ``cloud`` of cover, known from the start) is realised at execution time: each
observation under it is clear with the forecast's probability, drawn once per target.

At each event :func:`sosp.replanning.replan` re-plans from the current plan (``now`` = the
event's time, ``freeze`` seconds kept), with every event known so far (the cloud and the
outage stay in force). The result compares the realised profit with that of a plan that knew
every event from the start (the same method, ``now`` = the horizon start) under the same
realised sky, and counts the changes. One seeded generator draws everything.

With ``--db`` the day's figures go to ``sosp bench``'s results database (table
``simulations``, read by ``sosp report``), once per day: a day stored already is not run
again.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

import numpy as np

from sosp.events import Cloud, Events, NewTarget, Outage, horizon
from sosp.instance import Instance
from sosp.replanning import apply_events, replan
from sosp.schedule import Schedule

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Day:
    """The events of a simulated day: urgent targets with their arrival times, the outage,
    the cloud forecast."""

    arrivals: tuple[tuple[float, NewTarget], ...]
    outage: Outage
    cloud: Cloud


def draw_day(
    instance: Instance, rng: np.random.Generator, rate: float, outage_hours: float, cloud: float
) -> Day:
    """Draw a day's events for ``instance`` (module docstring)."""
    h0, h1 = horizon(instance)
    lat0, lat1 = float(instance.target_lat.min()), float(instance.target_lat.max())
    lon0, lon1 = float(instance.target_lon.min()), float(instance.target_lon.max())
    n = int(rng.poisson(rate * (h1 - h0) / 3600.0))
    times = np.sort(rng.uniform(h0, h1, n))
    arrivals = tuple(
        (float(t), NewTarget(f"SIM{i + 1:03d}", float(rng.uniform(lat0, lat1)),
                             float(rng.uniform(lon0, lon1)), 10))
        for i, t in enumerate(times)
    )  # fmt: skip
    sat = instance.satellite_names[int(rng.integers(len(instance.satellite_names)))]
    a = float(rng.uniform(h0, max(h0, h1 - outage_hours * 3600.0)))
    la, lo = (
        float(rng.uniform(lat0, (lat0 + lat1) / 2)),
        float(rng.uniform(lon0, (lon0 + lon1) / 2)),
    )
    area = (la, la + (lat1 - lat0) / 2, lo, lo + (lon1 - lon0) / 2)
    return Day(arrivals, Outage(sat, a, min(h1, a + outage_hours * 3600.0)),
               Cloud(h0, h1, cloud, area=area))  # fmt: skip


def realised(inst: Instance, sched: Schedule, clear: np.ndarray, sky: dict[str, float]) -> float:
    """Profit of ``sched`` under the realised sky: a target counts when the draw ``sky[id]``
    (uniform in [0, 1), one per target) is below the clear probability of its opportunity."""
    total = 0.0
    seen: set[int] = set()
    for i in sched.observed_opps():
        k = int(inst.opp_target[i])
        if k not in seen and sky.setdefault(inst.target_ids[k], 0.5) < clear[i]:
            seen.add(k)
            total += float(inst.target_weight[k])
    return total


def simulate(
    instance: Instance,
    schedule: Schedule,
    *,
    rate: float = 2.0,
    outage_hours: float = 2.0,
    cloud: float = 0.5,
    freeze: float = 600.0,
    method: str = "repair",
    time_limit: float | None = None,
    seed: int = 0,
) -> dict[str, Any]:
    """Run the day on ``schedule`` (the morning's plan of ``instance``); returns the figures."""
    rng = np.random.default_rng(int(seed))
    day = draw_day(instance, rng, rate, outage_hours, cloud)
    known: list[tuple[float, str, Any]] = [(t, "new", nt) for t, nt in day.arrivals]
    known.append((day.outage.start, "outage", day.outage))
    known.sort(key=lambda e: e[0])
    inst, plan = instance, schedule
    h0 = horizon(instance)[0]
    news: list[NewTarget] = []
    outages: list[Outage] = []
    n_changes, seconds = 0, []
    # the forecast is known from the start: a first re-plan at the horizon start
    steps = [(h0, "forecast", None), *known]
    for t, kind, ev in steps:
        if kind == "new":
            news.append(ev)
        elif kind == "outage":
            outages.append(ev)
        # new targets already in ``inst`` are not new any more
        fresh = tuple(n for n in news if n.id not in inst.target_index)
        r = replan(inst, plan, Events(new_targets=fresh, outages=tuple(outages),
                   clouds=(day.cloud,)), now=t, freeze=freeze, method=method,
                   time_limit=time_limit, seed=seed)  # fmt: skip
        inst, plan = r.instance, r.schedule
        n_changes += len(r.changes)
        seconds.append(r.runtime_s)
    all_events = Events(new_targets=tuple(n for _, n in day.arrivals), outages=(day.outage,),
                        clouds=(day.cloud,))  # fmt: skip
    hind = replan(instance, schedule, all_events, now=h0, freeze=0.0, method=method,
                  time_limit=time_limit, seed=seed)  # fmt: skip
    sky = {tid: float(u) for tid, u in zip(hind.instance.target_ids,
           rng.random(hind.instance.n_targets), strict=True)}  # fmt: skip
    sky_events = Events(clouds=(day.cloud,))
    online = realised(inst, plan, apply_events(inst, sky_events).clear, sky)
    best = realised(
        hind.instance, hind.schedule, apply_events(hind.instance, sky_events).clear, sky
    )
    return {
        "urgent": len(day.arrivals), "replans": len(seconds), "changes": n_changes,
        "replan_s_mean": float(np.mean(seconds)), "replan_s_max": float(np.max(seconds)),
        "realised_profit": online, "hindsight_profit": best,
        "ratio": online / best if best else 1.0, "outage": [day.outage.satellite,
                                                             day.outage.start, day.outage.end],
    }  # fmt: skip


def plan_fingerprint(instance: Instance, schedule: Schedule) -> str:
    """A hash of the morning plan's observations and downlinks (part of a stored day's key)."""
    data = schedule.to_dict(instance)
    blob = json.dumps([data["observations"], data.get("downlinks")], sort_keys=True)
    return "sha256:" + hashlib.sha256(blob.encode()).hexdigest()


def add_simulate_parser(subparsers: Any) -> Any:
    """Add ``simulate`` to the ``sosp`` subcommands."""
    from sosp.params import positive

    p = subparsers.add_parser(
        "simulate",
        help="a day of urgent targets, an outage and cloud, re-planned at each event",
        description=__doc__.split("\n\n")[1].replace("\n", " "),
    )
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument("schedule", help="the morning's schedule file (.json)")
    p.add_argument("--rate", type=positive(float), default=2.0, help="urgent targets per hour")
    p.add_argument("--outage-hours", type=positive(float), default=2.0)
    p.add_argument("--cloud", type=float, default=0.5, help="forecast probability of cover")
    p.add_argument("--freeze", type=float, default=600.0, help="seconds")
    p.add_argument("--method", default="repair")
    p.add_argument("--time-limit", type=positive(float), default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--db", help="store the day in this results database (sosp bench, report)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_simulate)
    return p


def cmd_simulate(args: Any) -> int:
    """Handler of ``sosp simulate``."""
    from datetime import UTC, datetime

    from sosp import __version__
    from sosp.campaign.runner import instance_info
    from sosp.campaign.store import SIMULATION_KEY, Store, new_database_guard
    from sosp.cli import emit
    from sosp.errors import InputError
    from sosp.instance import load_instance
    from sosp.io import check_output
    from sosp.schedule import load_schedule

    if not 0.0 <= args.cloud <= 1.0:
        raise InputError(f"--cloud: expected a probability in [0, 1], got {args.cloud}")
    if args.db:
        check_output(args.db, "--db")
    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    with ExitStack() as stack:
        store = None
        if args.db:  # the key as sosp bench identifies instances: label and fingerprint
            stack.enter_context(new_database_guard(args.db))
            store = stack.enter_context(Store(args.db))
            day = {"scenario": args.instance, "fingerprint": inst.fingerprint,
                   "plan": plan_fingerprint(inst, sched), "method": args.method,
                   "seed": args.seed, "rate": args.rate, "outage_hours": args.outage_hours,
                   "cloud": args.cloud, "freeze": args.freeze,
                   "time_limit": args.time_limit or 0.0}  # fmt: skip
            where = " AND ".join(f"{k}=?" for k in SIMULATION_KEY)
            if done := store.simulations(where, [day[k] for k in SIMULATION_KEY]):
                row = done[0]
                text = (
                    f"{args.db}: this day is stored already, not run again: {row['changes']} "
                    f"changes, realised profit {row['realised_profit']:g} against "
                    f"{row['hindsight_profit']:g} ({100 * row['ratio']:.1f} %)"
                )
                emit(args, row, text)
                return 0
        t0 = time.perf_counter()
        out = simulate(inst, sched, rate=args.rate, outage_hours=args.outage_hours,
                       cloud=args.cloud, freeze=args.freeze, method=args.method,
                       time_limit=args.time_limit, seed=args.seed)  # fmt: skip
        text = (
            f"{out['urgent']} urgent targets, outage of {out['outage'][0]}, cloud "
            f"{args.cloud:g}: {out['replans']} re-plans ({out['replan_s_mean']:.2f} s mean, "
            f"{out['replan_s_max']:.2f} s max), {out['changes']} changes\n"
            f"realised profit {out['realised_profit']:g} against {out['hindsight_profit']:g} "
            f"for a plan that knew everything ({100 * out['ratio']:.1f} %); "
            f"{time.perf_counter() - t0:.1f} s"
        )
        if store is not None:
            finished = datetime.now(UTC).isoformat(timespec="seconds")
            store.put_instances([instance_info(args.instance, inst)])
            store.put_simulation(day | out | {"version": __version__, "finished_at": finished})
            text += f"; stored in {args.db}"
    emit(args, out, text)
    return 0
