"""GA-STC: validity, the static optimum as a ceiling, and its operators by hand
(repair's DROP and ADD, uniform crossover, mutation, tournament)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.ga import GAParams, mutate, random_member, repair, tournament, uniform_crossover
from heuristics.stc import stc_data
from sosp.clustering import tasks_to_schedule
from sosp.errors import InputError
from sosp.instance import Instance
from sosp.params import from_kwargs
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import small_instances
from tests.heuristics.test_aco import four_apart
from tests.heuristics.test_hpfs import x_blocks_y_and_z
from tests.oracle import brute_force


def _bits(inst: Instance, data, names: str) -> np.ndarray:  # noqa: ANN001
    """Chromosome with the tasks of the named targets on (one task per target here)."""
    bits = np.zeros(len(data.usable), dtype=bool)
    for n in names:
        (t,) = data.target_tasks[inst.target_index[n]]
        bits[data.position[t]] = True
    return bits


def _names(inst: Instance, data, bits: np.ndarray) -> str:  # noqa: ANN001
    return "".join(sorted(inst.target_ids[k] for t in data.usable[bits] for k in data.targets[t]))


# ---------------------------------------------------------------------------- properties
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(), seed=st.integers(0, 2**16))
def test_every_schedule_passes_the_validator(inst: Instance, seed: int) -> None:
    res = solve(inst, "ga-stc", seed=seed, iterations=30, population=10, check=False)
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=8), seed=st.integers(0, 2**16))
def test_profit_never_exceeds_the_static_optimum(inst: Instance, seed: int) -> None:
    res = solve(inst, "ga-stc", seed=seed, iterations=30, population=10)
    assert res.profit <= brute_force(inst, "static").profit + 1e-9


def test_finds_the_pair_that_highest_weight_first_misses() -> None:
    # x (6) blocks y (5) and z (4); the optimum is {y, z} = 9 (tests/heuristics/test_hpfs).
    res = solve(x_blocks_y_and_z(), "ga-stc", seed=0, iterations=50, population=4)
    assert res.profit == 9


def test_time_limit_stops_early(c1) -> None:
    inst = c1
    res = solve(inst, "ga-stc", time_limit=0.5, iterations=10**6)
    assert res.iterations < 10**6
    assert validate(inst, res.schedule).feasible


# --------------------------------------------------------------------------------- repair
def test_repair_drops_what_breaks_the_openings_least_useful_first() -> None:
    inst = four_apart()  # one orbit, max_openings 2, a..d weigh 1..4, equal costs
    data = stc_data(inst)
    bits, profit = repair(data, _bits(inst, data, "abcd"))
    assert _names(inst, data, bits) == "cd" and profit == 7


def test_repair_adds_by_utility_after_dropping() -> None:
    inst = four_apart()
    data = stc_data(inst)
    # {a} is kept (it fits), then ADD takes the most useful task that still fits: d.
    bits, profit = repair(data, _bits(inst, data, "a"))
    assert _names(inst, data, bits) == "ad" and profit == 5
    bits, profit = repair(data, _bits(inst, data, ""))
    assert _names(inst, data, bits) == "cd" and profit == 7


def test_repair_drops_a_setup_conflict() -> None:
    inst = x_blocks_y_and_z()  # x conflicts by (3) with y and with z
    data = stc_data(inst)
    bits, profit = repair(data, _bits(inst, data, "xyz"))
    # whichever of x or {y, z} comes first by utility stays; the result is feasible and maximal
    assert _names(inst, data, bits) in ("x", "yz")
    assert profit == (6 if _names(inst, data, bits) == "x" else 9)
    assert validate(inst, tasks_to_schedule(inst, data.tasks, data.usable[bits])).feasible


def test_random_member_is_maximal() -> None:
    inst = four_apart()
    data = stc_data(inst)
    bits, profit = random_member(data, np.random.default_rng(3))
    assert bits.sum() == 2 and profit == sum(" abcd".index(c) for c in _names(inst, data, bits))


# ------------------------------------------------------------------------------ operators
def test_uniform_crossover_takes_each_bit_from_a_parent() -> None:
    rng = np.random.default_rng(0)
    a = rng.random(64) < 0.5
    b = rng.random(64) < 0.5
    child = uniform_crossover(a, b, np.random.default_rng(1))
    assert np.all((child == a) | (child == b))
    assert np.all(child[a == b] == a[a == b])
    differ = a != b
    assert 0 < np.sum(child[differ] == a[differ]) < differ.sum()  # both parents contribute


def test_mutation_flips_exactly_n_bits() -> None:
    bits = np.zeros(20, dtype=bool)
    out = mutate(bits, 2, np.random.default_rng(5))
    assert out.sum() == 2 and bits.sum() == 0
    assert mutate(np.zeros(1, dtype=bool), 3, np.random.default_rng(0)).sum() == 1


def test_tournament_returns_the_fittest_drawn() -> None:
    fitness = np.array([5, 9, 1, 7])
    rng = np.random.default_rng(2)
    for _ in range(20):
        state = rng.bit_generator.state
        drawn = rng.integers(0, 4, size=2)
        rng.bit_generator.state = state
        assert fitness[tournament(fitness, 2, rng)] == fitness[drawn].max()
    assert tournament(fitness, 4 * 50, np.random.default_rng(0)) == 1


# ------------------------------------------------------------------------------- parameters
def test_params_from_command_line_strings() -> None:
    p = from_kwargs(
        GAParams, {"population": "50", "mutation_bits": "0", "roll_rule": "nadir"}, method="ga-stc"
    )
    assert (p.population, p.mutation_bits, p.roll_rule) == (50, 0, "nadir")


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"population": 1}, "population"),
        ({"population": "many"}, "population"),
        ({"tournament": 0}, "tournament"),
        ({"tournament": 200}, "tournament"),
        ({"mutation_bits": -1}, "mutation_bits"),
        ({"iterations": 1.5}, "iterations"),
        ({"roll_rule": "left"}, "roll_rule"),
        ({"crossover": "one-point"}, "crossover"),
    ],
)
def test_bad_params_name_the_field(kwargs: dict, field: str) -> None:
    with pytest.raises(InputError, match=field):
        from_kwargs(GAParams, kwargs, method="ga-stc")


def test_a_stop_request_ends_the_ga_with_its_best(c1) -> None:
    from sosp.progress import Progress
    from sosp.result import Status
    from sosp.stop import clear_stop, request_stop

    inst = c1

    def cb(snap) -> None:  # noqa: ANN001
        if snap.elapsed > 0.3:
            request_stop("test")

    try:
        res = solve(inst, "ga-stc", seed=1, iterations=10**9, progress=Progress(cb, interval=0.05))
    finally:
        clear_stop()
    assert res.status is Status.INTERRUPTED and res.iterations < 10**9
    assert validate(inst, res.schedule).feasible and res.profit > 0


def test_iterations_default_to_the_time_limit_else_a_constant(monkeypatch) -> None:  # noqa: ANN001
    import heuristics.ga as ga

    monkeypatch.setattr(ga, "DEFAULT_ITERATIONS", 7)
    inst = x_blocks_y_and_z()
    assert solve(inst, "ga-stc", seed=0, population=4).iterations == 7
    assert solve(inst, "ga-stc", seed=0, population=4, time_limit=0.3).iterations > 7
