"""Lagrangian upper bound without candidate observations (the window relaxation).

The bound of :func:`models.lagrangian.lagrangian_bound` with each orbit's maximum replaced by
the relaxation of :mod:`sosp.windows`: for multipliers ``mu >= 0`` on "each target counts
once" and ``lam >= 0`` on the knapsacks (4)-(5) of each orbit,

    L(mu, lam) = sum_k max(0, p_k - mu_k)
                 + sum_j [ relaxed max over plans of orbit j under (3), (6) at prices mu,
                           penalties lam_j + lam_ej + lam_wj ].

Each orbit's relaxed maximum is at least its exact maximum over the explicit candidates
(:func:`sosp.windows.relaxed_best_path`: every real observation is dominated by a relaxed
item), so L is at least the explicit-candidate Lagrangian function at the same multipliers,
which is an upper bound on the optimum: every value is a valid bound. The relaxed items are
priced per orbit at each step by a sweep over the orbit's windows, so memory stays at the
opportunities' size where the explicit candidates need tens of gigabytes (10,000 targets in
the C region). The subgradient of an orbit's term is the targets its items count (priced
members at each item's argmax roll) and the relaxed plan's energy and memory.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from models.lagrangian import Priced, capped_bound, subgradient
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.windows import OrbitOpps, item_targets, orbit_opps, relaxed_best_path

log = logging.getLogger(__name__)


def window_lagrangian_bound(
    instance: Instance,
    *,
    iterations: int = 300,
    time_limit: float | None = None,
    lower_bound: float | None = None,
    start: float = 1.0,
) -> dict[str, Any]:
    """Upper bound on the optimum by Lagrangian relaxation over the window relaxation.

    The same subgradient steps as :func:`models.lagrangian.lagrangian_bound`
    (:func:`models.lagrangian.subgradient`); the least value found, rounded down (the optimum is an
    integer) and capped by the total weight of the targets with an opportunity no longer
    than Delta T, is returned. Every complete step's value is a valid bound; a step that would
    end after the time limit is not started (judged by the last step's time), one cut by it
    is dropped, and with no complete step the cap is returned.

    Parameters
    ----------
    instance
        The problem.
    iterations
        Subgradient steps at most.
    time_limit
        Seconds for everything, the lower bound's ascent included (None: no limit).
    lower_bound
        A known feasible profit (Polyak's target); None: the profit of one orbit-by-orbit
        pass of real plans (:func:`heuristics.orbit_search.window_ascent_profit`).
    start
        The first multipliers, ``mu = start * p`` (in [0, 1]). At 1 (default) the first value
        is the sum of the orbits' relaxed optima at the targets' weights, a good bound where
        a few steps are all the time allows: on D100 30,302 after one step against 45,096
        from 0.5 (the start of :func:`models.lagrangian.lagrangian_bound`), and on D30 no
        worse than 0.5 after 180 steps (9,600 both).

    Returns
    -------
    dict
        ``bound``, ``method`` ("lagrangian"), ``model`` ("windows"), ``runtime_s``,
        ``iterations``, ``items`` (relaxed items at the last step), ``lower_bound``.
    """
    t0 = time.perf_counter()
    if isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1:
        raise InputError(f"iterations: expected a positive integer, got {iterations!r}")
    orbits: list[OrbitOpps] = [orbit_opps(instance, j) for j in range(instance.n_orbits)]
    # a target whose every opportunity is longer than Delta T is never observed
    fit = np.asarray(instance.opp_end) - np.asarray(instance.opp_start) <= (
        np.asarray(instance.max_duration)[np.asarray(instance.opp_orbit)] + 1e-9
    )
    seen = np.zeros(instance.n_targets, dtype=bool)
    seen[np.asarray(instance.opp_target)[fit]] = True
    p = np.where(seen, np.asarray(instance.target_weight, dtype=float), 0.0)
    cap = float(p.sum())
    if lower_bound is None:
        from heuristics.orbit_search import window_ascent_profit

        lower_bound = window_ascent_profit(instance, deadline=_share(t0, time_limit, 0.2))
    if not 0.0 <= start <= 1.0:
        raise InputError(f"start: expected a number in [0, 1], got {start!r}")
    stop = None if time_limit is None else t0 + float(time_limit)
    items = 0

    def price(mu: np.ndarray, lam: np.ndarray) -> Priced | None:
        nonlocal items
        value = 0.0
        count = np.zeros(len(p))
        grad_lam = np.ones((len(orbits), 2))
        n_items = 0
        for g, oo in enumerate(orbits):
            if stop is not None and time.perf_counter() > stop:
                return None  # a partial sum over the orbits is no bound: drop this step
            v, path, ri = relaxed_best_path(oo, mu, float(lam[g, 0]), float(lam[g, 1]))
            n_items += ri.size
            value += v + lam[g, 0] + lam[g, 1]
            if len(path):
                np.add.at(count, item_targets(oo, mu, ri, path), 1.0)
                r = oo.rules
                energy, memory = r.usage(ri.duration[path], ri.slew_s[path] * r.slew_rate)
                grad_lam[g] = (1.0 - energy / r.energy_capacity, 1.0 - memory / r.memory_capacity)
        items = n_items
        return value, count, grad_lam

    best, done = subgradient(p, len(orbits), price, start * p, iterations, lower_bound, stop)
    bound = capped_bound(best, cap)
    log.info("window lagrangian bound %g after %d steps", bound, done)
    return {
        "bound": bound,
        "method": "lagrangian",
        "model": "windows",
        "runtime_s": round(time.perf_counter() - t0, 6),
        "iterations": done,
        "items": items,
        "lower_bound": float(lower_bound),
    }


def _share(t0: float, time_limit: float | None, share: float) -> float | None:
    """A :func:`time.perf_counter` deadline ``share`` of ``time_limit`` after ``t0``."""
    return None if time_limit is None else t0 + share * float(time_limit)
