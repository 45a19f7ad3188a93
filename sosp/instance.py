"""The problem data: targets, orbits with their resources, and observation opportunities.

An :class:`Instance` is immutable and stores every table as numpy columns, so solvers can
vectorise over it. Opportunities are kept sorted by (orbit, start, end); the opportunities of
orbit ``j`` are the contiguous slice :meth:`Instance.orbit_opps`.

Units: times are seconds from :attr:`Instance.epoch` (ISO 8601 UTC); angles are degrees;
memory and energy are in the units of Table 1 of the paper.

The file format (``format: "sosp-instance"``, ``version: 1``) is documented in
``docs/formats.md``. Each table may be a list of records or an object of equal-length columns.
A path ending in ``.npz`` holds the same content as numpy arrays (``format:
"sosp-instance-npz"``, ``version: 1``), which loads in seconds where the JSON of a
million-opportunity instance takes minutes.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from datetime import datetime
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from sosp.downlink import DownlinkParams
from sosp.errors import InputError
from sosp.io import (
    atomic_output,
    atomic_write_text,
    is_finite_number,
    read_bytes,
    read_json,
    reject_json_constant,
)
from sosp.stations import CONTACT_DTYPE, CSV_COLUMNS, Station

FORMAT_NAME = "sosp-instance"
FORMAT_VERSION = 1

#: Tolerance (seconds or degrees) for the consistency checks of loaded data.
DATA_TOL = 1e-9

#: dtype of the opportunities' target and orbit indices. Times, rolls and coordinates stay
#: float64: the candidate observations compare windows and roll ranges to 1e-9 (seconds since
#: the epoch reach 1e5, beyond float32's 7 digits), and the files and the fingerprint are
#: defined by the float64 values.
INDEX_DTYPE = np.int32

#: From this many opportunities on, :meth:`Instance.save` writes the columns layout (one list
#: per field) unless told otherwise: about half the size of the records layout.
COLUMNS_FROM = 50_000


@dataclass(frozen=True)
class Resources:
    """Per-orbit resource and sensor parameters (Table 1 of the paper as defaults).

    Parameters
    ----------
    memory_capacity
        W_j, memory per orbit, constraint (5).
    memory_rate
        w_j, memory per second observed, (5).
    energy_capacity
        E_j, energy per orbit, (4).
    observe_energy_rate
        eo_j, energy per second observed, (4).
    slew_energy_rate
        es_j, energy per second slewing, (4).
    slew_rate
        v_j, degrees per second, (3)-(4).
    setup_time
        a_j, seconds before each observation, (3).
    max_openings
        c_j, sensor openings per orbit, (6).
    max_duration
        Delta T, longest continuous observation in seconds, (11).
    """

    memory_capacity: float = 1000.0
    memory_rate: float = 1.0
    energy_capacity: float = 1500.0
    observe_energy_rate: float = 1.0
    slew_energy_rate: float = 1.0
    slew_rate: float = 1.0
    setup_time: float = 10.0
    max_openings: int = 10
    max_duration: float = 120.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _check_resource(f.name, getattr(self, f.name), "resources")


#: The resource keys of an orbit record, in file order.
RESOURCE_KEYS: tuple[str, ...] = tuple(f.name for f in fields(Resources))

#: The columns of an opportunity besides its id (``opp_<key>`` in :meth:`Instance.from_arrays`).
OPP_KEYS = ("target", "orbit", "start", "end", "roll", "roll_min", "roll_max")

#: Largest target weight accepted: every profit, bound and sum of weights stays an integer
#: that float64 holds exactly (the models and the LP bounds compute in floats) for up to
#: nine million targets; a weight of 1e20 once wrapped to a negative int64 profit.
MAX_WEIGHT = 10**9

#: The binary encoding written for a path ending in ``.npz``: its own format name and version
#: (in the ``header`` entry), so the array layout can change without touching the JSON format.
NPZ_FORMAT_NAME = "sosp-instance-npz"
NPZ_FORMAT_VERSION = 1

#: The .npz entry holding the scalar fields (format, version, name, epoch, meta) as JSON text.
NPZ_HEADER = "header"

#: The .npz arrays per table, in file order, with the kind of dtype each must have: "f"
#: float64, "i" any integer, "U" numpy unicode. Opportunities' ``target`` and ``orbit`` are
#: 0-based row indices into the targets and orbits tables (the JSON format uses the ids).
NPZ_TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "targets": (("id", "U"), ("lat", "f"), ("lon", "f"), ("weight", "i")),
    "orbits": (
        ("id", "U"),
        ("satellite", "U"),
        ("start", "f"),
        ("end", "f"),
        *((k, "i" if k == "max_openings" else "f") for k in RESOURCE_KEYS),
    ),
    "opportunities": (
        ("id", "U"),
        *((k, "i" if k in ("target", "orbit") else "f") for k in OPP_KEYS),
    ),
}

#: The tables of an instance with ground stations (issue 60), as :data:`NPZ_TABLES`: the
#: :class:`~sosp.stations.Station` fields, and the contact windows (:data:`CONTACT_DTYPE`;
#: ``satellite`` a row of :attr:`Instance.satellite_names`, ``station`` of the stations; the
#: JSON format names them). Both are absent from the files of an instance without stations.
STATION_TABLES: dict[str, tuple[tuple[str, str], ...]] = {
    "stations": (
        ("id", "U"),
        *((k, "i" if k == "antennas" else "f") for k, _, _ in CSV_COLUMNS),
        ("description", "U"),
    ),
    "contacts": tuple(
        (k, "i" if k in ("satellite", "station") else "f") for k in CONTACT_DTYPE.names
    ),
}

_NPZ_KIND_NAMES = {"f": "float64", "i": "an integer dtype", "U": "a unicode string dtype"}
_NPZ_KINDS = {"f": "f", "i": "iu", "U": "U"}

#: The fixed time stamp of every .npz member, so one instance always gives the same bytes.
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)


#: The largest ``max_openings`` accepted (a plan never has more observations than an orbit
#: has opportunities; a larger value would not fit the planner's integers).
MAX_OPENINGS = 2**31 - 1


def _bad_resource(key: str, value: Any) -> Any:
    """Where a resource value (or a numpy column of them) is out of its range."""
    if key == "max_openings":
        return (value < 0) | (value != np.round(value)) | (value > MAX_OPENINGS)
    return value <= 0 if key in ("slew_rate", "max_duration") else value < 0


def _check_resource(key: str, value: Any, where: str, source: str | None = None) -> None:
    """Check a resource value, or a per-orbit float column of them (``where`` then names
    its first bad row)."""
    if isinstance(value, np.ndarray):
        rows = np.flatnonzero(~np.isfinite(value) | _bad_resource(key, value))
        if not rows.size:
            return
        where, value = f"{where}[{rows[0]}]", float(value[rows[0]])
    if not is_finite_number(value):
        raise InputError(f"{where}.{key}: expected a finite number, got {value!r}", source=source)
    if _bad_resource(key, np.float64(value)):
        need = {"max_openings": f"expected an integer from 0 to {MAX_OPENINGS}"}.get(
            key, "must be > 0" if key in ("slew_rate", "max_duration") else "must be >= 0"
        )
        raise InputError(f"{where}.{key}: {need}, got {value!r}", source=source)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Instance:
    """An immutable scheduling instance (targets, orbits, opportunities) as numpy columns.

    Build one with :meth:`from_arrays`, :meth:`build` (small hand-made instances),
    :meth:`from_dict` or :func:`load_instance`. The constructor itself does no validation
    and is not meant to be called directly.
    """

    epoch: str
    target_ids: tuple[str, ...]
    target_lat: np.ndarray
    target_lon: np.ndarray
    target_weight: np.ndarray
    orbit_ids: tuple[str, ...]
    orbit_satellite: tuple[str, ...]
    orbit_start: np.ndarray
    orbit_end: np.ndarray
    memory_capacity: np.ndarray
    memory_rate: np.ndarray
    energy_capacity: np.ndarray
    observe_energy_rate: np.ndarray
    slew_energy_rate: np.ndarray
    slew_rate: np.ndarray
    setup_time: np.ndarray
    max_openings: np.ndarray
    max_duration: np.ndarray
    opp_ids: tuple[str, ...]
    opp_target: np.ndarray
    opp_orbit: np.ndarray
    opp_start: np.ndarray
    opp_end: np.ndarray
    opp_roll: np.ndarray
    opp_roll_min: np.ndarray
    opp_roll_max: np.ndarray
    name: str = ""
    meta: Mapping[str, Any] = field(default_factory=dict)
    stations: tuple[Station, ...] = ()
    contacts: np.ndarray = field(default_factory=lambda: np.empty(0, CONTACT_DTYPE))
    downlink: DownlinkParams = field(default_factory=DownlinkParams)

    # ------------------------------------------------------------------ sizes
    @property
    def n_targets(self) -> int:
        return len(self.target_ids)

    @property
    def n_orbits(self) -> int:
        return len(self.orbit_ids)

    @property
    def n_opps(self) -> int:
        return len(self.opp_ids)

    # ------------------------------------------------------------- structure
    @cached_property
    def orbit_offsets(self) -> np.ndarray:
        """CSR offsets: the opportunities of orbit j are ``offsets[j]:offsets[j+1]``."""
        counts = np.bincount(self.opp_orbit, minlength=self.n_orbits)
        return _readonly(np.concatenate(([0], np.cumsum(counts))).astype(np.int64))

    def orbit_opps(self, j: int) -> slice:
        """The slice of opportunity indices on orbit ``j`` (sorted by start time)."""
        off = self.orbit_offsets
        return slice(int(off[j]), int(off[j + 1]))

    @cached_property
    def target_opps(self) -> tuple[np.ndarray, ...]:
        """For each target, the indices of its opportunities (ascending)."""
        order = np.argsort(self.opp_target, kind="stable")
        counts = np.bincount(self.opp_target, minlength=self.n_targets)
        parts = np.split(order, np.cumsum(counts)[:-1])
        return tuple(_readonly(p.astype(np.int64)) for p in parts)

    @cached_property
    def opp_weight(self) -> np.ndarray:
        """The weight p_k of each opportunity's target."""
        return _readonly(self.target_weight[self.opp_target])

    @cached_property
    def target_index(self) -> dict[str, int]:
        return {t: i for i, t in enumerate(self.target_ids)}

    @cached_property
    def orbit_index(self) -> dict[str, int]:
        return {o: i for i, o in enumerate(self.orbit_ids)}

    @cached_property
    def opp_index(self) -> dict[str, int]:
        return {o: i for i, o in enumerate(self.opp_ids)}

    @cached_property
    def satellite_names(self) -> tuple[str, ...]:
        """The satellites of the orbits, in order of first appearance."""
        return tuple(dict.fromkeys(self.orbit_satellite))

    def with_stations(
        self, stations: Sequence[Station], downlink: DownlinkParams | None = None
    ) -> Instance:
        """This instance with ground stations, their contact windows with its satellites
        over its horizon (:func:`sosp.stations.contact_windows`, from the orbits the instance
        records: :func:`sosp.orbits.instance_satellites`) and how data is sent to them
        (``downlink``, :class:`~sosp.downlink.DownlinkParams` defaults when None)."""
        from sosp.orbits import instance_satellites
        from sosp.stations import contact_windows

        if not stations:
            return self.without_stations()
        if not self.n_orbits or (sats := instance_satellites(self)) is None:
            raise InputError("--stations: the instance does not record its satellites' orbits")
        c = contact_windows(
            sats, stations, self.epoch, self.orbit_start.min(), self.orbit_end.max()
        )
        row = {n: i for i, n in enumerate(self.satellite_names)}
        c["satellite"] = np.array([row[s.name] for s in sats], np.int64)[c["satellite"]]
        c = c[np.lexsort((c["start_s"], c["station"], c["satellite"]))]
        return replace(
            self, stations=tuple(stations), contacts=_readonly(c),
            downlink=downlink or DownlinkParams(),
        )  # fmt: skip

    def with_opportunities(self, keep: np.ndarray) -> Instance:
        """This instance with only the opportunities where ``keep`` (a boolean mask) is True,
        in the same order (so an index ``i`` here is ``np.flatnonzero(keep)[i]`` in this
        instance); targets and orbits are unchanged."""
        keep = np.asarray(keep, dtype=bool)
        cols = {f"opp_{k}": _readonly(getattr(self, f"opp_{k}")[keep]) for k in OPP_KEYS}
        ids = tuple(i for i, k in zip(self.opp_ids, keep, strict=True) if k)
        return replace(self, opp_ids=ids, **cols)

    def without_stations(self) -> Instance:
        """This instance without ground stations: the paper's problem, weights counted when
        observed and memory reset per orbit (5)."""
        empty = _readonly(np.empty(0, CONTACT_DTYPE))
        return replace(self, stations=(), contacts=empty, downlink=DownlinkParams())

    @cached_property
    def observable_targets(self) -> int:
        """EN: the number of targets with at least one opportunity."""
        return int(np.count_nonzero(np.bincount(self.opp_target, minlength=self.n_targets)))

    @cached_property
    def observable_weight(self) -> float:
        """Total weight of the targets with at least one opportunity: the profit (1) of
        observing all of them, so a bound on every schedule's for free."""
        seen = np.bincount(self.opp_target, minlength=self.n_targets) > 0
        return float(np.asarray(self.target_weight, dtype=float)[seen].sum())

    def resources(self, j: int) -> Resources:
        """The resource parameters of orbit ``j`` as a :class:`Resources`."""
        vals = {k: getattr(self, k)[j].item() for k in RESOURCE_KEYS}
        vals["max_openings"] = int(vals["max_openings"])
        return Resources(**vals)

    @cached_property
    def fingerprint(self) -> str:
        """A hash of the instance's content (name and meta excluded)."""
        data = {k: v for k, v in self.to_dict("columns").items() if k not in ("name", "meta")}
        blob = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
        return "sha256:" + hashlib.sha256(blob.encode()).hexdigest()

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Instance):
            return NotImplemented
        return (
            self.fingerprint == other.fingerprint
            and self.name == other.name
            and dict(self.meta) == dict(other.meta)
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"Instance(name={self.name!r}, targets={self.n_targets}, orbits={self.n_orbits}, "
            f"opportunities={self.n_opps})"
        )

    # ----------------------------------------------------------- constructors
    @classmethod
    def from_arrays(
        cls,
        *,
        epoch: str,
        target_ids: Sequence[Any],
        target_lat: Any,
        target_lon: Any,
        target_weight: Any,
        orbit_ids: Sequence[Any],
        orbit_satellite: Sequence[Any],
        orbit_start: Any,
        orbit_end: Any,
        opp_target: Any,
        opp_orbit: Any,
        opp_start: Any,
        opp_end: Any,
        opp_roll: Any,
        opp_roll_min: Any,
        opp_roll_max: Any,
        resources: Resources | Mapping[str, Any] | None = None,
        opp_ids: Sequence[Any] | None = None,
        name: str = "",
        meta: Mapping[str, Any] | None = None,
        source: str | None = None,
        stations: Mapping[str, Any] | None = None,
        contacts: Mapping[str, Any] | None = None,
        downlink: DownlinkParams | Mapping[str, Any] | None = None,
    ) -> Instance:
        """Build and validate an instance from columns.

        ``resources`` is a :class:`Resources` applied to every orbit, or a mapping from each
        key of :data:`RESOURCE_KEYS` to a scalar or a per-orbit array. ``stations`` and
        ``contacts`` are the columns of :data:`STATION_TABLES`, rows by index; ``downlink``
        (with stations only) a :class:`~sosp.downlink.DownlinkParams` or its dict.
        ``opp_target`` and ``opp_orbit`` are integer indices. Opportunities are sorted by
        (orbit, start, end); missing ``opp_ids`` become ``"o1"``, ``"o2"``, ... in that order.

        Raises
        ------
        InputError
            On any inconsistency, naming the table, row and field.
        """
        _check_epoch(epoch, source)
        n_t, n_o, n_p = len(target_ids), len(orbit_ids), len(opp_target)

        def col(values: Any, table: str, key: str, n: int) -> np.ndarray:
            try:
                arr = np.array(values, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                raise InputError(f"{table}.{key}: expected numbers", source=source) from None
            if arr.shape != (n,):
                raise InputError(
                    f"{table}.{key}: expected {n} values, got {arr.size}", source=source
                )
            first(~np.isfinite(arr), f".{key}: expected a finite number, got %s", table, arr)
            return arr

        def first(
            mask: np.ndarray, msg: str, table: str = "opportunities", got: Any = None
        ) -> None:
            """Refuse the first row of ``table`` where ``mask`` holds: ``msg`` after
            ``table[row]``, with ``%`` the row's entry of ``got`` when given."""
            bad = np.flatnonzero(mask)
            if bad.size:
                text = msg if got is None else msg % got[bad[0]]
                raise InputError(f"{table}[{bad[0]}]{text}", source=source)

        tid = _ids(target_ids, "targets", source)
        lat = col(target_lat, "targets", "lat", n_t)
        lon = col(target_lon, "targets", "lon", n_t)
        w_raw = col(target_weight, "targets", "weight", n_t)
        for key, a, lo, hi in (("lat", lat, -90.0, 90.0), ("lon", lon, -180.0, 360.0)):
            first((a < lo) | (a > hi), f".{key}: %g is outside [{lo:g}, {hi:g}]", "targets", a)
        first(
            (w_raw < 0) | (w_raw > MAX_WEIGHT) | (w_raw != np.round(w_raw)),
            f".weight: expected an integer in [0, {MAX_WEIGHT:.0e}], got %g",
            "targets",
            w_raw,
        )
        weight = w_raw.astype(np.int64)

        oid = _ids(orbit_ids, "orbits", source)
        sat = tuple(str(s) for s in orbit_satellite)
        if len(sat) != n_o:
            raise InputError(f"orbits.satellite: expected {n_o} values", source=source)
        o_start = col(orbit_start, "orbits", "start", n_o)
        o_end = col(orbit_end, "orbits", "end", n_o)
        first(o_start >= o_end, ": start must be < end", "orbits")

        if not isinstance(resources, Mapping):
            resources = asdict(resources or Resources())
        res_cols: dict[str, np.ndarray] = {}
        for key in RESOURCE_KEYS:
            if key not in resources:
                raise InputError(f"orbits: missing resource key {key!r}", source=source)
            try:
                arr = np.broadcast_to(np.asarray(resources[key], dtype=float), (n_o,)).copy()
            except (TypeError, ValueError):
                raise InputError(f"orbits.{key}: expected {n_o} numbers", source=source) from None
            _check_resource(key, arr, "orbits", source)
            if key == "max_openings":
                arr = arr.astype(np.int64)
            res_cols[key] = arr

        values = (opp_target, opp_orbit, opp_start, opp_end, opp_roll, opp_roll_min, opp_roll_max)
        opp = {k: col(v, "opportunities", k, n_p) for k, v in zip(OPP_KEYS, values, strict=True)}
        for key, n in (("target", n_t), ("orbit", n_o)):
            arr = opp[key]
            bad = (arr < 0) | (arr >= n) | (arr != np.round(arr))
            first(bad, f".{key}: unknown {key} index %g", "opportunities", arr)
            # int32 indices: half the memory of int64 on instances with millions of opportunities
            opp[key] = arr.astype(INDEX_DTYPE)
        pid = _ids(opp_ids, "opportunities", source) if opp_ids is not None else None
        if pid is not None and len(pid) != n_p:
            raise InputError(f"opportunities.id: expected {n_p} values", source=source)

        p_start, p_end, p_orbit = opp["start"], opp["end"], opp["orbit"]
        roll, rmin, rmax = opp["roll"], opp["roll_min"], opp["roll_max"]
        first(p_start >= p_end, ": start must be < end")
        first(
            (rmin > roll + DATA_TOL) | (roll > rmax + DATA_TOL),
            ": need roll_min <= roll <= roll_max",
        )
        first((np.abs(rmin) > 90) | (np.abs(rmax) > 90), ": roll range must lie in [-90, 90] deg")
        if n_p:
            first(
                (p_start < o_start[p_orbit] - DATA_TOL) | (p_end > o_end[p_orbit] + DATA_TOL),
                ": window must lie inside its orbit's [start, end]",
            )

        order: np.ndarray | slice
        if _is_sorted(p_orbit, p_start, p_end):
            # what save() wrote is in this order already: no sort, no copies (millions of rows)
            order = slice(None)
        else:
            order = np.lexsort((p_end, p_start, p_orbit))
        if pid is None:
            pid = tuple(f"o{i + 1}" for i in range(n_p))
        elif isinstance(order, np.ndarray):
            pid = tuple(pid[i] for i in order)
        sat_names = tuple(dict.fromkeys(sat))
        st, ct = _station_tables(stations, contacts, len(sat_names), source)
        if downlink is not None and not isinstance(downlink, DownlinkParams):
            if not st:
                raise InputError("downlink: given without stations", source=source)
            try:
                downlink = DownlinkParams.from_dict(downlink)
            except InputError as e:
                raise InputError(str(e), source=source) from None
        return cls(
            stations=st,
            contacts=ct,
            downlink=downlink or DownlinkParams(),
            epoch=epoch,
            target_ids=tid,
            target_lat=_readonly(lat),
            target_lon=_readonly(lon),
            target_weight=_readonly(weight),
            orbit_ids=oid,
            orbit_satellite=sat,
            orbit_start=_readonly(o_start),
            orbit_end=_readonly(o_end),
            **{k: _readonly(v) for k, v in res_cols.items()},
            opp_ids=pid,
            **{f"opp_{k}": _readonly(v[order]) for k, v in opp.items()},
            name=str(name),
            meta=dict(meta or {}),
        )

    @classmethod
    def build(
        cls,
        weights: Mapping[str, int] | Sequence[int],
        opportunities: Sequence[Sequence[Any]],
        *,
        resources: Resources | None = None,
        n_orbits: int | None = None,
        orbit_length: float | None = None,
        name: str = "",
        epoch: str = "2026-01-01T00:00:00Z",
    ) -> Instance:
        """Build a small instance by hand, with opportunities given directly (no orbits).

        Parameters
        ----------
        weights
            Target weights, as ``{"a": 5, ...}`` or a list (ids become ``"t0"``, ``"t1"``...).
        opportunities
            Rows ``(target, orbit, start, end, roll[, roll_min, roll_max])``; ``target`` is an
            id or index, ``orbit`` an integer index. A missing roll range is
            ``[roll - 3, roll + 3]`` clipped to [-33, 33] deg (sigma = 6 deg, theta_max = 33 deg).
        resources
            Applied to every orbit (Table 1 defaults).
        n_orbits
            Number of orbits (default: one more than the largest orbit index used).
        orbit_length
            Each orbit spans ``[0, orbit_length]`` seconds (default: covers every window).

        Examples
        --------
        >>> inst = Instance.build({"a": 5, "b": 3}, [("a", 0, 0, 4, 10.0), ("b", 0, 30, 34, -5.0)])
        >>> inst.n_opps
        2
        """
        if isinstance(weights, Mapping):
            tids = [str(k) for k in weights]
            wts = list(weights.values())
        else:
            wts = list(weights)
            tids = [f"t{i}" for i in range(len(wts))]
        index = {t: i for i, t in enumerate(tids)}
        cols = []
        for r, row in enumerate(map(tuple, opportunities)):
            if len(row) not in (5, 7):
                raise InputError(f"opportunities[{r}]: expected 5 or 7 fields, got {len(row)}")
            t = index.get(row[0], -1) if isinstance(row[0], str) else row[0]
            if t == -1:
                raise InputError(f"opportunities[{r}].target: unknown target {row[0]!r}")
            roll = float(row[4])
            rng = row[5:] if len(row) == 7 else (max(-33.0, roll - 3.0), min(33.0, roll + 3.0))
            cols.append((t, row[1], *map(float, row[2:5]), *map(float, rng)))
        columns = map(list, zip(*cols, strict=True)) if cols else [[]] * 7
        opp = dict(zip(OPP_KEYS, columns, strict=True))
        orb, st, en = opp["orbit"], opp["start"], opp["end"]
        m = n_orbits if n_orbits is not None else (max(orb) + 1 if orb else 1)
        length = orbit_length if orbit_length is not None else max([*en, 0.0]) + 1.0
        lo_start = min([*st, 0.0])
        return cls.from_arrays(
            epoch=epoch,
            target_ids=tids,
            target_lat=np.zeros(len(tids)),
            target_lon=np.zeros(len(tids)),
            target_weight=wts,
            orbit_ids=[f"orbit{j}" for j in range(m)],
            orbit_satellite=["SAT"] * m,
            orbit_start=np.full(m, lo_start),
            orbit_end=np.full(m, length),
            resources=resources or Resources(),
            name=name,
            **{f"opp_{k}": v for k, v in opp.items()},
        )

    # ------------------------------------------------------------ (de)serialise
    def _columns(self) -> dict[str, dict[str, Any]]:
        """The tables as columns in file order (:data:`NPZ_TABLES`): numpy arrays, and tuples
        for the ids; the opportunities' ``target`` and ``orbit`` as row indices."""
        out = {
            table: {k: getattr(self, _attribute(table, k)) for k, _ in spec}
            for table, spec in NPZ_TABLES.items()
        }
        if self.stations:
            out["stations"] = {
                k: (tuple if kind == "U" else np.array)([getattr(s, k) for s in self.stations])
                for k, kind in STATION_TABLES["stations"]
            }
            out["contacts"] = {k: self.contacts[k] for k, _ in STATION_TABLES["contacts"]}
        return out

    def _header(self, fmt: str, version: int) -> dict[str, Any]:
        """The scalar fields of a file (JSON's top level, the .npz header entry)."""
        return {
            "format": fmt,
            "version": version,
            "name": self.name,
            "epoch": self.epoch,
            "meta": dict(self.meta),
            **({"downlink": self.downlink.to_dict()} if self.stations else {}),
        }

    def to_dict(self, layout: str = "records") -> dict[str, Any]:
        """The instance as a JSON-ready dict (``layout`` "records" or "columns")."""
        tables = {
            t: {k: list(v) if isinstance(v, tuple) else v.tolist() for k, v in cols.items()}
            for t, cols in self._columns().items()
        }
        opps = tables["opportunities"]
        opps["target"] = [self.target_ids[i] for i in self.opp_target]
        opps["orbit"] = [self.orbit_ids[j] for j in self.opp_orbit]
        if self.stations:
            con = tables["contacts"]
            con["satellite"] = [self.satellite_names[i] for i in con["satellite"]]
            con["station"] = [self.stations[i].id for i in con["station"]]
        conv = {"records": _to_records, "columns": dict}.get(layout)
        if conv is None:
            raise InputError(f"layout: expected 'records' or 'columns', got {layout!r}")
        return {
            **self._header(FORMAT_NAME, FORMAT_VERSION),
            **{t: conv(cols) for t, cols in tables.items()},
        }

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None) -> Instance:
        """Validate a dict read from an instance file and build the instance."""
        if not isinstance(data, dict):
            raise InputError("expected a JSON object at the top level", source=source)
        _check_header(data, "", source)
        for key in ("targets", "orbits", "opportunities"):
            if key not in data:
                raise InputError(f"missing key {key!r}", source=source)

        # the JSON tables have the columns of the .npz ones; opportunities name their
        # target and orbit by id, contacts their satellite and station
        specs = NPZ_TABLES | (STATION_TABLES if {"stations", "contacts"} & set(data) else {})
        for key in specs:
            if key not in data:
                raise InputError(f"missing key {key!r}", source=source)
        tables = {
            t: _table(data[t], t, tuple(k for k, _ in spec), source) for t, spec in specs.items()
        }
        for t, spec in specs.items():
            for key, kind in spec:
                if key == "description":
                    _strings(tables[t][key], t, key, source)
                elif kind != "U" and key not in ("target", "orbit", "satellite", "station"):
                    _numbers(tables[t][key], t, key, source)
        targets, orbits, opps = (tables[t] for t in NPZ_TABLES)
        for r, v in enumerate(orbits["satellite"]):
            if not isinstance(v, str):
                raise InputError(f"orbits[{r}].satellite: expected a string", source=source)
        targets["id"] = _ids(targets["id"], "targets", source)
        orbits["id"] = _ids(orbits["id"], "orbits", source)
        for key, table in (("target", targets), ("orbit", orbits)):
            index = {t: i for i, t in enumerate(table["id"])}
            opps[key] = _refs(opps[key], index, "opportunities", key, source)
        if "stations" in tables:
            con, ids = tables["contacts"], _ids(tables["stations"]["id"], "stations", source)
            for key, names in (("satellite", dict.fromkeys(orbits["satellite"])), ("station", ids)):
                index = {n: i for i, n in enumerate(names)}
                con[key] = _refs(con[key], index, "contacts", key, source)
        return _from_tables(data, tables, source)

    def to_npz_arrays(self) -> dict[str, np.ndarray]:
        """The instance as the named arrays of a ``.npz`` file (see :data:`NPZ_TABLES`).

        Every column keeps its dtype (float64 times, rolls and coordinates; int64 weights and
        openings; int32 opportunity indices); ids are numpy unicode arrays; ``name``,
        ``epoch`` and ``meta`` go, with the format name and version, into the JSON text of
        the :data:`NPZ_HEADER` entry.

        Raises
        ------
        InputError
            If an id ends with a NUL character, which a numpy unicode array cannot hold.
        """
        header = self._header(NPZ_FORMAT_NAME, NPZ_FORMAT_VERSION)
        out: dict[str, np.ndarray] = {
            # meta keys in their order: a .json saved from a loaded .npz is the same file
            NPZ_HEADER: np.array(json.dumps(header, allow_nan=False))
        }
        for table, cols in self._columns().items():
            for key, value in cols.items():
                name = f"{table}.{key}"
                out[name] = _str_array(value, name) if isinstance(value, tuple) else value
        return out

    def save(self, path: str | os.PathLike[str], layout: str = "auto") -> None:
        """Write the instance file atomically.

        ``layout``: "records", "columns", or "auto" (columns from :data:`COLUMNS_FROM`
        opportunities on, else records). A path ending in ``.gz`` is written gzip-compressed
        (:func:`load_instance` reads it back). A path ending in ``.npz`` is written as numpy
        arrays (:meth:`to_npz_arrays`; ``layout`` does not apply), the fastest to load.
        """
        if layout not in ("auto", "records", "columns"):
            raise InputError(f"layout: expected 'records' or 'columns', got {layout!r}")
        if _is_npz(path):
            _write_npz(path, self.to_npz_arrays())
            return
        big = self.n_opps >= COLUMNS_FROM
        if layout == "auto":
            layout = "columns" if big else "records"
        # big: one line, no indentation: with millions of values the indented text is mostly
        # white space and takes several times longer to write
        indent, separators = (None, (",", ":")) if big else (1, None)
        text = json.dumps(
            self.to_dict(layout), indent=indent, separators=separators, allow_nan=False
        )
        atomic_write_text(path, text + "\n")


def load_instance(path: str | os.PathLike[str]) -> Instance:
    """Read and validate an instance file (``.json`` or ``.json.gz``, either layout, or
    ``.npz``); :class:`InputError` names the file and field."""
    if _is_npz(path):
        return _read_npz(path)
    return Instance.from_dict(read_json(path), source=str(path))


# --------------------------------------------------------------------------- .npz files
def _is_npz(path: str | os.PathLike[str]) -> bool:
    """True for a path the .npz format is written to and read from (``.npz``, any case)."""
    return os.fspath(path).lower().endswith(".npz")


def _str_array(values: tuple[str, ...], key: str) -> np.ndarray:
    """``values`` as a numpy unicode array, refusing what it would not give back."""
    # numpy pads unicode arrays with NUL characters and strips them on reading
    if "\0" in "".join(values):  # rare: look for the row only then
        for r, v in enumerate(values):
            if v.endswith("\0"):
                table, field_ = key.split(".")
                raise InputError(
                    f"{table}[{r}].{field_}: ends with a NUL character, which .npz cannot "
                    "store; save as .json"
                )
    return np.array(values, dtype=str) if values else np.zeros(0, dtype="<U1")


def _write_npz(path: str | os.PathLike[str], arrays: Mapping[str, np.ndarray]) -> None:
    """Write ``arrays`` as a ``.npz`` file atomically (what ``np.savez_compressed`` writes,
    with fixed member time stamps so the same instance always gives the same bytes)."""
    target = Path(path)
    if target.is_dir():
        raise InputError(f"{path} is a folder, not a file")
    compression = zipfile.ZIP_DEFLATED
    # Write into the open temporary file: given a name, numpy would append ".npz" to it.
    with atomic_output(target, suffix=".npz") as tmp, open(tmp, "wb") as fh:
        with zipfile.ZipFile(fh, "w", compression=compression, allowZip64=True) as zf:
            for key, arr in arrays.items():
                info = zipfile.ZipInfo(key + ".npy", date_time=_ZIP_DATE)
                info.compress_type = compression
                info.external_attr = 0o644 << 16
                with zf.open(info, "w", force_zip64=True) as member:
                    np.lib.format.write_array(member, np.asanyarray(arr), allow_pickle=False)
        fh.flush()
        os.fsync(fh.fileno())


#: What reading a damaged zip member or .npy header can raise (zipfile: NotImplementedError
#: for an unknown compression method, RuntimeError for an encrypted member; numpy:
#: MemoryError for a header claiming an absurd shape).
_NPZ_READ_ERRORS = (
    ValueError,
    OSError,
    EOFError,
    KeyError,
    zipfile.BadZipFile,
    zlib.error,
    NotImplementedError,
    RuntimeError,
    MemoryError,
)


def _read_npz(path: str | os.PathLike[str]) -> Instance:
    """Read a ``.npz`` instance (never unpickling) and validate it as :meth:`from_arrays`
    validates any instance; every problem is one :class:`InputError` line naming the array."""
    src = str(path)
    with io.BytesIO(read_bytes(path)) as fh:
        try:
            is_zip = zipfile.is_zipfile(fh)
            fh.seek(0)
            npz = np.load(fh, allow_pickle=False) if is_zip else None
        except _NPZ_READ_ERRORS as exc:
            raise InputError(f"not a .npz file: {exc}", source=src) from None
        if not isinstance(npz, np.lib.npyio.NpzFile):
            raise InputError("not a .npz file (not a zip archive of .npy arrays)", source=src)
        with npz:
            return _instance_from_npz(npz, src)


def _instance_from_npz(npz: Any, src: str) -> Instance:
    """Check the arrays of an open ``NpzFile`` (names, dimensions, dtype kinds, equal lengths
    per table) and hand them to :meth:`Instance.from_arrays`, which checks the values."""
    names = set(npz.files)

    def get(key: str) -> np.ndarray:
        if key not in names:
            raise InputError(f"missing array {key!r}", source=src)
        try:
            arr = npz[key]
        except _NPZ_READ_ERRORS as exc:
            raise InputError(f"{key}: cannot read the array: {exc}", source=src) from None
        if not isinstance(arr, np.ndarray):
            raise InputError(f"{key}: expected a numpy array", source=src)
        return arr

    header = _npz_header(get(NPZ_HEADER), src)
    specs = NPZ_TABLES | (STATION_TABLES if "stations.id" in names else {})
    expected = {NPZ_HEADER} | {f"{t}.{k}" for t, spec in specs.items() for k, _ in spec}
    extra = sorted(names - expected)
    if extra:
        raise InputError(f"unexpected array {extra[0]!r}", source=src)
    tables: dict[str, dict[str, np.ndarray]] = {table: {} for table in specs}
    for table, spec in specs.items():
        for key, kind in spec:
            full = f"{table}.{key}"
            arr = get(full)
            if arr.ndim != 1:
                raise InputError(f"{full}: expected a 1-d array, got shape {arr.shape}", source=src)
            dt = arr.dtype
            if dt.kind not in _NPZ_KINDS[kind] or (kind == "f" and dt.itemsize != 8):
                raise InputError(
                    f"{full}: expected {_NPZ_KIND_NAMES[kind]}, got dtype {dt}", source=src
                )
            n = len(tables[table].get("id", arr))
            if len(arr) != n:
                raise InputError(
                    f"{full}: has {len(arr)} values, expected {n} (as {table}.id)", source=src
                )
            tables[table][key] = arr
    return _from_tables(header, tables, src)


def _as_list(values: Any) -> Any:
    """A numpy column (``.npz``) as a list of Python values; a JSON list as it is."""
    return values.tolist() if isinstance(values, np.ndarray) else values


def _from_tables(
    head: Mapping[str, Any], tables: Mapping[str, Mapping[str, Any]], source: str | None
) -> Instance:
    """:meth:`Instance.from_arrays` from the three tables as columns (JSON and ``.npz``
    readers), the opportunities' target and orbit already resolved to rows by the caller;
    ``head`` holds the epoch, name and meta."""
    cols = {
        _attribute(table, k): _as_list(v) if k in ("id", "satellite") else v
        for table, values in tables.items()
        if table in NPZ_TABLES
        for k, v in values.items()
    }
    return Instance.from_arrays(
        stations=tables.get("stations"),
        contacts=tables.get("contacts"),
        downlink=head.get("downlink"),
        epoch=head["epoch"],
        resources={k: cols.pop(k) for k in RESOURCE_KEYS},
        name=head.get("name", ""),
        meta=head.get("meta", {}),
        source=source,
        **cols,
    )


def _attribute(table: str, key: str) -> str:
    """The :class:`Instance` attribute of a column of :data:`NPZ_TABLES` (``opp_roll`` for
    the opportunities' ``roll``, ``target_ids`` for the targets' ``id``; resources as they
    are)."""
    if key in RESOURCE_KEYS:
        return key
    prefix = {"targets": "target_", "orbits": "orbit_", "opportunities": "opp_"}[table]
    return prefix + ("ids" if key == "id" else key)


def _npz_header(arr: np.ndarray, src: str) -> dict[str, Any]:
    """Parse and check the JSON header entry (format, version, name, epoch, meta)."""
    if arr.dtype.kind != "U" or arr.ndim != 0:
        raise InputError(
            f"{NPZ_HEADER}: expected a JSON string (0-d unicode array), got dtype {arr.dtype} "
            f"shape {arr.shape}",
            source=src,
        )
    try:
        header = json.loads(str(arr), parse_constant=reject_json_constant)
    except ValueError as exc:
        raise InputError(f"{NPZ_HEADER}: malformed JSON: {exc}", source=src) from None
    if not isinstance(header, dict):
        raise InputError(f"{NPZ_HEADER}: expected a JSON object", source=src)
    _check_header(header, NPZ_HEADER, src)
    return header


def _check_header(data: dict[str, Any], where: str, source: str | None) -> None:
    """Check the format, version, epoch, name and meta of an instance file's top level
    (``where`` "") or of a .npz file's header entry (``where`` :data:`NPZ_HEADER`, where the
    format and version must be given)."""
    npz = where == NPZ_HEADER
    fmt, version = (NPZ_FORMAT_NAME, NPZ_FORMAT_VERSION) if npz else (FORMAT_NAME, FORMAT_VERSION)
    at = f"{where}." if where else ""
    got = data.get("format", None if npz else fmt)
    if got != fmt:
        raise InputError(f"{at}format: expected {fmt!r}, got {got!r}", source=source)
    got = data.get("version", None if npz else version)
    if got != version or isinstance(got, bool):
        raise InputError(
            f"{at}version: this sosp reads {'.npz ' if npz else ''}version {version}, got {got!r}",
            source=source,
        )
    if "epoch" not in data:
        raise InputError(f"{where}{': ' if where else ''}missing key 'epoch'", source=source)
    if not isinstance(data.get("name", ""), str):
        raise InputError(f"{at}name: expected a string", source=source)
    if not isinstance(data.get("meta", {}), dict):
        raise InputError(f"{at}meta: expected an object", source=source)


# --------------------------------------------------------------------------- helpers
def _check_epoch(epoch: Any, source: str | None) -> None:
    if not isinstance(epoch, str):
        raise InputError("epoch: expected an ISO 8601 string", source=source)
    try:
        dt = datetime.fromisoformat(epoch.replace("Z", "+00:00"))
    except ValueError:
        raise InputError(f"epoch: not an ISO 8601 time: {epoch!r}", source=source) from None
    if dt.tzinfo is None or dt.utcoffset().total_seconds() != 0:  # type: ignore[union-attr]
        raise InputError(f"epoch: must be UTC (end with Z or +00:00): {epoch!r}", source=source)


def _is_sorted(orbit: np.ndarray, start: np.ndarray, end: np.ndarray) -> bool:
    """True if the rows are in (orbit, start, end) order, where a stable sort keeps them."""
    if orbit.size < 2:
        return True
    o0, o1 = orbit[:-1], orbit[1:]
    s0, s1 = start[:-1], start[1:]
    same_os = (o0 == o1) & (s0 == s1)
    ok = (o0 < o1) | ((o0 == o1) & (s0 < s1)) | (same_os & (end[:-1] <= end[1:]))
    return bool(ok.all())


def _ids(values: Sequence[Any], table: str, source: str | None) -> tuple[str, ...]:
    """The ids as strings, checked non-empty and unique (the first bad row is named)."""
    vals = list(values)
    # Fast path for what the files hold (millions of ids on large instances): all strings,
    # none empty, no duplicate. Anything else goes through the loop that names the row.
    if set(map(type, vals)) <= {str}:
        unique = set(vals)
        if len(unique) == len(vals) and "" not in unique:
            return tuple(vals)
    seen: dict[str, None] = {}  # in order
    for r, v in enumerate(vals):
        if isinstance(v, bool) or not isinstance(v, str | int | np.integer):
            raise InputError(f"{table}[{r}].id: expected a string or integer", source=source)
        s = str(v)
        if not s:
            raise InputError(f"{table}[{r}].id: must not be empty", source=source)
        if s in seen:
            raise InputError(f"{table}[{r}].id: duplicate id {s!r}", source=source)
        seen[s] = None
    return tuple(seen)


def _station_tables(
    stations: Mapping[str, Any] | None,
    contacts: Mapping[str, Any] | None,
    n_sat: int,
    source: str | None,
) -> tuple[tuple[Station, ...], np.ndarray]:
    """The stations and contact windows of :meth:`Instance.from_arrays`, checked."""
    con = np.empty(0 if contacts is None else len(contacts["start_s"]), CONTACT_DTYPE)
    if stations is None or not len(stations["id"]):
        if len(con):
            raise InputError("contacts: given without stations", source=source)
        return (), _readonly(con)
    ids = _ids(stations["id"], "stations", source)
    cols = {k: np.asarray(stations[k], dtype=float) for k, _, _ in CSV_COLUMNS}
    for key, ok, what in CSV_COLUMNS:
        for r, v in enumerate(cols[key]):
            if not ok(float(v)):
                raise InputError(f"stations[{r}].{key}: must be {what}, got {v!r}", source=source)
    desc = [str(d) for d in stations["description"]]
    st = tuple(
        Station(
            sid,
            *(float(cols[k][r]) for k, _, _ in CSV_COLUMNS[:4]),
            antennas=int(cols["antennas"][r]),
            description=desc[r],
        )
        for r, sid in enumerate(ids)
    )
    for k in CONTACT_DTYPE.names:
        con[k] = np.asarray(contacts[k])  # type: ignore[index]
    for key, n in (("satellite", n_sat), ("station", len(st))):
        bad = np.flatnonzero((con[key] < 0) | (con[key] >= n))
        if bad.size:
            raise InputError(
                f"contacts[{bad[0]}].{key}: unknown index {con[key][bad[0]]}", source=source
            )
    bad = np.flatnonzero(~(con["start_s"] < con["end_s"]) | ~np.isfinite(con["max_elevation_deg"]))
    if bad.size:
        raise InputError(f"contacts[{bad[0]}]: need finite start < end", source=source)
    return st, _readonly(con)


def _strings(values: list[Any], table: str, key: str, source: str | None) -> None:
    for r, v in enumerate(values):
        if not isinstance(v, str):
            raise InputError(f"{table}[{r}].{key}: expected a string", source=source)


def _refs(
    values: list[Any], index: dict[str, int], table: str, key: str, source: str | None
) -> list[int]:
    out = []
    for r, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, str | int):
            raise InputError(f"{table}[{r}].{key}: expected an id", source=source)
        try:
            out.append(index[str(v)])
        except KeyError:
            raise InputError(f"{table}[{r}].{key}: unknown {key} {v!r}", source=source) from None
    return out


def _numbers(values: list[Any], table: str, key: str, source: str | None) -> None:
    for r, v in enumerate(values):
        if not is_finite_number(v):
            raise InputError(
                f"{table}[{r}].{key}: expected a finite number, got {v!r}", source=source
            )


def _table(
    value: Any, name: str, keys: tuple[str, ...], source: str | None
) -> dict[str, list[Any]]:
    """Normalise a table given as records or as columns to columns, checking its keys."""
    if isinstance(value, list):
        cols: dict[str, list[Any]] = {k: [] for k in keys}
        for r, rec in enumerate(value):
            if not isinstance(rec, dict):
                raise InputError(f"{name}[{r}]: expected an object", source=source)
            for k in keys:
                if k not in rec:
                    raise InputError(f"{name}[{r}]: missing key {k!r}", source=source)
                cols[k].append(rec[k])
        return cols
    if isinstance(value, dict):
        for k in keys:
            if k not in value:
                raise InputError(f"{name}: missing column {k!r}", source=source)
            if not isinstance(value[k], list):
                raise InputError(f"{name}.{k}: expected a list", source=source)
            if len(value[k]) != len(value[keys[0]]):  # the first column checked first
                n = len(value[keys[0]])
                raise InputError(
                    f"{name}.{k}: has {len(value[k])} values, expected {n}", source=source
                )
        return {k: value[k] for k in keys}
    raise InputError(f"{name}: expected a list of records or an object of columns", source=source)


def _to_records(cols: dict[str, list[Any]]) -> list[dict[str, Any]]:
    keys = list(cols)
    return [dict(zip(keys, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]
