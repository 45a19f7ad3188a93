"""Guarded HiGHS solves (:func:`models.highs_direct.run_highs` with ``guard``): a MIP whose
HiGHS does not return by the deadline is stopped, keeping what it reported."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from models.highs_direct import (
    BOUND_WATCH_S,
    GUARD_GRACE_S,
    HighsOutcome,
    _Lp,
    _run_guarded,
    build_arrays,
    run_highs,
    watching_bound,
)
from models.solve import model_data
from sosp.parallel import ChildStartError
from tests.conftest import tiny_cluster
from tests.limits import limit_kept


def _model() -> Any:
    return build_arrays(model_data(tiny_cluster(), "cluster"), relax=False)


def hanging_child(conn: Any, halt: Any, lp: _Lp, left: float, kwargs: dict) -> None:
    """Reports one incumbent and a dual bound, then never returns (as HiGHS in a presolve
    that reads no clock)."""
    x = np.zeros(lp.n_items)
    x[0] = 1.0
    conn.send(("incumbent", 5.0, x))
    conn.send(("progress", 3, 9.0))
    time.sleep(60)


def test_guarded_solve_equals_the_solve_in_process() -> None:
    am = _model()
    here = run_highs(am, deadline=time.perf_counter() + 30, guard=False)
    there = run_highs(am, deadline=time.perf_counter() + 30, guard=True)
    assert there.status == here.status == "optimal"
    assert there.objective == here.objective and there.bound == here.bound
    assert np.array_equal(there.x, here.x)


@pytest.mark.limits
def test_a_hanging_solve_is_stopped_with_what_it_reported() -> None:
    lp = _Lp.of(_model())
    t0 = time.perf_counter()
    # 4 s: time for a fresh interpreter to start and report on a loaded machine
    out = _run_guarded(lp, t0 + 4.0, {}, child=hanging_child)
    took = time.perf_counter() - t0
    assert 4.0 < took  # not stopped before the deadline
    limit_kept("hanging child, 4 s", took, 4.0 + GUARD_GRACE_S + 1.0)  # not waited for
    assert out.status == "time_limit" and out.info["guard_stopped"]
    assert out.objective == 5.0 and out.bound == 9.0 and out.x[0] == 1.0


def test_a_guarded_solve_hands_its_dual_bound_to_the_watcher() -> None:
    lp = _Lp.of(_model())
    got: list[tuple[float, float]] = []
    with watching_bound(lambda dual, primal: got.append((dual, primal)) or False):
        _run_guarded(lp, time.perf_counter() + 4.0, {}, child=hanging_child)
    # asked every BOUND_WATCH_S: nothing known before the child reports, then what it did
    # (its incumbent alone when the watcher is asked between its two messages)
    assert got[-1] == (9.0, 5.0)
    assert set(got) <= {(np.inf, -np.inf), (np.inf, 5.0), (9.0, 5.0)}
    assert len(got) <= 4.0 / BOUND_WATCH_S + 2
    seen = len(got)
    _run_guarded(lp, time.perf_counter() + 4.0, {}, child=hanging_child)
    assert len(got) == seen  # outside the block, nobody is told


def halting_child(conn: Any, halt: Any, lp: _Lp, left: float, kwargs: dict) -> None:
    """Reports a dual bound, then answers only when halted."""
    conn.send(("progress", 3, 9.0))
    halt.wait(60)
    conn.send(("done", HighsOutcome("time_limit", "halted", None, 9.0, None, 0.0, 0.0, {})))


@pytest.mark.limits
def test_a_watcher_halts_a_guarded_solve() -> None:
    lp = _Lp.of(_model())
    t0 = time.perf_counter()
    # halted once the child has reported (a watcher that halts before the spawned child has
    # even started leaves it only GUARD_GRACE_S to start and answer, less than its imports)
    with watching_bound(lambda dual, primal: dual < np.inf):
        out = _run_guarded(lp, t0 + 30.0, {}, child=halting_child)
    assert out.model_status == "halted"
    limit_kept("halted by a watcher, 30 s", time.perf_counter() - t0, 20.0)


def silent_child(conn: Any, halt: Any, lp: _Lp, left: float, kwargs: dict) -> None:
    """Reports nothing and never returns (HiGHS in a presolve that reads no clock)."""
    time.sleep(60)


@pytest.mark.limits
def test_a_watcher_stops_a_silent_guarded_solve() -> None:
    # asked while the child reports nothing, a watcher's True stops it within the grace
    lp = _Lp.of(_model())
    got: list[tuple[float, float]] = []
    t0 = time.perf_counter()
    with watching_bound(lambda dual, primal: got.append((dual, primal)) or True):
        out = _run_guarded(lp, t0 + 30.0, {}, child=silent_child)
    limit_kept("silent child stopped, 30 s", time.perf_counter() - t0, 2.0 + GUARD_GRACE_S)
    assert got == [(np.inf, -np.inf)] and out.info["guard_stopped"] and out.objective is None


@pytest.mark.limits
def test_a_stop_request_does_not_wait_for_the_grace(monkeypatch: pytest.MonkeyPatch) -> None:
    """A stop request (Ctrl-C) halts the child and gives it :data:`STOP_GRACE_S` to answer,
    not the grace of a deadline: HiGHS's presolve sees no interrupt, and the 0.5 s were
    most of a Ctrl-C's time to exit during the MILP (issue 63)."""
    import models.highs_direct as hd
    from sosp.stop import clear_stop, request_stop

    monkeypatch.setattr(hd, "GUARD_GRACE_S", 60.0)  # what a stop must not wait for
    lp = _Lp.of(_model())
    t0 = time.perf_counter()
    try:  # the request made once the child runs (the watcher is asked in the parent's loop)
        with watching_bound(lambda dual, primal: request_stop("test") or False):
            out = _run_guarded(lp, t0 + 30.0, {}, child=silent_child)
    finally:
        clear_stop()
    limit_kept("silent child stopped on request, 30 s", time.perf_counter() - t0, 20.0)
    assert out.info["guard_stopped"] and out.objective is None
    assert out.solve_s < 30.0  # stopped, not waited for past its deadline and the 60 s
    request_stop("test")  # before the solve: no child is started (a second under load)
    try:
        out = _run_guarded(lp, time.perf_counter() + 30.0, {}, child=hanging_child)
    finally:
        clear_stop()
    assert out.model_status == "not started" and out.objective is None


def test_a_child_that_ends_before_its_work_does_not_hang_the_parent(tmp_path: Path) -> None:
    # A script without the __main__ guard: spawn's child imports it again, fails to start a
    # grandchild and ends before reading its work. Sent with the start, work larger than a
    # pipe's buffer (here 8 MB) blocked the parent for ever; now the start is refused.
    script = tmp_path / "unguarded.py"
    script.write_text(
        textwrap.dedent(
            """
            import numpy as np
            from sosp.parallel import Child, ChildStartError
            try:
                Child(print, (), (np.zeros(1_000_000),))
            except ChildStartError as exc:
                print("REFUSED", exc)
            """
        )
    )
    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, str(script)], cwd=root, capture_output=True, text=True, timeout=60,
        env={"PYTHONPATH": str(root), "PATH": ""},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "REFUSED" in done.stdout and "__main__" in done.stdout


def test_a_guarded_solve_whose_child_cannot_start_runs_here(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import models.highs_direct as hd

    def refuse(*args: object, **kwargs: object) -> None:
        raise ChildStartError("ended at its start")

    monkeypatch.setattr(hd, "Child", refuse)
    am = _model()
    here = run_highs(am, deadline=time.perf_counter() + 30, guard=False)
    out = _run_guarded(_Lp.of(am), time.perf_counter() + 30, {})
    assert out.status == here.status == "optimal" and out.objective == here.objective
