"""Run the CLI as ``python -m sosp``."""

import sys

from sosp.cli import main

sys.exit(main())
