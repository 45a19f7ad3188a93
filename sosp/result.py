"""What every solver returns: a :class:`Result` with the schedule, status and measures."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
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


@dataclass(frozen=True)
class Stage:
    """One stage of a solve (:mod:`sosp.pipeline`) that ran.

    Attributes
    ----------
    kind
        ``"start"`` (the schedule the method starts from), ``"method"`` (the improving
        method) or ``"bound"`` (the certifying bound).
    name
        What ran: a method of :data:`sosp.registry.METHODS` or a bound of
        :data:`sosp.registry.BOUNDS`.
    seconds
        Its wall time.
    profit
        The profit (1) of its schedule (a start or a method).
    bound
        The upper bound it proved (a bound, or a method's own).
    """

    kind: str
    name: str
    seconds: float
    profit: float | None = None
    bound: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "seconds": round(self.seconds, 6)}


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
    stages
        The stages that ran, in order (:class:`Stage`; :mod:`sosp.pipeline`); a method
        that ran another in its place (ASA-DTC's large-instance fallback) names it here.
    restriction
        The restricted model (``static``, ``task``) that ``bound`` and an ``optimal``
        status refer to: the method solves that model, whose optimum may lie below the
        problem's (None: they refer to the problem itself).
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
    stages: tuple[Stage, ...] = ()
    restriction: str | None = None

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
            "restriction": self.restriction,
            "iterations": self.iterations,
            "runtime_s": round(self.runtime_s, 6),
            # of which the numba kernels' load (a first compilation on a machine: seconds)
            "kernels_s": self.stats.get("kernels_s"),
            "stages": [st.to_dict() for st in self.stages],
            # with ground stations: delivered, latency, on board, store peaks, station use
            **({"downlink": d} if (d := self.stats.get("downlink")) is not None else {}),
        }
