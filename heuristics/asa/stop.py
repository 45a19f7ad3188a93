"""Stopping criteria: small callables (PyVRP style), combined by :class:`FirstOf`.

Each is called once per iteration with the :class:`SearchStatus` and returns True to stop.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol


@dataclass
class SearchStatus:
    """What a stopping criterion may look at."""

    iteration: int = 0
    since_best: int = 0
    best: float = 0.0


class StoppingCriterion(Protocol):
    def __call__(self, status: SearchStatus) -> bool: ...


class MaxIterations:
    """Stop after ``n`` iterations."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __call__(self, status: SearchStatus) -> bool:
        return status.iteration >= self.n


class MaxRuntime:
    """Stop once ``seconds`` of wall time have passed since construction."""

    def __init__(self, seconds: float, clock=time.perf_counter) -> None:
        self.clock = clock
        self.deadline = clock() + seconds

    def __call__(self, status: SearchStatus) -> bool:
        return self.clock() >= self.deadline


class NoImprovement:
    """Stop after ``n`` consecutive iterations without a new best."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __call__(self, status: SearchStatus) -> bool:
        return status.since_best >= self.n


class FirstOf:
    """Stop when any of the criteria says so (an empty list never stops)."""

    def __init__(self, *criteria: StoppingCriterion) -> None:
        self.criteria = criteria

    def __call__(self, status: SearchStatus) -> bool:
        return any(c(status) for c in self.criteria)
