"""Several ASA chains on several cores, the best of them returned (sosp's, not the paper's).

Algorithm 1 is one sequential chain. On a machine with more than one core, ``workers=n``
runs ``n`` independent chains side by side, one process each:

1. each chain is a :class:`~heuristics.asa.search.Search` with its own generator, spawned from
   the entry point's (:meth:`numpy.random.Generator.spawn`), so the chains differ from the
   first iteration and the run is reproducible from the one seed;
2. every chain runs to the run's limit (time, iterations or ``no_improve``, counted per chain);
3. the result is the best chain's (ties: the lower index), with the iterations of all chains
   summed and a per-chain summary in ``stats["chains"]``.

The chains do not exchange schedules: making the chains behind adopt the best of all a few
times per run measured no better on B10 and C10 (``docs/asa.md``, "Two cores"; it was removed
with its parameter ``epochs``): the chains then search near one schedule, and what two chains
buy on these instances is a second draw. A chain that fails sends its error to the parent,
which stops the others and raises it.

A stop request (:func:`sosp.stop.request_stop`, e.g. Ctrl-C or SIGTERM under the CLI) in the
parent reaches the chains through a shared event; they stop at the next check and the best of
their schedules so far is returned. The chains publish their iterations and best in shared
memory, which the parent reports to the solve's progress while it waits.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import signal
import time
from contextlib import suppress
from dataclasses import replace
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from heuristics.asa.params import ASAParams
from heuristics.asa.search import run_asa
from sosp.instance import Instance
from sosp.parallel import Child
from sosp.progress import Progress, Snapshot, reporting
from sosp.progress import current as current_progress
from sosp.result import Result
from sosp.stop import Budget, request_stop, stop_requested

#: Seconds between two looks of a waiting parent at the stop flag and the chains' progress.
POLL_S = 0.2

log = logging.getLogger(__name__)


def _chain(
    conn: Connection,
    instance: Instance,
    mode: str,
    rng: np.random.Generator,
    run: Budget,
    params: ASAParams,
    index: int,
    shared: Any,
    halt: Any,
) -> None:
    """One chain, in its own process: :func:`~heuristics.asa.search.run_asa`, its result sent.

    ``run`` is the parent's time (:class:`sosp.stop.Budget`, whose end holds across the
    processes of a machine), so starting the process does not lengthen the run.

    ``shared`` (a shared array of doubles, two per chain) receives the chain's iterations and
    best at each progress report; once ``halt`` (a shared event) is set, the chain stops its
    search as on a stop request. SIGINT (Ctrl-C reaches the whole process group) requests a
    stop too instead of killing the chain, so its best schedule is not lost. The answer is
    ``("ok", Result)`` or ``("error", message)``.
    """

    def publish(snap: Snapshot) -> None:
        shared[2 * index : 2 * index + 2] = [snap.iterations, snap.best or 0.0]
        if halt.is_set():
            request_stop("parent")

    try:
        signal.signal(signal.SIGINT, lambda signum, frame: request_stop("SIGINT"))
        with reporting(Progress(publish, interval=POLL_S)):
            res = run_asa(instance, mode, rng=rng, time_limit=run.left(), params=params)
            conn.send(("ok", res))
    except (KeyboardInterrupt, EOFError):  # the parent is gone or interrupted
        return
    except Exception as exc:
        log.debug("asa chain failed", exc_info=True)
        with suppress(OSError):  # the parent may be gone
            conn.send(("error", f"{type(exc).__name__}: {exc}"))


def run_parallel(
    instance: Instance,
    mode: str,
    *,
    rng: np.random.Generator,
    time_limit: float | None,
    params: ASAParams,
) -> Result:
    """Run ``params.workers`` independent chains (module docstring) and return the best.

    Parameters
    ----------
    instance, mode, rng, time_limit
        As :func:`heuristics.asa.search.run_asa`; ``rng`` only spawns the chains' generators.
    params
        The chains' parameters; ``workers`` chains. ``iterations`` and ``no_improve`` count
        per chain.

    Returns
    -------
    Result
        The best chain's result; ``iterations`` is the sum over the chains, ``stats["chains"]``
        holds each chain's best and iterations.
    """
    t0, run = time.perf_counter(), Budget.of(time_limit)
    n, ctx, progress = params.workers, mp.get_context(), current_progress()
    shared, halt, one = ctx.RawArray("d", 2 * n), ctx.Event(), replace(params, workers=1)
    # the platform's start method (sosp.parallel.Child); everything goes with the start (the
    # shared array and event must be inherited)
    chains = [
        Child(_chain, (instance, mode, r, run, one, i, shared, halt), method=None)
        for i, r in enumerate(rng.spawn(n))
    ]
    results: list[Result] = []
    try:
        for i, chain in enumerate(chains):
            while not chain.conn.poll(POLL_S):  # pass a stop on, report the chains' progress
                if stop_requested():
                    halt.set()
                # best None: the chains are still building
                progress.update(int(sum(shared[::2])), max(shared[1::2]) or None)
            try:
                kind, value = chain.conn.recv()
            except EOFError:
                chain.proc.join(timeout=1.0)
                kind, value = "error", f"no answer (exit code {chain.proc.exitcode})"
            if kind == "error":
                raise RuntimeError(f"asa chain {i}: {value}")
            results.append(value)
    finally:
        for chain in chains:
            chain.stop(wait=1.0)
    out = results[max(range(n), key=lambda i: (results[i].profit, -i))]  # ties: the first
    out.stats["chains"] = [{"best": r.profit, "iterations": r.iterations} for r in results]
    out.stats["workers"] = n
    out.iterations = sum(r.iterations or 0 for r in results)
    out.runtime_s = time.perf_counter() - t0
    return out
