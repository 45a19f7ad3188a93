"""Parameters of ASA-DTC and its variants.

The defaults are sosp's best configuration measured across generated instances (rolls closest
to nadir, a cooler temperature (21) than Table 2's, whole-orbit re-planning with shared
coverage); ``preset="paper"`` is the paper's Algorithm 1 with Table 2's parameters, as
published, which the paper campaign and the reproduce-paper notebook use (``docs/asa.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from sosp import params as P
from sosp.errors import InputError
from sosp.params import Params, param
from sosp.rules import RollRule

#: Named parameter sets, applied before the caller's own parameters (``preset="paper"``).
#:
#: * ``"default"``: the defaults (sosp's best measured configuration; ``"quality"`` is kept as
#:   its former name).
#: * ``"paper"``: Algorithm 1 as published: Table 2's parameters (lambda_min, rho), the midpoint
#:   roll (9) with single tasks at their own roll, the paper's two neighbourhoods only, no
#:   restarts. Where the paper is silent or contradicts itself sosp's documented reading stays
#:   (``docs/asa.md``, "Decisions" 2-5 and 8): step 1's roulette among the ``pool`` heaviest
#:   tasks (the literal rule retries a rejected task forever), (16) counting the openings it
#:   saves (the literal rule refuses the clusters the paper's own motivation asks for), the
#:   feasible-first choice of opportunity (the literal one builds an initial solution below
#:   plain greedy), r of (20) updated on every generated move (section 5.2's text).
PRESETS: dict[str, dict[str, Any]] = {
    "default": {},
    "quality": {},
    "paper": {
        "lambda_min": 0.5,
        "rho": 1.0,
        "roll_rule": "midpoint",
        "nadir_singles": False,
        "replan": False,
        "restart": None,
        "init": "greedy",
    },
}

OptionRule = Literal["resources", "feasible-first"]
Candidates = Literal["auto", "explicit", "windows"]


@dataclass(frozen=True)
class ASAParams(Params):
    """Every tunable of the search; each can be overridden by a keyword of the solve functions.

    Parameters
    ----------
    lambda_min
        Minimum temperature lambda_min of (21) (default 0.2; Table 2 and ``preset="paper"``:
        0.5).
    rho
        Weight coefficient rho of (21) (default 0.2; Table 2 and ``preset="paper"``: 1).
    delta
        Rising-rate coefficient delta of (21) (Table 2: 10).
    eta
        Inertial weight eta of (17) (Table 2: 0.8).
    itr
        Iterations between two updates (17)-(18) of the neighbourhood probabilities (Table 2: 10).
    pro1, pro2
        Initial probabilities of the insertion-removal and the migration neighbourhoods
        (Table 2: 0.5 each); normalised by (18).
    replan
        Add sosp's third neighbourhood, orbit re-planning (``heuristics.asa.replan``, not in
        the paper): free a stretch of one orbit and rebuild it by dynamic programming over
        candidate cluster-tasks. Default True (measured in ``docs/asa.md``);
        ``False`` is the paper's Algorithm 1 with its two moves.
    pro3
        Initial probability of orbit re-planning (used when ``replan``), normalised with
        ``pro1`` and ``pro2`` by (18).
    replan_opps
        Orbit re-planning frees a stretch of at most this many consecutive options of the
        orbit (the whole orbit when it has fewer).
    replan_pull
        Orbit re-planning may also take tasks observed on other orbits, each worth this share
        of its weight (0: only unscheduled tasks); the orbits they leave are re-planned next
        (an ejection chain of depth two). DTC and NONTC; STC ignores it.
    replan_pair
        Probability that orbit re-planning re-plans two orbits together: the stretch and the
        stretch of the orbit sharing most of its tasks, which orbit takes a shared task being
        decided by Lagrangian relaxation of (2) (DTC and NONTC; STC ignores it).
    replan_floor
        With ``replan``, floor of every neighbourhood probability after (18) (without
        ``replan``, none: the paper's (17)-(18)): without it (17) drives a neighbourhood whose moves
        rarely improve (re-planning an already optimal stretch) to zero for good.
    replan_orbit
        ASA-DTC: probability that a re-planning move re-plans a whole orbit exactly
        (``heuristics.asa.orbit``: the recursion of ``sosp.planner`` over the
        clustering-exact candidates at the search's rolls) instead of a stretch. The
        candidates are generated once when the search starts; 0 turns the
        move off. Default 1 (every re-planning move on a whole orbit). STC and NONTC ignore it.
    orbit_steal
        Whole-orbit re-planning: probability that a target scheduled on another orbit keeps
        its weight for the re-planned orbit (else it is worth nothing to it); the orbits that
        lose a target are re-planned next.
    orbit_noise
        Whole-orbit re-planning: the drawn orbit's prices are multiplied by
        U(1 - orbit_noise, 1 + orbit_noise), in [0, 1) (0: exact prices; the move is then a
        no-op on an orbit that is already optimal for the others).
    orbit_ascent
        Whole-orbit re-planning: after the drawn orbit, re-plan at most this many more (the
        orbits that lost a task to it, then those seeing a task it let go, and so on), each
        kept only when it gains (0: the drawn orbit and nothing else).
    orbit_share
        Whole-orbit re-planning: a task the drawn orbit's plan covers while another orbit
        keeps it is shared for the rest of the move: the orbit keeping it is re-planned with
        it worth nothing, and a task it lets go joins the drawn orbit's observation
        (``heuristics.asa.orbit``, step 5). Default True (measured in ``docs/asa.md``).
    tabu_length
        L, length of the FIFO tabu list; ``None`` gives ``max(1, N // 50)`` with N the number of
        observable tasks (5.3).
    pool
        Step 1 of the insertion neighbourhood: roulette by weight among the ``pool`` heaviest
        unscheduled non-tabu tasks. ``1`` is the paper's literal deterministic rule.
    roll_rule
        Roll of a cluster-task inside its common range: ``"nadir"`` (default: the point
        closest to nadir, never more slew or energy) or the paper's ``"midpoint"`` (9).
    nadir_singles
        ASA-DTC only: an option observed alone is rolled to the point of its roll range closest
        to nadir instead of its own roll (the validator accepts any roll in the range, and the
        clustering-exact model does the same, ``docs/asa.md``). Default True; ``False``: the
        paper's single task at its own roll.
    rule16
        Apply the effectiveness test (16) to clustering insertion (``False``: (7), (11) only).
    rule16_openings
        Count the sensor openings (6) as a third resource in (16), beside energy and memory:
        gamma * 1 (clustered) against gamma * 2 (separate), gamma = openings used / c (1/c on
        an orbit that has used nothing). The paper weighs energy and memory only (default
        False); with openings binding (the B scenarios) the literal rule refuses clusters the
        schedule needs (``docs/asa.md``, decision 3). Default True: sosp's reading, which the
        paper's own motivation for clustering supports (section 1: "finish more tasks at the
        cost of fewer sensor opening times"); False is the literal rule.
    r_update
        When the bad-move counter r of (20) is updated: ``"accepted"`` on accepted moves only
        (Algorithm 1, lines 13 and 23), ``"generated"`` on every generated move.
    option_rule
        Which opportunity steps 2-6 of the insertion neighbourhood take: ``"resources"`` is the
        paper's literal rule (clustering insertion first, then the orbit with most resources
        left); ``"feasible-first"`` ranks first the opportunities that fit without removing
        anything, then applies the paper's rule (see ``docs/asa.md``).
    restart
        Every ``restart`` iterations without a new best, make the best solution the current one
        again (sosp's intensification, not in the paper; ``None``: never, Algorithm 1).
        Default 2000 (measured in ``docs/asa.md``).
    polish
        At each restart, try two-orbit re-planning (``heuristics.asa.replan.polish``) on up
        to this many pairs of orbits sharing options, keeping what loses nothing (0: none).
        With whole-orbit re-planning (``replan_orbit``) the restart re-plans every orbit
        exactly until none gains instead (``heuristics.asa.orbit.ascend``).
    iterations
        Stop after this many iterations (``None``: no limit from this rule).
    no_improve
        Stop after this many iterations without a new best (``None``: no limit).
    trace_every
        Record a trace row every this many iterations (and at each new best).
    candidates
        What the whole-orbit move plans over, as ``orbit-dp``'s parameter of that name:
        ``"explicit"``, every candidate observation made once (the exact single-orbit
        optimum); ``"windows"``, none made up front, each plan prices the orbit's windows
        (``sosp.windows.window_plan``, a restricted set); ``"auto"`` (default): explicit
        unless the candidates would not fit in memory or in half the time limit.
    init
        How the search starts. ``"greedy"``: section 5.4's insertion of every task by
        decreasing weight (the paper's). ``"orbit-dp"`` (sosp's, not the paper's): the
        iterated local search of ``orbit-dp`` (``sosp.ascent.iterate``) over the
        whole-orbit move's candidates, for ``init_share`` of the time limit, then section
        5.4's insertion on what is left; the annealing continues from there. ``"lp"``
        (default): the same, the search started from the plans of the column-generation root
        (``heuristics.orbit_search.lp_start``; ``docs/asa.md``, "Start from the root"); over
        window candidates, from HPFS-STC's schedule first and then the root's plans where
        the share has time left (``heuristics.orbit_search.hpfs_start``).
        Both need the whole-orbit move (``replan``, ``replan_orbit > 0``, ASA-DTC);
        otherwise ``"greedy"``.
    init_share
        Share of the time limit the ``"orbit-dp"`` or ``"lp"`` start may take, candidate
        generation included (in (0, 1]; default 0.3). Without a time limit the start stops after
        :data:`heuristics.asa.orbit.INIT_NO_IMPROVE` steps without a gain.
    workers
        Chains run side by side, one process each (``heuristics.asa.parallel``; sosp's, not
        the paper's): 1 is Algorithm 1's single chain. ``iterations`` and ``no_improve``
        count per chain; set it to the number of cores the run may use.
    """

    #: ``from_kwargs``'s keyword beside the fields, for ``sosp methods``.
    KEYWORDS: ClassVar[dict[str, tuple[str, Any, str]]] = {
        "preset": (
            " | ".join(map(repr, PRESETS)) + " | None",
            None,
            "A named set of parameters applied first; the other keywords override it: "
            + "; ".join(
                f"{k}: {', '.join(f'{a}={v}' for a, v in p.items()) or 'the defaults'}"
                for k, p in PRESETS.items()
            ),
        )
    }

    lambda_min: float = param(0.2, "Minimum temperature of (21) (Table 2, preset paper: 0.5).")
    rho: float = param(0.2, "Weight coefficient of (21) (Table 2, preset paper: 1).")
    delta: float = param(10.0, "Rising-rate coefficient delta of (21) (Table 2: 10).")
    eta: float = param(0.8, "Inertial weight eta of (17) (Table 2: 0.8).")
    itr: int = param(10, "Iterations between two updates (17)-(18) of the probabilities.")
    pro1: float = param(0.5, "Initial probability of insertion-removal (Table 2: 0.5).")
    pro2: float = param(0.5, "Initial probability of migration (Table 2: 0.5).")
    replan: bool = param(True, "Add sosp's third neighbourhood, orbit re-planning.")
    pro3: float = param(0.5, "Initial probability of orbit re-planning (with replan).")
    replan_opps: int = param(40, "Most consecutive options of a re-planned stretch.")
    replan_pull: float = param(0.5, "Share of its weight a task scheduled elsewhere keeps.")
    replan_pair: float = param(0.3, "Probability of re-planning two orbits together.")
    replan_floor: float = param(0.1, "With replan, floor of each probability after (18).")
    replan_orbit: float = param(1.0, "ASA-DTC: probability of re-planning a whole orbit.")
    orbit_steal: float = param(0.3, "Probability a target scheduled elsewhere keeps its weight.")
    orbit_noise: float = param(0.5, "Price noise of whole-orbit re-planning, in [0, 1).")
    orbit_ascent: int = param(10, "More orbits re-planned after the drawn one, at most.")
    orbit_share: bool = param(True, "Share a task two orbits' plans cover for the move.")
    tabu_length: int | None = param(None, "FIFO tabu list length (None: max(1, N // 50)).")
    pool: int = param(32, "Insertion step 1: roulette among this many heaviest tasks.")
    roll_rule: RollRule = param("nadir", "Roll of a cluster-task: 'nadir' or 'midpoint' (9).")
    nadir_singles: bool = param(True, "ASA-DTC: roll a lone option closest to nadir.")
    rule16: bool = param(True, "Apply the effectiveness test (16) to clustering insertion.")
    rule16_openings: bool = param(True, "Count the openings (6) as a resource in (16).")
    r_update: Literal["accepted", "generated"] = param("generated", "When r of (20) is updated.")
    option_rule: OptionRule = param("feasible-first", "Opportunity choice of insertion.")
    restart: int | None = param(2000, "Back to the best after this many idle iterations.")
    polish: int = param(300, "Orbit pairs re-planned at each restart, at most.")
    iterations: int | None = param(None, "Stop after this many iterations (None: no limit).")
    no_improve: int | None = param(None, "Stop after this many without a new best.")
    trace_every: int = param(100, "Record a trace row every this many iterations.")
    candidates: Candidates = param("auto", "Candidates of the whole-orbit moves.")
    init: Literal["greedy", "orbit-dp", "lp"] = param("lp", "How the search starts.")
    init_share: float = param(0.3, "Share of the limit the orbit-dp or lp start may take.")
    workers: int = param(1, "Chains run side by side, one process each.")

    def check(self) -> None:
        # check_types has made each int field an integer (or None where allowed) and each
        # float field a number: what is left are the ranges
        ranges = (
            ("lambda_min delta", "a number > 0", lambda v: v > 0),
            ("rho pro1 pro2 pro3", "a number >= 0", lambda v: v >= 0),
            ("replan_pull replan_pair replan_orbit", "a number in [0, 1]", lambda v: 0 <= v <= 1),
            ("orbit_steal eta", "a number in [0, 1]", lambda v: 0 <= v <= 1),
            ("init_share", "a number in (0, 1]", lambda v: 0 < v <= 1),
            ("replan_floor", "a number in [0, 1/3)", lambda v: 0 <= v < 1 / 3),
            ("orbit_noise", "a number in [0, 1)", lambda v: 0 <= v < 1),
            ("itr pool replan_opps no_improve", "an integer >= 1", lambda v: v >= 1),
            ("restart trace_every workers", "an integer >= 1", lambda v: v >= 1),
            ("tabu_length orbit_ascent iterations polish", "an integer >= 0", lambda v: v >= 0),
        )
        for names, text, ok in ranges:
            for name in names.split():
                v = getattr(self, name)
                if v is not None and not (math.isfinite(v) and ok(v)):
                    raise InputError(f"{name}: expected {text}, got {v!r}")
        if self.pro1 + self.pro2 + (self.pro3 if self.replan else 0.0) <= 0:
            raise InputError("pro1, pro2 (pro3 with replan): at least one must be > 0")

    @classmethod
    def from_kwargs(cls, preset: str | None = None, **kwargs: Any) -> ASAParams:
        """Build from keyword parameters, coercing CLI strings (``--param key=value``) by the
        fields' type hints.

        ``preset`` names a set of :data:`PRESETS` applied first; the other keywords override
        it (``preset="paper", workers=2`` is the paper's configuration on two chains).
        """
        if preset is not None and preset not in PRESETS:
            raise InputError(f"preset: expected one of {', '.join(PRESETS)}, got {preset!r}")
        base = PRESETS[preset] if preset is not None else {}
        return P.from_kwargs(cls, kwargs, method="asa", base=base)
