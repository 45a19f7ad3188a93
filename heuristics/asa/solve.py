"""The registered entry points of ASA-DTC and its variants.

One chain runs :func:`heuristics.asa.search.run_asa`; ``workers > 1`` runs chains in processes
(:func:`heuristics.asa.parallel.run_parallel`). Kept apart from both so neither imports the
other.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from heuristics.asa.parallel import run_parallel
from heuristics.asa.params import ASAParams
from heuristics.asa.search import run_asa
from sosp.instance import Instance
from sosp.result import Result


def _solve(
    instance: Instance, mode: str, rng: np.random.Generator, time_limit: float | None, **kw: Any
) -> Result:
    params = ASAParams.from_kwargs(**kw)
    if params.workers > 1:
        return run_parallel(instance, mode, rng=rng, time_limit=time_limit, params=params)
    return run_asa(instance, mode, rng=rng, time_limit=time_limit, params=params)


def solve_asa_dtc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-DTC: adaptive simulated annealing with dynamic task clustering (Algorithm 1).

    Parameters
    ----------
    instance
        The problem.
    rng
        The only randomness (seeded by :func:`sosp.solve.solve`).
    time_limit
        Wall-time limit, seconds.
    **params
        Any field of :class:`~heuristics.asa.params.ASAParams` (``iterations``, ``lambda_min``,
        ``roll_rule``, ...), and ``preset`` (a name of
        :data:`~heuristics.asa.params.PRESETS`, applied first); CLI strings are converted.
        Bad values raise :class:`~sosp.errors.InputError`.
    """
    return _solve(instance, "dtc", rng, time_limit, **params)


def solve_asa_stc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-STC: the same search over static cluster-tasks built once (no dynamic clustering).

    Parameters are those of :func:`solve_asa_dtc`; ``roll_rule`` sets the static tasks' roll.
    """
    return _solve(instance, "stc", rng, time_limit, **params)


def solve_asa_nontc(
    instance: Instance,
    *,
    rng: np.random.Generator,
    time_limit: float | None = None,
    **params: Any,
) -> Result:
    """ASA-NONTC: the same search over single opportunities, never clustered.

    Parameters are those of :func:`solve_asa_dtc`.
    """
    return _solve(instance, "nontc", rng, time_limit, **params)
