"""``sosp plot``: a schedule as a Gantt chart per orbit and a map of targets and ground tracks.

The Gantt chart has one row per orbit that has opportunities (time measured from the orbit's
start, or UTC clock time with ``utc=True`` / ``sosp plot --utc``): opportunities as thin grey
ticks, observations as bars (ordinary tasks blue, cluster-tasks covering several
opportunities orange and labelled with their count) and the setup + slew time each
observation needs before it, constraint (3), as a red band.

The map (plain latitude/longitude axes, no map download) is zoomed to the targets: observed
targets as green dots, unobserved ones as red crosses drawn on top (so none hides under an
observed one), and the satellites' ground tracks. Legends sit outside the data, below the
Gantt chart and beside the map. Ground tracks are propagated with
:func:`sosp.orbits.propagate` when the instance was generated from the built-in satellites
(``meta["satellite_source"] == "builtin"``); for other instances (user TLEs are not stored in
the instance) the map shows only the targets, and the title says so.

With ground stations (issue 60), a panel per satellite below them draws its store, the data
on board, over the horizon (:func:`store_profile`): a step up when an observation ends, a
linear ramp down over each downlink, the memory capacity as a dashed line, contact windows
as grey bands and downlinks as magenta ones.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sosp.params import positive
from sosp.rules import orbit_rules

if TYPE_CHECKING:
    import numpy as np

    from sosp.instance import Instance
    from sosp.schedule import Schedule

#: Figure formats of ``sosp plot -o``, chosen by the file's extension.
PLOT_FORMATS = ("png", "pdf", "svg")

#: Seconds between ground-track points.
TRACK_STEP = 60.0
#: The counts of ``sosp plot``'s line, as words.
WORDS = {
    "observations": "observation",
    "clusters": "cluster-task",
    "orbits": "orbit",
    "observed": "target",
}

#: Ground-track colours: matplotlib's tab10 without its green and red (the targets'), so that
#: any two satellites' tracks differ in hue (two blues once looked alike).
TRACK_COLOURS = (
    "#1f77b4",
    "#ff7f0e",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)

#: On a UTC axis (the whole horizon), the least width of a drawn observation, as a share of
#: the axis: a 10-s observation on a 24-h axis is a tenth of a pixel wide.
MIN_BAR_SHARE = 0.003

#: Margin around the targets on the map, as a share of their extent (at least 1 degree).
MAP_MARGIN = 0.15


def map_extent(lat: np.ndarray, lon: np.ndarray) -> tuple[float, float, float, float, bool]:
    """The map's frame around the targets: ``(lon0, lon1, lat0, lat1, wrap)``.

    ``wrap`` is True when the targets are closer together measured across the antimeridian;
    longitudes are then drawn in [0, 360) (:func:`map_lon`) instead of [-180, 180). The
    frame has a margin of :data:`MAP_MARGIN` of the extent, at least 1 degree.
    """
    import numpy as np

    if not len(lat):
        return -180.0, 180.0, -90.0, 90.0, False
    plain = map_lon(lon, False)
    wrapped = map_lon(lon, True)
    wrap = bool(np.ptp(wrapped) < np.ptp(plain) - 1e-6)
    x = wrapped if wrap else plain
    x0, x1 = float(x.min()), float(x.max())
    y0, y1 = float(np.min(lat)), float(np.max(lat))
    mx = max(1.0, MAP_MARGIN * (x1 - x0))
    my = max(1.0, MAP_MARGIN * (y1 - y0))
    lo_min, lo_max = (0.0, 360.0) if wrap else (-180.0, 180.0)
    x0, x1 = max(lo_min, x0 - mx), min(lo_max, x1 + mx)
    return x0, x1, max(-90.0, y0 - my), min(90.0, y1 + my), wrap


def _clock(epoch: str, t: float) -> str:
    """``HH:MM`` UTC of ``t`` seconds from the ISO 8601 ``epoch``."""
    from datetime import datetime, timedelta

    when = datetime.fromisoformat(epoch.replace("Z", "+00:00")) + timedelta(seconds=t)
    return when.strftime("%H:%MZ")


def map_lon(lon: np.ndarray, wrap: bool) -> np.ndarray:
    """Longitudes in [-180, 180) or, with ``wrap``, in [0, 360)."""
    import numpy as np

    lon = np.asarray(lon, dtype=float)
    return np.mod(lon, 360.0) if wrap else np.mod(lon + 180.0, 360.0) - 180.0


def ground_tracks(instance: Instance) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
    """Sub-satellite (lat, lon) per satellite over the horizon, or None when unknown.

    Uses the orbits the instance records, as ``sosp export`` does: built-in satellites
    named in ``meta["satellites"]`` or element lines in ``meta["tle"]`` (TLE and Walker
    instances); geocentric latitude.
    """
    import numpy as np

    from sosp.export import subsatellite_points
    from sosp.orbits import instance_satellites

    if not (sats := instance_satellites(instance)):
        return None
    t0 = float(instance.orbit_start.min()) if instance.n_orbits else 0.0
    t1 = float(instance.orbit_end.max()) if instance.n_orbits else 0.0
    t = np.arange(t0, t1 + TRACK_STEP, TRACK_STEP)
    points = subsatellite_points(sats, instance.epoch, t)
    return {name: (p[:, 0], p[:, 1]) for name, p in points.items()}


def store_profile(
    instance: Instance, schedule: Schedule
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each satellite's store (data on board) over time, as the model counts it (D2, D5 of
    ``docs/model.md``): an observation adds its volume when it ends, a downlink removes its
    volume evenly from its start to its end.

    Returns
    -------
    dict
        Per satellite of :attr:`~sosp.instance.Instance.satellite_names`, the vertices
        ``(t, store)`` of the piecewise linear curve from the horizon's start to its end, a
        step drawn as two vertices at the same time (the store before, then after).
    """
    import numpy as np

    from sosp.downlink import satellite_of_orbit, volume

    sat_of = satellite_of_orbit(instance)
    t0 = float(instance.orbit_start.min()) if instance.n_orbits else 0.0
    t1 = float(instance.orbit_end.max()) if instance.n_orbits else 0.0
    out = {}
    for s, name in enumerate(instance.satellite_names):
        mine = [ob for ob in schedule.observations if sat_of[ob.orbit] == s]
        ends = np.array([ob.end for ob in mine], dtype=float)
        vols = np.array([volume(instance, ob) for ob in mine], dtype=float)
        dls = [d for d in schedule.downlinks if d.satellite == s]
        t = np.unique(np.r_[t0, t1, ends, [d.start for d in dls], [d.end for d in dls]])
        gone = sum((d.volume * np.clip((t - d.start) / (d.end - d.start), 0, 1) for d in dls), 0)
        before = (ends[None, :] < t[:, None]) @ vols - gone  # just before each vertex
        after = (ends[None, :] <= t[:, None]) @ vols - gone
        out[name] = (np.repeat(t, 2), np.column_stack([before, after]).ravel())
    return out


def plot_schedule(
    instance: Instance,
    schedule: Schedule,
    path: str | os.PathLike[str],
    title: str | None = None,
    max_orbits: int = 60,
    utc: bool = False,
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
    utc
        Gantt time axis in UTC clock time (the instance's epoch plus seconds) instead of
        seconds from each orbit's start.

    Returns
    -------
    dict
        ``orbits`` drawn, ``observations``, ``clusters``, ``observed`` and ``tracks``
        (whether ground tracks were drawn).
    """
    import matplotlib.pyplot as plt

    from sosp.io import atomic_output

    fmt = plot_format(path)
    fig, info = schedule_figure(instance, schedule, title, max_orbits, utc)
    try:
        with atomic_output(path, suffix=f".{fmt}") as tmp:
            fig.savefig(tmp, dpi=110, format=fmt)
    finally:
        plt.close(fig)
    return info


def schedule_figure(
    instance: Instance,
    schedule: Schedule,
    title: str | None = None,
    max_orbits: int = 60,
    utc: bool = False,
) -> tuple[Any, dict[str, Any]]:
    """The figure of :func:`plot_schedule` (a matplotlib ``Figure``, Agg backend; the caller
    closes it) and its counts. Parameters as :func:`plot_schedule`."""
    import matplotlib
    import numpy as np

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from sosp.validate import validate

    inst = instance
    rep = validate(inst, schedule)
    counts = np.diff(inst.orbit_offsets)
    used = {o.orbit for o in schedule.observations}
    orbits = [j for j in range(inst.n_orbits) if counts[j] > 0 or j in used]
    orbits.sort(key=lambda j: (j not in used, -counts[j], j))
    total, orbits = len(orbits), orbits[:max_orbits]
    # by satellite then time; on a UTC axis by time alone, so the passes read as a timeline
    orbits.sort(key=lambda j: (float(inst.orbit_start[j]), j) if utc else j)
    row = {j: r for r, j in enumerate(orbits)}

    size = (14, max(4.5, 0.22 * len(orbits) + 2.5))
    n_store = len(inst.satellite_names) if inst.stations else 0
    if n_store:  # one store panel per satellite below the Gantt chart and the map
        fig = plt.figure(figsize=(size[0], size[1] + 1.6 * n_store), layout="constrained")
        grid = fig.add_gridspec(
            1 + n_store, 2, width_ratios=[1.3, 1], height_ratios=[size[1] - 0.5] + [1.6] * n_store
        )
        ax_g, ax_m = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
        ax_s = [fig.add_subplot(grid[1 + i, :]) for i in range(n_store)]
    else:
        fig, (ax_g, ax_m) = plt.subplots(
            1, 2, figsize=size, width_ratios=[1.3, 1], layout="constrained"
        )
    # Gantt: x is seconds from the orbit's start, or UTC clock time as matplotlib dates.
    scale = 86400.0 if utc else 1.0  # seconds per x unit
    if utc:
        from datetime import datetime

        import matplotlib.dates as mdates

        day0 = mdates.date2num(datetime.fromisoformat(inst.epoch.replace("Z", "+00:00")))

    def x_of(j: int, t: Any) -> Any:
        return (day0 if utc else -float(inst.orbit_start[j])) + np.asarray(t) / scale

    def dx(d: Any) -> Any:
        return np.asarray(d) / scale

    # on a UTC axis, bars keep a visible width (MIN_BAR_SHARE of the shown span)
    least = 0.0
    if utc and orbits:
        lo = min(
            float(inst.opp_start[inst.orbit_opps(j)].min(initial=inst.orbit_start[j]))
            for j in orbits
        )
        hi = max(
            float(inst.opp_end[inst.orbit_opps(j)].max(initial=inst.orbit_end[j])) for j in orbits
        )
        least = MIN_BAR_SHARE * (hi - lo) / scale

    # opportunities, setup + slew gaps (3), observations
    for j in orbits:
        sl = inst.orbit_opps(j)
        starts = x_of(j, inst.opp_start[sl])
        ax_g.broken_barh(
            list(zip(starts, dx(inst.opp_end[sl] - inst.opp_start[sl]), strict=True)),
            (row[j] - 0.15, 0.3),
            facecolors="0.75",
        )
    n_clusters = 0
    for prev, ob in pairwise((None, *schedule.observations)):  # sorted by (orbit, start)
        j = ob.orbit
        if j not in row:
            continue
        if prev is not None and prev.orbit == j:
            r = orbit_rules(inst, j)
            need = r.setup_time + r.turn(prev.roll, ob.roll)  # (3)
            ax_g.broken_barh(
                [(x_of(j, ob.start - need), dx(need))], (row[j] - 0.3, 0.6), facecolors="#f4a6a6"
            )
        cluster = len(ob.opps) > 1
        n_clusters += cluster
        ax_g.broken_barh(
            [(x_of(j, ob.start), max(dx(ob.end - ob.start), least))],
            (row[j] - 0.35, 0.7),
            facecolors="#e8890c" if cluster else "#2b6cb0",
        )
        if cluster and not utc:
            ax_g.text(x_of(j, ob.end), row[j], f" {len(ob.opps)}", va="center", fontsize=6)
    if utc:  # one count per pass after its last bar: bars a few pixels apart would pile up
        for j in orbits:
            mine = [ob for ob in schedule.observations if ob.orbit == j]
            if mine:
                end = max(x_of(j, ob.end) for ob in mine) + least
                k = sum(len(ob.opps) for ob in mine)
                text = f" {len(mine)} obs, {k} target{'' if k == 1 else 's'}"
                ax_g.text(end, row[j], text, va="center", fontsize=6)
    labels = [inst.orbit_ids[j] for j in orbits]
    if utc:  # each pass's first opportunity, clock time: the axis spans the whole horizon
        first = [
            float(inst.opp_start[inst.orbit_opps(j)].min(initial=inst.orbit_end[j])) for j in orbits
        ]
        labels = [f"{name} {_clock(inst.epoch, t)}" for name, t in zip(labels, first, strict=True)]
    ax_g.set_yticks(range(len(orbits)), labels, fontsize=6)
    ax_g.set_ylim(-1, max(len(orbits), 1))
    ax_g.invert_yaxis()
    if utc:
        loc = mdates.AutoDateLocator()
        ax_g.xaxis.set_major_locator(loc)
        ax_g.xaxis.set_major_formatter(mdates.ConciseDateFormatter(loc, tz=None))
        ax_g.set_xlabel("UTC")
    else:
        ax_g.set_xlabel("time from orbit start (s)")
    shown = f" (showing {len(orbits)} of {total} orbits)" if len(orbits) < total else ""
    ax_g.set_title("observations per orbit" + shown, pad=20)
    ax_g.legend(  # between the title and the chart, never over a bar
        handles=[
            Patch(color="#2b6cb0", label="task"),
            Patch(color="#e8890c", label="cluster-task (n covered)"),
            Patch(color="#f4a6a6", label="setup + slew before an observation"),
            Patch(color="0.75", label="opportunity"),
        ],
        fontsize=7,
        loc="lower center",
        bbox_to_anchor=(0.5, 1.0),
        ncol=4,
        frameon=False,
    )

    # Map, zoomed to the targets: ground tracks, observed targets, unobserved ones on top.
    observed = np.zeros(inst.n_targets, dtype=bool)
    for i in schedule.observed_opps():
        observed[int(inst.opp_target[i])] = True
    x0, x1, y0, y1, wrap = map_extent(inst.target_lat, inst.target_lon)
    tracks = ground_tracks(inst)
    for n, (name, (lat, lon)) in enumerate((tracks or {}).items()):
        lon = map_lon(lon, wrap)
        jump = np.flatnonzero(np.abs(np.diff(lon)) > 180) + 1
        style = {"lw": 0.6, "alpha": 0.5, "color": TRACK_COLOURS[n % len(TRACK_COLOURS)]}
        for k, (la, lo) in enumerate(zip(np.split(lat, jump), np.split(lon, jump), strict=True)):
            ax_m.plot(lo, la, label=None if k else name, zorder=1, **style)
    lon = map_lon(inst.target_lon, wrap)
    ax_m.scatter(
        lon[observed], inst.target_lat[observed], s=12, c="#2f855a", label="observed", zorder=2
    )
    ax_m.scatter(
        lon[~observed],
        inst.target_lat[~observed],
        s=14,
        c="#c53030",
        marker="x",
        linewidths=0.8,
        label="unobserved",
        zorder=3,
    )
    ax_m.set_xlim(x0, x1)
    ax_m.set_ylim(y0, y1)
    ax_m.set_xlabel("longitude (deg)" + (", 0-360" if wrap else ""))
    ax_m.set_ylabel("latitude (deg)")
    ax_m.set_aspect("equal", adjustable="box")
    ax_m.grid(alpha=0.3)
    ax_m.set_title("targets and ground tracks" if tracks else "targets (ground tracks unknown)")
    ax_m.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    if n_store:
        for ax in ax_s[1:]:
            ax.sharex(ax_s[0])
        _store_panels(inst, schedule, ax_s, (lambda t: day0 + t / scale) if utc else None)
    fig.suptitle(
        title
        or f"{inst.name or 'instance'}: {schedule.method or 'schedule'}, profit {rep.profit:g}, "
        f"{rep.observed} targets, {len(schedule)} observations"
    )
    return fig, {
        "orbits": len(orbits),
        "orbits_total": total,
        "observations": len(schedule),
        "clusters": n_clusters,
        "observed": int(observed.sum()),
        "tracks": bool(tracks),
        **({"stores": n_store, "downlinks": len(schedule.downlinks)} if n_store else {}),
    }


def _store_panels(inst: Instance, schedule: Schedule, axes: list[Any], utc_x: Any | None) -> None:
    """Per satellite, its store over time (:func:`store_profile`), its memory capacity
    (dashed; per orbit, as (5) and D5 read it), contact windows (grey) and downlinks
    (magenta) as bands. x is hours from the epoch, or UTC clock time (``utc_x`` maps seconds
    to matplotlib dates)."""
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def x(t: Any) -> Any:
        return utc_x(np.asarray(t, dtype=float)) if utc_x else np.asarray(t, dtype=float) / 3600

    prof = store_profile(inst, schedule)
    con = inst.contacts
    for s, (ax, name) in enumerate(zip(axes, inst.satellite_names, strict=True)):
        for c in con[con["satellite"] == s]:
            ax.axvspan(x(c["start_s"]), x(c["end_s"]), color="0.85", lw=0, zorder=0)
        for d in schedule.downlinks:
            if d.satellite == s:
                ax.axvspan(x(d.start), x(d.end), color="#d53f8c", alpha=0.5, lw=0, zorder=1)
        js = [j for j in range(inst.n_orbits) if inst.orbit_satellite[j] == name]
        if js:
            edges = np.r_[inst.orbit_start[js], inst.orbit_end[js][-1]]
            cap = np.asarray(inst.memory_capacity, dtype=float)[js]
            ax.stairs(cap, x(edges), baseline=None, color="#c53030", ls="--", lw=1, zorder=2)
        t, store = prof[name]
        ax.plot(x(t), store, color="#2b6cb0", lw=1.2, zorder=3)
        ax.set_ylabel(f"{name}\nstore", fontsize=7)
        ax.set_ylim(bottom=0)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in axes[:-1]:  # one shared time axis, labelled under the last panel
        ax.tick_params(labelbottom=False)
        ax.xaxis.offsetText.set_visible(False)
    axes[0].set_title("data on board per satellite", fontsize=9, pad=20)
    axes[0].legend(
        handles=[
            Line2D([], [], color="#2b6cb0", lw=1.2, label="store (memory in use)"),
            Line2D([], [], color="#c53030", ls="--", lw=1, label="capacity"),
            Patch(color="0.85", label="contact window"),
            Patch(color="#d53f8c", alpha=0.5, label="downlink"),
        ],
        fontsize=7,
        loc="lower center",
        bbox_to_anchor=(0.5, 1.0),
        ncol=4,
        frameon=False,
    )
    if utc_x:
        import matplotlib.dates as mdates

        loc = mdates.AutoDateLocator()
        axes[-1].xaxis.set_major_locator(loc)
        axes[-1].xaxis.set_major_formatter(mdates.ConciseDateFormatter(loc))
        axes[-1].set_xlabel("UTC")
    else:
        axes[-1].set_xlabel("hours from the epoch")


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
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument("schedule", help="schedule file (.json)")
    p.add_argument(
        "-o", "--output", required=True, help="figure to write: .png, .pdf or .svg (by extension)"
    )
    p.add_argument("--title", default=None, help="figure title")
    p.add_argument(
        "--utc",
        action="store_true",
        help="Gantt time axis in UTC clock time (default: seconds from each orbit's start)",
    )
    p.add_argument(
        "--max-orbits",
        type=positive(int),
        default=60,
        metavar="N",
        help="at most N orbit rows, those with observations first (60); the output says how "
        "many of how many are drawn",
    )
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
    info = plot_schedule(
        inst, sched, args.output, title=args.title, max_orbits=args.max_orbits, utc=args.utc
    )
    info["output"] = args.output
    n = {k: f"{info[k]} {w}{'' if info[k] == 1 else 's'}" for k, w in WORDS.items()}
    shown = "" if info["orbits"] == info["orbits_total"] else f" (of {info['orbits_total']})"
    text = (
        f"wrote {args.output}: {n['observations']} ({n['clusters']}) on {n['orbits']}{shown}, "
        f"{n['observed']} observed"
        + ("" if info["tracks"] else "; ground tracks unknown for this instance")
    )
    if "stores" in info:
        text += f"; store over time of {info['stores']} satellite(s), {info['downlinks']} downlinks"
    sys.stdout.write((json.dumps(info) if args.json else text) + "\n")
    return 0
