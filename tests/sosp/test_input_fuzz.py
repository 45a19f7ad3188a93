"""Damaged input files give :class:`InputError` (one line, naming the field), never another
exception: instance and schedule files with a field deleted, repeated or set to a wrong
value; targets and TLE files with characters replaced or lines cut, dropped or repeated.

A fuzz of the command line with the same damage found two tracebacks (a schedule start of
1e300 and a TLE that sgp4 rejects); these tests keep every loader to its contract."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sosp.errors import InputError
from sosp.instance import Instance
from sosp.orbits import parse_tle
from sosp.scenarios import custom_scenario, read_targets_csv
from sosp.schedule import Schedule
from sosp.solve import solve

L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"
TLE = f"CBERS 2\n{L1}\n{L2}\n"
CSV = "id,lat,lon,weight\nrome,41.9,12.5,5\nbeijing,39.9,116.4,7\nquito,-0.2,-78.5,1\n"

#: Values a damaged file may hold where another was expected.
BAD = [
    None, "x", "", -1, -1e300, 1e300, 10**20, True, [], {}, 0, 1.5, -0.0, "NaN", [1, 2],
    {"a": 1}, "2026-06-01T00:00:00Z",
]  # fmt: skip
#: Text put in place of a few characters of a text file.
TOKENS = ["", "x", "-1", "1e400", "nan", "inf", "5.5", "\ufeff", ",", '"', "999", "-91", " "]


@pytest.fixture(scope="module")
def files() -> tuple[dict[str, Any], dict[str, Any], Instance]:
    inst = custom_scenario(
        region=(30.0, 34.0, 100.0, 104.0), count=12, seed=1, hours=24.0, name="fuzz"
    )
    sched = solve(inst, "greedy").schedule
    assert len(sched.observations) >= 2  # something in each part of the file to damage
    return inst.to_dict(), sched.to_dict(inst), inst


def _paths(data: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a JSON document (the first three items of each list)."""
    out: list[tuple[Any, ...]] = []
    items = data.items() if isinstance(data, dict) else enumerate(data[:3])
    for key, value in items:
        out.append((*prefix, key))
        if isinstance(value, dict | list):
            out.extend(_paths(value, (*prefix, key)))
    return out


def _damage(doc: dict[str, Any], data: st.DataObject, under: str | None = None) -> dict[str, Any]:
    """``doc`` with one field deleted, repeated or replaced (only within ``doc[under]``)."""
    doc = copy.deepcopy(doc)
    paths = _paths(doc) if under is None else _paths(doc[under], (under,))
    path = data.draw(st.sampled_from(paths))
    parent = doc
    for key in path[:-1]:
        parent = parent[key]
    how = data.draw(st.sampled_from(["delete", "repeat", "replace"]))
    if how == "delete" and isinstance(parent, dict):
        del parent[path[-1]]
    elif how == "repeat" and isinstance(parent, list):
        parent.append(copy.deepcopy(parent[path[-1]]))
    else:
        parent[path[-1]] = data.draw(st.sampled_from(BAD))
    return doc


def _damage_text(text: str, data: st.DataObject) -> str:
    lines = text.split("\n")
    how = data.draw(st.sampled_from(["cut", "drop", "repeat", "replace"]))
    i = data.draw(st.integers(0, len(lines) - 1))
    if how == "cut":
        lines[i] = lines[i][: data.draw(st.integers(0, len(lines[i])))]
    elif how == "drop":
        del lines[i]
    elif how == "repeat":
        lines.insert(i, lines[data.draw(st.integers(0, len(lines) - 1))])
    else:
        at = data.draw(st.integers(0, len(text)))
        width = data.draw(st.integers(0, 5))
        return text[:at] + data.draw(st.sampled_from(TOKENS)) + text[at + width :]
    return "\n".join(lines)


# a loader either reads the file or raises InputError; anything else escapes the CLI as a
# traceback
_SETTINGS = settings(
    max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


@_SETTINGS
@given(data=st.data())
def test_a_damaged_instance_file_is_read_or_refused(files, data) -> None:
    doc = _damage(files[0], data)
    try:
        Instance.from_dict(json.loads(json.dumps(doc)), source="i.json")
    except InputError as exc:
        assert str(exc).startswith("i.json: ") and "\n" not in str(exc)


@_SETTINGS
@given(data=st.data())
def test_a_damaged_schedule_file_is_read_or_refused(files, data) -> None:
    doc = _damage(files[1], data, under=data.draw(st.sampled_from([None, "observations"])))
    try:
        Schedule.from_dict(json.loads(json.dumps(doc)), files[2], source="s.json")
    except InputError as exc:
        assert str(exc).startswith("s.json: ") and "\n" not in str(exc)


@_SETTINGS
@given(data=st.data())
def test_a_damaged_tle_file_is_read_or_refused(data) -> None:
    try:
        parse_tle(_damage_text(TLE, data), source="s.tle")
    except InputError as exc:
        assert str(exc).startswith("s.tle: ") and "\n" not in str(exc)


@_SETTINGS
@given(data=st.data())
def test_a_damaged_targets_file_is_read_or_refused(tmp_path: Path, data) -> None:
    path = tmp_path / "t.csv"
    path.write_text(_damage_text(CSV, data), encoding="utf-8")
    try:
        read_targets_csv(path)
    except InputError as exc:
        assert "\n" not in str(exc)
