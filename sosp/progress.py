"""Progress of a running solve, for a live status line.

A search reports its state from its stopping checks: a :class:`Progress` is itself a
stopping criterion that never stops (put it first in a :class:`~sosp.stop.FirstOf`), or it is
called with :meth:`Progress.update` by a search whose loop has no criterion object. Either
call costs one clock reading until ``interval`` seconds have passed; then the progress
takes a :class:`Snapshot` and hands it to its callback. The library never prints: the
callback belongs to the application (the CLI installs a :class:`StatusLine`).

The searches find the progress of the solve in hand with :func:`current`, which
:func:`sosp.solve.solve` sets for the duration of a call (``solve(..., progress=p)``); like
the logging configuration, it is ambient so that the methods' signatures stay their
parameters. Outside a solve, :func:`current` is a silent progress that only keeps the last
snapshot.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TextIO

from sosp.stop import SearchStatus


@dataclass(frozen=True)
class Snapshot:
    """The state of a solve at one moment.

    Attributes
    ----------
    method
        The method being run.
    elapsed
        Seconds since the solve started.
    iterations
        Iterations reported by the search (its own unit: moves, steps, nodes).
    best
        Profit (1) of the best schedule so far (None before the first report).
    bound
        A proven upper bound, when the search has one.
    rate
        Iterations per second since the previous snapshot (None for the first).
    """

    method: str
    elapsed: float
    iterations: int
    best: float | None
    bound: float | None = None
    rate: float | None = None

    @property
    def gap(self) -> float | None:
        """Relative gap ``(bound - best) / bound`` when both are known (as ``Result.gap``)."""
        if self.bound is None or self.best is None:
            return None
        if self.bound <= 0:
            return 0.0
        return max(0.0, (self.bound - self.best) / self.bound)


class Progress:
    """Rate-limited sink of a search's state (module docstring).

    Parameters
    ----------
    callback
        Called with each :class:`Snapshot` (None: only :attr:`last` is kept).
    interval
        Seconds between two snapshots at least.
    clock
        Time source (``time.perf_counter``; tests pass a fake one).
    """

    def __init__(
        self,
        callback: Callable[[Snapshot], None] | None = None,
        interval: float = 0.5,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.callback = callback
        self.interval = float(interval)
        self.clock = clock
        self.start("")

    def start(self, method: str) -> None:
        """A solve of ``method`` begins: elapsed time counts from now."""
        self.method = method
        self.last: Snapshot | None = None
        self.t0 = self.clock()
        self._next = self._tick_next = self.t0 + self.interval

    def __call__(self, status: SearchStatus) -> bool:
        """Stopping-criterion form: report ``status`` when due; never stops."""
        if self.clock() >= self._next:
            self.update(status.iteration, status.best, status.bound, force=True)
        return False

    def update(
        self,
        iterations: int,
        best: float | None,
        bound: float | None = None,
        *,
        force: bool = False,
    ) -> None:
        """Report the search's state; a snapshot is taken when ``interval`` has passed since
        the last one, or at once with ``force``. ``best`` None keeps the last one known (a
        search reporting from deep inside, where only its iteration count is at hand)."""
        now = self.clock()
        if not force and now < self._next:
            return
        self._next = now + self.interval
        elapsed = now - self.t0
        rate = None
        prev = self.last
        if best is None and prev is not None:
            best = prev.best
        if prev is not None and elapsed > prev.elapsed and iterations >= prev.iterations:
            rate = (iterations - prev.iterations) / (elapsed - prev.elapsed)
        snap = Snapshot(self.method, elapsed, int(iterations), best, bound, rate)
        self.last = snap
        if self.callback is not None:
            self.callback(snap)

    def tick(self) -> None:
        """Show the last state known with the time now, when due (from :meth:`ticking`'s
        thread: a method inside a long step, HiGHS or its preparation reports nothing, and
        its line would stay blank or frozen). The iteration rate is not known then."""
        now = self.clock()
        if now < self._next or now < self._tick_next:  # a report is not overdue, or drawn
            return
        self._tick_next = now + self.interval  # the search's own reports keep their slots
        last = self.last
        snap = Snapshot(
            self.method,
            now - self.t0,
            0 if last is None else last.iterations,
            None if last is None else last.best,
            None if last is None else last.bound,
        )
        if self.callback is not None:
            self.callback(snap)

    @contextmanager
    def ticking(self, period: float = 0.25) -> Iterator[None]:
        """Within the block, a thread calls :meth:`tick` every ``period`` seconds, so the
        status line appears within a second of the start and its clock keeps running."""
        done = threading.Event()

        def run() -> None:
            while not done.wait(period):
                self.tick()

        thread = threading.Thread(target=run, name="sosp-progress", daemon=True)
        thread.start()
        try:
            yield
        finally:
            done.set()
            thread.join(timeout=1.0)


_current: list[Progress] = [Progress()]


def current() -> Progress:
    """The progress of the solve in hand (a silent one outside :func:`reporting`)."""
    return _current[-1]


@contextmanager
def reporting(progress: Progress | None) -> Iterator[Progress]:
    """Make ``progress`` the :func:`current` one within the block (None: a silent one)."""
    p = Progress() if progress is None else progress
    _current.append(p)
    try:
        yield p
    finally:
        _current.pop()


# --------------------------------------------------------------------------- the CLI's view
def format_snapshot(snap: Snapshot) -> str:
    """One status line: method, elapsed, best, bound and gap when known, iterations/s."""
    parts = [snap.method or "solving", f"{snap.elapsed:6.1f} s"]
    if snap.best is not None:
        parts.append(f"best {snap.best:g}")
    if snap.bound is not None:
        parts.append(f"bound {snap.bound:g}")
        gap = snap.gap
        if gap is not None:
            parts.append(f"gap {100 * gap:.2f}%")
    if snap.rate is not None:
        parts.append(f"{snap.rate:,.0f} it/s")
    return "  ".join(parts)


class StatusLine:
    """The CLI's progress callback: a status line on ``stream`` (stderr).

    Nothing is shown during the first ``delay`` seconds (solves of under a second stay quiet;
    a user waiting longer sees the line within about a second, not after three). On a
    terminal the line is rewritten in place (``\\r``) at every snapshot; otherwise (a log
    file, a pipe) a plain line is written every ``every`` seconds. :meth:`close` clears the
    terminal line so the final summary starts on a clean line.
    """

    def __init__(
        self, stream: TextIO, tty: bool | None = None, delay: float = 1.0, every: float = 10.0
    ) -> None:
        self.stream = stream
        self.tty = stream.isatty() if tty is None else tty
        self.delay = delay
        self.every = every
        self._width = 0
        self._printed_at: float | None = None
        self._lock = threading.Lock()  # the solve's thread and the ticking one both draw

    def __call__(self, snap: Snapshot) -> None:
        with self._lock:
            self._draw(snap)

    def _draw(self, snap: Snapshot) -> None:
        if snap.elapsed < self.delay:
            return
        line = format_snapshot(snap)
        if self.tty:
            pad = max(0, self._width - len(line))
            self.stream.write("\r" + line + " " * pad)
            self._width = len(line)
        else:
            if snap.elapsed < (self._printed_at or 0.0) + self.every:
                return
            self.stream.write(line + "\n")
            self._printed_at = snap.elapsed
        self.stream.flush()

    def stopping(self, reason: str) -> None:
        """Acknowledge a stop request at once (called from the signal watcher's thread): the
        user sees that the first Ctrl-C was heard and need not press it again."""
        self.close()
        self.stream.write(
            f"{reason}: stopping, the best schedule so far will be written "
            "(press Ctrl-C again to abort without writing)\n"
        )
        self.stream.flush()

    def filter(self, record: logging.LogRecord) -> bool:
        """As a filter of the log handlers writing to the same terminal: clear the live line
        before each record, so a log line never lands after the status text (the next
        snapshot draws it again)."""
        self.close()
        return True

    def close(self) -> None:
        """Clear the live line (terminal only)."""
        if self.tty and self._width:
            self.stream.write("\r" + " " * self._width + "\r")
            self.stream.flush()
            self._width = 0
