"""Candidate observations (sosp.candidates): an orbit's candidates cut to a stretch."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sosp.candidates import OppGroups, OrbitCandidates, orbit_candidates
from sosp.rules import EPS
from tests.conftest import tiny_cluster


def _within_reference(
    cands: OrbitCandidates, opts: list[int], t0: float, t1: float
) -> list[tuple[int, ...]]:
    """:meth:`OrbitCandidates.within` read literally: in order, inside the span, cut, once."""
    allowed = set(opts)
    out: list[tuple[int, ...]] = []
    for v in range(cands.size):
        if not (t0 - EPS <= cands.start[v] <= t1 + EPS and cands.end[v] <= t1 + EPS):
            continue
        cut = tuple(x for x in cands.opps[v] if x in allowed)
        if cut and cut not in out:
            out.append(cut)
    return out


def _groups(ptr: np.ndarray, flat: np.ndarray) -> list[tuple[int, ...]]:
    return [tuple(flat[ptr[v] : ptr[v + 1]].tolist()) for v in range(len(ptr) - 1)]


@st.composite
def _orbit_candidates(draw: st.DrawFn) -> tuple[OrbitCandidates, int]:
    """Random candidates (sorted by start) over few options, so that many cut alike."""
    n_options = draw(st.integers(1, 8))
    n = draw(st.integers(0, 30))
    start = np.sort(np.asarray(draw(st.lists(st.integers(0, 20), min_size=n, max_size=n)), float))
    length = draw(st.lists(st.integers(0, 6), min_size=n, max_size=n))
    members = [
        tuple(sorted(draw(st.sets(st.integers(0, n_options - 1), min_size=1, max_size=4))))
        for _ in range(n)
    ]
    cands = OrbitCandidates(
        orbit=0,
        start=start,
        end=start + np.asarray(length, float),
        roll=np.zeros(n),
        opps=OppGroups.from_groups(members) if n else OppGroups(np.zeros(1), np.zeros(0)),
    )
    return cands, n_options


@settings(max_examples=300, deadline=None)
@given(_orbit_candidates(), st.data())
def test_within_equals_its_definition(drawn: tuple[OrbitCandidates, int], data: st.DataObject):
    cands, n_options = drawn
    opts = data.draw(st.lists(st.integers(0, n_options - 1), unique=True, max_size=n_options))
    t0 = data.draw(st.integers(-2, 22))
    t1 = data.draw(st.integers(t0, 30))
    ptr, flat = cands.within(np.asarray(opts, dtype=np.int64), n_options, t0, t1)
    assert ptr.dtype == flat.dtype == np.int64
    assert _groups(ptr, flat) == _within_reference(cands, opts, t0, t1)


def test_within_on_a_real_orbit():
    """The tiny cluster fixture's orbit: every option allowed gives back the candidates."""
    inst = tiny_cluster()
    cands = orbit_candidates(inst, 0)
    n = inst.n_opps
    opts = np.arange(n, dtype=np.int64)
    t0, t1 = float(cands.start.min()), float(cands.end.max())
    ptr, flat = cands.within(opts, n, t0, t1)
    assert _groups(ptr, flat) == [tuple(g) for g in cands.opps]
    # without the first option, no group holds it and none is empty
    ptr, flat = cands.within(opts[1:], n, t0, t1)
    assert 0 not in flat.tolist() and np.all(np.diff(ptr) > 0)
    assert _groups(ptr, flat) == _within_reference(cands, list(range(1, n)), t0, t1)


def test_generation_gives_up_when_the_orbits_left_are_foreseen_past_the_deadline(
    monkeypatch,
    c3,
) -> None:
    """After the first orbit, the rest foreseen (at its rate) past the deadline: the error
    comes at once, with the other orbits not generated; with room to spare, all are."""
    import time

    import pytest

    import sosp.candidates as cands
    from sosp.errors import TimeLimitReached

    inst = c3
    monkeypatch.setattr(cands, "FORESIGHT_AFTER_S", 0.0)
    # a deadline far off, but a margin that foresees any rate as too slow for it
    monkeypatch.setattr(cands, "FORESIGHT_MARGIN", 1e-12)
    with pytest.raises(TimeLimitReached, match="foreseen"):
        cands.cluster_candidates(inst, None, deadline=time.perf_counter() + 3600.0)
    made = [j for j in range(inst.n_orbits) if cands.cached_orbit_candidates(inst, j)]
    assert made == [0]
    monkeypatch.setattr(cands, "FORESIGHT_MARGIN", 1.25)
    got = cands.cluster_candidates(inst, None, deadline=time.perf_counter() + 3600.0)
    assert len(got[0]) > 0 and inst.n_orbits > 2


def _slow_samples(monkeypatch, cands, seconds: float) -> list[float]:
    """Every orbit sampled, each sample taking the list's last value (``seconds`` first);
    the list grows by one value a sample."""
    import time

    real, made = cands._start_counts, [seconds]

    def slow(*args):
        made.append(made[-1])
        time.sleep(made[-1])
        return real(*args)

    monkeypatch.setattr(cands, "_SAMPLE_FROM", 0)
    monkeypatch.setattr(cands, "_start_counts", slow)
    return made


def test_auto_plans_over_windows_when_the_estimate_alone_would_not_fit(monkeypatch, c3) -> None:
    """``auto`` with a deadline: an estimate foreseen (at the rate of its first sample) to
    take more than its share of the time left means windows, after that one sample and with
    nothing estimated; without a deadline, or with room, the estimate decides as before
    (C3's candidates fit: explicit)."""
    import time

    import sosp.candidates as cands

    inst = c3
    made = _slow_samples(monkeypatch, cands, 0.05)
    assert sum(len(p) for _, p in cands._samples(inst)) * 0.05 > 1.0  # past 2 s / 4
    assert cands.candidate_mode(inst, "auto", time.perf_counter() + 2.0) == "windows"
    assert "need" not in cands._cache_of(inst) and len(made) == 2  # one sample
    made.append(0.0)  # samples at no cost from here
    assert cands.candidate_mode(inst, "auto") == "explicit"
    cands._cache_of(inst).pop("need")
    soon = time.perf_counter() + 600.0
    assert cands.candidate_mode(inst, "auto", soon) == "explicit"
    assert cands.candidate_mode(inst, "explicit", soon) == "explicit"


def test_generation_refuses_at_once_when_the_estimate_alone_would_not_fit(monkeypatch, c3) -> None:
    """Without a cap, the size estimate comes first: foreseen past its share of the time
    left, the error comes before it and before any orbit is generated (every caller, such
    as ASA-DTC's planner, then plans over windows)."""
    import time

    import pytest

    import sosp.candidates as cands
    from sosp.errors import TimeLimitReached

    inst = c3
    made = _slow_samples(monkeypatch, cands, 0.05)
    with pytest.raises(TimeLimitReached, match="estimating"):
        cands.cluster_candidates(inst, None, deadline=time.perf_counter() + 2.0)
    assert "need" not in cands._cache_of(inst) and len(made) == 2  # one sample
    assert not any(cands.cached_orbit_candidates(inst, j) for j in range(inst.n_orbits))


def test_a_generation_foreseen_past_the_deadline_is_not_started(monkeypatch, c3) -> None:
    """At :data:`GENERATE_S_PER_BYTE` of the estimate, a generation that would end past the
    deadline is refused before any orbit (``auto``: windows at once); with room, or without
    a deadline, it goes ahead. A drawn 5,000-target instance (1.66 GB, 69 s) spent 2-2.5 s
    of a 5 s run generating before its deadline stopped it."""
    import time

    import pytest

    import sosp.candidates as cands
    from sosp.errors import TimeLimitReached

    inst = c3
    monkeypatch.setattr(cands, "_SAMPLE_FROM", 0)  # every orbit sampled: a non-zero estimate
    monkeypatch.setattr(cands, "GENERATE_S_PER_BYTE", 1.0)  # a second per byte
    soon = time.perf_counter() + 60.0
    assert cands.candidate_mode(inst, "auto", soon) == "windows"
    with pytest.raises(TimeLimitReached, match="generating"):
        cands.cluster_candidates(inst, None, deadline=soon)
    assert not any(cands.cached_orbit_candidates(inst, j) for j in range(inst.n_orbits))
    assert cands.candidate_mode(inst, "auto") == "explicit"  # no deadline: no foresight
    monkeypatch.setattr(cands, "GENERATE_S_PER_BYTE", 1e-15)
    assert cands.candidate_mode(inst, "auto", soon) == "explicit"
    assert len(cands.cluster_candidates(inst, None, deadline=soon)[0]) > 0


def test_an_estimate_past_its_share_of_the_time_stops_and_means_windows(monkeypatch, c3) -> None:
    """The size estimate reads the clock before each sample: not done by its share of the
    time left, it stops; ``auto``
    then plans over windows and the generation refuses, with nothing kept. A drawn
    5,000-target instance spent 17 s of a 5 s limit estimating, and its searches found
    nothing."""
    import time

    import pytest

    import sosp.candidates as cands
    from sosp.errors import TimeLimitReached

    inst = c3
    monkeypatch.setattr(cands, "_SAMPLE_FROM", 0)  # every orbit sampled
    now = time.perf_counter()
    assert cands.candidate_mode(inst, "auto", now) == "windows"
    assert "need" not in cands._cache_of(inst)
    with pytest.raises(TimeLimitReached, match="estimating"):
        cands.cluster_candidates(inst, None, deadline=now)
    assert not any(cands.cached_orbit_candidates(inst, j) for j in range(inst.n_orbits))
    assert cands.candidate_mode(inst, "auto", time.perf_counter() + 600.0) == "explicit"
    assert cands._cache_of(inst)["need"] == cands.estimate_bytes(inst)
