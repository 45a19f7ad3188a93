"""Data prepared outside the Pyomo models: items, target coverage, cliques and resources.

Every exact model schedules *items*: single opportunities (the ``task`` model, the paper's
IP (1)-(6)), candidate observations (the clustering-exact ``cluster`` model) or static
cluster-tasks (the ``static`` model). An item is one sensor opening with a fixed orbit, window
[ts_u, te_u], roll theta_u and set of covered opportunities. :class:`ModelData` holds them as
numpy columns together with everything the builder in :mod:`models.formulation` needs, so the
builder does no geometry and no search.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from models.cliques import clique_events, cliques_from_events, orbit_intervals
from sosp import rules
from sosp.candidates import OppGroups
from sosp.instance import Instance
from sosp.rules import orbit_rules
from sosp.stop import stop_requested


@dataclass(frozen=True, eq=False)
class ModelData:
    """Items of one exact model and the data of constraints (1)-(6).

    Attributes
    ----------
    name
        ``"task"``, ``"cluster"`` or ``"static"``.
    orbit, start, end, roll
        Per item: orbit j, window [ts_u, te_u] (10), roll theta_u.
    opps
        Per item, the sorted opportunity indices it covers (a
        :class:`~sosp.candidates.OppGroups`: indexing gives a tuple).
    targets
        Per item, the sorted distinct targets it covers (an ``OppGroups`` of target indices).
    coverage
        True: a target's weight is counted once through z_k <= sum of the x covering it
        (cluster and static models, where an item covers several targets). False: the paper's
        (2), ``sum_u x_u <= 1`` per target (task model, one target per item).
    weight
        p_k of every target of the instance, objective (1).
    target_items
        For each covered target k, the items covering it.
    orbit_items
        For each orbit with items, the items in (start, end) order: the order of the first/last
        indicators of the exact slew term of (4).
    event_first, event_last
        Per item, its half-open range of *events* (maximal cliques of the conflict graph of
        (3), numbered orbit by orbit in time order, see :func:`models.cliques.clique_events`):
        item u lies in the cliques ``event_first[u] <= e < event_last[u]``.
    event_block_end
        Per event, one past the last event of its orbit (the network form of (3) differences
        consecutive clique rows within an orbit only).
    slew_orbits
        Orbits whose energy constraint (4) can bind (the others need no slew variables).
    """

    name: str
    instance: Instance
    orbit: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    opps: Sequence[tuple[int, ...]]
    targets: Sequence[tuple[int, ...]]
    coverage: bool
    weight: np.ndarray
    target_items: dict[int, tuple[int, ...]]
    orbit_items: dict[int, np.ndarray]
    event_first: np.ndarray
    event_last: np.ndarray
    event_block_end: np.ndarray
    energy_orbits: tuple[int, ...]
    memory_orbits: tuple[int, ...]
    opening_orbits: tuple[int, ...]
    stats: dict[str, float] = field(default_factory=dict)

    @property
    def n_items(self) -> int:
        return len(self.opps)

    @property
    def n_events(self) -> int:
        """Number of maximal cliques of (3) (of two or more items)."""
        return len(self.event_block_end)

    @cached_property
    def cliques(self) -> list[tuple[int, ...]]:
        """Maximal cliques of the conflict graph of (3), orbit by orbit, in time order.

        Built on first use only: their total size is quadratic on dense orbits, and the
        network form of :mod:`models.highs_direct` never needs them.
        """
        members = cliques_from_events(self.event_first, self.event_last, self.n_events)
        return [tuple(int(u) for u in c) for c in members]

    @property
    def duration(self) -> np.ndarray:
        """te_u - ts_u, the observed time of (4) and (5)."""
        return self.end - self.start

    def slew_time(self) -> np.ndarray:
        """|theta_u| / v_j, half of each consecutive slew that touches item u, (3)-(4)."""
        return np.abs(self.roll) / self.instance.slew_rate[self.orbit]

    def covered_weight(self) -> float:
        """Total weight of the targets some item covers: no schedule of the model exceeds it
        (at most :func:`observable_weight`)."""
        if not self.target_items:
            return 0.0
        return float(self.weight[np.fromiter(self.target_items, dtype=np.int64)].sum())


class TimeUp(Exception):
    """The deadline passed, or would pass, or a stop was requested, while a model was being
    built (caught by :mod:`models.solve`, which then reports what it has)."""


def check_stop() -> None:
    """Raise :class:`TimeUp` once a stop was requested (:func:`sosp.stop.request_stop`):
    called between the steps of a stage that reads no clock (C10's :func:`prepare` takes
    0.5 s after its candidates, a 2,000-target instance's 0.9 s, and a Ctrl-C waited for
    it and for the MILP's other preparation: 1.5-2 s to exit, issue 63)."""
    if stop_requested():
        raise TimeUp("stopped")


#: Seconds per item of the building stages that cannot stop midway: twice what they took on
#: C10's cluster model (176 610 items; 1.1e-5, 0.6e-5, 1.7e-5) with the 2 cores shared by
#: other jobs (a load of 10): a stage whose estimate does not fit before the deadline is not
#: started (:func:`fits`).
SECONDS_PER_ITEM = {"prepare": 3.0e-5, "arrange": 2.0e-5, "build": 5.0e-5}


def fits(stage: str, n_items: int, deadline: float | None) -> bool:
    """Whether ``stage`` (a key of :data:`SECONDS_PER_ITEM`) on ``n_items`` items is expected
    to end before ``deadline`` (a :func:`time.perf_counter` value; None: always); never once a
    stop was requested."""
    if stop_requested():
        return False
    if deadline is None:
        return True
    return time.perf_counter() + SECONDS_PER_ITEM[stage] * n_items < deadline


def observable_weight(instance: Instance) -> float:
    """Total weight of the targets with at least one opportunity: a bound on (1) for free.

    A target nobody can see adds nothing to any schedule, so every upper bound the suite
    reports (LP, MILP, Lagrangian) is capped by this sum.
    """
    return instance.observable_weight


def prepare(
    name: str,
    instance: Instance,
    orbit: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    roll: np.ndarray,
    opps: Sequence[Sequence[int]],
    *,
    coverage: bool,
) -> ModelData:
    """Collect items into a :class:`ModelData`: coverage, orbit order, clique events of (3).

    Resource constraints (4)-(6) of an orbit are kept only when they can bind, i.e. when
    taking every item of the orbit (with the largest possible slews) would exceed the capacity:
    dropping a constraint that no schedule can violate changes nothing but the model size.
    A stop request raises :class:`TimeUp` between its steps (:func:`check_stop`).

    Parameters
    ----------
    name
        Model name.
    instance
        The problem.
    orbit, start, end, roll, opps
        The items, one entry each.
    coverage
        See :class:`ModelData`.
    """
    orbit = np.asarray(orbit, dtype=np.int64)
    start, end, roll = (np.asarray(a, dtype=float) for a in (start, end, roll))
    opps, targets, target_items = _coverage(instance, opps)
    check_stop()
    orbit_items: dict[int, np.ndarray] = {}
    event_first, event_last = np.zeros((2, len(opps)), dtype=np.int64)
    block_ends: list[np.ndarray] = [np.zeros(0, dtype=np.int64)]
    n_events = 0
    binding: tuple[list[int], list[int], list[int]] = ([], [], [])  # (4), (5), (6)
    if len(opps):
        order = np.lexsort((end, start, orbit))
        cuts = np.flatnonzero(np.diff(orbit[order])) + 1
        for block in np.split(order, cuts):
            check_stop()
            j = int(orbit[block[0]])
            orbit_items[j] = block
            rj = orbit_rules(instance, j)
            left, right = orbit_intervals(
                start[block], end[block], roll[block], rj.setup_time, rj.slew_rate
            )
            first, last, m = clique_events(left, right)
            event_first[block] = first + n_events
            event_last[block] = last + n_events
            n_events += m
            block_ends.append(np.full(m, n_events, dtype=np.int64))
            dur = float((end[block] - start[block]).sum())
            # Can (4)-(6) bind on this orbit at all? Taking every item, with the slew bounded
            # above (sosp.rules.slew_upper), decides it conservatively.
            slew = rules.slew_upper(float(np.abs(roll[block]).sum()), rj.slew_rate)
            binds = (
                rj.energy(dur, slew) > rj.energy_capacity,
                rj.memory(dur) > rj.memory_capacity,
                len(block) > rj.max_openings,
            )
            for orbits, bind in zip(binding, binds, strict=True):
                orbits += [j] if bind else []
    weight, block_end = np.asarray(instance.target_weight), np.concatenate(block_ends)
    # the fields of ModelData in their order
    return ModelData(
        *(name, instance, orbit, start, end, roll, opps, targets, coverage, weight),
        *(target_items, orbit_items, event_first, event_last, block_end),
        *(tuple(orbits) for orbits in binding),
    )


def _coverage(
    instance: Instance, opps: Sequence[Sequence[int]]
) -> tuple[OppGroups, OppGroups, dict[int, tuple[int, ...]]]:
    """Per item its opportunities and its distinct targets (sorted groups, CSR), and per
    covered target the items covering it (in item order), by array operations: C10's 176 610
    candidates cover millions of (item, opportunity) pairs, and tuples of tuples or a loop
    over sets took seconds."""
    groups = OppGroups.from_groups(opps)
    sizes, flat = groups.sizes, np.asarray(groups.flat, dtype=np.int64)
    n = len(sizes)
    seg = np.repeat(np.arange(n, dtype=np.int64), sizes)
    tg = np.asarray(instance.opp_target, dtype=np.int64)[flat]
    order = np.lexsort((tg, seg))
    check_stop()
    tg, seg = tg[order], seg[order]
    keep = np.ones(len(tg), dtype=bool)
    keep[1:] = (tg[1:] != tg[:-1]) | (seg[1:] != seg[:-1])
    tg, seg = tg[keep], seg[keep]
    tptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(seg, minlength=n), out=tptr[1:])
    check_stop()
    by_target = np.lexsort((seg, tg))  # items of each target, in item order
    check_stop()
    k_sorted, u_sorted = tg[by_target], seg[by_target]
    ks, first = np.unique(k_sorted, return_index=True)
    items = np.split(u_sorted, first[1:]) if len(ks) else []
    check_stop()
    target_items = {int(k): tuple(us.tolist()) for k, us in zip(ks.tolist(), items, strict=True)}
    return groups, OppGroups(tptr, tg), target_items
