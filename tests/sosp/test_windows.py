"""The window pricing (sosp.windows): G(i, k) against brute force over rolls, the relaxation
never below the exact single-orbit plan, the real plans feasible."""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from heuristics.orbit_search import ascend_from_both, hpfs_start, lp_start
from models.colgen import colgen_bound
from models.window_bound import window_colgen_bound
from sosp.ascent import START_MODES, WindowData, WindowSearch, ascent_profit
from sosp.instance import Instance, Resources
from sosp.planner import best_path, orbit_data
from sosp.rules import EPS, orbit_rules
from sosp.schedule import Observation, Schedule
from sosp.solve import solve
from sosp.stop import Budget
from sosp.validate import validate
from sosp.windows import (
    OrbitOpps,
    orbit_opps,
    relaxed_best_path,
    window_items,
    window_plan,
)
from tests.conftest import scenario, small_instances
from tests.limits import limit_kept
from tests.oracle import brute_force


def _random_orbit(seed: int, n: int = 30, span: float = 200.0, limit: float = 60.0):
    rng = np.random.default_rng(seed)
    ts = np.sort(rng.integers(0, span, n)).astype(float)  # integer starts: ties happen
    te = ts + rng.integers(1, 15, n)
    theta = rng.integers(-33, 34, n).astype(float)
    lo, hi = np.maximum(theta - 3.0, -33.0), np.minimum(theta + 3.0, 33.0)
    price = np.where(rng.random(n) < 0.2, 0.0, rng.integers(1, 10, n).astype(float))
    rules = orbit_rules(Instance.build([1], [(0, 0, 0, 1, 0.0)]), 0)
    rules = dataclasses.replace(rules, max_duration=limit)
    oo = OrbitOpps(0, 0, ts, te, lo, hi, np.arange(n), rules)
    return oo, price


def _brute_gain(oo: OrbitOpps, w: np.ndarray, i: int, k: int) -> tuple[float, np.ndarray]:
    """max over rolls in i's range of the priced opportunities inside [ts_i, te_k] holding it,
    over every range end (the maximum of a sum of intervals is at an end)."""
    inside = (oo.start >= oo.start[i]) & (oo.end <= oo.end[k]) & (w > 0)
    rolls = np.concatenate((oo.roll_min, oo.roll_max))
    rolls = rolls[(rolls >= oo.roll_min[i] - EPS) & (rolls <= oo.roll_max[i] + EPS)]
    best, at = -1.0, np.zeros(0)
    for r in rolls:
        hold = inside & (oo.roll_min - EPS <= r) & (r <= oo.roll_max + EPS)
        v = float(w[hold].sum())
        if v > best:
            best, at = v, hold
    return best, at


@pytest.mark.parametrize("seed", range(30))
def test_gains_against_brute_force_over_rolls(seed: int) -> None:
    oo, w = _random_orbit(seed)
    wi = window_items(oo, w)
    limit = oo.rules.max_duration
    # every kept row is worth G(i, k) exactly, at a roll in i's range that reaches it
    for i, k, g, r in zip(wi.first, wi.last, wi.gain, wi.point, strict=True):
        assert w[i] > 0 and oo.end[k] >= oo.end[i] and oo.end[k] <= oo.start[i] + limit + EPS
        assert g == pytest.approx(_brute_gain(oo, w, i, k)[0])
        assert oo.roll_min[i] - EPS <= r <= oo.roll_max[i] + EPS
        inside = (oo.start >= oo.start[i]) & (oo.end <= oo.end[k]) & (w > 0)
        hold = inside & (oo.roll_min - EPS <= r) & (r <= oo.roll_max + EPS)
        assert float(w[hold].sum()) == pytest.approx(g)
    # the real observation of each row: its members' latest end and common range
    for u in range(wi.size):
        i, k, r = wi.first[u], wi.last[u], wi.point[u]
        inside = (oo.start >= oo.start[i]) & (oo.end <= oo.end[k]) & (w > 0)
        hold = inside & (oo.roll_min - EPS <= r) & (r <= oo.roll_max + EPS)
        assert hold[i]
        assert wi.end[u] == oo.end[hold].max()
        assert wi.roll_lo[u] == oo.roll_min[hold].max()
        assert wi.roll_hi[u] == oo.roll_max[hold].min()
    # every (i, k) is covered: the kept row of i with the latest end <= te_k is worth G(i, k)
    for i in np.flatnonzero(w > 0):
        for k in range(oo.size):
            if (
                oo.end[k] < oo.end[i]
                or oo.end[k] > oo.start[i] + limit
                or oo.start[k] < oo.start[i]
            ):
                continue
            rows = np.flatnonzero((wi.first == i) & (oo.end[wi.last] <= oo.end[k]))
            assert len(rows), (i, k)
            assert wi.gain[rows].max() == pytest.approx(_brute_gain(oo, w, i, k)[0])


@pytest.mark.parametrize("band", [0.5, 2.0, 7.0])
@pytest.mark.parametrize("seed", range(15))
def test_banded_rows_against_brute_force(seed: int, band: float) -> None:
    oo, w = _random_orbit(seed)
    whole = window_items(oo, w)
    wi = window_items(oo, w, band)
    bare = window_items(oo, w, band, span=False)  # the relaxation's call: the same rows
    for f in ("first", "last", "gain", "point", "least_roll"):
        assert np.array_equal(getattr(bare, f), getattr(wi, f))
    assert bare.end.size == 0 and wi.end.size == wi.size
    limit = oo.rules.max_duration
    for i, k, g, r, a in zip(wi.first, wi.last, wi.gain, wi.point, wi.least_roll, strict=True):
        # a row's gain is reached at its roll, inside i's range, at most one band further
        # from nadir than its least roll
        assert oo.roll_min[i] - EPS <= r <= oo.roll_max[i] + EPS
        assert abs(r) >= a - EPS
        assert abs(r) - a <= band + EPS
        inside = (oo.start >= oo.start[i]) & (oo.end <= oo.end[k]) & (w > 0)
        hold = inside & (oo.roll_min - EPS <= r) & (r <= oo.roll_max + EPS)
        assert float(w[hold].sum()) == pytest.approx(g)
        assert g <= _brute_gain(oo, w, i, k)[0] + 1e-9
        assert oo.end[k] <= oo.start[i] + limit + EPS
    for u in range(wi.size):
        # the real observation of r*: every member's range holds its common range
        i, k, r = wi.first[u], wi.last[u], wi.point[u]
        inside = (oo.start >= oo.start[i]) & (oo.end <= oo.end[k]) & (w > 0)
        hold = inside & (oo.roll_min - EPS <= r) & (r <= oo.roll_max + EPS)
        assert wi.end[u] == oo.end[hold].max()
        assert oo.roll_min[hold].max() <= wi.roll_lo[u] + EPS
        assert wi.roll_hi[u] <= oo.roll_max[hold].min() + EPS
        assert wi.roll_lo[u] - EPS <= r <= wi.roll_hi[u] + EPS
    # the bands' rows together reach every (i, k)'s G, at no larger least roll
    for i in np.flatnonzero(w > 0):
        for k in np.flatnonzero(whole.first == i):
            end = oo.end[whole.last[k]]
            rows = np.flatnonzero((wi.first == i) & (oo.end[wi.last] <= end + EPS))
            assert wi.gain[rows].max() == pytest.approx(whole.gain[k])
            assert wi.least_roll[rows].min() >= whole.least_roll[k] - EPS


def _relaxation_holds(inst: Instance, rng: np.random.Generator) -> None:
    data = orbit_data(inst)
    for o in data.orbits:
        oo = orbit_opps(inst, o.orbit)
        for lam_e, lam_w in ((0.0, 0.0), tuple(rng.uniform(0, 50, 2))):
            price = rng.uniform(0, 10, inst.n_targets) * (rng.random(inst.n_targets) < 0.8)
            exact, _ = best_path(o, price, lam_e, lam_w)
            relaxed, _, _ = relaxed_best_path(oo, price, lam_e, lam_w)
            assert relaxed >= exact - 1e-9
            # per roll band: tighter than the whole range, still above the exact plan
            for band in (0.5, 2.0):
                banded, _, _ = relaxed_best_path(oo, price, lam_e, lam_w, band=band)
                assert exact - 1e-9 <= banded <= relaxed + 1e-9


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances(max_opps=9), seed=st.integers(0, 2**16))
def test_relaxation_is_never_below_the_exact_plan(inst: Instance, seed: int) -> None:
    _relaxation_holds(inst, np.random.default_rng(seed))


@pytest.fixture(scope="module")
def c1() -> Instance:
    return scenario("C1")


def test_relaxation_on_c1_orbits(c1: Instance) -> None:
    _relaxation_holds(c1, np.random.default_rng(0))


def test_relaxation_equals_the_exact_plan_when_every_range_holds_nadir() -> None:
    # every roll range holds 0: the relaxed |theta| (0) and the real nadir rolls agree, and
    # every window's real observation covers what G counts, so both optima are the same
    rows = [(k, 0, 10.0 * k, 10.0 * k + 4, 0.0, -3.0, 3.0) for k in range(6)]
    inst = Instance.build([3, 1, 4, 1, 5, 9], rows, resources=Resources(max_duration=15))
    price = np.asarray(inst.target_weight, dtype=float)
    exact, _ = best_path(orbit_data(inst).orbits[0], price)
    relaxed, _, _ = relaxed_best_path(orbit_opps(inst, 0), price)
    assert relaxed == pytest.approx(exact)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    inst=small_instances(max_opps=9),
    seed=st.integers(0, 2**16),
    start=st.sampled_from(START_MODES),
)
def test_window_plans_are_feasible_and_bounded(inst: Instance, seed: int, start: str) -> None:
    price = np.asarray(inst.target_weight, dtype=float)
    for j in range(inst.n_orbits):
        plan = window_plan(orbit_opps(inst, j), price)
        claimed: set[int] = set()
        obs = []
        for u in range(plan.size):
            mine = tuple(i for i in plan.opps[u] if int(inst.opp_target[i]) not in claimed)
            claimed.update(int(inst.opp_target[i]) for i in mine)
            if mine:  # a target seen twice on the orbit may be planned twice (as the planner)
                obs.append(Observation(j, plan.start[u], plan.end[u], plan.roll[u], mine))
        rep = validate(inst, Schedule(tuple(obs)))
        assert rep.feasible, rep.violations
    res = solve(
        inst, "orbit-dp", seed=seed, iterations=10, candidates="windows", start=start, check=False
    )
    rep = validate(inst, res.schedule)
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(res.profit)
    optimum = brute_force(inst, "cluster").profit
    assert res.profit <= optimum + 1e-9
    assert window_colgen_bound(inst)["bound"] >= optimum
    assert window_colgen_bound(inst, max_rounds=2)["bound"] >= optimum


def test_windows_orbit_dp_on_c1(c1: Instance) -> None:
    res = solve(c1, "orbit-dp", seed=0, iterations=5, candidates="windows")
    assert validate(c1, res.schedule).feasible
    assert res.stats["candidate_mode"] == "windows"
    # the restricted candidates reach most of what every candidate reaches
    explicit = ascent_profit(orbit_data(c1))
    assert res.profit >= 0.9 * explicit
    ws = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    ws.ascent()
    assert validate(c1, ws.schedule()).profit == pytest.approx(ws.profit)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances())
def test_window_colgen_bound_between_the_optimum_and_the_cap(inst: Instance) -> None:
    out = window_colgen_bound(inst, band=None)
    banded = window_colgen_bound(inst, band=1.0)
    optimum = brute_force(inst, "cluster").profit
    for b in (out, banded):
        assert optimum <= b["bound"] <= b["cap"] and b["bound"] == int(b["bound"])
    explicit = colgen_bound(inst)
    if explicit["converged"]:
        # the relaxation's value at any multipliers is at least the exact one, so never
        # below the exact master's optimum (rounded)
        assert out["bound"] >= explicit["bound"]
        assert banded["bound"] >= explicit["bound"]
    if out["converged"] and banded["converged"]:
        # the banded relaxation is dominated by the whole-range one at every multipliers
        assert banded["bound"] <= out["bound"]


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(inst=small_instances())
def test_refined_bands_only_lower_the_bound(inst: Instance) -> None:
    from unittest.mock import patch

    import models.window_bound as wb

    plain = window_colgen_bound(inst, time_limit=60.0, refine=False)
    fine = window_colgen_bound(inst, time_limit=60.0)  # tiny: the finest first band at once

    def from_band(*args: Any) -> tuple[float, float, float]:
        return args[2], 0.0, float("inf")  # BAND, no time taken, no bound of its own

    with patch.object(wb, "_first_band", from_band):
        refined = window_colgen_bound(inst, time_limit=60.0)  # from BAND, halved when converged
    assert plain["bands"] == [wb.BAND] or plain["cap"] == 0.0
    optimum = brute_force(inst, "cluster").profit
    for out in (fine, refined):
        assert optimum <= out["bound"] <= plain["bound"]
        # each converged band is halved, down to the finest; the last one is not refined
        bands = out["bands"]
        assert not bands or bands[0] <= wb.BAND
        assert all(b1 == b0 / 2 for b0, b1 in zip(bands, bands[1:], strict=False))
        assert all(b >= wb.MIN_BAND for b in bands)
        if out["converged"] and bands:
            assert bands[-1] / 2 < wb.MIN_BAND
    if refined["bands"] and refined["converged"]:
        assert refined["bands"][0] == wb.BAND and len(refined["bands"]) == 3


def test_window_lp_start_on_c1(c1: Instance) -> None:
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    figures = lp_start(search, None)
    root = window_colgen_bound(c1, band=None)  # the start's root is unbanded
    assert figures["lp_master"] == root["master"] and figures["lp_rounds"] == root["rounds"]
    planned = {g for g, targets, _, _, _ in root["plans"] if len(targets)}
    assert {g for g, path in enumerate(search.paths) if path.size} == planned
    rep = validate(c1, search.schedule())
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(search.profit) == pytest.approx(figures["lp_profit"])
    assert search.profit > 0.9 * root["master"]


@pytest.mark.limits
def test_window_root_foreseen_too_slow_makes_no_round(c1: Instance, monkeypatch) -> None:
    """With a deadline, an unbanded root whose ``expect_rounds`` rounds are foreseen past it
    prices nothing (before, its first round ran until the deadline); without a deadline,
    or banded, the foresight plays no part."""
    import models.window_bound as wb

    quick = window_colgen_bound(c1, time_limit=60.0, expect_rounds=20, band=None)
    assert quick["rounds"] > 0 and quick["plans"]
    monkeypatch.setattr(wb, "ROUND_S_PER_PAIR", 1.0)  # every round foreseen at hours
    t = time.perf_counter()
    out = window_colgen_bound(c1, time_limit=60.0, expect_rounds=20, band=None)
    limit_kept("rounds foreseen at hours", time.perf_counter() - t, 5.0)
    assert out["rounds"] == 0 and out["plans"] == [] and out["master"] is None
    assert out["bound"] == out["cap"]
    assert window_colgen_bound(c1, expect_rounds=20, band=None)["rounds"] == quick["rounds"]
    assert window_colgen_bound(c1, time_limit=60.0, expect_rounds=20, band=1.0)["rounds"] > 0
    # the search then keeps the start it had
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    figures = lp_start(search, time.perf_counter() + 60.0)
    assert figures["lp_rounds"] == 0 and figures["lp_profit"] == 0.0


def test_hpfs_start_sets_hpfs_schedule_on_c1(c1: Instance) -> None:
    """The window search's HPFS start holds HPFS-STC's schedule, orbit by orbit, and is what
    ``start="auto"`` does over windows (the LP root where the candidates are explicit)."""
    from heuristics.hpfs import solve_hpfs_stc

    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    figures = hpfs_start(search, None)
    hpfs = solve_hpfs_stc(c1, rng=np.random.default_rng(0))
    assert figures["hpfs_profit"] == search.profit == hpfs.profit > 0
    rep = validate(c1, search.schedule())
    assert rep.feasible, rep.violations
    assert rep.profit == pytest.approx(hpfs.profit) and not search.journal
    for g, plan in enumerate(search.paths):
        mine = [ob for ob in hpfs.schedule.observations if ob.orbit == g]
        assert plan.start.tolist() == sorted(ob.start for ob in mine)
    only = solve(c1, "orbit-dp", seed=0, iterations=3, candidates="windows", start="hpfs")
    assert only.stats["hpfs_profit"] == hpfs.profit and "lp_rounds" not in only.stats
    assert only.profit >= hpfs.profit  # the ascent replaces a plan only when it gains
    # auto: HPFS's plans, then the root's where it has time (here no limit)
    auto = solve(c1, "orbit-dp", seed=0, iterations=3, candidates="windows")
    assert auto.stats["hpfs_profit"] == hpfs.profit and auto.stats["lp_rounds"] >= 1
    assert validate(c1, auto.schedule).feasible
    explicit = solve(c1, "orbit-dp", seed=0, iterations=3)
    assert explicit.stats["lp_rounds"] >= 1 and "hpfs_s" not in explicit.stats


def test_root_after_hpfs_keeps_its_plans_only_when_they_gain(c1: Instance) -> None:
    """After HPFS-STC's schedule the root's plans stay only when together they do not lower
    the profit; else HPFS-STC's come back (the start never ends below HPFS-STC's)."""
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs = hpfs_start(search, None)["hpfs_profit"]
    figures = lp_start(search, None, keep=True)
    assert figures["lp_rounds"] >= 1 and search.profit >= hpfs
    assert figures["lp_kept"] is (search.profit > hpfs)
    assert not search.journal and validate(c1, search.schedule()).feasible
    plain = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    lp_start(plain, None)  # on C1 the root's plans gain over HPFS-STC's: they are kept
    assert search.profit == plain.profit > hpfs
    # a start above anything the root's plans give: they are undone, the start comes back
    high = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    high.set_schedule(solve(c1, "orbit-dp", seed=0, iterations=20).schedule)
    best, plans = high.profit, [plan.start.tolist() for plan in high.paths]
    assert best > plain.profit  # C1: 561 against the root's 552
    assert lp_start(high, None, keep=True)["lp_kept"] is False
    assert high.profit == best and [p.start.tolist() for p in high.paths] == plans
    assert not high.journal and high.dirty.all()


def test_lp_start_makes_no_replan_foreseen_past_the_runs_limit(c1: Instance) -> None:
    """The root may end in its share, but its plans' re-plans over windows take seconds on a
    dense orbit: one foreseen past the run's limit is not made, and the orbit keeps its plan."""
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs = hpfs_start(search, None)["hpfs_profit"]
    plans = [plan.start.tolist() for plan in search.paths]
    figures = lp_start(search, None, plan_budget=time.perf_counter())
    assert figures["lp_rounds"] >= 1 and search.profit == hpfs
    assert [plan.start.tolist() for plan in search.paths] == plans
    assert lp_start(search, None)["lp_profit"] != hpfs  # with time, the root's plans go in


@pytest.mark.parametrize("start", ["hpfs", "lp"])
def test_ascent_after_a_start_replans_every_orbit(c1: Instance, start: str) -> None:
    """Plans set from outside the search (HPFS-STC's schedule, the root's plans re-planned at
    their own targets' weights) are no optimum at the search's prices: every orbit stays
    dirty, and the ascent that follows ends where no single orbit's re-plan gains."""
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    if start == "hpfs":
        set_profit = hpfs_start(search, None)["hpfs_profit"]
    else:
        set_profit = lp_start(search, None)["lp_profit"]
    assert search.dirty.all()
    search.ascent()
    assert search.profit > set_profit  # C1: HPFS-STC's 490, the root's 552
    assert validate(c1, search.schedule()).feasible
    assert not any(search.replan(g) for g in range(len(search.paths)))


def test_ascend_from_both_keeps_the_higher_ascent(c1: Instance) -> None:
    """After HPFS-STC's schedule, a second ascent from nothing is made where it is foreseen to
    fit, and the search that ends higher is kept; where it does not fit only the first."""
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs_start(search, None)
    kept, figures = ascend_from_both(search, None)
    assert figures["empty_ascent"] is not None and figures["hpfs_ascent"] > 0
    assert kept.profit == max(figures["hpfs_ascent"], figures["empty_ascent"])
    assert validate(c1, kept.schedule()).feasible
    # the one from nothing is a plain ascent with the same generator's next draws
    alone = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs_start(alone, None)
    alone.ascent()
    assert alone.profit == figures["hpfs_ascent"]
    late = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs_start(late, None)
    kept, figures = ascend_from_both(late, time.perf_counter() + 1e-6)
    assert kept is late and figures["empty_ascent"] is None
    # where the root's plans went in, that coordinated start stays alone: no ascent here, no
    # figures; where they were undone (HPFS-STC's schedule back) both ascents are made
    root = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    hpfs_start(root, None)
    kept_root = {"hpfs_profit": 1.0, "lp_rounds": 3, "lp_kept": True}
    kept, figures = ascend_from_both(root, None, kept_root)
    assert kept is root and figures == {} and root.dirty.all() and root.replans == 0
    undone = {"hpfs_profit": 1.0, "lp_rounds": 3, "lp_kept": False}
    kept, figures = ascend_from_both(root, None, undone)
    assert figures["empty_ascent"] is not None and validate(c1, kept.schedule()).feasible
    # through solve: the figures are in the statistics, the same for the same seed
    a = solve(c1, "orbit-dp", seed=3, iterations=5, candidates="windows", start="hpfs")
    b = solve(c1, "orbit-dp", seed=3, iterations=5, candidates="windows", start="hpfs")
    assert a.stats["empty_ascent"] is not None and a.profit == b.profit
    assert a.stats["ascent_profit"] >= max(a.stats["hpfs_ascent"], a.stats["empty_ascent"])


def test_hpfs_start_foreseen_late_falls_back_to_lp(c1: Instance) -> None:
    search = WindowSearch(WindowData.build(c1), np.random.default_rng(0))
    figures = hpfs_start(search, time.perf_counter())  # no time at all
    assert figures["hpfs_profit"] is None and search.profit == 0.0
    assert all(plan.size == 0 for plan in search.paths)
    res = solve(c1, "orbit-dp", seed=0, time_limit=1e-3, candidates="windows", start="hpfs")
    assert res.stats["hpfs_profit"] is None and "lp_rounds" in res.stats
    assert validate(c1, res.schedule).feasible


def test_hpfs_start_needs_windows(caplog: pytest.LogCaptureFixture, b1) -> None:
    inst = b1
    with caplog.at_level("WARNING"):
        res = solve(inst, "orbit-dp", seed=0, iterations=2, candidates="explicit", start="hpfs")
    assert "start hpfs needs window candidates" in caplog.text
    assert res.stats["lp_rounds"] >= 1


@pytest.mark.limits
def test_window_colgen_bound_on_c1(c1: Instance) -> None:
    out = window_colgen_bound(c1)
    assert out["converged"] and out["rounds"] >= 2
    assert out["bound"] >= solve(c1, "orbit-dp", seed=0, iterations=20).profit
    assert out["model"] == "windows" and out["bound"] == int(out["bound"])
    # the bound is the least over the rounds: one round alone is never tighter
    assert out["bound"] <= window_colgen_bound(c1, max_rounds=1)["bound"]
    start = time.perf_counter()
    cut = window_colgen_bound(c1, time_limit=0.05)
    limit_kept("window bound, 0.05 s", time.perf_counter() - start, 1.0)
    assert cut["bound"] >= out["bound"]


def test_bound_method_windows_and_auto_fallback(
    c1: Instance, monkeypatch: pytest.MonkeyPatch
) -> None:
    import models.solve as ms
    import sosp.planner as planner
    from sosp.errors import InputError

    best = solve(c1, "orbit-dp", seed=0, iterations=20).profit
    out = ms.bound(c1, method="windows", iterations=20)
    assert out["bound"] >= best and out["source"] == "windows"

    def refuse(*args: object, **kwargs: object) -> None:
        raise InputError("too many candidates")

    # too dense for the MILP's items and for the planner's candidates: auto uses the windows
    monkeypatch.setattr(ms, "model_data", refuse)
    monkeypatch.setattr(planner, "orbit_data", refuse)
    out = ms.bound(c1, method="auto", iterations=20)
    assert out["method"] == "auto" and out["parts"] == {"windows": out["bound"]}
    assert out["bound"] >= best


def test_window_colgen_bound_in_processes_is_the_same(c1: Instance) -> None:
    # the rounds priced in two processes: the same columns, so the same bound and rounds
    one = window_colgen_bound(c1, workers=1)
    two = window_colgen_bound(c1, workers=2)
    for key in ("bound", "rounds", "columns", "master", "converged"):
        assert one[key] == two[key], key


def test_plan_pool_gives_up_at_its_timeout() -> None:
    from sosp.planner import PlanPool

    pool = PlanPool([_Slow(), _Slow()], workers=2, plans_of=_slow_plans)
    try:
        if pool.pool is None:
            pytest.skip("no fork here")
        assert pool.best_paths(np.zeros(1), np.zeros((2, 2)), time.perf_counter() + 0.05) is None
        assert pool.pool is None  # closed
    finally:
        pool.close()


class _Slow:
    size = 1


def _slow_plans(orbits: Any, idx: Any, price: Any, lam: Any, until: Any = None) -> list[Any]:
    time.sleep(5.0)
    return [(0.0, np.zeros(0, dtype=np.int64), None) for _ in idx]


@settings(max_examples=20, deadline=None)
@given(inst=small_instances())
def test_the_timed_first_round_is_a_bound(inst: Instance) -> None:
    """The round ``_first_band`` times (every orbit at mu = p, lam = 0) bounds the optimum."""
    import models.window_bound as wb

    orbits = [orbit_opps(inst, j) for j in range(inst.n_orbits)]
    _, p = wb._observable(inst)
    band, round_s, value = wb._first_band(orbits, p, wb.BAND, Budget.of(60.0), 1)
    assert wb.MIN_BAND <= band <= wb.BAND and round_s >= 0.0
    assert value + 1e-6 >= brute_force(inst, "cluster").profit


def test_the_timed_first_round_stops_at_the_deadline(c1) -> None:
    """The timed round reads the clock before each orbit: past the deadline it is no round,
    no bound from it and no time for another (5,000 targets on 24 satellites take 5 s a
    round, and the bound at 5 s ran to 6.2 s)."""
    import models.window_bound as wb

    inst = c1
    orbits = [orbit_opps(inst, j) for j in range(inst.n_orbits)]
    _, p = wb._observable(inst)
    band, round_s, value = wb._first_band(orbits, p, wb.BAND, Budget.of(-1.0), 1)
    assert band == wb.BAND and round_s == math.inf and value == math.inf


def test_a_round_ends_before_an_orbit_foreseen_past_until(
    monkeypatch: pytest.MonkeyPatch,
    c1,
) -> None:
    """One orbit's relaxed plan reads no clock (a 10 s bound ran to 12.7 s): an orbit
    foreseen past ``until`` at the most rate of those before it is not started, and the
    round is none. Without ``until``, every orbit is planned."""
    import models.window_bound as wb

    inst = c1
    orbits = [orbit_opps(inst, j) for j in range(inst.n_orbits)]
    g = max(range(len(orbits)), key=lambda j: len(orbits[j].start))
    _, p = wb._observable(inst)
    lam = np.zeros((len(orbits), 2))
    calls: list[int] = []
    real = wb.relaxed_best_path

    def slow(oo, *a, **k):  # 0.3 s an orbit
        calls.append(1)
        time.sleep(0.3)
        return real(oo, *a, **k)

    monkeypatch.setattr(wb, "relaxed_best_path", slow)
    monkeypatch.setattr(wb, "RELAXED_RATE_FROM_PAIRS", 0.0)
    t = time.perf_counter()
    assert wb._relaxed_plans(orbits, [g, g], p, lam, until=t + 0.45) is None
    assert len(calls) == 1 and time.perf_counter() < t + 0.45  # the second foreseen late
    assert wb._relaxed_plans(orbits, [g, g], p, lam) is not None and len(calls) == 3
    assert wb._pairs(orbits[g]) > 0


@pytest.mark.limits
def test_no_round_is_started_that_cannot_end_in_time(monkeypatch: pytest.MonkeyPatch, c1) -> None:
    """When the timed round shows that no round fits in the time left, the bound returns at
    once: the timed round's value or the cap, the least (G100k spent its whole limit on a
    round that could not end)."""
    import models.window_bound as wb

    inst = c1

    def never(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("a round was started")

    for first, source in ((1e9, "cap"), (123.4, "round")):
        monkeypatch.setattr(wb, "_first_band", lambda *a, v=first: (a[2], 1e6, v))
        monkeypatch.setattr("models.colgen.column_generation", never)
        t = time.perf_counter()
        out = window_colgen_bound(inst, time_limit=30.0)
        limit_kept(f"no round fits, {source}", time.perf_counter() - t, 10.0)
        assert out["rounds"] == 0 and out["bands"] == []
        assert out["bound"] == (out["cap"] if source == "cap" else 123)


def test_compile_kernels_compiles_the_window_sweep_for_every_call() -> None:
    """The sweep's kernels compiled inside a first window bound's time limit (D30 at 0.05 s
    ran 7 s): :func:`sosp.planner.compile_kernels`, called before the clocks, compiles them
    with the argument types of every call, so the window bound, the window search and
    ASA-DTC's window planner compile nothing more. In a fresh process (this one may have
    compiled them in other tests)."""
    import subprocess
    import sys

    code = """
import sosp.windows as w
from sosp.planner import compile_kernels
from models.solve import bound
from sosp.solve import solve
from tests.models.instances import random_tiny

def count():
    return len(w._sweep.signatures), len(w._members.signatures)

compile_kernels()
ready = count()
for seed in range(3):
    inst = random_tiny(seed)
    bound(inst, method="windows", time_limit=5)
    solve(inst, "asa-dtc", seed=0, iterations=200, candidates="windows")
    solve(inst, "orbit-dp", seed=0, iterations=20, candidates="windows")
print(*ready, *count())
"""
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True
    )
    counts = [int(n) for n in out.stdout.split()[-4:]]
    assert min(counts[:2]) >= 1  # both compiled before any call
    assert counts[2:] == counts[:2]


@pytest.mark.parametrize("seed", range(6))
def test_member_scan_counts_what_the_listing_reads(seed: int) -> None:
    """The listing's foresight measure: at least its members, and exactly the opportunities
    read from each row's first i (no ties of starts before i here)."""
    from sosp.windows import _observations, member_scan, window_candidates

    oo, price = _random_orbit(seed, n=40)
    oo = dataclasses.replace(oo, start=oo.start + 1e-3 * np.arange(40))  # no tied starts
    wi = window_items(oo, price)
    keep, *_ = _observations(oo, wi, "nadir")
    first, last = wi.first[keep], wi.last[keep]
    reads = sum(
        int(np.sum((np.arange(40) >= i) & (oo.start <= oo.end[k])))
        for i, k in zip(first, last, strict=True)
    )
    scan = member_scan(oo, first, last)
    assert scan == reads
    seen: list[int] = []
    *_, groups = window_candidates(oo, price, ahead=seen.append)
    assert seen == [scan] and len(groups.flat) <= scan
    assert member_scan(oo, first[:0], last[:0]) == 0


def test_ahead_can_stop_the_listing() -> None:
    """``ahead`` raising stops window_candidates before the members are listed."""
    from sosp.windows import window_candidates

    oo, price = _random_orbit(0, n=40)

    class Stop(Exception):
        pass

    def stop(scan: int) -> None:
        raise Stop(scan)

    with pytest.raises(Stop):
        window_candidates(oo, price, ahead=stop)


@pytest.mark.parametrize("seed", range(6))
def test_window_candidates_list_their_members_in_int32_made_global_in_place(seed: int) -> None:
    """Each candidate's members are the priced opportunities starting from its first's start,
    ending by its last's end and holding its roll, as global int32 indices; the listing is
    int32 from the start (on a fresh process an int64 list and its global copy took 4.9 s
    for 70 million members, past a 5 s limit, where int32 made in place takes 1.7 s)."""
    from sosp.windows import _member_lists, _observations, window_candidates

    oo, price = _random_orbit(seed, n=40)
    oo = dataclasses.replace(oo, first=1000)
    wi = window_items(oo, price)
    keep, *_ = _observations(oo, wi, "nadir")
    _, flat = _member_lists(oo, price, wi.first[keep], wi.last[keep], wi.point[keep])
    assert flat.dtype == np.int32
    _, _, roll, groups = window_candidates(oo, price)
    assert groups.flat.dtype == np.int32 and len(groups) == len(keep)
    for u, row in enumerate(keep):
        i, k, r = wi.first[row], wi.last[row], wi.point[row]
        hold = (
            (oo.start >= oo.start[i])
            & (oo.end <= oo.end[k])
            & (price > 0)
            & (oo.roll_min - EPS <= r)
            & (r <= oo.roll_max + EPS)
        )
        assert list(groups[u]) == (1000 + np.flatnonzero(hold)).tolist(), u
