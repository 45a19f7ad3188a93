"""``sosp view``: the HTML page loads offline in a real browser with what the schedule holds.

The browser test drives Debian's Chromium with Playwright (no browser download); it is skipped
with the reason when either is missing (``.ci/run`` installs both).
"""

from __future__ import annotations

import json
import re
import shutil
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest

from sosp.cli import main
from sosp.instance import Instance
from sosp.orbits import utc_at
from sosp.schedule import Schedule, make_observation
from sosp.solve import solve
from sosp.validate import validate
from tests.conftest import scenario, tiny_cluster

pytest.importorskip("plotly", reason="sosp view needs Plotly: pip install -e '.[view]'")

from sosp.view import WEBGL_TARGETS, ground_points, view_page, write_view  # noqa: E402


@pytest.fixture(scope="module")
def c1() -> tuple[Instance, Schedule]:
    """C1 (100 targets, 4 built-in satellites) and its greedy schedule, checked feasible."""
    inst = scenario("C1")
    sched = solve(inst, "greedy").schedule
    assert validate(inst, sched).feasible and len(sched) > 10
    return inst, sched


def test_strips_meet_their_targets(c1: tuple[Instance, Schedule]) -> None:
    """At the middle of an observation, the ground point seen at its roll is its target (a
    wrong roll sign or frame would put it tens of km off, on the other side of the track)."""
    from sosp.orbits import instance_satellites

    inst, sched = c1
    sats = {s.name: s for s in instance_satellites(inst)}
    max_roll = float(np.max(np.abs(inst.opp_roll)))
    miss = []
    for ob in sched.observations:
        k = int(inst.opp_target[ob.opps[0]])
        if len(ob.opps) > 1 or abs(ob.roll) >= max_roll - 1e-9:
            continue  # a cluster or a clamped roll looks beside its target, by design
        sat = sats[inst.orbit_satellite[ob.orbit]]
        mid = np.array([(ob.start + ob.end) / 2])
        lat, lon = ground_points([sat], inst.epoch, mid, np.array([ob.roll]))
        dlat = np.radians(lat[0, 0] - inst.target_lat[k])
        dlon = np.radians((lon[0, 0] - inst.target_lon[k] + 180) % 360 - 180)
        miss.append(6371.0 * np.hypot(dlat, dlon * np.cos(np.radians(inst.target_lat[k]))))
    assert len(miss) > 5 and max(miss) < 1.0  # km


def test_page_is_self_contained(c1: tuple[Instance, Schedule]) -> None:
    inst, sched = c1
    page, info = view_page(inst, sched)
    assert info["observations"] == len(sched) and info["feasible"]
    assert not re.search(r"<(script|link|img)[^>]+(src|href)=", page)  # nothing fetched
    body = page[page.index('<table id="obs">') :]
    assert body.count("<tr>") == len(sched) + 1  # header + one row per observation
    assert "Plotly.newPlot" in page and page.count("<script>") == page.count("</script>") == 2


def test_ids_cannot_break_the_page() -> None:
    """Ids are data: escaped in the table and hover texts, and no ``</script>`` in the data."""
    bad = '</script><img src=x onerror="alert(1)">&'
    inst = Instance.build({bad: 3, "b": 2}, [(bad, 0, 0.0, 4.0, 1.0), ("b", 0, 50.0, 54.0, 0.0)])
    page, _ = view_page(inst, Schedule((make_observation(inst, [0]),)), title=bad)
    assert bad not in page and page.count("<script>") == page.count("</script>") == 2
    assert "&lt;/script&gt;&lt;img src=x onerror=&quot;alert(1)&quot;&gt;&amp;" in page


def test_view_without_orbits_and_clusters(tmp_path: Path) -> None:
    """A hand-made instance (no satellites known): no ground tracks, a cluster-task bar."""
    inst = tiny_cluster()
    sched = Schedule((make_observation(inst, [0, 1]), make_observation(inst, [2])))
    info = write_view(inst, sched, tmp_path / "p.html")
    assert (info["observations"], info["clusters"], info["observed"]) == (2, 1, 3)
    assert info["profit"] == 11 and info["bytes"] == (tmp_path / "p.html").stat().st_size
    assert [p.name for p in tmp_path.iterdir()] == ["p.html"]


def _browser():
    """Playwright's Chromium driving the system's browser, or skip saying what is missing."""
    sync_api = pytest.importorskip(
        "playwright.sync_api",
        reason="the browser test needs Playwright: pip install playwright",
        exc_type=ImportError,
    )
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("the browser test needs Chromium: apt-get install chromium")
    return sync_api, exe


def test_page_in_headless_chromium(tmp_path: Path, c1: tuple[Instance, Schedule]) -> None:
    sync_api, exe = _browser()
    inst, sched = c1
    sats, sat = list(inst.satellite_names), inst.orbit_satellite[sched.observations[0].orbit]
    assert inst.n_targets < WEBGL_TARGETS  # SVG markers: each is an element to count
    page_path = tmp_path / "plan.html"
    write_view(inst, sched, page_path)
    errors: list[str] = []
    fetched: list[str] = []
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: fetched.append(r.url))
            page.goto(page_path.as_uri())
            page.wait_for_selector("body[data-ready='1']", timeout=60_000)
            count = page.evaluate(
                """() => ({
                  bars: document.querySelectorAll('#gantt .barlayer .point').length,
                  markers: document.querySelectorAll('#map .scatterlayer path.point').length,
                  rows: document.querySelectorAll('#obs tbody tr').length,
                  resources: document.querySelectorAll('#resources .barlayer .point').length,
                })"""
            )
            used = sum(1 for u in validate(inst, sched).orbits if u.openings)
            assert count == {
                "bars": len(sched),
                "markers": inst.n_targets,
                "rows": len(sched),
                "resources": 3 * used,  # energy, memory, openings per used orbit
            }
            page.screenshot(path=str(tmp_path / "plan.png"), full_page=True)
            # zoom the Gantt chart on the first observation, hover its bar: its orbit,
            # target, weight, roll and UTC window
            ob = sched.observations[0]
            t0 = 1000 * (datetime.fromisoformat(inst.epoch.replace("Z", "+00:00")).timestamp())
            at = page.evaluate(
                """([t0, t1, row]) => {
                  const gd = document.getElementById('gantt');
                  return Plotly.relayout(gd, {'xaxis.range': [t0, t1]}).then(() => {
                    const xa = gd._fullLayout.xaxis, ya = gd._fullLayout.yaxis;
                    const box = gd.querySelector('.nsewdrag').getBoundingClientRect();
                    return [box.left + xa.l2p((t0 + t1) / 2), box.top + ya.l2p(row)];
                  });
                }""",
                [t0 + 1000 * (ob.start - 60), t0 + 1000 * (ob.end + 60), sats.index(sat)],
            )
            page.mouse.move(*at)
            page.wait_for_selector("#gantt .hoverlayer .hovertext", timeout=10_000)
            label = page.text_content("#gantt .hoverlayer .hovertext")
            target = inst.target_ids[int(inst.opp_target[ob.opps[0]])]
            for part in ("(observation 1)", inst.orbit_ids[ob.orbit], target, f"{ob.roll:.2f}"):
                assert part in label, (part, label)
            assert utc_at(inst.epoch, ob.start) in label and utc_at(inst.epoch, ob.end) in label
            # search: a target's id leaves the rows that observe it
            page.fill("#search", target)
            shown = page.locator("#obs tbody tr:visible")
            assert shown.count() >= 1
            assert all(target in t for t in shown.all_inner_texts())
            assert page.text_content("#shown") == str(shown.count())
            page.fill("#search", "")
            # sort: a click on "roll (deg)" orders the rows by roll, numerically
            page.click("#obs th:has-text('roll')")
            rolls = [float(v) for v in page.locator("#obs tbody td:nth-child(7)").all_inner_texts()]
            assert rolls == sorted(rolls) and len(rolls) == len(sched)
        finally:
            browser.close()
    assert not errors, errors
    assert all(u.startswith("file:") for u in fetched), fetched  # works offline
    assert (tmp_path / "plan.png").stat().st_size > 50_000


def test_view_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inst_p, sched_p, out = tmp_path / "c1.json", tmp_path / "s.json", tmp_path / "p.html"
    assert main(["scenario", "C1", "-o", str(inst_p)]) == 0
    assert main(["solve", str(inst_p), "--method", "greedy", "-o", str(sched_p)]) == 0
    capsys.readouterr()
    assert main(["view", str(inst_p), str(sched_p), "-o", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    data = json.loads(sched_p.read_text())
    assert info["observations"] == len(data["observations"]) and info["feasible"]
    assert info["profit"] == data["profit"] and out.stat().st_size == info["bytes"]


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str], tmp_path: Path) -> str:
    before = sorted(tmp_path.iterdir())
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1, err
    assert sorted(tmp_path.iterdir()) == before  # nothing written
    return err


def test_view_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inst_p, other_p, sched_p = tmp_path / "i.json", tmp_path / "o.json", tmp_path / "s.json"
    inst = tiny_cluster()
    inst.save(inst_p)
    Schedule((make_observation(inst, [2]),)).save(sched_p, inst)
    other = Instance.build({"z": 1}, [("z", 0, 0.0, 4.0, 0.0)], name="other")
    other.save(other_p)
    out = str(tmp_path / "p.html")
    assert "nope.json" in _refused(
        ["view", str(inst_p), str(tmp_path / "nope.json"), "-o", out], capsys, tmp_path
    )
    assert "nope.json" in _refused(
        ["view", str(tmp_path / "nope.json"), str(sched_p), "-o", out], capsys, tmp_path
    )
    assert "another instance" in _refused(
        ["view", str(other_p), str(sched_p), "-o", out], capsys, tmp_path
    )
    _refused(
        ["view", str(inst_p), str(sched_p), "-o", str(tmp_path / "no/p.html")], capsys, tmp_path
    )


def test_view_without_plotly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    inst_p, sched_p = tmp_path / "i.json", tmp_path / "s.json"
    inst = tiny_cluster()
    inst.save(inst_p)
    Schedule((make_observation(inst, [2]),)).save(sched_p, inst)
    monkeypatch.setitem(sys.modules, "plotly", None)  # import plotly raises ImportError
    err = _refused(
        ["view", str(inst_p), str(sched_p), "-o", str(tmp_path / "p.html")], capsys, tmp_path
    )
    assert "Plotly" in err and "pip install" in err


@pytest.mark.slow
def test_10000_target_page_in_headless_chromium(tmp_path: Path) -> None:
    """Issue 63's acceptance: a 10,000-target plan opens; its map is WebGL, so the markers are
    checked as drawn data (one per target) and as pixels of the two target colours."""
    import io

    import matplotlib.image as mpimg

    from sosp.scenarios import custom_scenario
    from sosp.view import OBSERVED, UNOBSERVED

    sync_api, exe = _browser()
    inst = custom_scenario(region=(25.0, 55.0, -10.0, 40.0), count=10_000, name="r10k")
    sched = solve(inst, "greedy").schedule
    assert validate(inst, sched).feasible and len(sched) > 50
    page_path = tmp_path / "plan.html"
    write_view(inst, sched, page_path)
    errors: list[str] = []
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(page_path.as_uri())
            page.wait_for_selector("body[data-ready='1']", timeout=120_000)
            drawn = page.evaluate(
                """() => Object.fromEntries(document.getElementById('map')._fullData
                    .filter(d => d.mode === 'markers')
                    .map(d => [d.type + ' ' + d.name, d._length]))"""
            )
            n_obs = validate(inst, sched).observed
            assert drawn == {
                f"scattergl observed ({n_obs})": n_obs,
                f"scattergl unobserved ({inst.n_targets - n_obs})": inst.n_targets - n_obs,
            }
            assert page.locator("#gantt .barlayer .point").count() == len(sched)
            assert page.locator("#obs tbody tr").count() == len(sched)
            shot = page.locator("#map").screenshot(path=str(tmp_path / "map.png"))
        finally:
            browser.close()
    assert not errors, errors
    rgb = mpimg.imread(io.BytesIO(shot), format="png")[..., :3]
    for colour, least in ((UNOBSERVED, 10_000), (OBSERVED, 500)):
        want = np.array([int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)])
        assert np.sum(np.abs(rgb - want).max(axis=-1) < 0.05) > least, colour
