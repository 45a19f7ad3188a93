"""Running a campaign: expand the grid, skip what is stored, run the rest in parallel.

Runs go to a local process pool, to a Dask distributed cluster, or run in this process
(``workers=1``): :func:`sosp.parallel.completed`. Only :class:`RunSpec` objects
and result rows cross process boundaries: each worker generates or loads its instances itself
(cached per process). The parent stores each finished run at once, in one transaction
(:class:`~sosp.campaign.store.Store`), so a crash loses only the runs in flight.
"""

from __future__ import annotations

import json
import logging
import os
import time
import traceback
from collections.abc import Callable
from contextlib import closing
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from functools import lru_cache
from itertools import product
from typing import TYPE_CHECKING, Any

from sosp.campaign.spec import KEY_COLUMNS, Campaign, RunSpec, canonical_params
from sosp.campaign.store import Store
from sosp.errors import InputError
from sosp.parallel import completed

if TYPE_CHECKING:
    from sosp.instance import Instance

log = logging.getLogger(__name__)

#: Instances kept per worker process.
CACHE_SIZE = 4


# --------------------------------------------------------------------------- instances
@lru_cache(maxsize=CACHE_SIZE)  # thread-safe: Dask workers may be threads sharing it
def load_scenario(label: str, path: str | None, instance_seed: int) -> Instance:
    """The instance of a scenario: generated (named) or loaded (file), cached per process."""
    if path is None:
        from sosp.scenarios import generate_scenario

        return generate_scenario(label, seed=instance_seed)
    from sosp.instance import load_instance

    return load_instance(path)


def instance_info(label: str, inst: Instance) -> dict[str, Any]:
    """The row of table ``instances`` for a scenario."""
    return {
        "scenario": label,
        "fingerprint": inst.fingerprint,
        "name": inst.name,
        "targets": inst.n_targets,
        "en": inst.observable_targets,
        "tn": inst.n_opps,
        "orbits": inst.n_orbits,
    }


# --------------------------------------------------------------------------- one run
def execute_run(spec: RunSpec) -> dict[str, Any]:
    """Run one grid cell and return its row (never raises: failures become status ``error``).

    The schedule is checked by the independent validator; its verdict (feasibility,
    violations, energy, memory) is part of the row.
    """
    from sosp import __version__

    row: dict[str, Any] = {k: getattr(spec, k) for k in KEY_COLUMNS} | {"version": __version__}
    t0 = time.perf_counter()
    try:
        from sosp.planner import compile_kernels
        from sosp.solve import solve
        from sosp.validate import validate

        compile_kernels()  # once a worker, outside the run: its first run keeps its whole limit
        inst = load_scenario(spec.scenario, spec.path, spec.instance_seed)
        if inst.fingerprint != spec.fingerprint:
            raise RuntimeError(
                f"instance of {spec.scenario} changed (fingerprint {inst.fingerprint[:19]}..."
                f" != {spec.fingerprint[:19]}...)"
            )
        params, limit = json.loads(spec.params), spec.time_limit or None  # 0: no limit
        result = solve(inst, spec.method, seed=spec.seed, time_limit=limit, check=False, **params)
        report = validate(inst, result.schedule)
        verdict = report.to_dict()
        verdict.pop("orbits", None)
        bound_count = (result.stats or {}).get("bound_targets")  # PBA-STC's F*
        compact = {"separators": (",", ":"), "allow_nan": False}
        row.update(
            status=str(result.status.value),
            message=None,
            profit=float(report.profit),
            observed=int(report.observed),
            bound=None if result.bound is None else float(result.bound),
            bound_count=None if bound_count is None else int(bound_count),
            energy=float(report.energy),
            memory=float(report.memory),
            runtime=float(result.runtime_s),
            iterations=result.iterations,
            feasible=int(report.feasible),
            verdict=json.dumps(verdict, sort_keys=True, **compact),
            schedule=json.dumps(result.schedule.to_dict(inst), **compact),
        )
    except Exception as exc:  # noqa: BLE001 - a failing run is data, not a crash
        log.debug("run %s failed:\n%s", spec, traceback.format_exc())
        msg = " ".join(f"{type(exc).__name__}: {exc}".split())
        row.update(status="error", message=msg[:2000], runtime=time.perf_counter() - t0)
    row["finished_at"] = datetime.now(UTC).isoformat(timespec="seconds")
    return row


# --------------------------------------------------------------------------- planning
@dataclass
class Plan:
    """The grid of a campaign against a store: all runs and those still to do."""

    runs: list[RunSpec]
    pending: list[RunSpec]
    skipped_methods: list[str]
    instances: list[dict[str, Any]]

    @property
    def done(self) -> int:
        return len(self.runs) - len(self.pending)


def check_methods(campaign: Campaign) -> tuple[list[str], list[str]]:
    """Check every method and its parameter names before anything runs.

    Returns
    -------
    usable, skipped
        Method labels to run, and those skipped as not installed (``skip_unavailable``).

    Raises
    ------
    InputError
        On an unknown method, a method not installed (unless skipped), an unknown parameter
        or a bad parameter value (:func:`sosp.methods.check_params`).
    """
    from sosp.methods import check_params
    from sosp.registry import METHODS, available_methods, method_function

    avail = set(available_methods())
    usable: list[str] = []
    skipped: list[str] = []
    for m in campaign.methods:
        if m.name not in METHODS:
            raise InputError(
                f"methods: unknown method {m.name!r} (choose from {', '.join(sorted(avail))})"
            )
        if m.name not in avail:
            if campaign.skip_unavailable:
                skipped.append(m.label)
                continue
            raise InputError(f"methods: {m.name!r} is not available in this build")
        try:
            method_function(m.name)
        except ImportError as exc:  # installed but broken: treat as unavailable
            if campaign.skip_unavailable:
                log.warning("skipping %s: %s", m.label, exc)
                skipped.append(m.label)
                continue
            raise InputError(f"methods: {m.name!r} cannot be imported: {exc}") from None
        try:  # names and values, so that a typo is refused now, not stored as a failed run
            check_params(m.name, m.params)
        except InputError as exc:
            raise InputError(f"methods: {m.label}: {exc}") from None
        usable.append(m.label)
    if not usable:
        raise InputError("methods: none of the campaign's methods is available")
    return usable, skipped


def plan(campaign: Campaign, store: Store | None, retry_failed: bool = False) -> Plan:
    """Expand the grid (fingerprinting each scenario once) and drop the runs already stored.

    ``store`` None stands for a database that does not exist yet (nothing stored).
    """
    usable, skipped = check_methods(campaign)
    infos, runs = [], []
    for sc in campaign.scenarios:
        inst = load_scenario(sc.label, sc.path, campaign.instance_seed)
        infos.append(instance_info(sc.label, inst))
        at = (sc.label, sc.path, campaign.instance_seed, inst.fingerprint)
        for m in campaign.methods:
            if m.label in usable:
                cells = product(m.time_limits or campaign.time_limits, m.seeds or campaign.seeds)
                params = canonical_params(m.params)
                runs += [RunSpec(*at, m.name, params, seed, float(tl)) for tl, seed in cells]
    done = set() if store is None else store.done_keys(include_failed=not retry_failed)
    pending = [r for r in runs if r.key not in done]
    return Plan(runs, pending, skipped, infos)


def _lost(spec: RunSpec, exc: BaseException) -> None:
    log.error("run %s lost (%s); it will run again on resume", spec, exc)


# --------------------------------------------------------------------------- campaign
@dataclass
class Outcome:
    """What one call of :func:`run_campaign` did."""

    total: int
    already: int
    ran: int
    failed: int
    infeasible: int
    skipped_methods: list[str]
    elapsed_s: float

    to_dict = asdict


def run_campaign(
    campaign: Campaign,
    store: Store,
    *,
    workers: int | None = None,
    dask: Any = None,
    retry_failed: bool = False,
    on_result: Callable[[dict[str, Any], int, int], None] | None = None,
) -> Outcome:
    """Run every pending cell of ``campaign`` and store each result as it arrives.

    Parameters
    ----------
    campaign
        The grid.
    store
        The open results database.
    workers
        Local processes (default: all cores; 1 runs in this process). With ``dask``, the
        number of workers of a ``"local"`` cluster.
    dask
        None (process pool), a scheduler address, ``"local"`` (a new ``LocalCluster``) or an
        existing ``distributed.Client``.
    retry_failed
        Run again the cells stored with status ``error``.
    on_result
        Called after each stored row with ``(row, finished, pending)``.

    Returns
    -------
    Outcome
    """
    t0 = time.perf_counter()
    p = plan(campaign, store, retry_failed=retry_failed)
    for label in p.skipped_methods:
        log.warning("skipping %s: not available in this build", label)
    n_workers = workers or campaign.workers or os.cpu_count() or 1
    if n_workers < 1:
        raise InputError(f"--workers: must be >= 1, got {n_workers}")
    log.info(
        "campaign %s: %d runs, %d stored, %d to run on %s",
        campaign.name,
        len(p.runs),
        p.done,
        len(p.pending),
        f"dask {dask}" if dask is not None else f"{n_workers} worker(s)",
    )
    stream = completed(execute_run, p.pending, n_workers, dask, _lost)
    if p.pending:
        store.put_instances(p.instances)
    out = Outcome(len(p.runs), p.done, 0, 0, 0, p.skipped_methods, 0.0)
    # stopped (Ctrl-C in a notebook), the pool closes now, not when the traceback that
    # holds the generator is collected
    with closing(stream):
        for row in stream:
            store.put(row)
            out.ran += 1
            if row["status"] == "error":
                out.failed += 1
                what = (row["scenario"], row["method"], row["seed"], row["message"])
                log.warning("%s %s seed %d failed: %s", *what)
            elif not row.get("feasible"):
                out.infeasible += 1
            if on_result is not None:
                on_result(row, out.ran, len(p.pending))
    out.elapsed_s = time.perf_counter() - t0
    return out
