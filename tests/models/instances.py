"""Tiny instances for the exact-model tests: a seeded generator and hand-built edge cases."""

from __future__ import annotations

import numpy as np

from sosp.instance import Instance, Resources


def random_tiny(seed: int) -> Instance:
    """A random tiny instance (at most 7 opportunities per orbit, at most 12 in all).

    Windows are dense in time so that (3) conflicts and clustering both occur; resources are
    drawn so that (4), (5), (6) and (11) bind in some of them.
    """
    rng = np.random.default_rng(seed)
    n_orbits = int(rng.integers(1, 4))
    n_targets = int(rng.integers(2, 8))
    rows = []
    for j in range(n_orbits):
        for _ in range(min(int(rng.integers(1, 6 if n_orbits > 1 else 8)), 12 - len(rows))):
            s = float(np.round(rng.uniform(0, 150), 1))
            d = float(np.round(rng.uniform(1, 12), 1))
            roll = float(np.round(rng.uniform(-30, 30), 1))
            half = float(rng.choice([3.0, rng.uniform(1, 6)]))
            lo, hi = max(-33.0, roll - half), min(33.0, roll + half)
            rows.append((int(rng.integers(n_targets)), j, s, s + d, roll, lo, hi))
    res = Resources(
        memory_capacity=float(rng.choice([1000.0, rng.uniform(10, 40)])),
        energy_capacity=float(rng.choice([1500.0, rng.uniform(20, 120)])),
        observe_energy_rate=float(rng.choice([1.0, 0.0, 0.5])),
        slew_energy_rate=float(rng.choice([1.0, 2.0])),
        slew_rate=float(rng.choice([1.0, 2.0, 4.0])),
        setup_time=float(rng.choice([10.0, 2.0, 0.0])),
        max_openings=int(rng.choice([10, 1, 2, 3])),
        max_duration=float(rng.choice([120.0, 15.0, 30.0])),
    )
    weights = [int(w) for w in rng.integers(2, 11, size=n_targets)]
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"rnd{seed}")


def rolls_at_range_ends() -> Instance:
    """Two overlapping windows whose roll ranges touch at one point (8 deg): a cluster at 8."""
    return Instance.build(
        {"a": 5, "b": 4},
        [("a", 0, 0.0, 4.0, 6.0, 5.0, 8.0), ("b", 0, 3.0, 7.0, 10.0, 8.0, 11.0)],
        name="range_ends",
    )


def energy_slew_only(capacity: float) -> Instance:
    """Energy spent on slews only (eo = 0): rolls 30, 0, 30 well apart.

    Consecutive slews of all three: (30 + 0) + (0 + 30) = 60; of the two rolled ones alone: 60;
    one alone: 0. With capacity 60 all three fit exactly (an over-approximation 2 sum |theta|
    = 120 would wrongly cut it); with 59 only two (one of them the nadir one) fit.
    """
    return Instance.build(
        {"a": 5, "b": 4, "c": 3},
        [
            ("a", 0, 0.0, 4.0, 30.0, 27.0, 33.0),
            ("b", 0, 100.0, 104.0, 0.0, -3.0, 3.0),
            ("c", 0, 200.0, 204.0, 30.0, 27.0, 33.0),
        ],
        resources=Resources(observe_energy_rate=0.0, energy_capacity=capacity),
        name=f"energy_slew_{capacity:g}",
    )


def memory_binding() -> Instance:
    """Memory 10 s: either the 8 s window (weight 6) or the two 4 s windows (weights 4 + 3)."""
    return Instance.build(
        {"a": 6, "b": 4, "c": 3},
        [
            ("a", 0, 0.0, 8.0, 0.0),
            ("b", 0, 50.0, 54.0, 0.0),
            ("c", 0, 100.0, 104.0, 0.0),
        ],
        resources=Resources(memory_capacity=10.0),
        name="memory",
    )


def overlap_same_target_two_orbits() -> Instance:
    """Overlapping windows on one orbit and a shared target on another (counted once)."""
    return Instance.build(
        {"a": 7, "b": 5, "c": 2},
        [
            ("a", 0, 0.0, 5.0, 10.0, 7.0, 13.0),
            ("b", 0, 2.0, 6.0, 12.0, 9.0, 15.0),
            ("c", 0, 4.0, 9.0, -10.0, -13.0, -7.0),
            ("a", 1, 10.0, 14.0, 5.0, 2.0, 8.0),
            ("c", 1, 20.0, 24.0, 5.0, 2.0, 8.0),
        ],
        name="overlap_two_orbits",
    )


def duration_binding() -> Instance:
    """Delta T = 10 s: a and c fit one opening only without b in between them in time."""
    return Instance.build(
        {"a": 3, "b": 3, "c": 3},
        [
            ("a", 0, 0.0, 3.0, 5.0, 2.0, 8.0),
            ("b", 0, 4.0, 8.0, 5.0, 2.0, 8.0),
            ("c", 0, 9.0, 12.0, 5.0, 2.0, 8.0),
        ],
        resources=Resources(max_duration=10.0),
        name="duration",
    )


EDGE_CASES = {
    "range_ends": rolls_at_range_ends,
    "energy_slew_60": lambda: energy_slew_only(60.0),
    "energy_slew_59": lambda: energy_slew_only(59.0),
    "memory": memory_binding,
    "overlap_two_orbits": overlap_same_target_two_orbits,
    "duration": duration_binding,
}


def scenario_tiny(count: int, hours: float, seed: int) -> Instance:
    """A real-orbit instance from the scenario generator with a few targets in a small box."""
    from sosp.scenarios import custom_scenario

    return custom_scenario(
        region=(30.0, 32.0, 110.0, 112.0), count=count, hours=hours, seed=seed, name="tiny"
    )


def random_dense(seed: int, n: int = 40, n_orbits: int = 2) -> Instance:
    """A random instance too large for the oracle (dense windows: many overlapping cliques)."""
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(n):
        s = float(np.round(rng.uniform(0, 300), 1))
        d = float(np.round(rng.uniform(1, 15), 1))
        roll = float(np.round(rng.uniform(-30, 30), 1))
        rows.append((int(rng.integers(n // 2)), k % n_orbits, s, s + d, roll, roll - 4, roll + 4))
    res = Resources(
        energy_capacity=float(rng.choice([1500.0, 150.0])),
        memory_capacity=float(rng.choice([1000.0, 60.0])),
        max_openings=int(rng.choice([10, 4])),
        setup_time=float(rng.choice([10.0, 2.0])),
        max_duration=30.0,
    )
    weights = [int(w) for w in rng.integers(1, 11, size=n // 2)]
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"dense{seed}")


def triangle() -> Instance:
    """Three orbits, one opening each: orbit j sees two of the targets a, b, c together (one
    strip) or a target of its own (weight 8) at the same time, in another direction.

    Two orbits cover a, b and c, the third its own target: 38. The master over orbit plans
    takes each orbit half on its pair and half on its own target, 42, and no branching on
    a single target is needed to see why: the subset-row cut over {a, b, c} (each pair plan
    counts ceil(2 / 2) = 1) allows at most 1 + 3/2 of the three, which the master's 3 breaks.
    """
    rows = []
    for j, (x, y) in enumerate([("a", "b"), ("b", "c"), ("a", "c")]):
        rows += [(x, j, 0.0, 4.0, 10.0), (y, j, 1.0, 5.0, 10.0), (f"d{j}", j, 2.0, 6.0, -20.0)]
    weights = {"a": 10, "b": 10, "c": 10, "d0": 8, "d1": 8, "d2": 8}
    return Instance.build(
        weights, rows, resources=Resources(max_openings=1), n_orbits=3, name="triangle"
    )


def split_pair() -> Instance:
    """Two orbits, one opening each: orbit 0 sees a or b (at the same time, in two
    directions), orbit 1 sees a and b together (one strip) or d (weight 8) at the same time,
    in another direction.

    Orbit 1 on a and b gives 20; orbit 1 on d and orbit 0 on a gives 18: the optimum is 20.
    The master over orbit plans takes orbit 0 half on a and half on b and orbit 1 half on the
    pair and half on d, 24; no subset-row cut over three targets holds it off, but the cut
    over {a, b} and orbit 0 (orbit 0 gives at most one of them, ``z_a + z_b <= 1 + the
    others' ceil(h / 2)``) does: with it the master is 20.
    """
    rows = [
        ("a", 0, 0.0, 4.0, 10.0), ("b", 0, 1.0, 5.0, -20.0),
        ("a", 1, 0.0, 4.0, 10.0), ("b", 1, 1.0, 5.0, 10.0), ("d", 1, 2.0, 6.0, -20.0),
    ]  # fmt: skip
    return Instance.build(
        {"a": 10, "b": 10, "d": 8}, rows, resources=Resources(max_openings=1), n_orbits=2,
        name="split_pair",
    )  # fmt: skip


def shared_tiny(seed: int) -> Instance:
    """A random tiny instance of :func:`triangle`'s kind: 3-4 orbits, each seeing two of 3-4
    shared targets together and, mostly, a target of its own at the same time; one or two
    openings. Its master mixes pair plans, so subset-row cuts are found on some."""
    rng = np.random.default_rng(seed)
    n_orbits = int(rng.integers(3, 5))
    n_shared = int(rng.integers(3, 5))
    rows = []
    for j in range(n_orbits):
        x, y = rng.choice(n_shared, size=2, replace=False)
        s = float(np.round(rng.uniform(0, 5), 1))
        roll = float(np.round(rng.uniform(-10, 10), 1))
        late = float(np.round(rng.uniform(0, 2), 1))
        turn = float(np.round(rng.uniform(-2, 2), 1))
        rows.append((f"s{x}", j, s, s + 4.0, roll))
        rows.append((f"s{y}", j, s + late, s + 5.0, roll + turn))
        if len(rows) < 14 - (n_orbits - 1 - j) * 2:  # the oracle's 14 opportunities
            own = float(np.round(rng.uniform(-30, -20), 1))
            rows.append((f"p{j}", j, s + 1.0, s + 5.0, own))
    names = sorted({r[0] for r in rows})
    weights = {n: int(rng.integers(4, 11)) for n in names}
    res = Resources(max_openings=int(rng.choice([1, 1, 2])))
    return Instance.build(weights, rows, resources=res, n_orbits=n_orbits, name=f"shared{seed}")


def random_tiny_stations(seed: int) -> Instance:
    """A random tiny instance with ground stations: one or two satellites of two 1000-s orbits
    each, at most 8 opportunities, one or two stations (one or two antennas) and two to five
    contacts, a small store, a slow downlink and downlink energy that can bind, so that
    (D5), (D7), (D8) and the antennas decide in some of them."""
    from sosp.downlink import DownlinkParams

    rng = np.random.default_rng(seed)
    n_sat, n_st = int(rng.integers(1, 3)), int(rng.integers(1, 3))
    n_targets = int(rng.integers(3, 7))
    rows = []
    for _ in range(int(rng.integers(3, 9))):
        j = int(rng.integers(2 * n_sat))
        s = float(np.round(rng.uniform(0, 900), 1)) + 1000.0 * (j % 2)
        d = float(np.round(rng.uniform(5, 30), 1))
        roll = float(np.round(rng.uniform(-20, 20), 1))
        rows.append((int(rng.integers(n_targets)), j, s, s + d, roll))
    t, o, st, en, ro = (np.array(c) for c in zip(*rows, strict=True))
    contacts = []
    for _ in range(int(rng.integers(2, 6))):
        a = float(np.round(rng.uniform(300, 1900), 1))
        contacts.append((int(rng.integers(n_sat)), int(rng.integers(n_st)), a,
                         a + float(np.round(rng.uniform(10, 60), 1))))  # fmt: skip
    res = Resources(
        memory_capacity=float(rng.choice([1000.0, rng.uniform(15, 40)])),
        energy_capacity=float(rng.choice([1000.0, rng.uniform(30, 90)])),
        observe_energy_rate=float(rng.choice([1.0, 0.5])),
        slew_energy_rate=1.0,
        slew_rate=2.0,
        setup_time=float(rng.choice([10.0, 0.0])),
        max_openings=int(rng.choice([10, 2])),
        max_duration=120.0,
    )
    sats = [f"S{s}" for s in range(n_sat)]
    return Instance.from_arrays(
        epoch="2026-01-01T00:00:00Z",
        target_ids=[f"t{k}" for k in range(n_targets)],
        target_lat=np.zeros(n_targets),
        target_lon=np.zeros(n_targets),
        target_weight=[int(w) for w in rng.integers(2, 11, size=n_targets)],
        orbit_ids=[f"{s}-{j}" for s in sats for j in (1, 2)],
        orbit_satellite=[s for s in sats for _ in (1, 2)],
        orbit_start=np.tile([0.0, 1000.0], n_sat),
        orbit_end=np.tile([1000.0, 2000.0], n_sat),
        resources=res,
        opp_target=t,
        opp_orbit=o,
        opp_start=st,
        opp_end=en,
        opp_roll=ro,
        opp_roll_min=ro - 3,
        opp_roll_max=ro + 3,
        stations={
            "id": [f"G{h}" for h in range(n_st)],
            "lat_deg": np.zeros(n_st),
            "lon_deg": np.zeros(n_st),
            "alt_m": np.zeros(n_st),
            "min_elevation_deg": np.full(n_st, 5.0),
            "antennas": [int(rng.integers(1, 3)) for _ in range(n_st)],
            "description": [""] * n_st,
        },
        contacts={
            "satellite": [c[0] for c in contacts],
            "station": [c[1] for c in contacts],
            "start_s": [c[2] for c in contacts],
            "end_s": [c[3] for c in contacts],
            "max_elevation_deg": [45.0] * len(contacts),
        },
        downlink=DownlinkParams(
            rate=float(rng.choice([0.5, 1.0])),
            energy_rate=float(rng.choice([0.0, 1.0])),
            station_setup_s=30.0,
            while_observing=bool(rng.integers(2)),
            count="observed" if rng.random() < 0.15 else "delivered",
        ),
        name=f"rnd-st{seed}",
    )
