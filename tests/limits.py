"""Wall-clock limits of the unit tests' calls, checked by ``benchmarks/bench_limits_kept.py``.

A unit test never asserts on the wall clock: on a loaded machine (or beside other test
workers) a run that keeps its limit can still take longer to come back. A test that makes a
call with a time limit asserts what the call returns, and hands the time the call took to
:func:`limit_kept`; the benchmark runs those tests (marker ``limits``) one at a time, alone,
and reports each limit as held or not.
"""

from __future__ import annotations

import json
import os

#: The file the benchmark reads (JSON lines); unset, :func:`limit_kept` records nothing.
RECORD_ENV = "SOSP_LIMITS_RECORD"


def limit_kept(label: str, seconds: float, allowed: float) -> None:
    """Record that the call ``label`` of the current test took ``seconds`` of wall time and
    should have taken at most ``allowed``."""
    path = os.environ.get(RECORD_ENV)
    if not path:
        return
    test = os.environ.get("PYTEST_CURRENT_TEST", "?").rsplit(" (", 1)[0]
    row = {"test": test, "case": label, "seconds": float(seconds), "allowed": float(allowed)}
    with open(path, "a", encoding="utf-8") as f:
        f.write(json.dumps(row) + "\n")
