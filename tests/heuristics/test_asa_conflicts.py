"""The shared conflict graph (sosp.conflicts) against an all-pairs brute force of (3) and (2)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from sosp.conflicts import conflict_graph
from sosp.instance import Instance
from tests.conftest import small_instances


def _brute(inst: Instance) -> set[tuple[int, int]]:
    edges = set()
    for i in range(inst.n_opps):
        for h in range(i + 1, inst.n_opps):
            if inst.opp_target[i] == inst.opp_target[h]:
                edges.add((i, h))
                continue
            j = inst.opp_orbit[i]
            if j != inst.opp_orbit[h]:
                continue
            u, v = (i, h) if inst.opp_start[i] <= inst.opp_start[h] else (h, i)
            need = (
                inst.setup_time[j]
                + (abs(inst.opp_roll[u]) + abs(inst.opp_roll[v])) / (inst.slew_rate[j])
            )
            if inst.opp_start[v] - inst.opp_end[u] < need - 1e-9:
                edges.add((i, h))
    return edges


@settings(max_examples=80, deadline=None)
@given(inst=small_instances(max_opps=12), _=st.none())
def test_conflict_graph_equals_all_pairs(inst: Instance, _: None) -> None:
    g = conflict_graph(inst)
    assert set(g.nodes) == set(range(inst.n_opps))
    assert {tuple(sorted(e)) for e in g.edges} == _brute(inst)
