"""The registered entry points of ASA-DTC and its variants.

One chain runs :func:`heuristics.asa.search.run_asa`; ``workers > 1`` runs chains in processes
(:func:`heuristics.asa.parallel.run_parallel`). Kept apart from both so neither imports the
other.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from heuristics.asa.parallel import run_parallel
from heuristics.asa.params import ASAParams
from heuristics.asa.search import run_asa
from sosp.instance import Instance
from sosp.result import Result, Stage


def _solve(
    instance: Instance, mode: str, rng: np.random.Generator, time_limit: float | None, **kw: Any
) -> Result:
    params = ASAParams.from_kwargs(**kw)
    run = run_parallel if params.workers > 1 else run_asa
    res = run(instance, mode, rng=rng, time_limit=time_limit, params=params)
    return replace(res, stages=_stages(res, mode, params))


def _stages(res: Result, mode: str, params: ASAParams) -> tuple[Stage, ...]:
    """What ran (:class:`~sosp.result.Stage`): on an instance ASA-DTC refuses, orbit-dp's
    search in its place (``stats["fallback"]``); else the initial solution (``init``) and
    the annealing."""
    name, profit = f"asa-{mode}", float(res.profit)
    if res.stats.get("fallback"):
        return (Stage("method", res.stats["fallback"], res.runtime_s, profit),)
    init_s = float(res.stats.get("initial_time_s") or 0.0)
    start = Stage("start", f"{name}:init={params.init}", init_s)
    return (start, Stage("method", name, max(0.0, res.runtime_s - init_s), profit))


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
