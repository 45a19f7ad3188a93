"""The ``static`` model: the IP (1)-(6) over static cluster-tasks (STC, the paper's ref. [10]).

The cluster-tasks of :func:`sosp.clustering.static_cluster_tasks` (a per-orbit partition of
the opportunities satisfying (7) and (11), midpoint roll (9) by default) are atomic items. A
target may lie in cluster-tasks of several orbits; its weight is counted once through z_k,
as the static heuristics count it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from models.data import ModelData, prepare
from sosp.clustering import static_cluster_tasks
from sosp.instance import Instance
from sosp.schedule import RollRule

if TYPE_CHECKING:
    import pyomo.environ as pyo


def static_data(instance: Instance, roll_rule: RollRule = "midpoint") -> ModelData:
    """Items of the static model: the STC cluster-tasks with their window (10) and roll (9)."""
    tasks = static_cluster_tasks(instance, roll_rule=roll_rule)
    return prepare(
        "static",
        instance,
        tasks.orbit,
        tasks.start,
        tasks.end,
        tasks.roll,
        tasks.opps,
        coverage=True,
    )


def build_static_model(
    instance: Instance, relax: bool = False, roll_rule: RollRule = "midpoint"
) -> pyo.ConcreteModel:
    """The IP (1)-(6) over static cluster-tasks, targets counted once (never solved here)."""
    from models.formulation import build_model

    return build_model(static_data(instance, roll_rule), relax=relax)
