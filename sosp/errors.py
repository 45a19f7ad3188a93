"""Errors raised by sosp.

Every problem with user input (files, parameters, references) raises :class:`InputError` with a
one-line message naming the file, field or row, so the CLI can print it and exit with code 2.
"""

from __future__ import annotations


class SospError(Exception):
    """Base class of sosp's own errors."""


class InputError(SospError, ValueError):
    """Bad input: a malformed file, an out-of-range value or impossible parameters.

    The message is one line and names the file, field or row at fault.
    """

    def __init__(self, message: str, *, source: str | None = None) -> None:
        self.source = source
        text = " ".join(str(message).split())  # always one line
        super().__init__(f"{source}: {text}" if source else text)


class TimeLimitReached(InputError):
    """A stage that cannot answer in part (candidate generation, their arranging) ran out of
    its time limit, or would have: :mod:`sosp.planner` does not start an orbit foreseen to
    end past it, so the error can come before the limit. Callers with something to fall
    back on catch this class, not the clock; elsewhere it is a one-line error as any other
    :class:`InputError` (exit code 2)."""
