"""Stopping criteria shared by every search, and the process-wide stop flag.

A criterion is a small callable (in the style of PyVRP's ``pyvrp.stop``): called with the
search's :class:`SearchStatus` at each stopping check, it returns True to stop. Searches
combine them with :class:`FirstOf`; none of them draws random numbers, so a criterion never
changes what a seeded search does before it stops.

:class:`Interrupted` stops a search once :func:`request_stop` was called: from another
thread, or from a signal handler installed by :func:`handle_signals` (the CLI installs it,
so Ctrl-C or SIGTERM ends the search and the best schedule found so far is kept). Reading the
flag is one attribute lookup, cheap enough for every iteration.

:class:`Budget` is the time (and memory) a piece of work may take: one object passed down
instead of deadline floats, cut into sub-budgets that never outlast their parent.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from types import SimpleNamespace
from typing import Any, Protocol


@dataclass
class SearchStatus:
    """What a stopping criterion (and a :class:`~sosp.progress.Progress`) may look at.

    Attributes
    ----------
    iteration
        Iterations (moves, steps, nodes) done so far.
    since_best
        Iterations since the last new best.
    best
        Profit (1) of the best schedule found so far.
    bound
        A proven upper bound on the optimum, when the search has one.
    """

    iteration: int = 0
    since_best: int = 0
    best: float = 0.0
    bound: float | None = None


class StoppingCriterion(Protocol):
    def __call__(self, status: SearchStatus) -> bool: ...


class MaxIterations:
    """Stop after ``n`` iterations."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __call__(self, status: SearchStatus) -> bool:
        return status.iteration >= self.n


class MaxRuntime:
    """Stop once ``seconds`` of wall time have passed since ``start`` (default: construction).

    ``start`` is a ``clock()`` value, for a search whose limit counts from before the
    criterion is built (e.g. candidate generation included). With ``foresee``, it also stops
    when the longest time between two of its checks (one iteration, for a search that checks
    once per iteration) would pass the deadline: a search whose single iteration can take
    seconds (ASA-DTC re-planning a whole orbit of 4,714 opportunities over windows: up to
    1.9 s) then ends before the limit rather than up to that long after it.
    """

    def __init__(
        self,
        seconds: float,
        clock: Callable[[], float] = time.perf_counter,
        start: float | None = None,
        foresee: bool = False,
    ) -> None:
        self.clock = clock
        self.deadline = (clock() if start is None else start) + seconds
        self.foresee = foresee
        self.last: float | None = None
        self.longest = 0.0

    def __call__(self, status: SearchStatus) -> bool:
        now = self.clock()
        if self.foresee:
            if self.last is not None:
                self.longest = max(self.longest, now - self.last)
            self.last = now
            return now + self.longest >= self.deadline
        return now >= self.deadline


class Foresight:
    """Seconds a repeated, uninterruptible job (an orbit's plan, its window columns) is
    foreseen to take, so that a search starts it only when it ends in time.

    A job is known by its key and its size ``work``. It is foreseen at its own last time,
    else at ``work`` times the rate: seconds per unit of work of the timed jobs (only those
    of at least ``min_work``, whose fixed costs do not dominate), before any
    ``prior``. With ``most``, the rate is the most seen and never below ``prior`` (for a
    cost that varies between jobs); without, the last one seen (for a cost that falls as
    the search goes on, such as plans at prices that cover more targets).

    Parameters
    ----------
    prior
        Seconds per unit of work before any job was timed (0: foresee nothing).
    most
        Keep the most rate seen (at least ``prior``) instead of the last.
    min_work
        Jobs of less work set no rate.
    """

    def __init__(self, prior: float, most: bool = False, min_work: float = 0.0) -> None:
        self.prior = prior
        self.most = most
        self.min_work = min_work
        self.rate = prior if most else 0.0
        self.took: dict[Any, float] = {}  # each job's last time

    def rate_or_prior(self) -> float:
        """Seconds per unit of work a job not timed yet is foreseen at."""
        return self.rate or self.prior

    def __call__(self, key: Any, work: float) -> float:
        """Seconds job ``key`` of size ``work`` is foreseen to take."""
        return self.took[key] if key in self.took else self.rate_or_prior() * work

    def late(self, key: Any, work: float, deadline: float | None) -> bool:
        """Whether job ``key`` of size ``work``, started now, is foreseen to end past
        ``deadline`` (a :func:`time.perf_counter` value; None: never)."""
        return deadline is not None and time.perf_counter() + self(key, work) > deadline

    def record(self, key: Any, work: float, seconds: float) -> None:
        """Job ``key`` of size ``work`` took ``seconds``."""
        self.took[key] = seconds
        if work >= max(self.min_work, 1e-300):
            rate = seconds / work
            self.rate = max(self.rate, rate) if self.most else rate


class NoImprovement:
    """Stop after ``n`` consecutive iterations without a new best."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __call__(self, status: SearchStatus) -> bool:
        return status.since_best >= self.n


class FirstOf:
    """Stop when any of the criteria says so (an empty list never stops).

    The criteria are asked in order and the first True ends the check, so a criterion with a
    side effect that must run at every check (a :class:`~sosp.progress.Progress`) goes first.
    """

    def __init__(self, *criteria: StoppingCriterion) -> None:
        self.criteria = criteria

    def __call__(self, status: SearchStatus) -> bool:
        for c in self.criteria:  # a loop, not any(genexpr): this runs every iteration
            if c(status):
                return True
        return False


# --------------------------------------------------------------------------- stop flag
#: The process-wide stop request and what asked for it (plain attributes: one lookup per check).
_FLAG = SimpleNamespace(requested=False, reason=None, cap=None)


def request_stop(reason: str = "requested") -> None:
    """Ask every running search of this process to stop at its next check (thread-safe: it
    only sets a flag). The searches return their best schedule so far."""
    _FLAG.reason = _FLAG.reason or reason
    _FLAG.requested = True


def stop_requested() -> bool:
    """True once :func:`request_stop` was called (until :func:`clear_stop`)."""
    return _FLAG.requested


def stop_reason() -> str | None:
    """What asked to stop (e.g. ``"SIGINT"``), or None."""
    return _FLAG.reason if _FLAG.requested else None


def clear_stop() -> None:
    """Forget a stop request, so the next search runs to its own limits."""
    _FLAG.requested = False
    _FLAG.reason = None


def reached_cap(best: float) -> bool:
    """True when profit ``best`` reaches the cap of the solve in hand (:func:`capped`): every
    target that can be observed is, so no schedule does better and a search can stop."""
    cap = _FLAG.cap
    return cap is not None and best >= cap - 1e-6


@contextmanager
def capped(cap: float | None) -> Iterator[None]:
    """Within the block, a profit of ``cap`` (the weight of the targets with an opportunity)
    is known to be optimal: :class:`Interrupted` and :func:`reached_cap` stop a search that
    reaches it (None: no cap)."""
    before, _FLAG.cap = _FLAG.cap, cap
    try:
        yield
    finally:
        _FLAG.cap = before


class Interrupted:
    """Stop once :func:`request_stop` was called (e.g. by Ctrl-C under :func:`handle_signals`),
    or once the best profit reaches the solve's cap (:func:`capped`): nothing is left to find
    (a search that ran to its limit there spent it for nothing)."""

    def __call__(self, status: SearchStatus | None = None) -> bool:
        return _FLAG.requested or (status is not None and reached_cap(status.best))


def _no_wakeup_in_child() -> None:
    """A forked child does not write its signals to its parent's wakeup pipe (a pool's
    SIGTERM to its workers would stop the parent's solve)."""
    try:
        signal.set_wakeup_fd(-1)
    except ValueError:  # forked from another thread: Python cannot change it there
        pass


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_no_wakeup_in_child)


@contextmanager
def handle_signals(
    signals: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM),
    on_stop: Callable[[str], None] | None = None,
) -> Iterator[None]:
    """Within the block, the first of ``signals`` requests a stop; a second one raises
    :class:`KeyboardInterrupt` (for a user who does not want to wait for the search's next
    check). The previous handlers are restored on exit and the flag is cleared on entry and
    exit. Outside the main thread (where Python cannot install handlers) it does nothing.

    The stop is requested at once, also while the main thread is inside a long call into
    compiled code (a numba kernel, HiGHS), where Python runs no signal handler until the call
    returns: the signal is written to a wakeup pipe (:func:`signal.set_wakeup_fd`) that a
    thread reads, which requests the stop (the solvers' callbacks see it) and calls
    ``on_stop(reason)`` (the CLI acknowledges the signal on its status line).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    seen = [0]  # signals the Python handler has run for

    def handler(signum: int, frame: Any) -> None:
        seen[0] += 1
        if seen[0] > 1:
            raise KeyboardInterrupt
        request_stop(signal.Signals(signum).name)

    wanted = {int(s) for s in signals}
    read, write = os.pipe()
    os.set_blocking(write, False)

    def watch() -> None:
        while data := os.read(read, 64):  # b"": the pipe was closed (the block ended)
            for signum in data:
                if signum in wanted and not _FLAG.requested:
                    request_stop(signal.Signals(signum).name)
                    if on_stop is not None:
                        on_stop(signal.Signals(signum).name)

    previous = {s: signal.getsignal(s) for s in signals}
    clear_stop()
    old_fd = signal.set_wakeup_fd(write, warn_on_full_buffer=False)
    watcher = threading.Thread(target=watch, name="sosp-signals", daemon=True)
    watcher.start()
    try:
        for s in signals:
            signal.signal(s, handler)
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        signal.set_wakeup_fd(old_fd)
        os.close(write)
        watcher.join(timeout=1.0)
        os.close(read)
        clear_stop()


# ------------------------------------------------------------------------------- budget
@dataclass(frozen=True)
class Budget:
    """The time (and memory) a piece of work may take, passed down instead of deadlines.

    Picklable: a child process given one keeps its end (:func:`time.perf_counter` reads a
    clock shared by the processes of a machine).

    Attributes
    ----------
    deadline
        :func:`time.perf_counter` value at which the time is up (None: no limit), for code
        that still takes a float.
    memory
        Bytes the work may hold (None: no limit); carried to sub-budgets.
    """

    deadline: float | None = None
    memory: int | None = None

    @classmethod
    def of(cls, time_limit: float | None, memory: int | None = None) -> Budget:
        """``time_limit`` seconds from now (None: no limit)."""
        return cls.until(None if time_limit is None else time.perf_counter() + time_limit, memory)

    @classmethod
    def until(cls, deadline: float | None, memory: int | None = None) -> Budget:
        """Until ``deadline``, a :func:`time.perf_counter` value (None: no limit)."""
        return cls(None if deadline is None else float(deadline), memory)

    def left(self) -> float | None:
        """Seconds left, at least 0 (None: no limit)."""
        return None if self.deadline is None else max(0.0, self.deadline - time.perf_counter())

    def fits(self, seconds: float) -> bool:
        """Whether work of ``seconds``, started now, ends in time (False once a stop was
        requested, :func:`request_stop`)."""
        end = self.deadline
        return not _FLAG.requested and (end is None or time.perf_counter() + seconds <= end)

    def expired(self) -> bool:
        """True once the time is up or a stop was requested (:func:`request_stop`)."""
        return not self.fits(0.0)

    def child(self, seconds: float | None = None, *, fraction: float | None = None) -> Budget:
        """A sub-budget of at most ``seconds`` from now and at most ``fraction`` of the time
        left (None: no such cap); it never ends after this one."""
        now, left = time.perf_counter(), self.left()
        caps = [seconds, None if fraction is None or left is None else fraction * left]
        ends = [self.deadline, *(now + c for c in caps if c is not None)]
        return replace(self, deadline=min((e for e in ends if e is not None), default=None))

    def share(self, fraction: float) -> Budget:
        """A sub-budget of ``fraction`` of the time left (unlimited stays unlimited)."""
        return self.child(fraction=fraction)
