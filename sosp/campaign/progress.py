"""Progress of a campaign on stderr: a live line on a terminal, plain lines otherwise."""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO


def _hms(seconds: float) -> str:
    s = int(round(max(0.0, seconds)))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


class Progress:
    """Finished/total, failures and an ETA from the mean time per finished run.

    Parameters
    ----------
    total
        Runs to do in this call.
    stream
        Where to write (stderr by default).
    interactive
        Rewrite one line in place (a terminal); default: ``stream.isatty()``. Otherwise a
        plain line is written at most every ``interval`` seconds and at the end.
    interval
        Seconds between plain lines.
    t0
        When the campaign started (``time.monotonic``; default: now). The caller learns
        ``total`` only with the first result, and the time before it counts too: without it
        the first ETA read 0:00:00 and the elapsed time ran behind the summary's.
    """

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        interactive: bool | None = None,
        interval: float = 10.0,
        t0: float | None = None,
    ) -> None:
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        if interactive is None:
            isatty = getattr(self.stream, "isatty", None)
            interactive = bool(isatty and isatty())
        self.interactive = interactive
        self.interval = interval
        self.done = 0
        self.failed = 0
        self.t0 = time.monotonic() if t0 is None else t0
        self._last = -float("inf")

    def line(self) -> str:
        elapsed = time.monotonic() - self.t0
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        pct = 100.0 * self.done / self.total if self.total else 100.0
        eta_s = _hms(eta) if self.done else "?"
        return (
            f"bench: {self.done}/{self.total} runs ({pct:.0f}%), {self.failed} failed, "
            f"elapsed {_hms(elapsed)}, ETA {eta_s}"
        )

    def update(self, row: dict[str, Any], *_: Any) -> None:
        """Count one finished run (a callback for :func:`~sosp.campaign.runner.run_campaign`)."""
        self.done += 1
        if row.get("status") == "error":
            self.failed += 1
        now = time.monotonic()
        if self.interactive:
            self.stream.write("\r" + self.line() + "\x1b[K")
            self.stream.flush()
        elif now - self._last >= self.interval or self.done == self.total:
            self._last = now
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def close(self) -> None:
        if self.interactive and self.done:
            self.stream.write("\n")
            self.stream.flush()
