"""Observation opportunities of ground targets from real orbits (replaces STK).

For every target and every revolution of every satellite this module finds at most one
opportunity, following ``docs/model.md`` "Geometry" (details and figures in ``docs/scenarios.md``):

Frames and roll
    All vectors are Earth-fixed (see :mod:`sosp.orbits`). At time ``t`` the pass frame is:
    ``x`` = unit ground-relative velocity ``v`` (along track; the cross-track plane is
    perpendicular to it); ``z`` = geocentric nadir ``-r`` projected into the cross-track plane
    (it leans from true nadir by the flight-path angle, below 0.2 deg for these near-circular
    orbits); ``y = z cross x`` (to the right of the ground track). The line of sight to a target
    is ``l = r_target - r``.

Crossing time t_c
    The root of the along-track coordinate ``f(t) = l . v``: the target crosses the plane
    through the satellite perpendicular to its Earth-fixed velocity; since the target is fixed
    on the Earth, ``d|l|^2/dt = -2 f``, so t_c is also the time of closest approach. Candidates
    are found where ``f`` changes sign from + (target ahead) to - (behind) on a coarse grid
    (the - to + change is the crossing behind the Earth), screened by the angle of the target
    from the orbital plane, and refined by safeguarded Newton iterations on ``f`` evaluated with
    cubic Hermite interpolation of the sgp4 states (vectorised over all pairs at once).

Roll
    ``theta = atan2(l . y, l . z)`` at t_c, in degrees: the rotation about the along-track axis
    that turns the nadir-pointing boresight onto the target. **Positive = to the right of the
    ground track** (east of an ascending, northbound pass).

Observability and ranges
    Observable iff the satellite is above the target's horizon (the Earth does not block the
    line of sight) and ``|theta| <= theta_max + fov/2``. Roll range
    ``[theta - fov/2, theta + fov/2]`` intersected with ``[-theta_max, theta_max]``; own roll =
    ``theta`` clamped to ``[-theta_max, theta_max]``.

Window
    ``[ts, te]`` is the time the target stays within the along-track half field of view of a
    sensor pointed at it: the along-track off-boresight angle ``phi(t) = asin(l . x / |l|)``
    (the angle of the line of sight out of the cross-track plane, 0 at t_c) equals ``+fov/2``
    at ``ts`` and ``-fov/2`` at ``te`` (secant iterations from t_c on both sides).

Horizon and revolutions
    An opportunity belongs to the revolution containing its t_c; it is dropped when t_c lies
    outside the horizon, and its window is clipped to its revolution (hence to the horizon).

Optional daylight rule: the Sun's elevation at the target at t_c must be at least
``min_sun_elevation`` degrees (low-precision analytic Sun; off by default, as in the paper).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from sosp.errors import InputError
from sosp.orbits import (
    DAY,
    EphemerisGrid,
    Revolutions,
    Satellite,
    ephemeris_grids,
    parse_epoch,
    revolutions,
    sun_direction_ecef,
)

log = logging.getLogger(__name__)

#: WGS84 ellipsoid (targets are geodetic points on it, altitude 0 unless given).
WGS84_A = 6378.137
WGS84_F = 1.0 / 298.257223563
WGS84_B = WGS84_A * (1.0 - WGS84_F)


@dataclass(frozen=True)
class Opportunities:
    """Opportunities as columns, sorted by (orbit, start).

    Attributes
    ----------
    target
        Index into the target arrays.
    orbit
        Index into :class:`~sosp.orbits.Revolutions`.
    t_cross
        Crossing time t_c (closest approach), seconds from the epoch.
    start, end
        The window [ts, te] (clipped to the revolution).
    roll
        Own roll: the crossing roll clamped to ``[-max_roll, max_roll]``, degrees.
    roll_min, roll_max
        Roll range, degrees.
    roll_cross
        The unclamped roll at t_c, degrees (positive to the right of the ground track).
    slant_range
        Distance satellite-target at t_c, km.
    """

    target: np.ndarray
    orbit: np.ndarray
    t_cross: np.ndarray
    start: np.ndarray
    end: np.ndarray
    roll: np.ndarray
    roll_min: np.ndarray
    roll_max: np.ndarray
    roll_cross: np.ndarray
    slant_range: np.ndarray

    def __len__(self) -> int:
        return len(self.target)


def geodetic_to_ecef(lat: np.ndarray, lon: np.ndarray, alt: float | np.ndarray = 0.0) -> np.ndarray:
    """WGS84 geodetic latitude/longitude (degrees) and altitude (km) to Earth-fixed km, (n, 3)."""
    phi = np.radians(np.asarray(lat, dtype=float))
    lam = np.radians(np.asarray(lon, dtype=float))
    e2 = WGS84_F * (2.0 - WGS84_F)
    sphi = np.sin(phi)
    n = WGS84_A / np.sqrt(1.0 - e2 * sphi * sphi)
    rho = (n + alt) * np.cos(phi)  # distance from the polar axis
    return np.stack([rho * np.cos(lam), rho * np.sin(lam), (n * (1.0 - e2) + alt) * sphi], axis=-1)


def geodetic_up(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Unit ellipsoid normal (local vertical) at geodetic lat/lon in degrees, (n, 3)."""
    phi = np.radians(np.asarray(lat, dtype=float))
    lam = np.radians(np.asarray(lon, dtype=float))
    return np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def _unit(a: np.ndarray) -> np.ndarray:
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _frame(r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pass frame from Earth-fixed r, v: x along the velocity, z geocentric nadir
    projected into the cross-track plane (perpendicular to x), y = z cross x (right)."""
    x = _unit(v)
    nadir = -r
    z = _unit(nadir - _dot(nadir, x)[..., None] * x)
    y = np.cross(z, x)
    return x, y, z


def _along_track_angle(grid: EphemerisGrid, t: np.ndarray, rt: np.ndarray) -> np.ndarray:
    """phi(t) = asin(l . x / |l|) in radians: positive while the target is ahead."""
    r, v, _ = grid.state(t)
    los = rt - r
    x, _, _ = _frame(r, v)
    return np.arcsin(np.clip(_dot(los, x) / np.linalg.norm(los, axis=-1), -1.0, 1.0))


def _solve_edge(
    grid: EphemerisGrid,
    rt: np.ndarray,
    t_c: np.ndarray,
    phi_c: np.ndarray,
    target: float,
    dt0: np.ndarray,
    iterations: int = 8,
) -> np.ndarray:
    """Secant iterations for ``phi(t) = target`` starting from ``t_c`` and ``t_c + dt0``."""
    t_a, g_a = t_c, phi_c - target
    t_b = t_c + dt0
    g_b = _along_track_angle(grid, t_b, rt) - target
    for _ in range(iterations):
        denom = g_b - g_a
        safe = np.abs(denom) > 1e-15
        step = np.where(safe, g_b * (t_b - t_a) / np.where(safe, denom, 1.0), 0.0)
        t_new = t_b - step
        if np.all(np.abs(step) < 1e-6):
            return t_new
        t_a, g_a = t_b, g_b
        t_b = t_new
        g_b = _along_track_angle(grid, t_b, rt) - target
    return t_b


def _refine_crossings(
    grid: EphemerisGrid,
    rt: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    t: np.ndarray,
    iterations: int = 10,
) -> np.ndarray:
    """Safeguarded Newton iterations for ``f(t) = (rt - r(t)) . v(t) = 0`` in ``[lo, hi]``.

    ``f' = -|v|^2 + (rt - r) . a``; a step leaving the bracket falls back to bisection, and the
    bracket shrinks with the sign of ``f`` (``f > 0`` before the root).
    """
    for _ in range(iterations):
        r, v, a = grid.state(t)
        los = rt - r
        f = _dot(los, v)
        fp = _dot(los, a) - _dot(v, v)
        pos = f > 0
        lo = np.where(pos, t, lo)
        hi = np.where(pos, hi, t)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_new = t - f / fp
        out = ~((t_new >= lo) & (t_new <= hi)) | ~np.isfinite(t_new)  # NaN-safe
        t_new = np.where(out, 0.5 * (lo + hi), t_new)
        done = np.abs(t_new - t) < 1e-7
        t = t_new
        if np.all(done):
            break
    return t


def _reach_angle(grid: EphemerisGrid, max_off_nadir: float) -> float:
    """Largest Earth central angle (radians) between the sub-satellite point and a target
    seen at ``max_off_nadir`` degrees, for the grid's highest altitude and the polar radius
    (a conservative bound for the orbital-plane screen)."""
    rmax = float(np.nanmax(np.linalg.norm(grid.r, axis=1), initial=0.0))  # 0: all NaN (decayed)
    eta = math.radians(min(max_off_nadir, 89.0))
    s = rmax / WGS84_B * math.sin(eta)
    if s >= 1.0:  # the whole visible cap
        return math.acos(WGS84_B / rmax)
    return math.asin(s) - eta


def find_opportunities(
    satellites: list[Satellite],
    target_lat: np.ndarray,
    target_lon: np.ndarray,
    *,
    epoch: str,
    horizon: tuple[float, float] = (0.0, DAY),
    max_roll: float = 33.0,
    fov: float = 6.0,
    min_sun_elevation: float | None = None,
    fine_step: float = 20.0,
    coarse_step: float = 240.0,
    chunk_size: int = 4096,
) -> tuple[Revolutions, Opportunities]:
    """Revolutions of the satellites and the opportunities of the targets on them.

    Parameters
    ----------
    satellites
        The satellites (a loop over them is the only Python loop besides target chunks).
    target_lat, target_lon
        Geodetic degrees (WGS84, altitude 0).
    epoch
        ISO 8601 UTC origin of all times.
    horizon
        ``(t_start, t_end)`` seconds from ``epoch``.
    max_roll
        theta_max, degrees.
    fov
        sigma, the full field of view, degrees.
    min_sun_elevation
        Optional daylight rule in degrees (None: no rule).
    fine_step
        Ephemeris grid step for interpolation, seconds.
    coarse_step
        Step of the sign-change search (a multiple of ``fine_step``; must be well below half
        a revolution).
    chunk_size
        Targets per block of the coarse search (memory ~ ``chunk_size * 24 h / coarse_step``
        doubles).

    Returns
    -------
    revolutions, opportunities
        See :func:`sosp.orbits.revolutions` and :class:`Opportunities`.
    """
    lat = np.asarray(target_lat, dtype=float).reshape(-1)
    lon = np.asarray(target_lon, dtype=float).reshape(-1)
    if lat.shape != lon.shape:
        raise InputError("targets: lat and lon differ in length")
    if not (0.0 <= max_roll < 90.0) or not (0.0 < fov < 90.0):
        raise InputError(f"max_roll must be in [0, 90) and fov in (0, 90): {max_roll}, {fov}")
    t0, t1 = map(float, horizon)
    if not t1 > t0:
        raise InputError(f"horizon: end must be after start, got {horizon}")
    m = int(round(coarse_step / fine_step))
    if m < 1 or abs(m * fine_step - coarse_step) > 1e-9:
        raise InputError("coarse_step must be a positive multiple of fine_step")
    pad = coarse_step + 600.0  # windows near the edges need states beyond them
    grids = ephemeris_grids(satellites, epoch, t0 - pad, t1 + pad, fine_step)
    revs = revolutions(satellites, grids, (t0, t1))

    half = math.radians(fov / 2.0)
    limit = max_roll + fov / 2.0
    rt_all = geodetic_to_ecef(lat, lon)
    up_all = geodetic_up(lat, lon)
    jd0, fr0 = parse_epoch(epoch)

    # per block: target, orbit, t_cross, start, end, roll_cross, slant_range (an empty first)
    parts = [(np.empty(0, np.int64),) * 2 + (np.empty(0),) * 5]
    for s, grid in enumerate(grids):
        rev_rows = np.flatnonzero(revs.satellite == s)
        rev_start = revs.start[rev_rows]
        reach = _reach_angle(grid, limit) + math.radians(2.0)
        rc = grid.r[::m]
        vc = grid.v[::m]
        tc_grid = grid.t0 + coarse_step * np.arange(len(rc))
        cvec = _dot(rc, vc)
        n_cand = 0
        for k0 in range(0, len(lat), chunk_size):
            rt = rt_all[k0 : k0 + chunk_size]
            f = rt @ vc.T - cvec  # (K, n_coarse): along-track coordinate times |v|
            # f <= 0 rather than not f > 0: where sgp4 failed (a decayed satellite) the
            # states are NaN, and a sign change into NaN is no crossing.
            kk, ii = np.nonzero((f[:, :-1] > 0) & (f[:, 1:] <= 0))
            if kk.size == 0:
                continue
            f0, f1 = f[kk, ii], f[kk, ii + 1]
            lo = tc_grid[ii]
            hi = lo + coarse_step
            guess = lo + coarse_step * f0 / (f0 - f1)
            rtk = rt[kk]
            # Screen by the angle from the orbital plane at the first guess (cheap).
            r, v, _ = grid.state(guess)
            hhat = _unit(np.cross(r, v))
            beta = np.abs(np.arcsin(np.clip(_dot(_unit(rtk), hhat), -1.0, 1.0)))
            keep = beta < reach
            kk, lo, hi, guess, rtk = kk[keep], lo[keep], hi[keep], guess[keep], rtk[keep]
            n_cand += kk.size
            if kk.size == 0:
                continue
            t_c = _refine_crossings(grid, rtk, lo, hi, guess)
            inside = (t_c >= t0) & (t_c < t1)
            r, v, _ = grid.state(t_c)
            los = rtk - r
            x, y, z = _frame(r, v)
            roll = np.degrees(np.arctan2(_dot(los, y), _dot(los, z)))
            kglob = kk + k0
            visible = _dot(-los, up_all[kglob]) > 0.0  # satellite above the target's horizon
            ok = inside & visible & (np.abs(roll) <= limit)
            if min_sun_elevation is not None and ok.any():
                sun = sun_direction_ecef(jd0, fr0 + t_c / DAY)
                sun_el = np.degrees(np.arcsin(np.clip(_dot(sun, up_all[kglob]), -1.0, 1.0)))
                ok &= sun_el >= min_sun_elevation
            if not ok.any():
                continue
            t_c, roll, rtk, kglob, los = t_c[ok], roll[ok], rtk[ok], kglob[ok], los[ok]
            dist = np.linalg.norm(los, axis=-1)
            x = x[ok]
            phi_c = np.arcsin(np.clip(_dot(los, x) / dist, -1.0, 1.0))
            speed = np.linalg.norm(v[ok], axis=-1)
            dt0 = dist * math.tan(half) / speed  # first guess of the half window
            ts = _solve_edge(grid, rtk, t_c, phi_c, half, -dt0)
            te = _solve_edge(grid, rtk, t_c, phi_c, -half, dt0)
            j = np.searchsorted(rev_start, t_c, side="right") - 1
            orbit = rev_rows[j]
            ts = np.maximum(ts, revs.start[orbit])
            te = np.minimum(te, revs.end[orbit])
            parts.append((kglob.astype(np.int64), orbit.astype(np.int64), t_c, ts, te, roll, dist))
        log.debug("%s: %d candidate passes refined", satellites[s].name, n_cand)

    keys = ("target", "orbit", "t_cross", "start", "end", "roll_cross", "slant_range")
    cols = dict(zip(keys, map(np.concatenate, zip(*parts, strict=True)), strict=True))
    order = np.lexsort((cols["target"], cols["start"], cols["orbit"]))
    cols = {k: v[order] for k, v in cols.items()}
    theta = cols["roll_cross"]
    opps = Opportunities(
        **cols,
        roll=np.clip(theta, -max_roll, max_roll),
        roll_min=np.maximum(theta - fov / 2.0, -max_roll),
        roll_max=np.minimum(theta + fov / 2.0, max_roll),
    )
    log.info(
        "%d targets x %d satellites: %d revolutions, %d opportunities, %d targets observable",
        len(lat),
        len(satellites),
        len(revs),
        len(opps),
        int(np.unique(opps.target).size),
    )
    return revs, opps
