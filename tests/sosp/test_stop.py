"""The shared stopping criteria (sosp.stop), stop requests reaching every search, and Ctrl-C /
SIGTERM during ``sosp solve`` through the real entry point: exit 130, the best schedule so far
written, valid and marked ``interrupted``."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import heuristics.asa as asa
import sosp.stop as stop_mod
from sosp.progress import Progress
from sosp.result import Status
from sosp.solve import solve
from sosp.stop import (
    FirstOf,
    Interrupted,
    MaxIterations,
    MaxRuntime,
    NoImprovement,
    SearchStatus,
    clear_stop,
    handle_signals,
    request_stop,
    stop_reason,
    stop_requested,
)
from sosp.validate import validate
from tests.conftest import scenario, tiny_chain
from tests.limits import limit_kept

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _clear_flag():
    clear_stop()
    yield
    clear_stop()


class FakeClock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def stop_after(monkeypatch: pytest.MonkeyPatch, owner: object, name: str) -> None:
    """Make ``owner.name`` request a stop once it returns."""
    original = getattr(owner, name)

    def then_stop(*args, **kwargs):
        out = original(*args, **kwargs)
        request_stop("test")
        return out

    monkeypatch.setattr(owner, name, then_stop)


def forbid(monkeypatch: pytest.MonkeyPatch, owner: object, name: str, message: str) -> None:
    """Make a call of ``owner.name`` fail the test with ``message``."""

    def never(*args, **kwargs):
        raise AssertionError(message)

    monkeypatch.setattr(owner, name, never)


def test_limits() -> None:
    s = SearchStatus(iteration=4, since_best=2, best=7.0)
    assert MaxIterations(4)(s) and not MaxIterations(5)(s)
    assert NoImprovement(2)(s) and not NoImprovement(3)(s)
    clock = FakeClock()
    rt = MaxRuntime(5.0, clock)
    assert not rt(s)
    clock.t = 104.9
    assert not rt(s)
    clock.t = 105.0
    assert rt(s)
    # counted from an earlier start
    assert MaxRuntime(5.0, clock, start=99.0)(s)
    assert not MaxRuntime(5.0, clock, start=101.0)(s)


def test_first_of_asks_in_order_and_stops_at_the_first_true() -> None:
    asked: list[str] = []

    def crit(name: str, answer: bool):
        def c(status: SearchStatus) -> bool:
            asked.append(name)
            return answer

        return c

    assert not FirstOf()(SearchStatus())
    assert FirstOf(crit("a", False), crit("b", True), crit("c", True))(SearchStatus())
    assert asked == ["a", "b"]


def test_request_and_clear() -> None:
    crit = Interrupted()
    assert not stop_requested() and not crit(SearchStatus()) and stop_reason() is None
    request_stop("test")
    request_stop("later")  # the first reason is kept
    assert stop_requested() and crit(SearchStatus()) and stop_reason() == "test"
    clear_stop()
    assert not stop_requested() and not crit(SearchStatus())


def test_asa_keeps_exporting_the_criteria() -> None:
    for name in ("FirstOf", "MaxIterations", "MaxRuntime", "NoImprovement", "SearchStatus"):
        assert getattr(asa, name) is getattr(stop_mod, name)
    from heuristics.asa.stop import MaxIterations as old

    assert old is MaxIterations


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_first_signal_requests_a_stop_the_second_aborts(sig: signal.Signals) -> None:
    before = signal.getsignal(sig)
    with handle_signals():
        os.kill(os.getpid(), sig)
        time.sleep(0.01)  # the handler runs at the next bytecode boundary
        assert stop_requested() and stop_reason() == sig.name
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), sig)
            time.sleep(0.01)
    assert signal.getsignal(sig) is before
    assert not stop_requested()


# ------------------------------------------------------------------- every search obeys
@pytest.fixture(scope="module")
def c1():
    return scenario("C1")


SEARCHES = [
    ("asa-dtc", {"iterations": 10**9}),
    ("asa-stc", {"iterations": 10**9}),
    ("asa-dtc", {"iterations": 10**9, "workers": 2}),
    ("orbit-dp", {"iterations": 10**9}),
    ("sa-stc", {"iterations": 10**9}),
    ("rds", {}),
    ("rds-stc", {}),
]


def _stopped(inst, profit: float) -> Status:
    """The status of a search ended by a request: interrupted, unless its schedule observes
    every target with an opportunity (C1's searches often get there within 0.3 s), which
    proves it optimal however it was stopped."""
    return Status.OPTIMAL if profit >= inst.observable_weight - 1e-9 else Status.INTERRUPTED


@pytest.mark.limits
@pytest.mark.parametrize(("method", "params"), SEARCHES, ids=lambda v: str(v))
def test_a_stop_request_ends_every_search_with_its_best(c1, method: str, params: dict) -> None:
    """Limits far out of reach: only the request (made from the progress callback, as a
    signal handler would between two checks) can end these runs."""
    seen: list[float] = []

    def cb(snap) -> None:
        seen.append(snap.elapsed)
        if snap.elapsed > 0.3:
            request_stop("test")

    t0 = time.perf_counter()
    result = solve(c1, method, seed=1, progress=Progress(cb, interval=0.05), **params)
    limit_kept(f"{method} stopped", time.perf_counter() - t0, 60.0)
    assert result.status is _stopped(c1, result.profit)
    # A search that reaches the cap at once (every target observed) ends before its first report.
    assert seen or result.status is Status.OPTIMAL, "the search never reported progress"
    assert validate(c1, result.schedule).feasible
    assert result.profit > 0


def test_an_exact_answer_keeps_its_status(monkeypatch: pytest.MonkeyPatch) -> None:
    """A request arriving once optimality is proven does not hide the proof; one arriving
    before the search starts stops it, unproven."""
    import heuristics.rds as rds

    proved = rds.solve_rds
    stop_after(monkeypatch, rds, "solve_rds")
    assert solve(tiny_chain(), "rds").status is Status.OPTIMAL
    monkeypatch.setattr(rds, "solve_rds", proved)
    assert solve(tiny_chain(), "rds").status is Status.INTERRUPTED  # the request is still on


def test_no_request_no_change() -> None:
    a = solve(tiny_chain(), "asa-dtc", seed=3, iterations=200)
    assert a.status is Status.FEASIBLE


# ------------------------------------------------------------------- the CLI, for real
def _start(args: list[str], tmp: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen(
        [sys.executable, "-m", "sosp", *args],
        cwd=tmp,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "extra"),
    [
        (signal.SIGINT, ["--method", "asa-dtc"]),
        (signal.SIGTERM, ["--method", "asa-dtc", "--param", "workers=2"]),
        (signal.SIGTERM, ["--method", "orbit-dp"]),
    ],
    ids=["sigint-asa", "sigterm-asa-workers", "sigterm-orbit-dp"],
)
def test_cli_signal_writes_the_best_so_far(
    tmp_path: Path, c2, sig: signal.Signals, extra: list[str]
) -> None:
    # C2, not C1: on C1 orbit-dp observes every target within a few seconds and stops there
    c1 = c2
    inst = tmp_path / "c2.json"
    c1.save(inst)
    out = tmp_path / "s.json"
    args = ["solve", str(inst), "--iterations", str(10**9), "-o", str(out), "--json", *extra]
    proc = _start(args, tmp_path)
    time.sleep(3.0)  # imports and the search's start; then the search is running
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    data = json.loads(stdout)
    assert data["status"] == _stopped(c1, data["profit"]).value
    assert out.exists()
    check = subprocess.run(
        [sys.executable, "-m", "sosp", "validate", str(inst), str(out), "--json"],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert check.returncode == 0, check.stdout
    assert json.loads(check.stdout)["profit"] == data["profit"]
    # the file itself says how the solve ended (issue 63, item 3)
    assert json.loads(out.read_text())["status"] == data["status"]


@pytest.mark.limits
@pytest.mark.slow
def test_milp_on_the_highs_backend_stops_with_its_incumbent(
    c2, monkeypatch: pytest.MonkeyPatch
) -> None:
    """HiGHS asks its interrupt callback (models.highs_direct) and stops at once when a stop
    is requested while it runs; the incumbent (the warm start at least) is returned,
    ``interrupted``. (A request before the MILP skips it: ``solve_milp``.)"""
    import models.highs_direct as hd

    inst = c2  # a limit of 60 s is reached without a request
    start = solve(inst, "greedy").schedule  # a start stage would stop on the request at once
    run_highs = hd.run_highs

    def requested_as_highs_starts(*args, **kwargs):
        request_stop("test")
        return run_highs(*args, **kwargs)

    monkeypatch.setattr(hd, "run_highs", requested_as_highs_starts)
    t0 = time.perf_counter()
    result = solve(inst, "milp", backend="highs", time_limit=60, warm_start=start)
    limit_kept("milp on HiGHS stopped", time.perf_counter() - t0, 40.0)
    assert result.status is Status.INTERRUPTED
    assert result.stats["termination"] == "Interrupted by user"
    assert result.profit > 0 and validate(inst, result.schedule).feasible


def test_a_stop_while_the_milp_model_is_prepared_ends_the_preparation() -> None:
    """Its data (:func:`models.data.prepare`: 0.5 s on C10, 0.9 s on 2,000 targets after
    the candidates) reads no clock: a Ctrl-C waited for it, then for the arranging and the
    warm start's mapping, 1.5-2 s to exit (issue 63). It now checks the flag between its
    steps, and no stage is foreseen to fit once a stop was requested."""
    from models.data import TimeUp, fits, prepare
    from sosp.candidates import cluster_candidates

    inst = scenario("C1")
    columns = cluster_candidates(inst)
    assert prepare("cluster", inst, *columns, coverage=True).n_items == len(columns[0])
    request_stop("test")
    with pytest.raises(TimeUp):
        prepare("cluster", inst, *columns, coverage=True)
    assert not fits("prepare", 1, None) and not fits("arrange", 1, 1e300)


@pytest.mark.parametrize("during", ["prepare", "arrange"])
def test_a_stop_while_the_milp_model_is_prepared_returns_the_warm_start(
    monkeypatch: pytest.MonkeyPatch, during: str
) -> None:
    """A stop during the model's preparation (its data, the items arranged per orbit) goes
    no further: neither the warm start's mapping onto the items (0.3 s on C10) nor the
    MILP; the warm start is the answer, ``interrupted``."""
    import models.data as md
    import models.solve as ms
    import sosp.planner as planner

    inst = scenario("C1")
    start = solve(inst, "greedy").schedule
    stage = {"prepare": (md, "_coverage"), "arrange": (planner, "with_rolls")}[during]
    stop_after(monkeypatch, *stage)
    forbid(monkeypatch, ms, "start_items", "the warm start was mapped after the stop")
    result = solve(inst, "milp", time_limit=60, warm_start=start)
    assert result.status is _stopped(inst, result.profit)
    assert result.stats["timed_out"] == "stopped" and result.stats["returned"] == "warm_start"
    assert result.profit == start.coverage_profit(inst)[0]


def test_a_stop_while_the_milp_arrays_are_built_starts_no_highs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A stop during the MILP's arrays leaves HiGHS unstarted: neither the warm start's
    values (0.3 s on 2,000 targets) nor HiGHS's child; the start is the answer."""
    import models.highs_direct as hd

    inst = scenario("C1")
    start = solve(inst, "greedy").schedule
    stop_after(monkeypatch, hd, "build_arrays")
    forbid(monkeypatch, hd, "run_highs", "HiGHS started after the stop")
    result = solve(inst, "milp", time_limit=60, warm_start=start, backend="highs")
    assert result.status is _stopped(inst, result.profit)
    assert result.stats["timed_out"] == "building"
    assert result.profit >= start.coverage_profit(inst)[0]


def test_a_stop_does_not_wait_for_the_side_branch_and_price(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The MILP's side bound (a child process, :class:`models.colgen.SideBound`) is stopped
    after up to 0.5 s for its last message; the child knows nothing of a stop request, so
    a Ctrl-C during the MILP waited those 0.5 s (issue 63). Stopped, it is read at once."""
    from models.colgen import SideBound

    class Child:
        def stop(self) -> None:
            waits.append("stopped")

    waits: list[float | str] = []
    side = object.__new__(SideBound)  # its state without a child process
    side._child, side._stopped, side._done, side.bound, side.found = Child(), False, False, 1, None
    monkeypatch.setattr(SideBound, "_read", lambda self, wait: waits.append(wait))
    side.finish()
    side._stopped = False
    request_stop("test")
    side.finish()
    assert waits == [0.5, "stopped", 0.0, "stopped"]


def test_a_stop_ends_a_round_of_the_window_bound(c1) -> None:
    """``--bound`` after a search on 10,000 targets prices every orbit's relaxed plan in a
    round of seconds that read only the deadline: a Ctrl-C then waited for the round, 1.5 s
    (issue 63). A round with a deadline now ends at the next orbit once a stop was
    requested (a partial round, no bound from it, as past the deadline)."""
    import numpy as np

    import models.window_bound as wb
    from sosp.windows import orbit_opps

    orbits = [orbit_opps(c1, j) for j in range(c1.n_orbits)]
    _, p = wb._observable(c1)
    lam, until = np.zeros((len(orbits), 2)), time.perf_counter() + 600
    assert wb._relaxed_plans(orbits, range(len(orbits)), p, lam, until=until) is not None
    request_stop("test")
    assert wb._relaxed_plans(orbits, range(len(orbits)), p, lam, until=until) is None
    assert wb._relaxed_plans(orbits, [0], p, lam) is not None  # no deadline: a whole round


def test_the_program_exits_without_the_interpreters_teardown() -> None:
    """``sosp`` and ``python -m sosp`` end with ``os._exit`` after the exit handlers and a
    flush: freeing a large solve's objects one by one took up to 1.3 s after its schedule
    was written (rds on 10,000 targets), most of a Ctrl-C's time to exit (issue 63)."""
    code = (
        "import atexit, sys\n"
        "from sosp import cli\n"
        "class Late:\n"
        "    def __del__(self):\n"
        "        print('teardown', flush=True)\n"
        "late = Late()\n"
        "atexit.register(print, 'exit handlers')\n"
        "sys.argv = ['sosp', 'methods', 'greedy']\n"
        "cli.run()\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert "greedy" in done.stdout and "exit handlers" in done.stdout
    assert "teardown" not in done.stdout


def test_max_runtime_foresees_its_longest_iteration() -> None:
    """With ``foresee``, the stop comes when the longest time between two checks would pass
    the deadline (a 1.9 s orbit move ran a 5 s ASA-DTC to 5.8 s); without, at the deadline."""
    now = [0.0]
    plain = MaxRuntime(10.0, clock=lambda: now[0])
    ahead = MaxRuntime(10.0, clock=lambda: now[0], foresee=True)
    status = SearchStatus()
    for t in (0.0, 1.0, 4.0):  # iterations of 1 s and 3 s
        now[0] = t
        assert not plain(status) and not ahead(status)
    now[0] = 7.5  # 2.5 s left, the longest iteration took 3.5 s
    assert ahead(status) and not plain(status)
    now[0] = 10.0
    assert plain(status)


def test_foresight_last_rate() -> None:
    """Without ``most``: own last time, else the last rate of a job of at least
    ``min_work``, else the prior."""
    from sosp.stop import Foresight

    f = Foresight(2.0, min_work=10.0)
    assert f("a", 5.0) == 10.0  # the prior
    f.record("a", 5.0, 1.0)  # too little work to set a rate
    assert f("a", 5.0) == 1.0 and f("b", 5.0) == 10.0
    f.record("b", 100.0, 50.0)  # 0.5 s a unit
    f.record("c", 100.0, 10.0)  # 0.1 s a unit: the last one counts
    assert f("d", 10.0) == pytest.approx(1.0) and f("b", 1.0) == 50.0
    assert Foresight(0.0)("x", 1e9) == 0.0  # no prior: nothing foreseen


def test_foresight_most_rate_never_below_the_prior() -> None:
    """With ``most``: the most rate seen, at least the prior; no work sets no rate."""
    from sosp.stop import Foresight

    f = Foresight(2.0, most=True)
    f.record("a", 10.0, 1.0)  # 0.1 s a unit, below the prior
    assert f("b", 1.0) == 2.0 and f.rate_or_prior() == 2.0
    f.record("c", 1.0, 5.0)
    f.record("d", 1.0, 3.0)  # less than the most: the most stands
    assert f("b", 2.0) == 10.0
    f.record("e", 0.0, 100.0)  # no work: a fixed cost, no rate
    assert f.rate == 5.0 and f("e", 0.0) == 100.0


def _signalled_before_the_initialiser() -> None:
    # a SIGTERM from Pool.terminate before the initialiser has run, then the initialiser
    from sosp.parallel import worker_signals

    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(0.2)
    worker_signals()
    time.sleep(5.0)  # alive here means the SIGTERM was taken as a stop request


@pytest.mark.skipif(
    "fork" not in __import__("multiprocessing").get_all_start_methods(), reason="no fork"
)
def test_a_sigterm_before_a_forked_workers_initialiser_still_ends_it() -> None:
    """A worker forked under ``handle_signals`` keeps its handler until ``worker_signals``
    runs: a SIGTERM in that window only requested a stop, and ``Pool.terminate`` waited for
    ever (a test's pricing pool, on a loaded machine). Held from the fork, it ends the worker
    as soon as the initialiser has run."""
    import multiprocessing as mp

    from sosp.parallel import held_for_fork
    from sosp.stop import handle_signals

    with handle_signals(), held_for_fork():
        proc = mp.get_context("fork").Process(target=_signalled_before_the_initialiser)
        proc.start()
    proc.join(10.0)
    assert proc.exitcode == -signal.SIGTERM


def test_a_schedule_file_keeps_its_status_and_bound(tmp_path: Path) -> None:
    """``-o`` records how the solve ended and its bound, and reads them back (issue 63, 3)."""
    from sosp.errors import InputError
    from sosp.schedule import load_schedule

    pytest.importorskip("highspy")
    inst = tiny_chain()
    result = solve(inst, "milp", time_limit=10)  # the problem's model: its own bound counts
    assert (result.schedule.status, result.schedule.bound) == ("optimal", result.bound)
    result.schedule.save(tmp_path / "s.json", inst)
    back = load_schedule(tmp_path / "s.json", inst)
    assert (back.status, back.bound) == ("optimal", result.bound)
    data = json.loads((tmp_path / "s.json").read_text())
    (tmp_path / "bad.json").write_text(json.dumps({**data, "bound": "high"}))
    with pytest.raises(InputError, match="bound"):
        load_schedule(tmp_path / "bad.json", inst)


@pytest.mark.parametrize(
    "method", ["asa-dtc", "asa-stc", "orbit-dp", "aco-ls-stc", "sa-stc", "ga-stc", "ts-stc"]
)
def test_a_search_stops_at_the_cap(method: str) -> None:
    # issue 63 item 5: the README's two-target instance, every target observable and both
    # observed by any search: nothing is left to find, so the search stops there instead of
    # running to its limit (ASA-DTC took 5.2 s on it, orbit-dp and ACO-LS their whole limit)
    from sosp.instance import Instance, Resources

    inst = Instance.build(
        {"a": 5, "b": 4},
        [("a", 0, 0, 4, 10.0), ("b", 0, 30, 34, -5.0)],
        resources=Resources(max_openings=2),
    )
    res = solve(inst, method, time_limit=30)
    assert res.profit == 9 and res.status is Status.OPTIMAL
    assert res.runtime_s < 5, res.runtime_s
    assert validate(inst, res.schedule).feasible


def test_a_signal_is_acknowledged_during_a_long_compiled_call() -> None:
    # issue 63 item 2: Python runs a signal handler only between bytecodes, so during a long
    # call into compiled code (here OpenSSL's PBKDF2, which releases the GIL as HiGHS does)
    # the first Ctrl-C went unacknowledged and the solver's callbacks never saw the request
    import hashlib
    import threading

    heard: list[tuple[str, bool, float]] = []

    def on_stop(reason: str) -> None:
        heard.append((reason, stop_requested(), time.perf_counter()))

    with handle_signals(on_stop=on_stop):
        threading.Timer(0.1, os.kill, (os.getpid(), signal.SIGINT)).start()
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < 0.5:  # calls of 0.5 s or more until the signal
            hashlib.pbkdf2_hmac("sha256", b"sosp", b"salt", 400_000)
        end = time.perf_counter()
        (reason, requested, at) = heard[0]
        assert reason == "SIGINT" and requested and len(heard) == 1
        assert at < end - 0.05, (at - t0, end - t0)  # within the call, not after it
    assert not stop_requested()


def test_a_stop_request_ends_candidate_generation() -> None:
    """Generating an orbit's cluster candidates (seconds on dense 10,000-target orbits) hears a
    stop request between two first opportunities, as it hears the deadline, so the search
    falls back to its best at once (before: 15-25 s from Ctrl-C on a 10,000-target region)."""
    from sosp.candidates import orbit_candidates
    from sosp.errors import TimeLimitReached

    inst = scenario("C1")
    j = int(inst.opp_orbit[0])
    assert len(orbit_candidates(inst, j).roll) > 0  # it answers without a request
    request_stop("test")
    with pytest.raises(TimeLimitReached, match="stopped while generating"):
        orbit_candidates(inst.with_opportunities(inst.opp_orbit >= 0), j)
