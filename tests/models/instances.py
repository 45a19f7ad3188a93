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
