"""Parallel work, written once: Dask clusters, forked pools and guarded child processes.

* Dask clusters (optional: ``pip install -e '.[dist]'``) for work that one machine does too
  slowly;
* the signal rules of forked workers (:func:`worker_signals`, :func:`held_for_fork`) and a
  pool of them that shares data copy-on-write (:func:`fork_pool`, :func:`inherited`);
* a guarded child process that answers through a pipe and is ended with its parent
  (:class:`Child`, :func:`child_setup`);
* independent calls whose results are taken as they finish, in processes or on a cluster
  (:func:`completed`: a campaign's runs).

Two kinds of work use a cluster:

* a campaign's runs (``sosp bench --dask``, :func:`sosp.campaign.runner.run_campaign`), one
  task per run;
* the pricing rounds of the bounds and of ``orbit-dp``'s start (``sosp bound --dask``,
  ``--param dask=`` of ``orbit-dp``): :class:`sosp.planner.PlanPool` sends each orbit's
  arrays to the workers once and then only the prices of each round.

Where it pays and where it does not is measured in ``docs/scenarios.md`` ("Several
processes, several machines"). Dask is imported here only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, ExitStack, contextmanager, nullcontext
from typing import TYPE_CHECKING, Any, TypeAlias

from sosp.errors import InputError

if TYPE_CHECKING:
    from distributed import Client

#: Where per-orbit work runs: processes on this machine, or a Dask cluster's client.
Workers: TypeAlias = "int | Client"

log = logging.getLogger(__name__)


def is_client(obj: Any) -> bool:
    """Whether ``obj`` is a Dask ``distributed.Client`` (duck-typed: Dask is optional)."""
    return hasattr(obj, "submit") and hasattr(obj, "scatter") and hasattr(obj, "gather")


@contextmanager
def dask_client(address: Any, workers: int | None = None) -> Iterator[Any]:
    """A ``distributed.Client`` for the duration of the block.

    Parameters
    ----------
    address
        An existing client (used as is, left open), ``"local"`` (a ``LocalCluster`` of
        ``workers`` single-threaded processes on this machine, closed on exit) or a
        scheduler's address (``tcp://host:8786``).
    workers
        Processes of a local cluster (None: Dask's default, one per core).

    Raises
    ------
    InputError
        Dask is not installed, or the scheduler cannot be reached (one line naming
        ``--dask``).
    """
    if is_client(address):
        yield address
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError("--dask: Dask is not installed (pip install -e '.[dist]')") from None
    if not isinstance(address, str) or not address:
        raise InputError(f"--dask: expected 'local' or a scheduler address, got {address!r}")
    with _quiet(logging.WARNING), ExitStack() as stack:  # closed: the client, the cluster
        if address == "local":
            # ":0": any free port. None still binds Dask's HTTP server to 8787 and warns
            # ("Port 8787 is already in use") beside another cluster on the same machine
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=":0")
            stack.callback(cluster.close)
            client = Client(cluster)
        else:
            try:
                client = Client(address, timeout=10)
            except OSError as exc:
                raise InputError(f"--dask: cannot connect to {address}: {exc}") from None
        stack.callback(client.close)
        log.info("dask cluster %s: %d worker thread(s)", address, cluster_size(client))
        yield client


def workers_for(
    processes: int, dask: Any = None, local: int | None = None
) -> AbstractContextManager[Any]:
    """Where a run's per-orbit work goes: ``processes`` on this machine, or with ``dask`` (an
    address or client as :func:`dask_client` takes it; ``local`` processes for ``"local"``)
    a client of that cluster for the duration of the block."""
    return nullcontext(processes) if dask is None else dask_client(dask, local)


@contextmanager
def _quiet(level: int) -> Iterator[None]:
    """Within the block, Dask's own loggers at ``level`` at least (Dask configures them at
    INFO: a local cluster logs some forty lines and a harmless traceback on closing); their
    levels are restored on exit. sosp's own messages keep theirs."""
    old = {}
    for name in list(logging.root.manager.loggerDict):
        if name == "distributed" or name.startswith("distributed."):
            logger = logging.getLogger(name)
            if logger.level < level:
                old[name] = logger.level
                logger.setLevel(level)
    try:
        yield
    finally:
        for name, old_level in old.items():
            logging.getLogger(name).setLevel(old_level)


def cluster_size(client: Any) -> int:
    """Worker threads of the cluster behind ``client`` (at least 1)."""
    info = client.scheduler_info().get("workers", {})
    return max(1, sum(int(w.get("nthreads", 1)) for w in info.values()))


def parallelism(workers: Any) -> int:
    """How many orbits are planned at once: ``workers`` processes, or a client's threads."""
    return cluster_size(workers) if is_client(workers) else max(1, int(workers))


def local_processes(workers: Any) -> int:
    """Processes of this machine for work that stays here (candidate generation): ``workers``,
    or 1 beside a cluster."""
    return 1 if is_client(workers) else max(1, int(workers))


def check_workers(workers: Any, name: str = "workers") -> None:
    """Raise :class:`InputError` unless ``workers`` is a positive integer or a client."""
    bad = isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    if bad and not is_client(workers):
        raise InputError(f"{name}: expected a positive integer, got {workers!r}")


# --------------------------------------------------------------------------- signals
def worker_signals() -> None:
    """Initialiser of a forked pool's workers: SIGTERM ends the worker, SIGINT is ignored.

    A forked worker inherits :func:`sosp.stop.handle_signals`'s handler, under which SIGTERM
    only requests a stop. ``multiprocessing.Pool.terminate`` ends its workers with one SIGTERM
    and then waits for them, so a worker blocked on the pool's task queue lived on and the
    parent waited for ever (a pricing pool closed inside ``sosp solve``: one close in a few
    hung). Ctrl-C reaches the whole process group; the parent decides what stops.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):  # held since the fork (held_for_fork)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _HELD)
    exit_with_parent()


def exit_with_parent(every_s: float = 0.5) -> None:
    """In a pool's worker: end it once its parent is gone (checked every ``every_s``).

    A parent killed outright (a notebook kernel stopped or restarted, ``kill -9``) cannot
    close its pool, and a worker waiting on the task queue would live on as an orphan."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(every_s)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


#: The signals :func:`held_for_fork` holds.
_HELD = {signal.SIGTERM, signal.SIGINT}


@contextmanager
def held_for_fork() -> Iterator[None]:
    """Hold SIGTERM and SIGINT (pending, not lost) in this thread while a pool forks its
    workers, which :func:`worker_signals` then releases in each worker.

    A worker forked under :func:`sosp.stop.handle_signals` keeps its handler until the
    initialiser runs; a SIGTERM from ``Pool.terminate`` in that window only requested a stop,
    the worker lived on and the parent's join waited for ever (a pricing pool closed at once,
    on a loaded machine: a test hung). Held, the signal waits in the worker until the
    initialiser has set its default disposition. Threads the pool starts here inherit the
    mask, so the workers it forks later are held too.
    """
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


# --------------------------------------------------------------------------- forked pools
#: What the workers of the pool being forked inherit (:func:`inherited`).
_INHERITED: Any = None


def inherited() -> Any:
    """In a :func:`fork_pool`'s worker: the ``shared`` object the pool was forked with."""
    return _INHERITED


def fork_pool(processes: int, shared: Any = None) -> Any:
    """A ``multiprocessing`` pool of ``processes`` forked workers, or None where one process
    is enough (``processes`` <= 1) or processes cannot be forked (not on Windows; macOS has
    fork, not as default): the caller works here.

    The workers find ``shared`` by :func:`inherited`: forked, they share it copy-on-write and
    nothing is pickled but each task's arguments and result. Their signals follow
    :func:`worker_signals` (held from the fork, :func:`held_for_fork`), so the pool's
    ``terminate`` always ends them. The caller closes the pool (``with pool:`` or
    ``terminate``).
    """
    global _INHERITED
    import multiprocessing as mp

    if processes <= 1 or "fork" not in mp.get_all_start_methods():
        return None
    _INHERITED = shared
    try:
        with held_for_fork():
            return mp.get_context("fork").Pool(processes, initializer=worker_signals)
    finally:
        _INHERITED = None


# --------------------------------------------------------------------------- child processes
class ChildStartError(RuntimeError):
    """A child process ended before it had read its work (:class:`Child`)."""


def child_setup() -> None:
    """Set up a solver's child process (a guarded solve's, a side branch and price's): Ctrl-C
    is the parent's to handle, and the child ends when its parent does. A parent killed
    outright (SIGKILL, SIGTERM) cannot stop its children, which would otherwise run on until
    their own time limits as orphans."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def _unpack(payload: Any, target: Callable[..., None], args: tuple[Any, ...]) -> None:
    """A :class:`Child` with work: read the work from ``payload``, then run ``target``."""
    work = payload.recv()
    payload.close()
    target(*args, *work)


class Child:
    """``target(conn, *args, *work)`` in a daemonic child process that answers through a pipe.

    ``conn`` is the child's end of the pipe (write-only unless ``duplex``), :attr:`conn` the
    parent's. ``args`` (connections, events: what must be inherited) go with the start,
    ``work`` (the large part: a model's arrays, an instance) through a second pipe once it has
    started. Sent with the start, a payload larger than a pipe's buffer blocks the parent for
    ever when the child ends before reading it, which is what a child does that imports a
    script without the ``__main__`` guard: it runs the script, whose solve fails to start a
    grandchild (andes-300's `milp` from such a script, 120 s limit, was still blocked in its
    side process's start when killed at 400 s). Through the pipe the parent's write fails
    instead.

    Parameters
    ----------
    target, args, work
        As above; ``target`` calls :func:`child_setup` if it is a solver's child.
    method
        The start method: ``"spawn"`` (default: a forked child would inherit HiGHS's
        process-wide task scheduler without its threads), or None for the platform's default.
    duplex
        Whether the parent may send to the child too.

    Raises
    ------
    ChildStartError
        The child ended before it read ``work``.
    """

    def __init__(
        self,
        target: Callable[..., None],
        args: tuple[Any, ...] = (),
        work: tuple[Any, ...] = (),
        *,
        method: str | None = "spawn",
        duplex: bool = False,
    ) -> None:
        import multiprocessing as mp

        ctx = mp.get_context(method)
        self.conn, end = ctx.Pipe(duplex=duplex)
        try:
            if not work:
                self.proc = ctx.Process(target=target, args=(end, *args), daemon=True)
                self.proc.start()
                return
            recv, send = ctx.Pipe(duplex=False)
            self.proc = ctx.Process(target=_unpack, args=(recv, target, (end, *args)), daemon=True)
            self.proc.start()
            recv.close()
            try:
                send.send(work)
            except OSError:  # BrokenPipeError: nobody reads the other end
                self.stop()
                raise ChildStartError(
                    f"a solver's child process ended at its start (exit code "
                    f"{self.proc.exitcode}): a script that solves should do so under "
                    '`if __name__ == "__main__":`, since the solver\'s child processes import '
                    "it again (multiprocessing's spawn)"
                ) from None
            finally:
                send.close()
        except BaseException:
            self.conn.close()
            raise
        finally:
            end.close()

    def stop(self, wait: float = 0.0) -> None:
        """End the child (after up to ``wait`` seconds for it to end by itself; then SIGTERM,
        and SIGKILL if it is still there 5 s later) and close the parent's end of the pipe."""
        proc = self.proc
        proc.join(wait)
        if proc.is_alive():
            proc.terminate()
        proc.join(timeout=5.0)
        if proc.is_alive():  # pragma: no cover - SIGTERM ignored
            proc.kill()
            proc.join()
        self.conn.close()


# --------------------------------------------------------------------------- completions
def completed(
    fn: Callable[[Any], Any],
    items: Sequence[Any],
    processes: int,
    dask: Any = None,
    lost: Callable[[Any, BaseException], None] | None = None,
) -> Iterator[Any]:
    """``fn(item)`` of every item, yielded as each finishes.

    In this process one after another when ``processes`` or the items are one (a failure
    raises), else in a pool of ``processes`` processes (``fn`` and the items are pickled), or
    with ``dask`` (as :func:`dask_client` takes it; ``processes`` workers of a ``"local"``
    cluster) on that cluster. In a pool or on a cluster a call that fails is passed to
    ``lost(item, exc)`` and skipped, but a broken process pool raises. Nothing starts before
    the first result is asked for.
    """
    if dask is None and (processes <= 1 or len(items) <= 1):
        for item in items:
            yield fn(item)
        return
    with ExitStack() as stack:
        if dask is None:
            from concurrent.futures import ProcessPoolExecutor, as_completed
            from concurrent.futures.process import BrokenProcessPool

            pool = stack.enter_context(
                ProcessPoolExecutor(min(processes, len(items)), initializer=exit_with_parent)
            )
            futures = {pool.submit(fn, item): item for item in items}
            stack.callback(lambda: [fut.cancel() for fut in futures])  # ended early
            fatal: tuple[type[BaseException], ...] = (BrokenProcessPool,)
        else:
            from distributed import as_completed

            client = stack.enter_context(dask_client(dask, processes))
            futures = {client.submit(fn, item, pure=False): item for item in items}
            fatal = ()
        for fut in as_completed(list(futures)):
            try:
                yield fut.result()
            except fatal:  # a broken process pool
                raise
            except Exception as exc:  # noqa: BLE001 - the caller's to report
                if lost is not None:
                    lost(futures[fut], exc)
            if dask is not None:
                fut.release()
