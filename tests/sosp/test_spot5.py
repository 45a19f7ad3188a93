"""The SPOT5 benchmark: reader, capacity readings, bad files, validator and the solvers
(MILP against brute force, RDS against the MILP, the tabu search never above an optimum)."""

from __future__ import annotations

import dataclasses
import itertools
import json
from pathlib import Path

import numpy as np
import pytest

from heuristics.spot5 import solve_spot5_rds, solve_spot5_tabu
from models.spot5 import solve_spot5_milp, spot5_bound, weight_split
from sosp.cli import main
from sosp.errors import InputError
from sosp.spot5 import (
    PUBLISHED,
    instance_path,
    load_spot5,
    read_solution,
    validate_spot5,
    write_solution,
)


def brute_force(problem) -> int:
    """Best profit over every assignment, checked by the validator."""
    best = 0
    for a in itertools.product(*[range(-1, int(d)) for d in problem.size]):
        rep = validate_spot5(problem, np.asarray(a))
        if rep.feasible:
            best = max(best, rep.profit)
    return best


def test_reader_reads_the_counts_values_and_capacity() -> None:
    p = load_spot5(instance_path("8"))
    assert (p.n, len(p.pairs) + len(p.triples), p.capacity) == (8, 7, None)
    assert p.values[4, : p.size[4]].tolist() == [13] and p.size[:4].tolist() == [3] * 4
    # "2 1 0 3 3 2 2 1 1": variables 1 and 0 may not take the same instrument
    assert p.pairs[0].tolist() == [1, 0] and len(p.pair_forbid[: p.pair_ptr[1]]) == 3
    m = load_spot5(instance_path("1502"))
    assert (m.n, m.capacity) == (209, 200)
    assert set(np.unique(m.consumption)) <= {0, 1, 2, 4} and m.consumption.max() == 4
    assert load_spot5(instance_path("1502"), "raw").capacity == 199


def test_both_capacity_readings(tmp_path: Path) -> None:
    """201 mono images of 451.15 units each against 90,000: 200 fit the default reading,
    199 the raw one; the MILP meets each and the validator tells them apart."""
    f = tmp_path / "cap.spot"
    rows = [f"{i} 1 1 2 451.15" for i in range(201)]
    f.write_text("\n".join(["201", *rows, "1", "90000", ""]))
    units, raw = load_spot5(f), load_spot5(f, "raw")
    assert (units.capacity, raw.capacity) == (200, 199)
    for problem, best in ((units, 200), (raw, 199)):
        r = solve_spot5_milp(problem, 30)
        assert (r.value, r.bound, r.status) == (best, best, "optimal")
    full = solve_spot5_milp(units, 30).assignment
    assert validate_spot5(units, full).feasible and not validate_spot5(raw, full).feasible


BAD_FILES = {
    "truncated": ("3\n0 1 1 2 0\n1 1 1 2 0\n", 4),
    "arity": ("2\n0 1 1 2 0\n1 1 1 2 0\n1\n4 0 1 2 2\n", 5),
    "tuple arity": ("2\n0 1 1 2 0\n1 1 1 2 0\n1\n2 0 1 2 2 2\n", 5),
    "value outside domain": ("2\n0 1 1 2 0\n1 1 1 2 0\n1\n2 0 1 2 3\n", 5),
    "negative weight": ("2\n0 1 1 2 0\n1 -4 1 2 0\n0\n", 3),
}


@pytest.mark.parametrize("kind", BAD_FILES)
def test_bad_files_exit_2_with_the_line(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text, line = BAD_FILES[kind]
    f = tmp_path / "bad.spot"
    f.write_text(text)
    out = tmp_path / "out.txt"
    assert main(["solve", str(f), "--method", "tabu", "--time-limit", "1", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"line {line}:" in err and "Traceback" not in err
    assert not out.exists()
    with pytest.raises(InputError):
        load_spot5(f)


def test_validator_catches_each_violation() -> None:
    p = load_spot5(instance_path("54"))
    empty = np.full(p.n, -1)
    assert validate_spot5(p, empty).feasible
    for cons, ptr, forbid in (
        (p.pairs, p.pair_ptr, p.pair_forbid),
        (p.triples, p.triple_ptr, p.triple_forbid),
    ):
        a = empty.copy()
        a[cons[0]] = forbid[ptr[0]]
        rep = validate_spot5(p, a)
        assert not rep.feasible and f"arity {cons.shape[1]}" in rep.violations[0]
        assert rep.profit == p.weight[cons[0]].sum()
    a = empty.copy()
    a[0] = p.size[0]  # a position outside the domain
    assert not validate_spot5(p, a).feasible
    m = load_spot5(instance_path("1502"))
    tight = dataclasses.replace(m, capacity=0)
    a = np.full(m.n, -1)
    a[np.flatnonzero(m.consumption[:, 0] > 0)[0]] = 0
    assert validate_spot5(m, a).feasible
    assert "recorder" in validate_spot5(tight, a).violations[0]


@pytest.mark.parametrize(("name", "keep", "cap"), [("54", 7, None), ("1502", 7, 3), ("8", 8, None)])
def test_milp_and_rds_equal_brute_force(name: str, keep: int, cap: int | None) -> None:
    p = load_spot5(instance_path(name)).subproblem(keep)
    if cap is not None:  # make the recorder bind
        p = dataclasses.replace(p, capacity=cap)
    best = brute_force(p)
    for r in (solve_spot5_milp(p, 30), solve_spot5_rds(p, 30)):
        assert validate_spot5(p, r.assignment).feasible
        assert (r.value, r.bound, r.status) == (best, best, "optimal")


def test_weight_split() -> None:
    """The heavy weights' gcd must exceed the lights' total: 1000 when 1, 2, 5 sum to 868."""
    p = load_spot5(instance_path("1407"))
    assert weight_split(p) == 1000 and p.weight[p.weight < 1000].sum() == 868
    for w, t in (([1, 2, 3], None), ([1, 1, 4], 4), ([1, 1, 6, 6, 9], 6), ([5, 5], None)):
        assert weight_split(dataclasses.replace(p, weight=np.array(w))) == t


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_lexicographic_milp_equals_brute_force(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Heavy images first, then all: the optimum of both stages is the brute force's, on
    subproblems of 1502 with random weights 1, 2, 1000, 2000 and a recorder that binds."""
    rng = np.random.default_rng(seed)
    p = load_spot5(instance_path("1502")).subproblem(8)
    p = dataclasses.replace(p, weight=rng.choice([1, 2, 1000, 2000], p.n), capacity=3 + seed % 2)
    split = weight_split(p)
    assert split in (1000, 2000)
    best = brute_force(p)
    heavy = brute_force(dataclasses.replace(p, weight=np.where(p.weight >= split, p.weight, 0)))
    r = solve_spot5_milp(p, 30)
    assert validate_spot5(p, r.assignment).feasible
    assert (r.value, r.bound, r.status) == (best, best, "optimal")
    assert r.stats["heavy_value"] == r.stats["heavy_bound"] == heavy
    assert solve_spot5_milp(p, 30, lexicographic=False).value == best
    # no time for the heavy stage: its bound is the heavy weights' total, still valid
    monkeypatch.setattr("models.spot5.HEAVY_SHARE", 0.0)
    r = solve_spot5_milp(p, 30)
    assert r.stats["heavy_bound"] == p.weight[p.weight >= split].sum()
    assert (r.value, r.bound) == (best, best)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lns_alone_reaches_the_brute_force_optimum(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """HiGHS given no time: the large neighbourhood search, from neighbourhoods of two images
    that grow, reaches the optimum of subproblems of 1502 with a recorder that binds; the
    bound stays valid (the heavy stage's, no second-stage bound)."""
    rng = np.random.default_rng(seed)
    p = load_spot5(instance_path("1502")).subproblem(10)
    p = dataclasses.replace(p, weight=rng.choice([1, 2, 5, 1000], p.n), capacity=4)
    best = brute_force(p)
    monkeypatch.setattr("models.spot5.HIGHS_SHARE", 0.0)
    monkeypatch.setattr("models.spot5.LNS_FREE", 2)
    for lexicographic in (False, True):
        r = solve_spot5_milp(p, 1, lexicographic=lexicographic, rng=np.random.default_rng(seed))
        assert validate_spot5(p, r.assignment).feasible
        assert r.value == best and r.stats["lns_gains"] > 0
        assert r.bound is None or r.bound >= best


@pytest.mark.parametrize("name", ["404", "503", "29"])
def test_rds_equals_milp_and_tabu_stays_below(name: str) -> None:
    p = load_spot5(instance_path(name))
    milp, rds = solve_spot5_milp(p, 60), solve_spot5_rds(p, 60)
    tabu = solve_spot5_tabu(p, 0.3, rng=np.random.default_rng(1))
    assert milp.status == rds.status == "optimal" and milp.value == rds.value
    assert milp.value == PUBLISHED[name][0]
    for r in (milp, rds, tabu):
        assert validate_spot5(p, r.assignment).feasible
    assert 0 < tabu.value <= milp.value


def test_tabu_stops_once_it_stalls_and_keeps_its_best() -> None:
    p = load_spot5(instance_path("503"))
    r = solve_spot5_tabu(p, 60, rng=np.random.default_rng(1), stall=2000, chunk=100)
    idle = r.stats["iterations"] - r.stats["last_improvement"]
    assert 2000 <= idle < 2100 and r.time_s < 60
    assert validate_spot5(p, r.assignment).profit == r.value > 0


def test_clique_lp_bound_is_valid_and_not_weaker() -> None:
    p = load_spot5(instance_path("503"))
    clique, plain = spot5_bound(p)["bound"], spot5_bound(p, cliques=False)["bound"]
    assert PUBLISHED["503"][0] <= clique <= plain and clique < plain


@pytest.mark.parametrize("suffix", [".txt", ".json"])
def test_cli_solve_writes_a_solution_that_validates(
    suffix: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = str(instance_path("54"))
    out = tmp_path / f"sol{suffix}"
    assert main(["solve", f, "--method", "milp", "--time-limit", "20", "-o", str(out)]) == 0
    assert "value 70, bound 70" in capsys.readouterr().out
    assert main(["validate", f, str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["profit"] == 70
    p = load_spot5(f)
    assert p.profit(read_solution(out, p)) == 70
    write_solution(out, p, np.full(p.n, 0))  # every image on its first value: infeasible
    assert main(["validate", f, str(out)]) == 1
    assert "INFEASIBLE" in capsys.readouterr().out
    assert main(["bound", f]) == 0 and "clique LP bound" in capsys.readouterr().out
