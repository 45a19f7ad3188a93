"""sosp: scheduling Earth-observing satellites (Wu et al., ASA-DTC, and beyond).

The core API::

    from sosp import Instance, Resources, Schedule, Observation, load_instance, load_schedule
    from sosp import validate, solve

Importing :mod:`sosp` is light: Pyomo, HiGHS and the solvers load only when a method runs.
"""

from sosp.errors import InputError, SospError
from sosp.instance import Instance, Resources, load_instance
from sosp.registry import METHODS
from sosp.replanning import replan
from sosp.result import Result, Status
from sosp.schedule import Observation, Schedule, load_schedule, make_observation
from sosp.solve import solve
from sosp.validate import ValidationReport, Violation, validate

__version__ = "0.1.0"

__all__ = [
    "METHODS",
    "InputError",
    "Instance",
    "Observation",
    "Resources",
    "Result",
    "Schedule",
    "SospError",
    "Status",
    "ValidationReport",
    "Violation",
    "__version__",
    "load_instance",
    "load_schedule",
    "make_observation",
    "replan",
    "solve",
    "validate",
]
