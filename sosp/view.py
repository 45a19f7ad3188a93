"""``sosp view``: a schedule as one interactive, self-contained HTML page.

The page works offline: plotly.js, the figures' data, the coastlines and a few lines of
script are all inside the file (no CDN, no map tile server). It shows

* **summary**: profit (as the validator computes it), the bound and gap the schedule file
  records, targets observed, and the resources each used orbit spends (energy, memory and
  openings as a share of the orbit's capacity) as a bar chart;
* **Gantt chart**: one row per satellite on a UTC time axis (zoom with the mouse), the orbits
  marked by ticks, one bar per observation (ordinary tasks blue, cluster-tasks orange);
  hovering a bar gives its orbit, target(s), weight, roll and UTC start and end;
* **map**: coastlines (Natural Earth 1:110m, shipped in ``sosp/data``), the satellites' ground
  tracks, each observation's strip (the ground point its sensor looks at, from the start to
  the end of the observation, at its roll) and the targets, observed or not. Longitude and
  latitude axes with equal scale, framed on the targets as ``sosp plot`` does. With more than
  :data:`SHOWN_TRACKS` satellites the tracks start hidden (one click on the legend shows one);
* **table** of the observations, sorted by clicking a column's header and filtered by the
  search box.

Plotly writes the figures (:mod:`plotly.graph_objects`; plotly.js embedded once, about 4.8 MB
of the page). It is an optional dependency (``pip install -e '.[view]'``). From
:data:`WEBGL_TARGETS` targets on, the map is drawn with WebGL (``scattergl``) so a
10,000-target page stays fluid; the ground tracks are sampled every :data:`TRACK_STEP`
seconds or coarser, at most :data:`MAX_TRACK_POINTS` points in all.
"""

from __future__ import annotations

import argparse
import html
import json
import sys
from datetime import datetime
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sosp.errors import InputError
from sosp.plot import TRACK_COLOURS, map_extent, map_lon

if TYPE_CHECKING:
    from sosp.instance import Instance
    from sosp.orbits import Satellite
    from sosp.schedule import Schedule

#: Seconds between ground-track points (at least; see :data:`MAX_TRACK_POINTS`).
TRACK_STEP = 60.0
#: At most this many ground-track points over all satellites (the step grows to keep it).
MAX_TRACK_POINTS = 40_000
#: With more satellites, their ground tracks start hidden (a click on the legend shows one).
SHOWN_TRACKS = 8
#: From this many targets on, the map's markers are drawn with WebGL.
WEBGL_TARGETS = 2000
#: Points along each observation strip.
STRIP_POINTS = 5
#: WGS84 semi-axes (km), for where a line of sight meets the ground.
WGS84_A, WGS84_B = 6378.137, 6356.7523142
#: Colours: tasks, cluster-tasks, observed and unobserved targets, strips.
TASK, CLUSTER, OBSERVED, UNOBSERVED, STRIP = "#2b6cb0", "#e8890c", "#2f855a", "#c53030", "#dd6b20"
#: Plotly's display options: no link to Plotly's cloud, no logo.
CONFIG = {"displaylogo": False, "responsive": True, "scrollZoom": True}


def coastlines() -> list[tuple[list[float], list[float]]]:
    """The shipped coastlines: ``(lon, lat)`` lists per polyline (Natural Earth 1:110m).

    Source and licence are recorded in the data file itself (``sosp/data/coastlines_110m.json``).
    """
    text = resources.files("sosp").joinpath("data/coastlines_110m.json").read_text("utf-8")
    return [(lon, lat) for lon, lat in json.loads(text)["lines"]]


def _lines(xs: list[np.ndarray], ys: list[np.ndarray], wrap: bool) -> tuple[np.ndarray, ...]:
    """Polylines as one pair of arrays separated by NaN (Plotly breaks a line there), also
    broken where the longitude jumps across the map's edge."""
    out_x, out_y = [], []
    for x, y in zip(xs, ys, strict=True):
        x = map_lon(x, wrap)
        cut = np.flatnonzero(np.abs(np.diff(x)) > 180.0) + 1
        x, y = np.insert(x, cut, np.nan), np.insert(np.asarray(y, dtype=float), cut, np.nan)
        out_x += [x, [np.nan]]
        out_y += [y, [np.nan]]
    if not out_x:
        return np.empty(0), np.empty(0)
    # float32: 1e-5 degree (a metre) is ample for a map and halves the page's share
    return np.concatenate(out_x).astype(np.float32), np.concatenate(out_y).astype(np.float32)


def ground_points(
    sats: list[Satellite], epoch: str, t: np.ndarray, roll: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Geodetic (lat, lon) in degrees, shape ``(len(sats), len(t))``, of the ground point each
    satellite looks at with roll ``roll`` (degrees, positive to the right of the ground
    track, per time; None: nadir, the sub-satellite point).

    The boresight is turned by the roll about the along-track axis in the pass frame of
    :mod:`sosp.visibility` and meets the WGS84 ellipsoid; NaN where it misses the Earth or the
    orbit is unknown.
    """
    from sosp.orbits import propagate

    r, v = propagate(sats, epoch, t)
    x = v / np.linalg.norm(v, axis=-1, keepdims=True)
    z = -r - np.sum(-r * x, axis=-1, keepdims=True) * x  # nadir in the cross-track plane
    z /= np.linalg.norm(z, axis=-1, keepdims=True)
    y = np.cross(z, x)  # to the right of the ground track
    th = np.radians(np.zeros(len(t)) if roll is None else np.asarray(roll, dtype=float))
    d = np.cos(th)[:, None] * z + np.sin(th)[:, None] * y
    if roll is None:  # the sub-satellite point: straight down to the centre
        d = -r / np.linalg.norm(r, axis=-1, keepdims=True)
    # the ellipsoid becomes a sphere of radius A when z is stretched by A/B
    s = np.array([1.0, 1.0, WGS84_A / WGS84_B])
    rs, ds = r * s, d * s
    a, b, c = np.sum(ds * ds, -1), np.sum(rs * ds, -1), np.sum(rs * rs, -1) - WGS84_A**2
    with np.errstate(invalid="ignore"):
        k = (-b - np.sqrt(b * b - a * c)) / a  # the nearer of the two crossings
    p = r + k[..., None] * d
    e2 = 1.0 - (WGS84_B / WGS84_A) ** 2
    lat = np.degrees(np.arctan2(p[..., 2], (1.0 - e2) * np.hypot(p[..., 0], p[..., 1])))
    return lat, np.degrees(np.arctan2(p[..., 1], p[..., 0]))


def _ms(epoch: str, t: np.ndarray) -> np.ndarray:
    """Milliseconds since 1970 UTC (Plotly's date axis) of ``t`` seconds from ``epoch``."""
    t0 = datetime.fromisoformat(epoch.replace("Z", "+00:00")).timestamp()
    return np.round((t0 + np.asarray(t, dtype=float)) * 1000.0)


def _observation_rows(inst: Instance, schedule: Schedule) -> list[dict[str, Any]]:
    """One dict per observation: what its hover text and its table row show."""
    from sosp.orbits import utc_at

    rows = []
    for u, ob in enumerate(schedule.observations):
        ks = sorted({int(inst.opp_target[i]) for i in ob.opps})
        rows.append(
            {
                "n": u + 1,
                "satellite": inst.orbit_satellite[ob.orbit],
                "orbit": inst.orbit_ids[ob.orbit],
                "start": utc_at(inst.epoch, ob.start),
                "end": utc_at(inst.epoch, ob.end),
                "duration": round(ob.end - ob.start, 2),
                "roll": round(ob.roll, 3),
                "targets": " ".join(inst.target_ids[k] for k in ks),
                "weight": int(inst.target_weight[ks].sum()),
            }
        )
    return rows


def _hover(row: dict[str, Any]) -> str:
    return (
        f"<b>{html.escape(row['orbit'])}</b> (observation {row['n']})<br>"
        f"target(s): {html.escape(row['targets'])}<br>weight {row['weight']}, "
        f"roll {row['roll']:.2f} deg, {row['duration']:.1f} s<br>"
        f"start {row['start']}<br>end {row['end']}"
    )


def gantt_figure(inst: Instance, schedule: Schedule, rows: list[dict[str, Any]]) -> Any:
    """The Gantt chart: a row per satellite, UTC time, a bar per observation, orbit ticks."""
    import plotly.graph_objects as go

    sats = list(inst.satellite_names)
    row_of = {s: r for r, s in enumerate(sats)}
    obs = schedule.observations
    fig = go.Figure()
    # orbit starts: short vertical ticks in each satellite's row, hover names the orbit
    ox, oy, otext, label = [], [], [], []
    for j in range(inst.n_orbits):
        sat, oid = inst.orbit_satellite[j], inst.orbit_ids[j]
        t = float(_ms(inst.epoch, [inst.orbit_start[j]])[0])
        ox += [t, t, None]
        oy += [row_of[sat] - 0.45, row_of[sat] + 0.45, None]
        otext += [f"orbit {oid} starts"] * 2 + [""]
        # the orbit's number in its row ("JB-3A#002" -> "#002"), at the top of its tick
        label += [oid[len(sat) :] if oid.startswith(sat) else oid, "", ""]
    fig.add_scatter(
        x=ox,
        y=oy,
        mode="lines+text",
        line={"color": "#a0aec0", "width": 1},
        text=label,
        textposition="bottom right",
        textfont={"size": 9, "color": "#718096"},
        name="orbit start",
        hovertext=otext,
        hoverinfo="text",
    )
    for label, colour, pick in (
        ("task", TASK, lambda ob: len(ob.opps) == 1),
        ("cluster-task", CLUSTER, lambda ob: len(ob.opps) > 1),
    ):
        idx = [u for u, ob in enumerate(obs) if pick(ob)]
        start = _ms(inst.epoch, [obs[u].start for u in idx])
        end = _ms(inst.epoch, [obs[u].end for u in idx])
        y = [row_of[inst.orbit_satellite[obs[u].orbit]] for u in idx]
        fig.add_bar(
            orientation="h",
            base=start,
            x=end - start,
            y=y,
            width=0.7,
            # an outline keeps a 10-second bar visible on a 24-hour axis
            marker={"color": colour, "line": {"color": colour, "width": 1.5}},
            name=f"{label} ({len(idx)})",
            legendgroup=label,
            hoverinfo="skip",
        )
        # Plotly hovers a bar only where its data is (a tenth of a pixel for 10 s of 24 h):
        # the details hang on an invisible marker at each bar's middle, found within 20 px
        fig.add_scatter(
            x=(start + end) / 2,
            y=y,
            mode="markers",
            marker={"size": 12, "color": "rgba(0,0,0,0)"},
            legendgroup=label,
            showlegend=False,
            hovertext=[_hover(rows[u]) for u in idx],
            hoverinfo="text",
            hoverlabel={"bgcolor": colour},
        )
    fig.update_layout(
        barmode="overlay",
        height=max(260, 60 + 40 * len(sats)),
        margin={"l": 10, "r": 10, "t": 40, "b": 40},
        legend={"orientation": "h", "yanchor": "bottom", "y": 1.0},
        xaxis={"type": "date", "title": "UTC"},
        yaxis={
            "tickvals": list(range(len(sats))),
            "ticktext": sats,
            "range": [len(sats) - 0.5, -0.5],
            "fixedrange": True,  # zoom in time only
        },
    )
    return fig


def map_figure(inst: Instance, schedule: Schedule) -> Any:
    """The map: coastlines, ground tracks, observation strips and targets (observed or not)."""
    import plotly.graph_objects as go

    from sosp.orbits import instance_satellites, utc_at

    x0, x1, y0, y1, wrap = map_extent(inst.target_lat, inst.target_lon)
    # one kind of trace for all, so they are drawn in order (WebGL draws above SVG)
    scatter = go.Scattergl if inst.n_targets >= WEBGL_TARGETS else go.Scatter
    fig = go.Figure()

    def lines(name: str, xy: tuple[np.ndarray, np.ndarray], **style: Any) -> None:
        fig.add_trace(scatter(x=xy[0], y=xy[1], mode="lines", name=name, **style))

    coast = coastlines()
    xy = _lines([np.asarray(c[0]) for c in coast], [np.asarray(c[1]) for c in coast], wrap)
    lines("coastline", xy, line={"color": "#a0aec0", "width": 1}, hoverinfo="skip")
    sats = instance_satellites(inst) or []
    strips = None
    if sats and inst.n_orbits:
        t0, t1 = float(inst.orbit_start.min()), float(inst.orbit_end.max())
        step = max(TRACK_STEP, (t1 - t0) * len(sats) / MAX_TRACK_POINTS)
        t = np.append(np.arange(t0, t1, step), t1)
        lat, lon = ground_points(sats, inst.epoch, t)
        for n, s in enumerate(sats):
            colour = TRACK_COLOURS[n % len(TRACK_COLOURS)]
            xy = _lines([lon[n]], [lat[n]], wrap)
            lines(
                s.name,
                xy,
                line={"color": colour, "width": 1},
                opacity=0.6,
                hoverinfo="name",
                # many tracks would hide the map: listed in the legend, a click shows one
                visible=True if len(sats) <= SHOWN_TRACKS else "legendonly",
            )
        # strips: the ground point looked at, start to end of each observation, at its roll
        sx, sy, snum = [], [], []
        obs = schedule.observations
        for s in sats:
            us = [u for u, ob in enumerate(obs) if inst.orbit_satellite[ob.orbit] == s.name]
            if not us:
                continue
            ts = np.linspace([obs[u].start for u in us], [obs[u].end for u in us], STRIP_POINTS)
            roll = np.broadcast_to([obs[u].roll for u in us], ts.shape)
            la, lo = ground_points([s], inst.epoch, ts.T.ravel(), roll.T.ravel())
            for m, u in enumerate(us):
                part = slice(m * STRIP_POINTS, (m + 1) * STRIP_POINTS)
                px, py = _lines([lo[0, part]], [la[0, part]], wrap)
                sx.append(px)
                sy.append(py)
                snum.append(np.full(len(px), u + 1, dtype=np.int32))
        if sx:
            strips = (np.concatenate(sx), np.concatenate(sy)), np.concatenate(snum)
    observed = np.zeros(inst.n_targets, dtype=bool)
    when: dict[int, str] = {}
    for ob in schedule.observations:
        for i in ob.opps:
            k = int(inst.opp_target[i])
            observed[k] = True
            when.setdefault(k, f"{inst.orbit_ids[ob.orbit]} {utc_at(inst.epoch, ob.start)}")
    lon = map_lon(inst.target_lon, wrap).astype(np.float32)

    def targets(label: str, mask: np.ndarray, marker: dict[str, Any]) -> None:
        ks = np.flatnonzero(mask)
        text = [
            f"<b>{html.escape(inst.target_ids[k])}</b> weight {int(inst.target_weight[k])}"
            + (f"<br>observed: {when[k]}" if k in when else "")
            for k in ks
        ]
        fig.add_trace(
            scatter(
                x=lon[ks],
                y=inst.target_lat[ks].astype(np.float32),
                mode="markers",
                marker=marker,
                name=f"{label} ({len(ks)})",
                hovertext=text,
                hoverinfo="text",
            )
        )

    # drawn in this order: the few observed targets and their strips over the many others
    targets("unobserved", ~observed, {"color": UNOBSERVED, "size": 5, "symbol": "x"})
    if strips is not None:
        (xy, num) = strips
        # the observation's number (its row in the table and its Gantt bar give the rest):
        # a full text per point would repeat it STRIP_POINTS times
        lines(
            "observation strip",
            xy,
            line={"color": STRIP, "width": 5},
            customdata=num,
            hovertemplate="observation %{customdata}<extra></extra>",
        )
    targets("observed", observed, {"color": OBSERVED, "size": 7, "symbol": "circle"})
    fig.update_layout(
        height=620,
        margin={"l": 10, "r": 10, "t": 30, "b": 40},
        legend={"orientation": "h", "yanchor": "bottom", "y": 1.0},
        xaxis={"range": [x0, x1], "title": "longitude (deg)" + (", 0-360" if wrap else "")},
        yaxis={"range": [y0, y1], "title": "latitude (deg)", "scaleanchor": "x"},
        plot_bgcolor="#f7fafc",
    )
    return fig


def resources_figure(inst: Instance, report: Any) -> Any:
    """Energy, memory and openings used per orbit, as a share of the orbit's capacity."""
    import plotly.graph_objects as go

    used = [u for u in report.orbits if u.openings]
    js = [inst.orbit_index[u.orbit] for u in used]
    names = [u.orbit for u in used]
    fig = go.Figure()
    for label, vals, caps, unit in (
        ("energy", [u.energy for u in used], inst.energy_capacity[js], "units"),
        ("memory", [u.memory for u in used], inst.memory_capacity[js], "units"),
        ("openings", [u.openings for u in used], inst.max_openings[js], ""),
    ):
        share = 100.0 * np.asarray(vals, dtype=float) / np.maximum(caps, 1e-12)
        fig.add_bar(
            x=names,
            y=np.round(share, 2),
            name=label,
            hovertext=[
                f"{n}: {label} {v:.1f} of {c:g} {unit}"
                for n, v, c in zip(names, vals, caps, strict=True)
            ],
            hoverinfo="text",
        )
    fig.update_layout(
        barmode="group",
        height=300,
        margin={"l": 10, "r": 10, "t": 30, "b": 80},
        legend={"orientation": "h", "yanchor": "bottom", "y": 1.0},
        yaxis={"title": "% of capacity", "range": [0, 105]},
    )
    return fig


def summary(inst: Instance, schedule: Schedule, report: Any) -> dict[str, Any]:
    """The figures at the top of the page."""
    bound = schedule.bound
    gap = None
    if bound is not None:  # as sosp.result.Result.gap
        gap = 0.0 if bound <= 0 else max(0.0, (bound - report.profit) / bound)
    return {
        "instance": inst.name or "instance",
        "method": schedule.method or "?",
        "status": schedule.status or "?",
        "profit": report.profit,
        "bound": bound,
        "gap": gap,
        "observed": report.observed,
        "targets": inst.n_targets,
        "observations": len(schedule),
        "clusters": sum(len(ob.opps) > 1 for ob in schedule.observations),
        "orbits_used": sum(1 for u in report.orbits if u.openings),
        "feasible": report.feasible,
        "violations": len(report.violations),
    }


TABLE_COLUMNS = (
    ("n", "#"),
    ("satellite", "satellite"),
    ("orbit", "orbit"),
    ("start", "start (UTC)"),
    ("end", "end (UTC)"),
    ("duration", "duration (s)"),
    ("roll", "roll (deg)"),
    ("targets", "target(s)"),
    ("weight", "weight"),
)

# Sorting (click a header; numbers as numbers) and searching (any cell contains the text).
SCRIPT = """
const table = document.getElementById("obs");
const body = table.tBodies[0];
document.getElementById("search").addEventListener("input", (e) => {
  const q = e.target.value.trim().toLowerCase();
  let shown = 0;
  for (const tr of body.rows) {
    const hit = !q || tr.textContent.toLowerCase().includes(q);
    tr.hidden = !hit;
    shown += hit;
  }
  document.getElementById("shown").textContent = shown;
});
table.tHead.querySelectorAll("th").forEach((th, col) => th.addEventListener("click", () => {
  const dir = th.dataset.dir === "asc" ? -1 : 1;
  table.tHead.querySelectorAll("th").forEach((h) => delete h.dataset.dir);
  th.dataset.dir = dir > 0 ? "asc" : "desc";
  const key = (tr) => {
    const v = tr.cells[col].textContent;
    return th.classList.contains("num") ? parseFloat(v) : v;
  };
  const rows = Array.from(body.rows).sort((a, b) => {
    const x = key(a), y = key(b);
    return dir * (x < y ? -1 : x > y ? 1 : 0);
  });
  body.append(...rows);
}));
Promise.all(FIGURES.map(([id, fig]) => Plotly.newPlot(id, fig.data, fig.layout, CONFIG)))
  .then(() => { document.body.dataset.ready = "1"; });
"""

STYLE = """
body { font-family: system-ui, sans-serif; margin: 1em 2em; color: #1a202c; }
.cards { display: flex; flex-wrap: wrap; gap: .6em; }
.card { border: 1px solid #e2e8f0; border-radius: 6px; padding: .4em .8em; }
.card b { display: block; font-size: 1.3em; }
table { border-collapse: collapse; font-size: .85em; }
th, td { border-bottom: 1px solid #e2e8f0; padding: .2em .6em; text-align: left; }
th { cursor: pointer; background: #edf2f7; position: sticky; top: 0; }
th[data-dir=asc]::after { content: " \\25B2"; } th[data-dir=desc]::after { content: " \\25BC"; }
td.num, th.num { text-align: right; }
td { white-space: nowrap; }
.scroll { max-height: 32em; overflow: auto; }
"""


def _fmt(v: Any) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return f"{v:g}" if v == int(v) else f"{v:.4g}"
    return str(v)


def view_page(
    instance: Instance, schedule: Schedule, title: str | None = None
) -> tuple[str, dict[str, Any]]:
    """The page of ``sosp view`` as one HTML string (plotly.js embedded) and its
    :func:`summary`."""
    from plotly.io import to_json
    from plotly.offline import get_plotlyjs

    from sosp.validate import validate

    report = validate(instance, schedule)
    rows = _observation_rows(instance, schedule)
    info = summary(instance, schedule, report)
    figures = [
        ("gantt", gantt_figure(instance, schedule, rows)),
        ("map", map_figure(instance, schedule)),
        ("resources", resources_figure(instance, report)),
    ]
    data = ",".join(f'["{name}", {to_json(fig, validate=False)}]' for name, fig in figures)
    gap = info["gap"]
    cards = [
        ("profit", _fmt(info["profit"])),
        ("bound", _fmt(info["bound"])),
        ("gap", "n/a" if gap is None else f"{100 * gap:.2f} %"),
        ("status", info["status"]),
        ("targets observed", f"{info['observed']} of {info['targets']}"),
        ("observations", f"{info['observations']} ({info['clusters']} cluster-tasks)"),
        ("orbits used", str(info["orbits_used"])),
        ("validator", "feasible" if info["feasible"] else f"{info['violations']} violations"),
    ]
    num = {"n", "duration", "roll", "weight"}
    head = "".join(
        f'<th class="{"num" if k in num else ""}">{html.escape(label)}</th>'
        for k, label in TABLE_COLUMNS
    )
    body = "\n".join(
        "<tr>"
        + "".join(
            f'<td class="{"num" if k in num else ""}">{html.escape(str(r[k]))}</td>'
            for k, _ in TABLE_COLUMNS
        )
        + "</tr>"
        for r in rows
    )
    name = title or f"{info['instance']}: {info['method']}, profit {_fmt(info['profit'])}"
    # "</" closes a script element wherever it appears: escape it in the embedded JSON
    script_data = f"const FIGURES = [{data}];\nconst CONFIG = {json.dumps(CONFIG)};".replace(
        "</", "<\\/"
    )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(name)}</title>
<style>{STYLE}</style>
<script>{get_plotlyjs()}</script></head>
<body>
<h1>{html.escape(name)}</h1>
<div class="cards">{"".join(f"<div class=card>{k}<b>{html.escape(v)}</b></div>" for k, v in cards)}
</div>
<h2>Observations per satellite (UTC; drag to zoom, double-click to reset)</h2>
<div id="gantt"></div>
<h2>Targets, ground tracks and observation strips</h2>
<div id="map"></div>
<h2>Resources used per orbit</h2>
<div id="resources"></div>
<h2>Observations (<span id="shown">{len(rows)}</span> shown)</h2>
<p><input id="search" type="search" placeholder="search: target, orbit, time..." size="40"></p>
<div class="scroll"><table id="obs"><thead><tr>{head}</tr></thead>
<tbody>
{body}
</tbody></table></div>
<script>{script_data}
{SCRIPT}</script>
</body></html>
"""
    return page, info


def write_view(
    instance: Instance, schedule: Schedule, path: str | Path, title: str | None = None
) -> dict[str, Any]:
    """Write :func:`view_page` to ``path`` atomically; returns the summary and the size."""
    from sosp.io import atomic_write_text

    text, info = view_page(instance, schedule, title)
    atomic_write_text(path, text)
    return {**info, "output": str(path), "bytes": len(text.encode("utf-8"))}


def require_plotly() -> None:
    """Raise a one-line :class:`InputError` when Plotly is not installed."""
    try:
        import plotly  # noqa: F401
    except ImportError:
        raise InputError(
            "sosp view needs Plotly, which is not installed: pip install -e '.[view]' "
            "(or pip install plotly)"
        ) from None


def add_view_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``view`` to the ``sosp`` subcommands."""
    p = subparsers.add_parser(
        "view",
        help="write a schedule as an interactive HTML page (Gantt chart, map, table)",
        description="Write one self-contained HTML page (works offline) with a zoomable "
        "Gantt chart per satellite, a map of targets, ground tracks and observation strips, "
        "a sortable and searchable table of the observations, and the summary figures.",
    )
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument("schedule", help="schedule file (.json)")
    p.add_argument("-o", "--output", required=True, help="HTML page to write")
    p.add_argument("--title", default=None, help="page title")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_view)
    return p


def cmd_view(args: argparse.Namespace) -> int:
    """Handler of ``sosp view``."""
    from sosp.instance import load_instance
    from sosp.io import check_output
    from sosp.schedule import load_schedule

    check_output(args.output)
    require_plotly()
    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    info = write_view(inst, sched, args.output, title=args.title)
    text = (
        f"wrote {args.output} ({info['bytes'] / 1e6:.1f} MB): {info['observations']} "
        f"observations, {info['observed']} of {info['targets']} targets observed, "
        f"profit {_fmt(info['profit'])}"
    )
    sys.stdout.write((json.dumps(info) if args.json else text) + "\n")
    return 0
