"""Dask clusters for the per-orbit work (sosp.parallel, PlanPool on a client, --dask options)."""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from models.solve import bound
from models.window_bound import _relaxed_plans
from sosp.cli import main
from sosp.errors import InputError
from sosp.parallel import check_workers, dask_client, parallelism
from sosp.planner import PlanPool, orbit_data
from sosp.solve import solve
from sosp.validate import validate
from sosp.windows import orbit_opps
from tests.heuristics.test_rds import random_tiny

pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """An in-process cluster (threads): the same scheduling and pickling path as a remote
    one, without starting processes."""
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0"
    ) as c:
        yield c


@pytest.fixture(scope="module")
def client(cluster: Any) -> Iterator[Any]:
    from distributed import Client

    with Client(cluster) as c:
        yield c


def _same_plans(a: list[Any], b: list[Any]) -> None:
    assert len(a) == len(b)
    for (va, ca, ua), (vb, cb, ub) in zip(a, b, strict=True):
        assert va == vb and np.array_equal(ca, cb) and ua == ub


@pytest.mark.parametrize("seed", [1, 4, 7])
def test_plans_on_a_cluster_are_those_of_one_process(client: Any, seed: int) -> None:
    """Both planners (the candidates' and the window relaxation's) give, orbit by orbit, the
    plans of one process, over several rounds of prices from one pool."""
    inst = random_tiny(seed)
    rng = np.random.default_rng(seed)
    data = orbit_data(inst)
    opps = [orbit_opps(inst, j) for j in range(inst.n_orbits)]
    for orbits, plans_of in (
        (data.orbits, None),
        (opps, partial(_relaxed_plans, band=0.5)),
    ):
        with PlanPool(orbits, 1, plans_of) as here, PlanPool(orbits, client, plans_of) as there:
            assert there.client is not None
            for _ in range(3):
                price = rng.uniform(0, 5, inst.n_targets)
                lam = rng.uniform(0, 3, (len(orbits), 2))
                _same_plans(here.best_paths(price, lam), there.best_paths(price, lam))


def test_a_round_past_its_deadline_is_none_and_frees_the_cluster(client: Any) -> None:
    inst = random_tiny(3)
    data = orbit_data(inst)
    pool = PlanPool(data.orbits, client)
    price = np.ones(inst.n_targets)
    lam = np.zeros((len(data.orbits), 2))
    assert pool.best_paths(price, lam, until=time.perf_counter() - 1.0) is None
    assert pool.client is None  # closed: its orbits were released from the cluster
    deadline = 10.0
    while client.who_has() and deadline > 0:  # the scheduler forgets them asynchronously
        time.sleep(0.05)
        deadline -= 0.05
    assert not client.who_has()


@pytest.mark.parametrize("method", ["colgen", "lagrangian", "windows"])
def test_bounds_on_a_cluster_equal_those_of_one_process(client: Any, method: str) -> None:
    inst = random_tiny(5)
    here = bound(inst, method=method, iterations=30)
    there = bound(inst, method=method, iterations=30, workers=client)
    assert there["bound"] == here["bound"]


def test_orbit_dp_start_on_a_cluster_finds_the_same_schedule(cluster: Any) -> None:
    inst = random_tiny(3)
    here = solve(inst, "orbit-dp", seed=1, iterations=30)
    there = solve(inst, "orbit-dp", seed=1, iterations=30, dask=cluster.scheduler_address)
    assert there.schedule.observations == here.schedule.observations
    assert validate(inst, there.schedule).feasible


def test_workers_are_checked_and_counted(client: Any) -> None:
    for bad in (0, -1, True, "2", 1.5):
        with pytest.raises(InputError, match="workers"):
            check_workers(bad)
    check_workers(client)
    assert parallelism(3) == 3 and parallelism(client) == 2
    with pytest.raises(InputError, match="dask"):
        solve(random_tiny(1), "orbit-dp", seed=1, iterations=3, dask="")


def test_without_dask_installed_the_option_is_a_one_line_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    with pytest.raises(InputError, match=r"--dask: Dask is not installed"):
        with dask_client("local"):
            pass


@pytest.mark.slow
def test_bound_cli_on_a_local_cluster(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``sosp bound --dask local``: worker processes of their own, the bound of one
    process."""
    inst = random_tiny(6)
    path = tmp_path / "i.json"
    inst.save(path)
    assert main(["bound", str(path), "--method", "colgen", "--json"]) == 0
    here = json.loads(capsys.readouterr().out)
    args = ["bound", str(path), "--method", "colgen", "--json", "--dask", "local"]
    assert main([*args, "--workers", "2"]) == 0
    there = json.loads(capsys.readouterr().out)
    assert there["bound"] == here["bound"]


def _broken_plans(*args: Any, **kwargs: Any) -> list[Any]:
    raise ModuleNotFoundError("No module named 'sosp'")  # as on a worker without sosp


def test_a_failing_worker_is_a_one_line_error(client: Any) -> None:
    inst = random_tiny(2)
    data = orbit_data(inst)
    pool = PlanPool(data.orbits, client, _broken_plans)
    with pytest.raises(InputError, match=r"^--dask: the cluster failed a pricing round: .*sosp"):
        pool.best_paths(np.ones(inst.n_targets), np.zeros((len(data.orbits), 2)))
    assert pool.client is None


def test_bound_cli_counts_the_cluster_start_in_the_time_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``sosp bound --time-limit T --dask ...``: the bound gets what the cluster's start-up
    left of T (and, for a local cluster, what its close will take)."""
    from contextlib import contextmanager

    import models.cli as mcli
    import models.solve as msolve

    @contextmanager
    def slow_start(*args: Any) -> Iterator[int]:
        time.sleep(0.3)
        yield 1

    given: list[float] = []

    def fake_bound(inst: Any, **kw: Any) -> dict[str, Any]:
        given.append(kw["time_limit"])
        return {"bound": 1.0, "model": "cluster", "method": "auto", "source": "cap",
                "runtime_s": 0.0}  # fmt: skip

    monkeypatch.setattr(mcli, "workers_for", slow_start)
    monkeypatch.setattr(msolve, "bound", fake_bound)
    path = tmp_path / "i.json"
    random_tiny(1).save(path)
    assert main(["bound", str(path), "--time-limit", "2", "--json"]) == 0
    capsys.readouterr()
    assert len(given) == 1 and 1.0 < given[0] <= 1.7
    # a local cluster's close is reserved too (it takes about as long as its start)
    assert main(["bound", str(path), "--time-limit", "2", "--dask", "local", "--json"]) == 0
    capsys.readouterr()
    assert len(given) == 2 and 0.5 < given[1] <= 1.4
