"""What every solver returns: a :class:`Result` with the schedule, status and measures."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from sosp.schedule import Schedule


class Status(StrEnum):
    """How a solve ended.

    ``optimal``: optimality proven (by any method whose schedule observes every target with
    an opportunity, :func:`sosp.solve.solve` says so). ``feasible``: a heuristic's schedule,
    optimality not proven. ``time_limit``: an exact method stopped at its limit with an incumbent.
    ``no_solution``: stopped without any schedule. ``infeasible``: proven infeasible.
    ``interrupted``: stopped on request (Ctrl-C, SIGTERM, :func:`sosp.stop.request_stop`)
    with the best schedule found so far.
    """

    OPTIMAL = "optimal"
    FEASIBLE = "feasible"
    TIME_LIMIT = "time_limit"
    NO_SOLUTION = "no_solution"
    INFEASIBLE = "infeasible"
    INTERRUPTED = "interrupted"


@dataclass
class Result:
    """The outcome of :func:`sosp.solve.solve`.

    Attributes
    ----------
    method
        Method name as registered in :data:`sosp.solve.METHODS`.
    status
        See :class:`Status`.
    schedule
        The best schedule found (empty when there is none).
    profit
        Objective (1) of ``schedule``.
    observed
        Number of targets observed.
    runtime_s
        Wall time of the solve, seconds.
    bound
        Best upper bound on the optimum, when the method proves one.
    iterations
        Search iterations, for iterative methods.
    stats
        Method-specific statistics (JSON-ready values).
    """

    method: str
    status: Status
    schedule: Schedule
    profit: float
    observed: int
    runtime_s: float = 0.0
    bound: float | None = None
    iterations: int | None = None
    stats: dict[str, Any] = field(default_factory=dict)

    @property
    def gap(self) -> float | None:
        """Relative gap ``(bound - profit) / bound`` (0 when both are 0), or None."""
        if self.bound is None:
            return None
        if self.bound <= 0:
            return 0.0
        return max(0.0, (self.bound - self.profit) / self.bound)

    def summary(self) -> dict[str, Any]:
        """A flat JSON-ready summary (what ``sosp solve --json`` prints)."""
        return {
            "method": self.method,
            "status": self.status.value,
            "profit": self.profit,
            "observed": self.observed,
            "observations": len(self.schedule),
            "bound": self.bound,
            "gap": self.gap,
            "iterations": self.iterations,
            "runtime_s": round(self.runtime_s, 6),
        }
