"""Parameters of ASA-DTC and its variants (Table 2 of the paper as defaults)."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from sosp.errors import InputError

#: Accepted values of the string switches.
ROLL_RULES = ("midpoint", "nadir")
RULE16_EMPTY = ("capacity", "always", "never")
R_UPDATES = ("accepted", "generated")
OPTION_RULES = ("resources", "feasible-first")
#: The switches: validated as booleans, and read from "true"/"false" (and 1/0, yes/no, on/off)
#: on the command line.
BOOL_FIELDS = ("rule16", "rule16_openings", "replan", "nadir_singles", "orbit_share")

#: Named parameter sets, applied before the caller's own parameters (``preset="quality"``).
#: ``"default"`` is the defaults: Table 2 and the paper's midpoint roll (9). ``"quality"`` is the
#: configuration that came closest to the best known schedules on B10 and C10 in 60 s
#: (``docs/asa.md``, "Whole-orbit re-planning: measured"): rolls closest to nadir for clusters
#: and single opportunities, a cooler temperature (21) than Table 2's, and every re-planning
#: move on a whole orbit, sharing the tasks it covers for free (``orbit_share``). It leaves
#: the paper's rules for schedule quality.
PRESETS: dict[str, dict[str, Any]] = {
    "default": {},
    "quality": {
        "roll_rule": "nadir",
        "nadir_singles": True,
        "rho": 0.2,
        "lambda_min": 0.2,
        "replan_orbit": 1.0,
        "orbit_share": True,
    },
}


@dataclass(frozen=True)
class ASAParams:
    """Every tunable of the search; each can be overridden by a keyword of the solve functions.

    Parameters
    ----------
    lambda_min
        Minimum temperature lambda_min of (21) (Table 2: 0.5).
    rho
        Weight coefficient rho of (21) (Table 2: 1).
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
        candidate cluster-tasks. Default True (``docs/asa.md``: B10, C10, C1 figures);
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
    replan_depth
        Levels of the ejection chain of orbit re-planning with ``replan_pull`` (1: no pull;
        2: the orbits that lost a task are re-planned with unscheduled tasks; 3: they may pull
        in turn, and so on).
    replan_target
        Probability that orbit re-planning takes the stretch around an option of an
        unscheduled task drawn as in step 1 (else a random stretch of a random orbit).
    replan_pair
        Probability that orbit re-planning re-plans two orbits together: the stretch and the
        stretch of the orbit sharing most of its tasks, which orbit takes a shared task being
        decided by Lagrangian relaxation of (2) (DTC and NONTC; STC ignores it).
    replan_floor
        With ``replan``, floor of every neighbourhood probability after (18) (the larger of
        this and ``min_probability``): without it (17) drives a neighbourhood whose moves
        rarely improve (re-planning an already optimal stretch) to zero for good.
    replan_orbit
        ASA-DTC: probability that a re-planning move re-plans a whole orbit exactly
        (``heuristics.asa.orbit``: the recursion of ``sosp.planner`` over the
        clustering-exact candidates at the search's rolls) instead of a stretch. The
        candidates are generated once when the search starts (C10: about 5 s); 0 turns the
        move off. STC and NONTC ignore it.
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
        (``heuristics.asa.orbit``, step 5). Default True: at 60 s it lifted the defaults by
        11 (B10) and 22 (C10) over seeds 0-7 and the quality preset from 1.05 % / 1.22 % to
        0.92 % / 0.59 % below the best known (``docs/asa.md``).
    tabu_length
        L, length of the FIFO tabu list; ``None`` gives ``max(1, N // 50)`` with N the number of
        observable tasks (5.3).
    pool
        Step 1 of the insertion neighbourhood: roulette by weight among the ``pool`` heaviest
        unscheduled non-tabu tasks. ``1`` is the paper's literal deterministic rule.
    migration_pool
        Step 1 of the migration neighbourhood: roulette by number of setup-time conflicts among
        the ``migration_pool`` scheduled tasks with most of them. ``1`` is deterministic.
    roll_rule
        Roll of a cluster-task inside its common range: ``"midpoint"`` (9) or ``"nadir"``.
    nadir_singles
        ASA-DTC only: an option observed alone is rolled to the point of its roll range closest
        to nadir instead of its own roll (the validator accepts any roll in the range, and the
        clustering-exact model does the same, ``docs/asa.md``). ``False``: the paper's single
        task at its own roll. Use with ``roll_rule="nadir"``.
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
    rule16_empty
        Reading of (16) when the orbit has consumed nothing (alpha = beta = 0, degenerate):
        ``"capacity"`` uses alpha = 1/E, beta = 1/W; ``"always"`` lets clustering pass;
        ``"never"`` keeps the literal ``0 < 0`` (clustering refused).
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
        Default 2000 (``docs/asa.md``: with it and ``polish`` C1 reaches its optimum).
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
    min_probability
        Floor applied to each neighbourhood probability after (18) (0 = the paper).
    workers
        Chains run side by side, one process each (``heuristics.asa.parallel``; sosp's, not
        the paper's): 1 is Algorithm 1's single chain. ``iterations`` and ``no_improve``
        count per chain; set it to the number of cores the run may use.
    epochs
        With ``workers > 1``: the limit (time, else iterations) is cut into this many equal
        parts, after each of which the chains behind adopt the best schedule of all. Default
        1: independent chains, the best of ``workers`` runs (six epochs measured no better
        on B10 and C10, ``docs/asa.md``).
    """

    lambda_min: float = 0.5
    rho: float = 1.0
    delta: float = 10.0
    eta: float = 0.8
    itr: int = 10
    pro1: float = 0.5
    pro2: float = 0.5
    replan: bool = True
    pro3: float = 0.5
    replan_opps: int = 40
    replan_pull: float = 0.5
    replan_depth: int = 2
    replan_target: float = 0.0
    replan_pair: float = 0.3
    replan_floor: float = 0.1
    replan_orbit: float = 0.5
    orbit_steal: float = 0.3
    orbit_noise: float = 0.5
    orbit_ascent: int = 10
    orbit_share: bool = True
    tabu_length: int | None = None
    pool: int = 32
    migration_pool: int = 8
    roll_rule: str = "midpoint"
    nadir_singles: bool = False
    rule16: bool = True
    rule16_openings: bool = True
    rule16_empty: str = "capacity"
    r_update: str = "generated"
    option_rule: str = "feasible-first"
    restart: int | None = 2000
    polish: int = 300
    iterations: int | None = None
    no_improve: int | None = None
    trace_every: int = 100
    min_probability: float = 0.0
    workers: int = 1
    epochs: int = 1

    def __post_init__(self) -> None:
        def positive(name: str, strict: bool = True) -> None:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise InputError(f"{name}: expected a finite number, got {v!r}")
            if v < 0 or (strict and v == 0):
                raise InputError(f"{name}: must be {'>' if strict else '>='} 0, got {v!r}")

        def integer(name: str, optional: bool = False, minimum: int = 1) -> None:
            v = getattr(self, name)
            if v is None and optional:
                return
            if isinstance(v, bool) or not isinstance(v, int) or v < minimum:
                raise InputError(f"{name}: expected an integer >= {minimum}, got {v!r}")

        def fraction(name: str) -> None:
            positive(name, strict=False)
            if getattr(self, name) > 1:
                raise InputError(f"{name}: must lie in [0, 1], got {getattr(self, name)!r}")

        positive("lambda_min")
        positive("rho", strict=False)
        positive("delta")
        positive("pro1", strict=False)
        positive("pro2", strict=False)
        positive("pro3", strict=False)
        for name in ("replan_pull", "replan_target", "replan_pair", "replan_orbit", "orbit_steal"):
            fraction(name)
        positive("replan_floor", strict=False)
        if self.replan_floor >= 1 / 3:
            raise InputError(f"replan_floor: must be < 1/3, got {self.replan_floor!r}")
        positive("orbit_noise", strict=False)
        if self.orbit_noise >= 1:
            raise InputError(f"orbit_noise: must lie in [0, 1), got {self.orbit_noise!r}")
        if self.pro1 + self.pro2 + (self.pro3 if self.replan is True else 0.0) <= 0:
            raise InputError("pro1, pro2 (pro3 with replan): at least one must be > 0")
        fraction("eta")
        positive("min_probability", strict=False)
        if self.min_probability >= 0.5:
            raise InputError(f"min_probability: must be < 0.5, got {self.min_probability!r}")
        integer("itr")
        integer("tabu_length", optional=True, minimum=0)
        integer("pool")
        integer("migration_pool")
        integer("replan_opps")
        integer("replan_depth")
        integer("orbit_ascent", minimum=0)
        integer("iterations", optional=True, minimum=0)
        integer("no_improve", optional=True)
        integer("restart", optional=True)
        integer("polish", minimum=0)
        integer("trace_every")
        integer("workers")
        integer("epochs")
        for name, allowed in (
            ("roll_rule", ROLL_RULES),
            ("rule16_empty", RULE16_EMPTY),
            ("r_update", R_UPDATES),
            ("option_rule", OPTION_RULES),
        ):
            if getattr(self, name) not in allowed:
                raise InputError(
                    f"{name}: expected one of {', '.join(allowed)}, got {getattr(self, name)!r}"
                )
        for name in BOOL_FIELDS:
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"{name}: expected true or false, got {getattr(self, name)!r}")

    @classmethod
    def from_kwargs(cls, preset: str | None = None, **kwargs: Any) -> ASAParams:
        """Build from keyword parameters, coercing CLI strings (``--param key=value``).

        ``preset`` names a set of :data:`PRESETS` applied first; the other keywords override
        it (``preset="quality", rho=0.5`` is the quality set with Table 2's rho).
        """
        if preset is not None and preset not in PRESETS:
            raise InputError(f"preset: expected one of {', '.join(PRESETS)}, got {preset!r}")
        known = {f.name: f for f in fields(cls)}
        out: dict[str, Any] = dict(PRESETS[preset]) if preset is not None else {}
        for key, value in kwargs.items():
            if key not in known:
                raise InputError(f"asa: unknown parameter {key!r}")
            out[key] = _coerce(key, value, cls.__dataclass_fields__[key].default)
        return cls(**out)

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def _coerce(key: str, value: Any, default: Any) -> Any:
    """Turn CLI strings into the field's type; other values pass through (then validated)."""
    if not isinstance(value, str):
        return value
    text = value.strip()
    if text.lower() in ("none", "null"):
        return None
    if key in BOOL_FIELDS:
        if text.lower() in ("true", "1", "yes", "on"):
            return True
        if text.lower() in ("false", "0", "no", "off"):
            return False
        raise InputError(f"{key}: expected true or false, got {value!r}")
    if key in ("roll_rule", "rule16_empty", "r_update", "option_rule"):
        return text
    try:
        if key in (
            "itr",
            "tabu_length",
            "pool",
            "migration_pool",
            "replan_opps",
            "replan_depth",
            "orbit_ascent",
            "restart",
            "polish",
            "iterations",
            "no_improve",
            "trace_every",
            "workers",
            "epochs",
        ):
            return int(text)
        return float(text)
    except ValueError:
        raise InputError(f"{key}: expected a number, got {value!r}") from None
