"""ASA-DTC's readings of two rules the paper leaves open (``docs/asa.md``, "Decisions on points
the paper leaves open"): (16) on an orbit that has consumed nothing (decision 2), and step 1
of the migration neighbourhood (decision 7)."""

from __future__ import annotations

import contextlib
import importlib
from collections import Counter

import numpy as np
import pytest

from heuristics.asa import ASAParams
from heuristics.asa.neighbourhoods import choose_migrating, clustering_gain, insert_options
from heuristics.asa.state import MEMBERS, State
from sosp.errors import InputError
from sosp.instance import Instance, Resources
from sosp.solve import solve
from sosp.validate import validate
from tests.heuristics.test_asa import _opp, _state

E_CAP = 1500.0  # Resources' default energy capacity E


# ---------------------------------------------------------------------- (16) on an empty orbit
def empty_orbit(observe_energy_rate: float = 0.0, memory_rate: float = 0.0) -> Instance:
    """One orbit; c [0, 4] at nadir (roll 0, range [-4, 4]) and three options to cluster with it.

    With ``eo = w = 0`` an orbit holding c alone has consumed nothing: no observation energy,
    no memory, no slew (roll 0), so alpha = ConE/E = beta = ConW/W = 0 and (16) is the
    degenerate ``0 < 0``. Setup a = 10 s, v = 1 deg/s, es = 1.

    * x [30, 34], roll 8, range [-2, 10]: separable from c (4 + 10 + 0 + 8 = 22 <= 30). Together
      the midpoint (9) of [-2, 4] is 1: en = es (0 + 8) = 8, ec = es * 1 = 1, so the
      capacity-normalised saving (en - ec)/E = 7/1500 > 0.
    * y [30, 34], roll 1, range [1, 10]: separable (4 + 10 + 1 = 15 <= 30). Together the
      midpoint of [1, 4] is 2.5: en = 1, ec = 2.5, saving -1.5/1500 < 0.
    * z [5, 9], roll 0, range [-4, 4]: exclusive with c by (3) (4 + 10 > 5), so (16) is not
      applied at all (decision 1).
    """
    return Instance.build(
        {"c": 1, "x": 2, "y": 3, "z": 4},
        [
            ("c", 0, 0.0, 4.0, 0.0, -4.0, 4.0),
            ("x", 0, 30.0, 34.0, 8.0, -2.0, 10.0),
            ("y", 0, 30.0, 34.0, 1.0, 1.0, 10.0),
            ("z", 0, 5.0, 9.0, 0.0, -4.0, 4.0),
        ],
        resources=Resources(observe_energy_rate=observe_energy_rate, memory_rate=memory_rate),
        name="empty_orbit_rule16",
    )


def _with_c(inst: Instance, **kw) -> tuple[State, ASAParams]:
    """The state (paper's rules, midpoint roll (9)) with c alone on the orbit."""
    state, params = _state(inst, **kw)
    state.begin()
    assert insert_options(state, [_opp(inst, "c")], params) == _opp(inst, "c")
    return state, params


def _gain(inst: Instance, target: str, openings: bool = False):
    """clustering_gain of ``target`` joining c."""
    state, params = _with_c(inst, rule16_openings=openings)
    line = state.lines[0]
    return clustering_gain(state, line, line.obs[0], _opp(inst, target), params), state


def test_orbit_holding_c_has_consumed_nothing() -> None:
    """The premise of the tests below: the reading is only consulted when alpha = beta = 0."""
    state, _ = _with_c(empty_orbit())
    line = state.lines[0]
    assert len(line.obs) == 1
    assert (line.energy, line.memory) == (0.0, 0.0)
    state, _ = _with_c(empty_orbit(1.0, 1.0))
    assert (state.lines[0].energy, state.lines[0].memory) == (4.0, 4.0)


def test_empty_orbit_positive_saving() -> None:
    """x saves 7/1500 of E: the capacity reading accepts it (the literal 0 < 0 would not)."""
    inst = empty_orbit()
    c, x = _opp(inst, "c"), _opp(inst, "x")
    saving, new = _gain(inst, "x")[0]
    assert saving == pytest.approx(7 / E_CAP)
    assert new == (0.0, 34.0, 1.0, -2.0, 4.0, (c, x))  # window (10), midpoint (9), range (8)


def test_empty_orbit_negative_saving() -> None:
    """y costs 1.5/1500 of E: refused."""
    assert _gain(empty_orbit(), "y")[0] is None


def test_empty_orbit_counts_openings_when_asked() -> None:
    """With openings counted (decision 3, c_j = 10, none used: gamma = 1/10) the capacity
    reading adds gamma/c = 0.01 to y's saving: -1.5/1500 + 0.01 > 0, so y is accepted."""
    g, _ = _gain(empty_orbit(), "y", openings=True)
    assert g is not None and g[0] == pytest.approx(-1.5 / E_CAP + 0.1 / 10)


def test_empty_orbit_reading_not_consulted_elsewhere() -> None:
    """The reading changes nothing outside its case: an exclusive pair (z, decision 1) is
    accepted; on an orbit that has consumed something (eo = w = 1: alpha = 4/1500, beta =
    4/1000) the literal (16) refuses x (en = 8 + 8 = 16 < ec = 34 + 1)."""
    g, _ = _gain(empty_orbit(), "z")
    assert g is not None and g[1][:3] == (0.0, 9.0, 0.0)
    assert _gain(empty_orbit(1.0, 1.0), "x")[0] is None


@pytest.mark.parametrize(("target", "clustered"), [("x", True), ("y", False)])
def test_empty_orbit_reading_decides_the_insertion(target: str, clustered: bool) -> None:
    """Steps 2-6 of the insertion neighbourhood follow the reading: the option joins c when
    the evaluation accepts it, and is otherwise observed alone (it fits: separable, (4)-(6))."""
    inst = empty_orbit()
    state, params = _with_c(inst, rule16_openings=False)
    t = _opp(inst, target)
    assert insert_options(state, [t], params) == t
    members = [c[MEMBERS] for c in state.lines[0].obs]
    c = _opp(inst, "c")
    assert members == ([(c, t)] if clustered else [(c,), (t,)])
    assert state.check()


def test_former_reading_parameters_are_refused() -> None:
    """``rule16_empty`` and ``migration_pool`` were measured not to matter and are gone: a
    caller still passing them gets a one-line error naming the key, not a silent default."""
    for key, value in (("rule16_empty", "never"), ("migration_pool", 3)):
        with pytest.raises(InputError, match=key):
            solve(empty_orbit(), "asa-dtc", seed=0, iterations=5, **{key: value})


# -------------------------------------------------------------------------- migration, step 1
#: Hubs on orbit 0 (start time, number of spokes, an option on orbit 1 to migrate to or not).
#: Units are targets in weight-dict order: b before c, so b wins their tie.
HUBS = {
    "a": (0, 3, True),
    "b": (200, 2, True),
    "c": (400, 2, True),
    "d": (600, 1, True),
    "f": (800, 0, True),
    "e": (1000, 4, False),
}


def hubs() -> Instance:
    """Orbit 0: each hub [t, t + 4] at nadir with its spokes [t + 5 + 3i, t + 7 + 3i], each
    exclusive with it by (3) (setup 10 s); hubs 200 s apart, so a hub's (3) conflicts are its
    spokes. Each hub but e has an empty slot on orbit 1; spokes are seen on orbit 0 only.
    Migration scores (3) degrees: a 3, b 2, c 2, d 1, f 0, e -1 (nowhere to go)."""
    weights: dict[str, float] = {}
    rows = []
    for h, (t, n, alt) in HUBS.items():
        weights[h] = 10.0
        rows.append((h, 0, float(t), t + 4.0, 0.0))
        if alt:
            rows.append((h, 1, float(t), t + 4.0, 0.0))
        for i in range(n):
            weights[f"{h}{i}"] = 1.0
            rows.append((f"{h}{i}", 0, t + 5.0 + 3 * i, t + 7.0 + 3 * i, 0.0))
    return Instance.build(weights, rows, n_orbits=2, name="migration_hubs")


def _hub_state(hub_names: str = "abcdfe") -> tuple[Instance, State]:
    """Hubs scheduled on orbit 0 (spokes unscheduled), checked feasible."""
    inst = hubs()
    state, params = _state(inst)
    state.begin()
    for h in hub_names:
        assert insert_options(state, [_opp(inst, h, 0)], params) == _opp(inst, h, 0)
    state.commit()
    assert state.check()
    return inst, state


def _names(inst: Instance, units) -> list[str]:
    return [inst.target_ids[u] for u in units]


def test_hub_scores() -> None:
    """The premise: each scheduled hub's option scores its number of spokes (-1 for e)."""
    inst, state = _hub_state()
    score = {h: state.pb.migration_score[state.sched[inst.target_index[h]]] for h in HUBS}
    assert score == {"a": 3, "b": 2, "c": 2, "d": 1, "f": 0, "e": -1}
    assert inst.target_index["b"] < inst.target_index["c"]


@pytest.mark.parametrize(
    ("scheduled", "expected"),
    [("abcdfe", "a"), ("bcdfe", "b"), ("cde", "c"), ("fe", "f"), ("e", None)],
)
def test_migration_pool_one_is_deterministic(scheduled: str, expected: str | None) -> None:
    """pool = 1: the scheduled unit whose option has most (3) conflicts, ties to the lower
    unit index (b before c), the same for every seed; e (no other opportunity) never, even
    alone or with the most conflicts (-1 when no unit qualifies)."""
    inst, state = _hub_state(scheduled)
    for seed in range(20):
        u = choose_migrating(state, np.random.default_rng(seed), 1)
        assert (inst.target_ids[u] if u >= 0 else None) == expected


@pytest.mark.parametrize(("pool", "expected"), [(2, "ab"), (3, "abc"), (4, "abcd"), (6, "abcd")])
def test_migration_pool_roulette_stays_in_the_top(pool: int, expected: str) -> None:
    """pool > 1: only the ``pool`` highest-scoring qualifying units are drawn, every one with
    a positive score at least once in 3000 draws; f (score 0) never, though in the pool of 6."""
    inst, state = _hub_state()
    rng = np.random.default_rng(11)
    draws = Counter(_names(inst, (choose_migrating(state, rng, pool) for _ in range(3000))))
    assert set(draws) == set(expected)
    if pool == 3:
        # roulette by score 3 : 2 : 2 (sd of a share over 3000 draws < 0.01)
        assert draws["a"] / 3000 == pytest.approx(3 / 7, abs=0.04)
        assert draws["b"] / 3000 == pytest.approx(2 / 7, abs=0.04)


def test_migration_pool_zero_scores_are_drawn_uniformly() -> None:
    """When every unit of the pool scores 0 the draw is uniform among them."""
    inst = Instance.build(
        {"p": 1.0, "q": 1.0},
        [
            ("p", 0, 0.0, 4.0, 0.0),
            ("p", 1, 0.0, 4.0, 0.0),
            ("q", 0, 200.0, 204.0, 0.0),
            ("q", 1, 200.0, 204.0, 0.0),
        ],
        n_orbits=2,
        name="migration_zero_scores",
    )
    state, params = _state(inst)
    state.begin()
    for t in "pq":
        insert_options(state, [_opp(inst, t, 0)], params)
    rng = np.random.default_rng(5)
    draws = Counter(_names(inst, (choose_migrating(state, rng, 2) for _ in range(400))))
    assert set(draws) == {"p", "q"}
    assert choose_migrating(state, np.random.default_rng(5), 1) == inst.target_index["p"]


def test_migration_solve_is_reproducible_and_valid(monkeypatch: pytest.MonkeyPatch) -> None:
    """A whole solve (the paper's two moves, so migration runs) twice with the same seed
    gives the same schedule, and the validator accepts it. The cap is lifted: the greedy start
    observes every hub target, and a solve that reaches the cap stops before migrating."""
    monkeypatch.setattr(importlib.import_module("sosp.solve"), "capped", contextlib.nullcontext)
    inst = hubs()
    kw = {"seed": 4, "iterations": 300, "preset": "paper"}
    r1, r2 = solve(inst, "asa-dtc", **kw), solve(inst, "asa-dtc", **kw)
    assert r1.schedule.observations == r2.schedule.observations
    assert r1.stats["trace"][-1][2:] == r2.stats["trace"][-1][2:]
    rep = validate(inst, r1.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(r1.profit)
    stats = r1.stats
    assert stats["accepted"]["migration"] + stats["rejected"]["migration"] > 0
