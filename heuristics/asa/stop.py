"""The stopping criteria, kept importable here; they live in :mod:`sosp.stop`, shared by every
search."""

from sosp.stop import *  # noqa: F403
