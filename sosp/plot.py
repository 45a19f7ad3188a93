"""``sosp plot``: a schedule as a Gantt chart per orbit and a map of targets and ground tracks.

The Gantt chart has one row per orbit that has opportunities (time measured from the orbit's
start): opportunities as thin grey ticks, observations as bars (ordinary tasks blue,
cluster-tasks covering several opportunities orange and labelled with their count) and the
setup + slew time each observation needs before it, constraint (3), as a red band.

The map (plain latitude/longitude axes, no map download) shows observed targets, unobserved
targets and the satellites' ground tracks. Ground tracks are propagated with
:func:`sosp.orbits.propagate` when the instance was generated from the built-in satellites
(``meta["satellite_source"] == "builtin"``); for other instances (user TLEs are not stored in
the instance) the map shows only the targets, and the title says so.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sosp.rules import orbit_rules

if TYPE_CHECKING:
    import numpy as np

    from sosp.instance import Instance
    from sosp.schedule import Schedule

#: Figure formats of ``sosp plot -o``, chosen by the file's extension.
PLOT_FORMATS = ("png", "pdf", "svg")

#: Seconds between ground-track points.
TRACK_STEP = 60.0


def ground_tracks(instance: Instance) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
    """Sub-satellite (lat, lon) per satellite over the horizon, or None when unknown.

    Uses the built-in satellites named in ``meta["satellites"]`` (geocentric latitude).
    """
    import numpy as np

    meta = dict(instance.meta)
    if meta.get("satellite_source") != "builtin" or not meta.get("satellites"):
        return None
    from sosp.orbits import builtin_satellites, propagate

    try:
        sats = builtin_satellites(list(meta["satellites"]))
    except Exception:  # noqa: BLE001 - unknown names: no tracks rather than no plot
        return None
    t0 = float(instance.orbit_start.min()) if instance.n_orbits else 0.0
    t1 = float(instance.orbit_end.max()) if instance.n_orbits else 0.0
    t = np.arange(t0, t1 + TRACK_STEP, TRACK_STEP)
    r, _ = propagate(sats, instance.epoch, t)
    out = {}
    for s, pos in zip(sats, r, strict=True):
        lat = np.degrees(np.arctan2(pos[:, 2], np.hypot(pos[:, 0], pos[:, 1])))
        lon = np.degrees(np.arctan2(pos[:, 1], pos[:, 0]))
        out[s.name] = (lat, lon)
    return out


def plot_schedule(
    instance: Instance,
    schedule: Schedule,
    path: str | os.PathLike[str],
    title: str | None = None,
    max_orbits: int = 60,
) -> dict[str, Any]:
    """Draw the Gantt chart and the map into one figure (PNG, PDF or SVG by the extension of
    ``path``), written atomically.

    Parameters
    ----------
    instance, schedule
        What to draw.
    path
        Figure to write: ``.png``, ``.pdf`` or ``.svg`` (:func:`plot_format`).
    title
        Figure title (default: instance name, method, profit).
    max_orbits
        At most this many orbit rows (those with observations first, then by opportunities).

    Returns
    -------
    dict
        ``orbits`` drawn, ``observations``, ``clusters``, ``observed`` and ``tracks``
        (whether ground tracks were drawn).
    """
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from sosp.errors import InputError
    from sosp.io import atomic_output
    from sosp.validate import validate

    target = Path(path)
    fmt = plot_format(target)
    if not target.parent.is_dir():
        raise InputError(f"output folder does not exist: {target.parent}")
    inst = instance
    rep = validate(inst, schedule)
    counts = np.diff(inst.orbit_offsets)
    used = {o.orbit for o in schedule.observations}
    orbits = [j for j in range(inst.n_orbits) if counts[j] > 0 or j in used]
    orbits.sort(key=lambda j: (j not in used, -counts[j], j))
    orbits = sorted(orbits[:max_orbits])
    row = {j: r for r, j in enumerate(orbits)}

    fig, (ax_g, ax_m) = plt.subplots(
        1, 2, figsize=(14, max(4.0, 0.22 * len(orbits) + 2)), width_ratios=[1.3, 1]
    )
    # Gantt: opportunities, setup + slew gaps (3), observations.
    for j in orbits:
        t0 = float(inst.orbit_start[j])
        sl = inst.orbit_opps(j)
        starts = inst.opp_start[sl] - t0
        ax_g.broken_barh(
            list(zip(starts, inst.opp_end[sl] - inst.opp_start[sl], strict=True)),
            (row[j] - 0.15, 0.3),
            facecolors="0.75",
        )
    by_orbit: dict[int, list[Any]] = {}
    for ob in schedule.observations:
        by_orbit.setdefault(ob.orbit, []).append(ob)
    n_clusters = 0
    for j, obs in by_orbit.items():
        if j not in row:
            continue
        obs.sort(key=lambda o: o.start)
        t0 = float(inst.orbit_start[j])
        r = orbit_rules(inst, j)
        for n, ob in enumerate(obs):
            if n:
                need = r.setup_time + r.turn(obs[n - 1].roll, ob.roll)  # (3)
                ax_g.broken_barh(
                    [(ob.start - t0 - need, need)], (row[j] - 0.3, 0.6), facecolors="#f4a6a6"
                )
            cluster = len(ob.opps) > 1
            n_clusters += cluster
            ax_g.broken_barh(
                [(ob.start - t0, ob.end - ob.start)],
                (row[j] - 0.35, 0.7),
                facecolors="#e8890c" if cluster else "#2b6cb0",
            )
            if cluster:
                ax_g.text(ob.end - t0, row[j], f" {len(ob.opps)}", va="center", fontsize=6)
    ax_g.set_yticks(range(len(orbits)), [inst.orbit_ids[j] for j in orbits], fontsize=6)
    ax_g.set_ylim(-1, max(len(orbits), 1))
    ax_g.invert_yaxis()
    ax_g.set_xlabel("time from orbit start (s)")
    ax_g.set_title("observations per orbit")
    ax_g.legend(
        handles=[
            Patch(color="#2b6cb0", label="task"),
            Patch(color="#e8890c", label="cluster-task (n covered)"),
            Patch(color="#f4a6a6", label="setup + slew (3)"),
            Patch(color="0.75", label="opportunity"),
        ],
        fontsize=7,
        loc="lower right",
    )

    # Map: ground tracks, unobserved and observed targets.
    tracks = ground_tracks(inst)
    if tracks:
        for name, (lat, lon) in tracks.items():
            jump = np.flatnonzero(np.abs(np.diff(lon)) > 180) + 1
            for k, (la, lo) in enumerate(
                zip(np.split(lat, jump), np.split(lon, jump), strict=True)
            ):
                ax_m.plot(
                    lo,
                    la,
                    lw=0.5,
                    alpha=0.5,
                    color=f"C{list(tracks).index(name) + 2}",
                    label=name if k == 0 else None,
                )
    observed = np.zeros(inst.n_targets, dtype=bool)
    for i in schedule.observed_opps():
        observed[int(inst.opp_target[i])] = True
    lon = np.where(inst.target_lon > 180, inst.target_lon - 360, inst.target_lon)
    ax_m.scatter(lon[~observed], inst.target_lat[~observed], s=8, c="0.6", label="unobserved")
    ax_m.scatter(lon[observed], inst.target_lat[observed], s=10, c="#2f855a", label="observed")
    ax_m.set_xlim(-180, 180)
    ax_m.set_ylim(-90, 90)
    ax_m.set_xlabel("longitude (deg)")
    ax_m.set_ylabel("latitude (deg)")
    ax_m.set_aspect("equal")
    ax_m.grid(alpha=0.3)
    ax_m.set_title("targets and ground tracks" if tracks else "targets (ground tracks unknown)")
    ax_m.legend(fontsize=7, loc="lower left")
    fig.suptitle(
        title
        or f"{inst.name or 'instance'}: {schedule.method or 'schedule'}, profit {rep.profit:g}, "
        f"{rep.observed} targets, {len(schedule)} observations"
    )
    fig.tight_layout()
    try:
        with atomic_output(target, suffix=f".{fmt}") as tmp:
            fig.savefig(tmp, dpi=110, format=fmt)
    finally:
        plt.close(fig)
    return {
        "orbits": len(orbits),
        "observations": len(schedule),
        "clusters": n_clusters,
        "observed": int(observed.sum()),
        "tracks": bool(tracks),
    }


def plot_format(path: str | os.PathLike[str]) -> str:
    """The figure format named by ``path``'s extension (``png``, ``pdf`` or ``svg``).

    Raises
    ------
    InputError
        For any other extension, naming ``-o``.
    """
    from sosp.errors import InputError

    ext = Path(path).suffix.lower().lstrip(".")
    if ext not in PLOT_FORMATS:
        raise InputError(
            f"-o: unknown figure format {Path(path).suffix or '(no extension)'!r} "
            f"(use {', '.join('.' + f for f in PLOT_FORMATS)})"
        )
    return ext


def add_plot_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``plot`` to the ``sosp`` subcommands."""
    p = subparsers.add_parser(
        "plot",
        help="draw a schedule: Gantt chart per orbit and a map of targets and ground tracks",
        description="Draw a schedule as a Gantt chart per orbit (cluster-tasks and setup gaps "
        "marked) and a latitude/longitude map of targets and ground tracks (PNG, PDF or SVG).",
    )
    p.add_argument("instance", help="instance file (JSON)")
    p.add_argument("schedule", help="schedule file (JSON)")
    p.add_argument(
        "-o", "--output", required=True, help="figure to write: .png, .pdf or .svg (by extension)"
    )
    p.add_argument("--title", default=None, help="figure title")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_plot)
    return p


def cmd_plot(args: argparse.Namespace) -> int:
    """Handler of ``sosp plot``."""
    from sosp.instance import load_instance
    from sosp.io import check_output
    from sosp.schedule import load_schedule

    check_output(args.output)
    plot_format(args.output)
    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    info = plot_schedule(inst, sched, args.output, title=args.title)
    info["output"] = args.output
    if args.json:
        sys.stdout.write(json.dumps(info) + "\n")
    else:
        sys.stdout.write(
            f"wrote {args.output}: {info['observations']} observations ({info['clusters']} "
            f"cluster-tasks) on {info['orbits']} orbits, {info['observed']} targets observed"
            + ("" if info["tracks"] else "; ground tracks unknown for this instance")
            + "\n"
        )
    return 0
