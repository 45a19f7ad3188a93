"""``sosp report``: the paper's Tables 3-4 and Figures 2-5 from a results database.

Tables (Markdown and CSV), one per scenario group: ``table3`` (B1..B10, targets over a large
area), ``table4`` (C1..C10, a small area) and ``table_other`` (instance files), in the paper's
column layout: SN, EN, TN; PBA-STC's bound R* (and the targets F of its schedule); RDS-STC's
proven optimum R, F; ACO-LS-STC's and ASA-DTC's mean profit R, mean observed targets F, sample
standard deviation SD of the profit and mean run time T; IMP, the relative improvement of
ASA-DTC over ACO-LS-STC, and a one-tailed Welch t-test at the 0.05 level (``+`` when ASA-DTC
is significantly better); then sosp's own columns, the best proven bound (the optimum when a
run proved it) and the best known profit of any valid run. ``<table>_methods`` has every
method's R, F, SD, T side by side (the numbers of Fig. 2).

Labels are short and stable (:func:`short_label`): the paper's configuration of a method is
``<method>@paper`` (ASA with ``preset=paper``), other parameter sets ``<method>[k=v,...]``.
A method without runs loses its columns, with a note.

Figures (PNG, matplotlib with the Agg backend), one panel per scenario group:

* ``fig2_methods.png``: mean profit of the eight methods of the paper's Fig. 2 per scenario;
* ``fig3_clustering.png``: ASA-DTC vs ASA-STC vs ASA-NONTC (Fig. 3);
* ``fig4_profit_memory.png`` and ``fig5_profit_energy.png``: profit/memory and profit/energy
  ratios of the same methods (Figs. 4-5).

Legends sit below the panels, outside the data. When methods are missing the report degrades:
their columns are omitted, Figures 3-5 show the clustering variants that exist, a method's
line needs runs on two scenarios of a group (one point is not a line), and a figure with
nothing to draw is left out; ``report.md`` says so in a note.
Failed runs (status ``error``) and schedules the validator rejects are left out of every
mean and counted in the notes. The days of ``sosp simulate --db`` (table ``simulations``), when
there are any, get their own table (``simulations.md/.csv``, :func:`build_simulations_table`).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import os
import re
import statistics
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sosp.errors import InputError

#: The clustering comparison of Figs. 3-5 (paper section 6.4-6.5).
CLUSTERING = ("asa-dtc", "asa-stc", "asa-nontc")

#: The eight methods of Fig. 2 (paper section 6.3), in the paper's order of merit.
FIG2 = ("asa-dtc", "asa-stc", "ts-stc", "aco-ls-stc", "aco-stc", "ga-stc", "sa-stc", "hpfs-stc")

#: Parameter sets that make a method the paper's configuration, labelled ``<method>@paper``:
#: ASA's Algorithm 1 as published (``preset="paper"``, ``docs/asa.md``).
PAPER_PARAMS: dict[str, tuple[dict[str, Any], ...]] = {
    m: ({"preset": "paper"},) for m in ("asa-dtc", "asa-stc", "asa-nontc")
}

#: Table 3-4 columns in the paper's layout: (column title, method labels in order of
#: preference). ASA-DTC is the target of IMP and the t-test, ACO-LS-STC the baseline.
PAPER_METHODS = {
    "PBA-STC": ("pba-stc",),
    "RDS-STC": ("rds-stc",),
    "ACO-LS-STC": ("aco-ls-stc",),
    "ASA-DTC": ("asa-dtc@paper", "asa-dtc"),
}

#: When no ACO-LS-STC runs exist, IMP and the t-test compare with the first of these (noted).
BASELINE_FALLBACK = ("asa-stc@paper", "asa-stc")

#: Significance level of the one-tailed t-test.
ALPHA = 0.05

#: Statuses whose schedules count (a heuristic's, a proven optimum, an incumbent at the limit).
COUNTED = ("optimal", "feasible", "time_limit")

GROUPS = {
    "B": ("table3", "Table 3: first group (targets over a large area)"),
    "C": ("table4", "Table 4: second group (targets in a small area)"),
    "": ("table_other", "Other scenarios (instance files)"),
}


def scenario_group(name: str) -> str:
    """``"B"`` or ``"C"`` for the paper's scenarios, ``""`` otherwise."""
    return name[0] if re.fullmatch(r"[BC](10|[1-9])", name) else ""


def _scenario_order(name: str) -> tuple[int, str, int, str]:
    g = scenario_group(name)
    return (0 if g else 1, g, int(name[1:]) if g else 0, name)


#: What a :class:`Cell` keeps of each counted run: its profit, observed targets, run time and
#: profit per unit of energy and of memory.
MEASURES = ("profit", "observed", "runtime", "per_energy", "per_memory")


@dataclass
class Cell:
    """The runs of one method on one scenario (errors and infeasible schedules left out):
    each of :data:`MEASURES` per run."""

    runs: dict[str, list[float]] = field(default_factory=lambda: {m: [] for m in MEASURES})
    failed: int = 0
    infeasible: int = 0

    @property
    def n(self) -> int:
        return len(self.runs["profit"])

    def mean(self, measure: str) -> float:
        """The mean of ``measure`` (one of :data:`MEASURES`) over the runs (NaN without)."""
        return sum(self.runs[measure]) / self.n if self.n else math.nan

    @property
    def sd(self) -> float:
        """Sample standard deviation of the profits (0 for a single run)."""
        profits = self.runs["profit"]
        return statistics.stdev(profits) if self.n > 1 else (0.0 if self.n else math.nan)


@dataclass
class Summary:
    """Everything the tables and figures need, read from one database."""

    scenarios: list[str] = field(default_factory=list)
    methods: list[str] = field(default_factory=list)
    cells: dict[tuple[str, str], Cell] = field(default_factory=dict)
    #: Per scenario: its EN and TN (observable targets, opportunities).
    sizes: dict[str, tuple[int, int]] = field(default_factory=dict)
    bound: dict[str, float] = field(default_factory=dict)
    exact: dict[str, tuple[float, int]] = field(default_factory=dict)
    best: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: Per (scenario, label): the least bound of the method's runs (PBA-STC's R*) and the
    #: count stored with it (PBA-STC's F*; None in databases of schema 1).
    method_bound: dict[tuple[str, str], tuple[float, int | None]] = field(default_factory=dict)
    #: Per (scenario, label): the profit and count of a run that proved optimality (RDS-STC).
    method_exact: dict[tuple[str, str], tuple[float, int]] = field(default_factory=dict)
    #: Per (scenario, label): the downlink figures (the validator's ``report.downlink``, kept
    #: in each run's verdict) of its counted runs on an instance with ground stations.
    downlink: dict[tuple[str, str], list[dict[str, Any]]] = field(default_factory=dict)
    #: The days of ``sosp simulate --db`` (rows of table ``simulations``).
    simulations: list[dict[str, Any]] = field(default_factory=list)


def short_label(method: str, params_json: str) -> str:
    """A short, stable label: ``<method>@paper`` for the paper's configuration of a method
    (:data:`PAPER_PARAMS`), else the method and its parameters (``name[k=v,...]``)."""
    from sosp.campaign.spec import method_label

    params = json.loads(params_json) if params_json else {}
    if params and params in PAPER_PARAMS.get(method, ()):
        return f"{method}@paper"
    return method_label(method, params_json)


def bounds_the_problem(method: str, params_json: str) -> bool:
    """Whether a run's bound and proven optimum are of sosp's problem (``docs/model.md``).

    The static-clustering and no-clustering methods (``*-stc``, ``*-nontc``, ``rds``) and
    the MILP's ``task`` and ``static`` models solve restricted problems: their optimum is a
    schedule of sosp's problem, not its optimum, and their bound (PBA-STC's R*) bounds only
    the restricted problem (a dynamic clustering may exceed it). Such runs fill their own
    columns (PBA-STC R*, RDS-STC R) but not "sosp bound" or "proven"."""
    if method.endswith(("-stc", "-nontc")) or method == "rds":
        return False
    params = json.loads(params_json) if params_json else {}
    return not (method == "milp" and params.get("model", "cluster") != "cluster")


def summarise(db: str | os.PathLike[str]) -> Summary:
    """Read a results database (read-only) and aggregate runs per scenario and method."""
    from sosp.campaign.store import Store

    with Store(db, readonly=True) as st:
        rows = st.rows()
        insts = st.instances()
        sims = st.simulations()
    if not rows and not sims:
        raise InputError("no runs stored", source=str(db))
    labels = [short_label(r["method"], r["params"]) for r in rows]
    tls: dict[str, set[float]] = defaultdict(set)
    for label, r in zip(labels, rows, strict=True):
        tls[label].add(r["time_limit"])
    sm = Summary(simulations=sims)
    cells: dict[tuple[str, str], Cell] = defaultdict(Cell)
    for label, r in zip(labels, rows, strict=True):
        s, tl = r["scenario"], r["time_limit"]
        if len(tls[label]) > 1:  # runs at several time limits: a label for each
            label += f"@{tl:g}s" if tl else "@nolimit"
        key = (s, label)
        cell = cells[key]
        if r["status"] == "error":
            cell.failed += 1
            continue
        if not r["feasible"]:
            cell.infeasible += 1
            continue
        full = bounds_the_problem(r["method"], r["params"])
        if r["bound"] is not None:
            if full:
                sm.bound[s] = min(sm.bound.get(s, math.inf), float(r["bound"]))
            if float(r["bound"]) < sm.method_bound.get(key, (math.inf,))[0]:
                sm.method_bound[key] = (float(r["bound"]), r.get("bound_count"))
        if r["schedule"] is not None:  # any valid schedule, of any method: the best known
            sm.best[s] = max(sm.best.get(s, -math.inf), float(r["profit"]))
        if r["status"] == "optimal":
            sm.method_exact[key] = exact = (float(r["profit"]), int(r["observed"]))
            if full and exact[0] > sm.exact.get(s, (-math.inf,))[0]:
                sm.exact[s] = exact
        if r["status"] not in COUNTED:
            continue
        for x in ("energy", "memory"):
            r[f"per_{x}"] = r["profit"] / r[x] if r[x] else 0.0
        for m in MEASURES:
            cell.runs[m].append(float(r[m]))
        if r["verdict"] and '"downlink"' in r["verdict"]:  # an instance with stations
            sm.downlink.setdefault(key, []).append(json.loads(r["verdict"])["downlink"])
    sm.sizes = {i["scenario"]: (int(i["en"]), int(i["tn"])) for i in insts}
    sm.scenarios = sorted({s for s, _ in cells}, key=_scenario_order)
    sm.methods = sorted({m for _, m in cells})
    sm.cells = dict(cells)
    for (s, m), c in sorted(cells.items()):
        if c.failed:
            sm.notes.append(f"{s} {m}: {c.failed} failed run(s) left out")
        if c.infeasible:
            sm.notes.append(
                f"{s} {m}: {c.infeasible} schedule(s) rejected by the validator left out"
            )
    if len({i["fingerprint"] for i in insts}) > len(sm.sizes):
        sm.notes.append("some scenarios were run on more than one instance; EN/TN show one of them")
    return sm


# --------------------------------------------------------------------------- tables
def welch_greater(a: list[float], b: list[float]) -> float:
    """p-value of the one-tailed Welch t-test that mean(a) > mean(b) (NaN if undefined)."""
    if len(a) < 2 or len(b) < 2:
        return math.nan
    import warnings

    from scipy.stats import ttest_ind

    ma, mb = sum(a) / len(a), sum(b) / len(b)
    if len(set(a)) == 1 and len(set(b)) == 1:  # no spread: the test is undefined
        return 0.0 if ma > mb else (1.0 if ma < mb else math.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # near-constant samples
        return float(ttest_ind(a, b, equal_var=False, alternative="greater").pvalue)


def _fmt(x: float, digits: int = 1) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "_"
    if float(x).is_integer() and digits <= 1:
        return f"{x:.0f}"
    return f"{x:.{digits}f}"


def resolve(methods: list[str], *candidates: str) -> str | None:
    """The first of ``candidates`` that has runs (labels of :func:`short_label`)."""
    return next((c for c in candidates if c in methods), None)


def comparison(
    target: str | None, baseline: str | None, methods: list[str]
) -> tuple[str | None, str | None, list[str]]:
    """The labels IMP and the t-test compare among ``methods``, and notes on how they were
    chosen.

    Defaults (None): ASA-DTC in the paper's configuration (``asa-dtc@paper``, else
    ``asa-dtc``) against ACO-LS-STC (``aco-ls-stc``, else ASA-STC with a note).
    """
    notes: list[str] = []
    t = target if target is not None else resolve(methods, *PAPER_METHODS["ASA-DTC"])
    b = baseline if baseline is not None else resolve(methods, *PAPER_METHODS["ACO-LS-STC"])
    if b is None and (b := resolve(methods, *BASELINE_FALLBACK)) is not None:
        notes.append(f"IMP and t-test against {b}: no runs of aco-ls-stc")
    return t, b, notes


def build_paper_table(
    summary: Summary, group: str, target: str | None = None, baseline: str | None = None
) -> tuple[list[str], list[list[Any]], list[str]]:
    """Table 3 or 4 in the paper's column layout, then sosp's own columns.

    SN, EN, TN; PBA-STC R* and F* (its bound and the targets the bound covers; F, the targets
    of its schedule, when the runs were stored without F*); RDS-STC R, F (when
    it proved optimality, else ``_`` as in the paper); ACO-LS-STC and ASA-DTC mean R, F, SD,
    T; IMP (relative improvement of ``target`` over ``baseline``), the one-tailed Welch
    t-test and its p-value; then the best proven bound (the optimum when proven, marked
    ``opt``) and the best known profit of any run. A method without runs loses its columns
    (noted).
    """
    scen, present = _group(summary, group)
    cols = {t: m for t, cands in PAPER_METHODS.items() if (m := resolve(present, *cands))}
    missing = [(t, cands[0]) for t, cands in PAPER_METHODS.items() if t not in cols]
    notes = [f"{t} columns omitted: no runs of {m}" for t, m in missing]
    target, baseline, cnotes = comparison(target, baseline, present)
    notes += cnotes
    header = ["SN", "EN", "TN"]
    pba = cols.get("PBA-STC")
    bounds = [summary.method_bound.get((s, pba)) for s in scen]
    star = pba is not None and all(b[1] is not None for b in bounds if b)
    if pba is not None:
        header += ["PBA-STC R*", "PBA-STC F*" if star else "PBA-STC F"]
        if not star:
            notes.append("PBA-STC F: targets of its schedule (runs stored without F*)")
    if "RDS-STC" in cols:
        header += ["RDS-STC R", "RDS-STC F"]
    for title in ("ACO-LS-STC", "ASA-DTC"):
        if title in cols:
            header += [f"{title} R", f"{title} F", f"{title} SD", f"{title} T (s)"]
    compare = _compared(target, baseline, present, notes)
    if compare:
        header += ["IMP", "t-test", "p"]
        notes.append(f"IMP and t-test: {target} against {baseline}")
    header += ["sosp bound", "proven", "sosp best"]
    rows: list[list[Any]] = []
    for s in scen:
        row: list[Any] = [s, *summary.sizes.get(s, (None, None))]
        if pba is not None:  # R*, and F* or the mean targets of its schedules
            r_star, f_star = summary.method_bound.get((s, pba), (None, None))
            c = summary.cells.get((s, pba))
            row += [r_star, f_star if star else c and c.mean("observed")]
        if "RDS-STC" in cols:
            row += summary.method_exact.get((s, cols["RDS-STC"])) or [None, None]
        for title in ("ACO-LS-STC", "ASA-DTC"):
            if title in cols:
                row += _rfst(summary.cells.get((s, cols[title])))
        if compare:
            row += _imp(summary, s, target, baseline)  # type: ignore[arg-type]
        ex = summary.exact.get(s)
        row += [ex[0] if ex else summary.bound.get(s), "opt" if ex else "", summary.best.get(s)]
        rows.append(row)
    return header, rows, notes


def _group(summary: Summary, group: str) -> tuple[list[str], list[str]]:
    """The scenarios of ``group`` and the method labels with runs on any of them."""
    scen = [s for s in summary.scenarios if scenario_group(s) == group]
    return scen, [m for m in summary.methods if any((s, m) in summary.cells for s in scen)]


def _compared(
    target: str | None, baseline: str | None, present: list[str], notes: list[str]
) -> bool:
    """Whether IMP and the t-test can be computed; if not, the reason goes into ``notes``."""
    if target in present and baseline in present and target != baseline:
        return True
    defaults = ("asa-dtc (the default --method)", "aco-ls-stc (the default --baseline)")
    missing = [
        x or d for x, d in zip((target, baseline), defaults, strict=True) if x not in present
    ]
    notes.append(
        "IMP and t-test omitted: "
        + (f"no runs of {', '.join(missing)}" if missing else "target equals baseline")
    )
    return False


def _rfst(c: Cell | None) -> list[Any]:
    """A method's R, F, SD, T on one scenario (None without a valid run)."""
    return (
        [c.mean("profit"), c.mean("observed"), c.sd, c.mean("runtime")] if c and c.n else [None] * 4
    )


def _imp(summary: Summary, s: str, target: str, baseline: str) -> list[Any]:
    """IMP, t-test sign and p-value of one scenario (paper Tables 3-4, last columns)."""
    t, b = summary.cells.get((s, target)), summary.cells.get((s, baseline))
    if t and b and t.n and b.n and b.mean("profit"):
        imp = (t.mean("profit") - b.mean("profit")) / b.mean("profit")
        p = welch_greater(t.runs["profit"], b.runs["profit"])
        return [imp, "+" if p < ALPHA else "", p]
    return [None, "", None]


def build_methods_table(
    summary: Summary, group: str, target: str | None = None, baseline: str | None = None
) -> tuple[list[str], list[list[Any]], list[str]]:
    """Every method's R, F, SD, T side by side (the numbers of Fig. 2), IMP and t-test."""
    scen, methods = _group(summary, group)
    notes: list[str] = []
    target, baseline, _ = comparison(target, baseline, methods)
    header = ["SN", "EN", "TN", "bound", "exact R", "exact F", "best R"]
    for m in methods:
        header += [f"{m} R", f"{m} F", f"{m} SD", f"{m} T (s)"]
    compare = _compared(target, baseline, methods, notes)
    if compare:
        header += [f"IMP ({target} vs {baseline})", "t-test", "p"]
    rows: list[list[Any]] = []
    for s in scen:
        exact = summary.exact.get(s) or (None, None)
        bounds = [summary.bound.get(s), *exact, summary.best.get(s)]
        row: list[Any] = [s, *summary.sizes.get(s, (None, None)), *bounds]
        for m in methods:
            row += _rfst(summary.cells.get((s, m)))
        if compare:
            row += _imp(summary, s, target, baseline)  # type: ignore[arg-type]
        rows.append(row)
    return header, rows, notes


def build_downlink_table(summary: Summary) -> tuple[list[str], list[list[Any]]]:
    """Per scenario with ground stations and method, the means over its counted runs of the
    validator's downlink figures: profit delivered and observed, observations delivered,
    latency (minutes from an observation's end to the end of its last downlink: each run's
    mean, 95th percentile and max), the largest store of any satellite, what is left on board
    and each station's use (minutes of downlink)."""
    stations = sorted(
        {g for runs in summary.downlink.values() for d in runs for g in d["station_seconds"]}
    )
    header = ["SN", "method", "runs", "delivered R", "observed R", "delivered F"]
    header += ["latency mean (min)", "latency p95 (min)", "latency max (min)"]
    header += ["store peak", "left on board"] + [f"{g} use (min)" for g in stations]

    def mean(xs: list[float | None], scale: float = 1.0) -> float | None:
        xs = [x for x in xs if x is not None]
        return sum(xs) / len(xs) / scale if xs else None

    rows: list[list[Any]] = []
    for (s, m), runs in sorted(
        summary.downlink.items(), key=lambda kv: (_scenario_order(kv[0][0]), kv[0][1])
    ):
        row: list[Any] = [s, m, len(runs)]
        row += [
            mean([d[k] for d in runs]) for k in ("delivered_profit", "observed_profit", "delivered")
        ]
        row += [mean([d["latency_s"][k] for d in runs], 60.0) for k in ("mean", "p95", "max")]
        row.append(mean([max(d["store_peak"].values(), default=0.0) for d in runs]))
        row.append(mean([d["on_board_end"] for d in runs]))
        row += [mean([d["station_seconds"].get(g, 0.0) for d in runs], 60.0) for g in stations]
        rows.append(row)
    return header, rows


def build_simulations_table(summary: Summary) -> tuple[list[str], list[list[Any]]]:
    """Per scenario, method (with its time limit) and kind of day (urgent targets per hour,
    outage hours, cloud forecast, freeze), over the days of ``sosp simulate --db``: how many,
    the mean realised profit, that of the plan that knew everything, their ratio (the mean of
    each day's), the mean changes and the re-plan time (mean of the means, max of the max)."""
    groups: dict[tuple[str, str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in summary.simulations:
        method = r["method"] + (f"@{r['time_limit']:g}s" if r["time_limit"] else "")
        day = (
            f"{r['rate']:g}/h, {r['outage_hours']:g} h out, cloud {r['cloud']:g}, "
            f"freeze {r['freeze']:g} s"
        )
        groups[(r["scenario"], method, day)].append(r)
    header = ["SN", "method", "day", "runs", "realised R", "hindsight R", "ratio (%)"]
    header += ["changes", "re-plan mean (s)", "re-plan max (s)"]
    rows: list[list[Any]] = []
    keys = ("realised_profit", "hindsight_profit", "ratio", "changes", "replan_s_mean")
    for (s, m, day), runs in sorted(groups.items()):
        real, hind, ratio, changes, t = (statistics.fmean(r[k] for r in runs) for k in keys)
        t_max = max(r["replan_s_max"] for r in runs)
        rows.append([s, m, day, len(runs), real, hind, 100 * ratio, changes, t, t_max])
    return header, rows


def _csv_text(header: list[str], rows: list[list[Any]]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow(["" if v is None or (isinstance(v, float) and math.isnan(v)) else v for v in r])
    return buf.getvalue()


def _markdown(header: list[str], rows: list[list[Any]], methods: list[str]) -> str:
    """The table in Markdown, each row's best mean profit among ``methods`` in bold."""
    r_cols = [header.index(f"{m} R") for m in methods if f"{m} R" in header]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        best = max((r[i] for i in r_cols if r[i] is not None), default=None)
        out = []
        for i, (h, v) in enumerate(zip(header, r, strict=True)):
            digits = 2 if h.endswith((" SD", " (s)")) or h == "p" else 1
            digits = 3 if h.startswith("IMP") else digits
            text = v if isinstance(v, str) else _fmt(v, digits)
            if i in r_cols and best is not None and v == best:
                text = f"**{text}**"
            out.append(text)
        lines.append("| " + " | ".join(out) + " |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- figures
#: Scenarios a method needs in a panel for its line: one point is not a line.
MIN_POINTS = 2

#: The y axis of each measure drawn.
YLABELS = {
    "profit": "mean profit",
    "per_memory": "profit / memory",
    "per_energy": "profit / energy",
}

#: The figures: file stem -> (measure drawn, title). Fig. 2 draws the methods of :data:`FIG2`,
#: the others those of :data:`CLUSTERING`.
FIGURES = {
    "fig2_methods": ("profit", "Fig. 2: methods"),
    "fig3_clustering": ("profit", "Fig. 3: dynamic vs static vs no task clustering"),
    "fig4_profit_memory": ("per_memory", "Fig. 4: profit-memory ratio"),
    "fig5_profit_energy": ("per_energy", "Fig. 5: profit-energy ratio"),
}

#: Panel titles by scenario group.
PANELS = {"B": "(a) first group", "C": "(b) second group", "": "other scenarios"}


def figure_series(
    summary: Summary, methods: list[str], measure: str
) -> tuple[dict[str, dict[str, list[float]]], list[str]]:
    """What a figure can draw: per scenario group, per method, ``measure`` per scenario of
    the group (NaN where the method has no valid run), for the methods with at least
    :data:`MIN_POINTS` scenarios in the group; and notes naming the lines left out.

    A group none of whose methods has enough scenarios has no panel; a figure without any
    panel is not drawn (:func:`write_report` says so in a note).
    """
    panels: dict[str, dict[str, list[float]]] = {}
    left_out: list[str] = []
    for g in ("B", "C", ""):
        scen = [s for s in summary.scenarios if scenario_group(s) == g]
        if not scen:
            continue
        lines: dict[str, list[float]] = {}
        for m in methods:
            cells = [summary.cells.get((s, m)) for s in scen]
            ys = [c.mean(measure) if c and c.n else math.nan for c in cells]
            points = sum(not math.isnan(y) for y in ys)
            if points >= MIN_POINTS:
                lines[m] = ys
            elif points:
                left_out.append(f"{m} in {PANELS[g]} (runs on {points} scenario)")
        if lines:
            panels[g] = lines
    notes = []
    if left_out:
        notes.append(f"lines left out (fewer than {MIN_POINTS} scenarios): {', '.join(left_out)}")
    return panels, notes


def _figure(
    summary: Summary,
    panels: dict[str, dict[str, list[float]]],
    ylabel: str,
    title: str,
    path: Path,
) -> None:
    """Draw ``panels`` (:func:`figure_series`) side by side, one legend for all of them
    below the panels (outside the data), and write the PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sosp.io import atomic_output

    groups = list(panels)
    n = len(groups)
    fig, axes = plt.subplots(1, n, figsize=(6.0 * n, 4.6), squeeze=False, layout="constrained")
    handles: dict[str, Any] = {}
    methods = [m for g in groups for m in panels[g]]
    colour = {m: f"C{i}" for i, m in enumerate(dict.fromkeys(methods))}
    for ax, g in zip(axes[0], groups, strict=True):
        scen = [s for s in summary.scenarios if scenario_group(s) == g]
        x = list(range(len(scen)))
        for m, ys in panels[g].items():
            (line,) = ax.plot(x, ys, marker="o", label=m, color=colour[m])
            handles.setdefault(m, line)
        ax.set_xticks(x, scen, rotation=45 if len(scen) > 10 else 0)
        ax.set(xlabel="scenario", ylabel=ylabel, title=PANELS[g])
        ax.grid(alpha=0.3)
    fig.legend(
        list(handles.values()),
        list(handles),
        loc="outside lower center",
        ncol=min(len(handles), 4),
        fontsize=8,
        frameon=False,
    )
    fig.suptitle(title)
    with atomic_output(path, suffix=".png") as tmp:  # atomic, with the user's umask
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


# --------------------------------------------------------------------------- report
def write_report(
    db: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    target: str | None = None,
    baseline: str | None = None,
) -> dict[str, Any]:
    """Write the tables (Markdown, CSV), figures (PNG) and ``report.md`` into ``out_dir``.

    Per scenario group: ``<table>.md/.csv`` in the paper's layout
    (:func:`build_paper_table`) and ``<table>_methods.md/.csv`` with every method
    (:func:`build_methods_table`). ``target`` and ``baseline`` name the methods IMP and the
    t-test compare (labels of :func:`short_label`; default ASA-DTC against ACO-LS-STC,
    :func:`comparison`).

    Returns
    -------
    dict
        ``files`` written, ``notes`` and the ``methods`` found.
    """
    from sosp.io import atomic_write_text

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("-o: not a folder", source=str(out))
    summary = summarise(db)
    ctarget, cbaseline, _ = comparison(target, baseline, summary.methods)
    ctarget, cbaseline = ctarget or "asa-dtc", cbaseline or "aco-ls-stc"  # named, if absent
    out.mkdir(parents=True, exist_ok=True)
    files: list[str] = []
    notes = list(summary.notes)
    md = [f"# Results of {Path(db).name}", ""]
    for g, (stem, title) in GROUPS.items():
        if not any(scenario_group(s) == g for s in summary.scenarios):
            continue
        header, rows, tnotes = build_paper_table(summary, g, target, baseline)
        mheader, mrows, _ = build_methods_table(summary, g, target, baseline)
        short = title.split(":")[0]
        for name, head, theader, trows, bold in (  # each table in Markdown and CSV
            (stem, title, header, rows, ["RDS-STC", "ACO-LS-STC", "ASA-DTC"]),
            (f"{stem}_methods", f"{short}, every method", mheader, mrows, summary.methods),
        ):
            text = _markdown(theader, trows, bold)
            atomic_write_text(out / f"{name}.md", f"## {head}\n\n{text}")
            atomic_write_text(out / f"{name}.csv", _csv_text(theader, trows))
            files += [f"{name}.md", f"{name}.csv"]
            md += [f"## {head}", "", text]
        notes += [f"{short}: {n}" for n in tnotes]
    # only instances with ground stations have downlink figures
    extra: list[tuple[str, str, list[str], list[list[Any]]]] = []
    if summary.downlink:
        head = "Downlink: delivered profit, data latency, memory and station use"
        extra.append(("downlink", head, *build_downlink_table(summary)))
    if summary.simulations:
        head = "Simulated days: realised profit against a plan that knew everything"
        extra.append(("simulations", head, *build_simulations_table(summary)))
    for name, head, header, rows in extra:
        text = _markdown(header, rows, [])
        atomic_write_text(out / f"{name}.md", f"## {head}\n\n{text}")
        atomic_write_text(out / f"{name}.csv", _csv_text(header, rows))
        files += [f"{name}.md", f"{name}.csv"]
        md += [f"## {head}", "", text]
    for name in ("table3", "table4") if summary.scenarios else ():  # runs of bench
        if f"{name}.md" not in files:
            notes.append(f"{name}: no scenarios of that group in the database")

    bare = {m: m.split("[")[0].split("@")[0] for m in summary.methods}
    clustering = [m for m in summary.methods if bare[m] in CLUSTERING]
    if summary.scenarios and (absent := [m for m in CLUSTERING if m not in bare.values()]):
        notes.append(f"Figures 3-5: no runs of {', '.join(absent)}")
    # a method of Fig. 2 in the paper's configuration when both exist
    fig2 = {x: resolve(summary.methods, f"{x}@paper", x) for x in FIG2}
    if summary.scenarios and (absent := [x for x, m in fig2.items() if m is None]):
        notes.append(f"Fig. 2: no runs of {', '.join(absent)}")
    for stem, (measure, title) in FIGURES.items() if summary.scenarios else ():
        ms = [m for m in fig2.values() if m] if stem == "fig2_methods" else clustering
        name = f"{stem}.png"
        panels, fnotes = figure_series(summary, ms, measure)
        short = title.split(":")[0]
        notes += [f"{short}: {n}" for n in fnotes]
        if not panels:
            # not drawn from a single point or from other methods: said instead
            why = f"no method ran on {MIN_POINTS} or more scenarios of a group"
            if not ms:
                why = "no runs of its methods"
            notes.append(f"{short} ({name}) left out: {why}")
            (out / name).unlink(missing_ok=True)  # no stale figure from an earlier report
            continue
        _figure(summary, panels, YLABELS[measure], title, out / name)
        files.append(name)
        md += [f"![{title}]({name})", ""]
    if notes:
        md += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    if summary.scenarios:  # runs of sosp bench
        md += [
            "R: mean profit, F: mean observed targets, SD: sample standard deviation of the "
            "profit, T: mean run time (s); PBA-STC R*: its upper bound on the static problem, "
            "PBA-STC F*: the targets its bound covers (PBA-STC F, when shown: targets of its "
            "schedule); RDS-STC R, F: "
            "its proven optimum ('_' when it did not finish, as in the paper); IMP: (R of "
            f"{ctarget} - R of {cbaseline}) / R of {cbaseline}; t-test: one-tailed Welch test "
            f"at {ALPHA} ('+': {ctarget} significantly better), p its p-value; sosp bound: the "
            "best proven upper bound of any run that bounds sosp's problem, not a static or "
            "no-clustering one ('opt' when an exact run proved it optimal), "
            "sosp best: the best profit of any valid run; exact R, F: a proven optimum.",
            "",
        ]
    if summary.downlink:
        md += [
            "Downlink (instances with ground stations, docs/model.md D1-D8): means over the "
            "counted runs; delivered R: profit of the observations whose data all reached the "
            "ground, observed R: of all observed; delivered F: observations delivered; latency: "
            "from an observation's end to the end of its last downlink (each run's mean, 95th "
            "percentile and max, in minutes); store peak: the most data any satellite held; "
            "left on board: memory units never sent; <station> use: minutes of downlink.",
            "",
        ]
    res: dict[str, Any] = {"files": files, "notes": notes, "methods": summary.methods}
    if summary.simulations:
        md += [
            "Simulated days (sosp simulate --db, docs/replan.md): day: urgent targets per "
            "hour, hours of outage, forecast probability of cover, freeze; runs: the days "
            "(seeds) stored; realised R: mean realised profit, hindsight R: that of a plan "
            "that knew every event at the start, ratio: the mean of each day's realised / "
            "hindsight; changes: mean per day; re-plan mean, max: seconds per re-plan.",
            "",
        ]
        header, rows = extra[-1][2:]
        res["simulations"] = [dict(zip(header, r, strict=True)) for r in rows]
    atomic_write_text(out / "report.md", "\n".join(md))
    files.append("report.md")
    return res


def add_report_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``report`` to the ``sosp`` subcommands."""
    p = subparsers.add_parser(
        "report",
        help="tables 3-4 and figures 2-5 of the paper from a results database",
        description="Write the paper's tables (Markdown, CSV) and figures (PNG) from a "
        "database made by sosp bench.",
    )
    p.add_argument("db", help="results database (sosp bench --db)")
    p.add_argument("-o", "--output", default="report", help="output folder (report)")
    p.add_argument(
        "--method",
        help="method whose improvement is measured (default asa-dtc@paper, else asa-dtc)",
    )
    p.add_argument(
        "--baseline",
        help="method it is compared with (default aco-ls-stc, else asa-stc@paper or asa-stc)",
    )
    p.set_defaults(func=cmd_report)
    return p


def cmd_report(args: argparse.Namespace) -> int:
    """Handler of ``sosp report``."""
    res = write_report(args.db, args.output, target=args.method, baseline=args.baseline)
    res["output"] = args.output
    text = f"wrote {len(res['files'])} files to {args.output}: {', '.join(res['files'])}"
    text += "".join(f"\nnote: {n}" for n in res["notes"])
    if sims := res.get("simulations"):
        table = _markdown(list(sims[0]), [list(r.values()) for r in sims], [])
        text += f"\nsimulated days:\n{table.rstrip()}"
    sys.stdout.write((json.dumps(res) if args.json else text) + "\n")
    return 0
