"""The ``task`` model: the paper's integer program (1)-(6) over single opportunities.

Each opportunity (k, j) is an item observed alone at its own roll (``Instance.opp_roll``);
x_u is the paper's x_kj. The model is :func:`models.formulation.build_model` with the
paper's (2) (each target at most once), no clustering.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from models.data import ModelData, prepare
from sosp.instance import Instance

if TYPE_CHECKING:
    import pyomo.environ as pyo


def task_data(instance: Instance) -> ModelData:
    """Items of the task model: one per opportunity, window [ts, te], roll theta_i."""
    return prepare(
        "task",
        instance,
        instance.opp_orbit,
        instance.opp_start,
        instance.opp_end,
        instance.opp_roll,
        tuple((i,) for i in range(instance.n_opps)),
        coverage=False,
    )


def build_task_model(instance: Instance, relax: bool = False) -> pyo.ConcreteModel:
    """The IP (1)-(6) over single opportunities (never solved here).

    Parameters
    ----------
    instance
        The problem.
    relax
        Continuous variables in [0, 1] (the clique-strengthened LP relaxation).
    """
    from models.formulation import build_model

    return build_model(task_data(instance), relax=relax)
