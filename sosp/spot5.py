"""The SPOT5 daily photograph scheduling problem (Bensana, Lemaître and Verfaillie, 1999).

The field's reference benchmark, 21 instances from a CNES simulator of the SPOT5 order book,
ships in ``sosp/data/spot5/`` (its README gives the source, the licence and the published
values). An instance is a weighted constraint problem:

* variables: candidate images, each with a weight and a domain of camera values (1, 2, 3 the
  front, middle and rear instruments of a mono image; 13 the front+rear pair of a stereo
  image). A variable may also stay unselected (the image is not taken);
* constraints: binary and ternary, each a list of forbidden tuples of values (a constraint
  holds when one of its variables is unselected or its values are not a forbidden tuple);
* multi-orbit instances (ids from 1000): the recorder capacity, a knapsack row over the
  values' consumptions;
* objective: the sum of the weights of the selected images.

File format (one file per instance, whitespace-separated integers)::

    N
    id weight d {value consumption}*d [extra...]     N lines
    M
    arity id... {forbidden tuple}*                   M lines (arity 2 or 3)

In the multi-orbit instances the last of the M lines is a single number, the recorder
capacity (the 1999 table counts it as a constraint). The two extra numbers that some variable
lines of this release carry are not part of the problem and are ignored.

Capacity reading (``capacity=``): the consumptions are about 451 per mono image and 1,805 per
stereo one, the capacity 90,000. ``"units"`` (the default) counts consumptions in whole units
of the smallest one (a mono image is 1, a stereo image 4) and the capacity as 200 units, the
reading behind the published values; ``"raw"`` reads 90,000 against the raw consumptions,
which allows only 199 units (floor of 90,000 / 451). Both are stored as integer units.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from sosp.errors import InputError

CapacityReading = Literal["units", "raw"]

#: The packaged instances (``sosp/data/spot5/``).
DATA_DIR = Path(__file__).parent / "data" / "spot5"

#: Published values (Table 1 of the 1999 paper), instance name -> (value, proven optimal).
PUBLISHED: dict[str, tuple[int, bool]] = {
    "8": (10, True), "54": (70, True), "29": (12032, True), "42": (108067, True),
    "28": (56053, True), "5": (115, True), "404": (49, True), "408": (3082, True),
    "412": (16102, True), "414": (22120, True), "503": (9096, True), "505": (13100, True),
    "507": (15137, True), "509": (19125, True), "1401": (176056, False),
    "1403": (176137, False), "1405": (176179, False), "1407": (176246, False),
    "1502": (61158, True), "1504": (124243, False), "1506": (168247, False),
}  # fmt: skip


@dataclass(frozen=True, eq=False)
class Spot5:
    """One SPOT5 instance, variables in file order (index ``i`` is the i-th variable line).

    Values are referred to by their *position* in the variable's domain (0..d-1); -1 is
    "unselected". Arrays of forbidden tuples hold positions too.

    Attributes
    ----------
    name
        Instance name (the file's stem).
    ids
        (n,) the file's variable ids.
    weight
        (n,) weight of each variable (image), non-negative integers.
    size
        (n,) domain size d of each variable.
    values
        (n, K) the camera values of each domain (K the largest d; padding 0).
    consumption
        (n, K) recorder consumption of each value in integer units (0 in single-orbit
        instances; padding 0).
    capacity
        Recorder capacity in the same units, None for single-orbit instances.
    pairs, pair_ptr, pair_forbid
        Binary constraints: (m2, 2) variable indices; constraint c forbids the position pairs
        ``pair_forbid[pair_ptr[c]:pair_ptr[c+1]]``.
    triples, triple_ptr, triple_forbid
        Ternary constraints, likewise with (m3, 3) and triples of positions.
    capacity_reading
        ``"units"`` (200) or ``"raw"`` (199), see the module docstring.
    """

    name: str
    ids: np.ndarray
    weight: np.ndarray
    size: np.ndarray
    values: np.ndarray
    consumption: np.ndarray
    capacity: int | None
    pairs: np.ndarray
    pair_ptr: np.ndarray
    pair_forbid: np.ndarray
    triples: np.ndarray
    triple_ptr: np.ndarray
    triple_forbid: np.ndarray
    capacity_reading: CapacityReading = "units"
    _index: dict[int, int] = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        """Number of variables."""
        return len(self.weight)

    def index_of(self, var_id: int) -> int:
        """Position of the variable with file id ``var_id`` (KeyError if none)."""
        if not self._index:
            self._index.update({int(v): i for i, v in enumerate(self.ids)})
        return self._index[int(var_id)]

    def value_usage(self, assignment: np.ndarray) -> int:
        """Recorder units used by ``assignment`` (positions, -1 unselected)."""
        a = np.asarray(assignment)
        on = np.flatnonzero(a >= 0)
        return int(self.consumption[on, a[on]].sum())

    def profit(self, assignment: np.ndarray) -> int:
        """Sum of the weights of the selected variables."""
        return int(self.weight[np.asarray(assignment) >= 0].sum())

    def subproblem(self, keep: np.ndarray | list[int] | int) -> Spot5:
        """The instance restricted to the variables ``keep`` (indices, or the first ``keep``):
        constraints over a dropped variable go (a dropped image is unselected, which meets
        them), the capacity stays."""
        keep = np.arange(keep) if isinstance(keep, int) else np.asarray(keep, dtype=np.int64)
        new = np.full(self.n, -1, dtype=np.int64)
        new[keep] = np.arange(len(keep))

        def part(cons: np.ndarray, ptr: np.ndarray, forbid: np.ndarray) -> tuple[np.ndarray, ...]:
            ok = np.flatnonzero((new[cons] >= 0).all(axis=1))
            rows = [forbid[ptr[c] : ptr[c + 1]] for c in ok]
            lens = np.array([len(r) for r in rows], dtype=np.int64)
            flat = np.concatenate(rows) if rows else forbid[:0]
            return new[cons[ok]], np.concatenate([[0], np.cumsum(lens)]).astype(np.int64), flat

        return Spot5(
            f"{self.name}[{len(keep)}]",
            self.ids[keep],
            self.weight[keep],
            self.size[keep],
            self.values[keep],
            self.consumption[keep],
            self.capacity,
            *part(self.pairs, self.pair_ptr, self.pair_forbid),
            *part(self.triples, self.triple_ptr, self.triple_forbid),
            capacity_reading=self.capacity_reading,
        )


def instance_path(name: str) -> Path:
    """Path of the packaged instance ``name`` (e.g. ``"404"``)."""
    path = DATA_DIR / f"{name}.spot"
    if not path.is_file():
        raise InputError(f"no packaged SPOT5 instance {name!r}")
    return path


def load_spot5(path: str | Path, capacity: CapacityReading = "units") -> Spot5:
    """Read a ``.spot`` file (format in the module docstring).

    Parameters
    ----------
    path
        The file.
    capacity
        ``"units"`` (200 units, default) or ``"raw"`` (199 units), see the module docstring.

    Raises
    ------
    InputError
        One line naming the file and line: a truncated file, a non-integer, a wrong arity or
        tuple length, a tuple value outside a domain, an unknown or repeated variable, a
        negative weight or consumption.
    """
    if capacity not in ("units", "raw"):
        raise InputError(f"capacity reading: expected 'units' or 'raw', not {capacity!r}")
    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read: {exc}") from None
    pos = 0  # index of the next line to read

    def bad(msg: str, at: int | None = None) -> InputError:
        return InputError(f"{path}: line {pos if at is None else at}: {msg}")

    def line(what: str) -> list[str]:
        nonlocal pos
        while pos < len(lines) and not lines[pos].strip():
            pos += 1
        if pos >= len(lines):
            raise bad(f"file ends early, expected {what}", pos + 1)
        pos += 1
        return lines[pos - 1].split()

    def ints(tokens: list[str]) -> list[int]:
        try:
            return [int(t) for t in tokens]
        except ValueError:
            raise bad("expected whole numbers") from None

    def count(what: str) -> int:
        t = ints(line(what))
        if len(t) != 1 or t[0] < 0:
            raise bad(f"expected one non-negative number, the {what}")
        return t[0]

    n = count("number of variables")
    ids, weight, doms, raw = [], [], [], []
    index: dict[int, int] = {}
    for _ in range(n):
        t = line("a variable line")
        try:
            head = [int(x) for x in t[:3]]
            d = head[2] if len(head) == 3 else -1
            vals = [int(x) for x in t[3 : 3 + 2 * d : 2]]
            cons = [float(x) for x in t[4 : 4 + 2 * d : 2]]
        except ValueError:
            raise bad("expected numbers") from None
        if len(head) < 3 or d < 1 or len(t) < 3 + 2 * d:
            raise bad("a variable line is: id weight d, then d pairs of value and consumption")
        if head[1] < 0:
            raise bad(f"negative weight {head[1]}")
        if min(cons) < 0 or not all(map(math.isfinite, cons)):
            raise bad("negative or non-finite consumption")
        if head[0] in index or len(set(vals)) != d:
            raise bad(f"variable {head[0]}: repeated variable or value")
        index[head[0]] = len(ids)
        ids.append(head[0])
        weight.append(head[1])
        doms.append(vals)
        raw.append(cons)
    m = count("number of constraints")
    pairs: list[list[int]] = []
    triples: list[list[int]] = []
    forbid: dict[int, list[list[int]]] = {2: [], 3: []}
    lens: dict[int, list[int]] = {2: [], 3: []}
    cap_raw: float | None = None
    for c in range(m):
        t = line("a constraint line")
        if len(t) == 1 and c == m - 1:  # the recorder capacity (multi-orbit instances)
            try:
                cap_raw = float(t[0])
            except ValueError:
                raise bad("expected the recorder capacity") from None
            if not (cap_raw >= 0 and math.isfinite(cap_raw)):
                raise bad("the recorder capacity must be non-negative")
            break
        t2 = ints(t)
        k = t2[0]
        if k not in (2, 3) or len(t2) < 1 + k or (len(t2) - 1 - k) % k:
            raise bad(f"arity {k}: expected 2 or 3 variable ids then whole tuples of {k} values")
        try:
            vs = [index[v] for v in t2[1 : 1 + k]]
        except KeyError as exc:
            raise bad(f"unknown variable {exc.args[0]}") from None
        tuples = np.asarray(t2[1 + k :], dtype=np.int64).reshape(-1, k)
        posn = np.empty_like(tuples)
        for j, v in enumerate(vs):
            dom = np.asarray(doms[v])
            hit = tuples[:, j, None] == dom[None, :]
            if not hit.any(axis=1).all():
                out = int(tuples[~hit.any(axis=1), j][0])
                raise bad(f"value {out} is not in the domain of variable {ids[v]}")
            posn[:, j] = hit.argmax(axis=1)
        (pairs if k == 2 else triples).append(vs)
        forbid[k].extend(posn.tolist())
        lens[k].append(len(posn))
    K = max((len(d) for d in doms), default=1)
    values = np.zeros((n, K), dtype=np.int64)
    cons_raw = np.zeros((n, K))
    for i, (d, r) in enumerate(zip(doms, raw, strict=True)):
        values[i, : len(d)], cons_raw[i, : len(r)] = d, r
    positive = cons_raw[cons_raw > 0]
    unit = float(positive.min()) if len(positive) else 1.0
    units = np.rint(cons_raw / unit).astype(np.int64)
    cap = None
    if cap_raw is not None:
        ratio = cap_raw / unit
        cap = math.ceil(ratio - 1e-9) if capacity == "units" else math.floor(ratio + 1e-9)

    def csr(k: int, cons: list[list[int]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (
            np.asarray(cons, dtype=np.int64).reshape(-1, k),
            np.concatenate([[0], np.cumsum(lens[k], dtype=np.int64)]).astype(np.int64),
            np.asarray(forbid[k], dtype=np.int64).reshape(-1, k),
        )

    return Spot5(
        path.stem,
        np.asarray(ids, dtype=np.int64),
        np.asarray(weight, dtype=np.int64),
        np.asarray([len(d) for d in doms], dtype=np.int64),
        values,
        units,
        cap,
        *csr(2, pairs),
        *csr(3, triples),
        capacity_reading=capacity,
    )


# --------------------------------------------------------------------------- solutions
def write_solution(path: str | Path, problem: Spot5, assignment: np.ndarray) -> None:
    """Write a solution: JSON ``{"instance", "profit", "assignment": {id: value}}`` when
    ``path`` ends in ``.json``, otherwise text lines ``id value`` (selected variables only,
    ``#`` comments). Values are the camera values (1, 2, 3, 13), not positions."""
    a = np.asarray(assignment)
    chosen = {int(problem.ids[i]): int(problem.values[i, a[i]]) for i in np.flatnonzero(a >= 0)}
    path = Path(path)
    if path.suffix == ".json":
        data = {"instance": problem.name, "profit": problem.profit(a), "assignment": chosen}
        text = json.dumps(data, indent=1) + "\n"
    else:
        head = f"# SPOT5 {problem.name}: profit {problem.profit(a)}; lines: id value\n"
        text = head + "".join(f"{k} {v}\n" for k, v in chosen.items())
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def read_solution(path: str | Path, problem: Spot5) -> np.ndarray:
    """Read a solution of :func:`write_solution` as positions (-1 unselected).

    Raises
    ------
    InputError
        Unknown variable, a value outside its domain, a variable given twice, bad syntax.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read: {exc}") from None
    rows: list[tuple[int, object, object]] = []
    if path.suffix == ".json":
        try:
            data = json.loads(text)["assignment"]
            rows = [(0, k, v) for k, v in data.items()]
        except (ValueError, KeyError, TypeError, AttributeError):
            raise InputError(f"{path}: expected a JSON object with 'assignment'") from None
    else:
        for no, ln in enumerate(text.splitlines(), 1):
            t = ln.split("#", 1)[0].split()
            if t:
                if len(t) != 2:
                    raise InputError(f"{path}: line {no}: expected 'id value'")
                rows.append((no, t[0], t[1]))
    a = np.full(problem.n, -1, dtype=np.int64)
    for no, k, v in rows:
        where = f"{path}: line {no}" if no else str(path)
        try:
            i, val = problem.index_of(int(k)), int(v)  # type: ignore[call-overload]
        except (ValueError, KeyError, TypeError):
            raise InputError(f"{where}: unknown variable or bad value {k} {v}") from None
        hit = np.flatnonzero(problem.values[i, : problem.size[i]] == val)
        if not len(hit) or a[i] >= 0:
            raise InputError(f"{where}: variable {k}: value {val} not in domain or repeated")
        a[i] = hit[0]
    return a


@dataclass(frozen=True)
class Spot5Report:
    """What :func:`validate_spot5` found: feasibility, profit, usage and violations."""

    feasible: bool
    profit: int
    selected: int
    usage: int
    violations: list[str]


@dataclass(frozen=True)
class Spot5Result:
    """What a SPOT5 solver returns.

    Attributes
    ----------
    method
        ``milp``, ``rds`` or ``tabu``.
    assignment
        (n,) value positions, -1 unselected.
    value
        Its profit.
    bound
        A proven upper bound on the optimum (None if the method has none).
    status
        ``optimal`` (value == bound), ``time_limit`` or ``heuristic``.
    time_s, cpu_s
        Wall and CPU (``time.process_time``) seconds.
    stats
        Method-specific figures.
    """

    method: str
    assignment: np.ndarray
    value: int
    bound: int | None
    status: str
    time_s: float
    cpu_s: float
    stats: dict = field(default_factory=dict)

    @property
    def gap(self) -> float | None:
        """``(bound - value) / bound``, None without a bound."""
        if self.bound is None:
            return None
        return 0.0 if self.bound <= 0 else (self.bound - self.value) / self.bound


def validate_spot5(problem: Spot5, assignment: np.ndarray) -> Spot5Report:
    """Check every constraint and the capacity, and recompute the profit, independently of
    the solvers (a plain loop over the forbidden tuples of each constraint).

    Parameters
    ----------
    problem
        The instance.
    assignment
        (n,) domain positions, -1 unselected.
    """
    a = [int(x) for x in np.asarray(assignment).tolist()]
    bad: list[str] = []
    if len(a) != problem.n:
        return Spot5Report(False, 0, 0, 0, [f"{len(a)} variables given, expected {problem.n}"])
    for i, x in enumerate(a):
        if not -1 <= x < int(problem.size[i]):
            bad.append(f"variable {problem.ids[i]}: position {x} outside its domain")
            a[i] = -1
    for cons, ptr, forbid in (
        (problem.pairs, problem.pair_ptr, problem.pair_forbid),
        (problem.triples, problem.triple_ptr, problem.triple_forbid),
    ):
        for c, vs in enumerate(cons.tolist()):
            got = tuple(a[v] for v in vs)
            if min(got) < 0:
                continue
            if any(tuple(t) == got for t in forbid[ptr[c] : ptr[c + 1]].tolist()):
                names = ", ".join(f"{problem.ids[v]}={problem.values[v, a[v]]}" for v in vs)
                bad.append(f"constraint {c + 1} of arity {len(vs)}: forbidden {names}")
    usage = sum(int(problem.consumption[i, x]) for i, x in enumerate(a) if x >= 0)
    if problem.capacity is not None and usage > problem.capacity:
        bad.append(f"recorder: {usage} units used, capacity {problem.capacity}")
    profit = sum(int(problem.weight[i]) for i, x in enumerate(a) if x >= 0)
    return Spot5Report(not bad, profit, sum(x >= 0 for x in a), usage, bad)
