"""Crash safety of ``sosp bench``: SIGKILL partway, resume, and get exactly the rows of an
uninterrupted run; the Dask path gives the same rows as the process pool."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sosp.campaign import Store, campaign_from_options
from sosp.campaign.runner import load_scenario, run_campaign
from sosp.instance import Instance
from sosp.result import Result
from sosp.schedule import Schedule
from sosp.validate import validate

REPO = Path(__file__).resolve().parents[2]

#: A test method, registered in the child process by _SCRIPT.
SLOW = f"{__name__}:solve_slow"

#: Seconds each run of the slow method sleeps.
NAP = 0.15

_SCRIPT = (
    "import sys\n"
    "from sosp.registry import METHODS, Method\n"
    "METHODS['slow'] = Method({slow!r})\n"
    "from sosp.cli import main\n"
    "sys.exit(main(sys.argv[1:]))\n"
)


def solve_slow(instance: Instance, *, rng: np.random.Generator, time_limit=None) -> Result:
    """Greedy, then drop a seeded random observation, after a nap: slow and seed-dependent."""
    from dataclasses import replace

    from heuristics.greedy import solve_greedy

    time.sleep(NAP)
    res = solve_greedy(instance, rng=rng, time_limit=time_limit)
    obs = list(res.schedule.observations)
    if obs:
        obs.pop(int(rng.integers(len(obs))))
    profit = float(sum(instance.target_weight[instance.opp_target[i]] for o in obs for i in o.opps))
    observed = sum(len(o.opps) for o in obs)
    return replace(res, schedule=Schedule(tuple(obs)), profit=profit, observed=observed)


def _bench(db: Path, seeds: str, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    argv = ["bench", "--scenarios", "B1,C1", "--methods", "slow,greedy", "--seeds", seeds]
    argv += ["--db", str(db), "--workers", "2"]
    return subprocess.Popen(
        [sys.executable, "-c", _SCRIPT.format(slow=SLOW), *argv],
        cwd=REPO,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def _count(db: Path) -> int:
    try:
        con = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5)
        try:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
        finally:
            con.close()
    except sqlite3.Error:
        return 0


def _det_rows(db: Path) -> list[tuple]:
    """Rows on their deterministic fields (not runtime, not time stamps)."""
    with Store(db, readonly=True) as st:
        return sorted(
            (
                r["scenario"],
                r["fingerprint"],
                r["method"],
                r["params"],
                r["seed"],
                r["time_limit"],
                r["status"],
                r["profit"],
                r["observed"],
                r["energy"],
                r["memory"],
                r["feasible"],
                r["schedule"],
            )
            for r in st.rows()
        )


def _check_schedules(rows: list[tuple]) -> None:
    insts = {s: load_scenario(s, None, 0) for s in {r[0] for r in rows}}
    for r in rows:
        inst = insts[r[0]]
        sched = Schedule.from_dict(json.loads(r[-1]), inst)
        rep = validate(inst, sched)
        assert rep.feasible and rep.profit == r[7] and rep.observed == r[8]


@pytest.mark.slow
def test_sigkill_then_resume_gives_the_uninterrupted_rows(tmp_path: Path) -> None:
    seeds = "1-8"  # 2 scenarios x 2 methods x 8 seeds = 32 runs, 16 of them napping
    ref_db = tmp_path / "ref.db"
    ref = _bench(ref_db, seeds)
    out, err = ref.communicate(timeout=120)
    assert ref.returncode == 0, err
    ref_rows = _det_rows(ref_db)
    assert len(ref_rows) == 32
    assert len({r[7] for r in ref_rows if r[2] == "slow"}) > 1  # seeds matter

    db = tmp_path / "crash.db"
    proc = _bench(db, seeds, start_new_session=True)
    deadline = time.monotonic() + 60
    while _count(db) < 4 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    assert proc.poll() is None, "the campaign ended before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)  # the parent and its pool workers, no clean-up
    proc.wait(timeout=30)
    partial = _count(db)
    assert 4 <= partial < 32

    res = _bench(db, seeds)
    out, err = res.communicate(timeout=120)
    assert res.returncode == 0, err
    assert f"{partial} already stored" in out
    rows = _det_rows(db)
    assert rows == ref_rows  # none missing, none doubled, same values
    _check_schedules(rows)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_process_pool_rows(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    camp = campaign_from_options("B1,C1", "greedy,hpfs-stc", "1-3", "5")
    with Store(tmp_path / "pool.db") as st:
        out = run_campaign(camp, st, workers=2)
        assert out.ran == 12 and out.failed == 0
    with (
        LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as client,
        Store(tmp_path / "dask.db") as st,
    ):
        out = run_campaign(camp, st, dask=client)
        assert out.ran == 12 and out.failed == 0
        assert run_campaign(camp, st, dask=client).ran == 0  # resume on Dask too
    pool, dask_rows = _det_rows(tmp_path / "pool.db"), _det_rows(tmp_path / "dask.db")
    assert pool == dask_rows
    _check_schedules(dask_rows)
