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
from sosp.stop import request_stop, stop_requested

#: Seconds between two looks of a waiting parent at the stop flag and the chains' progress.
POLL_S = 0.2

log = logging.getLogger(__name__)


def _chain(
    conn: Connection,
    instance: Instance,
    mode: str,
    rng: np.random.Generator,
    time_limit: float | None,
    params: ASAParams,
    started: float,
    index: int,
    shared: Any,
    halt: Any,
) -> None:
    """One chain, in its own process: :func:`~heuristics.asa.search.run_asa`, its result sent.

    ``started`` is the parent's :func:`time.time` at the start of the run: ``time_limit``
    counts from it, so starting the process does not lengthen the run.

    ``shared`` (a shared array of doubles, two per chain) receives the chain's iterations and
    best at each progress report; once ``halt`` (a shared event) is set, the chain stops its
    search as on a stop request. SIGINT (Ctrl-C reaches the whole process group) requests a
    stop too instead of killing the chain, so its best schedule is not lost. The answer is
    ``("ok", Result)`` or ``("error", message)``.
    """

    def publish(snap: Snapshot) -> None:
        shared[2 * index] = snap.iterations
        shared[2 * index + 1] = snap.best or 0.0
        if halt.is_set():
            request_stop("parent")

    try:
        signal.signal(signal.SIGINT, lambda signum, frame: request_stop("SIGINT"))
        with reporting(Progress(publish, interval=POLL_S)):
            if time_limit is not None:  # the parent's limit, counted from its start
                time_limit = max(0.0, time_limit - (time.time() - started))
            conn.send(
                ("ok", run_asa(instance, mode, rng=rng, time_limit=time_limit, params=params))
            )
    except (KeyboardInterrupt, EOFError):  # the parent is gone or interrupted
        return
    except Exception as exc:
        log.debug("asa chain failed", exc_info=True)
        try:
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
        except OSError:  # pragma: no cover - the parent is gone
            pass


class _Chains:
    """The parent's handles on the chain processes (:class:`sosp.parallel.Child`)."""

    def __init__(
        self,
        instance: Instance,
        mode: str,
        rngs: list[np.random.Generator],
        time_limit: float | None,
        params: ASAParams,
    ) -> None:
        ctx = mp.get_context()
        started = time.time()
        self.shared = ctx.RawArray("d", 2 * len(rngs))
        self.halt = ctx.Event()
        self.progress = current_progress()
        self.chains: list[Child] = []
        for i, rng in enumerate(rngs):
            args = (instance, mode, rng, time_limit, params, started, i, self.shared, self.halt)
            # the platform's start method; everything goes with the start (the shared
            # array and event must be inherited)
            self.chains.append(Child(_chain, args, method=None))

    def results(self) -> list[Result]:
        """Each chain's result, in order; a chain's error is raised here."""
        out = []
        for i, chain in enumerate(self.chains):
            while not chain.conn.poll(POLL_S):
                self.tick()
            try:
                kind, value = chain.conn.recv()
            except EOFError:
                chain.proc.join(timeout=1.0)
                code = chain.proc.exitcode
                raise RuntimeError(
                    f"asa chain {i} ended without answering (exit code {code})"
                ) from None
            if kind == "error":
                raise RuntimeError(f"asa chain {i}: {value}")
            out.append(value)
        return out

    def tick(self) -> None:
        """While waiting: pass a stop request on to the chains, report their progress."""
        if stop_requested() and not self.halt.is_set():
            self.halt.set()
        n = len(self.chains)
        iterations = sum(int(self.shared[2 * i]) for i in range(n))
        best = max(self.shared[2 * i + 1] for i in range(n))
        self.progress.update(iterations, best or None)  # None: the chains are still building

    def close(self) -> None:
        for chain in self.chains:
            chain.stop(wait=1.0)


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
    t0 = time.perf_counter()
    n = params.workers
    chains = _Chains(instance, mode, rng.spawn(n), time_limit, replace(params, workers=1))
    try:
        results = chains.results()
    finally:
        chains.close()
    best = max(range(n), key=lambda i: (results[i].profit, -i))
    out = results[best]
    out.stats["chains"] = [{"best": r.profit, "iterations": r.iterations} for r in results]
    out.stats["workers"] = n
    out.iterations = sum(r.iterations or 0 for r in results)
    out.runtime_s = time.perf_counter() - t0
    return out
