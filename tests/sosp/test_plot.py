"""``sosp plot``: a PNG with a Gantt chart and a map; counts reported match the schedule."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sosp.cli import main
from sosp.plot import ground_tracks, plot_schedule
from sosp.schedule import Schedule, make_observation
from tests.conftest import tiny_cluster


def test_plot_tiny_cluster_counts_and_png(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    inst = tiny_cluster()
    sched = Schedule((make_observation(inst, [0, 1]), make_observation(inst, [2])))
    out = tmp_path / "s.png"
    info = plot_schedule(inst, sched, out)
    assert info == {"orbits": 1, "observations": 2, "clusters": 1, "observed": 3, "tracks": False}
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
