"""What each registered method accepts, read from its parameter dataclass.

A method's parameters are the fields of its dataclass in :data:`sosp.registry.METHODS` (each
made by :func:`sosp.params.param`: default, help, unit), plus the keywords the class names in
``KEYWORDS`` (ASA's ``preset``). ``sosp methods`` lists them; :func:`check_params` is the one
check of a parameter set, used by :func:`sosp.solve.solve` and by ``sosp bench`` before a
campaign starts.
"""

from __future__ import annotations

import dataclasses
import inspect
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from sosp.errors import InputError
from sosp.params import field_types, from_kwargs
from sosp.registry import available_methods, method_function, param_class
from sosp.schedule import jsonable


@dataclass(frozen=True)
class ParamInfo:
    """One parameter of a method: keyword name (``--param NAME=VALUE``), type as text
    (``"int | None"``, ``"'midpoint' | 'nadir'"``), default (JSON-ready), help line, unit."""

    name: str
    type: str
    default: Any
    help: str
    unit: str = ""

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class MethodInfo:
    """A registered method: name, one-line description and parameters."""

    name: str
    help: str
    params: tuple[ParamInfo, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "help": self.help, "params": [p.to_dict() for p in self.params]}

    def keys(self) -> list[str]:
        return [p.name for p in self.params]


def _type_text(hint: Any) -> str:
    """A type hint as text (``Literal`` as its values)."""
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        return " | ".join(repr(a) for a in typing.get_args(hint))
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_text(a) for a in typing.get_args(hint))
    if hint is type(None):
        return "None"
    return hint.__name__ if isinstance(hint, type) else str(hint).replace("typing.", "")


def method_info(method: str) -> MethodInfo:
    """Parameters of ``method`` read from its parameter dataclass.

    Raises
    ------
    InputError
        For an unknown method or one not installed.
    """
    func = method_function(method)
    cls = param_class(method)
    hints = field_types(cls)
    params = [ParamInfo(name, *spec) for name, spec in getattr(cls, "KEYWORDS", {}).items()]
    for f in dataclasses.fields(cls):
        params.append(
            ParamInfo(
                f.name,
                _type_text(hints[f.name]),
                jsonable(f.default),
                f.metadata.get("help", ""),
                f.metadata.get("unit", ""),
            )
        )
    summary = (inspect.getdoc(func) or "").split("\n\n")[0]
    return MethodInfo(method, " ".join(summary.replace("``", "").split()), tuple(params))


def describe_methods() -> list[MethodInfo]:
    """Every registered and installed method, in registry order."""
    return [method_info(m) for m in available_methods()]


def check_params(method: str, params: Mapping[str, Any]) -> None:
    """Check a parameter set of ``method`` before anything runs.

    Unknown keys are refused with the list of valid ones, and the values are checked by
    building the method's parameter dataclass (its own validation, e.g. ASA's ranges and
    presets), so a campaign never stores a run that failed on a typo.

    Raises
    ------
    InputError
        One line naming the method and the parameter at fault.
    """
    valid = method_info(method).keys()
    for key in params:
        if key not in valid:
            raise InputError(
                f"method {method!r} has no parameter {key!r} (valid: "
                f"{', '.join(valid) if valid else 'none'}; see sosp methods)"
            )
    cls = param_class(method)
    # keywords of the function itself that are not the class's (milp-lns's warm_start)
    own = inspect.signature(method_function(method)).parameters
    fields = {f.name for f in dataclasses.fields(cls)}
    kw = {k: v for k, v in params.items() if k in fields or k not in own}
    build: Callable[..., Any] = getattr(cls, "from_kwargs", None) or (
        lambda **kw: from_kwargs(cls, kw, method=method)
    )
    try:
        build(**kw)
    except InputError as exc:
        raise InputError(f"method {method!r}: {exc}") from None
