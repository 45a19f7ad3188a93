"""Campaign specifications: a grid of scenarios x methods x seeds x time limits.

A campaign comes from command-line options or from a TOML file (parsed with :mod:`tomllib`)::

    [campaign]
    name = "paper"
    scenarios = ["B1", "C1", "instances/my.json"]   # named scenarios or instance files
    instance_seed = 0                                # seed of the scenario generator
    seeds = "1-10"                                   # or a list of integers
    time_limits = [60]                               # seconds; 0 means no limit
    skip_unavailable = true                          # skip registered methods not installed

    [[methods]]
    name = "milp"
    params = { model = "cluster" }
    time_limits = [600]                              # optional, overrides the campaign's
    seeds = [1]                                      # optional, overrides the campaign's

    [[methods]]
    name = "asa-dtc"

``methods`` may also be a list of strings such as ``"milp:model=cluster,mip_gap=0.01"``.
This module imports only the standard library, :mod:`sosp.errors` and :mod:`sosp.params`, so
``sosp --help`` stays fast.
"""

from __future__ import annotations

import json
import math
import os
import re
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from operator import attrgetter
from pathlib import Path
from typing import Any

from sosp.errors import InputError
from sosp.params import key_values

#: Named scenarios of the paper (section 6.1).
SCENARIO_RE = re.compile(r"^[BC](10|[1-9])$")

#: What identifies a run: the results store's unique key, :attr:`RunSpec.key`.
KEY_COLUMNS = ("scenario", "fingerprint", "method", "params", "seed", "time_limit")


def canonical_params(params: Mapping[str, Any]) -> str:
    """Parameters as canonical JSON (sorted keys, no spaces): the form stored and compared."""
    try:
        return json.dumps(dict(params), sort_keys=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise InputError(f"params: not JSON-serialisable: {exc}") from None


@dataclass(frozen=True)
class MethodSpec:
    """A method with fixed parameters (and optionally its own time limits)."""

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)
    time_limits: tuple[float, ...] | None = None
    seeds: tuple[int, ...] | None = None

    @property
    def label(self) -> str:
        """``name`` or ``name[key=value,...]``: how reports name the column."""
        return method_label(self.name, canonical_params(self.params))


def method_label(name: str, params_json: str) -> str:
    """Display label of a method and its canonical parameters."""
    params = json.loads(params_json) if params_json else {}
    if not params:
        return name
    inner = ",".join(f"{k}={v}" for k, v in sorted(params.items()))
    return f"{name}[{inner}]"


@dataclass(frozen=True)
class ScenarioSpec:
    """A named scenario (``B1``..``C10``, generated) or an instance file (loaded).

    ``label`` is what the store records (the name, or the path as written in the campaign);
    ``path`` is the resolved file path for files, None for named scenarios.
    """

    label: str
    path: str | None = None


@dataclass(frozen=True)
class RunSpec:
    """One run of the grid: small and picklable, it is all that crosses process boundaries."""

    scenario: str
    path: str | None
    instance_seed: int
    fingerprint: str
    method: str
    params: str  # canonical JSON
    seed: int
    time_limit: float  # 0 means no limit

    @property
    def key(self) -> tuple[str, str, str, str, int, float]:
        """The store's unique key (:data:`KEY_COLUMNS`)."""
        return attrgetter(*KEY_COLUMNS)(self)


@dataclass(frozen=True)
class Campaign:
    """A grid of runs. ``source`` is the campaign file (None when built from options)."""

    name: str
    scenarios: tuple[ScenarioSpec, ...]
    methods: tuple[MethodSpec, ...]
    seeds: tuple[int, ...]
    time_limits: tuple[float, ...]
    instance_seed: int = 0
    skip_unavailable: bool = False
    workers: int | None = None
    source: str | None = None

    def size(self) -> int:
        """Number of runs in the grid."""
        per_scenario = sum(
            len(m.time_limits or self.time_limits) * len(m.seeds or self.seeds)
            for m in self.methods
        )
        return per_scenario * len(self.scenarios)


#: The keys of a campaign file's tables: their specs' fields (``time_limit`` too, singular).
_CAMPAIGN_KEYS = {f.name for f in fields(Campaign)} - {"methods", "source"} | {"time_limit"}
_METHOD_KEYS = {f.name for f in fields(MethodSpec)} | {"time_limit"}


# --------------------------------------------------------------------------- parsing helpers
def parse_seeds(value: Any, where: str = "seeds") -> tuple[int, ...]:
    """Seeds from ``"1-3,7"``, an integer or a list of integers (duplicates dropped, order kept).

    Raises
    ------
    InputError
        On anything else, or a negative seed.
    """
    if isinstance(value, int) and not isinstance(value, bool):
        value = [value]
    if isinstance(value, str):
        items: list[int] = []
        for part in (p.strip() for p in value.split(",")):
            m = re.fullmatch(r"(\d+)(?:-(\d+))?", part)
            if not m:
                raise InputError(f"{where}: expected integers or ranges like 1-10, got {part!r}")
            lo, hi = int(m[1]), int(m[2] or m[1])
            if hi < lo:
                raise InputError(f"{where}: empty range {part!r}")
            items.extend(range(lo, hi + 1))
    elif isinstance(value, list):
        if bad := [v for v in value if isinstance(v, bool) or not isinstance(v, int)]:
            raise InputError(f"{where}: expected integers, got {bad[0]!r}")
        items = value
    else:
        raise InputError(f"{where}: expected integers or ranges like 1-10, got {value!r}")
    if any(s < 0 for s in items):
        raise InputError(f"{where}: seeds must be >= 0")
    if not items:
        raise InputError(f"{where}: no seed given")
    return tuple(dict.fromkeys(items))


def parse_time_limits(value: Any, where: str = "time_limits") -> tuple[float, ...]:
    """Time limits in seconds from a number, ``"5,60"`` or a list; 0 or ``"none"``: no limit."""
    raw = [p.strip() for p in value.split(",")] if isinstance(value, str) else value
    out: list[float] = []
    for v in raw if isinstance(raw, list) else [raw]:
        if isinstance(v, str):
            try:
                v = 0.0 if v.lower() == "none" else float(v)
            except ValueError:
                raise InputError(f"{where}: expected seconds, got {v!r}") from None
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v < 0:
            raise InputError(f"{where}: expected a finite number of seconds >= 0, got {v!r}")
        out.append(float(v))
    if not out:
        raise InputError(f"{where}: no time limit given")
    return tuple(dict.fromkeys(out))


def parse_method(text: str, where: str = "methods") -> MethodSpec:
    """``"name"`` or ``"name:key=value,key=value"`` (values are JSON, else text)."""
    if not isinstance(text, str) or not text.strip():
        raise InputError(f"{where}: expected a method name, got {text!r}")
    name, _, rest = text.strip().partition(":")
    malformed = f"{where}: expected key=value in {text!r}"
    params = key_values(rest.split(",") if rest else [], malformed)
    canonical_params(params)
    return MethodSpec(name.strip(), params)


def _method_from_table(rec: Any, where: str) -> MethodSpec:
    if isinstance(rec, str):
        return parse_method(rec, where)
    if not isinstance(rec, dict):
        raise InputError(f"{where}: expected a string or a table")
    if unknown := set(rec) - _METHOD_KEYS:
        raise InputError(f"{where}: unknown key {sorted(unknown)[0]!r}")
    name = rec.get("name")
    if not isinstance(name, str) or not name:
        raise InputError(f"{where}.name: expected a method name")
    params = rec.get("params", {})
    if not isinstance(params, dict):
        raise InputError(f"{where}.params: expected a table")
    canonical_params(params)
    tl = rec.get("time_limits", rec.get("time_limit"))  # TOML has no null: None is absent
    tl = None if tl is None else parse_time_limits(tl, f"{where}.time_limits")
    seeds = parse_seeds(rec["seeds"], f"{where}.seeds") if "seeds" in rec else None
    return MethodSpec(name, dict(params), tl, seeds)


def parse_scenarios(
    items: Iterable[Any], base: Path | None, where: str
) -> tuple[ScenarioSpec, ...]:
    """Scenario names (B1..B10, C1..C10) or instance files (relative to ``base``)."""
    out: list[ScenarioSpec] = []
    for raw in items:
        if not isinstance(raw, str) or not raw.strip():
            raise InputError(f"{where}: expected a scenario name or an instance file, got {raw!r}")
        s = raw.strip()
        if SCENARIO_RE.match(s):
            out.append(ScenarioSpec(s))
            continue
        p = Path(s) if base is None else base / s  # an absolute path stays as it is
        if s.endswith((".json", ".json.gz", ".npz")) or os.sep in s or "/" in s:
            if not p.is_file():
                raise InputError(f"{where}: instance file not found: {s}")
            out.append(ScenarioSpec(s, str(p)))
            continue
        raise InputError(
            f"{where}: unknown scenario {s!r}; expected B1..B10, C1..C10 or an instance file"
        )
    if not out:
        raise InputError(f"{where}: no scenario given")
    if len({s.label for s in out}) != len(out):
        raise InputError(f"{where}: a scenario is listed twice")
    return tuple(out)


def expand_scenario_names(text: str) -> list[str]:
    """``"B1-B3,C1"`` -> ``["B1", "B2", "B3", "C1"]``; ``"all"``: the 20 named scenarios."""
    out: list[str] = []
    for part in text.split(","):
        part = part.strip()
        if part.lower() == "all":
            out.extend(f"{g}{k}" for g in "BC" for k in range(1, 11))
            continue
        if m := re.fullmatch(r"([BC])(\d+)-\1?(\d+)", part):
            out.extend(f"{m[1]}{k}" for k in range(int(m[2]), int(m[3]) + 1))
        elif part:
            out.append(part)
    return out


# --------------------------------------------------------------------------- campaigns
def load_campaign(path: str | os.PathLike[str]) -> Campaign:
    """Read and check a TOML campaign file; :class:`InputError` names the file and key."""
    p = Path(path)
    src = str(p)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("campaign file not found", source=src) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read: {exc}", source=src) from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"malformed TOML: {exc}", source=src) from None
    try:
        return campaign_from_dict(data, base=p.parent, source=src)
    except InputError as exc:
        if exc.source:
            raise
        raise InputError(str(exc), source=src) from None


def campaign_from_dict(
    data: Mapping[str, Any], base: Path | None = None, source: str | None = None
) -> Campaign:
    """Build a :class:`Campaign` from parsed TOML (tables ``campaign`` and ``methods``)."""
    if unknown := set(data) - {"campaign", "methods"}:
        raise InputError(f"unknown table {sorted(unknown)[0]!r} (expected campaign, methods)")
    camp = data.get("campaign")
    if not isinstance(camp, dict):
        raise InputError("missing table [campaign]")
    if unknown := set(camp) - _CAMPAIGN_KEYS:
        raise InputError(f"campaign: unknown key {sorted(unknown)[0]!r}")
    if missing := [key for key in ("scenarios", "seeds") if key not in camp]:
        raise InputError(f"campaign: missing key {missing[0]!r}")
    scen = camp["scenarios"]
    if isinstance(scen, str):
        scen = expand_scenario_names(scen)
    if not isinstance(scen, list):
        raise InputError("campaign.scenarios: expected a list or a string like 'B1-B10,C1'")
    methods_raw = data.get("methods")
    if not isinstance(methods_raw, list) or not methods_raw:
        raise InputError("methods: expected a non-empty list ([[methods]] tables or strings)")
    methods = tuple(_method_from_table(m, f"methods[{i}]") for i, m in enumerate(methods_raw))
    tl = camp.get("time_limits", camp.get("time_limit", 0))
    stem = Path(source).stem if source else "campaign"
    # the other keys: (default, whether a value is valid, what is expected)
    checks: dict[str, tuple[Any, Callable[[Any], bool], str]] = {
        "instance_seed": (0, lambda v: type(v) is int and v >= 0, "a non-negative integer"),
        "skip_unavailable": (False, lambda v: isinstance(v, bool), "true or false"),
        "workers": (None, lambda v: v is None or type(v) is int, "an integer"),
        "name": (stem, lambda v: isinstance(v, str), "a string"),
    }
    given = {key: camp.get(key, default) for key, (default, _, _) in checks.items()}
    for key, (_, valid, what) in checks.items():
        if not valid(given[key]):
            raise InputError(f"campaign.{key}: expected {what}")
    return Campaign(
        scenarios=parse_scenarios(scen, base, "campaign.scenarios"),
        methods=_unique_methods(methods),
        seeds=parse_seeds(camp["seeds"], "campaign.seeds"),
        time_limits=parse_time_limits(tl, "campaign.time_limits"),
        source=source,
        **given,
    )


def _unique_methods(methods: Sequence[MethodSpec]) -> tuple[MethodSpec, ...]:
    seen: set[tuple[str, str]] = set()
    for m in methods:
        k = (m.name, canonical_params(m.params))
        if k in seen:
            raise InputError(f"methods: {m.label} is listed twice")
        seen.add(k)
    return tuple(methods)


def campaign_from_options(
    scenarios: str,
    methods: str,
    seeds: str,
    time_limits: str = "0",
    instance_seed: int = 0,
    name: str = "bench",
) -> Campaign:
    """Build a campaign from ``sosp bench`` options (comma-separated lists).

    ``methods`` separates methods by ``;`` or by commas not inside a parameter list, e.g.
    ``"greedy,milp:model=cluster"``; a method with several parameters needs ``;``:
    ``"milp:model=task,mip_gap=0.01;greedy"``.
    """
    if ";" in methods:
        parts = [m for m in methods.split(";") if m.strip()]
    else:
        parts = []
        for item in methods.split(","):
            if "=" in item and ":" not in item and parts:
                parts[-1] += "," + item  # a further key=value of the previous method
            elif item.strip():
                parts.append(item)
    if not parts:
        raise InputError("--methods: no method given")
    return Campaign(
        name=name,
        scenarios=parse_scenarios(expand_scenario_names(scenarios), None, "--scenarios"),
        methods=_unique_methods([parse_method(m, "--methods") for m in parts]),
        seeds=parse_seeds(seeds, "--seeds"),
        time_limits=parse_time_limits(time_limits, "--time-limit"),
        instance_seed=instance_seed,
    )
