"""Run the CLI as ``python -m sosp``."""

from sosp.cli import run

run()
