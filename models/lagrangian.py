"""Upper bound by Lagrangian relaxation across orbits, over the single-orbit planner.

Relax "each target counts once" across orbits with multipliers ``mu_k`` (and the knapsacks (4)-(5)
with ``lam``); every multiplier vector gives an upper bound
``sum_k max(0, p_k - mu_k) + sum_j max_plan_j(mu, lam) + lam_e + lam_w`` on the optimum of the
cluster model, each orbit's maximum computed exactly by :func:`sosp.planner.best_path`. It is at
least as tight as the LP over the same candidates with the orbit constraints convexified, and
needs no LP solver.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from contextlib import closing
from typing import TYPE_CHECKING, Any

import numpy as np

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.planner import OrbitData, PlanPool, orbit_data
from sosp.stop import Budget

if TYPE_CHECKING:
    from sosp.parallel import Workers

log = logging.getLogger(__name__)

#: Share of the previous direction added to the subgradient in :func:`lagrangian_bound` (0.5
#: beat 0, 0.7 and a longer patience on C1, B10, C5 at 300 steps: 569.0 / 6190.6 / 2242.7
#: against 570.4 / 6193.1 / 2243.5 without).
DEFLECTION = 0.5


def lagrangian_bound(
    instance: Instance,
    *,
    iterations: int = 300,
    time_limit: float | None = None,
    lower_bound: float | None = None,
    data: OrbitData | None = None,
    workers: Workers = 1,
) -> dict[str, Any]:
    """Upper bound on the optimum (cluster model) by Lagrangian relaxation across orbits.

    The cluster model is ``max sum_k p_k z_k`` s.t. ``z_k <= sum of x over the candidates
    covering k``, ``z_k <= 1``, and per orbit the plan keeps (3)-(6). Relaxing the coverage
    rows with ``mu_k >= 0`` and the knapsacks (4)-(5) of orbit j with ``lam_j >= 0`` (per unit
    of capacity) gives, for any such multipliers, the upper bound

        L(mu, lam) = sum_k max(0, p_k - mu_k)
                     + sum_j [ max over plans of orbit j under (3), (6) of
                               sum_u (mu(targets of u) - penalties of u) + lam_ej + lam_wj ],

    each orbit's maximum computed exactly by :func:`best_path`. Subgradient steps (Polyak's
    rule towards ``lower_bound``, the direction deflected by half the previous one, step
    factor halved after 20 steps without progress) lower it; the least value found, rounded
    down (the optimum is an integer) and capped by the total weight of the targets some
    candidate covers (no schedule observes more), is returned. The subgradient in ``mu_k`` is
    the number of plans counting k minus ``[mu_k < p_k]``; a step that would not end within
    the time limit (judged by the last step's time) is not started.

    Parameters
    ----------
    instance
        The problem.
    iterations
        Subgradient steps at most.
    time_limit
        Seconds for everything, candidates included (None: no limit).
    lower_bound
        A known feasible profit (Polyak's target); None: the profit of a quick orbit-by-orbit
        plan (:func:`sosp.ascent.ascent_profit`).
    data
        Prepared candidates (built here when None).
    workers
        Processes for the candidates and for the orbits' plans of each step
        (:class:`sosp.planner.PlanPool`; the bound is the same for any number).

    Returns
    -------
    dict
        ``bound``, ``method`` ("lagrangian"), ``model`` ("cluster"), ``runtime_s``,
        ``iterations``, ``candidates``, ``lower_bound``.
    """
    t0 = time.perf_counter()
    budget = Budget.of(time_limit)
    check_count("iterations", iterations)
    if data is None:
        data = orbit_data(instance, budget.deadline, workers=workers)
    _, p = seen_weights(instance, data.orbits)
    cap = float(p.sum())
    groups = data.orbits
    if lower_bound is None:
        from sosp.ascent import ascent_profit

        lower_bound = ascent_profit(data)
    mu, lam = 0.5 * p, np.zeros((len(groups), 2))
    best = math.inf
    factor, stale, done = 1.0, 0, 0
    prev_dir: tuple[np.ndarray, np.ndarray] | None = None
    last_step = 0.0
    with closing(PlanPool(groups, workers)) as pool:
        while done < iterations:
            if done and not budget.fits(last_step):
                break  # the next step would end after the limit
            t_step = time.perf_counter()
            plans = pool.best_paths(mu, lam)
            assert plans is not None  # no timeout given
            orbits_value, count = 0.0, np.zeros(len(p))
            grad_lam = np.ones((len(groups), 2))
            for g, (v, covered, used) in enumerate(plans):
                orbits_value += v + lam[g, 0] + lam[g, 1]
                if used is not None:
                    np.add.at(count, covered, 1.0)
                    r = groups[g].rules
                    grad_lam[g] = 1.0 - np.divide(used, (r.energy_capacity, r.memory_capacity))
            value = float(np.maximum(p - mu, 0.0).sum()) + orbits_value
            done += 1
            last_step = time.perf_counter() - t_step
            if value < best - 1e-9:
                best, stale = value, 0
            else:
                stale += 1
                if stale >= 20:
                    factor, stale = factor / 2.0, 0
            log.debug("subgradient step %d: %.3f (best %.3f)", done, value, best)
            grad_mu = count - (mu < p)
            if prev_dir is not None:  # deflection: part of the last direction damps the zigzag
                grad_mu = grad_mu + DEFLECTION * prev_dir[0]
                grad_lam = grad_lam + DEFLECTION * prev_dir[1]
            prev_dir = (grad_mu, grad_lam)
            norm = float((grad_mu**2).sum() + (grad_lam**2).sum())
            if norm == 0.0 or value - lower_bound <= 1e-9 or factor < 1e-6:
                break  # the plans agree with the multipliers, or the bound meets the target
            step = factor * (value - lower_bound) / norm
            mu = np.clip(mu - step * grad_mu, 0.0, p)
            lam = np.maximum(lam - step * grad_lam, 0.0)
    bound = capped_bound(best, cap)
    log.info("lagrangian bound %g after %d steps", bound, done)
    return {
        "bound": bound,
        "method": "lagrangian",
        "model": "cluster",
        "runtime_s": round(time.perf_counter() - t0, 6),
        "iterations": done,
        "candidates": data.n_items,
        "lower_bound": float(lower_bound),
    }


def check_count(name: str, value: Any, least: int = 1) -> None:
    """Refuse ``value`` (an option of a bound) unless it is an integer, not a bool, of at
    least ``least`` (1 or 0)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < least:
        kind = "positive" if least == 1 else "non-negative"
        raise InputError(f"{name}: expected a {kind} integer, got {value!r}")


def seen_weights(instance: Instance, orbits: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """The targets some orbit's candidates cover, and the target weights with 0 for the
    others: a target no candidate covers adds nothing to a bound."""
    seen = np.zeros(instance.n_targets, dtype=bool)
    for o in orbits:
        seen[o.targets] = True
    return seen, np.where(seen, np.asarray(instance.target_weight, dtype=float), 0.0)


def capped_bound(best: float, cap: float) -> float:
    """A dual value as the reported bound: rounded down (the optimum is an integer; the 1e-6
    margin is far above the float error of these sums) and never above ``cap``, the total
    weight of the targets some plan can cover (an unfinished run can end a unit or two above
    it); ``cap`` itself when no value was found."""
    return min(float(math.floor(best + 1e-6)), cap) if math.isfinite(best) else cap
