"""``sosp report``: the tables' numbers equal those recomputed from the database's rows."""

from __future__ import annotations

import csv
import json
import sqlite3
import statistics
from pathlib import Path

import pytest
from scipy.stats import ttest_ind

from sosp.campaign import Store, campaign_from_options
from sosp.campaign.runner import run_campaign
from sosp.cli import main
from sosp.report import short_label, welch_greater

# Synthetic profits of the ASA variants on B1 and C1 (the report does not care who made them).
FAKE = {
    ("B1", "asa-dtc"): [620.0, 624.0, 631.0],
    ("B1", "asa-stc"): [610.0, 618.0, 612.0],
    ("B1", "asa-nontc"): [600.0, 605.0, 601.0],
    ("C1", "asa-dtc"): [500.0, 505.0, 499.0],
    ("C1", "asa-stc"): [503.0, 506.0, 511.0],
}


def _fake_row(scenario: str, fp: str, method: str, seed: int, profit: float, **kw) -> dict:
    row = {
        "scenario": scenario,
        "fingerprint": fp,
        "method": method,
        "params": "{}",
        "seed": seed,
        "time_limit": 5.0,
        "status": "feasible",
        "message": None,
        "profit": profit,
        "observed": int(profit // 6),
        "bound": None,
        "energy": 2 * profit,
        "memory": profit + 10 * seed,
        "runtime": 0.5 * seed,
        "iterations": None,
        "feasible": 1,
        "verdict": "{}",
        "schedule": "{}",
        "version": "test",
        "finished_at": "2026-01-01T00:00:00+00:00",
    }
    row.update(kw)
    return row


@pytest.fixture(scope="module")
def db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("report") / "r.db"
    camp = campaign_from_options("B1,C1", "greedy", "1-3", "5")
    with Store(path) as st:
        run_campaign(camp, st, workers=1)
        fps = {i["scenario"]: i["fingerprint"] for i in st.instances()}
        for (s, m), profits in FAKE.items():
            for seed, p in enumerate(profits, start=1):
                st.put(_fake_row(s, fps[s], m, seed, p))
        st.put(_fake_row("B1", fps["B1"], "milp", 1, 640.0, status="optimal", bound=640.0))
        st.put(_fake_row("B1", fps["B1"], "asa-dtc", 9, 0.0, status="error", feasible=None))
    # greedy's real runs observe every target of B1 (618), which proves them optimal by the
    # cap; the fake rows above go beyond it, so that proof is dropped for them to stand
    con = sqlite3.connect(path)
    with con:
        con.execute("UPDATE runs SET status='feasible', bound=NULL WHERE method='greedy'")
    con.close()
    return path


def _db_profits(db: Path, scenario: str, method: str) -> list[float]:
    con = sqlite3.connect(db)
    try:
        rows = con.execute(
            "SELECT profit FROM runs WHERE scenario=? AND method=? AND status!='error' "
            "AND feasible=1",
            (scenario, method),
        ).fetchall()
    finally:
        con.close()
    return [r[0] for r in rows]


def _read_csv(path: Path) -> dict[str, dict[str, str]]:
    with path.open() as fh:
        return {r["SN"]: r for r in csv.DictReader(fh)}


def test_report_tables_match_the_database(db: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "rep"
    argv = ["report", str(db), "-o", str(out), "--baseline", "asa-stc", "--json"]
    assert main(argv) == 0
    res = json.loads(capsys.readouterr().out)
    for name in ("table3.md", "table3.csv", "table4.md", "table4.csv", "report.md"):
        assert name in res["files"]
    t3, t4 = _read_csv(out / "table3_methods.csv"), _read_csv(out / "table4_methods.csv")
    assert set(t3) == {"B1"} and set(t4) == {"C1"}
    con = sqlite3.connect(db)
    en, tn = con.execute("SELECT en, tn FROM instances WHERE scenario='B1'").fetchone()
    con.close()
    assert (int(t3["B1"]["EN"]), int(t3["B1"]["TN"])) == (en, tn)
    assert float(t3["B1"]["bound"]) == 640.0 and float(t3["B1"]["exact R"]) == 640.0
    assert t4["C1"]["bound"] == "" and t4["C1"]["exact R"] == ""
    con = sqlite3.connect(db)
    for table, s in ((t3, "B1"), (t4, "C1")):
        (best,) = con.execute(
            "SELECT MAX(profit) FROM runs WHERE scenario=? AND feasible=1", (s,)
        ).fetchone()
        assert float(table[s]["best R"]) == best  # the best known: any valid run of any method
    con.close()
    for table, s in ((t3, "B1"), (t4, "C1")):
        for m in ("greedy", "asa-dtc", "asa-stc"):
            ps = _db_profits(db, s, m)
            assert float(table[s][f"{m} R"]) == pytest.approx(statistics.mean(ps))
            assert float(table[s][f"{m} SD"]) == pytest.approx(statistics.stdev(ps))
        dtc, stc = _db_profits(db, s, "asa-dtc"), _db_profits(db, s, "asa-stc")
        imp = (statistics.mean(dtc) - statistics.mean(stc)) / statistics.mean(stc)
        col = "IMP (asa-dtc vs asa-stc)"
        assert float(table[s][col]) == pytest.approx(imp)
        p = ttest_ind(dtc, stc, equal_var=False, alternative="greater").pvalue
        assert float(table[s]["p"]) == pytest.approx(p)
        assert table[s]["t-test"] == ("+" if p < 0.05 else "")
    assert t3["B1"]["t-test"] == "+" and t4["C1"]["t-test"] == ""  # B1 better, C1 worse
    assert "asa-nontc R" not in t4["C1"] or t4["C1"]["asa-nontc R"] == ""
    assert float(t3["B1"]["asa-dtc T (s)"]) == pytest.approx(1.0)  # the error row left out
    md = (out / "table3_methods.md").read_text()
    assert "**640**" in md  # the best mean profit of the row in bold (milp)
    report = (out / "report.md").read_text()
    assert "1 failed run(s) left out" in report
    assert "downlink.md" not in res["files"] and "Downlink" not in report  # no stations


FIGURES = (
    "fig2_methods.png",
    "fig3_clustering.png",
    "fig4_profit_memory.png",
    "fig5_profit_energy.png",
)


@pytest.fixture(scope="module")
def fig_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two scenarios per group; asa-nontc ran on C1 alone (one point: no line)."""
    path = tmp_path_factory.mktemp("figs") / "f.db"
    with Store(path) as st:
        run_campaign(campaign_from_options("B1,B2,C1,C2", "greedy", "1", "5"), st, workers=1)
        fps = {i["scenario"]: i["fingerprint"] for i in st.instances()}
        for s in ("B1", "B2", "C1", "C2"):
            for k, m in enumerate(("asa-dtc", "asa-stc")):
                for seed in (1, 2):
                    st.put(_fake_row(s, fps[s], m, seed, 600.0 - 10 * k + seed))
        st.put(_fake_row("C1", fps["C1"], "asa-nontc", 1, 500.0))
    return path


def test_report_figures_are_pngs_with_both_groups(fig_db: Path, tmp_path: Path, capsys) -> None:
    import matplotlib.image as mpimg

    out = tmp_path / "rep"
    assert main(["report", str(fig_db), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    for name in FIGURES:
        img = mpimg.imread(out / name)
        assert img.shape[1] > img.shape[0] > 100  # two panels side by side
        assert img.std() > 0.01  # something drawn
    assert not list(out.glob(".*"))  # no temp files left behind
    # asa-nontc's single point is no line: left out of Figs. 3-5 with a note
    assert "asa-nontc in (b) second group (runs on 1 scenario)" in text
    report = (out / "report.md").read_text()
    assert all(f"]({name})" in report for name in FIGURES)


def test_figures_from_a_single_scenario_are_left_out(db: Path, tmp_path: Path, capsys) -> None:
    """One scenario per group: every line would be a single point, so no figure is drawn,
    and report.md says why instead of linking it."""
    out = tmp_path / "rep"
    out.mkdir()
    (out / "fig2_methods.png").write_bytes(b"stale")  # from an earlier report
    assert main(["report", str(db), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert not any((out / name).exists() for name in FIGURES)
    report = (out / "report.md").read_text()
    assert "![" not in report
    for n, name in enumerate(FIGURES, start=2):
        assert f"Fig. {n} ({name}) left out: no method ran on 2 or more scenarios" in report
    assert "left out" in text


def test_figure_series_keeps_lines_of_two_points_or_more(fig_db: Path) -> None:
    from sosp.report import figure_series, summarise

    summary = summarise(fig_db)
    panels, notes = figure_series(summary, ["asa-dtc", "asa-nontc", "milp"], "profit")
    assert list(panels) == ["B", "C"]
    assert list(panels["C"]) == ["asa-dtc"] and list(panels["B"]) == ["asa-dtc"]
    assert panels["C"]["asa-dtc"] == pytest.approx([601.5, 601.5])
    assert notes == [
        "lines left out (fewer than 2 scenarios): asa-nontc in (b) second group "
        "(runs on 1 scenario)"
    ]


def test_report_degrades_without_the_asa_methods(tmp_path: Path, capsys) -> None:
    path = tmp_path / "g.db"
    with Store(path) as st:
        run_campaign(campaign_from_options("C2", "greedy", "1-2"), st, workers=1)
    out = tmp_path / "rep"
    assert main(["report", str(path), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "IMP and t-test omitted" in text and "Figures 3-5" in text
    assert not (out / "table3.csv").exists()
    header = (out / "table4_methods.csv").read_text().splitlines()[0]
    assert "IMP" not in header and "greedy R" in header
    paper = (out / "table4.csv").read_text().splitlines()[0].split(",")
    assert paper == ["SN", "EN", "TN", "sosp bound", "proven", "sosp best"]
    assert "no runs of aco-ls-stc" in text and "Fig. 2: no runs of asa-dtc" in text
    # issue 63, item 9: what is missing is named, not "?" or "None"
    assert "?" not in text and "None" not in (out / "report.md").read_text()
    assert "no runs of asa-dtc (the default --method)" in text
    # no ASA runs: Figs. 3-5 are left out (not drawn with other methods), said in a note;
    # greedy ran on C2 alone, so Fig. 2 has no line either
    assert not any((out / name).exists() for name in FIGURES)
    assert "Fig. 5 (fig5_profit_energy.png) left out: no runs of its methods" in text
    # no sosp simulate days stored: nothing about them
    assert "simulat" not in text.lower() and not (out / "simulations.md").exists()
    assert "Simulated" not in (out / "report.md").read_text()


def test_report_bad_input(tmp_path: Path, capsys) -> None:
    assert main(["report", str(tmp_path / "none.db"), "-o", str(tmp_path / "o")]) == 2
    assert "not found" in capsys.readouterr().err
    empty = tmp_path / "e.db"
    Store(empty).close()
    assert main(["report", str(empty), "-o", str(tmp_path / "o")]) == 2
    assert "no runs" in capsys.readouterr().err


def test_welch_greater_edge_cases() -> None:
    assert welch_greater([1.0], [0.0, 1.0]) != welch_greater([1.0], [0.0, 1.0])  # NaN
    assert welch_greater([2.0, 2.0], [1.0, 1.0]) == 0.0
    assert welch_greater([3.0, 4.0, 5.0], [1.0, 2.0, 3.0]) == pytest.approx(
        ttest_ind([3, 4, 5], [1, 2, 3], equal_var=False, alternative="greater").pvalue
    )


# --------------------------------------------------------------------------- paper layout
PAPER = json.dumps({"preset": "paper"})
PAPER_FAKE = {  # (scenario, method, params): profits of seeds 1.. (C1 has no ACO-LS-STC)
    ("B1", "aco-ls-stc", "{}"): [600.0, 604.0, 602.0],
    ("B1", "asa-dtc", PAPER): [610.0, 615.0, 612.0],
    ("B1", "asa-dtc", "{}"): [650.0, 651.0, 652.0],  # sosp's defaults: not the paper's column
    ("C1", "asa-dtc", PAPER): [500.0, 502.0, 504.0],
    ("C1", "asa-stc", PAPER): [490.0, 491.0, 495.0],
}


@pytest.fixture(scope="module")
def paper_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("paper") / "p.db"
    with Store(path) as st:
        run_campaign(campaign_from_options("B1,C1", "hpfs-stc", "1", "5"), st, workers=1)
        fps = {i["scenario"]: i["fingerprint"] for i in st.instances()}
        for (s, m, params), profits in PAPER_FAKE.items():
            for seed, p in enumerate(profits, start=1):
                st.put(_fake_row(s, fps[s], m, seed, p, params=params))
        for seed, b, f in ((1, 700.0, 110), (2, 690.0, 108)):
            st.put(_fake_row("B1", fps["B1"], "pba-stc", seed, 590.0, bound=b, bound_count=f))
        st.put(_fake_row("B1", fps["B1"], "rds-stc", 1, 640.0, status="optimal", bound=640.0))
        # the cluster model's proof; the static and task models' are not of sosp's problem
        st.put(_fake_row("B1", fps["B1"], "milp", 1, 655.0, status="optimal", bound=655.0))
        task = json.dumps({"model": "task"})
        st.put(
            _fake_row("B1", fps["B1"], "milp", 1, 600.0, status="optimal", bound=600.0, params=task)
        )
        st.put(_fake_row("C1", fps["C1"], "rds-stc", 1, 480.0, status="time_limit", bound=560))
    return path


def test_short_labels_name_the_papers_configuration() -> None:
    assert short_label("asa-dtc", PAPER) == "asa-dtc@paper"
    assert short_label("asa-stc", PAPER) == "asa-stc@paper"
    assert short_label("asa-dtc", "{}") == "asa-dtc"
    assert short_label("asa-dtc", json.dumps({"replan": False})) == "asa-dtc[replan=False]"
    both = json.dumps({"preset": "paper", "seeds": 2})
    assert short_label("asa-dtc", both) == "asa-dtc[preset=paper,seeds=2]"  # not the preset
    assert short_label("ts-stc", PAPER) != "ts-stc@paper"  # only methods with a paper preset


def test_paper_tables_have_the_papers_columns(paper_db: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "rep"
    assert main(["report", str(paper_db), "-o", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert "asa-dtc@paper" in res["methods"] and "asa-dtc" in res["methods"]
    header = (out / "table3.csv").read_text().splitlines()[0].split(",")
    assert header == [
        "SN", "EN", "TN", "PBA-STC R*", "PBA-STC F*", "RDS-STC R", "RDS-STC F",
        "ACO-LS-STC R", "ACO-LS-STC F", "ACO-LS-STC SD", "ACO-LS-STC T (s)",
        "ASA-DTC R", "ASA-DTC F", "ASA-DTC SD", "ASA-DTC T (s)", "IMP", "t-test", "p",
        "sosp bound", "proven", "sosp best",
    ]  # fmt: skip
    b1 = _read_csv(out / "table3.csv")["B1"]
    assert float(b1["PBA-STC R*"]) == 690.0  # the least bound of its runs
    assert int(b1["PBA-STC F*"]) == 108  # the F* of that least bound, not of the schedule
    assert (float(b1["RDS-STC R"]), int(b1["RDS-STC F"])) == (640.0, 640 // 6)
    aco, dtc = PAPER_FAKE[("B1", "aco-ls-stc", "{}")], PAPER_FAKE[("B1", "asa-dtc", PAPER)]
    assert float(b1["ASA-DTC R"]) == pytest.approx(statistics.mean(dtc))  # not the defaults'
    assert float(b1["ACO-LS-STC SD"]) == pytest.approx(statistics.stdev(aco))
    imp = (statistics.mean(dtc) - statistics.mean(aco)) / statistics.mean(aco)
    assert float(b1["IMP"]) == pytest.approx(imp)
    p = ttest_ind(dtc, aco, equal_var=False, alternative="greater").pvalue
    assert float(b1["p"]) == pytest.approx(p) and b1["t-test"] == "+"
    # RDS-STC's 640 and PBA-STC's 690 are the static problem's; the task model's 600 its own
    assert (float(b1["sosp bound"]), b1["proven"]) == (655.0, "opt")
    assert float(b1["sosp best"]) == 655.0  # any valid run, sosp's defaults included
    c1 = _read_csv(out / "table4.csv")["C1"]
    assert c1["RDS-STC R"] == "" and "PBA-STC R*" not in c1  # unfinished: '_'; no runs: out
    assert c1["sosp bound"] == "" and c1["proven"] == ""  # RDS-STC's 560 bounds the static one
    # No ACO-LS-STC on C1: IMP there is against ASA-STC in the paper's configuration, noted.
    stc, dtc = PAPER_FAKE[("C1", "asa-stc", PAPER)], PAPER_FAKE[("C1", "asa-dtc", PAPER)]
    assert "ACO-LS-STC R" not in c1
    assert float(c1["IMP"]) == pytest.approx((statistics.mean(dtc) / statistics.mean(stc)) - 1)
    assert "Table 4: IMP and t-test against asa-stc@paper: no runs of aco-ls-stc" in res["notes"]
    md = (out / "table3.md").read_text()
    assert "| SN | EN | TN | PBA-STC R* |" in md and "**640**" in md
    assert "Fig. 2: no runs of ts-stc, aco-stc, ga-stc, sa-stc" in res["notes"]


def test_imp_falls_back_to_asa_stc_without_aco_ls(paper_db: Path, tmp_path: Path) -> None:
    import shutil

    db = tmp_path / "noaco.db"
    shutil.copy(paper_db, db)
    con = sqlite3.connect(db)
    con.execute("DELETE FROM runs WHERE method IN ('aco-ls-stc', 'pba-stc', 'rds-stc')")
    con.commit()
    con.close()
    res = main(["report", str(db), "-o", str(tmp_path / "rep")])
    assert res == 0
    b1 = _read_csv(tmp_path / "rep" / "table3.csv")["B1"]
    assert "IMP" not in b1  # B1 has neither ACO-LS-STC nor ASA-STC runs
    header = (tmp_path / "rep" / "table3.csv").read_text().splitlines()[0]
    assert "PBA-STC" not in header and "RDS-STC" not in header and "ACO-LS-STC" not in header
    report = (tmp_path / "rep" / "report.md").read_text()
    assert "Table 4: IMP and t-test against asa-stc@paper: no runs of aco-ls-stc" in report
    assert "Table 3: IMP and t-test omitted: no runs of" in report
    assert "PBA-STC columns omitted: no runs of pba-stc" in report


def test_downlink_figures_in_the_database_and_the_report(tmp_path: Path, capsys) -> None:
    """The bench keeps the validator's downlink figures in each run's verdict; the report's
    downlink table holds their means, and nothing about downlinks without stations."""
    from sosp.scenarios import generate_scenario
    from sosp.stations import builtin_stations

    inst = generate_scenario("C1", hours=4)
    inst = inst.with_stations([s for s in builtin_stations() if s.id in ("SG", "MIY", "KSH")])
    inst.save(tmp_path / "c1s.json")
    path = tmp_path / "d.db"
    with Store(path) as st:
        camp = campaign_from_options(str(tmp_path / "c1s.json"), "greedy;orbit-dp", "1", "2")
        run_campaign(camp, st, workers=1)
        rows = st.rows()
    assert len(rows) == 2 and all(r["feasible"] for r in rows)
    down = {r["method"]: json.loads(r["verdict"])["downlink"] for r in rows}
    for r in rows:  # the profit stored is what reached the ground (D8)
        assert r["profit"] == down[r["method"]]["delivered_profit"] > 0
    out = tmp_path / "rep"
    assert main(["report", str(path), "-o", str(out), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert {"downlink.md", "downlink.csv"} <= set(res["files"])
    with (out / "downlink.csv").open() as fh:
        table = {r["method"]: r for r in csv.DictReader(fh)}
    assert set(table) == {"greedy", "orbit-dp"}
    for m, t in table.items():
        d = down[m]
        assert int(t["runs"]) == 1 and int(float(t["delivered F"])) == d["delivered"]
        assert float(t["delivered R"]) == d["delivered_profit"]
        assert float(t["observed R"]) == d["observed_profit"]
        for k in ("mean", "p95", "max"):
            assert float(t[f"latency {k} (min)"]) == pytest.approx(d["latency_s"][k] / 60)
        assert float(t["store peak"]) == pytest.approx(max(d["store_peak"].values()))
        for g in ("SG", "MIY", "KSH"):
            want = d["station_seconds"].get(g, 0.0) / 60
            assert float(t.get(f"{g} use (min)") or 0) == pytest.approx(want)
    assert "## Downlink" in (out / "report.md").read_text()
