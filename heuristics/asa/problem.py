"""The data the search works on, flattened to plain Python lists for the hot path.

The search schedules *units* (the paper's initial tasks) at *options* (their observation
opportunities Opt_k):

* ASA-DTC and ASA-NONTC: a unit is a target, its options are its opportunities; DTC may
  cluster options of one orbit into one observation (a cluster-task), NONTC never does.
* ASA-STC: a unit is a static cluster-task of :func:`sosp.clustering.static_cluster_tasks`,
  with one option (its fixed window and roll); units are atomic. A target may be covered by
  static tasks of several orbits; it counts once (coverage semantics of ``sosp.clustering``).

Options that can never be scheduled alone (window longer than Delta T (11), or more memory or
energy than the orbit holds, or an orbit with c = 0) are dropped up front.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sosp.clustering import TaskSet, single_tasks, static_cluster_tasks
from sosp.conflicts import TooManyConflicts, setup_conflict_rows
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.rules import OrbitRules, all_orbit_rules, alone_ok_mask

#: Most (3) conflict pairs between options ASA-DTC keeps (:class:`ConflictLists`, 8 bytes a
#: pair; they were Python lists, about 80). C10 has 185,131, a 5,000-target instance of 24
#: satellites 12.6 million; G100k (100,000 targets, 48 satellites) has 342 million, and
#: refusing with one line beats the search's other per-option state on 4 million options.
MAX_CONFLICTS = 25_000_000


class TooLargeForASA(InputError):
    """The instance's (3) conflicts exceed :data:`MAX_CONFLICTS`: :func:`build_problem`
    refuses it (ASA-DTC then answers with its start's search instead, see
    :func:`heuristics.asa.search.run_asa`)."""


@dataclass
class Problem:
    """Flattened units, options, orbits and the setup-conflict adjacency (3).

    Attributes
    ----------
    mode
        ``"dtc"``, ``"stc"`` or ``"nontc"``.
    clustering
        Whether options may be clustered dynamically (DTC only).
    opt_orbit, opt_start, opt_end, opt_roll, opt_lo, opt_hi, opt_unit
        Per option.
    unit_options
        Per unit, its usable options.
    unit_targets
        Per unit, the target indices it covers.
    unit_weight
        Per unit, the sum of its targets' weights.
    target_weight
        Per target.
    conflicts
        Per option, the options it conflicts with by (3) (same orbit, alone at own roll):
        the "setup-time conflicting tasks" of the migration neighbourhood.
    alternatives
        Per option, the options of other orbits (or other windows) a migration may move its
        targets to: DTC/NONTC the unit's other options; STC the static tasks of other orbits
        sharing a target.
    tasks
        The :class:`~sosp.clustering.TaskSet` behind the options.
    migration_score
        Per option, its number of setup-time conflicting options, or -1 when it has no
        alternative (its task cannot migrate).
    orbit_options
        Per orbit, its usable options sorted by (start, index) (orbit re-planning).
    replan_orbits
        The orbits with at least one usable option.
    instance
        The instance (DTC: its options are its opportunities, and the stretch re-planning
        takes its candidate observations from :mod:`sosp.candidates`).
    """

    mode: str
    clustering: bool
    orbits: list[OrbitRules]
    opt_orbit: list[int]
    opt_start: list[float]
    opt_end: list[float]
    opt_roll: list[float]
    opt_lo: list[float]
    opt_hi: list[float]
    opt_unit: list[int]
    unit_options: list[list[int]]
    unit_targets: list[tuple[int, ...]]
    unit_weight: list[float]
    target_weight: list[float]
    conflicts: Sequence[list[int]]
    alternatives: Sequence[list[int]]
    tasks: TaskSet
    migration_score: list[int]
    orbit_options: list[list[int]]
    replan_orbits: list[int]
    instance: Instance | None = None

    @property
    def n_units(self) -> int:
        return len(self.unit_options)

    @property
    def n_observable(self) -> int:
        """N of 5.3: units with at least one usable option."""
        return sum(1 for o in self.unit_options if o)


class ConflictLists(Sequence[list[int]]):
    """Per option, the usable options it conflicts with by (3), ascending: a compressed
    sparse row adjacency whose rows are made lists only when asked for.

    A 5,000-target instance of 24 satellites has 12.6 million conflict pairs; as Python lists
    they took seconds to make (longer than short time limits) and gigabytes to hold, while
    a search asks for a few thousand rows (the migration neighbourhood's step 3).

    Parameters
    ----------
    indptr, indices
        Row ``x`` is ``indices[indptr[x]:indptr[x + 1]]``.
    """

    __slots__ = ("indices", "indptr")

    def __init__(self, indptr: np.ndarray, indices: np.ndarray) -> None:
        self.indptr = indptr
        self.indices = indices

    def __len__(self) -> int:
        return len(self.indptr) - 1

    def __getitem__(self, x: int) -> list[int]:  # type: ignore[override]
        return self.indices[self.indptr[x] : self.indptr[x + 1]].tolist()

    def degrees(self) -> np.ndarray:
        """Per option, its number of conflicting options."""
        return np.diff(self.indptr)


class Alternatives(Sequence[list[int]]):
    """Per option, its unit's other usable options (DTC and NONTC), made when asked for;
    listing them for every option took seconds on instances of 200,000 opportunities."""

    __slots__ = ("opt_unit", "unit_options")

    def __init__(self, unit_options: list[list[int]], opt_unit: list[int]) -> None:
        self.unit_options = unit_options
        self.opt_unit = opt_unit

    def __len__(self) -> int:
        return len(self.opt_unit)

    def __getitem__(self, x: int) -> list[int]:  # type: ignore[override]
        opts = self.unit_options[self.opt_unit[x]]
        # an unusable option has no alternatives
        return [y for y in opts if y != x] if x in opts else []


def build_problem(instance: Instance, mode: str, roll_rule: str = "midpoint") -> Problem:
    """Flatten ``instance`` for the search in ``mode`` (``"dtc"``, ``"stc"``, ``"nontc"``)."""
    stc = mode == "stc"
    tasks = static_cluster_tasks(instance, roll_rule=roll_rule) if stc else single_tasks(instance)  # type: ignore[arg-type]
    orbits = list(all_orbit_rules(instance))
    roll = tasks.roll.tolist()
    usable_mask = alone_ok_mask(instance, tasks.orbit, tasks.start, tasks.end)
    usable_ids = np.flatnonzero(usable_mask)
    if stc:
        # Static tasks are atomic: their roll is fixed, so their "range" is the roll itself.
        lo, hi = list(roll), list(roll)
        unit_of = list(range(len(tasks)))
        unit_targets = [tuple(t) for t in tasks.targets]
        unit_options = [[x] if ok else [] for x, ok in enumerate(usable_mask.tolist())]
    else:
        lo, hi = instance.opp_roll_min.tolist(), instance.opp_roll_max.tolist()
        unit_of = instance.opp_target.tolist()
        unit_targets = [(k,) for k in range(instance.n_targets)]
        # each target's usable opportunities in index order: a stable sort by target
        by_unit = usable_ids[np.argsort(instance.opp_target[usable_ids], kind="stable")]
        counts = np.bincount(instance.opp_target[usable_ids], minlength=instance.n_targets)
        unit_options = [part.tolist() for part in np.split(by_unit, np.cumsum(counts)[:-1])]
    tw = instance.target_weight.astype(float).tolist()
    unit_weight = [float(sum(tw[k] for k in ks)) for ks in unit_targets]
    cols = (tasks.orbit, tasks.start, tasks.end, tasks.roll)
    try:
        rows = setup_conflict_rows(instance, *cols, keep=usable_mask, max_pairs=MAX_CONFLICTS)
    except TooManyConflicts as exc:
        raise TooLargeForASA(
            f"instance: {exc}: too large for ASA's conflict lists (use orbit-dp, greedy or "
            "hpfs-stc)"
        ) from None
    conflicts = ConflictLists(*rows)
    alternatives: Sequence[list[int]]
    if stc:
        stc_alternatives: list[list[int]] = [[] for _ in range(len(tasks))]
        usable = usable_mask.tolist()
        for x in usable_ids.tolist():
            alt = {
                t for k in unit_targets[x] for t in tasks.target_tasks[k] if t != x and usable[t]
            }
            stc_alternatives[x] = sorted(alt, key=lambda t: (-unit_weight[t], t))
        alternatives = stc_alternatives
        migrates = np.array([bool(a) for a in stc_alternatives], dtype=bool)
    else:
        alternatives = Alternatives(unit_options, unit_of)
        n_alone = np.array([len(o) for o in unit_options], dtype=np.int64)
        migrates = usable_mask & (n_alone[np.asarray(unit_of, dtype=np.int64)] > 1)
    # each orbit's usable options by (start, index)
    by_start = usable_ids[np.lexsort((usable_ids, tasks.start[usable_ids]))]
    by_start = by_start[np.argsort(tasks.orbit[by_start], kind="stable")]
    per_orbit = np.bincount(tasks.orbit[by_start], minlength=len(orbits))
    orbit_options = [part.tolist() for part in np.split(by_start, np.cumsum(per_orbit)[:-1])]
    return Problem(
        mode=mode,
        clustering=mode == "dtc",
        orbits=orbits,
        opt_orbit=tasks.orbit.tolist(),
        opt_start=tasks.start.tolist(),
        opt_end=tasks.end.tolist(),
        opt_roll=roll,
        opt_lo=lo,
        opt_hi=hi,
        opt_unit=unit_of,
        unit_options=unit_options,
        unit_targets=unit_targets,
        unit_weight=unit_weight,
        target_weight=tw,
        conflicts=conflicts,
        alternatives=alternatives,
        tasks=tasks,
        migration_score=np.where(migrates, conflicts.degrees(), -1).tolist(),
        orbit_options=orbit_options,
        replan_orbits=[j for j, opts in enumerate(orbit_options) if opts],
        instance=instance,
    )
