"""Re-planning: a new plan when targets, satellites or the sky change (issue 61).

:func:`replan` takes an instance, the schedule made for it, :class:`~sosp.events.Events`
and the time ``now``, and returns a new instance (the events applied), a new schedule, the
list of changes and a cheap bound. ``docs/replan.md`` says what it does and why it is right;
in short:

* **frozen**: the observations starting before ``now + freeze`` (the uplink lead time) are
  kept exactly, unless an outage of their satellite covers them (they cannot happen);
* **objective**: expected profit (weight times the probability of a clear sky, 1 without
  cloud) first, then fewest changes: each observation kept unchanged earns ``stability``
  (default :data:`STABILITY`, far below any weight; larger values trade profit for
  stability);
* **repair** (default): the old plan cleaned of what the events forbid, then the orbits the
  events touch are re-planned exactly, one at a time, by the single-orbit planner's recursion
  (:func:`sosp.planner.plan_sequence`) after their frozen observations, over the clustering-
  exact candidate observations of their usable opportunities (:func:`sosp.candidates.generate`,
  so new targets join existing strips) and the orbit's current observations (which earn the
  stability bonus). A target an orbit lets go is free again and the orbits seeing it are
  queued (insert, shift, swap, drop and re-insert are all such re-plans); a last round lets
  the orbits seeing a still-free event target pull targets from other orbits, undone unless
  the objective grows (:meth:`_State.pull_round`);
* any other method of :data:`sosp.registry.METHODS` solves the restricted problem (the
  unfrozen part, each orbit's resources less its frozen observations') with the old plan's
  unfrozen part as its warm start where it takes one, and the better of the two is kept.

Every result passes :func:`sosp.validate.validate` (else :class:`sosp.solve.SolverError`).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sosp.errors import InputError
from sosp.events import Events, horizon, in_area
from sosp.instance import OPP_KEYS, Instance
from sosp.rules import EPS, choose_roll, cluster_window, group_roll_ranges, orbit_rules
from sosp.schedule import Observation, Schedule

log = logging.getLogger(__name__)

#: Default worth of one observation kept unchanged, in weight units: below any difference of
#: integer weights (and of expected profits but for rounding), so profit comes first.
STABILITY = 1e-3

#: Times one orbit may be re-planned by the repair (its first visit included): the chains of
#: freed targets stop there.
MAX_VISITS = 3

#: Whether the repair ends with a round of pulls (:meth:`_State.pull_round`).
PULL = True


@dataclass(frozen=True)
class Change:
    """One change from the old plan: ``removed`` (``old`` only), ``added`` (``new`` only) or
    ``moved`` (the same orbit and at least one target in common, window, roll or targets
    changed)."""

    kind: str
    old: Observation | None = None
    new: Observation | None = None


@dataclass(frozen=True)
class Replanned:
    """What :func:`replan` returns.

    Attributes
    ----------
    instance, schedule
        The new problem (events applied) and its plan.
    changes
        Every change from the old plan.
    profit
        Expected profit of ``schedule`` (its profit when there is no cloud).
    bound
        An upper bound on the expected profit of any re-plan (frozen part plus every usable
        target at its clearest), or None.
    frozen
        Observations kept as frozen.
    runtime_s, method, stats
        How it went.
    """

    instance: Instance
    schedule: Schedule
    changes: tuple[Change, ...]
    profit: float
    bound: float | None
    frozen: int
    runtime_s: float
    method: str
    stats: dict[str, Any] = field(default_factory=dict)

    def counts(self) -> dict[str, int]:
        out = {"removed": 0, "added": 0, "moved": 0}
        for c in self.changes:
            out[c.kind] += 1
        return out


# ------------------------------------------------------------------------ the new problem
@dataclass(frozen=True)
class Applied:
    """The events applied to an instance: the new instance, where each old opportunity went
    (``index``), each opportunity's probability of a clear sky and whether it is blocked
    (cancelled target, outage)."""

    instance: Instance
    index: np.ndarray
    clear: np.ndarray
    blocked: np.ndarray
    outage: list[tuple[int, float, float]]


def apply_events(instance: Instance, events: Events) -> Applied:
    """The instance after ``events``: new targets with their opportunities from the
    instance's own orbits (:func:`sosp.visibility.find_opportunities`), new weights, cancelled
    targets at weight 0 (their opportunities stay for the frozen part, blocked for new use),
    clear-sky probabilities per opportunity (independent clouds multiply) and the outages as
    ``(satellite row, start, end)``."""
    inst = instance
    weight = np.array(inst.target_weight, dtype=np.int64)
    for tid, w in (events.weights or {}).items():
        if tid in inst.target_index:
            weight[inst.target_index[tid]] = w
    if events.new_targets:
        inst = _with_new_targets(inst, events, weight)
        index = np.array([inst.opp_index[i] for i in instance.opp_ids], dtype=np.int64)
    else:
        inst = replace(inst, target_weight=_ro(weight))
        index = np.arange(inst.n_opps, dtype=np.int64)
    weight = np.array(inst.target_weight, dtype=np.int64)
    for tid, w in (events.weights or {}).items():  # weight events about new targets
        weight[inst.target_index[tid]] = w
    cancelled = np.zeros(inst.n_targets, dtype=bool)
    for tid in events.cancelled:
        cancelled[inst.target_index[tid]] = True
    weight[cancelled] = 0
    inst = replace(inst, target_weight=_ro(weight))
    if instance.stations:
        inst = replace(
            inst, stations=instance.stations, contacts=instance.contacts,
            downlink=instance.downlink,
        )  # fmt: skip
    blocked = cancelled[inst.opp_target]
    sat_row = {n: s for s, n in enumerate(inst.satellite_names)}
    orbit_sat = np.array([sat_row[s] for s in inst.orbit_satellite], dtype=np.int64)
    outages = []
    for o in events.outages:
        s = sat_row[o.satellite]
        outages.append((s, o.start, o.end))
        blocked |= (orbit_sat[inst.opp_orbit] == s) & _overlaps(inst.opp_start, inst.opp_end, o)
    clear = np.ones(inst.n_opps)
    for c in events.clouds:
        if c.area is not None:
            hit = in_area(inst.target_lat, inst.target_lon, c.area)
        else:
            hit = np.zeros(inst.n_targets, dtype=bool)
            hit[[inst.target_index[t] for t in c.targets]] = True
        under = hit[inst.opp_target] & _overlaps(inst.opp_start, inst.opp_end, c)
        clear[under] *= 1.0 - c.probability
    return Applied(inst, index, clear, blocked, outages)


def _overlaps(start: np.ndarray, end: np.ndarray, span: Any) -> np.ndarray:
    return (start < span.end) & (end > span.start)


def _ro(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _with_new_targets(inst: Instance, events: Events, weight: np.ndarray) -> Instance:
    """``inst`` with the new targets and their opportunities on its own orbits."""
    from sosp.orbits import instance_satellites
    from sosp.visibility import find_opportunities

    sats = instance_satellites(inst)
    if sats is None:
        raise InputError(
            "events: new targets need the satellites' orbits, which this instance does not "
            "record (make it with sosp scenario)"
        )
    new = events.new_targets
    meta = dict(inst.meta)
    revs, opps = find_opportunities(
        sats,
        np.array([t.lat for t in new]),
        np.array([t.lon for t in new]),
        epoch=inst.epoch,
        horizon=horizon(inst),
        max_roll=float(meta.get("max_roll", 33.0)),
        fov=float(meta.get("fov", 6.0)),
        min_sun_elevation=meta.get("min_sun_elevation"),
    )
    orbit = np.array([inst.orbit_index.get(revs.ids[j], -1) for j in opps.orbit], dtype=np.int64)
    deadline = np.array([np.inf if t.deadline is None else t.deadline for t in new])
    keep = (orbit >= 0) & (opps.end <= deadline[opps.target] + EPS)
    if np.count_nonzero(orbit < 0):
        log.warning("%d opportunities of new targets fall on no orbit of the instance",
                    int(np.count_nonzero(orbit < 0)))  # fmt: skip
    n_old = inst.n_targets
    cols = {
        k: np.concatenate((getattr(inst, f"opp_{k}"), getattr(opps, k)[keep]))
        for k in OPP_KEYS
        if k not in ("target", "orbit")
    }
    ids = [*inst.target_ids, *(t.id for t in new)]
    new_opp_ids = [f"{new[k].id}@{inst.orbit_ids[j]}" for k, j in zip(
        opps.target[keep], orbit[keep], strict=True)]  # fmt: skip
    out = Instance.from_arrays(
        epoch=inst.epoch,
        target_ids=ids,
        target_lat=np.concatenate((inst.target_lat, [t.lat for t in new])),
        target_lon=np.concatenate((inst.target_lon, [t.lon for t in new])),
        target_weight=np.concatenate((weight, [t.weight for t in new])),
        orbit_ids=list(inst.orbit_ids),
        orbit_satellite=list(inst.orbit_satellite),
        orbit_start=inst.orbit_start,
        orbit_end=inst.orbit_end,
        resources={k: getattr(inst, k) for k in _RESOURCES},
        opp_target=np.concatenate((inst.opp_target, opps.target[keep] + n_old)),
        opp_orbit=np.concatenate((inst.opp_orbit, orbit[keep])),
        opp_ids=[*inst.opp_ids, *new_opp_ids],
        name=inst.name,
        meta=meta,
        **{f"opp_{k}": v for k, v in cols.items()},
    )
    log.info("%d new targets: %d opportunities", len(new), int(np.count_nonzero(keep)))
    return out


_RESOURCES = (
    "memory_capacity", "memory_rate", "energy_capacity", "observe_energy_rate",
    "slew_energy_rate", "slew_rate", "setup_time", "max_openings", "max_duration",
)  # fmt: skip


# ------------------------------------------------------------------------------ changes
def changes(old: Schedule, new: Schedule, instance: Instance) -> tuple[Change, ...]:
    """The changes from ``old`` to ``new`` (both over ``instance``'s opportunities): an
    observation in both unchanged is no change; one of ``new`` on the orbit of one of ``old``
    sharing a target with it is ``moved`` (each paired once, most shared targets first);
    the others are ``removed`` and ``added``."""
    same = set(old.observations) & set(new.observations)
    gone = [o for o in old.observations if o not in same]
    came = [o for o in new.observations if o not in same]
    tg = instance.opp_target
    pairs = []
    for a, o in enumerate(gone):
        ko = {int(tg[i]) for i in o.opps}
        for b, n in enumerate(came):
            if n.orbit == o.orbit and (shared := len(ko & {int(tg[i]) for i in n.opps})):
                pairs.append((-shared, a, b))
    used_a: set[int] = set()
    used_b: set[int] = set()
    out = []
    for _, a, b in sorted(pairs):
        if a not in used_a and b not in used_b:
            used_a.add(a)
            used_b.add(b)
            out.append(Change("moved", gone[a], came[b]))
    out += [Change("removed", old=o) for a, o in enumerate(gone) if a not in used_a]
    out += [Change("added", new=n) for b, n in enumerate(came) if b not in used_b]
    return tuple(out)


def expected_profit(instance: Instance, schedule: Schedule, clear: np.ndarray) -> float:
    """Objective (1) with each covered target worth its weight times the probability of a
    clear sky over the opportunity that covers it (the best one if several do)."""
    best: dict[int, float] = {}
    for i in schedule.observed_opps():
        k = int(instance.opp_target[i])
        best[k] = max(best.get(k, 0.0), float(clear[i]))
    w = instance.target_weight
    return float(sum(int(w[k]) * p for k, p in best.items()))


# ------------------------------------------------------------------------------- replan
def replan(
    instance: Instance,
    schedule: Schedule,
    events: Events,
    *,
    now: float,
    freeze: float = 0.0,
    stability: float = STABILITY,
    method: str = "repair",
    time_limit: float | None = None,
    seed: int = 0,
    warm_start: bool = True,
) -> Replanned:
    """A new plan for ``instance`` after ``events``, keeping what is frozen.

    Parameters
    ----------
    instance, schedule
        The problem and the plan made for it.
    events
        What changed (:func:`sosp.events.load_events`).
    now
        Seconds from the epoch (:func:`sosp.events.parse_time` reads a file's time).
    freeze
        Uplink lead time, seconds: observations starting before ``now + freeze`` are kept.
    stability
        Worth of one observation kept unchanged, in weight units (>= 0).
    method
        ``"repair"`` or a method of :data:`sosp.registry.METHODS`.
    time_limit
        Seconds (None: the repair's own end; a method's own stopping rule).
    seed
        Seeds the method's generator (the repair is deterministic).
    warm_start
        Start a method from the old plan's unfrozen part (False: from scratch, for
        comparisons).

    Returns
    -------
    Replanned
    """
    from sosp.solve import SolverError, check_time_limit
    from sosp.validate import validate

    t0 = time.perf_counter()
    time_limit = check_time_limit(time_limit)
    for name, v in (("freeze", freeze), ("stability", stability), ("now", now)):
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            raise InputError(f"{name}: expected a number, got {v!r}")
    if freeze < 0 or stability < 0:
        raise InputError("freeze and stability must be >= 0")
    if method != "repair":
        from sosp.registry import method_function

        method_function(method)  # an unknown method is refused before any work
    t_freeze = float(now) + float(freeze)
    if events.empty:
        kept = sum(1 for o in schedule.observations if o.start < t_freeze)
        profit = schedule.coverage_profit(instance)[0]
        return Replanned(instance, schedule, (), profit, None, kept,
                         time.perf_counter() - t0, method, {"events": 0})  # fmt: skip
    ap = apply_events(instance, events)
    inst = ap.instance
    old = Schedule(tuple(
        replace(o, opps=tuple(int(ap.index[i]) for i in o.opps)) for o in schedule.observations
    ))  # fmt: skip
    st = _State(ap, old, instance.target_weight, float(now), t_freeze, stability)
    if method == "repair":
        st.repair(None if time_limit is None else t0 + time_limit)
        obs, stats = st.observations(), st.stats
    else:
        obs, stats = _solve_restricted(st, method, seed, time_limit, warm_start)
    new = Schedule(tuple(obs), method=f"replan-{method}", params={
        "now": float(now), "freeze": float(freeze), "stability": float(stability),
        "events": len(events)}, seed=int(seed), fingerprint=inst.fingerprint)  # fmt: skip
    if inst.stations:
        old = replace(old, downlinks=tuple(
            replace(d, parts=tuple((int(ap.index[i]), v) for i, v in d.parts))
            for d in schedule.downlinks
        ))  # fmt: skip
        new = _deliver(inst, new, st, old)
    profit, _ = new.coverage_profit(inst)
    new = replace(new, profit=profit)
    report = validate(inst, new)
    if not report.feasible:
        first = report.violations[0]
        raise SolverError(f"replan ({method}) made an infeasible schedule: ({first.constraint}) "
                          f"{first.message}")  # fmt: skip
    exp = expected_profit(inst, new, ap.clear)
    out = Replanned(
        inst,
        new,
        changes(old, new, inst),
        exp,
        st.bound(),
        len(st.frozen_obs),
        time.perf_counter() - t0,
        method,
        {**stats, "profit": profit, "expected_profit": exp},
    )
    log.info("replan %s: expected profit %g, %s, %.3f s", method, exp, out.counts(),
             out.runtime_s)  # fmt: skip
    return out


class _State:
    """The plan being repaired: per orbit its observations (frozen ones first), which orbit
    holds each target, and what each opportunity is worth."""

    def __init__(
        self,
        ap: Applied,
        old: Schedule,
        old_weight: np.ndarray,
        now: float,
        t_freeze: float,
        stability: float,
    ) -> None:
        inst = ap.instance
        self.inst, self.ap, self.t_freeze, self.stability = inst, ap, t_freeze, stability
        self.value = inst.target_weight[inst.opp_target] * ap.clear
        self.owner = np.full(inst.n_targets, -1, dtype=np.int64)
        self.locked = np.zeros(inst.n_targets, dtype=bool)
        self.frozen_obs: list[Observation] = []
        self.plan: dict[int, list[Observation]] = {}
        self.lost: set[int] = set()  # orbits that lost observations
        self._cands: dict[int, Any] = {}
        self.touched: set[int] = set()
        self.stats: dict[str, Any] = {"visits": 0, "improved": 0, "outage_removed": 0}
        n_old = len(old_weight)
        # targets to look at again: new ones, re-weighted ones, clouded ones, freed ones
        self.hot: set[int] = set(range(n_old, inst.n_targets))
        self.hot.update(np.flatnonzero(inst.target_weight[:n_old] != old_weight).tolist())
        self.hot.update(np.unique(inst.opp_target[ap.clear < 1.0]).tolist())
        row = {n: s for s, n in enumerate(inst.satellite_names)}
        cancelled = inst.target_weight == 0
        for o in old.observations:
            s = row[inst.orbit_satellite[o.orbit]]
            if o.start >= now and any(s == q and o.start < b and o.end > a
                                      for q, a, b in ap.outage):  # fmt: skip
                # an outage removes what has not started, frozen or not: it cannot happen
                self.stats["outage_removed"] += 1
                self.lost.add(o.orbit)
                self.hot.update(int(inst.opp_target[i]) for i in o.opps)
                continue
            if o.start < t_freeze:
                self.frozen_obs.append(o)
                self.plan.setdefault(o.orbit, []).append(o)
                for i in o.opps:
                    k = int(inst.opp_target[i])
                    self.owner[k], self.locked[k] = o.orbit, True
                continue
            keep = tuple(i for i in o.opps if not cancelled[inst.opp_target[i]])
            if len(keep) < len(o.opps):
                self.lost.add(o.orbit)
                if not keep:
                    continue
                o = replace(o, opps=keep)
            self.plan.setdefault(o.orbit, []).append(o)
            for i in o.opps:
                self.owner[int(inst.opp_target[i])] = o.orbit
        self.start_obs = {o for obs in self.plan.values() for o in obs}

    # --------------------------------------------------------------- one orbit
    def usable(self, j: int, pull: bool = False) -> np.ndarray:
        """Opportunities of orbit j a new observation may cover: after the freeze, not
        blocked, worth something, their target free or held by j itself (with ``pull``: or
        by another orbit), never a frozen-observed one."""
        inst = self.inst
        sl = inst.orbit_opps(j)
        idx = np.arange(sl.start, sl.stop)
        own = self.owner[inst.opp_target[sl]]
        mine = (own < 0) | (own == j) if not pull else np.ones(len(own), dtype=bool)
        ok = (
            (inst.opp_start[sl] >= self.t_freeze)
            & ~self.ap.blocked[sl]
            & (self.value[sl] > 0)
            & mine
            & ~self.locked[inst.opp_target[sl]]
        )
        return idx[ok]

    def candidates(self, j: int) -> Any:
        """Orbit j's clustering-exact candidate observations over the opportunities that may
        ever be used in this repair (after the freeze, not blocked, worth something, target
        not frozen-observed), generated on the first visit (:func:`sosp.candidates.generate`)
        and cut to those usable at each visit (:meth:`OrbitCandidates.within`)."""
        from sosp.candidates import OppGroups, OrbitCandidates, generate, offsets
        from sosp.rules import starts_within

        if (hit := self._cands.get(j)) is not None:
            return hit
        inst = self.inst
        sl = inst.orbit_opps(j)
        tg = inst.opp_target[sl]
        ok = (
            (inst.opp_start[sl] >= self.t_freeze)
            & ~self.ap.blocked[sl]
            & (self.value[sl] > 0)
            & ~self.locked[tg]
        )
        base = np.flatnonzero(ok) + sl.start
        ts, te = inst.opp_start[base], inst.opp_end[base]
        limit = float(inst.max_duration[j])
        got = list(generate(ts, te, inst.opp_roll_min[base], inst.opp_roll_max[base], limit,
                            starts_within(ts, limit)))  # fmt: skip
        if got:
            roll = np.concatenate([g[0] for g in got])
            ptr = offsets(np.concatenate([g[1] for g in got]))
            flat = base[np.concatenate([g[2] for g in got])].astype(np.int32)
            start = np.minimum.reduceat(inst.opp_start[flat], ptr[:-1])
            end = np.maximum.reduceat(inst.opp_end[flat], ptr[:-1])
        else:
            roll = start = end = np.zeros(0)
            ptr, flat = np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int32)
        out = OrbitCandidates(j, start, end, roll, OppGroups(ptr, flat))
        self._cands[j] = out
        return out

    def replan_orbit(self, j: int, pull: bool = False) -> list[int]:
        """Re-plan orbit j's unfrozen part exactly (:func:`sosp.planner.plan_sequence`);
        returns the targets it let go. With ``pull`` it may take targets other orbits hold
        (they leave those orbits' observations, which stay feasible: :func:`_drop`)."""

        inst, r = self.inst, orbit_rules(self.inst, j)
        self.stats["visits"] += 1
        obs = self.plan.get(j, [])
        fixed = [o for o in obs if o.start < self.t_freeze]
        tail = [o for o in obs if o.start >= self.t_freeze]
        energy, memory = r.usage(np.array([o.duration for o in fixed]),
                                 np.array([o.roll for o in fixed]))  # fmt: skip
        left = (fixed[-1].end, fixed[-1].roll) if fixed else None
        opts = self.usable(j, pull)
        tg = inst.opp_target
        ptr = np.zeros(1, dtype=np.int64)
        if len(opts):
            # the orbit's candidates (generated once, cached with the instance) cut to the
            # usable opportunities: each still dominates what it dominated among them
            source = self.candidates(j)
            t1 = float(inst.opp_end[opts].max())
            ptr, flat = source.within(opts, inst.n_opps, float(inst.opp_start[opts[0]]), t1)
        if len(ptr) > 1:
            lo, hi = group_roll_ranges(inst.opp_roll_min, inst.opp_roll_max, ptr, flat)
            c_start = np.minimum.reduceat(inst.opp_start[flat], ptr[:-1])
            c_end = np.maximum.reduceat(inst.opp_end[flat], ptr[:-1])
            c_roll = choose_roll(lo, hi, "nadir")
            c_gain = np.add.reduceat(self.value[flat], ptr[:-1])
        else:
            c_start = c_end = c_roll = c_gain = np.zeros(0)
        t_start = np.array([o.start for o in tail])
        t_end = np.array([o.end for o in tail])
        t_roll = np.array([o.roll for o in tail])
        t_gain = np.array([self.value[list(o.opps)].sum() + self.stability for o in tail])
        current = float(t_gain.sum())
        from sosp.planner import plan_sequence

        gain, path = plan_sequence(
            np.concatenate((c_start, t_start)), np.concatenate((c_end, t_end)),
            np.concatenate((c_roll, t_roll)), np.concatenate((c_gain, t_gain)), r,
            left=left, energy=r.energy_capacity - energy, memory=r.memory_capacity - memory,
            openings=r.max_openings - len(fixed),
        )  # fmt: skip
        if gain <= current + 1e-9:
            return []
        n_c = len(ptr) - 1
        claimed: set[int] = set()
        new_tail = []
        for u in path.tolist():
            if u >= n_c:
                o = tail[u - n_c]
            else:
                mine = tuple(int(i) for i in flat[ptr[u] : ptr[u + 1]] if int(tg[i]) not in claimed)
                if not mine:
                    continue
                # the window (10) of what it keeps: never longer (with stations it must not
                # end later than its last opportunity, docs/model.md)
                ts, te = cluster_window(inst.opp_start[list(mine)], inst.opp_end[list(mine)])
                o = Observation(j, ts, te, float(c_roll[u]), mine)
            claimed.update(int(tg[i]) for i in o.opps)
            new_tail.append(o)
        before = {int(tg[i]) for o in tail for i in o.opps}
        freed = sorted(before - claimed)
        if pull:
            for i, ks in self._holders(claimed - before, j).items():
                self.plan[i] = _drop(self.plan[i], ks, tg)
                self.touched.add(i)
        self.owner[freed] = -1
        self.owner[sorted(claimed)] = j
        self.plan[j] = fixed + new_tail
        self.stats["improved"] += 1
        return freed

    def _holders(self, targets: set[int], j: int) -> dict[int, set[int]]:
        """The orbits other than j holding some of ``targets``, and which."""
        out: dict[int, set[int]] = {}
        for k in targets:
            if (i := int(self.owner[k])) >= 0 and i != j:
                out.setdefault(i, set()).add(k)
        return out

    def objective(self) -> float:
        """Expected profit plus ``stability`` per observation of the old plan kept."""
        kept, total = 0, 0.0
        for obs in self.plan.values():
            for o in obs:
                kept += o in self.start_obs
                total += float(self.value[list(o.opps)].sum())
        return total + self.stability * kept

    def pull_round(self, until: float | None) -> None:
        """For each orbit seeing a target still free that the events concern: re-plan it
        taking targets from other orbits as well, then those orbits and the orbits seeing
        what they let go; kept only when :meth:`objective` grows (else undone)."""
        inst = self.inst
        hot = [k for k in self.hot if self.owner[k] < 0]
        for j in sorted(self.orbits_seeing(hot), key=lambda i: inst.orbit_start[i]):
            if until is not None and time.perf_counter() > until:
                self.stats["stopped"] = "time_limit"
                return
            plan, owner, before = dict(self.plan), self.owner.copy(), self.objective()
            self.touched = set()
            freed = self.replan_orbit(j, pull=True)
            if not self.touched and not freed:
                continue
            for i in sorted(self.touched):
                freed += self.replan_orbit(i)
            for i in sorted(self.orbits_seeing(freed) - {j}):
                self.replan_orbit(i)
            if self.objective() <= before + 1e-9:
                self.plan, self.owner = plan, owner
            else:
                self.stats["pulled"] = self.stats.get("pulled", 0) + 1

    def orbits_seeing(self, targets: Any) -> set[int]:
        inst = self.inst
        out: set[int] = set()
        for k in targets:
            opps = inst.target_opps[int(k)]
            ok = (inst.opp_start[opps] >= self.t_freeze) & ~self.ap.blocked[opps] & (
                self.value[opps] > 0)  # fmt: skip
            out.update(int(j) for j in inst.opp_orbit[opps[ok]])
        return out

    def repair(self, until: float | None) -> None:
        """Re-plan the touched orbits, then the orbits seeing each target let go."""
        inst = self.inst
        touched = set(self.lost) | self.orbits_seeing(self.hot)
        queue = deque(sorted(touched, key=lambda j: inst.orbit_start[j]))
        visits: dict[int, int] = {}
        queued = set(queue)
        while queue:
            if until is not None and time.perf_counter() > until:
                self.stats["stopped"] = "time_limit"
                break
            j = queue.popleft()
            queued.discard(j)
            visits[j] = visits.get(j, 0) + 1
            freed = self.replan_orbit(j)
            for i in sorted(self.orbits_seeing(freed), key=lambda i: inst.orbit_start[i]):
                if i not in queued and visits.get(i, 0) < MAX_VISITS:
                    queue.append(i)
                    queued.add(i)
        self.stats["orbits"] = len(visits)
        if PULL:
            self.pull_round(until)

    def observations(self) -> list[Observation]:
        return [o for j in sorted(self.plan) for o in self.plan[j]]

    def bound(self) -> float:
        """Frozen part's expected profit plus every other target's weight at its clearest
        usable opportunity: no re-plan does better (cheap, not tight)."""
        inst = self.inst
        frozen = set()
        total = 0.0
        for o in self.frozen_obs:
            for i in o.opps:
                k = int(inst.opp_target[i])
                if k not in frozen:
                    frozen.add(k)
                    total += float(self.value[i])
        ok = (inst.opp_start >= self.t_freeze) & ~self.ap.blocked
        best = np.zeros(inst.n_targets)
        np.maximum.at(best, inst.opp_target[ok], self.value[ok])
        best[list(frozen)] = 0.0
        return total + float(best.sum())


def _drop(obs: list[Observation], targets: set[int], tg: np.ndarray) -> list[Observation]:
    """``obs`` without ``targets``: an observation keeps its window and roll (its roll stays
    in the range of fewer opportunities; a window may be longer than needed) and goes when it
    covers nothing else, which keeps (3)-(6) (``docs/model.md``)."""
    out = []
    for o in obs:
        keep = tuple(i for i in o.opps if int(tg[i]) not in targets)
        if keep:
            out.append(o if len(keep) == len(o.opps) else replace(o, opps=keep))
    return out


def _solve_restricted(
    st: _State, method: str, seed: int, time_limit: float | None, warm: bool
) -> tuple[list[Observation], dict[str, Any]]:
    """Solve the unfrozen part with ``method``: the restricted problem of :func:`restricted`,
    started from the old plan's unfrozen part when the method takes a start and ``warm``;
    with ``warm`` the better of its plan and that part is kept (ties: the old one)."""
    from sosp.methods import method_info
    from sosp.solve import solve

    sub, index = restricted(st)
    at = {int(i): n for n, i in enumerate(index)}
    old_tail = [o for j in sorted(st.plan) for o in st.plan[j] if o.start >= st.t_freeze]
    start = Schedule(tuple(
        replace(o, opps=tuple(at[i] for i in o.opps))
        for o in old_tail if all(i in at for i in o.opps)
    ))  # fmt: skip
    params = {"warm_start": start} if warm and "warm_start" in method_info(method).keys() else {}
    res = solve(sub, method, seed=seed, time_limit=time_limit, **params)
    found = [replace(o, opps=tuple(int(index[i]) for i in o.opps))
             for o in res.schedule.observations]  # fmt: skip
    mine = st.frozen_obs + found
    stats = {"method_profit": float(res.profit), "status": res.status.value,
             "warm_start": bool(params)}  # fmt: skip
    if warm:
        clear = st.ap.clear
        theirs = st.frozen_obs + old_tail
        if expected_profit(st.inst, Schedule(tuple(theirs)), clear) >= expected_profit(
            st.inst, Schedule(tuple(mine)), clear
        ):
            stats["kept_old"] = True
            return theirs, stats
    return mine, stats


def restricted(st: _State) -> tuple[Instance, np.ndarray]:
    """The problem left after the frozen part, without stations, and its opportunities'
    rows in ``st.inst``.

    Its opportunities are the usable ones (after the freeze, not blocked, worth something,
    target not frozen-observed) that start late enough after the orbit's last frozen
    observation for (3) at any roll of their range; each orbit's capacities (4)-(6) lose
    what its frozen observations use and, for (4), the largest turn from the last of them to
    any of these opportunities. So any plan of it joined to the frozen part keeps (3)-(6).
    With cloud, each target keeps only its clearest opportunities and weighs
    ``round(1000 * weight * P(clear))``: expected profit for the search, exact when the
    clearest opportunities are the ones worth observing.
    """
    inst, ap = st.inst, st.ap
    tg = inst.opp_target
    ok = (inst.opp_start >= st.t_freeze) & ~ap.blocked & (st.value > 0) & ~st.locked[tg]
    reach = np.maximum(np.abs(inst.opp_roll_min), np.abs(inst.opp_roll_max))
    energy = np.array(inst.energy_capacity, dtype=float)
    memory = np.array(inst.memory_capacity, dtype=float)
    openings = np.array(inst.max_openings, dtype=np.int64)
    for j, obs in st.plan.items():
        fixed = [o for o in obs if o.start < st.t_freeze]
        if not fixed:
            continue
        r, sl = orbit_rules(inst, j), inst.orbit_opps(j)
        e, m = r.usage(np.array([o.duration for o in fixed]), np.array([o.roll for o in fixed]))
        last = fixed[-1]
        ok[sl] &= inst.opp_start[sl] - reach[sl] / r.slew_rate >= r.right(last.end, last.roll)
        turn = r.slew_energy_rate * r.turn(last.roll, float(reach[sl].max(initial=0.0)))
        energy[j] = max(0.0, r.energy_capacity - e - turn)
        memory[j] = max(0.0, r.memory_capacity - m)
        openings[j] = max(0, r.max_openings - len(fixed))
    weight = np.array(inst.target_weight, dtype=np.int64)
    if (ap.clear < 1.0).any():
        best = np.zeros(inst.n_targets)
        np.maximum.at(best, tg[ok], ap.clear[ok])
        ok &= ap.clear >= best[tg] - 1e-12
        weight = np.round(1000.0 * weight * best).astype(np.int64)
    index = np.flatnonzero(ok)
    sub = inst.without_stations().with_opportunities(ok)
    sub = replace(
        sub, target_weight=_ro(weight), energy_capacity=_ro(energy),
        memory_capacity=_ro(memory), max_openings=_ro(openings),
    )  # fmt: skip
    return sub, index


def _deliver(inst: Instance, new: Schedule, st: _State, old: Schedule) -> Schedule:
    """With ground stations: the downlinks of the new plan (:func:`sosp.downlink.deliver`,
    which drops what cannot be delivered), and whether the frozen part (observations, and
    downlinks starting before the freeze time) came out unchanged (``stats["frozen_kept"]``,
    a warning when not: the greedy downlink planner may send differently once new
    observations share a contact)."""
    from sosp.downlink import deliver

    obs, dls = deliver(inst, new.observations)
    t = st.t_freeze
    new = replace(new, observations=obs, downlinks=tuple(dls))  # sorted as old's
    kept = set(st.frozen_obs) <= set(obs) and [d for d in new.downlinks if d.start < t] == [
        d for d in old.downlinks if d.start < t
    ]
    st.stats["frozen_kept"] = bool(kept)
    if not kept:
        log.warning("replan with stations: the frozen downlinks or observations changed")
    return new


# ---------------------------------------------------------------------------------- CLI
def add_replan_parser(subparsers: Any) -> Any:
    """Add ``replan`` to the ``sosp`` subcommands."""
    from sosp.params import positive

    p = subparsers.add_parser(
        "replan",
        help="re-plan a schedule after events (urgent targets, outages, cloud)",
        description="Re-plan SCHEDULE of INSTANCE after the events of --events (docs/formats.md)"
        " at time --now: what starts before now + --freeze is kept, the rest re-planned for "
        "expected profit first, then fewest changes (docs/replan.md). Writes the new schedule "
        "(-o) and the new instance it refers to (--instance-out).",
    )
    p.add_argument("instance", help="instance file (.json or .npz)")
    p.add_argument("schedule", help="schedule file (.json) made for it")
    p.add_argument("--events", required=True, help="events file (.json, docs/formats.md)")
    p.add_argument("--now", required=True,
                   help="ISO 8601 UTC time or seconds from the horizon start")  # fmt: skip
    p.add_argument("--freeze", type=float, default=0.0,
                   help="uplink lead time, seconds (default 0)")  # fmt: skip
    p.add_argument("--stability", type=float, default=STABILITY,
                   help=f"worth of an unchanged observation in weight units (default "
                   f"{STABILITY:g}: profit first)")  # fmt: skip
    p.add_argument("--method", default="repair",
                   help="repair (default) or any method of sosp methods")  # fmt: skip
    p.add_argument("--time-limit", type=positive(float), default=None, help="seconds")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-o", "--output", required=True, help="new schedule file (.json)")
    p.add_argument("--instance-out", default=None,
                   help="new instance file (default: OUTPUT with .instance.json)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_replan)
    return p


def cmd_replan(args: Any) -> int:
    """Handler of ``sosp replan``: nothing is written unless every input is good."""
    from sosp.cli import emit
    from sosp.events import load_events, parse_time
    from sosp.instance import load_instance
    from sosp.io import check_output
    from sosp.orbits import utc_at
    from sosp.schedule import load_schedule

    out = check_output(args.output)
    inst_out = args.instance_out or str(out.with_name(out.name.split(".")[0] + ".instance.json"))
    check_output(inst_out, "--instance-out")
    inst = load_instance(args.instance)
    sched = load_schedule(args.schedule, inst)
    events = load_events(args.events, inst)
    now = parse_time(args.now, inst, "--now")
    res = replan(
        inst, sched, events, now=now, freeze=args.freeze, stability=args.stability,
        method=args.method, time_limit=args.time_limit, seed=args.seed,
    )  # fmt: skip
    new = res.instance
    res.instance.save(inst_out)
    res.schedule.save(args.output, new)
    c = res.counts()
    old_profit = sched.coverage_profit(inst)[0]

    def row(ch: Change) -> dict[str, Any]:
        o = ch.new or ch.old
        assert o is not None
        return {
            "change": ch.kind, "orbit": new.orbit_ids[o.orbit], "start_utc": utc_at(
                new.epoch, o.start), "targets": sorted({new.target_ids[int(new.opp_target[i])]
                                                        for i in o.opps}),
        }  # fmt: skip

    rows = [row(ch) for ch in res.changes]
    data = {
        "method": res.method, "expected_profit": res.profit, "old_profit": old_profit,
        "bound": res.bound, "frozen": res.frozen, **c, "runtime_s": round(res.runtime_s, 4),
        "output": str(args.output), "instance": inst_out, "changes": rows,
    }  # fmt: skip
    bound = "" if res.bound is None else f", bound {res.bound:g}"
    lines = [
        f"replan ({res.method}): expected profit {res.profit:g} (old plan {old_profit:g}"
        f"{bound}) in {res.runtime_s:.2f} s",
        f"frozen {res.frozen} observations; changes: {c['removed']} removed, {c['added']} "
        f"added, {c['moved']} moved",
        *(
            f"  {r['change']:<8} {r['orbit']:<16} {r['start_utc']}  {' '.join(r['targets'])}"
            for r in rows[:40]
        ),  # fmt: skip
        *([f"  ... {len(rows) - 40} more (--json lists them all)"] if len(rows) > 40 else []),
        f"wrote {args.output} and {inst_out}",
    ]
    emit(args, data, "\n".join(lines))
    return 0
