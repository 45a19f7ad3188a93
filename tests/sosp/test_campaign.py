"""Campaign specs, the SQLite store and ``sosp bench`` on bad input (in-process, fast)."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import numpy as np
import pytest

import sosp.campaign.store as store_mod
from sosp.campaign import Store, campaign_from_options, load_campaign, parse_method, parse_seeds
from sosp.campaign.runner import run_campaign
from sosp.cli import main
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.result import Result, Status
from sosp.schedule import Schedule
from sosp.validate import validate
from tests.conftest import tiny_chain, tiny_cluster

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def inst_files(tmp_path: Path) -> list[str]:
    paths = []
    for make in (tiny_chain, tiny_cluster):
        p = tmp_path / f"{make.__name__}.json"
        make().save(p)
        paths.append(str(p))
    return paths


def _rows(db: Path) -> list[tuple]:
    con = sqlite3.connect(db)
    try:
        return con.execute(
            "SELECT scenario, fingerprint, method, params, seed, time_limit, status, profit, "
            "observed, schedule FROM runs ORDER BY scenario, method, params, seed"
        ).fetchall()
    finally:
        con.close()


# --------------------------------------------------------------------------- specs
def test_parse_seeds_ranges_lists_and_errors() -> None:
    assert parse_seeds("1-3,7,2") == (1, 2, 3, 7)
    assert parse_seeds([4, 5]) == (4, 5)
    assert parse_seeds(0) == (0,)
    for bad in ("3-1", "a", "", [1.5], True, "-1"):
        with pytest.raises(InputError):
            parse_seeds(bad)


def test_parse_method_params_are_json_and_canonical() -> None:
    m = parse_method("milp:model=cluster,mip_gap=0.01")
    assert m.name == "milp" and dict(m.params) == {"model": "cluster", "mip_gap": 0.01}
    assert m.label == "milp[mip_gap=0.01,model=cluster]"
    with pytest.raises(InputError):
        parse_method("milp:model")


def test_options_split_methods_with_several_parameters() -> None:
    c = campaign_from_options("B1-B3,C2", "greedy,milp:model=task,mip_gap=0.1", "1-2", "5,10")
    assert [s.label for s in c.scenarios] == ["B1", "B2", "B3", "C2"]
    assert [m.label for m in c.methods] == ["greedy", "milp[mip_gap=0.1,model=task]"]
    assert c.time_limits == (5.0, 10.0)
    assert c.size() == 4 * 2 * 2 * 2


def test_toml_campaign(tmp_path: Path, inst_files: list[str]) -> None:
    f = tmp_path / "c.toml"
    f.write_text(
        "[campaign]\nscenarios = ['tiny_chain.json', 'C3']\nseeds = '1-2'\ntime_limits = 3\n"
        "[[methods]]\nname = 'greedy'\n[[methods]]\nname = 'milp'\n"
        "params = { model = 'task' }\ntime_limits = [30]\n"
    )
    c = load_campaign(f)
    assert c.name == "c" and c.scenarios[0].path == str(tmp_path / "tiny_chain.json")
    assert c.methods[1].time_limits == (30.0,) and c.time_limits == (3.0,)
    assert c.size() == 2 * 2 * 2


@pytest.mark.parametrize("suffix", [".npz", ".json.gz"])
def test_instance_files_of_every_format_are_scenarios(tmp_path: Path, suffix: str) -> None:
    from tests.conftest import tiny_chain

    tiny_chain().save(tmp_path / f"t{suffix}")
    f = tmp_path / "c.toml"
    f.write_text(
        f"[campaign]\nscenarios = ['t{suffix}']\nseeds = 1\n[[methods]]\nname = 'greedy'\n"
    )
    assert load_campaign(f).scenarios[0].path == str(tmp_path / f"t{suffix}")


@pytest.mark.parametrize(
    "text, words",
    [
        ("[campaign\n", "malformed TOML"),
        ("[campaign]\nseeds = 1\n[[methods]]\nname='greedy'\n", "missing key 'scenarios'"),
        ("[campaign]\nscenarios=['B1']\nseeds=1\n", "methods"),
        ("[campaign]\nscenarios=['B11']\nseeds=1\n[[methods]]\nname='greedy'\n", "B11"),
        ("[campaign]\nscenarios=['B1']\nseeds=1\nfoo=2\n[[methods]]\nname='greedy'\n", "foo"),
        ("[campaign]\nscenarios=['B1']\nseeds=[-1]\n[[methods]]\nname='greedy'\n", "seeds"),
        ("[campaign]\nscenarios=['x.json']\nseeds=1\n[[methods]]\nname='greedy'\n", "x.json"),
        (
            "[campaign]\nscenarios=['x.npz']\nseeds=1\n[[methods]]\nname='greedy'\n",
            "not found: x.npz",
        ),
    ],
)
def test_malformed_campaign_files(tmp_path: Path, text: str, words: str) -> None:
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError) as exc:
        load_campaign(f)
    msg = str(exc.value)
    assert words in msg and "\n" not in msg and msg.startswith(str(f))


# --------------------------------------------------------------------------- store and runs
def test_bench_stores_validated_rows_and_resumes(tmp_path: Path, inst_files: list[str]) -> None:
    db = tmp_path / "r.db"
    argv = ["bench", "--scenarios", ",".join(inst_files), "--methods", "greedy"]
    argv += ["--seeds", "1-3", "--db", str(db), "--workers", "1"]
    assert main(argv) == 0
    rows = _rows(db)
    assert len(rows) == 2 * 3
    insts = {p: Instance.from_dict(json.loads(Path(p).read_text())) for p in inst_files}
    for scen, fp, method, params, seed, tl, status, profit, observed, sched in rows:
        inst = insts[scen]
        assert fp == inst.fingerprint and method == "greedy" and params == "{}" and tl == 0.0
        s = Schedule.from_dict(json.loads(sched), inst)
        rep = validate(inst, s)
        assert rep.feasible and rep.profit == profit and rep.observed == observed
        assert s.seed == seed and status == "feasible"
    with Store(db, readonly=True) as st:
        info = {r["scenario"]: r for r in st.instances()}
        assert info[inst_files[0]]["tn"] == insts[inst_files[0]].n_opps
        assert st.rows()[0]["version"]
    assert main(argv) == 0  # resume: nothing to run, nothing doubled
    assert _rows(db) == rows


def test_failures_are_stored_and_retried_only_on_request(
    tmp_path: Path, inst_files: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from sosp.registry import METHODS, Method

    monkeypatch.setitem(METHODS, "flaky", Method(f"{__name__}:solve_flaky_seed"))
    db = tmp_path / "r.db"
    c = campaign_from_options(inst_files[0], "flaky", "1-3")
    _FLAKY["fail"] = {2}
    with Store(db) as st:
        out = run_campaign(c, st, workers=1)
        assert (out.ran, out.failed) == (3, 1)
        errs = st.rows("status = 'error'")
        assert len(errs) == 1 and errs[0]["seed"] == 2
        assert errs[0]["message"] == "RuntimeError: boom second line"
        _FLAKY["fail"] = set()
        assert run_campaign(c, st, workers=1).ran == 0
        out = run_campaign(c, st, workers=1, retry_failed=True)
        assert (out.ran, out.failed) == (1, 0)
        assert st.count() == 3 and not st.rows("status = 'error'")


_FLAKY: dict[str, set[int]] = {"fail": set()}


def solve_flaky_seed(instance: Instance, *, rng: np.random.Generator, time_limit=None) -> Result:
    """Greedy that raises when the run's seed (recovered from ``rng``) is in ``_FLAKY``."""
    from heuristics.greedy import solve_greedy

    draw = int(rng.integers(1 << 62))
    for s in _FLAKY["fail"]:
        if int(np.random.default_rng(s).integers(1 << 62)) == draw:
            raise RuntimeError("boom\nsecond line")
    return solve_greedy(instance, rng=rng, time_limit=time_limit)


def _bad(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1
    return err


@pytest.fixture
def stored(tmp_path: Path, inst_files: list[str]) -> tuple[Path, list[str], list[tuple]]:
    db = tmp_path / "r.db"
    argv = ["bench", "--scenarios", inst_files[0], "--methods", "greedy", "--seeds", "1-2"]
    argv += ["--db", str(db), "--workers", "1"]
    assert main(argv) == 0
    return db, argv, _rows(db)


def test_unknown_method_or_scenario_touch_nothing(
    stored: tuple[Path, list[str], list[tuple]], capsys: pytest.CaptureFixture[str]
) -> None:
    db, argv, rows = stored
    capsys.readouterr()
    i = argv.index("--methods") + 1
    assert "nosuch" in _bad(argv[:i] + ["greedy,nosuch"] + argv[i + 1 :], capsys)
    assert "no parameter" in _bad(argv[:i] + ["greedy:bogus=1"] + argv[i + 1 :], capsys)
    j = argv.index("--scenarios") + 1
    assert "Z9" in _bad(argv[:j] + ["B1,Z9"] + argv[j + 1 :], capsys)
    assert _rows(db) == rows


def test_schema_1_databases_are_read_and_upgraded(tmp_path: Path) -> None:
    # A database of schema 1 had no bound_count column: readable as it is, upgraded in place
    # (nothing else touched) when a campaign writes to it again.
    path = tmp_path / "old.db"
    with Store(path) as st:
        run_campaign(campaign_from_options("B1", "greedy", "1", "5"), st, workers=1)
    con = sqlite3.connect(path)
    con.execute("ALTER TABLE runs DROP COLUMN bound_count")
    con.execute("DROP TABLE simulations")  # schema 3's
    con.execute("UPDATE meta SET value='1' WHERE key='schema_version'")
    con.commit()
    con.close()
    with Store(path, readonly=True) as st:
        (row,) = st.rows()
        assert "bound_count" not in row and row["profit"] > 0
    with Store(path) as st:
        run_campaign(campaign_from_options("B1", "pba-stc", "1", "5"), st, workers=1)
        rows = {r["method"]: r for r in st.rows()}
    assert rows["greedy"]["bound_count"] is None
    assert rows["pba-stc"]["bound_count"] > 0  # F*, stored with R*
    con = sqlite3.connect(path)
    version = con.execute("SELECT value FROM meta WHERE key='schema_version'").fetchone()
    assert version == (str(store_mod.SCHEMA_VERSION),)  # through every upgrade
    assert con.execute("SELECT COUNT(*) FROM simulations").fetchone() == (0,)
    con.close()


def test_other_schema_version_is_refused(
    stored: tuple[Path, list[str], list[tuple]], capsys: pytest.CaptureFixture[str]
) -> None:
    db, argv, rows = stored
    con = sqlite3.connect(db)
    con.execute("UPDATE meta SET value='999' WHERE key='schema_version'")
    con.commit()
    con.close()
    capsys.readouterr()
    argv = [a if a != "1-2" else "1-4" for a in argv]
    assert "schema version 999" in _bad(argv, capsys)
    assert _rows(db) == rows


def test_not_a_database_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "junk.db"
    db.write_text("not sqlite at all " * 100)
    assert "not a sosp results database" in _bad(
        ["bench", "--scenarios", "B1", "--methods", "greedy", "--db", str(db)], capsys
    )
    assert db.read_text().startswith("not sqlite")


def test_locked_database_is_refused(
    stored: tuple[Path, list[str], list[tuple]],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    db, argv, rows = stored
    monkeypatch.setattr(store_mod, "OPEN_TIMEOUT", 0.1)
    other = sqlite3.connect(db, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    try:
        capsys.readouterr()
        argv = [a if a != "1-2" else "1-4" for a in argv]
        assert "locked" in _bad(argv, capsys)
    finally:
        other.execute("ROLLBACK")
        other.close()
    assert _rows(db) == rows


def test_dry_run_counts_pending(
    stored: tuple[Path, list[str], list[tuple]], capsys: pytest.CaptureFixture[str]
) -> None:
    db, argv, rows = stored
    argv = [a if a != "1-2" else "1-5" for a in argv]
    capsys.readouterr()
    assert main([*argv, "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["total"], out["stored"], out["pending"]) == (5, 2, 3)
    assert _rows(db) == rows


def test_unavailable_methods_are_skipped_only_when_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    from sosp.campaign import campaign_from_dict
    from sosp.campaign.runner import check_methods
    from sosp.registry import METHODS, Method

    monkeypatch.setitem(METHODS, "notyet", Method("heuristics.not_written_yet:solve"))
    data = {
        "campaign": {"scenarios": ["B1"], "seeds": 1, "skip_unavailable": True},
        "methods": ["greedy", "notyet"],
    }
    usable, skipped = check_methods(campaign_from_dict(data))
    assert usable == ["greedy"] and skipped == ["notyet"]
    data["campaign"]["skip_unavailable"] = False
    with pytest.raises(InputError, match="not available"):
        check_methods(campaign_from_dict(data))


def test_per_method_seeds_and_time_limits(tmp_path: Path, inst_files: list[str]) -> None:
    from sosp.campaign import campaign_from_dict

    data = {
        "campaign": {"scenarios": [inst_files[0]], "seeds": "1-3", "time_limits": 2},
        "methods": [{"name": "greedy", "seeds": [7], "time_limits": [1, 4]}, "hpfs-stc"],
    }
    c = campaign_from_dict(data)
    assert c.size() == 2 + 3
    with Store(tmp_path / "r.db") as st:
        assert run_campaign(c, st, workers=1).ran == 5
        keys = sorted((r["method"], r["seed"], r["time_limit"]) for r in st.rows())
    assert keys[:2] == [("greedy", 7, 1.0), ("greedy", 7, 4.0)]
    assert keys[2:] == [("hpfs-stc", s, 2.0) for s in (1, 2, 3)]


def test_status_values_are_known() -> None:
    assert {s.value for s in Status} >= {"optimal", "feasible"}


# ----------------------------------------------------------------- nothing stray (issue 19)
def _sosp(*argv: str, cwd: Path):
    import shutil
    import subprocess
    import sys

    exe = shutil.which("sosp", path=str(Path(sys.executable).parent)) or shutil.which("sosp")
    cmd = [exe] if exe else [sys.executable, "-m", "sosp"]
    return subprocess.run(cmd + list(argv), capture_output=True, text=True, cwd=cwd, timeout=120)


def _one_line(proc, *needles: str) -> None:
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: ") and proc.stderr.count("\n") == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for needle in needles:
        assert needle in proc.stderr, proc.stderr


@pytest.mark.parametrize(
    ("methods", "needles"),
    [
        ("asa-dtc:presett=quality", ("presett", "valid: preset,")),
        ("asa-dtc:preset=fastest", ("preset: expected one of default, quality",)),
        ("orbit-dp:noise=2", ("noise: expected a number in [0, 1)",)),
        ("greedy,nosuch", ("nosuch",)),
    ],
)
def test_refused_bench_creates_no_database(tmp_path: Path, methods: str, needles) -> None:
    tiny_chain().save(tmp_path / "t.json")
    proc = _sosp(
        "bench", "--scenarios", "t.json", "--methods", methods, "--db", "r.db", cwd=tmp_path
    )
    _one_line(proc, *needles)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json"]


def test_bench_refused_after_opening_removes_the_new_database(tmp_path: Path) -> None:
    proc = _sosp(
        "bench", "--scenarios", "missing.json", "--methods", "greedy", "--db", "r.db", cwd=tmp_path
    )
    _one_line(proc, "missing.json")
    assert list(tmp_path.iterdir()) == []


def test_bench_db_option_checked_first(tmp_path: Path) -> None:
    (tmp_path / "adir").mkdir()
    for db, needle in (("adir", "is a folder"), ("nope/r.db", "folder does not exist")):
        proc = _sosp("bench", "--scenarios", "B1", "--methods", "greedy", "--db", db, cwd=tmp_path)
        _one_line(proc, "--db", needle)
    assert [p.name for p in tmp_path.iterdir()] == ["adir"] and not list(
        (tmp_path / "adir").iterdir()
    )


def test_dry_run_writes_nothing_and_report_leaves_no_side_files(tmp_path: Path) -> None:
    tiny_chain().save(tmp_path / "t.json")
    argv = ["bench", "--scenarios", "t.json", "--methods", "greedy", "--db", "r.db"]
    proc = _sosp(*argv, "--dry-run", "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["pending"] == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json"]
    proc = _sosp(*argv, "--workers", "1", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.db", "t.json"]
    before = (tmp_path / "r.db").read_bytes()
    proc = _sosp(*argv, "--seeds", "1-3", "--dry-run", "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (json.loads(proc.stdout)["stored"], json.loads(proc.stdout)["pending"]) == (1, 2)
    proc = _sosp("report", "r.db", "-o", "rep", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.db", "rep", "t.json"]
    assert (tmp_path / "r.db").read_bytes() == before
    import os
    import stat

    mask = os.umask(0)
    os.umask(mask)
    modes = {stat.S_IMODE(f.stat().st_mode) for f in (tmp_path / "rep").iterdir()}
    assert modes == {0o666 & ~mask}  # figures and tables: the user's normal permissions


def test_report_of_a_database_left_in_wal_mode_creates_no_side_files(tmp_path: Path) -> None:
    db = tmp_path / "r.db"
    with Store(db) as st:
        assert st.count() == 0
    con = sqlite3.connect(db)  # an older sosp left its databases in WAL mode
    assert con.execute("PRAGMA journal_mode=WAL").fetchone()[0] == "wal"
    con.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.db"]
    with Store(db, readonly=True, allow_empty=True) as ro:
        assert ro.count() == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.db"]


def test_bench_progress_counts_from_the_campaign_start() -> None:
    """The ETA and elapsed time count from the campaign's start, not from its first result
    (issue 63, item 15: "ETA 0:00:00" after the first of 12 runs)."""
    import io
    import time

    from sosp.campaign.progress import Progress

    out = io.StringIO()
    p = Progress(12, out, interactive=False, t0=time.monotonic() - 10.0)
    p.update({"status": "feasible"})
    assert "elapsed 0:00:10" in out.getvalue() and "ETA 0:01:50" in out.getvalue()


def test_a_killed_campaign_leaves_no_worker_behind(tmp_path) -> None:
    """Issue 63 item 10: a parent killed outright (a notebook kernel stopped) cannot close
    its pool; the workers notice and end instead of living on as orphans."""
    import os
    import signal
    import subprocess
    import sys
    import time

    code = (
        "import os, sys, time\n"
        "from sosp.parallel import completed\n"
        "def nap(i):\n"
        "    time.sleep(0.2 if i < 2 else 60)\n"
        "    return os.getpid()\n"
        "for pid in completed(nap, list(range(6)), 2):\n"
        "    print(pid, flush=True)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    workers = {int(proc.stdout.readline()), int(proc.stdout.readline())}
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.monotonic() + 10
    alive = set(workers)
    while alive and time.monotonic() < deadline:
        time.sleep(0.2)
        for pid in list(alive):
            try:
                done, _ = os.waitpid(pid, os.WNOHANG)  # not our child: raises
            except ChildProcessError:
                try:
                    os.kill(pid, 0)
                except ProcessLookupError:
                    alive.discard(pid)
    assert not alive, f"orphan workers {alive}"
