"""Several ASA chains on several cores, the best of them returned (sosp's, not the paper's).

Algorithm 1 is one sequential chain. On a machine with more than one core, ``workers=n``
runs ``n`` chains side by side, one process each, optionally cooperating:

1. each chain is a :class:`~heuristics.asa.search.Search` with its own generator, spawned from
   the entry point's (:meth:`numpy.random.Generator.spawn`), so the chains differ from the
   first iteration and the run is reproducible from the one seed;
2. the run's limit (time, else iterations) is cut into ``epochs`` equal parts; every chain
   runs one part;
3. between two parts, every chain whose best is below the best of all adopts that schedule as
   its current and best solution (:meth:`~heuristics.asa.search.Search.adopt`); its
   temperature (21), neighbourhood probabilities (17)-(18), tabu list and counters carry on.
   Ties go to the chain with the lower index, so with an iteration limit the result depends
   on the seed alone;
4. the result is the best chain's, with the iterations of all chains summed and a per-chain
   summary in ``stats["chains"]``.

``epochs=1`` (the default) gives independent chains: the best of ``n`` runs, in the wall time
of one. Exchanging the best in six epochs measured no better on B10 and C10 (``docs/asa.md``,
"Two cores"): the chains then search near one schedule, and what two chains buy on these
instances is a second draw. A chain that fails sends its error to the parent, which stops
the others and raises it.

A stop request (:func:`sosp.stop.request_stop`, e.g. Ctrl-C or SIGTERM under the CLI) in the
parent reaches the chains through a shared event; they end their epoch at the next check and
the best of their schedules so far is returned. The chains publish their iterations and best
in shared memory, which the parent reports to the solve's progress while it waits.
"""

from __future__ import annotations

import logging
import math
import multiprocessing as mp
import signal
import time
from dataclasses import replace
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from heuristics.asa.params import ASAParams
from heuristics.asa.search import DEFAULT_ITERATIONS, Search, stop_rule
from sosp.instance import Instance
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
    index: int = 0,
    shared: Any = None,
    halt: Any = None,
) -> None:
    """One chain, in its own process: build the search, then obey the parent's commands.

    ``shared`` (a shared array of doubles, two per chain) receives the chain's iterations and
    best at each progress report; once ``halt`` (a shared event) is set, the chain stops its
    search as on a stop request. SIGINT (Ctrl-C reaches the whole process group) requests a
    stop too instead of killing the chain, so its best schedule is not lost.

    Commands (``(name, argument)``): ``run`` ``(last_iteration, seconds)`` runs until either
    limit (None: none) or ``params.no_improve`` and answers the chain's best profit; ``snap``
    answers the best schedule; ``adopt`` ``(snapshot, profit)`` takes it over; ``result``
    answers the :class:`~sosp.result.Result` and ends the chain.
    """

    def publish(snap: Snapshot) -> None:
        if shared is not None:
            shared[2 * index] = snap.iterations
            shared[2 * index + 1] = snap.best or 0.0
        if halt is not None and halt.is_set():
            request_stop("parent")

    try:
        signal.signal(signal.SIGINT, lambda signum, frame: request_stop("SIGINT"))
        with reporting(Progress(publish, interval=POLL_S)):
            search = Search(instance, mode, rng=rng, time_limit=time_limit, params=params)
            conn.send(("ok", search.best))
            while True:
                name, arg = conn.recv()
                if name == "run":
                    last, seconds = arg
                    search.run(stop_rule(last, seconds, params.no_improve))
                    conn.send(("ok", (search.best, search.status.since_best)))
                elif name == "snap":
                    conn.send(("ok", search.best_snap))
                elif name == "adopt":
                    search.adopt(*arg)
                    conn.send(("ok", None))
                elif name == "result":
                    conn.send(("ok", search.result()))
                    return
                else:  # pragma: no cover - the parent sends only the names above
                    raise ValueError(f"unknown command {name!r}")
    except (KeyboardInterrupt, EOFError):  # the parent is gone or interrupted
        return
    except Exception as exc:
        log.debug("asa chain failed", exc_info=True)
        try:
            conn.send(("error", f"{type(exc).__name__}: {exc}"))
        except OSError:  # pragma: no cover - the parent is gone
            pass


class _Chains:
    """The parent's handles on the chain processes (pipes and processes)."""

    def __init__(
        self,
        instance: Instance,
        mode: str,
        rngs: list[np.random.Generator],
        time_limit: float | None,
        params: ASAParams,
    ) -> None:
        ctx = mp.get_context()
        self.conns: list[Connection] = []
        self.procs: list[Any] = []
        self.shared = ctx.RawArray("d", 2 * len(rngs))
        self.halt = ctx.Event()
        self.progress = current_progress()
        for i, rng in enumerate(rngs):
            parent, child = ctx.Pipe()
            proc = ctx.Process(
                target=_chain,
                args=(child, instance, mode, rng, time_limit, params, i, self.shared, self.halt),
                daemon=True,
            )
            proc.start()
            child.close()
            self.conns.append(parent)
            self.procs.append(proc)

    def ask(
        self, which: list[int], name: str | None = None, args: list[Any] | None = None
    ) -> list[Any]:
        """Send a command to each chain of ``which`` (all first, so they work side by side),
        then collect the answers in order; a chain's error is raised here."""
        if name is not None:
            for n, i in enumerate(which):
                self.conns[i].send((name, None if args is None else args[n]))
        out = []
        for i in which:
            while not self.conns[i].poll(POLL_S):
                self.tick()
            try:
                kind, value = self.conns[i].recv()
            except EOFError:
                self.procs[i].join(timeout=1.0)
                code = self.procs[i].exitcode
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
        n = len(self.procs)
        iterations = sum(int(self.shared[2 * i]) for i in range(n))
        best = max(self.shared[2 * i + 1] for i in range(n))
        self.progress.update(iterations, best or None)  # None: the chains are still building

    def close(self) -> None:
        for conn in self.conns:
            conn.close()
        for proc in self.procs:
            proc.join(timeout=1.0)
            if proc.is_alive():
                proc.terminate()
                proc.join()


def run_parallel(
    instance: Instance,
    mode: str,
    *,
    rng: np.random.Generator,
    time_limit: float | None,
    params: ASAParams,
) -> Result:
    """Run ``params.workers`` cooperating chains (module docstring) and return the best.

    Parameters
    ----------
    instance, mode, rng, time_limit
        As :func:`heuristics.asa.search.run_asa`; ``rng`` only spawns the chains' generators.
    params
        The chains' parameters; ``workers`` chains, limit cut into ``epochs`` parts.
        ``iterations`` and ``no_improve`` count per chain.

    Returns
    -------
    Result
        The best chain's result; ``iterations`` is the sum over the chains, ``stats["chains"]``
        holds each chain's best, iterations and adoptions, ``stats["epochs"]`` the best of all
        after each epoch.
    """
    t0 = time.perf_counter()
    n = params.workers
    child_params = replace(params, workers=1)
    chains = _Chains(instance, mode, rng.spawn(n), time_limit, child_params)
    try:
        everyone = list(range(n))
        chains.ask(everyone)  # built: candidates and initial solutions
        epochs = params.epochs
        iterations = params.iterations
        if time_limit is None and iterations is None and params.no_improve is None:
            iterations = DEFAULT_ITERATIONS
        if time_limit is None and iterations is None:
            epochs = 1  # no_improve alone: nothing to cut into parts
        live = everyone
        history: list[float] = []
        for e in range(1, epochs + 1):
            last = None if iterations is None else math.ceil(iterations * e / epochs)
            seconds = None
            if time_limit is not None:
                seconds = max(0.0, t0 + time_limit * e / epochs - time.perf_counter())
            answers = chains.ask(live, "run", [(last, seconds)] * len(live))
            bests = dict(zip(live, (a[0] for a in answers), strict=True))
            if params.no_improve is not None:
                # A chain stopped by its own no_improve rule is done.
                live = [i for i, a in zip(live, answers, strict=True) if a[1] < params.no_improve]
            top = max(bests.values())
            leader = min(i for i, b in bests.items() if b == top)
            history.append(top)
            log.debug("asa x%d: epoch %d/%d, best %g (chain %d)", n, e, epochs, top, leader)
            behind = [i for i in live if bests[i] < top - 1e-9]
            if e < epochs and behind:
                (snap,) = chains.ask([leader], "snap")
                chains.ask(behind, "adopt", [(snap, top)] * len(behind))
            if not live or stop_requested():
                break
        results: list[Result] = chains.ask(everyone, "result")
    finally:
        chains.close()
    best = max(range(n), key=lambda i: (results[i].profit, -i))
    out = results[best]
    out.stats["chains"] = [
        {"best": r.profit, "iterations": r.iterations, "adopted": r.stats["adopted"]}
        for r in results
    ]
    out.stats["epochs"] = history
    out.stats["workers"] = n
    out.iterations = sum(r.iterations or 0 for r in results)
    out.runtime_s = time.perf_counter() - t0
    return out
