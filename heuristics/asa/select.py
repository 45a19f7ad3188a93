"""Neighbourhood selection (swappable, ALNS style).

A selector has ``probabilities``, ``choose(rng) -> int`` and ``record(i, outcome)`` called once
per iteration. The default, :class:`AdaptiveRoulette`, is the paper's (17)-(18).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Sequence
from itertools import accumulate

import numpy as np

from heuristics.asa.accept import Outcome


def roulette(weights: Sequence[float], z: float) -> int:
    """The index whose share of the running sum of ``weights`` holds ``z`` (drawn in
    ``[0, sum)``): the first whose running sum exceeds ``z``, else the last."""
    return min(bisect_right(list(accumulate(weights)), z), len(weights) - 1)


class AdaptiveRoulette:
    r"""Roulette over neighbourhoods with the adaptive probabilities of (17)-(18).

    Every ``itr`` iterations each probability is updated from the last ``itr`` iterations:

    .. math:: pro'_i = \eta\, pro_i + (1 - \eta)\, Suc_i / Sel_i                      \quad (17)
    .. math:: pro_i = pro'_i / \sum_i pro'_i                                          \quad (18)

    where ``Sel_i`` counts the selections of neighbourhood i and ``Suc_i`` those that improved
    the current solution (Outcome BEST or BETTER). A neighbourhood not selected in the period
    (``Sel_i = 0``, where (17) is undefined) has ``Suc_i / Sel_i`` read as 0. Then ``Sel`` and
    ``Suc`` are reset (Algorithm 1, lines 25-33). ``floor`` (0 in the paper) bounds each
    probability from below after (18) so no neighbourhood dies out.
    """

    def __init__(self, probs: list[float], eta: float, itr: int, floor: float = 0.0) -> None:
        total = sum(probs)
        self.probabilities = [p / total for p in probs]
        self.eta = eta
        self.itr = itr
        self.floor = floor
        self._count = 0
        self.reset()

    def choose(self, rng: np.random.Generator) -> int:
        """Roulette wheel by the current probabilities (Algorithm 1, line 8)."""
        return roulette(self.probabilities, rng.random())

    def record(self, i: int, outcome: Outcome) -> None:
        """Count a selection and a success; every ``itr`` calls apply (17)-(18)."""
        self.sel[i] += 1
        if outcome <= Outcome.BETTER:
            self.suc[i] += 1
        self._count += 1
        if self._count % self.itr == 0:
            self.update()

    def update(self) -> None:
        """(17) then (18), then reset the period counters."""
        new = [
            self.eta * p + (1.0 - self.eta) * (s / n if n else 0.0)
            for p, s, n in zip(self.probabilities, self.suc, self.sel, strict=True)
        ]
        total = sum(new)
        if total > 0:
            new = [p / total for p in new]
            if self.floor > 0:
                new = [max(p, self.floor) for p in new]
                total = sum(new)
                new = [p / total for p in new]
            self.probabilities = new
        self.reset()

    def reset(self) -> None:
        """Start a period: no selection, no success counted."""
        self.sel = [0] * len(self.probabilities)
        self.suc = [0] * len(self.probabilities)


class FixedRoulette(AdaptiveRoulette):
    """Constant probabilities (no adaptation; an ablation of (17)-(18))."""

    update = AdaptiveRoulette.reset
