"""The one table of methods and bounds: a method or a bound is one entry here plus its function.

This module is the one place ``sosp/`` reaches ``models/`` and ``heuristics/``: every entry
names its function (and parameter class) as ``"module:name"``, imported on first use, so the
CLI starts fast and a build without Pyomo or HiGHS still lists what it has. Everything else
(the CLI's choices, ``sosp methods``, ``sosp bound``, what ``solve(..., bound=...)`` accepts,
the methods of :func:`models.solve.bound`) is read from :data:`METHODS` and :data:`BOUNDS`.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from sosp.errors import InputError

#: The model whose optimum is the problem's (``docs/model.md``): the clustering-exact model.
#: A bound of another model (a restriction: fixed cluster-tasks, no clustering) can be below
#: the problem's optimum, so it certifies no schedule.
PROBLEM_MODEL = "cluster"


@dataclass(frozen=True)
class Method:
    """A method: ``function(instance, *, rng, time_limit, **params) -> Result``.

    Attributes
    ----------
    function
        ``"module:name"`` of the solve function.
    params
        ``"module:Class"`` of its parameter dataclass (:class:`sosp.params.Params`).
    model
        The model whose optimum the method's own ``Result.bound`` bounds (None: it claims
        none). A method with a ``model`` parameter (``milp``) bounds the model it is given.
    start
        ``"module:name"`` of its start rule (:data:`sosp.pipeline.StartRule`): its parameters
        -> the :class:`sosp.pipeline.Start` stage run before it, whose schedule it is given
        as ``warm_start`` (None: it takes no start stage).
    kernels
        Whether it runs the numba kernels (:func:`sosp.planner.compile_kernels`, loaded
        before its clock starts: about a second in a fresh process, seconds to compile).
    stations
        Whether it plans downlinks itself on an instance with ground stations (its result
        passes D1-D8 and its bound bounds that problem); otherwise :func:`sosp.solve.solve`
        runs it on the memory allowances and plans the downlinks after it.
    """

    function: str
    params: str = "sosp.params:NoParams"
    model: str | None = None
    start: str | None = None
    kernels: bool = True
    stations: bool = False


@dataclass(frozen=True)
class Bound:
    """A bound: ``function(instance, *, time_limit, lower_bound, workers, **options) -> dict``
    with at least ``{"bound": value}``.

    Attributes
    ----------
    function
        ``"module:name"`` of the bound function.
    help
        One line for ``sosp bound --help``.
    model
        The model whose optimum it bounds: only a bound of :data:`PROBLEM_MODEL` certifies a
        schedule (:data:`CERTIFYING_BOUNDS`).
    options
        Keywords the function is always called with (``method`` of :func:`models.solve.bound`).
    """

    function: str
    help: str
    model: str = PROBLEM_MODEL
    options: Mapping[str, Any] = field(default_factory=dict)


#: Method name -> :class:`Method`, in the order ``sosp methods`` lists them.
METHODS: dict[str, Method] = {
    "greedy": Method("heuristics.greedy:solve_greedy", kernels=False),
    "hpfs-stc": Method("heuristics.hpfs:solve_hpfs_stc", "heuristics.hpfs:HPFSParams"),
    "asa-dtc": Method("heuristics.asa:solve_asa_dtc", "heuristics.asa.params:ASAParams"),
    "asa-stc": Method("heuristics.asa:solve_asa_stc", "heuristics.asa.params:ASAParams"),
    "asa-nontc": Method("heuristics.asa:solve_asa_nontc", "heuristics.asa.params:ASAParams"),
    "rds": Method("heuristics.rds:solve_rds", "heuristics.rds:RDSParams", "task"),
    "rds-stc": Method("heuristics.rds:solve_rds_stc", "heuristics.rds:RDSSTCParams", "static"),
    "sa-stc": Method("heuristics.sa:solve_sa_stc", "heuristics.sa:SAParams"),
    "aco-stc": Method("heuristics.aco:solve_aco_stc", "heuristics.aco:ACOParams"),
    "aco-ls-stc": Method("heuristics.aco:solve_aco_ls_stc", "heuristics.aco:ACOLSParams"),
    "ga-stc": Method("heuristics.ga:solve_ga_stc", "heuristics.ga:GAParams"),
    "ts-stc": Method("heuristics.tabu_search:solve_ts_stc", "heuristics.tabu_search:TSParams"),
    "pba-stc": Method("heuristics.pba:solve_pba_stc", "heuristics.pba:PBAParams", "static"),
    "milp": Method(
        "models.solve:solve_milp",
        "models.solve:MILPParams",
        PROBLEM_MODEL,
        "models.solve:start_stage",
        stations=True,  # models.downlink
    ),  # fmt: skip
    "milp-lns": Method(
        "heuristics.lns:solve_milp_lns",
        "heuristics.lns:LNSParams",
        start="heuristics.lns:start_stage",
    ),
    "orbit-dp": Method(
        "heuristics.orbit_search:solve_orbit_dp", "heuristics.orbit_search:OrbitSearchParams"
    ),
}

#: The method of :func:`sosp.solve.solve` and of ``sosp solve`` when none is named.
DEFAULT_METHOD = "asa-dtc"


def _solve_bound(method: str, help: str) -> Bound:  # noqa: A002 - the bound's help
    """A bound of :func:`models.solve.bound` with ``method=method``."""
    return Bound("models.solve:bound", help, options={"method": method})


#: Bound name -> :class:`Bound`, in the order ``sosp bound --method`` lists them.
BOUNDS: dict[str, Bound] = {
    "auto": _solve_bound(
        "auto",
        "the column-generation bound, then the LP with the time left unless it converged "
        "(the least of the two)",
    ),
    "lp": _solve_bound("lp", "the clique-strengthened LP"),
    "milp": _solve_bound("milp", "the bound of a time-limited MILP"),
    "lagrangian": Bound(
        "models.lagrangian:lagrangian_bound",
        "the Lagrangian relaxation across orbits by dynamic programming (no LP solver)",
    ),
    "colgen": _solve_bound(
        "colgen",
        "Dantzig-Wolfe over orbit plans, then branch and price with the time left (docs/exact.md)",
    ),
    "windows": _solve_bound(
        "windows",
        "the Lagrangian bound over the window relaxation, no candidate list: what auto uses "
        "where the candidates would not fit in memory",
    ),
    "pba": Bound(
        "heuristics.pba:pba_bound",
        "PBA-STC's partition-based bound of the static model (docs/baselines.md)",
        model="static",
    ),
}

#: Bounds of the problem itself (:data:`PROBLEM_MODEL`): what ``solve(..., bound=...)`` and
#: ``sosp solve --bound`` accept.
CERTIFYING_BOUNDS = tuple(name for name, b in BOUNDS.items() if b.model == PROBLEM_MODEL)

#: What fills a delivered schedule back up, for the methods that do not plan downlinks
#: (:func:`sosp.solve.solve` on an instance with stations).
REFILL = "heuristics.refill:refill"


def load(target: str, optional: bool = False) -> Any:
    """The object named by ``"module:name"``, its module imported now; with ``optional``,
    None when that module (or its package) is not installed."""
    module, name = target.split(":")
    try:
        return getattr(importlib.import_module(module), name)
    except ModuleNotFoundError as exc:
        if optional and exc.name and module.startswith(exc.name):
            return None
        raise


def available_methods() -> list[str]:
    """The registered methods whose module is installed."""
    out = []
    for name, m in METHODS.items():
        try:
            if importlib.util.find_spec(m.function.split(":")[0]) is not None:
                out.append(name)
        except ModuleNotFoundError:
            pass
    return out


def _method(method: str) -> Method:
    if method not in METHODS:
        raise InputError(
            f"method: unknown method {method!r} (choose from {', '.join(available_methods())})"
        )
    return METHODS[method]


def method_function(method: str) -> Callable[..., Any]:
    """The solve function of ``method``; :class:`InputError` if unknown or not installed."""
    if (function := load(_method(method).function, optional=True)) is None:
        raise InputError(f"method: {method!r} is not available in this build")
    return function


def param_class(method: str) -> type:
    """The parameter dataclass of ``method`` (:class:`sosp.params.Params`)."""
    return load(_method(method).params)


def bounded_model(method: str, params: Mapping[str, Any]) -> str | None:
    """The model whose optimum ``method``'s own bound bounds with ``params`` (None: none)."""
    model = _method(method).model
    return None if model is None else params.get("model") or model


def uses_kernels(method: str) -> bool:
    """Whether ``method`` runs the numba kernels (:attr:`Method.kernels`)."""
    return _method(method).kernels


def plans_downlinks(method: str) -> bool:
    """Whether ``method`` plans downlinks itself (:attr:`Method.stations`)."""
    return _method(method).stations


def method_start(method: str, instance: Any, params: Mapping[str, Any]) -> Any:
    """The :class:`sosp.pipeline.Start` ``method`` takes on ``instance`` with ``params``
    (None: none)."""
    rule = _method(method).start
    return None if rule is None else load(rule)(instance, params)


def compute_bound(name: str, instance: Any, **kwargs: Any) -> dict[str, Any]:
    """Bound ``name`` of ``instance`` (``kwargs``: ``time_limit``, ``lower_bound``, ...)."""
    if name not in BOUNDS:
        raise InputError(f"bound: unknown method {name!r} (choose from {', '.join(BOUNDS)})")
    b = BOUNDS[name]
    if instance.stations:  # every bound is of the relaxation without them (docs/model.md)
        from sosp.downlink import relaxed_instance

        instance = relaxed_instance(instance)
    return load(b.function)(instance, **b.options, **kwargs)
