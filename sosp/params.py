"""Method parameters as small validated dataclasses, read from ``--param key=value`` strings.

Every method's parameters are a frozen dataclass (registered in :mod:`sosp.registry`) whose
fields are made by :func:`param`: a default, one line of help and a unit, which ``sosp methods``
prints. :class:`Params` checks each value against its field's type on construction (raising
:class:`~sosp.errors.InputError` naming the field); a subclass adds its ranges in ``check``.
This module converts command-line strings to each field's type *from its type hints*, so no
list of field names is kept by hand: ``bool`` reads true/false (1/0, yes/no, on/off), ``int``
and ``float`` numbers, ``Literal[...]`` one of its values, and ``X | None`` also
``none``/``null``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import types
import typing
from collections.abc import Iterable
from numbers import Integral
from typing import Any, ClassVar, Literal, TypeVar, get_args, get_origin

from sosp.errors import InputError

P = TypeVar("P")

_TRUE = ("true", "1", "yes", "on")
_FALSE = ("false", "0", "no", "off")


def param(default: Any, help: str, unit: str = "") -> Any:  # noqa: A002 - the field's help
    """A dataclass field with its default, its help line and its unit (``sosp methods``)."""
    return dataclasses.field(default=default, metadata={"help": help, "unit": unit})


@dataclasses.dataclass(frozen=True)
class Params:
    """Base of the parameter dataclasses: each value is checked against its field's type
    (:func:`check_types`), then by the subclass's own :meth:`check`."""

    #: Keywords of ``from_kwargs`` that are not fields (ASA's ``preset``): name -> (type,
    #: default, help), for ``sosp methods``.
    KEYWORDS: ClassVar[dict[str, tuple[str, Any, str]]] = {}

    def __post_init__(self) -> None:
        check_types(self)
        self.check()

    def check(self) -> None:
        """Ranges and relations of the values (raise :class:`InputError` naming the field)."""


@dataclasses.dataclass(frozen=True)
class NoParams(Params):
    """A method without parameters."""


def field_types(cls: type) -> dict[str, Any]:
    """The resolved type hint of each dataclass field of ``cls``."""
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)}


def _parts(hint: Any) -> tuple[list[Any], bool]:
    """The non-None members of a union hint, and whether None is allowed."""
    if get_origin(hint) in (typing.Union, types.UnionType):
        args = list(get_args(hint))
        return [a for a in args if a is not type(None)], type(None) in args
    return [hint], False


def choices(hint: Any) -> tuple[Any, ...] | None:
    """The allowed values of a ``Literal[...]`` hint (or ``Literal[...] | None``), else None."""
    return next((get_args(m) for m in _parts(hint)[0] if get_origin(m) is Literal), None)


def coerce(key: str, value: Any, hint: Any) -> Any:
    """Convert a command-line string to the type of ``hint``; other values pass through
    unchanged (the dataclass validates them)."""
    members, optional = _parts(hint)
    if not isinstance(value, str):
        if float in members and isinstance(value, int) and not isinstance(value, bool):
            return float(value)  # 2 for a float field is 2.0
        return value
    text = value.strip()
    if optional and text.lower() in ("none", "null"):
        return None
    if bool in members:
        if text.lower() in _TRUE:
            return True
        if text.lower() in _FALSE:
            return False
        raise InputError(f"{key}: expected true or false, got {value!r}")
    allowed = choices(hint)
    if allowed is not None:
        return text  # checked against the choices by check_types
    if numeric := [m for m in members if m in (int, float)]:
        try:
            return int(text) if numeric[0] is int else float(text)
        except ValueError:
            kind = "an integer" if numeric[0] is int else "a number"
            raise InputError(f"{key}: expected {kind}, got {value!r}") from None
    return text


def check_types(params: Any) -> None:
    """Raise :class:`InputError` for a ``Literal`` field whose value is not one of its
    choices, a ``bool`` field holding anything but True or False, and an ``int``, ``float``
    or ``str`` field not holding one (None where the hint allows it); other hints are the
    subclass's to check."""
    for name, hint in field_types(type(params)).items():
        value = getattr(params, name)
        members, optional = _parts(hint)
        if value is None and optional:
            continue
        allowed = choices(hint)
        if allowed is not None and value not in allowed:
            raise InputError(
                f"{name}: expected one of {', '.join(map(str, allowed))}, got {value!r}"
            )
        if bool in members and not isinstance(value, bool):
            raise InputError(f"{name}: expected true or false, got {value!r}")
        if allowed is not None or bool in members:
            continue
        number = not isinstance(value, bool) and isinstance(value, Integral)  # numpy's too
        if int in members and number:
            continue
        if float in members and (number or isinstance(value, float)):
            continue
        if str in members and isinstance(value, str):
            continue
        kinds = {int: "an integer", float: "a number", str: "text"}
        known = [kinds[m] for m in members if m in kinds]
        if len(known) == len(members):  # every member is one of these: the value is none
            raise InputError(f"{name}: expected {' or '.join(known)}, got {value!r}")


def from_kwargs(
    cls: type[P],
    kwargs: dict[str, Any],
    *,
    method: str,
    base: dict[str, Any] | None = None,
) -> P:
    """Build ``cls`` from keyword parameters (CLI strings converted by the field types).

    ``base`` (e.g. a preset) is applied first and the keywords override it. An unknown key is
    refused with the list of valid ones.
    """
    hints = field_types(cls)
    out: dict[str, Any] = dict(base or {})
    for key, value in kwargs.items():
        if key not in hints:
            raise InputError(
                f"{method}: unknown parameter {key!r} (valid: {', '.join(sorted(hints))})"
            )
        out[key] = coerce(key, value, hints[key])
    return cls(**out)


def positive(kind: type) -> Any:
    """An argparse type: a number of ``kind`` that must be > 0 (NaN refused)."""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a {kind.__name__}, got {text!r}") from None
        if value != value or value <= 0:  # NaN or not positive
            raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
        return value

    parse.__name__ = f"positive {kind.__name__}"
    return parse


def key_values(items: Iterable[str], malformed: str) -> dict[str, Any]:
    """``KEY=VALUE`` items as keyword parameters: VALUE is JSON, else text (stripped), and a
    ``-`` in KEY reads ``_``. An item without ``=`` or key raises :class:`InputError`
    ``"<malformed>, got <item>"``."""
    out: dict[str, Any] = {}
    for item in items:
        key, eq, value = item.partition("=")
        key = key.strip().replace("-", "_")
        if not eq or not key:
            raise InputError(f"{malformed}, got {item!r}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value.strip()
    return out
