"""Re-planning (issue 61): events, the repair, the restricted solve and ``sosp replan``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sosp import replan, solve, validate
from sosp.cli import main
from sosp.events import Cloud, Events, NewTarget, Outage, parse_events, parse_time
from sosp.replanning import expected_profit
from sosp.scenarios import generate_scenario

NOW, FREEZE = 12 * 3600.0, 600.0


@pytest.fixture(scope="module")
def case():
    inst = generate_scenario("C2")
    old = solve(inst, "greedy").schedule
    return inst, old


def _records(inst, sched, before=None):
    """Observations as comparable records (ids, not indices), those starting before
    ``before`` only when given."""
    return sorted(
        (inst.orbit_ids[o.orbit], o.start, o.end, o.roll, tuple(inst.opp_ids[i] for i in o.opps))
        for o in sched.observations
        if before is None or o.start < before
    )


def _urgent(inst, old, weight=1000):
    """A new target at the place of a target observed after the freeze (so seen then)."""
    late = [o for o in old.observations if o.start > NOW + FREEZE + 3600]
    k = int(inst.opp_target[late[0].opps[0]])
    return NewTarget("URGENT", float(inst.target_lat[k]), float(inst.target_lon[k]), weight)


def _all_kinds(inst, old):
    sat = inst.satellite_names[0]
    return Events(
        new_targets=(_urgent(inst, old),),
        cancelled=(inst.target_ids[3],),
        weights={inst.target_ids[4]: 10},
        outages=(Outage(sat, NOW + 1800, NOW + 5 * 3600),),
        clouds=(Cloud(NOW, 86400.0, 0.5, area=(30.0, 45.0, 90.0, 120.0)),),
    )


def test_no_events_returns_the_old_plan(case):
    inst, old = case
    r = replan(inst, old, Events(), now=NOW, freeze=FREEZE)
    assert r.schedule is old and r.instance is inst and r.changes == ()


def test_frozen_part_identical_and_every_replan_valid(case):
    inst, old = case
    events = _all_kinds(inst, old)
    for method in ("repair", "greedy"):
        r = replan(inst, old, events, now=NOW, freeze=FREEZE, method=method, time_limit=5)
        assert validate(r.instance, r.schedule).feasible
        # the outage starts after the freeze: everything frozen stays, exactly
        assert _records(r.instance, r.schedule, NOW + FREEZE) == _records(inst, old, NOW + FREEZE)
        assert r.frozen == len(_records(inst, old, NOW + FREEZE)) > 0
        assert r.bound >= r.profit


def test_urgent_target_inserted(case):
    inst, old = case
    r = replan(inst, old, Events(new_targets=(_urgent(inst, old),)), now=NOW, freeze=FREEZE)
    observed = {
        r.instance.target_ids[int(r.instance.opp_target[i])] for i in r.schedule.observed_opps()
    }
    assert "URGENT" in observed
    assert r.profit >= old.coverage_profit(inst)[0] + 1000 - 10  # at most a weight given up
    assert any(c.new is not None for c in r.changes)


def test_outage_removes_the_satellites_observations_in_its_window(case):
    inst, old = case
    sat = inst.orbit_satellite[old.observations[-1].orbit]
    a, b = NOW + 600, 86400.0
    hit = [o for o in old.observations if inst.orbit_satellite[o.orbit] == sat and o.end > a]
    assert hit  # the test means something
    r = replan(inst, old, Events(outages=(Outage(sat, a, b),)), now=NOW, freeze=FREEZE)
    new = r.instance
    left = [o for o in r.schedule.observations if new.orbit_satellite[o.orbit] == sat]
    assert all(o.end <= a or o.start >= b for o in left if o.start >= NOW)
    assert r.stats["outage_removed"] >= len([o for o in hit if o.start >= NOW])
    assert validate(new, r.schedule).feasible


def test_cloud_expected_profit(case):
    inst, old = case
    k = int(inst.opp_target[[o for o in old.observations if o.start > NOW + FREEZE][0].opps[0]])
    dark = inst.target_ids[k]
    events = Events(
        clouds=(
            Cloud(NOW, 86400.0, 0.5, area=(30.0, 60.0, 90.0, 105.0)),
            Cloud(NOW, 86400.0, 1.0, targets=(dark,)),
        )
    )
    r = replan(inst, old, events, now=NOW, freeze=FREEZE)
    new = r.instance
    # the expected profit, computed here from the definition: weight x P(clear)
    lon = new.target_lon
    total = 0.0
    for o in r.schedule.observations:
        for i in o.opps:
            k2 = int(new.opp_target[i])
            p = 1.0
            if new.opp_end[i] > NOW and 30 <= new.target_lat[k2] <= 60 and 90 <= lon[k2] <= 105:
                p *= 0.5
            if new.target_ids[k2] == dark and new.opp_end[i] > NOW:
                p = 0.0
            total += int(new.target_weight[k2]) * p
    assert r.profit == pytest.approx(total)
    # a target surely under cloud is not observed after the freeze
    late = [o for o in r.schedule.observations if o.start >= NOW + FREEZE]
    assert dark not in {new.target_ids[int(new.opp_target[i])] for o in late for i in o.opps}
    assert r.profit >= expected_profit(new, _remap(old, inst, new), _clear(r, events)) - 1e-6


def _remap(old, inst, new):
    from dataclasses import replace

    return replace(
        old,
        observations=tuple(
            replace(o, opps=tuple(new.opp_index[inst.opp_ids[i]] for i in o.opps))
            for o in old.observations
            if o.start < NOW + FREEZE
        ),
    )


def _clear(r, events):
    from sosp.replanning import apply_events

    return apply_events(r.instance, events).clear


def test_deterministic_with_a_seed(case):
    inst, old = case
    events = _all_kinds(inst, old)
    runs = [
        replan(inst, old, events, now=NOW, freeze=FREEZE, method="greedy", seed=3) for _ in (0, 1)
    ]
    runs += [replan(inst, old, events, now=NOW, freeze=FREEZE, seed=3) for _ in (0, 1)]
    for a, b in (runs[:2], runs[2:]):
        assert a.schedule.to_dict(a.instance) == b.schedule.to_dict(b.instance)


@pytest.fixture(scope="module")
def files(case, tmp_path_factory):
    inst, old = case
    d = tmp_path_factory.mktemp("replan")
    inst.save(d / "inst.json")
    old.save(d / "old.json", inst)
    return d


def _write(d, events):
    path = d / "events.json"
    path.write_text(json.dumps({"format": "sosp-events", "version": 1, "events": events}))
    return path


def test_cli_replan_writes_the_plan_and_its_instance(case, files, capsys):
    inst, old = case
    u = _urgent(inst, old)
    ev = _write(files, [{"type": "new_target", "id": "U1", "lat": u.lat, "lon": u.lon,
                         "weight": 50, "deadline": "2026-06-02T00:00:00Z"}])  # fmt: skip
    out = files / "new.json"
    argv = ["replan", str(files / "inst.json"), str(files / "old.json"), "--events", str(ev)]
    assert main([*argv, "--now", "2026-06-01T12:00:00Z", "--freeze", "600", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "changes:" in text and (files / "new.instance.json").exists()
    assert main(["validate", str(files / "new.instance.json"), str(out)]) == 0


@pytest.mark.parametrize(
    ("event", "message"),
    [
        ({"type": "cancel", "target": "NOPE"}, "events[0].target: unknown target"),
        ({"type": "outage", "satellite": "X", "from": 0, "to": 10}, "events[0].satellite"),
        ({"type": "outage", "satellite": "JB-3A", "from": 0, "to": 1e6}, "events[0].to"),
        ({"type": "cloud", "targets": ["T0001"], "from": 0, "to": 10, "probability": 1.5},
         "events[0].probability"),
        ({"type": "weight", "target": "T0001", "weight": -1}, "events[0].weight"),
    ],
)  # fmt: skip
def test_bad_events_exit_2_one_line_nothing_written(files, capsys, event, message):
    ev = _write(files, [event])
    out = files / "bad.json"
    argv = ["replan", str(files / "inst.json"), str(files / "old.json"), "--events", str(ev)]
    assert main([*argv, "--now", "43200", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not out.exists() and not (files / "bad.instance.json").exists()


def test_events_parse_times_and_areas(case):
    inst, _ = case
    ev = parse_events(
        [{"type": "cloud", "area": [30, 40, 90, 100], "from": "2026-06-01T06:00:00Z",
          "to": 36000, "probability": 0.2}], inst,
    )  # fmt: skip
    (c,) = ev.clouds
    assert (c.start, c.end, c.probability) == (21600.0, 36000.0, 0.2)
    assert parse_time("43200", inst, "--now") == parse_time("2026-06-01T12:00:00Z", inst, "x")
    assert not np.isnan(c.area).any()


def test_simulate_a_day(case):
    from sosp.simulate import simulate

    inst, old = case
    a = simulate(inst, old, rate=0.05, seed=2)
    assert a["replans"] == a["urgent"] + 2  # the forecast, each arrival, the outage
    assert 0 < a["realised_profit"] and 0 < a["hindsight_profit"]
    assert a == simulate(inst, old, rate=0.05, seed=2) | {
        k: a[k] for k in ("replan_s_mean", "replan_s_max")
    }


def test_with_stations_frozen_downlinks_kept(case):
    from sosp.stations import builtin_stations

    inst, _ = case
    inst = inst.with_stations([s for s in builtin_stations() if s.id in ("SG", "MIY", "KSH")])
    old = solve(inst, "greedy").schedule
    assert old.downlinks
    r = replan(inst, old, Events(new_targets=(_urgent(inst, old, 50),)), now=NOW, freeze=FREEZE)
    assert validate(r.instance, r.schedule).feasible
    before = NOW + FREEZE
    assert _records(r.instance, r.schedule, before) == _records(inst, old, before)

    def frozen_downlinks(i, sched):
        return [
            (d.satellite, d.station, d.start, d.end, [(i.opp_ids[o], v) for o, v in d.parts])
            for d in sched.downlinks
            if d.start < before
        ]

    assert frozen_downlinks(r.instance, r.schedule) == frozen_downlinks(inst, old)
    assert r.stats["frozen_kept"]


@pytest.fixture
def day_files(case, tmp_path):
    inst, old = case
    inst.save(tmp_path / "inst.json")
    old.save(tmp_path / "old.json", inst)
    return [str(tmp_path / "inst.json"), str(tmp_path / "old.json")]


def _simulations(db):
    from sosp.campaign import Store

    with Store(db, readonly=True) as st:
        return st.simulations()


def test_simulate_stores_each_day_once_and_the_report_shows_it(day_files, tmp_path, capsys):
    db, rep = tmp_path / "r.db", tmp_path / "rep"
    argv = ["simulate", *day_files, "--rate", "0.05", "--seed", "2", "--db", str(db)]
    assert main(argv) == 0
    assert f"stored in {db}" in capsys.readouterr().out
    (row,) = _simulations(db)
    key = (row["scenario"], row["method"], row["seed"], row["rate"], row["time_limit"])
    assert key == (day_files[0], "repair", 2, 0.05, 0.0)
    assert row["fingerprint"] == generate_scenario("C2").fingerprint
    assert row["replans"] == row["urgent"] + 2 and row["hindsight_profit"] > 0
    assert main(argv) == 0  # the same day again: not run, not stored twice
    assert "stored already" in capsys.readouterr().out
    assert _simulations(db) == [row]
    assert main([*argv[:-3], "3", "--db", str(db)]) == 0  # another seed: another row
    assert len(_simulations(db)) == 2
    capsys.readouterr()
    assert main(["report", str(db), "-o", str(rep)]) == 0
    text = capsys.readouterr().out
    assert "simulated days" in text and f"| {day_files[0]} | repair |" in text
    assert "| 2 |" in (rep / "simulations.md").read_text()  # two days in one row
    assert "## Simulated days" in (rep / "report.md").read_text()
    assert "table3" not in text  # no bench runs: no notes about their tables
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inst.json", "old.json", "r.db", "rep"]


def test_simulate_upgrades_an_old_database_and_refuses_bad_input(day_files, tmp_path, capsys):
    import sqlite3

    from sosp.campaign import SCHEMA_VERSION, Store

    db = tmp_path / "old.db"
    Store(db).close()
    con = sqlite3.connect(db)  # a database of schema 2: no simulations table
    con.execute("DROP TABLE simulations")
    con.execute("UPDATE meta SET value='2' WHERE key='schema_version'")
    con.commit()
    con.close()
    assert _simulations(db) == []  # read as it is
    argv = ["simulate", *day_files, "--rate", "0.05", "--seed", "2"]
    assert main([*argv, "--db", str(db)]) == 0
    assert len(_simulations(db)) == 1
    con = sqlite3.connect(db)
    assert con.execute("SELECT value FROM meta WHERE key='schema_version'").fetchone() == (
        str(SCHEMA_VERSION),
    )
    con.close()
    capsys.readouterr()
    for bad, message in (
        (["--db", str(tmp_path / "no" / "r.db")], "--db: folder does not exist"),
        (["--db", str(tmp_path / "new.db"), "--method", "nosuch"], "unknown method"),
    ):
        assert main([*argv, *bad]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inst.json", "old.db", "old.json"]
