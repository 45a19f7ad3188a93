"""Experiment campaigns: a grid of scenarios x methods x seeds x time limits, run in parallel
and stored in SQLite so that a crash loses nothing finished (``sosp bench``).

Importing this package is light (standard library only); the runner imports the solvers, and
Dask, inside functions.
"""

from sosp.campaign.spec import (
    Campaign,
    MethodSpec,
    RunSpec,
    ScenarioSpec,
    campaign_from_dict,
    campaign_from_options,
    canonical_params,
    load_campaign,
    method_label,
    parse_method,
    parse_seeds,
)
from sosp.campaign.store import SCHEMA_VERSION, Store

__all__ = [
    "SCHEMA_VERSION",
    "Campaign",
    "MethodSpec",
    "RunSpec",
    "ScenarioSpec",
    "Store",
    "campaign_from_dict",
    "campaign_from_options",
    "canonical_params",
    "load_campaign",
    "method_label",
    "parse_method",
    "parse_seeds",
]
