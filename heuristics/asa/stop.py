"""The stopping criteria, kept importable here; they live in :mod:`sosp.stop`, shared by every
search."""

from sosp.stop import (
    FirstOf,
    Interrupted,
    MaxIterations,
    MaxRuntime,
    NoImprovement,
    SearchStatus,
    StoppingCriterion,
)

__all__ = [
    "FirstOf",
    "Interrupted",
    "MaxIterations",
    "MaxRuntime",
    "NoImprovement",
    "SearchStatus",
    "StoppingCriterion",
]
