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
