"""Numba kernels compiled on first use: one explicit signature each, cached on disk.

A kernel written as plain Python (``*_py``, also runnable and testable without numba) is
compiled by :func:`compiled` the first time it is asked for: numba's import and the load
from its disk cache cost about 0.5 s a process, a first compilation on a machine seconds,
so neither is paid by a process that never needs the kernel, and
:func:`sosp.planner.compile_kernels` pays both before the solvers' clocks start. One
signature per kernel means one compilation, whatever arrays the callers hold.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any


@cache
def compiled(py_func: Callable[..., Any], signature: str) -> Callable[..., Any]:
    """``py_func`` compiled by numba for ``signature`` (a numba signature string), once per
    process and cached on disk."""
    from numba import njit

    return njit(signature, cache=True)(py_func)
