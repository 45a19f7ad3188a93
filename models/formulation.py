"""The Pyomo builder shared by the task, cluster and static models (never solves).

Variables (u an item, k a target, j an orbit):

* x_u in {0, 1}: item u is scheduled (the paper's x_ij);
* z_k in [0, 1]: target k is observed (coverage models only);
* f_u, l_u in [0, 1]: u is the first / last scheduled item of its orbit, and
  s_u, r_u in [0, 1]: some item at or before / at or after u (orbit order) is scheduled.
  They exist only on orbits whose energy constraint can bind.

Constraints:

* (2) task model: ``sum_{u covers k} x_u <= 1``; coverage models: ``z_k <= sum_{u covers k} x_u``;
* (3) one clique inequality ``sum_{u in Q} x_u <= 1`` per maximal clique Q of the conflict
  graph of the orbit (:mod:`models.cliques`);
* (4) exact slew term: over the scheduled items u_1 < ... < u_n of an orbit, the consecutive
  slews add up to ``sum_{t<n} (|th_t| + |th_t+1|) / v = (2 sum_t |th_t| - |th_1| - |th_n|) / v``,
  so ``eo sum_u d_u x_u + es sum_u (|th_u| / v) (2 x_u - f_u - l_u) <= E`` with first/last
  indicators forced by prefix variables: ``s_u >= x_u``, ``s_u >= s_prev``, ``f_u <= x_u``,
  ``f_u <= 1 - s_prev`` (and the mirror image for l_u, r_u). For integral x, f_u can be 1 only
  for the first scheduled item and l_u only for the last, and the solver sets both to 1 there
  (it helps (4)), so the term equals the validator's slew exactly; it is never an
  over-approximation;
* (5) ``w sum_u d_u x_u <= W``; (6) ``sum_u x_u <= c``.

Objective (1): ``max sum_k p_k z_k`` (coverage) or ``max sum_u p_u x_u`` (task).

A ``block`` extends the model with a family of constraints of its own (the downlinks of
:mod:`models.downlink`): it adds its variables and rows and returns, per orbit, a term for the
left side of that orbit's energy row (4).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import pyomo.environ as pyo

from models.data import ModelData

#: A constraint family added to the model: ``block(m, data)`` adds its components and returns
#: the extra energy term of each orbit in (4).
Block = Callable[[pyo.ConcreteModel, ModelData], Mapping[int, Any]]


def build_model(
    data: ModelData, relax: bool = False, block: Block | None = None
) -> pyo.ConcreteModel:
    """Build the model of ``data`` (a pure function: data in, ``ConcreteModel`` out).

    Parameters
    ----------
    data
        Items and constraint data from :mod:`models.data`.
    relax
        Make x continuous in [0, 1]: the clique-strengthened LP relaxation (an upper bound).
    block
        An extra constraint family (see :data:`Block`); its orbits' energy rows (4) get its
        terms, so every orbit it charges must be in ``data.energy_orbits`` or have no items.

    Returns
    -------
    pyomo.environ.ConcreteModel
        With ``m.data`` pointing back to ``data`` (for reading the solution).
    """
    m = pyo.ConcreteModel(name=f"sosp-{data.name}")
    m.data = data
    _sets(m, data)
    _variables(m, data, relax)
    _target_constraints(m, data)
    _clique_constraints(m, data)
    _slew_order_constraints(m, data)
    extra = {} if block is None else block(m, data)
    _energy_constraints(m, data, extra)
    _resource_constraints(m, data)
    _objective(m, data)
    return m


# --------------------------------------------------------------------------- sets
def _sets(m: pyo.ConcreteModel, d: ModelData) -> None:
    m.U = pyo.Set(initialize=range(d.n_items), ordered=True, doc="items")
    m.K = pyo.Set(initialize=list(d.target_items), ordered=True, doc="covered targets")
    m.Q = pyo.Set(initialize=range(len(d.cliques)), ordered=True, doc="cliques of (3)")
    slew_items = [int(u) for j in d.energy_orbits for u in d.orbit_items[j]]
    m.S = pyo.Set(initialize=slew_items, ordered=True, doc="items on energy-binding orbits")
    # predecessor / successor of each slew item on its orbit (None at the ends)
    prev: dict[int, int | None] = {}
    nxt: dict[int, int | None] = {}
    for j in d.energy_orbits:
        seq = [None, *(int(u) for u in d.orbit_items[j]), None]
        prev.update(zip(seq[1:-1], seq[:-2], strict=True))
        nxt.update(zip(seq[1:-1], seq[2:], strict=True))
    m._prev, m._next = prev, nxt


# --------------------------------------------------------------------------- variables
def _variables(m: pyo.ConcreteModel, d: ModelData, relax: bool) -> None:
    dom = pyo.UnitInterval if relax else pyo.Binary
    m.x = pyo.Var(m.U, domain=dom, doc="item scheduled")
    if d.coverage:
        m.z = pyo.Var(m.K, domain=pyo.UnitInterval, doc="target observed")
    m.f = pyo.Var(m.S, domain=pyo.UnitInterval, doc="first scheduled item of its orbit")
    m.l = pyo.Var(m.S, domain=pyo.UnitInterval, doc="last scheduled item of its orbit")
    m.s = pyo.Var(m.S, domain=pyo.UnitInterval, doc="an item at or before u is scheduled")
    m.r = pyo.Var(m.S, domain=pyo.UnitInterval, doc="an item at or after u is scheduled")


# --------------------------------------------------------------------------- constraints
def _target_constraints(m: pyo.ConcreteModel, d: ModelData) -> None:
    """(2) each target at most once (task), or z_k <= its coverage (cluster, static)."""
    items = d.target_items
    if d.coverage:

        @m.Constraint(m.K)
        def cover(m, k):
            return m.z[k] <= sum(m.x[u] for u in items[k])

    else:

        @m.Constraint(m.K)
        def target_once(m, k):
            if len(items[k]) < 2:
                return pyo.Constraint.Skip
            return sum(m.x[u] for u in items[k]) <= 1


def _clique_constraints(m: pyo.ConcreteModel, d: ModelData) -> None:
    """(3) setup time: at most one item of each maximal conflict clique."""
    cliques = d.cliques

    @m.Constraint(m.Q)
    def setup_clique(m, q):
        return sum(m.x[u] for u in cliques[q]) <= 1


def _slew_order_constraints(m: pyo.ConcreteModel, d: ModelData) -> None:
    """First/last indicators of the exact slew term of (4), via prefix/suffix variables (a
    chain row is skipped at the orbit's end where its neighbour is None)."""
    skip, prev, nxt = pyo.Constraint.Skip, m._prev, m._next
    rules = {
        "prefix_self": lambda m, u: m.s[u] >= m.x[u],
        "prefix_chain": lambda m, u: skip if prev[u] is None else m.s[u] >= m.s[prev[u]],
        "suffix_self": lambda m, u: m.r[u] >= m.x[u],
        "suffix_chain": lambda m, u: skip if nxt[u] is None else m.r[u] >= m.r[nxt[u]],
        "first_taken": lambda m, u: m.f[u] <= m.x[u],
        "first_nothing_before": lambda m, u: (
            skip if prev[u] is None else m.f[u] <= 1 - m.s[prev[u]]
        ),
        "last_taken": lambda m, u: m.l[u] <= m.x[u],
        "last_nothing_after": lambda m, u: skip if nxt[u] is None else m.l[u] <= 1 - m.r[nxt[u]],
    }
    for name, rule in rules.items():
        m.add_component(name, pyo.Constraint(m.S, rule=rule))


def _energy_constraints(m: pyo.ConcreteModel, d: ModelData, extra: Mapping[int, Any]) -> None:
    """(4) observation energy plus the exact slew energy over consecutive observations, plus
    a block's term (``extra``, per orbit)."""
    inst, dur, half = d.instance, d.duration, d.slew_time()  # half: |theta_u| / v

    @m.Constraint(sorted(set(d.energy_orbits) | set(extra)))
    def energy(m, j):
        seq = [int(u) for u in d.orbit_items.get(j, ())]
        eo, es = float(inst.observe_energy_rate[j]), float(inst.slew_energy_rate[j])
        observe = sum(eo * float(dur[u]) * m.x[u] for u in seq)
        slew = sum(es * float(half[u]) * (2 * m.x[u] - m.f[u] - m.l[u]) for u in seq if half[u] > 0)
        return observe + slew + extra.get(j, 0) <= float(inst.energy_capacity[j])


def _resource_constraints(m: pyo.ConcreteModel, d: ModelData) -> None:
    """(5) memory and (6) sensor openings."""
    inst, dur = d.instance, d.duration

    @m.Constraint(list(d.memory_orbits))
    def memory(m, j):
        w = float(inst.memory_rate[j])
        return sum(w * float(dur[u]) * m.x[u] for u in d.orbit_items[j]) <= float(
            inst.memory_capacity[j]
        )

    @m.Constraint(list(d.opening_orbits))
    def openings(m, j):
        return sum(m.x[int(u)] for u in d.orbit_items[j]) <= int(inst.max_openings[j])


# --------------------------------------------------------------------------- objective
def _objective(m: pyo.ConcreteModel, d: ModelData) -> None:
    """(1) total weight of the observed targets."""
    p = d.weight
    if d.coverage:
        expr = sum(int(p[k]) * m.z[k] for k in m.K)
    else:
        expr = sum(int(p[d.targets[u][0]]) * m.x[u] for u in m.U)
    m.profit = pyo.Objective(expr=expr, sense=pyo.maximize)
