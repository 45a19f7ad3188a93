"""What each registered method accepts: parameters, types, defaults and one-line help.

Everything here is read from the code, never from a hand-kept table: a method's keyword
parameters come from its function's signature, and a method taking ``**params`` reads them
into the parameter dataclass registered in :data:`sosp.solve.PARAM_CLASSES` (its fields, plus
the extra keywords of its ``from_kwargs``). Types come from the annotations, defaults from the
signature or the field, and the help line from the numpydoc ``Parameters`` section of the
class or function docstring (its first sentence).

:func:`check_params` is the one check of a parameter set, used by :func:`sosp.solve.solve`
and by ``sosp bench`` before a campaign starts.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from sosp.errors import InputError

#: Keywords every method receives from :func:`sosp.solve.solve`, not user parameters.
RESERVED = ("instance", "rng", "time_limit")


@dataclass(frozen=True)
class ParamInfo:
    """One parameter of a method.

    Attributes
    ----------
    name
        Keyword name (``--param NAME=VALUE`` on the command line).
    type
        The annotation as text (``"float"``, ``"int | None"``, ``"'midpoint' | 'nadir'"``).
    default
        The default value (JSON-ready).
    help
        One line: the first sentence of the parameter's docstring entry.
    """

    name: str
    type: str
    default: Any
    help: str

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


# --------------------------------------------------------------------------- docstrings
_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")


def _clean(text: str) -> str:
    """Docstring text as plain one-line text (roles and double backquotes removed)."""
    text = _ROLE.sub(lambda m: m.group(1).rsplit(".", 1)[-1], text)
    return " ".join(text.replace("``", "").split())


def _first_sentence(text: str) -> str:
    text = _clean(text)
    depth = 0
    for i, ch in enumerate(text):
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth = max(0, depth - 1)
        elif ch == "." and depth == 0 and (i + 1 == len(text) or text[i + 1] == " "):
            # "e.g." and "i.e." are not the end of a sentence
            if not text[max(0, i - 3) : i + 1].endswith(("e.g.", "i.e.")):
                return text[: i + 1]
    return text


def param_docs(doc: str | None) -> dict[str, str]:
    """Map each name of a numpydoc ``Parameters`` section to its description's first sentence.

    An entry naming several parameters (``pro1, pro2``) gives each the same line.
    """
    if not doc:
        return {}
    lines = inspect.cleandoc(doc).splitlines()
    out: dict[str, str] = {}
    try:
        start = next(
            i
            for i, line in enumerate(lines[:-1])
            if line.strip() == "Parameters" and _is_rule(lines[i + 1])
        )
    except StopIteration:
        return {}
    end = len(lines)
    for j in range(start + 2, len(lines) - 1):
        if lines[j].strip() and not lines[j].startswith(" ") and _is_rule(lines[j + 1]):
            end = j  # the next section's title
            break
    names: list[str] = []
    body: list[str] = []
    for line in [*lines[start + 2 : end], "END"]:
        if line and not line.startswith(" "):
            for n in names:
                out[n] = _first_sentence(" ".join(body))
            head = line.split(":")[0]
            names = [n.strip().lstrip("*") for n in head.split(",") if n.strip()]
            body = []
        elif line.strip():
            body.append(line.strip())
    return out


def _is_rule(line: str) -> bool:
    """Whether a docstring line is a section underline (``----------``)."""
    return bool(line.strip()) and set(line.strip()) == {"-"}


def _follow(func: Any, name: str, text: str) -> str:
    """Resolve an entry ``See Other.`` to ``Other``'s own entry for ``name`` when it has one."""
    m = re.fullmatch(r"See ([A-Za-z_][\w.]*)\.?", text)
    if not m:
        return text
    obj: Any = inspect.getmodule(func)
    for part in m.group(1).rstrip(".").split("."):
        obj = getattr(obj, part, None)
    return param_docs(getattr(obj, "__doc__", None)).get(name, text) if obj is not None else text


def _mentions(doc: str | None, name: str) -> str:
    """The first sentence of ``doc`` mentioning ````name````, for keywords with no entry."""
    if not doc:
        return ""
    text = " ".join(inspect.cleandoc(doc).split())
    for sentence in re.split(r"(?<=[.;])\s+", text):
        if f"``{name}``" in sentence:
            return _first_sentence(sentence.rstrip(";") + ".")
    return ""


# --------------------------------------------------------------------------- types, defaults
def _type_text(hint: Any, raw: Any) -> str:
    """A type hint as text (``Literal`` as its values); ``raw`` (the annotation string) when
    the hint could not be resolved."""
    if hint is inspect.Parameter.empty or hint is None:
        return "" if raw is inspect.Parameter.empty else str(raw)
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        return " | ".join(repr(a) for a in typing.get_args(hint))
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_type_text(a, a) for a in typing.get_args(hint))
    if hint is type(None):
        return "None"
    if isinstance(hint, type):
        return hint.__name__
    return str(raw if isinstance(raw, str) else hint).replace("typing.", "")


def _hints(obj: Any) -> dict[str, Any]:
    try:
        return typing.get_type_hints(obj)
    except Exception:  # noqa: BLE001 - forward references that cannot resolve: use the text
        return {}


def _jsonable(value: Any) -> Any:
    if value is dataclasses.MISSING or value is inspect.Parameter.empty:
        return None
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    return str(value)


# --------------------------------------------------------------------------- registry
def param_class(method: str) -> type | None:
    """The parameter dataclass a ``**params`` method reads its keywords into, if registered."""
    from sosp.solve import PARAM_CLASSES

    target = PARAM_CLASSES.get(method)
    if target is None:
        return None
    module, name = target.split(":")
    return getattr(importlib.import_module(module), name)


def method_info(method: str) -> MethodInfo:
    """Parameters of ``method`` read from its signature and parameter dataclass.

    Raises
    ------
    InputError
        For an unknown method or one not installed.
    """
    from sosp.solve import method_function

    func = method_function(method)
    sig = inspect.signature(func)
    hints = _hints(func)
    docs = {k: _follow(func, k, v) for k, v in param_docs(func.__doc__).items()}
    params: list[ParamInfo] = []
    for p in sig.parameters.values():
        if p.name in RESERVED or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            continue
        params.append(
            ParamInfo(
                p.name,
                _type_text(hints.get(p.name, p.annotation), p.annotation),
                _jsonable(p.default),
                docs.get(p.name, ""),
            )
        )
    cls = param_class(method)
    if cls is not None:
        cdocs = param_docs(cls.__doc__)
        chints = _hints(cls)
        builder = getattr(cls, "from_kwargs", None)
        if builder is not None:  # extra keywords of from_kwargs (e.g. ASA's preset)
            bsig = inspect.signature(builder)
            bhints = _hints(builder)
            module = inspect.getmodule(cls)
            for p in bsig.parameters.values():
                if p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL) or p.name == "cls":
                    continue
                # A keyword naming an entry of a module table (preset -> PRESETS): its keys.
                table = getattr(module, f"{p.name.upper()}S", None)
                type_text = _type_text(bhints.get(p.name, p.annotation), p.annotation)
                if isinstance(table, dict) and table:
                    type_text = " | ".join(repr(k) for k in table) + (
                        " | None" if "None" in type_text else ""
                    )
                params.append(
                    ParamInfo(
                        p.name,
                        type_text,
                        _jsonable(p.default),
                        cdocs.get(p.name)
                        or _mentions(builder.__doc__, p.name)
                        or _mentions(func.__doc__, p.name),
                    )
                )
        for f in dataclasses.fields(cls):
            default = f.default
            if default is dataclasses.MISSING and f.default_factory is not dataclasses.MISSING:
                default = f.default_factory()
            params.append(
                ParamInfo(
                    f.name,
                    _type_text(chints.get(f.name, f.type), f.type),
                    _jsonable(default),
                    cdocs.get(f.name, ""),
                )
            )
    doc = inspect.getdoc(func) or ""
    return MethodInfo(method, _first_sentence(doc.split("\n\n")[0]), tuple(params))


def describe_methods() -> list[MethodInfo]:
    """Every registered and installed method (:data:`sosp.solve.METHODS`), in registry order."""
    from sosp.solve import available_methods

    return [method_info(m) for m in available_methods()]


def check_params(method: str, params: Mapping[str, Any]) -> None:
    """Check a parameter set of ``method`` before anything runs.

    Unknown keys are refused with the list of valid ones; a method with a registered parameter
    dataclass also has its values checked (the dataclass's own validation, e.g. ASA's ranges
    and presets), so a campaign never stores a run that failed on a typo.

    Raises
    ------
    InputError
        One line naming the method and the parameter at fault.
    """
    from sosp.solve import method_function

    func = method_function(method)
    info = method_info(method)
    valid = info.keys()
    sig = inspect.signature(func).parameters
    cls = param_class(method)
    if cls is None and any(p.kind is p.VAR_KEYWORD for p in sig.values()):
        return  # keywords the method reads itself: it checks them
    for key in params:
        if key not in valid:
            raise InputError(
                f"method {method!r} has no parameter {key!r} (valid: "
                f"{', '.join(valid) if valid else 'none'}; see sosp methods)"
            )
    if cls is None:
        return
    own = {k: v for k, v in params.items() if k not in sig}
    build: Callable[..., Any] = getattr(cls, "from_kwargs", cls)
    try:
        build(**own)
    except InputError as exc:
        raise InputError(f"method {method!r}: {exc}") from None
