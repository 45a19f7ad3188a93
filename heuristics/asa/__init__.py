"""ASA-DTC: adaptive simulated annealing with dynamic task clustering (Wu et al.), and variants.

``solve_asa_dtc`` (dynamic clustering), ``solve_asa_stc`` (static cluster-tasks) and
``solve_asa_nontc`` (no clustering) share one search (Algorithm 1); see ``docs/asa.md``.
"""

from heuristics.asa.accept import AdaptiveTemperature, HillClimbing, Outcome
from heuristics.asa.params import PRESETS, ASAParams
from heuristics.asa.search import TRACE_COLUMNS, run_asa, trace_csv, write_trace_csv
from heuristics.asa.select import AdaptiveRoulette, FixedRoulette
from heuristics.asa.solve import solve_asa_dtc, solve_asa_nontc, solve_asa_stc
from heuristics.asa.tabu import TabuList
from sosp.stop import FirstOf, MaxIterations, MaxRuntime, NoImprovement, SearchStatus

__all__ = [
    "ASAParams",
    "AdaptiveRoulette",
    "AdaptiveTemperature",
    "FirstOf",
    "FixedRoulette",
    "HillClimbing",
    "MaxIterations",
    "MaxRuntime",
    "NoImprovement",
    "Outcome",
    "PRESETS",
    "SearchStatus",
    "TRACE_COLUMNS",
    "TabuList",
    "run_asa",
    "solve_asa_dtc",
    "solve_asa_nontc",
    "solve_asa_stc",
    "trace_csv",
    "write_trace_csv",
]
