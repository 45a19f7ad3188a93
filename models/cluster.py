"""The ``cluster`` model: the exact optimum of the validator's problem (clustering allowed).

Items are the candidate observations of :func:`sosp.candidates.cluster_candidates`; every
feasible observation is dominated by one of them, so the optimum of this model is the optimum
of the problem of ``docs/model.md`` and an upper bound for ASA-DTC (which uses midpoint rolls).
Each target counts once: z_k <= sum of the x of the candidates covering k.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from models.data import ModelData, TimeUp, fits, prepare
from sosp.candidates import cluster_candidates
from sosp.instance import Instance

if TYPE_CHECKING:
    import pyomo.environ as pyo


def cluster_data(
    instance: Instance, deadline: float | None = None, generate_by: float | None = None
) -> ModelData:
    """Items of the cluster model: the non-dominated candidate observations.

    ``deadline`` (a :func:`time.perf_counter` value) stops the candidate generation with a
    :class:`~sosp.errors.TimeLimitReached` when it passes (see
    :func:`sosp.candidates.cluster_candidates`), or ``generate_by`` when it is given and
    earlier, and raises :class:`models.data.TimeUp` when arranging them would not end before
    ``deadline``.
    """
    if generate_by is not None and deadline is not None:
        generate_by = min(generate_by, deadline)
    orbit, start, end, roll, opps = cluster_candidates(
        instance, deadline=deadline if generate_by is None else generate_by
    )
    if not fits("prepare", len(opps), deadline):
        raise TimeUp("no time left to arrange the candidates")
    return prepare("cluster", instance, orbit, start, end, roll, opps, coverage=True)


def build_cluster_model(instance: Instance, relax: bool = False) -> pyo.ConcreteModel:
    """The clustering-exact model (1)-(7), (11) over candidate observations (never solved here)."""
    from models.formulation import build_model

    return build_model(cluster_data(instance), relax=relax)
