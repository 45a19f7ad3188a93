"""Acceptance rules (swappable, ALNS style) and the outcome of one iteration.

An acceptance rule is a small object with ``temperature`` and ``__call__(delta, rng) -> bool``
plus ``update(delta, accepted)`` called once per iteration. The default,
:class:`AdaptiveTemperature`, is the paper's section 5.2.
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np


class Outcome(IntEnum):
    """What an iteration produced; feeds the operator weights and the statistics.

    ``BEST``: a new global best. ``BETTER``: better than the current solution (counts as a
    success ``Suc_i`` of (17)). ``ACCEPTED``: not better but accepted. ``REJECTED``: undone.
    """

    BEST, BETTER, ACCEPTED, REJECTED = range(4)


class AdaptiveTemperature:
    r"""Adaptive temperature of (19)-(21) with the Metropolis test of Algorithm 1.

    The temperature is

    .. math:: \lambda = \lambda_{min} + \rho \ln(1 + r/\delta)                      \quad (21)

    and a move with profit change :math:`\Delta = f(S') - f(S)` is accepted when
    :math:`\Delta > 0` or :math:`\exp(\Delta/\lambda) > \xi`, :math:`\xi \sim U(0,1)`
    (Algorithm 1, lines 10 and 19; a move with :math:`\Delta = 0` is always accepted).
    The bad-move counter follows (20), written for maximisation:

    .. math:: r \leftarrow r + 1 \text{ if } \Delta < 0,\quad r \text{ if } \Delta = 0,\quad
              0 \text{ if } \Delta > 0.                                               \quad (20)

    ``r_update="accepted"`` applies (20) on accepted moves only (Algorithm 1 updates r in the
    acceptance branches); ``"generated"`` on every generated move.
    """

    def __init__(
        self, lambda_min: float, rho: float, delta: float, r_update: str = "accepted"
    ) -> None:
        self.lambda_min = lambda_min
        self.rho = rho
        self.delta = delta
        self.r_update = r_update
        self.r = 0
        self.temperature = lambda_min

    def __call__(self, delta: float, rng: np.random.Generator) -> bool:
        if delta > 0:
            return True
        return math.exp(delta / self.temperature) > rng.random()

    def update(self, delta: float, accepted: bool) -> None:
        """Apply (20) to r and recompute the temperature by (21)."""
        if self.r_update == "accepted" and not accepted:
            return
        if delta > 0:
            self.r = 0
        elif delta < 0:
            self.r += 1
        self.temperature = self.lambda_min + self.rho * math.log1p(self.r / self.delta)


class HillClimbing:
    """Accept only moves that do not lose profit (a baseline for ablations)."""

    temperature = 0.0

    def __call__(self, delta: float, rng: np.random.Generator) -> bool:
        return delta >= 0

    def update(self, delta: float, accepted: bool) -> None:
        return None
