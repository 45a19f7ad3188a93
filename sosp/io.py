"""Small I/O helpers: atomic writes and JSON reading with one-line errors."""

from __future__ import annotations

import csv
import gzip
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sosp.errors import InputError


def _umask() -> int:
    """The process umask (read by setting it and restoring it at once)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def check_output(path: str | os.PathLike[str], option: str = "-o") -> Path:
    """Check that ``path`` can be written as a file before any work is done.

    Refuses a folder, a missing folder and a folder this user cannot write to, with one line
    naming ``option``. Nothing is created.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    target = Path(path)
    if not str(path).strip():
        raise InputError(f"{option}: empty file name")
    if target.is_dir():
        raise InputError(f"{option}: {path} is a folder; give a file name")
    folder = target.parent
    if not folder.is_dir():
        raise InputError(f"{option}: folder does not exist: {folder}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{option}: cannot write to folder {folder} (permission denied)")
    if target.exists() and not os.access(target, os.W_OK):
        raise InputError(f"{option}: {path} is not writable (permission denied)")
    return target


@contextmanager
def atomic_output(path: str | os.PathLike[str], suffix: str = ".tmp") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success it replaces ``path`` atomically.

    For writers that want a file name (``matplotlib`` ``savefig``, ``sqlite3``). The file gets
    the permissions of a normal new file (``0o666`` less the umask), not ``mkstemp``'s
    ``0o600``; on any error the temporary file is removed and ``path`` is left untouched.
    """
    target = Path(path)
    if not target.parent.is_dir():
        raise InputError(f"output folder does not exist: {target.parent}")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=target.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` atomically (temp file in the same folder, fsync, rename).

    A path ending in ``.gz`` is written gzip-compressed (:func:`read_json` reads it back).

    A reader never sees a half-written file, and a crash leaves the old file (or none) behind.
    The file gets the permissions of a normal new file (``0o666`` less the umask).
    """
    target = Path(path)
    if target.is_dir():
        raise InputError(f"{path} is a folder, not a file")
    data = text.encode("utf-8")
    if target.name.endswith(".gz"):  # gzip, transparently (mtime 0: same text, same bytes)
        data = gzip.compress(data, compresslevel=6, mtime=0)
    with atomic_output(target) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def atomic_write_json(path: str | os.PathLike[str], data: Any) -> None:
    """Serialise ``data`` as JSON (strict: no NaN or infinity) and write it atomically."""
    atomic_write_text(path, json.dumps(data, indent=1, allow_nan=False) + "\n")


def reject_json_constant(name: str) -> float:
    """``parse_constant`` for :func:`json.loads`: NaN and Infinity are not JSON."""
    raise ValueError(f"{name} is not valid JSON")


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """A file's content; :class:`InputError` names the file when it is missing, a folder or
    unreadable."""
    src = str(Path(path))
    try:
        return Path(path).read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", source=src) from None
    except IsADirectoryError:
        raise InputError("is a directory, not a file", source=src) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc}", source=src) from None


def read_text(path: str | os.PathLike[str], encoding: str = "utf-8") -> str:
    """A text file's content, gzip-decompressed first when its name ends in ``.gz``;
    :class:`InputError` names the file (see :func:`read_bytes`)."""
    data = read_bytes(path)
    try:
        return (gzip.decompress(data) if str(path).endswith(".gz") else data).decode(encoding)
    except (OSError, UnicodeDecodeError, EOFError) as exc:
        raise InputError(f"cannot read: {exc}", source=str(Path(path))) from None


def read_json(path: str | os.PathLike[str]) -> Any:
    """Read a JSON file, raising :class:`InputError` naming the file and position on failure.

    A file whose name ends in ``.gz`` is gzip-decompressed first.
    """
    text, src = read_text(path), str(Path(path))
    try:
        return json.loads(text, parse_constant=reject_json_constant)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", source=src
        ) from None
    except ValueError as exc:
        raise InputError(f"malformed JSON: {exc}", source=src) from None


def is_finite_number(value: Any) -> bool:
    """True for an int or float (not bool) that is finite."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


#: A numeric column of a CSV table: its name, a test of its values and what the error says
#: they must be (the test must refuse NaN: comparisons do).
Column = tuple[str, Callable[[float], bool], str]


def read_id_table(
    path: str | os.PathLike[str], columns: Sequence[Column], rows_are: str, comments: bool = False
) -> list[tuple[int, str, dict[str, float], dict[str, str]]]:
    """The rows of a CSV table with a header, an ``id`` column and numeric ``columns`` (any
    order; other columns kept as text): per row its line (1-based, blank lines counted), its
    id, its numbers and all its fields. Blank lines are skipped, and with ``comments`` lines
    whose first field starts with ``#``. The targets and the stations files read through it.

    Raises
    ------
    InputError
        Naming the file, the line and the field: an empty file, a column missing from the
        header, a row of the wrong length, an empty or duplicate id, a value that is not a
        number or fails its test, no row after the header (``rows_are`` names the rows).
    """
    src = str(Path(path))
    names = ("id", *(k for k, _, _ in columns))
    expect = f"the header {','.join(names)}"
    lines = csv.reader(read_text(path, encoding="utf-8-sig").splitlines())
    numbered = [
        (i + 1, r)
        for i, r in enumerate(lines)
        if any(c.strip() for c in r) and not (comments and r[0].lstrip().startswith("#"))
    ]
    if not numbered:
        raise InputError(f"empty file: expected {expect}", source=src)
    hline, header = numbered[0]
    cols = [c.strip().lower() for c in header]
    if missing := [c for c in names if c not in cols]:
        raise InputError(
            f"line {hline}: header lacks {', '.join(missing)} (expected {','.join(names)})",
            source=src,
        )
    seen: dict[str, int] = {}
    out = []
    for lineno, row in numbered[1:]:
        if len(row) != len(cols):
            raise InputError(
                f"line {lineno}: expected {len(cols)} fields, got {len(row)}", source=src
            )
        field = dict(zip(cols, (c.strip() for c in row), strict=True))
        if not (rid := field["id"]):
            raise InputError(f"line {lineno}: empty id", source=src)
        if rid in seen:
            raise InputError(
                f"line {lineno}: duplicate id {rid!r} (first on line {seen[rid]})", source=src
            )
        seen[rid] = lineno
        values = {}
        for key, ok, what in columns:
            try:
                values[key] = float(field[key])
            except ValueError:
                raise InputError(
                    f"line {lineno}: {key} is not a number: {field[key]!r}", source=src
                ) from None
            if not ok(values[key]):
                raise InputError(
                    f"line {lineno}: {key} must be {what}, got {field[key]!r}", source=src
                )
        out.append((lineno, rid, values, field))
    if not out:
        raise InputError(f"no {rows_are} after the header", source=src)
    return out
