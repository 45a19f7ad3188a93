"""``sosp plot``: a PNG with a Gantt chart and a map; counts reported match the schedule."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sosp.cli import main
from sosp.plot import (
    MAP_MARGIN,
    ground_tracks,
    map_extent,
    map_lon,
    plot_schedule,
    schedule_figure,
)
from sosp.schedule import Schedule, make_observation
from tests.conftest import scenario, tiny_cluster


def test_plot_tiny_cluster_counts_and_png(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    inst = tiny_cluster()
    sched = Schedule((make_observation(inst, [0, 1]), make_observation(inst, [2])))
    out = tmp_path / "s.png"
    info = plot_schedule(inst, sched, out)
    assert info == {
        "orbits": 1,
        "orbits_total": 1,
        "observations": 2,
        "clusters": 1,
        "observed": 3,
        "tracks": False,
    }
    img = mpimg.imread(out)
    assert img.shape[1] > 500 and img.std() > 0.01
    assert ground_tracks(inst) is None  # hand-made: no satellites known
    assert not list(tmp_path.glob(".*"))


def test_plot_cli_with_ground_tracks(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inst_p, sched_p, png = tmp_path / "c1.json", tmp_path / "s.json", tmp_path / "p.png"
    assert main(["scenario", "C1", "-o", str(inst_p)]) == 0
    assert main(["solve", str(inst_p), "--method", "greedy", "-o", str(sched_p)]) == 0
    capsys.readouterr()
    assert main(["plot", str(inst_p), str(sched_p), "-o", str(png), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    data = json.loads(sched_p.read_text())
    assert info["observations"] == len(data["observations"]) and info["tracks"] is True
    assert info["observed"] == sum(len(o["opportunities"]) for o in data["observations"])
    assert png.stat().st_size > 10_000


def test_plot_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inst_p = tmp_path / "i.json"
    tiny_cluster().save(inst_p)
    assert main(["plot", str(inst_p), str(tmp_path / "nope.json"), "-o", "x.png"]) == 2
    assert "not found" in capsys.readouterr().err
    sched_p = tmp_path / "s.json"
    sched_p.write_text('{"observations": [{"orbit": "zz"}]}')
    assert main(["plot", str(inst_p), str(sched_p), "-o", str(tmp_path / "x.png")]) == 2
    assert not (tmp_path / "x.png").exists()


# ------------------------------------------------------------------- figures people read
def _c1_figure(utc: bool = False):
    from sosp.solve import solve

    inst = scenario("C1")
    sched = solve(inst, "greedy").schedule
    fig, info = schedule_figure(inst, sched, utc=utc)
    return inst, sched, fig, info


def _extent(fig, artist):
    return artist.get_window_extent(fig.canvas.get_renderer())


def test_legends_sit_outside_the_data() -> None:
    import matplotlib.pyplot as plt

    _, _, fig, _ = _c1_figure()
    try:
        fig.canvas.draw()
        ax_g, ax_m = fig.axes[:2]
        for ax in (ax_g, ax_m):
            legend, box = _extent(fig, ax.get_legend()), _extent(fig, ax)
            # no overlap with the axes' data area
            assert (
                legend.y0 >= box.y1 - 1
                or legend.x0 >= box.x1 - 1
                or legend.y1 <= box.y0 + 1
                or legend.x1 <= box.x0 + 1
            ), (ax.get_title(), legend, box)
            # and inside the figure
            assert legend.x1 <= fig.bbox.x1 + 1 and legend.y1 <= fig.bbox.y1 + 1
    finally:
        plt.close(fig)


def test_unobserved_targets_are_drawn_on_top_and_distinct() -> None:
    import matplotlib.pyplot as plt
    import numpy as np

    inst, sched, fig, info = _c1_figure()
    try:
        ax_m = fig.axes[1]
        by_label = {c.get_label(): c for c in ax_m.collections}
        obs, unobs = by_label["observed"], by_label["unobserved"]
        assert len(obs.get_offsets()) == info["observed"]
        assert len(unobs.get_offsets()) == inst.n_targets - info["observed"]
        assert unobs.get_zorder() > obs.get_zorder()
        assert unobs.get_zorder() > max(ln.get_zorder() for ln in ax_m.lines)  # over tracks
        assert not np.allclose(unobs.get_facecolor()[0], obs.get_facecolor()[0])
    finally:
        plt.close(fig)


def test_the_map_is_zoomed_to_the_targets() -> None:
    import matplotlib.pyplot as plt

    inst, _, fig, _ = _c1_figure()
    try:
        x0, x1 = fig.axes[1].get_xlim()
        y0, y1 = fig.axes[1].get_ylim()
        lon, lat = inst.target_lon, inst.target_lat
        assert x0 <= lon.min() and lon.max() <= x1 and y0 <= lat.min() and lat.max() <= y1
        # no more than the margin around them (C1 covers a few degrees, not the globe)
        assert x1 - x0 <= (lon.max() - lon.min()) * (1 + 2 * MAP_MARGIN) + 2.01
        assert y1 - y0 <= (lat.max() - lat.min()) * (1 + 2 * MAP_MARGIN) + 2.01
    finally:
        plt.close(fig)


def test_map_extent_across_the_antimeridian() -> None:
    import numpy as np

    lat = np.array([10.0, 12.0, 14.0])
    x0, x1, y0, y1, wrap = map_extent(lat, np.array([175.0, -178.0, 179.0]))
    assert wrap and 170 < x0 < 175 and 182 < x1 < 190  # drawn in 0..360, 175..182
    assert list(map_lon(np.array([-178.0, 175.0]), wrap)) == [182.0, 175.0]
    assert y0 < 10 and y1 > 14
    x0, x1, _, _, wrap = map_extent(lat, np.array([-10.0, 0.0, 10.0]))
    assert not wrap and x0 < -10 and x1 > 10
    assert map_extent(lat[:0], lat[:0]) == (-180.0, 180.0, -90.0, 90.0, False)


def test_utc_axis_shows_clock_time(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from datetime import datetime

    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    inst, sched, fig, _ = _c1_figure(utc=True)
    try:
        ax_g = fig.axes[0]
        fig.canvas.draw()
        lo, hi = (mdates.num2date(x) for x in ax_g.get_xlim())
        epoch = datetime.fromisoformat(inst.epoch.replace("Z", "+00:00"))
        first = epoch.timestamp() + min(o.start for o in sched.observations)
        last = epoch.timestamp() + max(o.end for o in sched.observations)
        assert lo.timestamp() <= first and last <= hi.timestamp()
        assert ax_g.get_xlabel() == "UTC"
        labels = [t.get_text() for t in ax_g.get_yticklabels()]
        assert all(lab.endswith("Z") for lab in labels)  # each pass with its clock time
        stamps = [datetime.strptime(lab.split()[-1], "%H:%MZ").time() for lab in labels]
        assert stamps == sorted(stamps)  # a timeline: passes in time order (one day)
    finally:
        plt.close(fig)
    # through the CLI
    inst_p, sched_p, png = tmp_path / "c1.json", tmp_path / "s.json", tmp_path / "u.png"
    inst.save(inst_p)
    sched.save(sched_p, inst)
    assert main(["plot", str(inst_p), str(sched_p), "-o", str(png), "--utc"]) == 0
    assert png.stat().st_size > 10_000


def test_labels_say_what_they_show(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 63, item 12: a cap on the rows is said, the gap is named, counts agree in number."""
    import matplotlib.pyplot as plt

    from sosp.solve import solve

    inst = scenario("C1")
    fig, info = schedule_figure(inst, solve(inst, "greedy").schedule, max_orbits=3)
    ax_g = fig.axes[0]
    legend = [t.get_text() for t in ax_g.get_legend().get_texts()]
    plt.close(fig)
    assert f"showing 3 of {info['orbits_total']} orbits" in ax_g.get_title()
    assert info["orbits"] == 3 < info["orbits_total"] and not any("(3)" in t for t in legend)
    inst = tiny_cluster()
    inst.save(tmp_path / "i.json")
    Schedule((make_observation(inst, [0, 1]),)).save(tmp_path / "s.json", inst)
    assert (
        main(
            [
                "plot",
                str(tmp_path / "i.json"),
                str(tmp_path / "s.json"),
                "-o",
                str(tmp_path / "p.png"),
            ]
        )
        == 0
    )
    assert "1 observation (1 cluster-task) on 1 orbit," in capsys.readouterr().out


def test_plot_draws_walker_instances_ground_tracks(tmp_path: Path) -> None:
    """A Walker (TLE-recorded) instance's tracks are drawn, as ``sosp export`` draws them
    (issue 63, item 6: "ground tracks unknown for this instance")."""
    inst = tmp_path / "w.json"
    args = ["--walker", "4/2/1", "--altitude", "550", "--region", "40", "50", "0", "10"]
    assert main(["scenario", "w", *args, "--targets", "20", "-o", str(inst)]) == 0
    assert main(["solve", str(inst), "--method", "greedy", "-o", str(tmp_path / "s.json")]) == 0
    from sosp.instance import load_instance

    tracks = ground_tracks(load_instance(inst))
    assert tracks is not None and len(tracks) == 4


# ------------------------------------------------------------------- ground stations
def test_store_steps_up_at_each_observation_end_and_ramps_down_over_a_downlink() -> None:
    import numpy as np

    from sosp.downlink import Downlink
    from sosp.plot import store_profile
    from tests.sosp.test_downlink import obs, tiny

    inst = tiny()  # a: 100-110 s (10 units), b: 300-320 s (20 units); contact 900-1000 s
    sched = Schedule(
        obs(inst, 0, 1), downlinks=(Downlink(0, 0, 900.0, 925.0, ((0, 10.0), (1, 15.0))),)
    )
    t, store = store_profile(inst, sched)["S1"]
    np.testing.assert_allclose(t, [0, 0, 110, 110, 320, 320, 900, 900, 925, 925, 2000, 2000])
    np.testing.assert_allclose(store, [0, 0, 0, 10, 10, 30, 30, 30, 5, 5, 5, 5])
    assert np.interp(912.5, t[6:10], store[6:10]) == pytest.approx(17.5)  # even ramp


def test_store_panels_per_satellite_agree_with_the_validator(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import to_hex

    from sosp.plot import store_profile
    from sosp.scenarios import generate_scenario
    from sosp.solve import solve
    from sosp.stations import builtin_stations
    from sosp.validate import validate

    inst = generate_scenario("C1", hours=4)  # 4 h: quick, still several passes per station
    inst = inst.with_stations([s for s in builtin_stations() if s.id in ("SG", "MIY", "KSH")])
    sched = solve(inst, "greedy").schedule
    rep = validate(inst, sched)
    assert rep.feasible and sched.downlinks
    prof = store_profile(inst, sched)
    # the curve's peaks are the validator's (D5) and what it ends with is left on board
    peaks = {s: float(v.max()) for s, (_, v) in prof.items() if v.max() > 0}
    assert peaks == pytest.approx(rep.downlink["store_peak"])
    assert sum(v[-1] for _, v in prof.values()) == pytest.approx(
        rep.downlink["on_board_end"], abs=1e-6
    )
    assert min(v.min() for _, v in prof.values()) >= -1e-6
    fig, info = schedule_figure(inst, sched)
    try:
        n = len(inst.satellite_names)
        assert info["stores"] == n and info["downlinks"] == len(sched.downlinks)
        assert len(fig.axes) == 2 + n
        for s, ax in enumerate(fig.axes[2:]):
            name = inst.satellite_names[s]
            (line,) = [ln for ln in ax.lines if ln.get_color() == "#2b6cb0"]
            np.testing.assert_allclose(line.get_ydata(), prof[name][1])
            np.testing.assert_allclose(line.get_xdata(), prof[name][0] / 3600)
            colours = [to_hex(p.get_facecolor(), keep_alpha=True) for p in ax.patches]
            assert colours.count("#d53f8c80") == sum(d.satellite == s for d in sched.downlinks)
            assert colours.count("#d9d9d9ff") == (inst.contacts["satellite"] == s).sum()
    finally:
        plt.close(fig)
    png = tmp_path / "s.png"
    assert plot_schedule(inst, sched, png)["stores"] == n and png.stat().st_size > 10_000
    fig, info = schedule_figure(inst.without_stations(), Schedule(sched.observations))
    plt.close(fig)
    assert "stores" not in info and len(fig.axes) == 2


def test_utc_bars_stay_visible_and_counts_do_not_pile_up() -> None:
    """Issue 63, item 12: on a UTC axis a 10-s bar was a sliver and every cluster's count
    label sat on its neighbours'; now bars keep MIN_BAR_SHARE of the axis and each pass
    has one count."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_hex

    from sosp.plot import MIN_BAR_SHARE

    inst, sched, fig, _ = _c1_figure(utc=True)
    try:
        ax_g = fig.axes[0]
        span = float(np.subtract(*ax_g.get_xlim()[::-1]))
        widths = [
            w
            for coll in ax_g.collections
            if to_hex(coll.get_facecolor()[0]) in ("#2b6cb0", "#e8890c")  # tasks, clusters
            for path in coll.get_paths()
            for w in [float(np.ptp(path.vertices[:, 0]))]
        ]
        assert widths and min(widths) >= 0.9 * MIN_BAR_SHARE * span
        passes = {o.orbit for o in sched.observations}
        counts = [t for t in ax_g.texts if " obs, " in t.get_text()]
        assert len(counts) == len(passes)
    finally:
        plt.close(fig)


def test_track_colours_differ_in_hue() -> None:
    """Issue 63, item 12: two satellites' tracks were near-identical blues."""
    from matplotlib.colors import to_rgb

    from sosp.plot import TRACK_COLOURS

    rgb = np.array([to_rgb(c) for c in TRACK_COLOURS])
    far = min(np.linalg.norm(a - b) for i, a in enumerate(rgb) for b in rgb[i + 1 :])
    assert far > 0.25


def test_max_orbits_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    inst, sched = scenario("C1"), None
    from sosp.solve import solve

    sched = solve(inst, "greedy").schedule
    inst_p, sched_p, png = tmp_path / "c1.json", tmp_path / "s.json", tmp_path / "m.png"
    inst.save(inst_p)
    sched.save(sched_p, inst)
    assert main(["plot", str(inst_p), str(sched_p), "-o", str(png), "--max-orbits", "2"]) == 0
    out = capsys.readouterr().out
    assert "on 2 orbits (of " in out
    assert main(["plot", str(inst_p), str(sched_p), "-o", str(png), "--max-orbits", "0"]) == 2
