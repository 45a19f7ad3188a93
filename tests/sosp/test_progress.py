"""Progress reports (sosp.progress) and the CLI's status line: rate-limited snapshots, the line
on a terminal (rewritten with \\r) and elsewhere (a plain line every 10 s), ``--quiet``."""

from __future__ import annotations

import io
import os
import pty
import select
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sosp.progress import Progress, Snapshot, StatusLine, current, format_snapshot, reporting
from sosp.solve import solve
from sosp.stop import FirstOf, MaxIterations, SearchStatus
from tests.conftest import scenario, tiny_chain

ROOT = Path(__file__).resolve().parents[2]


class FakeClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_snapshots_are_rate_limited_by_time() -> None:
    clock = FakeClock()
    got: list[Snapshot] = []
    p = Progress(got.append, interval=1.0, clock=clock)
    p.start("m")
    status = SearchStatus(iteration=0, best=5.0)
    for i in range(100):  # 100 checks within the first second: none reported
        status.iteration = i
        clock.t = i * 0.009
        assert p(status) is False  # a criterion that never stops
    assert got == []
    clock.t = 1.0
    status.iteration = 200
    p(status)
    clock.t = 1.5
    p(status)  # too soon
    clock.t = 2.0
    status.iteration, status.best, status.bound = 500, 8.0, 10.0
    p(status)
    assert [(s.elapsed, s.iterations, s.best) for s in got] == [(1.0, 200, 5.0), (2.0, 500, 8.0)]
    assert got[0].rate is None and got[1].rate == pytest.approx(300.0)
    assert got[1].gap == pytest.approx(0.2) and got[0].gap is None
    assert p.last is got[1] and got[1].method == "m"


def test_update_without_best_keeps_the_last_and_force() -> None:
    clock = FakeClock()
    got: list[Snapshot] = []
    p = Progress(got.append, interval=10.0, clock=clock)
    p.update(1, 3.0, force=True)
    p.update(2, None)  # not due
    p.update(5, None, force=True)
    assert [(s.iterations, s.best) for s in got] == [(1, 3.0), (5, 3.0)]
    p.update(2, 4.0, force=True)  # iterations went back (a new phase): no rate
    assert got[-1].rate is None


def test_reporting_sets_the_current_progress() -> None:
    outer = current()
    p = Progress()
    with reporting(p) as q:
        assert q is p and current() is p
        with reporting(None) as silent:
            assert current() is silent and silent is not p
        assert current() is p
    assert current() is outer


def test_solve_passes_progress_to_the_search() -> None:
    got: list[Snapshot] = []
    solve(tiny_chain(), "asa-dtc", seed=0, iterations=3000, progress=Progress(got.append, 0.0))
    assert got and got[0].method == "asa-dtc"
    assert max(s.iterations for s in got) >= 2999
    assert all(s.best is not None and s.best > 0 for s in got)


def test_progress_does_not_change_a_seeded_run(c1) -> None:
    inst = c1
    for method, kw in (("asa-dtc", {"iterations": 300}), ("orbit-dp", {"iterations": 20})):
        a = solve(inst, method, seed=5, **kw)
        b = solve(inst, method, seed=5, progress=Progress(lambda s: None, 0.0), **kw)
        assert a.schedule.observations == b.schedule.observations


def test_first_of_with_progress_first_still_reports() -> None:
    got: list[Snapshot] = []
    p = Progress(got.append, 0.0)
    stop = FirstOf(p, MaxIterations(0))
    assert stop(SearchStatus()) and len(got) == 1


def test_format() -> None:
    line = format_snapshot(Snapshot("asa-dtc", 12.34, 900, 1234.0, 1300.0, 8100.4))
    assert line.split() == ("asa-dtc 12.3 s best 1234 bound 1300 gap 5.08% 8,100 it/s".split())
    assert format_snapshot(Snapshot("orbit-dp", 3.0, 0, None)).split() == ["orbit-dp", "3.0", "s"]


def snap(t: float, best: float = 1.0) -> Snapshot:
    return Snapshot("m", t, 10, best, None, 5.0)


def test_status_line_on_a_terminal_rewrites_in_place() -> None:
    out = io.StringIO()
    line = StatusLine(out, tty=True, delay=3.0)
    line(snap(1.0))
    assert out.getvalue() == ""  # quick solves stay quiet
    line(snap(3.5, best=12345.0))
    line(snap(4.0, best=2.0))
    text = out.getvalue()
    assert text.count("\r") == 2 and "\n" not in text
    # the shorter second line blanks out the rest of the first
    first, second = text.split("\r")[1:]
    assert len(second) == len(first)
    line.close()
    assert out.getvalue().endswith("\r") and "\n" not in out.getvalue()


def test_status_line_shows_within_a_second_by_default() -> None:
    """A user waiting on a terminal sees the line about a second in (issue 63, item 4)."""
    out = io.StringIO()
    line = StatusLine(out, tty=True)
    line(snap(0.6))
    assert out.getvalue() == ""  # solves of under a second stay quiet
    line(snap(1.1))
    assert "\r" in out.getvalue() and "1.1" in out.getvalue()


def test_status_line_elsewhere_prints_a_line_every_10_s() -> None:
    out = io.StringIO()
    line = StatusLine(out, tty=False, delay=3.0, every=10.0)
    for t in (1, 4, 9.9, 10.0, 12, 19.9, 20.5, 25):
        line(snap(t))
    lines = out.getvalue().splitlines()
    assert [ln.split()[1] for ln in lines] == ["10.0", "20.5"]
    assert "\r" not in out.getvalue()
    line.close()
    assert len(out.getvalue().splitlines()) == 2


# ------------------------------------------------------------------- the CLI on a terminal
def _run_on_a_terminal(args: list[str], cwd: Path) -> tuple[int, str]:
    """Run ``sosp ARGS`` with stderr on a pseudo-terminal; its exit code and stderr."""
    master, slave = pty.openpty()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sosp", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=slave,
    )
    os.close(slave)
    chunks = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], 0.5)
        if ready:
            try:
                data = os.read(master, 4096)
            except OSError:  # the child closed the terminal
                break
            if not data:
                break
            chunks.append(data)
        elif proc.poll() is not None:
            break
    os.close(master)
    return proc.wait(timeout=30), b"".join(chunks).decode()


@pytest.mark.slow
@pytest.mark.parametrize("quiet", [False, True])
def test_cli_status_line_and_quiet(tmp_path: Path, quiet: bool) -> None:
    inst = tmp_path / "c2.json"
    scenario("C2").save(inst)  # not C1: orbit-dp observes all of it and stops at once
    args = ["solve", str(inst), "--method", "orbit-dp", "--time-limit", "5", "-o", "s.json"]
    code, err = _run_on_a_terminal(args + (["--quiet"] if quiet else []), tmp_path)
    assert code == 0
    assert (tmp_path / "s.json").exists()
    if quiet:
        assert err == ""
    else:
        assert "\r" in err and "orbit-dp" in err and "best" in err and "it/s" in err


def test_log_records_clear_the_live_line_first() -> None:
    import logging

    out = io.StringIO()
    line = StatusLine(out, tty=True, delay=0.0)
    handler = logging.StreamHandler(out)
    handler.addFilter(line)
    logger = logging.getLogger("sosp.test_progress")
    logger.addHandler(handler)
    try:
        line(snap(1.0, best=42.0))
        logger.warning("something")
    finally:
        logger.removeHandler(handler)
    text = out.getvalue()
    drawn = text.split("\r")[1]
    assert text.endswith("\r" + " " * len(drawn) + "\rsomething\n")


def test_a_silent_method_gets_a_line_within_a_second(monkeypatch: pytest.MonkeyPatch) -> None:
    # issue 63 item 4: milp inside HiGHS (or a method's preparation) reports nothing: C10's
    # milp showed no status line in 25 s; the ticking thread draws one within a second, with
    # the last state known and the clock running
    import sosp.progress as progress_mod

    seen: list[Snapshot] = []
    prog = Progress(seen.append, interval=0.25)
    prog.start("milp")
    line = StatusLine(io.StringIO(), tty=True, delay=1.0)
    with progress_mod.reporting(prog), prog.ticking(0.05):
        prog.update(3, 17.0, 20.0, force=True)
        time.sleep(1.3)  # the method, silent in compiled code
    late = [s for s in seen if s.elapsed >= 1.0]
    assert late and late[0].elapsed < 1.3
    assert (late[0].best, late[0].bound, late[0].rate) == (17.0, 20.0, None)
    line(late[0])
    assert "best 17" in line.stream.getvalue() and "it/s" not in line.stream.getvalue()


def test_ticks_leave_the_searchs_reports_their_slots() -> None:
    # the ticking thread draws only when the search's report is overdue: it must not take
    # the search's slots (its line then never showed a rate: it/s)
    now = [0.0]
    seen: list[Snapshot] = []
    prog = Progress(seen.append, interval=1.0, clock=lambda: now[0])
    prog.start("x")
    for step in range(1, 5):
        now[0] = step + 0.0
        prog.tick()  # due by the clock, yet the search reports at the same moment
        prog(SearchStatus(iteration=100 * step, best=1.0))
    assert any(s.rate for s in seen)
